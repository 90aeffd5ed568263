/* Ground-truth occupancy grid from a floor plan (rule and layout in sim_grid.h). */
#include "sim_grid.h"
#include "hal_host_file.h"

#include <errno.h>
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    double x0, y0, x1, y1;
} bbox_t;

static bbox_t poly_bbox(const sim_poly_t *p)
{
    bbox_t b = {INFINITY, INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < p->n; i++) {
        b.x0 = fmin(b.x0, p->p[i].x);
        b.y0 = fmin(b.y0, p->p[i].y);
        b.x1 = fmax(b.x1, p->p[i].x);
        b.y1 = fmax(b.y1, p->p[i].y);
    }
    return b;
}

/* Free space (rooms, doors) is closed: a point within this of a room's or a door's edge is in
 * it. Two rooms share an edge (an opening without a door, or a T-junction of three rooms)
 * and each computes it from its own vertices: a point on it could fall, by rounding, between
 * the two and in neither, and a line of such cells closes a doorway. 1 um is far above the
 * rounding of any coordinate within the plan limits (10 km) and far below any drawing detail.
 * Solids stay half-open (sim_poly_contains): a wall grows by nothing. */
#define FREE_EDGE_TOL_M 1e-6

int sim_plan_classify_point(const sim_plan_t *plan, double x, double y)
{
    for (int i = 0; i < plan->n_solids; i++)
        if (sim_poly_contains(&plan->solids[i].outline, x, y))
            return SIM_CELL_WALL;
    for (int i = 0; i < plan->n_rooms; i++)
        if (sim_poly_covers(&plan->rooms[i].outline, x, y, FREE_EDGE_TOL_M))
            return SIM_CELL_FREE;
    for (int i = 0; i < plan->n_openings; i++)
        if (plan->openings[i].kind == SIM_OPENING_DOOR &&
            sim_poly_covers(&plan->openings[i].outline, x, y, FREE_EDGE_TOL_M))
            return SIM_CELL_FREE;
    return SIM_CELL_OUTSIDE;
}

int sim_grid_init(sim_grid_t *grid, double res_m, double origin_x, double origin_y, int w, int h)
{
    if (grid == NULL)
        return -EINVAL;
    memset(grid, 0, sizeof *grid);
    if (!(res_m > 0.0) || !isfinite(res_m) || !isfinite(origin_x) || !isfinite(origin_y) || w <= 0 || h <= 0)
        return -EINVAL;
    if (w > SIM_GRID_MAX_SIDE || h > SIM_GRID_MAX_SIDE)
        return -E2BIG;
    grid->cells = malloc((size_t)w * (size_t)h);
    if (grid->cells == NULL)
        return -ENOMEM;
    memset(grid->cells, SIM_CELL_OUTSIDE, (size_t)w * (size_t)h);
    grid->res = res_m;
    grid->origin.x = origin_x;
    grid->origin.y = origin_y;
    grid->w = w;
    grid->h = h;
    return 0;
}

void sim_grid_free(sim_grid_t *grid)
{
    if (grid == NULL)
        return;
    free(grid->cells);
    memset(grid, 0, sizeof *grid);
}

int sim_grid_world_to_cell(const sim_grid_t *grid, double x, double y, int *col, int *row)
{
    double fc = floor((x - grid->origin.x) / grid->res), fr = floor((y - grid->origin.y) / grid->res);
    /* Clamp before converting so a far point cannot overflow int. */
    fc = fmax(fmin(fc, (double)SIM_GRID_MAX_SIDE * 4), -(double)SIM_GRID_MAX_SIDE * 4);
    fr = fmax(fmin(fr, (double)SIM_GRID_MAX_SIDE * 4), -(double)SIM_GRID_MAX_SIDE * 4);
    if (isnan(fc) || isnan(fr))
        fc = fr = -1;
    int c = (int)fc, r = (int)fr;
    if (col != NULL)
        *col = c;
    if (row != NULL)
        *row = r;
    return (c >= 0 && r >= 0 && c < grid->w && r < grid->h) ? 0 : -ERANGE;
}

