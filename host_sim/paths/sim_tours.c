/* The multi-robot coverage tour generator: traversable cells, A*, sweep goals per room,
 * rooms shared out between robots (contract in sim_paths.h). */
#include "sim_paths.h"
#include "sim_paths_util.h"
#include "sim_rng.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- traversability --------------------------------------------------------------------- */

typedef struct {
    const sim_plan_t *plan;
    sim_grid_t g;
    uint8_t *trav; /* 1 = the robot centre may be here */
    double need;   /* clearance_m + res_m */
} planner_t;

static int build_trav(planner_t *pl)
{
    sim_grid_t *g = &pl->g;
    size_t n = (size_t)g->w * (size_t)g->h;
    pl->trav = calloc(n, 1);
    if (pl->trav == NULL)
        return -ENOMEM;
    const sim_plan_t *plan = pl->plan;
    double need = pl->need;
    /* Solid bounding boxes grown by `need`, for the prefilter below. */
    double *bb = malloc((size_t)(plan->n_solids > 0 ? plan->n_solids : 1) * 4 * sizeof *bb);
    if (bb == NULL)
        return -ENOMEM;
    for (int s = 0; s < plan->n_solids; s++) {
        const sim_poly_t *o = &plan->solids[s].outline;
        double *b = bb + 4 * s;
        b[0] = b[1] = INFINITY;
        b[2] = b[3] = -INFINITY;
        for (int k = 0; k < o->n; k++) {
            b[0] = fmin(b[0], o->p[k].x);
            b[1] = fmin(b[1], o->p[k].y);
            b[2] = fmax(b[2], o->p[k].x);
            b[3] = fmax(b[3], o->p[k].y);
        }
        b[0] -= need;
        b[1] -= need;
        b[2] += need;
        b[3] += need;
    }
    /* Free cells far enough from every solid (bounding-box prefilter, exact distance). */
    for (int r = 0; r < g->h; r++)
        for (int c = 0; c < g->w; c++) {
            size_t i = (size_t)r * (size_t)g->w + (size_t)c;
            if (g->cells[i] != SIM_CELL_FREE)
                continue;
            double x, y;
            sim_grid_cell_centre(g, c, r, &x, &y);
            int ok = 1;
            for (int s = 0; s < plan->n_solids && ok; s++) {
                const double *b = bb + 4 * s;
                if (x < b[0] || x > b[2] || y < b[1] || y > b[3])
                    continue;
                if (sim_paths_point_poly_dist(&plan->solids[s].outline, x, y) < need)
                    ok = 0;
            }
            pl->trav[i] = (uint8_t)ok;
        }
    free(bb);
    /* Away from OUTSIDE cells (and the grid border) too: only border outside cells matter. */
    int rad = (int)ceil(need / g->res);
    for (int r = -1; r <= g->h; r++)
        for (int c = -1; c <= g->w; c++) {
            if (sim_grid_at(g, c, r) != SIM_CELL_OUTSIDE)
                continue;
            int border = 0;
            for (int k = 0; k < 4 && !border; k++) {
                int cc = c + (k == 0) - (k == 1), rr = r + (k == 2) - (k == 3);
                if (cc >= 0 && rr >= 0 && cc < g->w && rr < g->h && sim_grid_at(g, cc, rr) != SIM_CELL_OUTSIDE)
                    border = 1;
            }
            if (!border)
                continue;
            for (int dr = -rad; dr <= rad; dr++)
                for (int dc = -rad; dc <= rad; dc++) {
                    int cc = c + dc, rr = r + dr;
                    if (cc < 0 || rr < 0 || cc >= g->w || rr >= g->h)
                        continue;
                    if ((double)(dc * dc + dr * dr) * g->res * g->res < need * need)
                        pl->trav[(size_t)rr * (size_t)g->w + (size_t)cc] = 0;
                }
        }
    /* Keep the largest 4-connected region only. */
    int *comp = malloc(n * sizeof *comp);
    int *queue = malloc(n * sizeof *queue);
    if (comp == NULL || queue == NULL) {
        free(comp);
        free(queue);
        return -ENOMEM;
    }
    for (size_t i = 0; i < n; i++)
        comp[i] = -1;
    int best = -1, best_size = 0, nc = 0;
    for (size_t s = 0; s < n; s++) {
        if (!pl->trav[s] || comp[s] >= 0)
            continue;
        int head = 0, tail = 0;
        queue[tail++] = (int)s;
        comp[s] = nc;
        while (head < tail) {
            int i = queue[head++], c = i % g->w, r = i / g->w;
            const int dc[4] = {1, -1, 0, 0}, dr[4] = {0, 0, 1, -1};
            for (int k = 0; k < 4; k++) {
                int cc = c + dc[k], rr = r + dr[k];
                if (cc < 0 || rr < 0 || cc >= g->w || rr >= g->h)
                    continue;
                int j = rr * g->w + cc;
                if (pl->trav[j] && comp[j] < 0) {
                    comp[j] = nc;
                    queue[tail++] = j;
                }
            }
        }
        if (tail > best_size) {
            best_size = tail;
            best = nc;
        }
        nc++;
    }
    for (size_t i = 0; i < n; i++)
        pl->trav[i] = (uint8_t)(pl->trav[i] && comp[i] == best);
    free(comp);
    free(queue);
    return best_size > 0 ? 0 : -ENOENT;
}

