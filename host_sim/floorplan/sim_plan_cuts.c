/* Openings against walls: which doors cut which walls, which openings are isolated, and the
 * solids (walls minus the doors that cut them). The rules are sim_plan.h's. */
#include "sim_plan_int.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Wall pieces shorter than this (metres) along the wall are not kept. */
#define PLAN_MIN_PIECE_M 1e-4
/* An opening this close to a wall (metres) is not isolated: a door drawn across a gap in a
 * wall touches the wall ends, and transforms leave rounding far below a millimetre. */
#define PLAN_TOUCH_M 1e-3
/* A door cuts a wall it is not nested in when their overlap reaches across at least this
 * fraction of the wall's thickness (doors are drawn as thick as their wall, or a little
 * thinner; one grazing a perpendicular wall reaches across a sliver of it). */
#define PLAN_CROSS_FRACTION 0.5
/* Room for a door clipped by every edge of a wall: a non-convex door gains a point per
 * crossing, so the slack is generous; running out only means "does not cross". */
#define XCLIP_MAX (4 * SIM_POLY_MAX_POINTS)

/* ---- solids ------------------------------------------------------------------------------ */

static int push_solid(sim_plan_t *p, int *cap, const sim_poly_t *poly, int is_rect, double height)
{
    int rc = sim_plan_grow((void **)&p->solids, cap, p->n_solids + 1, sizeof *p->solids);
    if (rc != 0)
        return rc;
    sim_solid_t *s = &p->solids[p->n_solids++];
    memset(s, 0, sizeof *s);
    s->outline = *poly;
    s->is_rect = is_rect;
    s->height = height;
    return 0;
}

typedef struct {
    double a, b;
} interval_t;

static int cmp_interval(const void *x, const void *y)
{
    const interval_t *p = x, *q = y;
    return (p->a > q->a) - (p->a < q->a);
}

/* A convex wall's frame for door cutting: origin c0 (its first point), unit long axis u (the
 * direction of its longest edge), its extent [tmin, tmax] along u and [nmin, nmax] across. */
typedef struct {
    sim_vec2_t c0;
    double ux, uy;
    double tmin, tmax, nmin, nmax;
} wall_axis_t;

static void wall_axis(const sim_poly_t *o, wall_axis_t *ax)
{
    ax->c0 = o->p[0];
    ax->ux = ax->uy = 0;
    double best = -1;
    for (int k = 0; k < o->n; k++) {
        double ex = o->p[(k + 1) % o->n].x - o->p[k].x, ey = o->p[(k + 1) % o->n].y - o->p[k].y;
        double l = hypot(ex, ey);
        if (l > best) {
            best = l;
            ax->ux = ex / l;
            ax->uy = ey / l;
        }
    }
    ax->tmin = ax->nmin = INFINITY;
    ax->tmax = ax->nmax = -INFINITY;
    for (int k = 0; k < o->n; k++) {
        double dx = o->p[k].x - ax->c0.x, dy = o->p[k].y - ax->c0.y;
        double t = dx * ax->ux + dy * ax->uy, s = dy * ax->ux - dx * ax->uy;
        ax->tmin = fmin(ax->tmin, t);
        ax->tmax = fmax(ax->tmax, t);
        ax->nmin = fmin(ax->nmin, s);
        ax->nmax = fmax(ax->nmax, s);
    }
}

/* The interval a door removes from a wall: its projection on the long axis, clamped to the
 * wall. 0 when that is empty (the door is beside the wall, not along it). */
static int door_interval(const wall_axis_t *ax, const sim_poly_t *dp, interval_t *cut)
{
    double lo = INFINITY, hi = -INFINITY;
    for (int k = 0; k < dp->n; k++) {
        double t = (dp->p[k].x - ax->c0.x) * ax->ux + (dp->p[k].y - ax->c0.y) * ax->uy;
        lo = fmin(lo, t);
        hi = fmax(hi, t);
    }
    lo = fmax(lo, ax->tmin);
    hi = fmin(hi, ax->tmax);
    if (hi <= lo)
        return 0;
    cut->a = lo;
    cut->b = hi;
    return 1;
}

/* The doors that cut each wall, as linked lists over the door indices: `first`/`next` for
 * the doors nested in the wall's group, `xfirst` over (xdoor, xnext) pairs for the other
 * doors that cross it (a door may cross several walls, hence pairs). */
typedef struct {
    int *first, *next;
    int *xfirst, *xdoor, *xnext;
    int n_pairs, cap_xdoor, cap_xnext;
} door_links_t;

