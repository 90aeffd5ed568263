/* Communication graphs: see dinno_graph.h. Components by union-find over the node pairs. */
#include "ai/dinno_graph.h"

#include <errno.h>
#include <math.h>
#include <string.h>

static int n_ok(const dinno_graph_t *g, uint32_t n)
{
    return g && n >= 1 && n <= DINNO_GRAPH_MAX_NODES;
}

static void reset(dinno_graph_t *g, uint32_t n)
{
    g->n = n;
    memset(g->deg, 0, sizeof g->deg);
}

int dinno_graph_full(dinno_graph_t *g, uint32_t n)
{
    if (!n_ok(g, n))
        return -EINVAL;
    if (n - 1u > DINNO_GRAPH_MAX_DEGREE)
        return -E2BIG;
    reset(g, n);
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = 0; j < n; j++)
            if (j != i)
                g->nb[i][g->deg[i]++] = (uint16_t)j;
    return 0;
}

int dinno_graph_ring(dinno_graph_t *g, uint32_t n)
{
    if (!n_ok(g, n))
        return -EINVAL;
    reset(g, n);
    for (uint32_t i = 0; i < n && n > 1; i++) {
        const uint32_t a = (i + n - 1u) % n, b = (i + 1u) % n, lo = a < b ? a : b, hi = a < b ? b : a;
        g->nb[i][g->deg[i]++] = (uint16_t)lo;
        if (hi != lo && DINNO_GRAPH_MAX_DEGREE > 1u)
            g->nb[i][g->deg[i]++] = (uint16_t)hi;
    }
    return 0;
}

int dinno_graph_disk(dinno_graph_t *g, uint32_t n, const double *xy, double radius)
{
    if (!n_ok(g, n) || !xy || !isfinite(radius) || radius < 0.0)
        return -EINVAL;
    for (uint32_t i = 0; i < 2 * n; i++)
        if (!isfinite(xy[i]))
            return -EINVAL;
    reset(g, n);
    const double r2 = radius * radius;
    for (uint32_t i = 0; i < n; i++) {
        /* The nearest in reach, kept sorted by (squared distance, id): the rule of gp_pse. */
        double d2s[DINNO_GRAPH_MAX_DEGREE];
        uint16_t *ids = g->nb[i];
        uint32_t m = 0;
        for (uint32_t j = 0; j < n; j++) {
            const double dx = xy[2 * i] - xy[2 * j], dy = xy[2 * i + 1] - xy[2 * j + 1], d2 = dx * dx + dy * dy;
            if (j == i || !(d2 <= r2) || (m == DINNO_GRAPH_MAX_DEGREE && !(d2 < d2s[m - 1u])))
                continue; /* j ascends: a tie with the last kept loses */
            uint32_t at = m < DINNO_GRAPH_MAX_DEGREE ? m++ : m - 1u;
            for (; at > 0 && d2 < d2s[at - 1u]; at--) {
                d2s[at] = d2s[at - 1u];
                ids[at] = ids[at - 1u];
            }
            d2s[at] = d2;
            ids[at] = (uint16_t)j;
        }
        /* Ascending ids: the order of DiNNO's slots. */
        for (uint32_t a = 1; a < m; a++)
            for (uint32_t b = a; b > 0 && ids[b - 1u] > ids[b]; b--) {
                const uint16_t t = ids[b];
                ids[b] = ids[b - 1u];
                ids[b - 1u] = t;
            }
        g->deg[i] = (uint16_t)m;
    }
    return 0;
}

int dinno_graph_has_edge(const dinno_graph_t *g, uint32_t i, uint32_t j)
{
    if (!g || i >= g->n || j >= g->n)
        return 0;
    for (uint32_t s = 0; s < g->deg[i]; s++)
        if (g->nb[i][s] == j)
            return 1;
    return 0;
}

uint32_t dinno_graph_degree(const dinno_graph_t *g, uint32_t i)
{
    if (!g || i >= g->n)
        return 0;
    return g->deg[i];
}

static uint32_t find(uint16_t *parent, uint32_t i)
{
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

void dinno_graph_report(const dinno_graph_t *g, dinno_graph_report_t *r)
{
    if (!g || !r)
        return;
    memset(r, 0, sizeof *r);
    uint16_t parent[DINNO_GRAPH_MAX_NODES], size[DINNO_GRAPH_MAX_NODES];
    for (uint32_t i = 0; i < g->n; i++) {
        parent[i] = (uint16_t)i;
        size[i] = 1;
    }
    for (uint32_t i = 0; i < g->n; i++) {
        if (g->deg[i] == 0)
            r->isolated++;
        for (uint32_t s = 0; s < g->deg[i]; s++) {
            const uint32_t j = g->nb[i][s];
            if (i < j || !dinno_graph_has_edge(g, j, i))
                r->edges++; /* a pair once, whichever way it goes */
            uint32_t a = find(parent, i), b = find(parent, j);
            if (a == b)
                continue;
            if (size[a] < size[b]) {
                const uint32_t t = a;
                a = b;
                b = t;
            }
            parent[b] = (uint16_t)a;
            size[a] = (uint16_t)(size[a] + size[b]);
        }
    }
    for (uint32_t i = 0; i < g->n; i++)
        if (find(parent, i) == i) {
            r->components++;
            if (size[i] > r->largest)
                r->largest = size[i];
        }
}

const char *dinno_graph_name(dinno_graph_kind_t k)
{
    switch (k) {
    case DINNO_GRAPH_FULL:
        return "full";
    case DINNO_GRAPH_RING:
        return "ring";
    case DINNO_GRAPH_DISK:
        return "disk";
    }
    return "?";
}

int dinno_graph_parse(const char *name, dinno_graph_kind_t *out)
{
    if (!name || !out)
        return -EINVAL;
    for (int k = DINNO_GRAPH_FULL; k <= DINNO_GRAPH_DISK; k++)
        if (strcmp(name, dinno_graph_name((dinno_graph_kind_t)k)) == 0) {
            *out = (dinno_graph_kind_t)k;
            return 0;
        }
    return -EINVAL;
}
