/* Path planner: see rt_plan.h for the contract. */
#include "rt/rt_plan.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

#define SQRT2 1.41421356237309504880

/* Neighbour order E, NE, N, NW, W, SW, S, SE: fixed, part of the tie rule. */
static const int8_t DC[8] = {1, 1, 0, -1, -1, -1, 0, 1};
static const int8_t DR[8] = {0, 1, 1, 1, 0, -1, -1, -1};

rt_plan_cfg_t rt_plan_default_cfg(void)
{
    rt_plan_cfg_t c = {
        .robot_radius_m = 0.105f,
        .margin_m = 0.05f,
        .k_clear_m = 0.1f,
        .occ_threshold = 128,
        .unknown_is_obstacle = 0,
        .flags = 0,
    };
    return c;
}

static int cfg_ok(const rt_plan_cfg_t *c)
{
    return isfinite(c->robot_radius_m) && c->robot_radius_m > 0.0f && isfinite(c->margin_m) &&
           c->margin_m >= 0.0f && isfinite(c->k_clear_m) && c->k_clear_m >= 0.0f &&
           c->occ_threshold > 0 && c->unknown_is_obstacle <= 1 &&
           (c->flags & ~(RT_PLAN_NEAREST_GOAL | RT_PLAN_TIGHT)) == 0;
}

static int is_obstacle(const rt_grid_t *g, const rt_plan_cfg_t *c, int32_t i)
{
    if (g->known[i] == 0)
        return c->unknown_is_obstacle;
    return g->occ[i] >= c->occ_threshold;
}

/* 1-D squared distance transform of the sampled function f (Felzenszwalb & Huttenlocher):
 * d[q] = min_p (q - p)^2 + f[p] over the sites p with a finite f, RT_PLAN_CLEAR_INF without
 * any. The lower envelope is built over finite sites only, so no infinity ever enters the
 * intersection formula (the classic version's INF - INF). Intersections in double: the
 * envelope must not drop a parabola by a rounding; the values themselves are integers. */
static void edt_1d(const float *f, int32_t n, float *d, int32_t stride, int32_t *v, double *z)
{
    int32_t k = -1;
    for (int32_t q = 0; q < n; q++) {
        if (f[q] >= RT_PLAN_CLEAR_INF)
            continue;
        double fq = (double)f[q] + (double)q * q;
        double s = -INFINITY;
        while (k >= 0) {
            int32_t p = v[k];
            s = (fq - ((double)f[p] + (double)p * p)) / (2.0 * (q - p));
            if (s > z[k])
                break;
            k--;
        }
        k++;
        v[k] = q;
        z[k] = k == 0 ? -INFINITY : s;
        z[k + 1] = INFINITY;
    }
    for (int32_t q = 0, j = 0; q < n; q++) {
        if (k < 0) {
            d[q * stride] = RT_PLAN_CLEAR_INF;
            continue;
        }
        while (z[j + 1] < (double)q)
            j++;
        float dq = (float)(q - v[j]);
        d[q * stride] = dq * dq + f[v[j]];
    }
}

int rt_plan_clearance(const rt_grid_t *grid, const rt_plan_cfg_t *cfg, rt_plan_workspace_t *ws)
{
    if (grid == NULL || cfg == NULL || ws == NULL || !cfg_ok(cfg))
        return -EINVAL;
    int r = rt_grid_check(grid);
    if (r != 0)
        return r;
    const int32_t w = grid->w, h = grid->h;
    /* Columns first: 0 on obstacles, INF elsewhere, transformed along y into clear2. */
    for (int32_t c = 0; c < w; c++) {
        for (int32_t rr = 0; rr < h; rr++)
            ws->line_f[rr] = is_obstacle(grid, cfg, rr * w + c) ? 0.0f : RT_PLAN_CLEAR_INF;
        edt_1d(ws->line_f, h, &ws->clear2[c], w, ws->line_v, ws->line_z);
    }
    /* Then rows, on the column results: the squared distance separates in x and y. */
    for (int32_t rr = 0; rr < h; rr++) {
        memcpy(ws->line_f, &ws->clear2[rr * w], (size_t)w * sizeof(float));
        edt_1d(ws->line_f, w, &ws->clear2[rr * w], 1, ws->line_v, ws->line_z);
    }
    return 0;
}

/* ---- A* ------------------------------------------------------------------------------- */

