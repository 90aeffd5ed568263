/* The picture convention of every host_sim figure: pictures are in metres with x to the
 * right and y UP (image row 0 shows the LARGEST y), as the map PNGs, ROS's map.pgm and the
 * Python plots (matplotlib axes) are. Plan coordinates are the SVG's (y grows down the
 * drawing), so a picture shows the building mirrored top to bottom against the SVG drawing,
 * and the same way in every figure: the grid PNG/PGM (sim_grid_write_image), the paths PNG
 * (sim_figure_paths_png), the map PNGs (sim_maps_write_png) and the 3D scene (sim_render,
 * whose camera looks with +y up the image). Robots are drawn in sim_palette.h's colours.
 * tests/sim/test_figure.c and tests/app/test_maps.c check the orientation. */
#ifndef SIM_FIGURE_H
#define SIM_FIGURE_H

#include <math.h>
#include <stddef.h>

#include "sim_grid.h"
#include "sim_paths.h"

/* The image row (row 0 the top) that shows world y in a picture of `rows` rows of `pix`
 * metres each whose bottom edge is at y0 (may be out of 0..rows-1 for a y outside). */
static inline int sim_figure_row(double y, double y0, double pix, int rows)
{
    return rows - 1 - (int)floor((y - y0) / pix);
}

/* Writes the ground truth g (free white, wall black, outside grey) with the tours on top,
 * each in its robot's colour (waypoints as crosses, the start as a filled square), as an RGB
 * PNG of k x k pixels per cell, k chosen so the map's long side is about 1000 px; y up. Around
 * the map, on white: a frame, axis ticks every 1, 2 or 5 m labelled in metres on the left and
 * below ("m" at the ends of the axes), and under them a legend, one coloured square and
 * "robot i" per tour. The map's place in the picture: sim_figure_paths_frame. Returns 0 or a
 * negative code with the reason in err. */
FS_MUST_CHECK
int sim_figure_paths_png(const sim_grid_t *g, const sim_path_t *paths, int n, const char *file, char *err,
                         size_t errlen);

/* The layout of sim_figure_paths_png's picture of g with n tours: the whole picture is *w x *h
 * pixels, the map (g->w x g->h cells of *k x *k pixels) starts at column *x0, row *y0. */
void sim_figure_paths_frame(const sim_grid_t *g, int n, int *w, int *h, int *x0, int *y0, int *k);

#endif /* SIM_FIGURE_H */
