/* Occupancy and uncertainty maps of a model over a plan, as PNG pictures. */
#ifndef SIM_MAPS_H
#define SIM_MAPS_H

#include <stddef.h>
#include <stdint.h>

#include "ai/bnn.h"
#include "ai/bnn_post.h"
#include "sim_paths.h"
#include "sim_plan.h"

/* MC mean and std (K passes) of model m on the plan's bounding box at res metres, written as
 * two PNGs (mean: white free .. black wall; std: dark blue .. yellow, scaled to the map's
 * max std, which goes to *std_max_out when not NULL), the paths drawn on top, each in its
 * robot's colour (sim_palette.h). The PNGs are y up (sim_figure.h): their first row shows
 * the grid's last row (largest y), as map.pgm and the .npy arrays of host_sim maps. Each
 * cell is drawn as zoom x zoom pixels, zoom = ceil(0.1 m / res) within 1..8, so every map
 * shows about 10 pixels per metre or more. Returns 0 or a negative code, err.
 * = sim_maps_compute + sim_maps_write_png + sim_maps_grid_free. */
FS_MUST_CHECK
int sim_maps_write(bnn_model_t *m, const sim_plan_t *plan, double res, uint32_t K, uint64_t seed,
                   const sim_path_t *paths, int n_paths, const char *mean_png, const char *std_png,
                   double *std_max_out, char *err, size_t errlen);

/* The cells of a map: w x h cells of res metres from the plan's lower corner (x0, y0) =
 * plan->min, row-major with row 0 the row of the SMALLEST y (the plan's axes: y down the
 * drawing, so row 0 is the drawing's top edge; the PNGs, y up, show it at their bottom).
 * Cell (r, c) has its centre at (x0 + (c + 0.5) res, y0 + (r + 0.5) res); the grid covers the bounding box, so its far
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

/* The epistemic map (ai/bnn_post.h) at the cells of g (a grid of sim_maps_compute on `plan`):
 * per cell the share of the read-out's prior variance the posterior leaves, in (0, 1], larger
 * = less known; unknown holds g->w * g->h floats, same order as g->mean. 0 or a negative code,
 * err. */
FS_MUST_CHECK
int sim_maps_epistemic(bnn_model_t *m, bnn_post_t *post, const sim_plan_t *plan, const sim_maps_grid_t *g,
                       float *unknown, char *err, size_t errlen);

/* Its picture, y up like the others, on a log scale: SIM_MAPS_EPI_FLOOR (and below: known)
 * dark blue .. 1 (nothing known) yellow, the paths on top. */
#define SIM_MAPS_EPI_FLOOR 1e-6
/* The share below which host_sim maps counts a cell as known, in its report. */
#define SIM_MAPS_EPI_KNOWN 1e-3
FS_MUST_CHECK
int sim_maps_write_epistemic_png(const sim_maps_grid_t *g, const float *unknown, const sim_plan_t *plan,
                                 const sim_path_t *paths, int n_paths, const char *png, char *err, size_t errlen);

/* Largest std of the grid (0 for an empty grid). */
double sim_maps_std_max(const sim_maps_grid_t *g);

/* ---- the ROS map (map.pgm + map.yaml of host_sim maps) ----------------------------------
 * nav2's map_server (map_io.cpp, mode trinary, negate 0) reads a pixel v as occupancy
 * (255 - v) / 255 and calls the cell occupied when occupancy > occupied_thresh, free when
 * occupancy < free_thresh, unknown otherwise. The map's pixel of a probability p is
 * round(255 (1 - p)), so a cell's occupancy is one of the 256 LEVELS L / 255, L = 255 - v. */

/* The pixel of an occupancy probability: round(255 (1 - p)), p clamped to [0, 1] (NaN: 255,
 * free, as the PNGs draw it). */
uint8_t sim_maps_pgm_pixel(float p);

/* The two thresholds of the trinary map, each half-way between two levels so that no
 * rounding can move a cell across: occupied = (occ_level + 0.5) / 255 (occupied: level >
 * occ_level), free = (free_level + 0.5) / 255 (free: level <= free_level), with
 * 0 <= free_level < occ_level <= 254, so free < occupied as nav2's map_saver demands. */
typedef struct sim_maps_thresh {
    int occ_level, free_level;
    double occupied, free_thresh;
    /* On the labelled points they were chosen on: */
    size_t n, n_hit; /* points, of which lidar hits (label >= 0.5) */
    double occ_f1;   /* F1 of the hits, predicted occupied = level > occ_level */
    double free_f1;  /* F1 of the free points, predicted free = level <= free_level */
} sim_maps_thresh_t;

/* The thresholds for map values p[i] (the same quantity as the map's cells, e.g. the MC mean
 * of the same passes) at n labelled points pts[i] (pts[i].occ: 1 a lidar hit, 0 free):
 * occ_level maximises the F1 score of the hits (the smallest such level), free_level the F1
 * score of the free points among the levels below occ_level (the smallest such level).
 * Returns 0, or -EINVAL when n == 0, a pointer is NULL, or the points are all hits or all
 * free (no F1 to maximise); *t is then zeroed. */
FS_MUST_CHECK
int sim_maps_choose_thresholds(const float *p, const ai_sample_t *pts, size_t n, sim_maps_thresh_t *t);

/* Frees the cells; *g is empty afterwards. Safe on an empty grid and twice. */
void sim_maps_grid_free(sim_maps_grid_t *g);

#endif /* SIM_MAPS_H */