typedef struct plan_ctx {
    const rt_grid_t *grid;
    rt_plan_workspace_t *ws;
    double allow2; /* allowed iff clear2 >= allow2 */
    int32_t w, h, n_heap;
} plan_ctx_t;

static int allowed(const plan_ctx_t *p, int32_t c, int32_t r)
{
    if (c < 0 || r < 0 || c >= p->w || r >= p->h)
        return 0;
    return (double)p->ws->clear2[r * p->w + c] >= p->allow2;
}

/* Heap order: lower f, then higher g, then lower index. A total order on distinct cells. */
static int before(const rt_plan_workspace_t *ws, int32_t a, int32_t b)
{
    if (ws->f[a] != ws->f[b])
        return ws->f[a] < ws->f[b];
    if (ws->g[a] != ws->g[b])
        return ws->g[a] > ws->g[b];
    return a < b;
}

static void heap_place(plan_ctx_t *p, int32_t slot, int32_t cell)
{
    p->ws->heap[slot] = cell;
    p->ws->pos[cell] = slot;
}

static void sift_up(plan_ctx_t *p, int32_t slot)
{
    rt_plan_workspace_t *ws = p->ws;
    int32_t cell = ws->heap[slot];
    while (slot > 0) {
        int32_t up = (slot - 1) / 2;
        if (!before(ws, cell, ws->heap[up]))
            break;
        heap_place(p, slot, ws->heap[up]);
        slot = up;
    }
    heap_place(p, slot, cell);
}

static void sift_down(plan_ctx_t *p, int32_t slot)
{
    rt_plan_workspace_t *ws = p->ws;
    int32_t cell = ws->heap[slot];
    for (;;) {
        int32_t kid = 2 * slot + 1;
        if (kid >= p->n_heap)
            break;
        if (kid + 1 < p->n_heap && before(ws, ws->heap[kid + 1], ws->heap[kid]))
            kid++;
        if (!before(ws, ws->heap[kid], cell))
            break;
        heap_place(p, slot, ws->heap[kid]);
        slot = kid;
    }
    heap_place(p, slot, cell);
}

static int32_t heap_pop(plan_ctx_t *p)
{
    rt_plan_workspace_t *ws = p->ws;
    int32_t top = ws->heap[0];
    p->n_heap--;
    if (p->n_heap > 0) {
        heap_place(p, 0, ws->heap[p->n_heap]);
        sift_down(p, 0);
    }
    ws->pos[top] = -2;
    return top;
}

static float octile_m(int32_t c, int32_t r, int32_t gc, int32_t gr, float res)
{
    int32_t dx = c > gc ? c - gc : gc - c, dy = r > gr ? r - gr : gr - r;
    int32_t lo = dx < dy ? dx : dy, hi = dx < dy ? dy : dx;
    return res * ((float)(hi - lo) + (float)SQRT2 * (float)lo);
}

/* The allowed cell nearest (c, r) in squared cell distance, ties to the lower index; -1 if
 * none. A full scan: O(w h), as cheap as the transform, and needs no extra storage. */
static int32_t nearest_allowed(const plan_ctx_t *p, int32_t c, int32_t r)
{
    int32_t best = -1;
    int64_t best_d = INT64_MAX;
    for (int32_t rr = 0; rr < p->h; rr++)
        for (int32_t cc = 0; cc < p->w; cc++) {
            if (!allowed(p, cc, rr))
                continue;
            int64_t d = (int64_t)(cc - c) * (cc - c) + (int64_t)(rr - r) * (rr - r);
            if (d < best_d) {
                best_d = d;
                best = rr * p->w + cc;
            }
        }
    return best;
}

/* Runs A* from cell s towards cell t. Returns the cell the path ends at: t when reached, else
 * (nearest_goal) the closed cell nearest t, else -1. */
