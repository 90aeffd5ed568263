/* Occupancy and uncertainty maps of a model: see sim_maps.h. */
#include "sim_maps.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sim_figure.h"
#include "sim_palette.h"

/* A compact perceptual ramp (dark blue -> teal -> yellow), t in [0, 1]. */
static void ramp(double t, uint8_t *px)
{
    static const double K[5][3] = {{13, 8, 135}, {84, 2, 163}, {33, 145, 140}, {122, 209, 81}, {253, 231, 37}};
    t = fmin(fmax(t, 0.0), 1.0) * 4.0;
    int i = (int)t;
    if (i > 3)
        i = 3;
    const double u = t - i;
    for (int c = 0; c < 3; c++)
        px[c] = (uint8_t)lround(K[i][c] + u * (K[i + 1][c] - K[i][c]));
}

static void draw_paths(uint8_t *rgb, int W, int H, const sim_plan_t *plan, double res, int zoom,
                       const sim_path_t *paths, int n_paths)
{
    const double pix = res / zoom;
    for (int k = 0; k < n_paths; k++) {
        const uint8_t *col = sim_palette_rgb(k);
        for (int i = 0; i + 1 < paths[k].n; i++) {
            const double x0 = paths[k].p[i].x, y0 = paths[k].p[i].y;
            const double x1 = paths[k].p[i + 1].x, y1 = paths[k].p[i + 1].y;
            const int steps = (int)ceil(hypot(x1 - x0, y1 - y0) / (pix * 0.5)) + 1;
            for (int s = 0; s <= steps; s++) {
                const double t = (double)s / steps;
                const int c = (int)floor((x0 + t * (x1 - x0) - plan->min.x) / pix);
                const int r = sim_figure_row(y0 + t * (y1 - y0), plan->min.y, pix, H); /* y up */
                for (int d = 0; d < 2; d++)
                    for (int e = 0; e < 2; e++) {
                        const int cc = c + d, rr = r + e;
                        if (cc < 0 || rr < 0 || cc >= W || rr >= H)
                            continue;
                        memcpy(rgb + 3 * ((size_t)rr * W + cc), col, 3);
                    }
            }
        }
    }
}

void sim_maps_grid_free(sim_maps_grid_t *g)
{
    if (g == NULL)
        return;
    free(g->mean);
    free(g->std);
    memset(g, 0, sizeof *g);
}

double sim_maps_std_max(const sim_maps_grid_t *g)
{
    double smax = 0.0;
    if (g == NULL || g->std == NULL || g->w < 1 || g->h < 1)
        return smax;
    const size_t n = (size_t)g->w * g->h;
    for (size_t i = 0; i < n; i++)
        smax = fmax(smax, g->std[i]);
    return smax;
}

uint8_t sim_maps_pgm_pixel(float p)
{
    if (!(p >= 0.0f)) /* negative or NaN: free, as the PNGs draw it */
        p = 0.0f;
    return (uint8_t)lround(255.0 * (1.0 - fmin((double)p, 1.0)));
}

/* F1 = 2 TP / (2 TP + FP + FN); 0 when there is no true positive. */
static double f1_score(uint64_t tp, uint64_t fp, uint64_t fn)
{
    return tp == 0 ? 0.0 : 2.0 * (double)tp / (2.0 * (double)tp + (double)fp + (double)fn);
}

int sim_maps_choose_thresholds(const float *p, const ai_sample_t *pts, size_t n, sim_maps_thresh_t *t)
{
    if (t == NULL)
        return -EINVAL;
    memset(t, 0, sizeof *t);
    if (p == NULL || pts == NULL || n == 0)
        return -EINVAL;
    /* Points per level, hits and free apart. */
    uint64_t hit[256] = {0}, fre[256] = {0}, n_hit = 0;
    for (size_t i = 0; i < n; i++) {
        const int level = 255 - sim_maps_pgm_pixel(p[i]);
        if (pts[i].occ >= 0.5f) {
            hit[level]++;
            n_hit++;
        } else {
            fre[level]++;
        }
    }
    const uint64_t n_free = (uint64_t)n - n_hit;
    if (n_hit == 0 || n_free == 0)
        return -EINVAL;
    /* Occupied: level > a. Walk a down from 254, the points above the cut accumulating. */
    uint64_t tp = 0, fp = 0;
    int best_a = 254;
    double best = -1.0;
    double f1_occ[255];
    for (int a = 254; a >= 0; a--) {
        tp += hit[a + 1];
        fp += fre[a + 1];
        f1_occ[a] = f1_score(tp, fp, n_hit - tp);
    }
    for (int a = 0; a <= 254; a++)
        if (f1_occ[a] > best) {
            best = f1_occ[a];
            best_a = a;
        }
    t->occ_level = best_a;
    t->occ_f1 = best;
    /* Free: level <= c with c < a (free < occupied). a = 0 leaves no level below it: then
       a = 1 (a model that calls nearly every point occupied). Walk c up, the points at or
       below the cut accumulating. */
    if (t->occ_level == 0) {
        t->occ_level = 1;
        t->occ_f1 = f1_occ[1];
    }
    uint64_t ftp = 0, ffp = 0;
    best = -1.0;
    for (int c = 0; c < t->occ_level; c++) {
        ftp += fre[c];
        ffp += hit[c];
        const double f = f1_score(ftp, ffp, n_free - ftp);
        if (f > best) {
            best = f;
            t->free_level = c;
        }
    }
    t->free_f1 = best;
    t->occupied = (t->occ_level + 0.5) / 255.0;
    t->free_thresh = (t->free_level + 0.5) / 255.0;
    t->n = n;
    t->n_hit = (size_t)n_hit;
    return 0;
}

