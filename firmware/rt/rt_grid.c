/* Belief grid: see rt_grid.h for the layout. */
#include "rt/rt_grid.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

static int geometry_ok(float res, float ox, float oy, int32_t w, int32_t h)
{
    if (!isfinite(res) || !(res > 0.0f) || !isfinite(ox) || !isfinite(oy) || w < 1 || h < 1)
        return -EINVAL;
    /* Sides first: w * h of two sides within RT_GRID_MAX_SIDE cannot overflow int32. */
    if (w > RT_GRID_MAX_SIDE || h > RT_GRID_MAX_SIDE || w * h > RT_GRID_MAX_CELLS)
        return -ENOSPC;
    return 0;
}

int rt_grid_init(rt_grid_t *grid, float res, float origin_x, float origin_y, int32_t w, int32_t h)
{
    if (grid == NULL)
        return -EINVAL;
    int r = geometry_ok(res, origin_x, origin_y, w, h);
    if (r != 0)
        return r;
    grid->res = res;
    grid->origin_x = origin_x;
    grid->origin_y = origin_y;
    grid->w = w;
    grid->h = h;
    memset(grid->occ, 0, sizeof grid->occ);
    memset(grid->known, 0, sizeof grid->known);
    return 0;
}

int rt_grid_check(const rt_grid_t *grid)
{
    if (grid == NULL)
        return -EINVAL;
    return geometry_ok(grid->res, grid->origin_x, grid->origin_y, grid->w, grid->h);
}

int rt_grid_set(rt_grid_t *grid, int32_t col, int32_t row, uint8_t occ, uint8_t known)
{
    if (grid == NULL || col < 0 || row < 0 || col >= grid->w || row >= grid->h)
        return -EINVAL;
    int32_t i = row * grid->w + col;
    grid->occ[i] = occ;
    grid->known[i] = known;
    return 0;
}

int rt_grid_world_to_cell(const rt_grid_t *grid, float x, float y, int32_t *col, int32_t *row)
{
    if (grid == NULL || col == NULL || row == NULL || !isfinite(x) || !isfinite(y))
        return -EINVAL;
    /* floor, not truncation: a point just left of the origin is outside, not in column 0. */
    float fc = floorf((x - grid->origin_x) / grid->res);
    float fr = floorf((y - grid->origin_y) / grid->res);
    if (!(fc >= 0.0f) || !(fr >= 0.0f) || fc >= (float)grid->w || fr >= (float)grid->h)
        return -EINVAL;
    *col = (int32_t)fc;
    *row = (int32_t)fr;
    return 0;
}

void rt_grid_cell_centre(const rt_grid_t *grid, int32_t col, int32_t row, float *x, float *y)
{
    *x = grid->origin_x + ((float)col + 0.5f) * grid->res;
    *y = grid->origin_y + ((float)row + 0.5f) * grid->res;
}