static int32_t astar(plan_ctx_t *p, const rt_plan_cfg_t *cfg, int32_t s, int32_t t,
                     int nearest_goal, int32_t *expanded)
{
    rt_plan_workspace_t *ws = p->ws;
    const int32_t w = p->w, n = p->w * p->h, tc = t % w, tr = t / w;
    const float res = p->grid->res;
    for (int32_t i = 0; i < n; i++) {
        ws->g[i] = INFINITY;
        ws->pos[i] = -1;
    }
    int32_t best = -1;
    int64_t best_d = INT64_MAX;
    ws->g[s] = 0.0f;
    ws->f[s] = octile_m(s % w, s / w, tc, tr, res);
    ws->parent[s] = 0xFF;
    p->n_heap = 0;
    heap_place(p, p->n_heap++, s);
    *expanded = 0;
    while (p->n_heap > 0) {
        int32_t u = heap_pop(p);
        (*expanded)++;
        if (u == t)
            return t;
        const int32_t uc = u % w, ur = u / w;
        int64_t du = (int64_t)(uc - tc) * (uc - tc) + (int64_t)(ur - tr) * (ur - tr);
        if (du < best_d || (du == best_d && u < best)) {
            best_d = du;
            best = u;
        }
        for (int d = 0; d < 8; d++) {
            int32_t nc = uc + DC[d], nr = ur + DR[d];
            if (!allowed(p, nc, nr))
                continue;
            int32_t v = nr * w + nc;
            if (ws->pos[v] == -2)
                continue;
            int diag = DC[d] != 0 && DR[d] != 0;
            if (diag && (!allowed(p, nc, ur) || !allowed(p, uc, nr)))
                continue; /* no corner cutting */
            float len = diag ? res * (float)SQRT2 : res;
            float clear_m = sqrtf(ws->clear2[v]) * res; /* >= allowed band > 0 */
            float ng = ws->g[u] + len * (1.0f + cfg->k_clear_m / clear_m);
            if (!(ng < ws->g[v]))
                continue;
            ws->g[v] = ng;
            ws->f[v] = ng + octile_m(nc, nr, tc, tr, res);
            ws->parent[v] = (uint8_t)d;
            if (ws->pos[v] == -1)
                heap_place(p, p->n_heap++, v);
            /* Both ways: a lower g with the same f (float rounding) ranks LATER by the tie
             * rule, so a decrease-key may have to move the cell down. */
            sift_up(p, ws->pos[v]);
            sift_down(p, ws->pos[v]);
        }
    }
    return nearest_goal ? best : -1;
}

/* Line of sight between two cell centres: every cell the segment touches is allowed; where it
 * passes exactly through a corner, both cells beside the corner must be too (supercover walk
 * with integer error terms, so the decision is exact). *factor_mean receives the mean of
 * (1 + k / clearance) over the cells the line enters (all but a's), its soft cost per metre. */
static int line_of_sight(const plan_ctx_t *p, int32_t a, int32_t b, float k, float *factor_mean)
{
    int32_t x = a % p->w, y = a / p->w, x1 = b % p->w, y1 = b / p->w;
    int32_t dx = x1 > x ? x1 - x : x - x1, dy = y1 > y ? y1 - y : y - y1;
    int32_t sx = x1 > x ? 1 : -1, sy = y1 > y ? 1 : -1;
    int32_t err = dx - dy, steps = dx + dy, visited = 0;
    float sum = 0.0f;
    dx *= 2;
    dy *= 2;
    for (;;) {
        if (!allowed(p, x, y))
            return 0;
        if (visited++ > 0) /* the cell left, like A*'s step cost, counts only cells entered */
            sum += 1.0f + k / (sqrtf(p->ws->clear2[y * p->w + x]) * p->grid->res);
        if (steps <= 0)
            break;
        if (err > 0) {
            x += sx;
            err -= dy;
            steps--;
        } else if (err < 0) {
            y += sy;
            err += dx;
            steps--;
        } else {
            if (!allowed(p, x + sx, y) || !allowed(p, x, y + sy))
                return 0;
            x += sx;
            y += sy;
            err += dx - dy;
            steps -= 2;
        }
    }
    *factor_mean = visited > 1 ? sum / (float)(visited - 1) : 1.0f;
    return 1;
}

/* A shortcut from path cell a to path cell b is taken when it is in line of sight AND costs no
 * more (its length times its mean factor) than the A* sub-path it replaces (g[b] - g[a], the
 * g values are final on the path): otherwise a straight line along a wall would undo what the
 * clearance cost bought. Relative slack 1e-5 for the float sums. */
static int shortcut_ok(const plan_ctx_t *p, int32_t a, int32_t b, float k)
{
    float mean;
    if (!line_of_sight(p, a, b, k, &mean))
        return 0;
    float dx = (float)(b % p->w - a % p->w), dy = (float)(b / p->w - a / p->w);
    float cost = p->grid->res * sqrtf(dx * dx + dy * dy) * mean;
    float sub = p->ws->g[b] - p->ws->g[a];
    return cost <= sub * (1.0f + 1e-5f);
}