static int trav_at_point(const planner_t *pl, double x, double y)
{
    int c, r;
    if (sim_grid_world_to_cell(&pl->g, x, y, &c, &r) != 0)
        return 0;
    return pl->trav[(size_t)r * (size_t)pl->g.w + (size_t)c];
}

/* Every sample (spacing res/2) of segment a-b lies on a traversable cell. With cell centres
 * at least clearance + res from the solids, each sample is at least clearance + 0.29 res
 * away, and the points between samples (within res/4 of one) at least clearance. */
static int seg_clear(const planner_t *pl, sim_vec2_t a, sim_vec2_t b)
{
    double len = hypot(b.x - a.x, b.y - a.y);
    int steps = (int)ceil(len / (pl->g.res * 0.5));
    if (steps < 1)
        steps = 1;
    for (int i = 0; i <= steps; i++) {
        double t = (double)i / steps;
        if (!trav_at_point(pl, a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)))
            return 0;
    }
    return 1;
}

/* ---- A* ------------------------------------------------------------------------------------ */

typedef struct {
    double f;
    int i;
} heap_item_t;

typedef struct {
    heap_item_t *a;
    int n, cap;
} heap_t;

static int heap_push(heap_t *h, double f, int i)
{
    if (h->n == h->cap) {
        int nc = h->cap ? h->cap * 2 : 1024;
        heap_item_t *na = realloc(h->a, (size_t)nc * sizeof *na);
        if (na == NULL)
            return -ENOMEM;
        h->a = na;
        h->cap = nc;
    }
    int k = h->n++;
    while (k > 0) {
        int p = (k - 1) / 2;
        /* Ties broken by cell index so the search is deterministic. */
        if (h->a[p].f < f || (h->a[p].f == f && h->a[p].i <= i))
            break;
        h->a[k] = h->a[p];
        k = p;
    }
    h->a[k].f = f;
    h->a[k].i = i;
    return 0;
}

static heap_item_t heap_pop(heap_t *h)
{
    heap_item_t top = h->a[0], last = h->a[--h->n];
    int k = 0;
    for (;;) {
        int c = 2 * k + 1;
        if (c >= h->n)
            break;
        if (c + 1 < h->n && (h->a[c + 1].f < h->a[c].f || (h->a[c + 1].f == h->a[c].f && h->a[c + 1].i < h->a[c].i)))
            c++;
        if (last.f < h->a[c].f || (last.f == h->a[c].f && last.i <= h->a[c].i))
            break;
        h->a[k] = h->a[c];
        k = c;
    }
    h->a[k] = last;
    return top;
}

/* Per-cell state of a search. A cell's gcost and closed flag count only when its stamp is the
 * current search's: a search starts by taking a new stamp instead of clearing the whole grid
 * (the legs between sweep goals are short, and a fleet of 1024 robots makes thousands of them
 * on grids of a million cells). */
