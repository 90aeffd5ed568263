/* Belief occupancy grid the RT core plans on (pure C11, storage fixed at compile time).
 *
 * The AI core fills it from its neural map (probability of occupied per cell, and whether the
 * map has seen the cell); the RT core plans paths on it (rt_plan.h). A coarse grid, not the
 * ground truth: the planner keeps its clearance on this grid only.
 *
 * Layout (the same as host_sim/maps/sim_grid.h): row-major, cell (col, row) at index
 * row * w + col; column c spans x in [origin_x + c*res, origin_x + (c+1)*res), row r spans
 * y in [origin_y + r*res, origin_y + (r+1)*res) (rows grow with y). Cell centres are at
 * origin + (c + 0.5, r + 0.5) * res.
 *
 * Per cell:
 *   occ[i]   0..255 = P(occupied) * 255, rounded (0 free, 255 certainly occupied);
 *   known[i] 0 = never observed (occ is then meaningless), 1..255 = observed (a confidence:
 *            the planner only tests known != 0).
 *
 * Size: at most RT_GRID_MAX_SIDE cells per side and RT_GRID_MAX_CELLS cells in all. The
 * default 65,536 cells (e.g. 256 x 256) hold a 12.8 m square at 0.05 m per cell (the default
 * apartment, 12 x 9 m, is 240 x 180 cells at 0.05 m) or a 25.6 m square at 0.1 m, for
 * 128 KiB of grid; a board may define a smaller RT_GRID_MAX_CELLS (and RT_GRID_MAX_SIDE) in its
 * board.h (common/fw_config.h). Sides up to 1024 keep every squared cell distance (< 2^21)
 * exact in a float (rt_plan.c relies on it).
 *
 * Units: metres. Not thread-safe per grid (the writer and the planner must not overlap). */
#ifndef RT_GRID_H
#define RT_GRID_H

#include <stdint.h>

/* RT_GRID_MAX_CELLS (default 65,536) and RT_GRID_MAX_SIDE (default 1024; rt_plan's per-line
 * scratch is sized by it, 16 KiB at 1024) come from common/fw_config.h: a board may lower
 * both in its board.h. */

_Static_assert(RT_GRID_MAX_SIDE >= 1 && RT_GRID_MAX_SIDE <= 1024, "RT_GRID_MAX_SIDE must be 1 .. 1024");
_Static_assert(RT_GRID_MAX_CELLS >= 1 && RT_GRID_MAX_CELLS <= RT_GRID_MAX_SIDE * RT_GRID_MAX_SIDE,
               "RT_GRID_MAX_CELLS must be in 1 .. RT_GRID_MAX_SIDE^2");
_Static_assert(2 * (RT_GRID_MAX_SIDE - 1) * (RT_GRID_MAX_SIDE - 1) < (1 << 24),
               "squared cell distances must stay exact in a float");

typedef struct rt_grid {
    float res;                        /* metres per cell, > 0 and finite */
    float origin_x, origin_y;         /* world position of the outer corner of cell (0, 0), m */
    int32_t w, h;                     /* columns (x), rows (y): 1 .. RT_GRID_MAX_SIDE each,
                                       * w * h <= RT_GRID_MAX_CELLS */
    uint8_t occ[RT_GRID_MAX_CELLS];   /* P(occupied) * 255, first w * h used */
    uint8_t known[RT_GRID_MAX_CELLS]; /* 0 unknown, else observed */
} rt_grid_t;

_Static_assert(sizeof(((rt_grid_t *)0)->occ) == RT_GRID_MAX_CELLS, "one occupancy byte per cell");

/* Sets the geometry and marks every cell unknown (occ 0, known 0). Returns 0, -EINVAL on
 * NULL, a non-positive or non-finite res or origin, w or h < 1, or -ENOSPC when a side
 * exceeds RT_GRID_MAX_SIDE or w * h exceeds RT_GRID_MAX_CELLS (the grid is untouched then). */
FS_MUST_CHECK
int rt_grid_init(rt_grid_t *grid, float res, float origin_x, float origin_y, int32_t w, int32_t h);

/* 0 when the geometry is one rt_grid_init accepts, else -EINVAL (or -ENOSPC, too large). */
FS_MUST_CHECK
int rt_grid_check(const rt_grid_t *grid);

/* Writes one cell. Returns 0 or -EINVAL (NULL grid, cell outside). */
FS_MUST_CHECK
int rt_grid_set(rt_grid_t *grid, int32_t col, int32_t row, uint8_t occ, uint8_t known);

/* World point -> cell. Returns 0, or -EINVAL for a NULL pointer, a non-finite point or a
 * point outside the grid (col/row are not written then). */
FS_MUST_CHECK
int rt_grid_world_to_cell(const rt_grid_t *grid, float x, float y, int32_t *col, int32_t *row);

/* Centre of a cell in world metres (no range check). */
void rt_grid_cell_centre(const rt_grid_t *grid, int32_t col, int32_t row, float *x, float *y);

#endif /* RT_GRID_H */
