/* Communication graphs: see dinno_graph.h. Components by a bitmask flood fill. */
#include "ai/dinno_graph.h"

#include <errno.h>
#include <math.h>
#include <string.h>

static int n_ok(const dinno_graph_t *g, uint32_t n)
{
    return g && n >= 1 && n <= DINNO_GRAPH_MAX_NODES;
}

static void add_edge(dinno_graph_t *g, uint32_t i, uint32_t j)
{
    if (i == j)
        return;
    g->adj[i] |= 1u << j;
    g->adj[j] |= 1u << i;
}

int dinno_graph_full(dinno_graph_t *g, uint32_t n)
{
    if (!n_ok(g, n))
        return -EINVAL;
    memset(g, 0, sizeof *g);
    g->n = n;
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = i + 1; j < n; j++)
            add_edge(g, i, j);
    return 0;
}

int dinno_graph_ring(dinno_graph_t *g, uint32_t n)
{
    if (!n_ok(g, n))
        return -EINVAL;
    memset(g, 0, sizeof *g);
    g->n = n;
    for (uint32_t i = 0; i < n && n > 1; i++)
        add_edge(g, i, (i + 1) % n);
    return 0;
}

int dinno_graph_disk(dinno_graph_t *g, uint32_t n, const double *xy, double radius)
{
    if (!n_ok(g, n) || !xy || !isfinite(radius) || radius < 0.0)
        return -EINVAL;
    for (uint32_t i = 0; i < 2 * n; i++)
        if (!isfinite(xy[i]))
            return -EINVAL;
    memset(g, 0, sizeof *g);
    g->n = n;
    const double r2 = radius * radius;
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = i + 1; j < n; j++) {
            const double dx = xy[2 * i] - xy[2 * j], dy = xy[2 * i + 1] - xy[2 * j + 1];
            if (dx * dx + dy * dy <= r2)
                add_edge(g, i, j);
        }
    return 0;
}

uint32_t dinno_graph_degree(const dinno_graph_t *g, uint32_t i)
{
    if (!g || i >= g->n)
        return 0;
    return (uint32_t)__builtin_popcount(g->adj[i]);
}

void dinno_graph_report(const dinno_graph_t *g, dinno_graph_report_t *r)
{
    if (!g || !r)
        return;
    memset(r, 0, sizeof *r);
    uint32_t seen = 0, deg_sum = 0;
    for (uint32_t i = 0; i < g->n; i++) {
        const uint32_t d = dinno_graph_degree(g, i);
        deg_sum += d;
        if (d == 0)
            r->isolated++;
        if ((seen >> i) & 1u)
            continue;
        uint32_t comp = 1u << i, grow;
        do { /* flood fill: add every neighbour of the component */
            grow = comp;
            for (uint32_t j = 0; j < g->n; j++)
                if ((comp >> j) & 1u)
                    grow |= g->adj[j];
            if (grow == comp)
                break;
            comp = grow;
        } while (1);
        seen |= comp;
        r->components++;
        const uint32_t size = (uint32_t)__builtin_popcount(comp);
        if (size > r->largest)
            r->largest = size;
    }
    r->edges = deg_sum / 2;
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