typedef struct {
    double *gcost;
    int *parent;
    uint32_t *open_at;   /* stamp of the search that set gcost */
    uint32_t *closed_at; /* stamp of the search that closed the cell */
    uint32_t stamp;
    heap_t heap;
    int *cells; /* result buffer */
    int cap_cells;
} astar_t;

static double octile(int c0, int r0, int c1, int r1)
{
    int dx = abs(c1 - c0), dy = abs(r1 - r0);
    int mn = dx < dy ? dx : dy, mx = dx < dy ? dy : dx;
    return (mx - mn) + 1.4142135623730951 * mn;
}

/* Shortest 8-connected path of traversable cells from s to t (no corner cutting). On success
 * as->cells[0..*len-1] holds it from s to t. */
static int astar(const planner_t *pl, astar_t *as, int s, int t, int *len)
{
    const sim_grid_t *g = &pl->g;
    if (++as->stamp == 0) { /* wrapped: forget every older stamp */
        size_t n = (size_t)g->w * (size_t)g->h;
        memset(as->open_at, 0, n * sizeof *as->open_at);
        memset(as->closed_at, 0, n * sizeof *as->closed_at);
        as->stamp = 1;
    }
    const uint32_t stamp = as->stamp;
    as->heap.n = 0;
    int tc = t % g->w, tr = t / g->w;
    as->gcost[s] = 0;
    as->open_at[s] = stamp;
    as->parent[s] = -1;
    int rc = heap_push(&as->heap, octile(s % g->w, s / g->w, tc, tr), s);
    int found = 0;
    while (rc == 0 && as->heap.n > 0) {
        heap_item_t it = heap_pop(&as->heap);
        int i = it.i;
        if (as->closed_at[i] == stamp)
            continue;
        as->closed_at[i] = stamp;
        if (i == t) {
            found = 1;
            break;
        }
        int c = i % g->w, r = i / g->w;
        for (int dr = -1; dr <= 1 && rc == 0; dr++)
            for (int dc = -1; dc <= 1 && rc == 0; dc++) {
                if (dr == 0 && dc == 0)
                    continue;
                int cc = c + dc, rr = r + dr;
                if (cc < 0 || rr < 0 || cc >= g->w || rr >= g->h)
                    continue;
                int j = rr * g->w + cc;
                if (!pl->trav[j] || as->closed_at[j] == stamp)
                    continue;
                if (dr != 0 && dc != 0 && (!pl->trav[r * g->w + cc] || !pl->trav[rr * g->w + c]))
                    continue;
                double ng = as->gcost[i] + ((dr != 0 && dc != 0) ? 1.4142135623730951 : 1.0);
                if (as->open_at[j] != stamp || ng < as->gcost[j]) {
                    as->gcost[j] = ng;
                    as->open_at[j] = stamp;
                    as->parent[j] = i;
                    rc = heap_push(&as->heap, ng + octile(cc, rr, tc, tr), j);
                }
            }
    }
    if (rc != 0)
        return rc;
    if (!found)
        return -ENOENT;
    int k = 0;
    for (int i = t; i >= 0; i = as->parent[i])
        k++;
    if (k > as->cap_cells) {
        int *nc = realloc(as->cells, (size_t)k * sizeof *nc);
        if (nc == NULL)
            return -ENOMEM;
        as->cells = nc;
        as->cap_cells = k;
    }
    int m = k;
    for (int i = t; i >= 0; i = as->parent[i])
        as->cells[--m] = i;
    *len = k;
    return 0;
}

/* Appends the leg s -> t: A*, then greedy line-of-sight shortcuts (from each kept point, the
 * farthest later cell of the leg whose straight segment stays clear). */
