/* Polygon geometry of the floor-plan parser: the helpers sim_plan.h exports (area, point in
 * polygon, rectangle test) and the ones door cutting needs (convexity, half-plane and slab
 * clipping, bounding boxes, proximity of two polygons). */
#include "sim_plan_int.h"

#include <math.h>
#include <string.h>

/* ---- exported (sim_plan.h) ---------------------------------------------------------------- */

double sim_poly_signed_area(const sim_poly_t *poly)
{
    double a = 0.0;
    for (int i = 0; i < poly->n; i++) {
        const sim_vec2_t *p = &poly->p[i], *q = &poly->p[(i + 1) % poly->n];
        a += p->x * q->y - q->x * p->y;
    }
    return 0.5 * a;
}

int sim_poly_contains(const sim_poly_t *poly, double x, double y)
{
    /* Even-odd ray crossing towards +x, half-open: an edge counts when y is in [its lower y,
     * its upper y) and x is left of it. The crossing is computed from the edge's endpoints in
     * one order (lower y first), not in the polygon's walking order: two polygons sharing an
     * edge walk it in opposite directions, and rounding the two ways could leave a point on it
     * in neither (a gap in the raster between two rooms) or in both. */
    int in = 0;
    for (int i = 0, j = poly->n - 1; i < poly->n; j = i++) {
        const sim_vec2_t *a = &poly->p[i], *b = &poly->p[j];
        if ((a->y > y) != (b->y > y)) {
            if (a->y > b->y) {
                const sim_vec2_t *t = a;
                a = b;
                b = t;
            }
            double xc = a->x + (y - a->y) * (b->x - a->x) / (b->y - a->y);
            if (x < xc)
                in = !in;
        }
    }
    return in;
}

static double seg_point_dist(sim_vec2_t a, sim_vec2_t b, sim_vec2_t p);

int sim_poly_covers(const sim_poly_t *poly, double x, double y, double tol)
{
    if (sim_poly_contains(poly, x, y))
        return 1;
    const sim_vec2_t q = {x, y};
    for (int i = 0, j = poly->n - 1; i < poly->n; j = i++)
        if (seg_point_dist(poly->p[j], poly->p[i], q) <= tol)
            return 1;
    return 0;
}

int sim_poly_is_rect(const sim_poly_t *poly)
{
    if (poly->n != 4)
        return 0;
    for (int i = 0; i < 4; i++) {
        const sim_vec2_t *a = &poly->p[(i + 3) % 4], *b = &poly->p[i], *c = &poly->p[(i + 1) % 4];
        double ux = a->x - b->x, uy = a->y - b->y, vx = c->x - b->x, vy = c->y - b->y;
        double lu = hypot(ux, uy), lv = hypot(vx, vy);
        if (lu <= 0.0 || lv <= 0.0)
            return 0;
        if (fabs(ux * vx + uy * vy) > 1e-6 * lu * lv)
            return 0;
    }
    return 1;
}

/* ---- clipping ------------------------------------------------------------------------------ */

int sim_plan_poly_is_convex(const sim_poly_t *o)
{
    int sign = 0;
    for (int i = 0; i < o->n; i++) {
        const sim_vec2_t *a = &o->p[i], *b = &o->p[(i + 1) % o->n], *c = &o->p[(i + 2) % o->n];
        double cr = (b->x - a->x) * (c->y - b->y) - (b->y - a->y) * (c->x - b->x);
        int sg = (cr > 1e-12) - (cr < -1e-12);
        if (sg != 0) {
            if (sign != 0 && sg != sign)
                return 0;
            sign = sg;
        }
    }
    return 1;
}

#define CLIP_MAX (SIM_POLY_MAX_POINTS + 4)