/* Walls minus door openings. A convex wall (rectangles, and the trapezoids CubiCasa5K draws
 * at mitred corners) is cut along its long axis, the direction of its longest edge: each door
 * removes the interval of its projection onto that axis, across the full wall thickness, and
 * the wall is clipped to the slabs that remain. Non-convex walls are kept whole even when they
 * hold a door (limitation: an L-shaped wall polygon with a door stays closed). */
static int build_solids(sim_plan_t *p, const door_links_t *dl, const unsigned char *convex, const wall_axis_t *axes)
{
    int cap = 0;
    interval_t *cuts = NULL;
    int cap_cuts = 0;
    int rc = 0;
    for (int w = 0; w < p->n_walls && rc == 0; w++) {
        const sim_poly_t *o = &p->walls[w].outline;
        if ((dl->first[w] < 0 && dl->xfirst[w] < 0) || !convex[w]) {
            rc = push_solid(p, &cap, o, sim_poly_is_rect(o), 0.0);
            continue;
        }
        const wall_axis_t *ax = &axes[w];
        int nc = 0;
        /* Nested doors first, then the crossing ones: the order does not matter (the cuts are
         * sorted and merged), the nested ones alone give exactly the cuts of old. */
        for (int d = dl->first[w], x = dl->xfirst[w]; rc == 0 && (d >= 0 || x >= 0);) {
            int door;
            if (d >= 0) {
                door = d;
                d = dl->next[d];
            } else {
                door = dl->xdoor[x];
                x = dl->xnext[x];
            }
            interval_t cut;
            if (!door_interval(ax, &p->openings[door].outline, &cut))
                continue; /* the door does not overlap this wall along its axis */
            if ((rc = sim_plan_grow((void **)&cuts, &cap_cuts, nc + 1, sizeof *cuts)) != 0)
                break;
            cuts[nc++] = cut;
        }
        if (rc != 0)
            break;
        if (nc > 1) /* cuts is still NULL when no door overlaps the wall: qsort wants an array */
            qsort(cuts, (size_t)nc, sizeof *cuts, cmp_interval);
        /* Clip every piece first: if one is too big for a polygon, keep the wall whole. */
        int first_piece = p->n_solids, overflow = 0;
        double t = ax->tmin;
        for (int k = 0; k <= nc && rc == 0 && !overflow; k++) {
            double end = k < nc ? cuts[k].a : ax->tmax;
            sim_poly_t piece;
            int got = end - t > PLAN_MIN_PIECE_M ? sim_plan_clip_slab(o, ax->c0, ax->ux, ax->uy, t, end, &piece) : 0;
            if (got < 0)
                overflow = 1;
            else if (got > 0)
                rc = push_solid(p, &cap, &piece, sim_poly_is_rect(&piece), 0.0);
            if (k < nc)
                t = fmax(t, cuts[k].b);
        }
        if (rc == 0 && overflow) {
            p->n_solids = first_piece;
            rc = push_solid(p, &cap, o, sim_poly_is_rect(o), 0.0);
        }
    }
    /* Then the railings, whole: no door cuts them (a gate drawn in a railing stays closed, as a
     * door in a non-convex wall does). */
    for (int k = 0; k < p->n_railings && rc == 0; k++) {
        const sim_poly_t *o = &p->railings[k].outline;
        rc = push_solid(p, &cap, o, sim_poly_is_rect(o), SIM_PLAN_RAILING_HEIGHT);
    }
    free(cuts);
    return rc;
}

/* ---- openings against walls ------------------------------------------------------------- */

/* 1 when door dp crosses convex wall o: their overlap has positive area and reaches across
 * at least PLAN_CROSS_FRACTION of the wall's thickness. The thickness test is what keeps a
 * door in one wall from punching a hole in a perpendicular wall whose face it grazes. */
static int door_crosses(const sim_poly_t *o, const wall_axis_t *ax, const sim_poly_t *dp)
{
    sim_vec2_t a[XCLIP_MAX], b[XCLIP_MAX];
    int n = dp->n;
    memcpy(a, dp->p, (size_t)n * sizeof *a);
    /* Outward normal of each edge: the interior is on the left of an edge of a polygon with
     * positive signed area, on the right otherwise. */
    double side = sim_poly_signed_area(o) > 0 ? 1.0 : -1.0;
    for (int k = 0; k < o->n && n > 0; k++) {
        sim_vec2_t e0 = o->p[k], e1 = o->p[(k + 1) % o->n];
        double ex = e1.x - e0.x, ey = e1.y - e0.y, l = hypot(ex, ey);
        if (!(l > 0))
            continue;
        n = sim_plan_clip_half(a, n, e0, side * ey / l, -side * ex / l, 0.0, 1.0, b, XCLIP_MAX);
        if (n >= XCLIP_MAX)
            return 0; /* ran out of room: treated as not crossing, the wall stays closed */
        memcpy(a, b, (size_t)n * sizeof *a);
    }
    if (n < 3)
        return 0;
    double area = 0.0, smin = INFINITY, smax = -INFINITY;
    for (int i = 0; i < n; i++) {
        const sim_vec2_t *p = &a[i], *q = &a[(i + 1) % n];
        area += p->x * q->y - q->x * p->y;
        double s = (p->y - ax->c0.y) * ax->ux - (p->x - ax->c0.x) * ax->uy;
        smin = fmin(smin, s);
        smax = fmax(smax, s);
    }
    return fabs(0.5 * area) >= PLAN_MIN_AREA_M2 && smax - smin >= PLAN_CROSS_FRACTION * (ax->nmax - ax->nmin);
}

