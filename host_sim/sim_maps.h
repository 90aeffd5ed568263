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
 * shows about 10 pixels per metre or more. Returns 0 or a negative code, err.
 * = sim_maps_compute + sim_maps_write_png + sim_maps_grid_free. */
FS_MUST_CHECK
int sim_maps_write(bnn_model_t *m, const sim_plan_t *plan, double res, uint32_t K, uint64_t seed,
                   const sim_path_t *paths, int n_paths, const char *mean_png, const char *std_png,
                   double *std_max_out, char *err, size_t errlen);

/* The cells of a map: w x h cells of res metres from the plan's lower corner (x0, y0) =
 * plan->min, row-major with row 0 the row of the SMALLEST y (the plan's axes: y down the
 * drawing, so row 0 is the drawing's top edge, as in the PNGs). Cell (r, c) has its centre
 * at (x0 + (c + 0.5) res, y0 + (r + 0.5) res); the grid covers the bounding box, so its far
 * edges x0 + w res, y0 + h res lie at or beyond plan->max. */
typedef struct sim_maps_grid {
    int w, h;
    double res, x0, y0;
    float *mean; /* w * h MC means of the occupancy probability, in [0, 1] */
    float *std;  /* w * h MC (population) standard deviations */
} sim_maps_grid_t;

/* MC mean and std of K passes (bnn_predict_mc, seed) of model m at every cell centre of the
 * plan's bounding box at res metres (the cells sim_maps_write draws; K = 1 is one stochastic
 * pass, std 0). At most 4,000,000 cells. *g is allocated here (sim_maps_grid_free); on error
 * it is left empty. Returns 0 or a negative code, with the reason in err. */
FS_MUST_CHECK
int sim_maps_compute(bnn_model_t *m, const sim_plan_t *plan, double res, uint32_t K, uint64_t seed,
                     sim_maps_grid_t *g, char *err, size_t errlen);

/* The two PNGs of sim_maps_write from computed cells (g from sim_maps_compute on `plan`). */
FS_MUST_CHECK
int sim_maps_write_png(const sim_maps_grid_t *g, const sim_plan_t *plan, const sim_path_t *paths, int n_paths,
                       const char *mean_png, const char *std_png, double *std_max_out, char *err,
                       size_t errlen);

/* Largest std of the grid (0 for an empty grid). */
double sim_maps_std_max(const sim_maps_grid_t *g);

/* Frees the cells; *g is empty afterwards. Safe on an empty grid and twice. */
void sim_maps_grid_free(sim_maps_grid_t *g);

#endif /* SIM_MAPS_H */
