/* Figures of plans and tours: the convention and contract in sim_figure.h. */
#include "sim_figure.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* ---- the frame: ticks, labels in metres, the legend ---------------------------------------- */

/* A 3 x 5 pixel font of what the frame writes (digits, '-', "m", "robot"); rows top first, the
 * glyph's 3 bits most significant first ('m' is 5 wide). */
typedef struct {
    char c;
    uint8_t wide;
    uint8_t rows[5];
} glyph_t;

static const glyph_t FONT[] = {
    {'0', 3, {7, 5, 5, 5, 7}}, {'1', 3, {2, 6, 2, 2, 7}}, {'2', 3, {7, 1, 7, 4, 7}}, {'3', 3, {7, 1, 7, 1, 7}},
    {'4', 3, {5, 5, 7, 1, 1}}, {'5', 3, {7, 4, 7, 1, 7}}, {'6', 3, {7, 4, 7, 5, 7}}, {'7', 3, {7, 1, 1, 1, 1}},
    {'8', 3, {7, 5, 7, 5, 7}}, {'9', 3, {7, 5, 7, 1, 7}}, {'-', 3, {0, 0, 7, 0, 0}}, {'m', 5, {0, 30, 21, 21, 21}},
    {'r', 3, {0, 7, 4, 4, 4}}, {'o', 3, {0, 7, 5, 5, 7}}, {'b', 3, {4, 4, 7, 5, 7}}, {'t', 3, {2, 7, 2, 2, 3}},
    {' ', 3, {0, 0, 0, 0, 0}},
};

static const glyph_t *glyph(char c)
{
    for (size_t i = 0; i < sizeof FONT / sizeof FONT[0]; i++)
        if (FONT[i].c == c)
            return &FONT[i];
    return &FONT[sizeof FONT / sizeof FONT[0] - 1];
}

/* Width in pixels of text at scale s (a pixel of the font is s x s; one column between glyphs). */
static int text_w(const char *t, int s)
{
    int w = 0;
    for (; *t; t++)
        w += (glyph(*t)->wide + 1) * s;
    return w > 0 ? w - s : 0;
}

static void draw_text(canvas_t *cv, int x, int y, const char *t, int s, const uint8_t *col)
{
    for (; *t; t++) {
        const glyph_t *gl = glyph(*t);
        for (int r = 0; r < 5; r++)
            for (int c = 0; c < gl->wide; c++)
                if (gl->rows[r] >> (gl->wide - 1 - c) & 1)
                    for (int dy = 0; dy < s; dy++)
                        for (int dx = 0; dx < s; dx++)
                            put_px(cv, x + c * s + dx, y + r * s + dy, col);
        x += (gl->wide + 1) * s;
    }
}

static void fill(canvas_t *cv, int x, int y, int w, int h, const uint8_t *col)
{
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++)
            put_px(cv, x + i, y + j, col);
}

/* Cell size in pixels (the map's long side about 1000 px) and the font scale. */
static void frame_scale(const sim_grid_t *g, int *k, int *s)
{
    const int side = g->w > g->h ? g->w : g->h;
    *k = side >= 1000 ? 1 : 1000 / side;
    const int mw = g->w * *k;
    *s = mw >= 600 ? 3 : (mw >= 200 ? 2 : 1);
}

/* Legend entries per row, given the map's width. */
static int legend_per_row(int map_w, int s)
{
    const int entry = 6 * s + text_w("robot 00", s) + 6 * s;
    const int per = map_w / entry;
    return per < 1 ? 1 : per;
}

void sim_figure_paths_frame(const sim_grid_t *g, int n, int *w, int *h, int *x0, int *y0, int *k)
{
    int kk, s;
    frame_scale(g, &kk, &s);
    const int rows = n > 0 ? (n + legend_per_row(g->w * kk, s) - 1) / legend_per_row(g->w * kk, s) : 0;
    const int left = text_w("-000", s) + 4 * s + 6, top = 12 * s, right = 14 * s;
    const int bottom = 3 * s + 5 * s + 5 * s + rows * 8 * s + 2 * s;
    *k = kk;
    *x0 = left;
    *y0 = top;
    *w = left + g->w * kk + right;
    *h = top + g->h * kk + bottom;
}

/* Tick spacing in metres: about 5 to 15 ticks along the longer side. */
static double tick_step(double extent)
{
    return extent <= 15.0 ? 1.0 : (extent <= 30.0 ? 2.0 : (extent <= 75.0 ? 5.0 : 10.0));
}