/* The RGB picture of a grid: each cell zoom x zoom pixels, zoom = ceil(0.1 m / res) within 1..8
 * (about 10 pixels per metre or more); malloc'd, NULL (err set) when out of memory. */
static uint8_t *canvas(const sim_maps_grid_t *g, int *zoom, int *W, int *H, char *err, size_t errlen)
{
    const double z = ceil(0.02 / g->res * 5.0);
    *zoom = z < 1.0 ? 1 : z > 8.0 ? 8 : (int)z;
    *W = g->w * *zoom;
    *H = g->h * *zoom;
    uint8_t *rgb = malloc((size_t)*W * *H * 3);
    if (!rgb)
        snprintf(err, errlen, "out of memory");
    return rgb;
}

/* The w x h cell centres of a map, normalised (interleaved x, y); malloc'd, NULL when out of
 * memory. */
static float *cell_centres(const sim_plan_t *plan, double res, int w, int h)
{
    float *xy = malloc((size_t)w * h * 2 * sizeof *xy);
    if (!xy)
        return NULL;
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            float xn, yn;
            sim_plan_normalise(plan, plan->min.x + (c + 0.5) * res, plan->min.y + (r + 0.5) * res, &xn, &yn);
            xy[2 * ((size_t)r * w + c)] = fminf(fmaxf(xn, -1.0f), 1.0f);
            xy[2 * ((size_t)r * w + c) + 1] = fminf(fmaxf(yn, -1.0f), 1.0f);
        }
    return xy;
}

int sim_maps_epistemic(bnn_model_t *m, bnn_post_t *post, const sim_plan_t *plan, const sim_maps_grid_t *g,
                       float *unknown, char *err, size_t errlen)
{
    if (!m || !post || !plan || !g || g->w < 1 || g->h < 1 || !unknown) {
        snprintf(err, errlen, "bad map arguments");
        return -EINVAL;
    }
    float *xy = cell_centres(plan, g->res, g->w, g->h);
    if (!xy) {
        snprintf(err, errlen, "out of memory");
        return -ENOMEM;
    }
    const int rc = bnn_post_predict(post, m, xy, (size_t)g->w * g->h, NULL, unknown);
    if (rc)
        snprintf(err, errlen, "epistemic posterior failed (%d%s)", rc,
                 rc == -EDOM ? ": its precision is not positive definite" : "");
    free(xy);
    return rc;
}

int sim_maps_write_epistemic_png(const sim_maps_grid_t *g, const float *unknown, const sim_plan_t *plan,
                                 const sim_path_t *paths, int n_paths, const char *png, char *err, size_t errlen)
{
    if (!g || !unknown || g->w < 1 || g->h < 1 || !plan || !png || (n_paths > 0 && !paths)) {
        snprintf(err, errlen, "bad map arguments");
        return -EINVAL;
    }
    const int w = g->w, h = g->h;
    int zoom, W, H;
    uint8_t *rgb = canvas(g, &zoom, &W, &H, err, errlen);
    if (!rgb)
        return -ENOMEM;
    for (int R = 0; R < H; R++)
        for (int C = 0; C < W; C++) {
            const size_t i = (size_t)(h - 1 - R / zoom) * w + (size_t)(C / zoom);
            const double v = unknown[i] > SIM_MAPS_EPI_FLOOR ? unknown[i] : SIM_MAPS_EPI_FLOOR;
            ramp(log10(v / SIM_MAPS_EPI_FLOOR) / -log10(SIM_MAPS_EPI_FLOOR), rgb + 3 * ((size_t)R * W + C));
        }
    draw_paths(rgb, W, H, plan, g->res, zoom, paths, n_paths);
    const int rc = sim_png_write_rgb(png, W, H, rgb, err, errlen);
    free(rgb);
    return rc;
}

