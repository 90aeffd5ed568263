/* Arc-length geometry of a waypoint tour, in double precision: where a robot is after s metres
 * along its path. The fleet uses it for the positions of the disk graph when training offline
 * (round k of R: the point at fraction k / R of the tour), and the in-process reference uses
 * the same function on the same float waypoints, so both build the same graph bit for bit.
 * Pure functions: no state, no allocation, thread-safe. */
#ifndef RT_RT_PATH_H
#define RT_RT_PATH_H

#include <stdint.h>

#include "rt/rt_follow.h"

/* Total length of the polyline w[0..n-1] (0 for n < 2). */
double rt_path_length(const rt_waypoint_t *w, int32_t n);

/* The point at arc length s (clamped to both ends; zero-length segments are skipped).
 * 0, or -EINVAL for NULL pointers, n < 1 or a non-finite s. */
FS_MUST_CHECK int rt_path_point(const rt_waypoint_t *w, int32_t n, double s, double *x, double *y);

/* The point at fraction k / of_n of the tour's length (k >= of_n: the end). 0 or -EINVAL. */
FS_MUST_CHECK int rt_path_point_frac(const rt_waypoint_t *w, int32_t n, uint32_t k, uint32_t of_n,
                                     double *x, double *y);

#endif /* RT_RT_PATH_H */
