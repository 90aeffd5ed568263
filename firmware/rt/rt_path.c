/* Arc-length geometry of a tour: see rt_path.h. */
#include "rt/rt_path.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>

double rt_path_length(const rt_waypoint_t *w, int32_t n)
{
    double len = 0.0;
    for (int32_t i = 0; w != NULL && i + 1 < n; i++)
        len += hypot((double)w[i + 1].x - (double)w[i].x, (double)w[i + 1].y - (double)w[i].y);
    return len;
}

int rt_path_point(const rt_waypoint_t *w, int32_t n, double s, double *x, double *y)
{
    if (w == NULL || n < 1 || x == NULL || y == NULL || !isfinite(s))
        return -EINVAL;
    *x = w[0].x;
    *y = w[0].y;
    for (int32_t i = 0; i + 1 < n; i++) {
        const double dx = (double)w[i + 1].x - (double)w[i].x, dy = (double)w[i + 1].y - (double)w[i].y;
        const double l = hypot(dx, dy);
        if (l <= 0.0)
            continue;
        if (s <= l || i + 2 == n) {
            const double t = fmin(fmax(s / l, 0.0), 1.0);
            *x = (double)w[i].x + t * dx;
            *y = (double)w[i].y + t * dy;
            return 0;
        }
        s -= l;
    }
    *x = w[n - 1].x; /* past a zero-length last segment: the end */
    *y = w[n - 1].y;
    return 0;
}

int rt_path_point_frac(const rt_waypoint_t *w, int32_t n, uint32_t k, uint32_t of_n, double *x, double *y)
{
    if (of_n == 0)
        return -EINVAL;
    const double frac = (double)k / (double)of_n;
    return rt_path_point(w, n, fmin(frac, 1.0) * rt_path_length(w, n), x, y);
}