static int append_leg(const planner_t *pl, astar_t *as, int s, int t, sim_path_t *path, int *cap)
{
    int len = 0;
    int rc = astar(pl, as, s, t, &len);
    if (rc != 0)
        return rc;
    if (len < 1)
        return -ENOENT; /* a found path holds at least its start cell */
    sim_vec2_t *pts = malloc((size_t)len * sizeof *pts);
    if (pts == NULL)
        return -ENOMEM;
    for (int k = 0; k < len; k++)
        sim_grid_cell_centre(&pl->g, as->cells[k] % pl->g.w, as->cells[k] / pl->g.w, &pts[k].x, &pts[k].y);
    int i = 0;
    rc = sim_paths_push(path, cap, pts[0].x, pts[0].y);
    while (rc == 0 && i < len - 1) {
        int best = i + 1;
        for (int j = len - 1; j > i + 1; j--)
            if (seg_clear(pl, pts[i], pts[j])) {
                best = j;
                break;
            }
        i = best;
        rc = sim_paths_push(path, cap, pts[i].x, pts[i].y);
    }
    free(pts);
    return rc;
}

/* ---- rooms and goals ---------------------------------------------------------------------- */

typedef struct {
    int *goals; /* cell indices in visiting order */
    int n_goals;
    int rep;      /* representative cell (nearest the centroid) */
    int robot;    /* assigned robot, -1 none */
    double rx, ry;
} room_info_t;

static void poly_centroid(const sim_poly_t *p, double *cx, double *cy)
{
    double a = 0, x = 0, y = 0;
    for (int i = 0; i < p->n; i++) {
        const sim_vec2_t *u = &p->p[i], *v = &p->p[(i + 1) % p->n];
        double cr = u->x * v->y - v->x * u->y;
        a += cr;
        x += (u->x + v->x) * cr;
        y += (u->y + v->y) * cr;
    }
    if (fabs(a) < 1e-12) {
        *cx = p->p[0].x;
        *cy = p->p[0].y;
        return;
    }
    *cx = x / (3 * a);
    *cy = y / (3 * a);
}

/* Sweep goals of one room: for each lattice point (spacing sweep), the traversable room cell
 * nearest to it within 0.75 sweep; ordered row by row, alternating direction. */
static int room_goals(const planner_t *pl, const sim_poly_t *room, double sweep, room_info_t *ri)
{
    const sim_grid_t *g = &pl->g;
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int k = 0; k < room->n; k++) {
        x0 = fmin(x0, room->p[k].x);
        x1 = fmax(x1, room->p[k].x);
        y0 = fmin(y0, room->p[k].y);
        y1 = fmax(y1, room->p[k].y);
    }
    /* Room cells in the traversable region. */
    int c0, r0, c1, r1;
    (void)sim_grid_world_to_cell(g, x0, y0, &c0, &r0);
    (void)sim_grid_world_to_cell(g, x1, y1, &c1, &r1);
    c0 = c0 < 0 ? 0 : c0;
    r0 = r0 < 0 ? 0 : r0;
    c1 = c1 >= g->w ? g->w - 1 : c1;
    r1 = r1 >= g->h ? g->h - 1 : r1;
    double cx, cy;
    poly_centroid(room, &cx, &cy);
    ri->rep = -1;
    ri->n_goals = 0;
    ri->goals = NULL;
    double best_rep = INFINITY;
    int nx = (int)floor((x1 - x0) / sweep) + 1, ny = (int)floor((y1 - y0) / sweep) + 1;
    double ox = x0 + 0.5 * ((x1 - x0) - (nx - 1) * sweep), oy = y0 + 0.5 * ((y1 - y0) - (ny - 1) * sweep);
    int *best = malloc((size_t)nx * (size_t)ny * sizeof *best);
    double *bestd = malloc((size_t)nx * (size_t)ny * sizeof *bestd);
    if (best == NULL || bestd == NULL) {
        free(best);
        free(bestd);
        return -ENOMEM;
    }
    for (int k = 0; k < nx * ny; k++) {
        best[k] = -1;
        bestd[k] = 0.75 * sweep;
    }
    for (int r = r0; r <= r1; r++)
        for (int c = c0; c <= c1; c++) {
            int i = r * g->w + c;
            if (!pl->trav[i])
                continue;
            double x, y;
            sim_grid_cell_centre(g, c, r, &x, &y);
            if (!sim_poly_contains(room, x, y))
                continue;
            double dc = hypot(x - cx, y - cy);
            if (dc < best_rep) {
                best_rep = dc;
                ri->rep = i;
                ri->rx = x;
                ri->ry = y;
            }
            /* The nearest lattice points (a cell can serve the 4 around it). */
            int gx = (int)floor((x - ox) / sweep), gy = (int)floor((y - oy) / sweep);
            for (int dy = 0; dy <= 1; dy++)
                for (int dx = 0; dx <= 1; dx++) {
                    int lx = gx + dx, ly = gy + dy;
                    if (lx < 0 || ly < 0 || lx >= nx || ly >= ny)
                        continue;
                    double d = hypot(x - (ox + lx * sweep), y - (oy + ly * sweep));
                    if (d < bestd[ly * nx + lx]) {
                        bestd[ly * nx + lx] = d;
                        best[ly * nx + lx] = i;
                    }
                }
        }
    int rc = 0;
    if (ri->rep >= 0) {
        ri->goals = malloc(((size_t)nx * (size_t)ny + 1) * sizeof *ri->goals);
        if (ri->goals == NULL) {
            rc = -ENOMEM;
        } else {
            for (int ly = 0; ly < ny; ly++)
                for (int k = 0; k < nx; k++) {
                    int lx = (ly % 2 == 0) ? k : nx - 1 - k;
                    int cell = best[ly * nx + lx];
                    if (cell >= 0)
                        ri->goals[ri->n_goals++] = cell;
                }
            if (ri->n_goals == 0)
                ri->goals[ri->n_goals++] = ri->rep;
        }
    }
    free(best);
    free(bestd);
    return rc;
}

