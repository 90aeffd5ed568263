/* Occupancy of a model against the ground truth: the known cells of a coarse grid built
 * once from the plan, and the model's mean-weight map on them (MSE and wall IoU). Used by
 * the fleet's metrics and by the image runner. Allocates at build; run allocates nothing. */
#ifndef SIM_OCC_EVAL_H
#define SIM_OCC_EVAL_H

#include <stddef.h>
#include <stdint.h>

#include "ai/bnn.h"
#include "sim_plan.h"

/* Known cells of a coarse grid: a coarse cell is WALL when any of its fine sub-cells (of the
 * plan rasterised at res / sub) is WALL, else FREE when any is FREE, else unknown (skipped).
 * This keeps 10 cm walls visible on a 0.1 m grid. */
typedef struct sim_occ_eval {
    double res;
    int w, h;           /* coarse grid */
    size_t n;           /* known cells */
    float *xy;          /* n normalised centres (interleaved) */
    uint8_t *truth;     /* n labels 0 free / 1 wall */
    int *cell;          /* n cell indices (row * w + col) */
    float *pred;        /* scratch, n */
} sim_occ_eval_t;

FS_MUST_CHECK
int sim_occ_eval_build(const sim_plan_t *plan, double res, sim_occ_eval_t *ev);
void sim_occ_eval_free(sim_occ_eval_t *ev);
/* Mean-weight map (one pass, eps = 0) of m on the known cells: MSE against the labels and
 * IoU of the wall class with the map thresholded at 0.5. */
FS_MUST_CHECK
int sim_occ_eval_run(const sim_occ_eval_t *ev, bnn_model_t *m, double *mse, double *iou);

#endif /* SIM_OCC_EVAL_H */
