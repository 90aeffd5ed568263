/* Polygon helpers. Ear clipping is O(n^3) worst case, fine for n <= SIM_POLY_MAX_POINTS. */
#include "sim_shape.h"

#include <errno.h>
#include <math.h>

double sim_shape_area(const sim_poly_t *p)
{
    double a = 0.0;
    for (int i = 0; i < p->n; i++) {
        const sim_vec2_t *u = &p->p[i], *v = &p->p[(i + 1) % p->n];
        a += u->x * v->y - v->x * u->y;
    }
    return 0.5 * a;
}

static double cross3(sim_vec2_t a, sim_vec2_t b, sim_vec2_t c)
{
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

static int in_triangle(sim_vec2_t p, sim_vec2_t a, sim_vec2_t b, sim_vec2_t c)
{
    /* Strictly-or-on-edge inside of a CCW triangle. */
    return cross3(a, b, p) >= 0.0 && cross3(b, c, p) >= 0.0 && cross3(c, a, p) >= 0.0;
}

int sim_shape_triangulate(const sim_poly_t *p, int tris[][3], int max_tris)
{
    if (p == NULL || tris == NULL || p->n < 3 || p->n > SIM_POLY_MAX_POINTS || max_tris < p->n - 2)
        return -EINVAL;
    int idx[SIM_POLY_MAX_POINTS];
    int n = p->n;
    int ccw = sim_shape_area(p) > 0.0;
    for (int i = 0; i < n; i++)
        idx[i] = ccw ? i : n - 1 - i; /* walk counter-clockwise */
    int nt = 0, guard = 0;
    while (n > 3) {
        int clipped = 0;
        for (int i = 0; i < n && n > 3; i++) {
            int ia = idx[(i + n - 1) % n], ib = idx[i], ic = idx[(i + 1) % n];
            sim_vec2_t a = p->p[ia], b = p->p[ib], c = p->p[ic];
            double cr = cross3(a, b, c);
            if (cr <= 1e-15) {
                /* Reflex or collinear vertex. A collinear one with zero area is clipped
                 * anyway when nothing else works (guard below). */
                if (!(guard > 0 && fabs(cr) <= 1e-15))
                    continue;
            }
            int ear = 1;
            for (int j = 0; j < n && ear; j++) {
                int ij = idx[j];
                if (ij == ia || ij == ib || ij == ic)
                    continue;
                if (cr > 1e-15 && in_triangle(p->p[ij], a, b, c))
                    ear = 0;
            }
            if (!ear)
                continue;
            if (cr > 1e-15) {
                tris[nt][0] = ia;
                tris[nt][1] = ib;
                tris[nt][2] = ic;
                nt++;
            }
            for (int j = i; j < n - 1; j++)
                idx[j] = idx[j + 1];
            n--;
            clipped = 1;
            guard = 0;
        }
        if (!clipped && ++guard > 1)
            return -EINVAL;
    }
    if (cross3(p->p[idx[0]], p->p[idx[1]], p->p[idx[2]]) > 1e-15) {
        tris[nt][0] = idx[0];
        tris[nt][1] = idx[1];
        tris[nt][2] = idx[2];
        nt++;
    }
    return nt;
}

int sim_shape_contains(const sim_poly_t *p, double x, double y)
{
    int in = 0;
    for (int i = 0, j = p->n - 1; i < p->n; j = i++) {
        const sim_vec2_t *a = &p->p[i], *b = &p->p[j];
        if ((a->y > y) != (b->y > y) && x < (b->x - a->x) * (y - a->y) / (b->y - a->y) + a->x)
            in = !in;
    }
    return in;
}

double sim_shape_edge_distance(const sim_poly_t *p, double x, double y)
{
    double best = INFINITY;
    for (int i = 0; i < p->n; i++) {
        const sim_vec2_t *a = &p->p[i], *b = &p->p[(i + 1) % p->n];
        double dx = b->x - a->x, dy = b->y - a->y;
        double l2 = dx * dx + dy * dy;
        double t = l2 > 0.0 ? ((x - a->x) * dx + (y - a->y) * dy) / l2 : 0.0;
        t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
        double ex = a->x + t * dx - x, ey = a->y + t * dy - y;
        double d = sqrt(ex * ex + ey * ey);
        if (d < best)
            best = d;
    }
    return best;
}
