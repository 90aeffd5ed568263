/* Figures of plans and tours: the convention and contract in sim_figure.h. */
#include "sim_figure.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>

#include "sim_palette.h"

typedef struct {
    uint8_t *rgb;
    int w, h, k;
} canvas_t;

static void put_px(canvas_t *cv, int x, int y, const uint8_t *col)
{
    if (x < 0 || y < 0 || x >= cv->w || y >= cv->h)
        return;
    uint8_t *p = cv->rgb + 3 * ((size_t)y * (size_t)cv->w + (size_t)x);
    p[0] = col[0];
    p[1] = col[1];
    p[2] = col[2];
}

/* World point -> pixel, y up: the grid's row 0 (smallest y) is the picture's bottom. */
static void world_px(const sim_grid_t *g, const canvas_t *cv, double x, double y, int *px, int *py)
{
    const double pix = g->res / cv->k;
    *px = (int)floor((x - g->origin.x) / pix);
    *py = sim_figure_row(y, g->origin.y, pix, cv->h);
}

int sim_figure_paths_png(const sim_grid_t *g, const sim_path_t *paths, int n, const char *file, char *err,
                         size_t errlen)
{
    if (g == NULL || g->cells == NULL || g->w < 1 || g->h < 1 || file == NULL || n < 0 || (n > 0 && paths == NULL)) {
        if (err != NULL && errlen > 0)
            snprintf(err, errlen, "paths picture: bad arguments");
        return -EINVAL;
    }
    canvas_t cv;
    const int side = g->w > g->h ? g->w : g->h;
    cv.k = side >= 1000 ? 1 : 1000 / side;
    cv.w = g->w * cv.k;
    cv.h = g->h * cv.k;
    cv.rgb = malloc((size_t)cv.w * (size_t)cv.h * 3);
    if (cv.rgb == NULL) {
        if (err != NULL && errlen > 0)
            snprintf(err, errlen, "%s: out of memory", file);
        return -ENOMEM;
    }
    for (int y = 0; y < cv.h; y++)
        for (int x = 0; x < cv.w; x++) {
            const int row = g->h - 1 - y / cv.k; /* y up: the picture's top row is the grid's last */
            const int c = g->cells[(size_t)row * (size_t)g->w + (size_t)(x / cv.k)];
            const uint8_t v = c == SIM_CELL_FREE ? 255 : (c == SIM_CELL_WALL ? 0 : 190);
            const uint8_t col[3] = {v, v, v};
            put_px(&cv, x, y, col);
        }
    for (int k = 0; k < n; k++) {
        const uint8_t *col = sim_palette_rgb(k);
        for (int i = 0; i + 1 < paths[k].n; i++) {
            const double x0 = paths[k].p[i].x, y0 = paths[k].p[i].y;
            const double x1 = paths[k].p[i + 1].x, y1 = paths[k].p[i + 1].y;
            const int steps = (int)ceil(hypot(x1 - x0, y1 - y0) / g->res * cv.k) + 1;
            for (int s = 0; s <= steps; s++) {
                const double t = (double)s / steps;
                int px, py;
                world_px(g, &cv, x0 + t * (x1 - x0), y0 + t * (y1 - y0), &px, &py);
                for (int d = 0; d < (cv.k > 2 ? 2 : 1); d++) {
                    put_px(&cv, px + d, py, col);
                    put_px(&cv, px, py + d, col);
                }
            }
        }
        /* Waypoints as small crosses, the start as a filled square. */
        for (int i = 0; i < paths[k].n; i++) {
            int px, py;
            world_px(g, &cv, paths[k].p[i].x, paths[k].p[i].y, &px, &py);
            const int rad = i == 0 ? 3 * cv.k : cv.k;
            for (int d = -rad; d <= rad; d++)
                for (int e = -rad; e <= rad; e++)
                    if (i == 0 || d == 0 || e == 0)
                        put_px(&cv, px + d, py + e, col);
        }
    }
    const int rc = sim_png_write_rgb(file, cv.w, cv.h, cv.rgb, err, errlen);
    free(cv.rgb);
    return rc;
}
