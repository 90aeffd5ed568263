/* Helpers for the planner tests: grids from ASCII art, the planner's allowed-cell rule and
 * connectivity recomputed by brute force, and a path checker that measures clearance on a
 * ground-truth obstacle raster (never the planner's own transform). */
#ifndef TESTS_RT_PLAN_TEST_UTIL_H
#define TESTS_RT_PLAN_TEST_UTIL_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rt/rt_grid.h"
#include "rt/rt_plan.h"

/* Ground truth: obstacle squares of a raster (1 = obstacle); space outside it is open. */
typedef struct pt_truth {
    int w, h;
    double res, ox, oy;
    const uint8_t *obst;
} pt_truth_t;

/* '#' occupied (known), '.' free (known), '?' unknown; rows[0] is row 0 (smallest y). */
static inline void pt_grid_ascii(rt_grid_t *g, const char *const *rows, int h, float res)
{
    int w = (int)strlen(rows[0]);
    if (rt_grid_init(g, res, 0.0f, 0.0f, w, h) != 0)
        abort();
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            char ch = rows[r][c];
            if (rt_grid_set(g, c, r, ch == '#' ? 255 : 0, ch == '?' ? 0 : 255) != 0)
                abort();
        }
}

/* Obstacle raster of an rt_grid under cfg's rule (the truth for hand-made grids). */
static inline void pt_obstacles(const rt_grid_t *g, const rt_plan_cfg_t *cfg, uint8_t *obst)
{
    for (int i = 0; i < g->w * g->h; i++)
        obst[i] = g->known[i] ? g->occ[i] >= cfg->occ_threshold : cfg->unknown_is_obstacle;
}

/* The planner's allowed rule (rt_plan.h, step 3) by brute force over a window of obstacle
 * centres: allowed iff no obstacle centre is closer than R / res + sqrt(2) cells. */
static inline void pt_allowed(const rt_grid_t *g, const rt_plan_cfg_t *cfg, const uint8_t *obst,
                              uint8_t *allow)
{
    double band = (double)(cfg->robot_radius_m + cfg->margin_m) / g->res + 1.41421356237309504880;
    int win = (int)ceil(band) + 1;
    for (int r = 0; r < g->h; r++)
        for (int c = 0; c < g->w; c++) {
            int ok = 1;
            for (int rr = r - win; rr <= r + win && ok; rr++)
                for (int cc = c - win; cc <= c + win && ok; cc++)
                    if (rr >= 0 && cc >= 0 && rr < g->h && cc < g->w && obst[rr * g->w + cc] &&
                        (double)((cc - c) * (cc - c) + (rr - r) * (rr - r)) < band * band)
                        ok = 0;
            allow[r * g->w + c] = (uint8_t)ok;
        }
}

/* Components of the allowed cells, 8-connected without corner cutting (label 0 = forbidden).
 * queue: w * h ints of scratch. */
static inline void pt_components(int w, int h, const uint8_t *allow, int32_t *label, int32_t *queue)
{
    static const int dc[8] = {1, 1, 0, -1, -1, -1, 0, 1}, dr[8] = {0, 1, 1, 1, 0, -1, -1, -1};
    memset(label, 0, (size_t)w * h * sizeof *label);
    int32_t next = 0;
    for (int i = 0; i < w * h; i++) {
        if (!allow[i] || label[i])
            continue;
        int32_t head = 0, tail = 0;
        label[i] = ++next;
        queue[tail++] = i;
        while (head < tail) {
            int u = queue[head++], uc = u % w, ur = u / w;
            for (int d = 0; d < 8; d++) {
                int nc = uc + dc[d], nr = ur + dr[d];
                if (nc < 0 || nr < 0 || nc >= w || nr >= h || !allow[nr * w + nc] ||
                    label[nr * w + nc])
                    continue;
                if (dc[d] && dr[d] && (!allow[ur * w + nc] || !allow[nr * w + uc]))
                    continue;
                label[nr * w + nc] = next;
                queue[tail++] = nr * w + nc;
            }
        }
    }
}

/* Distance from (x, y) to the nearest obstacle square within `reach` metres (reach if none). */
static inline double pt_clearance(const pt_truth_t *t, double x, double y, double reach)
{
    int c0 = (int)floor((x - t->ox) / t->res), r0 = (int)floor((y - t->oy) / t->res);
    int win = (int)ceil(reach / t->res) + 1;
    double best = reach;
    for (int r = r0 - win; r <= r0 + win; r++)
        for (int c = c0 - win; c <= c0 + win; c++) {
            if (r < 0 || c < 0 || r >= t->h || c >= t->w || !t->obst[r * t->w + c])
                continue;
            double x0 = t->ox + c * t->res, y0 = t->oy + r * t->res;
            double dx = fmax(fmax(x0 - x, 0.0), x - (x0 + t->res));
            double dy = fmax(fmax(y0 - y, 0.0), y - (y0 + t->res));
            best = fmin(best, sqrt(dx * dx + dy * dy));
        }
    return best;
}

/* Checks a planned path: it starts at the centre of (sc, sr) and ends at the centre of
 * (gc, gr) of grid g, every waypoint and every point every 1 cm along every segment is at
 * least R (minus 0.1 mm of float rounding) from every obstacle square of the truth. Returns
 * the smallest clearance seen, or -1 on a broken path. */
static inline double pt_check_path(const rt_grid_t *g, const rt_plan_result_t *res, int sc,
                                   int sr, int gc, int gr, const pt_truth_t *t, double R)
{
    if (res->n_wps < 1 || res->n_wps > RT_PLAN_MAX_WAYPOINTS)
        return -1;
    float x, y;
    rt_grid_cell_centre(g, sc, sr, &x, &y);
    if (fabsf(res->wps[0].x - x) > 1e-4f || fabsf(res->wps[0].y - y) > 1e-4f)
        return -1;
    rt_grid_cell_centre(g, gc, gr, &x, &y);
    const rt_waypoint_t *last = &res->wps[res->n_wps - 1];
    if (fabsf(last->x - x) > 1e-4f || fabsf(last->y - y) > 1e-4f)
        return -1;
    double lowest = pt_clearance(t, res->wps[0].x, res->wps[0].y, R + 1.0);
    for (int i = 1; i < res->n_wps; i++) {
        double ax = res->wps[i - 1].x, ay = res->wps[i - 1].y;
        double bx = res->wps[i].x, by = res->wps[i].y;
        int n = (int)ceil(hypot(bx - ax, by - ay) / 0.01);
        if (n < 1)
            return -1; /* a repeated waypoint: the simplification never makes one */
        for (int k = 1; k <= n; k++) {
            double s = (double)k / n;
            lowest = fmin(lowest, pt_clearance(t, ax + s * (bx - ax), ay + s * (by - ay), R + 1.0));
        }
    }
    return lowest >= R - 1e-4 ? lowest : -1;
}

#endif /* TESTS_RT_PLAN_TEST_UTIL_H */