/* ---- more robots than rooms -------------------------------------------------------------- */

static int astar_alloc(astar_t *as, size_t ncell)
{
    as->gcost = malloc(ncell * sizeof *as->gcost);
    as->parent = malloc(ncell * sizeof *as->parent);
    as->open_at = calloc(ncell, sizeof *as->open_at);
    as->closed_at = calloc(ncell, sizeof *as->closed_at);
    return as->gcost == NULL || as->parent == NULL || as->open_at == NULL || as->closed_at == NULL ? -ENOMEM : 0;
}

/* Keeps, in sweep order, the room's goals at least half the lattice spacing from every goal
 * kept before (two lattice points near a wall may pick one cell, or two cells side by side);
 * then, while they are fewer than `need`, recomputes them on a lattice of half the spacing,
 * down to the grid's resolution: so `need` robots start on distinct cells, as far apart as
 * the room allows. O(goals^2): goals stay within a few times `need`. 0, -ENOSPC, -ENOMEM. */
static int distinct_goals(const planner_t *pl, const sim_poly_t *room, double sweep, int need, room_info_t *ri)
{
    const int w = pl->g.w;
    for (;;) {
        const double apart = 0.5 * sweep / pl->g.res; /* in cells */
        int n = 0;
        for (int k = 0; k < ri->n_goals; k++) {
            int near = 0, c = ri->goals[k];
            for (int q = 0; q < n && !near; q++)
                near = hypot(ri->goals[q] % w - c % w, ri->goals[q] / w - c / w) < apart;
            if (!near)
                ri->goals[n++] = c;
        }
        ri->n_goals = n;
        if (n >= need)
            return 0;
        sweep *= 0.5;
        if (sweep < pl->g.res)
            return -ENOSPC;
        room_info_t finer = *ri;
        int rc = room_goals(pl, room, sweep, &finer);
        if (rc != 0)
            return rc;
        free(ri->goals);
        ri->goals = finer.goals;
        ri->n_goals = finer.n_goals;
    }
}

/* Tours for more robots than reachable rooms (the rule in sim_paths.h): robot r < eligible
 * starts in the r-th reachable room; each further robot goes to the room with the most sweep
 * goals per robot so far (ties: the lower room index); a room's robots split its goals, in
 * sweep order, into consecutive runs of near equal length (robot j of k: goals j*g/k ..
 * (j+1)*g/k - 1), each starting on the first goal of its run. pl, as and ri are the
 * generator's, ready; the caller frees them and, on failure, the paths. */
