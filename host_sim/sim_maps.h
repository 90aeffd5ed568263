/* Occupancy and uncertainty maps of a model over a plan, as PNG pictures. */
#ifndef SIM_MAPS_H
#define SIM_MAPS_H

#include <stddef.h>
#include <stdint.h>

#include "ai/bnn.h"
#include "sim_paths.h"
#include "sim_plan.h"

/* MC mean and std (K passes) of model m on the plan's bounding box at res metres, written as
 * two PNGs (mean: white free .. black wall; std: dark blue .. yellow, scaled to the map's
 * max std, which goes to *std_max_out when not NULL), the paths drawn on top in colour. Each
 * cell is drawn as zoom x zoom pixels, zoom = ceil(0.1 m / res) within 1..8, so every map
 * shows about 10 pixels per metre or more. Returns 0 or a negative code, err. */
FS_MUST_CHECK
int sim_maps_write(bnn_model_t *m, const sim_plan_t *plan, double res, uint32_t K, uint64_t seed,
                   const sim_path_t *paths, int n_paths, const char *mean_png, const char *std_png,
                   double *std_max_out, char *err, size_t errlen);

#endif /* SIM_MAPS_H */