int sim_plan_clip_half(const sim_vec2_t *in, int n, sim_vec2_t c0, double ux, double uy, double lim, double sgn,
                       sim_vec2_t *out, int cap)
{
    int m = 0;
    for (int i = 0; i < n; i++) {
        sim_vec2_t a = in[i], b = in[(i + 1) % n];
        double da = sgn * ((a.x - c0.x) * ux + (a.y - c0.y) * uy - lim);
        double db = sgn * ((b.x - c0.x) * ux + (b.y - c0.y) * uy - lim);
        if (da <= 0 && m < cap)
            out[m++] = a;
        if (((da < 0 && db > 0) || (da > 0 && db < 0)) && m < cap) {
            double t = da / (da - db);
            out[m].x = a.x + t * (b.x - a.x);
            out[m].y = a.y + t * (b.y - a.y);
            m++;
        }
    }
    return m;
}

int sim_plan_clip_slab(const sim_poly_t *in, sim_vec2_t c0, double ux, double uy, double lo, double hi,
                       sim_poly_t *out)
{
    sim_vec2_t t1[CLIP_MAX], t2[CLIP_MAX];
    int n = sim_plan_clip_half(in->p, in->n, c0, ux, uy, lo, -1.0, t1, CLIP_MAX);
    n = sim_plan_clip_half(t1, n, c0, ux, uy, hi, 1.0, t2, CLIP_MAX);
    int m = 0;
    for (int i = 0; i < n; i++) {
        if (m > 0 && fabs(t2[i].x - out->p[m - 1].x) < 1e-12 && fabs(t2[i].y - out->p[m - 1].y) < 1e-12)
            continue;
        if (m >= SIM_POLY_MAX_POINTS)
            return -1;
        out->p[m++] = t2[i];
    }
    while (m > 1 && fabs(out->p[0].x - out->p[m - 1].x) < 1e-12 && fabs(out->p[0].y - out->p[m - 1].y) < 1e-12)
        m--;
    out->n = m;
    return m >= 3 && fabs(sim_poly_signed_area(out)) >= PLAN_MIN_AREA_M2;
}

/* ---- boxes and proximity ------------------------------------------------------------------- */

sim_plan_box_t sim_plan_poly_box(const sim_poly_t *o)
{
    sim_plan_box_t b = {INFINITY, INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < o->n; k++) {
        b.x0 = fmin(b.x0, o->p[k].x);
        b.y0 = fmin(b.y0, o->p[k].y);
        b.x1 = fmax(b.x1, o->p[k].x);
        b.y1 = fmax(b.y1, o->p[k].y);
    }
    return b;
}

static double seg_point_dist(sim_vec2_t a, sim_vec2_t b, sim_vec2_t p)
{
    double ex = b.x - a.x, ey = b.y - a.y, l2 = ex * ex + ey * ey;
    double t = l2 > 0 ? ((p.x - a.x) * ex + (p.y - a.y) * ey) / l2 : 0.0;
    t = fmax(0.0, fmin(1.0, t));
    return hypot(a.x + t * ex - p.x, a.y + t * ey - p.y);
}

static double orient(sim_vec2_t a, sim_vec2_t b, sim_vec2_t c)
{
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

/* Two edges cross or pass within tol, or (no edge near any other) one polygon lies inside the
 * other. */
int sim_plan_polys_near(const sim_poly_t *a, const sim_poly_t *b, double tol)
{
    for (int i = 0; i < a->n; i++) {
        sim_vec2_t a0 = a->p[i], a1 = a->p[(i + 1) % a->n];
        for (int j = 0; j < b->n; j++) {
            sim_vec2_t b0 = b->p[j], b1 = b->p[(j + 1) % b->n];
            double o1 = orient(a0, a1, b0), o2 = orient(a0, a1, b1);
            double o3 = orient(b0, b1, a0), o4 = orient(b0, b1, a1);
            if (((o1 < 0 && o2 > 0) || (o1 > 0 && o2 < 0)) && ((o3 < 0 && o4 > 0) || (o3 > 0 && o4 < 0)))
                return 1;
            if (seg_point_dist(a0, a1, b0) <= tol || seg_point_dist(a0, a1, b1) <= tol ||
                seg_point_dist(b0, b1, a0) <= tol || seg_point_dist(b0, b1, a1) <= tol)
                return 1;
        }
    }
    return sim_poly_contains(a, b->p[0].x, b->p[0].y) || sim_poly_contains(b, a->p[0].x, a->p[0].y);
}