static void centre(const rt_grid_t *g, int32_t cell, rt_waypoint_t *wp)
{
    rt_grid_cell_centre(g, cell % g->w, cell / g->w, &wp->x, &wp->y);
}

/* Cell path (ws->heap[0..m-1], start first) -> waypoints, greedy farthest shortcut. */
static int simplify(const plan_ctx_t *p, float k, int32_t m, rt_plan_result_t *out)
{
    const int32_t *cells = p->ws->heap;
    int32_t n = 0;
    centre(p->grid, cells[0], &out->wps[n++]);
    int32_t anchor = 0;
    while (anchor < m - 1) {
        int32_t j = anchor + 1; /* neighbours on the A* path always see each other */
        while (j + 1 < m && shortcut_ok(p, cells[anchor], cells[j + 1], k))
            j++;
        if (n == RT_PLAN_MAX_WAYPOINTS)
            return -ENOSPC;
        centre(p->grid, cells[j], &out->wps[n++]);
        anchor = j;
    }
    out->n_wps = n;
    return 0;
}

/* The band of rt_plan.h step 3, squared: allowed iff clear2 >= it. */
static double band2(const rt_grid_t *grid, const rt_plan_cfg_t *cfg)
{
    const double band = (double)(cfg->robot_radius_m + cfg->margin_m) / grid->res +
                        ((cfg->flags & RT_PLAN_TIGHT) != 0 ? 1.0 : SQRT2);
    return band * band;
}

int rt_plan_path(const rt_grid_t *grid, const rt_plan_cfg_t *cfg, float sx, float sy, float gx,
                 float gy, rt_plan_workspace_t *ws, rt_plan_result_t *out)
{
    if (out == NULL)
        return -EINVAL;
    out->n_wps = 0;
    out->flags = 0;
    if (grid == NULL || cfg == NULL || ws == NULL || !cfg_ok(cfg))
        return -EINVAL;
    int r = rt_grid_check(grid);
    if (r != 0)
        return r;
    int32_t sc, sr, gc, gr;
    if (rt_grid_world_to_cell(grid, sx, sy, &sc, &sr) != 0 ||
        rt_grid_world_to_cell(grid, gx, gy, &gc, &gr) != 0)
        return -EINVAL;
    r = rt_plan_clearance(grid, cfg, ws);
    if (r != 0)
        return r;
    plan_ctx_t p = {.grid = grid, .ws = ws, .w = grid->w, .h = grid->h, .allow2 = band2(grid, cfg)};
    const int nearest_goal = (cfg->flags & RT_PLAN_NEAREST_GOAL) != 0;
    int32_t s = sr * p.w + sc, t = gr * p.w + gc;
    if (!allowed(&p, sc, sr)) {
        s = nearest_allowed(&p, sc, sr);
        if (s < 0)
            return -ENOENT;
        out->flags |= RT_PLAN_START_MOVED;
    }
    if (!allowed(&p, gc, gr) && !nearest_goal)
        return -ENOENT; /* nothing to search for */
    int32_t expanded = 0;
    int32_t end = astar(&p, cfg, s, t, nearest_goal, &expanded);
    out->expanded = expanded;
    if (end < 0)
        return -ENOENT;
    if (end != t)
        out->flags |= RT_PLAN_GOAL_MOVED;
    /* Walk the parents back from the end, then reverse: the heap's storage is free now. */
    int32_t m = 0;
    for (int32_t c = end;; c = (c / p.w - DR[ws->parent[c]]) * p.w + (c % p.w - DC[ws->parent[c]])) {
        ws->heap[m++] = c;
        if (c == s)
            break;
    }
    for (int32_t i = 0; i < m / 2; i++) {
        int32_t tmp = ws->heap[i];
        ws->heap[i] = ws->heap[m - 1 - i];
        ws->heap[m - 1 - i] = tmp;
    }
    r = simplify(&p, cfg->k_clear_m, m, out);
    if (r != 0) {
        out->n_wps = 0;
        return r;
    }
    out->start_col = s % p.w;
    out->start_row = s / p.w;
    out->goal_col = end % p.w;
    out->goal_row = end / p.w;
    out->path_cells = m;
    out->cost = ws->g[end];
    out->length_m = 0.0f;
    for (int32_t i = 1; i < out->n_wps; i++)
        out->length_m += hypotf(out->wps[i].x - out->wps[i - 1].x, out->wps[i].y - out->wps[i - 1].y);
    return 0;
}