int sim_maps_compute(bnn_model_t *m, const sim_plan_t *plan, double res, uint32_t K, uint64_t seed,
                     sim_maps_grid_t *g, char *err, size_t errlen)
{
    if (g != NULL)
        memset(g, 0, sizeof *g);
    if (!m || !plan || !g || !isfinite(res) || res <= 0.0 || K < 1) {
        snprintf(err, errlen, "bad map arguments");
        return -EINVAL;
    }
    const int w = (int)ceil((plan->max.x - plan->min.x) / res), h = (int)ceil((plan->max.y - plan->min.y) / res);
    if (w < 1 || h < 1 || (size_t)w * h > 4000000u) {
        snprintf(err, errlen, "map of %d x %d cells is out of range", w, h);
        return -EINVAL;
    }
    const size_t n = (size_t)w * h;
    float *xy = cell_centres(plan, res, w, h);
    g->mean = malloc(n * sizeof *g->mean);
    g->std = malloc(n * sizeof *g->std);
    int rc = -ENOMEM;
    if (!xy || !g->mean || !g->std) {
        snprintf(err, errlen, "out of memory");
        goto done;
    }
    rc = bnn_predict_mc(m, xy, n, K, seed, g->mean, g->std);
    if (rc)
        snprintf(err, errlen, "MC prediction failed (%d)", rc);
done:
    free(xy);
    if (rc) {
        sim_maps_grid_free(g);
    } else {
        g->w = w;
        g->h = h;
        g->res = res;
        g->x0 = plan->min.x;
        g->y0 = plan->min.y;
    }
    return rc;
}

int sim_maps_write_png(const sim_maps_grid_t *g, const sim_plan_t *plan, const sim_path_t *paths, int n_paths,
                       const char *mean_png, const char *std_png, double *std_max_out, char *err,
                       size_t errlen)
{
    if (!g || !g->mean || !g->std || g->w < 1 || g->h < 1 || !plan || !isfinite(g->res) || g->res <= 0.0 ||
        !mean_png || !std_png || (n_paths > 0 && !paths)) {
        snprintf(err, errlen, "bad map arguments");
        return -EINVAL;
    }
    const double res = g->res;
    const int w = g->w, h = g->h;
    const float *mean = g->mean, *sd = g->std;
    int zoom, W, H;
    uint8_t *rgb = canvas(g, &zoom, &W, &H, err, errlen);
    if (!rgb)
        return -ENOMEM;
    const double smax = sim_maps_std_max(g);
    if (std_max_out)
        *std_max_out = smax;
    int rc = 0;
    for (int pass = 0; pass < 2; pass++) {
        for (int R = 0; R < H; R++)
            for (int C = 0; C < W; C++) {
                /* y up (sim_figure.h): picture row R shows cell row h - 1 - R / zoom. */
                const size_t i = (size_t)(h - 1 - R / zoom) * w + (size_t)(C / zoom);
                uint8_t *px = rgb + 3 * ((size_t)R * W + C);
                if (pass == 0) {
                    const uint8_t v = (uint8_t)lround(255.0 * (1.0 - fmin(fmax(mean[i], 0.0f), 1.0f)));
                    px[0] = px[1] = px[2] = v;
                } else {
                    ramp(smax > 0.0 ? sd[i] / smax : 0.0, px);
                }
            }
        draw_paths(rgb, W, H, plan, res, zoom, paths, n_paths);
        rc = sim_png_write_rgb(pass == 0 ? mean_png : std_png, W, H, rgb, err, errlen);
        if (rc)
            break;
    }
    free(rgb);
    return rc;
}

int sim_maps_write(bnn_model_t *m, const sim_plan_t *plan, double res, uint32_t K, uint64_t seed,
                   const sim_path_t *paths, int n_paths, const char *mean_png, const char *std_png,
                   double *std_max_out, char *err, size_t errlen)
{
    if (!m || !plan || !isfinite(res) || res <= 0.0 || K < 1 || !mean_png || !std_png || (n_paths > 0 && !paths)) {
        snprintf(err, errlen, "bad map arguments");
        return -EINVAL;
    }
    sim_maps_grid_t g;
    int rc = sim_maps_compute(m, plan, res, K, seed, &g, err, errlen);
    if (rc == 0)
        rc = sim_maps_write_png(&g, plan, paths, n_paths, mean_png, std_png, std_max_out, err, errlen);
    sim_maps_grid_free(&g);
    return rc;
}
