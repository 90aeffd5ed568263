/* Ground-truth occupancy grid: a floor plan rasterised at a fixed resolution.
 *
 * Cell rule (cell centres, not coverage): a cell is
 *   SIM_CELL_WALL    when its centre lies inside a solid (wall minus door openings, or a
 *                    railing), a point on a solid's edge decided by sim_poly_contains's
 *                    half-open rule,
 *   SIM_CELL_FREE    otherwise, when its centre lies inside or on the edge (within 1 um) of
 *                    a room polygon or a door opening, so a centre on an edge two rooms
 *                    share is free whatever the rounding,
 *   SIM_CELL_OUTSIDE otherwise (outside the building or in an unlabelled gap).
 * Centre sampling means a solid thinner than one cell may fall between centres; use a
 * resolution at most half the thinnest wall (0.05 m for 10 cm walls) for a closed raster.
 *
 * Layout: row-major, cells[row * w + col]; column c spans x in [origin.x + c*res,
 * origin.x + (c+1)*res), row r spans y likewise (rows grow with y, which points DOWN the SVG
 * drawing). Pictures are y up (sim_figure.h), so sim_grid_write_image writes row h-1 first
 * and row 0 at the bottom: never write cells as an image row by row. The grid covers the plan's
 * bounding box (walls and railings): origin = plan->min, w = ceil(width / res),
 * h = ceil(height / res).
 * Not thread-safe per grid. Allocates (host side). */
#ifndef SIM_GRID_H
#define SIM_GRID_H

#include <stddef.h>
#include <stdint.h>

#include "sim_plan.h"

enum { SIM_CELL_FREE = 0, SIM_CELL_WALL = 1, SIM_CELL_OUTSIDE = 2 };

/* Largest grid accepted (cells per side), so a bad --res cannot ask for gigabytes. */
#define SIM_GRID_MAX_SIDE 20000

typedef struct sim_grid {
    double res;        /* metres per cell, > 0 */
    sim_vec2_t origin; /* world position of the outer corner of cell (0, 0), metres */
    int w, h;          /* columns (x), rows (y) */
    uint8_t *cells;    /* w * h values SIM_CELL_* */
} sim_grid_t;

/* The class (SIM_CELL_*) of one world point under the rule above. */
int sim_plan_classify_point(const sim_plan_t *plan, double x_m, double y_m);

/* Rasterises `plan` at `res_m` metres per cell. -EINVAL on bad arguments, -E2BIG when a side
 * would exceed SIM_GRID_MAX_SIDE, -ENOMEM. On failure *grid is left empty. */
FS_MUST_CHECK
int sim_grid_from_plan(const sim_plan_t *plan, double res_m, sim_grid_t *grid);

/* An all-OUTSIDE grid of w x h cells (for tests and tools). */
FS_MUST_CHECK
int sim_grid_init(sim_grid_t *grid, double res_m, double origin_x, double origin_y, int w, int h);

void sim_grid_free(sim_grid_t *grid);

/* World point -> cell. Returns 0 and the cell when inside the grid, -ERANGE otherwise
 * (col/row are still written, possibly out of range, so callers that clamp or check with
 * sim_grid_at may ignore the result). */
int sim_grid_world_to_cell(const sim_grid_t *grid, double x_m, double y_m, int *col, int *row);

/* Centre of a cell in world metres (any col/row, no range check). */
void sim_grid_cell_centre(const sim_grid_t *grid, int col, int row, double *x_m, double *y_m);

/* Cell value, or SIM_CELL_OUTSIDE for a cell outside the grid. */
static inline int sim_grid_at(const sim_grid_t *grid, int col, int row)
{
    if (col < 0 || row < 0 || col >= grid->w || row >= grid->h)
        return SIM_CELL_OUTSIDE;
    return grid->cells[(size_t)row * (size_t)grid->w + (size_t)col];
}

/* Writes the grid as an 8-bit grey image, chosen by the file name's extension: ".png"
 * (libpng) or ".pgm" (binary P5). Free 255, wall 0, outside 160. y up (sim_figure.h): the
 * image's first row is the grid's last row (largest y), as in ROS's map.pgm. */
FS_MUST_CHECK
int sim_grid_write_image(const sim_grid_t *grid, const char *path, char *err, size_t errlen);

/* Writes an 8-bit RGB PNG (rgb: w * h * 3 bytes, row-major). */
FS_MUST_CHECK
int sim_png_write_rgb(const char *path, int w, int h, const uint8_t *rgb, char *err, size_t errlen);

#endif /* SIM_GRID_H */
