/* Helpers shared by the files of the paths module (sim_paths.c: paths and their figures,
 * sim_tours.c: the tour generator, sim_paths_csv.c: waypoint files). Not part of its API. */
#ifndef SIM_PATHS_UTIL_H
#define SIM_PATHS_UTIL_H

#include <stddef.h>

#include "sim_paths.h"

/* Writes the message into err (when not NULL) and returns -EINVAL. */
__attribute__((format(printf, 3, 4))) int sim_paths_errf(char *err, size_t errlen, const char *fmt, ...);

/* Appends (x, y) to p unless it repeats the last point; *cap is p's allocated length.
 * 0, -E2BIG beyond SIM_PATH_MAX_POINTS, -ENOMEM. */
int sim_paths_push(sim_path_t *p, int *cap, double x, double y);

/* Distance from a point to a polygon (0 inside). */
double sim_paths_point_poly_dist(const sim_poly_t *poly, double x, double y);

#endif /* SIM_PATHS_UTIL_H */