void sim_grid_cell_centre(const sim_grid_t *grid, int col, int row, double *x, double *y)
{
    if (x != NULL)
        *x = grid->origin.x + (col + 0.5) * grid->res;
    if (y != NULL)
        *y = grid->origin.y + (row + 0.5) * grid->res;
}

/* Sets every cell whose centre is inside `poly` (closed: or within FREE_EDGE_TOL_M of its
 * boundary) to `value` (only cells whose current value is in `from_mask`, a bit set over
 * SIM_CELL_* values). Walks the polygon's bounding box only. */
static void fill_poly(sim_grid_t *g, const sim_poly_t *poly, int value, unsigned from_mask, int closed)
{
    bbox_t b = poly_bbox(poly);
    int c0 = (int)floor((b.x0 - g->origin.x) / g->res) - 1, c1 = (int)ceil((b.x1 - g->origin.x) / g->res) + 1;
    int r0 = (int)floor((b.y0 - g->origin.y) / g->res) - 1, r1 = (int)ceil((b.y1 - g->origin.y) / g->res) + 1;
    c0 = c0 < 0 ? 0 : c0;
    r0 = r0 < 0 ? 0 : r0;
    c1 = c1 > g->w - 1 ? g->w - 1 : c1;
    r1 = r1 > g->h - 1 ? g->h - 1 : r1;
    for (int r = r0; r <= r1; r++)
        for (int c = c0; c <= c1; c++) {
            uint8_t *cell = &g->cells[(size_t)r * (size_t)g->w + (size_t)c];
            if (!(from_mask & (1u << *cell)))
                continue;
            double x, y;
            sim_grid_cell_centre(g, c, r, &x, &y);
            if (closed ? sim_poly_covers(poly, x, y, FREE_EDGE_TOL_M) : sim_poly_contains(poly, x, y))
                *cell = (uint8_t)value;
        }
}

int sim_grid_from_plan(const sim_plan_t *plan, double res_m, sim_grid_t *grid)
{
    if (grid == NULL)
        return -EINVAL;
    memset(grid, 0, sizeof *grid);
    if (plan == NULL || plan->n_walls <= 0 || !(res_m > 0.0) || !isfinite(res_m))
        return -EINVAL;
    double wx = plan->max.x - plan->min.x, wy = plan->max.y - plan->min.y;
    double fw = ceil(wx / res_m - 1e-9), fh = ceil(wy / res_m - 1e-9);
    if (!(fw >= 1) || !(fh >= 1))
        return -EINVAL;
    if (fw > SIM_GRID_MAX_SIDE || fh > SIM_GRID_MAX_SIDE)
        return -E2BIG;
    int rc = sim_grid_init(grid, res_m, plan->min.x, plan->min.y, (int)fw, (int)fh);
    if (rc != 0)
        return rc;
    /* Same precedence as sim_plan_classify_point: solid over room/door over outside. */
    const unsigned OUT = 1u << SIM_CELL_OUTSIDE, FREE = 1u << SIM_CELL_FREE;
    for (int i = 0; i < plan->n_rooms; i++)
        fill_poly(grid, &plan->rooms[i].outline, SIM_CELL_FREE, OUT, 1);
    for (int i = 0; i < plan->n_openings; i++)
        if (plan->openings[i].kind == SIM_OPENING_DOOR)
            fill_poly(grid, &plan->openings[i].outline, SIM_CELL_FREE, OUT, 1);
    for (int i = 0; i < plan->n_solids; i++)
        fill_poly(grid, &plan->solids[i].outline, SIM_CELL_WALL, OUT | FREE, 0);
    return 0;
}