static int crowded_tours(const sim_plan_t *plan, const sim_paths_cfg_t *cfg, const planner_t *pl, astar_t *as,
                         room_info_t *ri, sim_path_t *paths, char *err, size_t errlen)
{
    const int N = cfg->n_robots;
    int *room_of = malloc((size_t)N * sizeof *room_of);      /* robot -> room */
    int *rank = malloc((size_t)N * sizeof *rank);            /* its place among the room's robots */
    int *count = calloc((size_t)plan->n_rooms, sizeof *count); /* robots per room */
    int *work = calloc((size_t)plan->n_rooms, sizeof *work);   /* the room's sweep goals */
    int rc = room_of == NULL || rank == NULL || count == NULL || work == NULL ? -ENOMEM : 0;
    int r = 0;
    for (int k = 0; k < plan->n_rooms && rc == 0; k++) {
        if (ri[k].rep < 0)
            continue;
        rc = distinct_goals(pl, &plan->rooms[k].outline, cfg->sweep_m, 1, &ri[k]);
        work[k] = ri[k].n_goals;
        room_of[r] = k;
        rank[r++] = 0;
        count[k] = 1;
    }
    for (; r < N && rc == 0; r++) {
        int kb = -1;
        for (int k = 0; k < plan->n_rooms; k++)
            if (count[k] > 0 && (kb < 0 || (long long)work[k] * count[kb] > (long long)work[kb] * count[k]))
                kb = k;
        room_of[r] = kb;
        rank[r] = count[kb]++;
    }
    for (int k = 0; k < plan->n_rooms && rc == 0; k++) {
        if (count[k] < 2)
            continue;
        rc = distinct_goals(pl, &plan->rooms[k].outline, cfg->sweep_m, count[k], &ri[k]);
        if (rc == -ENOSPC)
            rc = sim_paths_errf(err, errlen,
                                "room %d (%s) gets %d robots, but only %d distinct start cells keep %g m clearance "
                                "on the %g m grid: give fewer robots, a finer --res or a plan with more rooms",
                                k, plan->rooms[k].type, count[k], ri[k].n_goals, cfg->clearance_m, cfg->res_m);
    }
    for (r = 0; r < N && rc == 0; r++) {
        const room_info_t *room = &ri[room_of[r]];
        const int g = room->n_goals, k = count[room_of[r]];
        const int lo = (int)((long long)rank[r] * g / k), hi = (int)((long long)(rank[r] + 1) * g / k);
        int cap = 0, cur = room->goals[lo];
        double x, y;
        sim_grid_cell_centre(&pl->g, cur % pl->g.w, cur / pl->g.w, &x, &y);
        rc = sim_paths_push(&paths[r], &cap, x, y);
        for (int q = lo + 1; q < hi && rc == 0; q++) {
            rc = append_leg(pl, as, cur, room->goals[q], &paths[r], &cap);
            cur = room->goals[q];
        }
        if (rc == 0 && paths[r].n < 2) {
            /* A run of one goal: on to the next run's first goal (the previous run's last for
             * the last run, the room's representative for a room of one goal) for a direction. */
            int to = hi < g ? room->goals[hi] : lo > 0 ? room->goals[lo - 1] : room->rep;
            if (to != cur)
                rc = append_leg(pl, as, cur, to, &paths[r], &cap);
            else
                rc = sim_paths_errf(err, errlen, "room %d is too small for a path of 2 waypoints", room_of[r]);
        }
        if (rc == -ENOENT)
            rc = sim_paths_errf(err, errlen, "robot %d: no path between two goals (disconnected region)", r);
        paths[r].start_room = room_of[r];
    }
    free(room_of);
    free(rank);
    free(count);
    free(work);
    return rc;
}

/* ---- the generator ---------------------------------------------------------------------- */