static void draw_frame(canvas_t *cv, const sim_grid_t *g, int n, int x0, int y0, int s)
{
    static const uint8_t ink[3] = {0, 0, 0};
    const int mw = g->w * cv->k, mh = g->h * cv->k;
    /* The frame around the map. */
    fill(cv, x0 - 1, y0 - 1, mw + 2, 1, ink);
    fill(cv, x0 - 1, y0 + mh, mw + 2, 1, ink);
    fill(cv, x0 - 1, y0 - 1, 1, mh + 2, ink);
    fill(cv, x0 + mw, y0 - 1, 1, mh + 2, ink);
    const double xe = g->w * g->res, ye = g->h * g->res;
    const double step = tick_step(xe > ye ? xe : ye);
    const double pix = g->res / cv->k;
    char t[32];
    /* x ticks below the map, labels centred under them; "m" after the last. */
    int last_right = x0;
    for (double v = ceil(g->origin.x / step - 1e-9) * step; v <= g->origin.x + xe + 1e-9; v += step) {
        const int px = x0 + (int)lround((v - g->origin.x) / pix);
        fill(cv, px, y0 + mh + 1, 1, 3 * s, ink);
        snprintf(t, sizeof t, "%ld", lround(v));
        const int tw = text_w(t, s);
        draw_text(cv, px - tw / 2, y0 + mh + 4 * s, t, s, ink);
        last_right = px + tw / 2 + (tw & 1);
    }
    draw_text(cv, last_right + 2 * s, y0 + mh + 4 * s, "m", s, ink);
    /* y ticks left of the map, labels right-aligned, centred on them; "m" above the top. */
    for (double v = ceil(g->origin.y / step - 1e-9) * step; v <= g->origin.y + ye + 1e-9; v += step) {
        const int py = y0 + mh - (int)lround((v - g->origin.y) / pix);
        fill(cv, x0 - 1 - 3 * s, py, 3 * s, 1, ink);
        snprintf(t, sizeof t, "%ld", lround(v));
        draw_text(cv, x0 - 4 * s - 2 - text_w(t, s), py - 5 * s / 2, t, s, ink);
    }
    draw_text(cv, x0 - 4 * s - 2 - text_w("m", s), y0 - 10 * s, "m", s, ink);
    /* The legend: a square in the robot's colour and "robot i". */
    const int per = legend_per_row(mw, s), entry = mw / per;
    const int ly = y0 + mh + 4 * s + 5 * s + 4 * s;
    for (int i = 0; i < n; i++) {
        const int ex = x0 + (i % per) * entry, ey = ly + (i / per) * 8 * s;
        fill(cv, ex, ey, 5 * s, 5 * s, sim_palette_rgb(i));
        snprintf(t, sizeof t, "robot %d", i);
        draw_text(cv, ex + 7 * s, ey, t, s, ink);
    }
}

int sim_figure_paths_png(const sim_grid_t *g, const sim_path_t *paths, int n, const char *file, char *err,
                         size_t errlen)
{
    if (g == NULL || g->cells == NULL || g->w < 1 || g->h < 1 || file == NULL || n < 0 || (n > 0 && paths == NULL)) {
        if (err != NULL && errlen > 0)
            snprintf(err, errlen, "paths picture: bad arguments");
        return -EINVAL;
    }
    /* The map alone first (the picture convention of world_px), then copied into the frame. */
    canvas_t cv;
    int W, H, fx0, fy0, s;
    sim_figure_paths_frame(g, n, &W, &H, &fx0, &fy0, &cv.k);
    frame_scale(g, &cv.k, &s);
    cv.w = g->w * cv.k;
    cv.h = g->h * cv.k;
    cv.rgb = malloc((size_t)cv.w * (size_t)cv.h * 3);
    canvas_t fr = {malloc((size_t)W * (size_t)H * 3), W, H, cv.k};
    if (cv.rgb == NULL || fr.rgb == NULL) {
        free(cv.rgb);
        free(fr.rgb);
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
    memset(fr.rgb, 255, (size_t)W * (size_t)H * 3);
    for (int y = 0; y < cv.h; y++)
        memcpy(fr.rgb + 3 * ((size_t)(fy0 + y) * (size_t)W + (size_t)fx0), cv.rgb + 3 * (size_t)y * (size_t)cv.w,
               3 * (size_t)cv.w);
    free(cv.rgb);
    draw_frame(&fr, g, n, fx0, fy0, s);
    const int rc = sim_png_write_rgb(file, W, H, fr.rgb, err, errlen);
    free(fr.rgb);
    return rc;
}