/* Walls bucketed on a uniform grid over the plan (compressed rows: the walls of cell c are
 * idx[start[c] .. start[c + 1] - 1]), so that an opening is tested against the walls near
 * it only: linear in the plan's size for real plans, however long some walls are. */
typedef struct {
    double x0, y0, cw, ch;
    int gx, gy;
    int *start, *idx;
} wall_grid_t;

/* Cells covered by box b grown by tol, clamped to the grid (openings may lie outside it). */
static void grid_range(const wall_grid_t *g, sim_plan_box_t b, double tol, int *c0, int *c1, int *r0, int *r1)
{
    double f[4] = {floor((b.x0 - tol - g->x0) / g->cw), floor((b.x1 + tol - g->x0) / g->cw),
                   floor((b.y0 - tol - g->y0) / g->ch), floor((b.y1 + tol - g->y0) / g->ch)};
    int lim[4] = {g->gx - 1, g->gx - 1, g->gy - 1, g->gy - 1}, out[4];
    for (int k = 0; k < 4; k++)
        out[k] = (int)fmax(0.0, fmin((double)lim[k], f[k])); /* clamp as doubles: no int overflow */
    *c0 = out[0];
    *c1 = out[1];
    *r0 = out[2];
    *r1 = out[3];
}

static int wall_grid_build(const sim_plan_t *p, const sim_plan_box_t *wb, double tol, wall_grid_t *g)
{
    int nw = p->n_walls;
    double wx = p->max.x - p->min.x, wy = p->max.y - p->min.y;
    /* About one cell per wall; a plan of long overlapping walls would register each in many
     * cells, so the grid is coarsened until the registrations fit a budget (1 x 1 always does). */
    double cs = sqrt(wx * wy / nw);
    int gx = (int)fmax(1.0, fmin(1024.0, ceil(wx / cs))), gy = (int)fmax(1.0, fmin(1024.0, ceil(wy / cs)));
    const long long budget = 16LL * nw + 65536;
    long long total;
    for (;;) {
        g->x0 = p->min.x;
        g->y0 = p->min.y;
        g->gx = gx;
        g->gy = gy;
        g->cw = wx / gx;
        g->ch = wy / gy;
        total = 0;
        for (int w = 0; w < nw; w++) {
            int c0, c1, r0, r1;
            grid_range(g, wb[w], tol, &c0, &c1, &r0, &r1);
            total += (long long)(c1 - c0 + 1) * (r1 - r0 + 1);
        }
        if (total <= budget || (gx == 1 && gy == 1))
            break;
        gx = (gx + 1) / 2;
        gy = (gy + 1) / 2;
    }
    size_t ncell = (size_t)gx * (size_t)gy;
    g->start = calloc(ncell + 1, sizeof *g->start);
    g->idx = malloc((size_t)total * sizeof *g->idx);
    if (g->start == NULL || g->idx == NULL)
        return -ENOMEM;
    for (int pass = 0; pass < 2; pass++) {
        for (int w = 0; w < nw; w++) {
            int c0, c1, r0, r1;
            grid_range(g, wb[w], tol, &c0, &c1, &r0, &r1);
            for (int r = r0; r <= r1; r++)
                for (int c = c0; c <= c1; c++) {
                    size_t cell = (size_t)r * (size_t)gx + (size_t)c;
                    if (pass == 0)
                        g->start[cell + 1]++;
                    else
                        g->idx[g->start[cell]++] = w;
                }
        }
        if (pass == 0) {
            for (size_t c = 0; c < ncell; c++)
                g->start[c + 1] += g->start[c];
        } else {
            /* The fill advanced each start to the next cell's: shift back. */
            for (size_t c = ncell; c > 0; c--)
                g->start[c] = g->start[c - 1];
            g->start[0] = 0;
        }
    }
    return 0;
}