static int set_err(char *err, size_t errlen, int rc, const char *fmt, const char *path)
{
    if (err != NULL && errlen > 0)
        snprintf(err, errlen, fmt, path, hal_host_file_strerror(rc < 0 ? rc : -rc));
    return rc;
}

/* libpng reports errors by longjmp; keep that contained in one function with plain locals. */
static int write_png(const char *path, int w, int h, int channels, const uint8_t *pix, char *err, size_t errlen)
{
    hal_host_file_t out; /* not modified after setjmp, so still valid after libpng's longjmp */
    int rc = hal_host_file_begin(&out, path);
    if (rc < 0)
        return set_err(err, errlen, rc, "%s: %s", path);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (png == NULL || info == NULL) {
        png_destroy_write_struct(&png, &info);
        hal_host_file_abort(&out);
        return set_err(err, errlen, -ENOMEM, "%s: libpng: %s", path);
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        hal_host_file_abort(&out);
        return set_err(err, errlen, -EIO, "%s: libpng write failed: %s", path);
    }
    png_init_io(png, hal_host_file_stream(&out));
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 8, channels == 3 ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_GRAY,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int r = 0; r < h; r++)
        png_write_row(png, (png_const_bytep)(pix + (size_t)r * (size_t)w * (size_t)channels));
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    rc = hal_host_file_commit(&out);
    if (rc < 0)
        return set_err(err, errlen, rc, "%s: %s", path);
    return 0;
}

int sim_png_write_rgb(const char *path, int w, int h, const uint8_t *rgb, char *err, size_t errlen)
{
    if (path == NULL || rgb == NULL || w <= 0 || h <= 0)
        return -EINVAL;
    return write_png(path, w, h, 3, rgb, err, errlen);
}

static int ends_with(const char *s, const char *suf)
{
    size_t a = strlen(s), b = strlen(suf);
    return a >= b && strcmp(s + a - b, suf) == 0;
}

int sim_grid_write_image(const sim_grid_t *grid, const char *path, char *err, size_t errlen)
{
    if (grid == NULL || grid->cells == NULL || path == NULL) {
        if (err != NULL && errlen > 0)
            snprintf(err, errlen, "no grid or no path");
        return -EINVAL;
    }
    int png = ends_with(path, ".png"), pgm = ends_with(path, ".pgm");
    if (!png && !pgm) {
        if (err != NULL && errlen > 0)
            snprintf(err, errlen, "%s: unknown image type (use .png or .pgm)", path);
        return -EINVAL;
    }
    size_t n = (size_t)grid->w * (size_t)grid->h;
    uint8_t *pix = malloc(n);
    if (pix == NULL)
        return set_err(err, errlen, -ENOMEM, "%s: %s", path);
    static const uint8_t shade[3] = {255, 0, 160};
    /* y up (sim_figure.h): the image's first row is the grid's last (largest y). */
    for (int r = 0; r < grid->h; r++) {
        const uint8_t *src = grid->cells + (size_t)(grid->h - 1 - r) * (size_t)grid->w;
        uint8_t *dst = pix + (size_t)r * (size_t)grid->w;
        for (int c = 0; c < grid->w; c++)
            dst[c] = shade[src[c] <= 2 ? src[c] : 2];
    }
    int rc = 0;
    if (png) {
        rc = write_png(path, grid->w, grid->h, 1, pix, err, errlen);
    } else {
        hal_host_file_t out;
        rc = hal_host_file_begin(&out, path);
        if (rc == 0) {
            char head[64];
            int hn = snprintf(head, sizeof head, "P5\n%d %d\n255\n", grid->w, grid->h);
            rc = hal_host_file_write(&out, head, (size_t)hn);
            if (rc == 0)
                rc = hal_host_file_write(&out, pix, n);
            if (rc == 0)
                rc = hal_host_file_commit(&out);
            if (rc < 0)
                hal_host_file_abort(&out);
        }
        if (rc < 0)
            set_err(err, errlen, rc, "%s: %s", path);
    }
    free(pix);
    return rc;
}