int sim_paths_generate(const sim_plan_t *plan, const sim_paths_cfg_t *cfg, sim_path_t *paths, char *err,
                       size_t errlen)
{
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (plan == NULL || cfg == NULL || paths == NULL)
        return sim_paths_errf(err, errlen, "no plan, configuration or output");
    if (cfg->n_robots < 1 || cfg->n_robots > SIM_PATHS_MAX_ROBOTS)
        return sim_paths_errf(err, errlen, "robots %d out of range 1..%d", cfg->n_robots, SIM_PATHS_MAX_ROBOTS);
    if (!(cfg->res_m >= 0.005 && cfg->res_m <= 1.0) || !(cfg->clearance_m >= 0.0 && cfg->clearance_m <= 5.0) ||
        !(cfg->sweep_m >= 0.1 && cfg->sweep_m <= 100.0) || (cfg->own_rooms != 0 && cfg->own_rooms != 1))
        return sim_paths_errf(err, errlen, "bad configuration (res %g m, clearance %g m, sweep %g m, own rooms %d)",
                              cfg->res_m, cfg->clearance_m, cfg->sweep_m, cfg->own_rooms);
    const int N = cfg->n_robots;
    for (int r = 0; r < N; r++) {
        sim_path_init(&paths[r]);
    }
    planner_t pl = {.plan = plan, .need = cfg->clearance_m + cfg->res_m};
    room_info_t *ri = NULL;
    astar_t as = {0};
    int rc = sim_grid_from_plan(plan, cfg->res_m, &pl.g);
    if (rc != 0) {
        sim_paths_errf(err, errlen, "cannot rasterise the plan at %g m: %s", cfg->res_m, strerror(-rc));
        return rc;
    }
    rc = build_trav(&pl);
    if (rc == -ENOENT) {
        sim_paths_errf(err, errlen, "no cell of the plan keeps %g m clearance from the walls", cfg->clearance_m);
        goto out;
    }
    if (rc != 0)
        goto out;

    ri = calloc((size_t)(plan->n_rooms > 0 ? plan->n_rooms : 1), sizeof *ri);
    if (ri == NULL) {
        rc = -ENOMEM;
        goto out;
    }
    int eligible = 0;
    for (int k = 0; k < plan->n_rooms && rc == 0; k++) {
        rc = room_goals(&pl, &plan->rooms[k].outline, cfg->sweep_m, &ri[k]);
        ri[k].robot = -1;
        eligible += ri[k].rep >= 0;
    }
    if (rc != 0)
        goto out;
    if (eligible == 0) {
        rc = sim_paths_errf(err, errlen, "the plan has no reachable room (with %g m clearance)", cfg->clearance_m);
        goto out;
    }
    if (N > eligible) {
        rc = astar_alloc(&as, (size_t)pl.g.w * (size_t)pl.g.h);
        if (rc == 0)
            rc = crowded_tours(plan, cfg, &pl, &as, ri, paths, err, errlen);
        goto out;
    }

    /* Start rooms: a seeded choice of N distinct reachable rooms (all of them when N equals
     * their number), robot r gets the r-th in room order so files are stable. */
    int *order = malloc((size_t)eligible * sizeof *order);
    int *robot_last = malloc((size_t)N * sizeof *robot_last);
    double *load = calloc((size_t)N, sizeof *load);
    int **tour = calloc((size_t)N, sizeof *tour);
    int *tour_n = calloc((size_t)N, sizeof *tour_n);
    if (order == NULL || robot_last == NULL || load == NULL || tour == NULL || tour_n == NULL) {
        rc = -ENOMEM;
        goto out2;
    }
    for (int k = 0, e = 0; k < plan->n_rooms; k++)
        if (ri[k].rep >= 0)
            order[e++] = k;
    sim_rng_seq_t rng = {cfg->seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull};
    for (int k = eligible - 1; k > 0; k--) {
        int j = (int)(sim_rng_next(&rng) % (uint64_t)(k + 1));
        int t = order[k];
        order[k] = order[j];
        order[j] = t;
    }
    /* The first N of the shuffle start; sort them so robot 0 has the lowest room index. */
    for (int a = 1; a < N; a++)
        for (int b = a; b > 0 && order[b - 1] > order[b]; b--) {
            int t = order[b];
            order[b] = order[b - 1];
            order[b - 1] = t;
        }
    for (int r = 0; r < N; r++) {
        tour[r] = malloc((size_t)plan->n_rooms * sizeof **tour);
        if (tour[r] == NULL) {
            rc = -ENOMEM;
            goto out2;
        }
        int k = order[r];
        tour[r][tour_n[r]++] = k;
        ri[k].robot = r;
        robot_last[r] = k;
        load[r] = ri[k].n_goals;
        paths[r].start_room = k;
    }
    /* The other rooms: the robot with the smallest load so far takes the unassigned room
     * nearest to its last one; its load grows by the room's goals and the trip there
     * (in units of sweep spacing). With own_rooms nobody takes them. */
    while (!cfg->own_rooms) {
        int rb = 0;
        for (int r = 1; r < N; r++)
            if (load[r] < load[rb])
                rb = r;
        int kb = -1;
        double db = INFINITY;
        const room_info_t *last = &ri[robot_last[rb]];
        for (int e = N; e < eligible; e++) {
            int k = order[e];
            if (ri[k].robot >= 0)
                continue;
            double d = hypot(ri[k].rx - last->rx, ri[k].ry - last->ry);
            if (d < db) {
                db = d;
                kb = k;
            }
        }
        if (kb < 0)
            break;
        ri[kb].robot = rb;
        tour[rb][tour_n[rb]++] = kb;
        robot_last[rb] = kb;
        load[rb] += ri[kb].n_goals + db / cfg->sweep_m;
    }

    /* Walk each tour: sweep goals of each room, nearer end first; A* legs between them. */
    rc = astar_alloc(&as, (size_t)pl.g.w * (size_t)pl.g.h);
    if (rc != 0)
        goto out2;
    for (int r = 0; r < N && rc == 0; r++) {
        int cap = 0, cur = -1;
        for (int q = 0; q < tour_n[r] && rc == 0; q++) {
            const room_info_t *room = &ri[tour[r][q]];
            int ng = room->n_goals, rev = 0;
            if (cur >= 0 && ng > 1) {
                int a = room->goals[0], b = room->goals[ng - 1], w = pl.g.w;
                double da = hypot(a % w - cur % w, a / w - cur / w), dbb = hypot(b % w - cur % w, b / w - cur / w);
                rev = dbb < da;
            }
            for (int k = 0; k < ng && rc == 0; k++) {
                int goal = room->goals[rev ? ng - 1 - k : k];
                if (cur < 0) {
                    double x, y;
                    sim_grid_cell_centre(&pl.g, goal % pl.g.w, goal / pl.g.w, &x, &y);
                    rc = sim_paths_push(&paths[r], &cap, x, y);
                } else if (goal != cur) {
                    rc = append_leg(&pl, &as, cur, goal, &paths[r], &cap);
                }
                cur = goal;
            }
        }
        if (rc == 0 && paths[r].n < 2) {
            /* A single-goal tour: add the room's representative (or a neighbour) as a second
             * point so every path has a direction. */
            const room_info_t *room = &ri[tour[r][0]];
            if (room->rep != cur)
                rc = append_leg(&pl, &as, cur, room->rep, &paths[r], &cap);
            else
                rc = sim_paths_errf(err, errlen, "room %d is too small for a path of 2 waypoints", tour[r][0]);
        }
        if (rc == -ENOENT)
            rc = sim_paths_errf(err, errlen, "robot %d: no path between two goals (disconnected region)", r);
    }

out2:
    if (tour != NULL)
        for (int r = 0; r < N; r++)
            free(tour[r]);
    free(tour);
    free(tour_n);
    free(order);
    free(robot_last);
    free(load);
out:
    if (ri != NULL)
        for (int k = 0; k < plan->n_rooms; k++)
            free(ri[k].goals);
    free(ri);
    free(as.gcost);
    free(as.parent);
    free(as.open_at);
    free(as.closed_at);
    free(as.cells);
    free(as.heap.a);
    free(pl.trav);
    sim_grid_free(&pl.g);
    if (rc != 0) {
        if (err != NULL && errlen > 0 && err[0] == '\0')
            snprintf(err, errlen, "path generation failed: %s", strerror(-rc));
        for (int r = 0; r < N; r++)
            sim_path_free(&paths[r]);
    }
    return rc;
}