/* For every opening: flags it isolated when it is near no wall, and links each door to the
 * convex walls it crosses other than the one it is nested in. */
static int link_openings(sim_plan_t *p, const unsigned char *convex, const wall_axis_t *axes, door_links_t *dl)
{
    int nw = p->n_walls;
    const double tol = PLAN_TOUCH_M;
    sim_plan_box_t *wb = malloc((size_t)nw * sizeof *wb);
    int *seen = malloc((size_t)nw * sizeof *seen); /* last opening that looked at each wall */
    wall_grid_t g = {0};
    int rc = wb != NULL && seen != NULL ? 0 : -ENOMEM;
    if (rc == 0) {
        for (int w = 0; w < nw; w++) {
            wb[w] = sim_plan_poly_box(&p->walls[w].outline);
            seen[w] = -1;
        }
        rc = wall_grid_build(p, wb, tol, &g);
    }
    for (int d = 0; d < p->n_openings && rc == 0; d++) {
        sim_opening_t *op = &p->openings[d];
        sim_plan_box_t ob = sim_plan_poly_box(&op->outline);
        int c0, c1, r0, r1, near = 0;
        grid_range(&g, ob, tol, &c0, &c1, &r0, &r1);
        for (int r = r0; r <= r1 && rc == 0; r++)
            for (int c = c0; c <= c1 && rc == 0; c++) {
                size_t cell = (size_t)r * (size_t)g.gx + (size_t)c;
                for (int k = g.start[cell]; k < g.start[cell + 1] && rc == 0; k++) {
                    int w = g.idx[k];
                    if (seen[w] == d)
                        continue;
                    seen[w] = d;
                    if (wb[w].x1 < ob.x0 - tol || wb[w].x0 > ob.x1 + tol || wb[w].y0 > ob.y1 + tol ||
                        wb[w].y1 < ob.y0 - tol)
                        continue;
                    const sim_poly_t *wo = &p->walls[w].outline;
                    if (!near)
                        near = sim_plan_polys_near(&op->outline, wo, tol);
                    if (op->kind != SIM_OPENING_DOOR || w == op->wall || !convex[w] ||
                        !door_crosses(wo, &axes[w], &op->outline))
                        continue;
                    int need = dl->n_pairs + 1;
                    if ((rc = sim_plan_grow((void **)&dl->xdoor, &dl->cap_xdoor, need, sizeof *dl->xdoor)) != 0 ||
                        (rc = sim_plan_grow((void **)&dl->xnext, &dl->cap_xnext, need, sizeof *dl->xnext)) != 0)
                        break;
                    dl->xdoor[dl->n_pairs] = d;
                    dl->xnext[dl->n_pairs] = dl->xfirst[w];
                    dl->xfirst[w] = dl->n_pairs++;
                }
            }
        op->isolated = !near;
    }
    free(wb);
    free(seen);
    free(g.start);
    free(g.idx);
    return rc;
}

int sim_plan_build_solids(sim_plan_t *p)
{
    /* The doors cutting each wall (nested, then crossing), then the solids. */
    size_t nw = (size_t)p->n_walls, no = (size_t)(p->n_openings > 0 ? p->n_openings : 1);
    door_links_t dl = {0};
    dl.first = malloc(nw * sizeof *dl.first);
    dl.next = malloc(no * sizeof *dl.next);
    dl.xfirst = malloc(nw * sizeof *dl.xfirst);
    unsigned char *convex = malloc(nw);
    wall_axis_t *axes = malloc(nw * sizeof *axes);
    int rc = 0;
    if (dl.first == NULL || dl.next == NULL || dl.xfirst == NULL || convex == NULL || axes == NULL)
        rc = -ENOMEM;
    if (rc == 0) {
        for (int w = 0; w < p->n_walls; w++) {
            dl.first[w] = dl.xfirst[w] = -1;
            convex[w] = (unsigned char)sim_plan_poly_is_convex(&p->walls[w].outline);
            if (convex[w])
                wall_axis(&p->walls[w].outline, &axes[w]);
        }
        for (int d = p->n_openings - 1; d >= 0; d--) {
            dl.next[d] = -1;
            if (p->openings[d].kind != SIM_OPENING_DOOR || p->openings[d].wall < 0)
                continue;
            dl.next[d] = dl.first[p->openings[d].wall];
            dl.first[p->openings[d].wall] = d;
        }
        rc = link_openings(p, convex, axes, &dl);
    }
    if (rc == 0)
        rc = build_solids(p, &dl, convex, axes);
    free(dl.first);
    free(dl.next);
    free(dl.xfirst);
    free(dl.xdoor);
    free(dl.xnext);
    free(convex);
    free(axes);
    return rc;
}
