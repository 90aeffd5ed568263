/* Robot paths and their figures: length, distance, exact clearance, coverage (contract in
 * sim_paths.h). The tour generator is sim_tours.c, the waypoint files sim_paths_csv.c. */
#include "sim_paths.h"
#include "sim_paths_util.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Spacing of the path samples used by the coverage measure, metres. */
#define COVER_STEP_M 0.2

/* ---- small helpers ------------------------------------------------------------------------ */

__attribute__((format(printf, 3, 4)))
int sim_paths_errf(char *err, size_t errlen, const char *fmt, ...)
{
    if (err != NULL && errlen > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return -EINVAL;
}

int sim_paths_push(sim_path_t *p, int *cap, double x, double y)
{
    if (p->n > 0 && p->p[p->n - 1].x == x && p->p[p->n - 1].y == y)
        return 0;
    if (p->n >= SIM_PATH_MAX_POINTS)
        return -E2BIG;
    if (p->n == *cap) {
        int nc = *cap ? *cap * 2 : 64;
        sim_vec2_t *np = realloc(p->p, (size_t)nc * sizeof *np);
        if (np == NULL)
            return -ENOMEM;
        p->p = np;
        *cap = nc;
    }
    p->p[p->n].x = x;
    p->p[p->n].y = y;
    p->n++;
    return 0;
}

void sim_path_init(sim_path_t *path)
{
    path->n = 0;
    path->p = NULL;
    path->line = NULL;
    path->start_room = -1;
}

void sim_path_free(sim_path_t *path)
{
    if (path == NULL)
        return;
    free(path->p);
    free(path->line);
    sim_path_init(path);
}

void sim_paths_cfg_default(sim_paths_cfg_t *cfg)
{
    if (cfg == NULL)
        return;
    cfg->n_robots = 7;
    cfg->seed = 1;
    cfg->clearance_m = 0.2;
    cfg->res_m = 0.05;
    cfg->sweep_m = 1.0;
    cfg->own_rooms = 0;
}

int sim_plan_room_at(const sim_plan_t *plan, double x, double y)
{
    for (int i = 0; i < plan->n_rooms; i++)
        if (sim_poly_contains(&plan->rooms[i].outline, x, y))
            return i;
    return -1;
}

/* ---- exact geometry for clearance --------------------------------------------------------- */

static double pt_seg_dist(double px, double py, sim_vec2_t a, sim_vec2_t b)
{
    double dx = b.x - a.x, dy = b.y - a.y, l2 = dx * dx + dy * dy;
    double t = l2 > 0 ? ((px - a.x) * dx + (py - a.y) * dy) / l2 : 0.0;
    t = t < 0 ? 0 : (t > 1 ? 1 : t);
    return hypot(px - (a.x + t * dx), py - (a.y + t * dy));
}

double sim_path_length(const sim_path_t *path)
{
    double len = 0.0;
    for (int i = 0; i + 1 < path->n; i++)
        len += hypot(path->p[i + 1].x - path->p[i].x, path->p[i + 1].y - path->p[i].y);
    return len;
}

double sim_path_distance(const sim_path_t *path, double x_m, double y_m)
{
    if (path->n == 1)
        return hypot(x_m - path->p[0].x, y_m - path->p[0].y);
    double d = INFINITY;
    for (int i = 0; i + 1 < path->n; i++)
        d = fmin(d, pt_seg_dist(x_m, y_m, path->p[i], path->p[i + 1]));
    return d;
}

static double cross(sim_vec2_t o, sim_vec2_t a, sim_vec2_t b)
{
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

static double seg_seg_dist(sim_vec2_t a, sim_vec2_t b, sim_vec2_t c, sim_vec2_t d)
{
    double d1 = cross(a, b, c), d2 = cross(a, b, d), d3 = cross(c, d, a), d4 = cross(c, d, b);
    if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
        return 0.0;
    double m = pt_seg_dist(a.x, a.y, c, d);
    m = fmin(m, pt_seg_dist(b.x, b.y, c, d));
    m = fmin(m, pt_seg_dist(c.x, c.y, a, b));
    m = fmin(m, pt_seg_dist(d.x, d.y, a, b));
    return m;
}

double sim_paths_point_poly_dist(const sim_poly_t *poly, double x, double y)
{
    if (sim_poly_contains(poly, x, y))
        return 0.0;
    double m = INFINITY;
    for (int i = 0; i < poly->n; i++)
        m = fmin(m, pt_seg_dist(x, y, poly->p[i], poly->p[(i + 1) % poly->n]));
    return m;
}

double sim_path_min_clearance(const sim_plan_t *plan, const sim_path_t *path)
{
    double m = INFINITY;
    if (plan == NULL || path == NULL || path->n <= 0)
        return m;
    for (int s = 0; s < plan->n_solids; s++) {
        const sim_poly_t *o = &plan->solids[s].outline;
        for (int i = 0; i < path->n; i++) {
            if (sim_poly_contains(o, path->p[i].x, path->p[i].y))
                return 0.0;
            if (i + 1 < path->n)
                for (int k = 0; k < o->n; k++)
                    m = fmin(m, seg_seg_dist(path->p[i], path->p[i + 1], o->p[k], o->p[(k + 1) % o->n]));
            else if (path->n == 1)
                m = fmin(m, sim_paths_point_poly_dist(o, path->p[i].x, path->p[i].y));
        }
    }
    return m;
}

int sim_path_first_tight_segment(const sim_plan_t *plan, const sim_path_t *path, double clearance_m, int *seg,
                                 double *dist_m)
{
    if (plan == NULL || path == NULL)
        return 0;
    for (int i = 0; i + 1 < path->n; i++) {
        double m = INFINITY;
        for (int s = 0; s < plan->n_solids && m >= clearance_m; s++) {
            const sim_poly_t *o = &plan->solids[s].outline;
            if (sim_poly_contains(o, path->p[i].x, path->p[i].y)) {
                m = 0.0;
                break;
            }
            for (int k = 0; k < o->n; k++)
                m = fmin(m, seg_seg_dist(path->p[i], path->p[i + 1], o->p[k], o->p[(k + 1) % o->n]));
        }
        if (m < clearance_m) {
            if (seg)
                *seg = i;
            if (dist_m)
                *dist_m = m;
            return 1;
        }
    }
    return 0;
}

/* ---- coverage ----------------------------------------------------------------------------- */

/* The cell of (x, y) as sim_grid_world_to_cell finds it, for points that may be off the grid
 * (0) but are never far from it: the coverage sweep asks this millions of times, and the
 * clamping that guards sim_grid_world_to_cell against absurd coordinates cost most of it. */
static inline int cell_near(const sim_grid_t *g, double x, double y, int *c, int *r)
{
    const double fc = floor((x - g->origin.x) / g->res), fr = floor((y - g->origin.y) / g->res);
    if (!(fc >= 0 && fr >= 0 && fc < g->w && fr < g->h)) /* NaN too */
        return 0;
    *c = (int)fc;
    *r = (int)fr;
    return 1;
}

static int line_of_sight(const sim_grid_t *g, double x0, double y0, double x1, double y1)
{
    double len = hypot(x1 - x0, y1 - y0);
    int steps = (int)ceil(len / (g->res * 0.5));
    for (int i = 1; i < steps; i++) {
        double t = (double)i / steps;
        int c, r;
        if (!cell_near(g, x0 + t * (x1 - x0), y0 + t * (y1 - y0), &c, &r))
            return 0;
        if (g->cells[(size_t)r * (size_t)g->w + (size_t)c] == SIM_CELL_WALL)
            return 0;
    }
    return 1;
}

/* Marks the FREE cells seen from (x, y) within range; returns how many were new. */
static size_t cover_from(const sim_grid_t *g, uint8_t *covered, double x, double y, double range)
{
    size_t added = 0;
    int rad = (int)ceil(range / g->res) + 1, pc, pr;
    (void)sim_grid_world_to_cell(g, x, y, &pc, &pr);
    for (int r = pr - rad; r <= pr + rad; r++)
        for (int c = pc - rad; c <= pc + rad; c++) {
            if (c < 0 || r < 0 || c >= g->w || r >= g->h)
                continue;
            size_t i = (size_t)r * (size_t)g->w + (size_t)c;
            if (covered[i] || g->cells[i] != SIM_CELL_FREE)
                continue;
            double cx, cy;
            sim_grid_cell_centre(g, c, r, &cx, &cy);
            if (hypot(cx - x, cy - y) > range)
                continue;
            if (line_of_sight(g, x, y, cx, cy)) {
                covered[i] = 1;
                added++;
            }
        }
    return added;
}

double sim_paths_coverage(const sim_grid_t *grid, const sim_path_t *paths, int n, double range_m)
{
    if (grid == NULL || grid->cells == NULL || paths == NULL || n <= 0 || !(range_m > 0))
        return 0.0;
    size_t ncell = (size_t)grid->w * (size_t)grid->h;
    uint8_t *covered = calloc(ncell, 1), *sourced = calloc(ncell, 1);
    if (covered == NULL || sourced == NULL) {
        free(covered);
        free(sourced);
        return -1.0;
    }
    size_t free_cells = 0;
    for (size_t i = 0; i < ncell; i++)
        free_cells += grid->cells[i] == SIM_CELL_FREE;
    size_t hit = 0;
    for (int k = 0; k < n && hit < free_cells; k++) {
        const sim_path_t *p = &paths[k];
        for (int i = 0; i < p->n && hit < free_cells; i++) {
            const int last = i + 1 == p->n;
            double dx = last ? 0 : p->p[i + 1].x - p->p[i].x, dy = last ? 0 : p->p[i + 1].y - p->p[i].y;
            int steps = last ? 1 : (int)ceil(hypot(dx, dy) / COVER_STEP_M);
            for (int s = 0; s < steps; s++) {
                double t = (double)s / steps, x = p->p[i].x + t * dx, y = p->p[i].y + t * dy;
                int c, r;
                if (sim_grid_world_to_cell(grid, x, y, &c, &r) == 0) {
                    uint8_t *src = &sourced[(size_t)r * (size_t)grid->w + (size_t)c];
                    if (*src) /* a place seen from already (a tour passing again) */
                        continue;
                    *src = 1;
                }
                hit += cover_from(grid, covered, x, y, range_m);
            }
        }
    }
    free(covered);
    free(sourced);
    return free_cells ? (double)hit / (double)free_cells : 0.0;
}
