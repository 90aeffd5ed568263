/* host_sim maps: the consensus map of a fleet. The final models (BNN checkpoints) are averaged
 * into the consensus model, whose MC maps are written as NumPy arrays, a ROS map_server map
 * (PGM + YAML) and the usual PNGs. */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ai/bnn_ckpt.h"
#include "cli.h"
#include "cmd_maps_opts.h"
#include "commands.h"
#include "hal_host_file.h"
#include "sim_grid.h"
#include "sim_maps.h"
#include "sim_plan.h"
#include "sim_samples.h"

#define MAPS_MAX_CELLS 4000000u /* sim_maps_compute's limit */

/* Everything one `host_sim maps` run holds; freed in one place (job_free). */
enum { OUT_BNN, OUT_CSV, OUT_MEAN, OUT_STD, OUT_SINGLE, OUT_TRUTH, OUT_META, OUT_PGM, OUT_YAML, OUT_EPI, OUT_N };
static const char *const out_names[OUT_N] = {"consensus.bnn",  "consensus.csv", "map_mean.npy",
                                             "map_std.npy",    "map_single.npy", "map_truth.npy",
                                             "map_meta.json",  "map.pgm",        "map.yaml",
                                             "map_epistemic.npy"};

typedef struct job {
    maps_opts_t o;
    sim_plan_t plan;
    ai_sample_t *val;
    size_t n_val;
    bnn_model_t *scratch, *cons; /* a model loaded or evaluated; the consensus model */
    bnn_config_t cfg;            /* the network of every model */
    bnn_post_t *post_in, *post;  /* a model's epistemic posterior; the fleet's (their sum) */
    int n_post;                  /* models that carried one */
    int post_shared;             /* one of them was a fleet's estimate: they are averaged */
    float *epi;                  /* the grid's cells: the epistemic map, when n_post > 0 */
    uint64_t seed0;              /* the first model's seed */
    size_t P;                    /* parameters per model */
    float *theta;                /* n_models x P */
    double *mean;                /* P: the mean in double */
    double *cerr;                /* n_models consensus errors */
    float *val_loss;             /* n_models + 1 (the consensus last) */
    uint8_t *buf;                /* file bytes: a checkpoint read or written */
    sim_maps_grid_t mc, single;
    uint8_t *truth;              /* the grid's cells (row 0 the smallest y): 0 free, 1 wall, 255 outside */
    float *val_p;                /* n_val MC means at the validation points (the map's values) */
    /* map.yaml's thresholds: the text written and the values nav2 reads back from it */
    int th_chosen;               /* 1: chosen on the validation set; 0: the defaults */
    sim_maps_thresh_t th;        /* when chosen */
    char th_occ[32], th_free[32];
    double occ_thresh, free_thresh;
    char th_note[256];           /* why the defaults, when they are */
    /* the map as nav2 reads it, against the ground truth */
    size_t nav_occ, nav_free, nav_unknown;
    size_t nav_walls, nav_occ_wall, nav_occ_known, nav_free_known, nav_free_free;
    double wall_iou, free_precision, level_max;
    char path[OUT_N][PATH_MAX];
    char png_mean[PATH_MAX], png_std[PATH_MAX], png_epi[PATH_MAX];
    hal_host_file_t out[OUT_N];
    int begun[OUT_N];
    char err[8192];
} job_t;

static void job_free(job_t *j)
{
    for (int k = 0; k < OUT_N; k++)
        if (j->begun[k])
            hal_host_file_abort(&j->out[k]); /* a no-op after a commit */
    sim_maps_grid_free(&j->mc);
    sim_maps_grid_free(&j->single);
    free(j->val_p);
    free(j->epi);
    free(j->post);
    free(j->post_in);
    free(j->truth);
    free(j->buf);
    free(j->val_loss);
    free(j->cerr);
    free(j->mean);
    free(j->theta);
    free(j->cons);
    free(j->scratch);
    free(j->val);
    sim_plan_free(&j->plan);
    free(j->o.models);
}

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static bnn_model_t *model_alloc(void)
{
    /* bnn_model_t holds 64-byte aligned vectors: malloc's 16 bytes are not enough. */
    return aligned_alloc(_Alignof(bnn_model_t), (sizeof(bnn_model_t) + 63) / 64 * 64);
}

/* Reads checkpoint `file` into j->scratch, set up for the network its header names (the
 * checkpoint is then validated whole by bnn_ckpt_load). 0 or -1 (printed, naming the file). */
static int load_model(job_t *j, const char *file)
{
    FILE *f = NULL;
    int rc = hal_host_file_open_read(file, &f);
    if (rc < 0) {
        fprintf(stderr, "host_sim maps: %s: %s\n", file, hal_host_file_strerror(rc));
        return -1;
    }
    const size_t cap = BNN_CKPT_MAX_BYTES + 1; /* one more: a file too large shows */
    size_t n = fread(j->buf, 1, cap, f);
    const int rerr = ferror(f);
    fclose(f);
    if (rerr) {
        fprintf(stderr, "host_sim maps: %s: read error\n", file);
        return -1;
    }
    if (n == cap) {
        fprintf(stderr, "host_sim maps: %s: larger than any checkpoint of preset '%s' (%zu bytes at most)\n", file,
                BNN_PRESET_NAME, (size_t)BNN_CKPT_MAX_BYTES);
        return -1;
    }
    /* The network the header names, when it is one this preset holds; otherwise the preset's
       own, and bnn_ckpt_load says what is wrong. */
    int ready = 0;
    if (n >= BNN_CKPT_HEADER_BYTES && memcmp(j->buf, "BNNC", 4) == 0 && get32(j->buf + 4) == BNN_CKPT_VERSION) {
        bnn_config_t c = bnn_default_config();
        c.siren_width = get32(j->buf + 16);
        c.hidden_width = get32(j->buf + 20);
        c.n_bayes = get32(j->buf + 24);
        ready = bnn_init(j->scratch, &c, 0) == 0;
    }
    if (!ready && bnn_init(j->scratch, NULL, 0) != 0) {
        fprintf(stderr, "host_sim maps: cannot set up a model of preset '%s'\n", BNN_PRESET_NAME);
        return -1;
    }
    const char *why = NULL;
    if (bnn_ckpt_load_post(j->scratch, j->post_in, j->buf, n, &why) != 0) {
        fprintf(stderr, "host_sim maps: %s: %s\n", file, why ? why : "invalid checkpoint");
        return -1;
    }
    const size_t end = BNN_CKPT_HEADER_BYTES + (size_t)get32(j->buf + 52);
    if (n != end) {
        fprintf(stderr, "host_sim maps: %s: %zu bytes after the end of the checkpoint (%zu bytes)\n", file, n - end,
                end);
        return -1;
    }
    return 0;
}

/* Every model, checked against the first: same network. Their theta go to j->theta. */
static int load_models(job_t *j)
{
    const maps_opts_t *o = &j->o;
    for (int i = 0; i < o->n_models; i++) {
        const char *file = o->models[i];
        if (load_model(j, file) != 0)
            return -1;
        const bnn_model_t *m = j->scratch;
        if (i == 0) {
            j->cfg = m->cfg;
            j->P = bnn_n_params(m);
            j->seed0 = m->seed;
            j->theta = malloc((size_t)o->n_models * j->P * sizeof *j->theta);
            if (j->theta == NULL) {
                fprintf(stderr, "host_sim maps: out of memory for %d models of %zu parameters\n", o->n_models, j->P);
                return -1;
            }
        } else if (bnn_n_params(m) != j->P || m->cfg.siren_width != j->cfg.siren_width ||
                   m->cfg.hidden_width != j->cfg.hidden_width || m->cfg.n_bayes != j->cfg.n_bayes) {
            fprintf(stderr,
                    "host_sim maps: %s: %zu parameters (SIREN %u, hidden %u, %u Bayesian layers), but %s has %zu "
                    "(%u, %u, %u): models of different networks cannot be averaged\n",
                    file, bnn_n_params(m), m->cfg.siren_width, m->cfg.hidden_width, m->cfg.n_bayes, o->models[0],
                    j->P, j->cfg.siren_width, j->cfg.hidden_width, j->cfg.n_bayes);
            return -1;
        }
        memcpy(j->theta + (size_t)i * j->P, bnn_params_const(m), j->P * sizeof *j->theta);
        /* the fleet's posterior: robots' own posteriors (robots 1) are summed, estimates of the
           fleet's (robots > 1, after consensus; consensus.bnn) averaged below */
        if (j->post_in->robots > 0.0) {
            if (j->post_in->robots > 1.0 + 1e-9)
                j->post_shared = 1;
            if (j->n_post == 0)
                *j->post = *j->post_in;
            else if (bnn_post_add(j->post, j->post_in, 1.0) != 0) {
                fprintf(stderr,
                        "host_sim maps: %s: its epistemic posterior is over other features than %s's (a fleet of "
                        "another seed or network)\n",
                        file, o->models[0]);
                return -1;
            }
            j->n_post++;
        }
    }
    if (j->post_shared && bnn_post_scale(j->post, 1.0 / j->n_post) != 0)
        return -1;
    return 0;
}

/* The validation set: the plan's (same bounding box), not empty. */
static int load_valset(job_t *j)
{
    const char *file = j->o.valset;
    sim_samples_header_t h;
    if (sim_samples_read(file, &h, &j->val, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim maps: %s\n", j->err); /* err names the file */
        return -1;
    }
    const sim_plan_t *p = &j->plan;
    if (fabs(h.min_x - p->min.x) > 1e-6 || fabs(h.min_y - p->min.y) > 1e-6 || fabs(h.max_x - p->max.x) > 1e-6 ||
        fabs(h.max_y - p->max.y) > 1e-6) {
        fprintf(stderr, "host_sim maps: %s: its bounding box is not the plan's (another plan?)\n", file);
        return -1;
    }
    if (h.count == 0) {
        fprintf(stderr, "host_sim maps: %s holds no samples\n", file);
        return -1;
    }
    j->n_val = (size_t)h.count;
    return 0;
}

/* DIR/NAME into out (PATH_MAX bytes). */
static int out_path(const char *dir, const char *name, char *out)
{
    const size_t n = strlen(dir);
    const int m = snprintf(out, PATH_MAX, "%s%s%s", dir, n > 0 && dir[n - 1] == '/' ? "" : "/", name);
    if (m < 0 || m >= PATH_MAX) {
        fprintf(stderr, "host_sim maps: %s/%s: %s\n", dir, name, strerror(ENAMETOOLONG));
        return -1;
    }
    return 0;
}

/* Plan, models, validation set, output folder: everything checked before any work. */
static int prepare(job_t *j)
{
    const maps_opts_t *o = &j->o;
    if (sim_plan_load(o->plan, o->scale, &j->plan, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim maps: %s\n", j->err);
        return -1;
    }
    const double w = ceil((j->plan.max.x - j->plan.min.x) / o->res), h = ceil((j->plan.max.y - j->plan.min.y) / o->res);
    if (w * h > MAPS_MAX_CELLS) {
        fprintf(stderr, "host_sim maps: --res %g gives %.0f x %.0f cells over the plan, more than %u: use a larger --res\n",
                o->res, w, h, MAPS_MAX_CELLS);
        return -1;
    }
    for (int k = 0; k < OUT_N; k++)
        if (out_path(o->out, out_names[k], j->path[k]) != 0)
            return -1;
    if (out_path(o->out, "map_mean.png", j->png_mean) != 0 || out_path(o->out, "map_std.png", j->png_std) != 0 ||
        out_path(o->out, "map_epistemic.png", j->png_epi) != 0)
        return -1;
    j->scratch = model_alloc();
    j->cons = model_alloc();
    j->buf = malloc(BNN_CKPT_MAX_BYTES + 1);
    j->post_in = malloc(sizeof *j->post_in);
    j->post = malloc(sizeof *j->post);
    if (j->scratch == NULL || j->cons == NULL || j->buf == NULL || j->post_in == NULL || j->post == NULL) {
        fprintf(stderr, "host_sim maps: out of memory\n");
        return -1;
    }
    if (load_models(j) != 0)
        return -1;
    if (o->valset && load_valset(j) != 0)
        return -1;
    return cmd_prepare_out_dir("maps", o->out);
}

/* The ground truth at the map's cell centres (sim_plan_classify_point): 0 free, 1 wall, 255
 * outside the building; what the map is scored against (map_truth.npy). */
static int compute_truth(job_t *j)
{
    const sim_maps_grid_t *g = &j->mc;
    j->truth = malloc((size_t)g->w * g->h);
    if (j->truth == NULL) {
        fprintf(stderr, "host_sim maps: out of memory\n");
        return -1;
    }
    for (int r = 0; r < g->h; r++)
        for (int c = 0; c < g->w; c++) {
            const int cls = sim_plan_classify_point(&j->plan, g->x0 + (c + 0.5) * g->res, g->y0 + (r + 0.5) * g->res);
            j->truth[(size_t)r * g->w + c] = cls == SIM_CELL_WALL ? 1 : cls == SIM_CELL_FREE ? 0 : 255;
        }
    return 0;
}

/* ROS map_server's customary thresholds, used without a validation set. */
#define ROS_OCCUPIED_DEFAULT "0.65"
#define ROS_FREE_DEFAULT "0.196"

/* map.yaml's thresholds: chosen on the validation set (the map's own values, the MC mean of
 * the same passes, at its points), else the defaults. The values are the text written, read
 * back, so everything scored below is what nav2 reads. */
static int choose_thresholds(job_t *j)
{
    const maps_opts_t *o = &j->o;
    snprintf(j->th_occ, sizeof j->th_occ, ROS_OCCUPIED_DEFAULT);
    snprintf(j->th_free, sizeof j->th_free, ROS_FREE_DEFAULT);
    snprintf(j->th_note, sizeof j->th_note, "no validation set given");
    if (j->n_val > 0) {
        float *xy = malloc(j->n_val * 2 * sizeof *xy);
        j->val_p = malloc(j->n_val * sizeof *j->val_p);
        if (xy == NULL || j->val_p == NULL) {
            free(xy);
            fprintf(stderr, "host_sim maps: out of memory for %zu validation points\n", j->n_val);
            return -1;
        }
        for (size_t i = 0; i < j->n_val; i++) {
            xy[2 * i] = j->val[i].x;
            xy[2 * i + 1] = j->val[i].y;
        }
        const int rc = bnn_predict_mc(j->cons, xy, j->n_val, (uint32_t)o->mc, (uint64_t)o->seed, j->val_p, NULL);
        free(xy);
        if (rc != 0) {
            fprintf(stderr, "host_sim maps: MC prediction at the validation points failed (%d)\n", rc);
            return -1;
        }
        if (sim_maps_choose_thresholds(j->val_p, j->val, j->n_val, &j->th) == 0) {
            j->th_chosen = 1;
            /* Half-way between two levels (1/510 from each): 4 decimals keep it there. */
            snprintf(j->th_occ, sizeof j->th_occ, "%.4f", j->th.occupied);
            snprintf(j->th_free, sizeof j->th_free, "%.4f", j->th.free_thresh);
        } else {
            snprintf(j->th_note, sizeof j->th_note, "the validation set's points are all %s",
                     j->val[0].occ >= 0.5f ? "lidar hits" : "free");
        }
    }
    j->occ_thresh = strtod(j->th_occ, NULL);
    j->free_thresh = strtod(j->th_free, NULL);
    return 0;
}

/* The map as nav2's map_io reads map.pgm with these thresholds (trinary, negate 0), against
 * the ground truth: wall IoU over the building's cells (occupied vs wall), and the share of
 * the building's free cells truly free. */
static int score_nav2(job_t *j)
{
    const sim_maps_grid_t *g = &j->mc;
    const size_t n = (size_t)g->w * g->h;
    for (size_t i = 0; i < n; i++) {
        const int px = sim_maps_pgm_pixel(g->mean[i]);
        const double occ = (255 - px) / 255.0; /* map_io: 1 - shade */
        j->level_max = fmax(j->level_max, occ);
        const int t = j->truth[i];
        j->nav_walls += t == 1;
        if (j->occ_thresh < occ) {
            j->nav_occ++;
            j->nav_occ_known += t != 255;
            j->nav_occ_wall += t == 1;
        } else if (occ < j->free_thresh) {
            j->nav_free++;
            j->nav_free_known += t != 255;
            j->nav_free_free += t == 0;
        } else {
            j->nav_unknown++;
        }
    }
    const size_t uni = j->nav_occ_known + j->nav_walls - j->nav_occ_wall;
    j->wall_iou = uni > 0 ? (double)j->nav_occ_wall / (double)uni : 0.0;
    j->free_precision = j->nav_free_known > 0 ? (double)j->nav_free_free / (double)j->nav_free_known : NAN;
    return 0;
}

/* Consensus model, consensus errors, validation losses, maps. */
static int compute(job_t *j)
{
    const maps_opts_t *o = &j->o;
    const int N = o->n_models;
    const size_t P = j->P;
    j->mean = calloc(P, sizeof *j->mean);
    j->cerr = calloc((size_t)N, sizeof *j->cerr);
    j->val_loss = malloc(((size_t)N + 1) * sizeof *j->val_loss);
    if (j->mean == NULL || j->cerr == NULL || j->val_loss == NULL) {
        fprintf(stderr, "host_sim maps: out of memory\n");
        return -1;
    }
    for (int i = 0; i < N; i++)
        for (size_t p = 0; p < P; p++)
            j->mean[p] += j->theta[(size_t)i * P + p];
    for (size_t p = 0; p < P; p++)
        j->mean[p] /= N;
    if (bnn_init(j->cons, &j->cfg, j->seed0) != 0) {
        fprintf(stderr, "host_sim maps: cannot set up the consensus model\n");
        return -1;
    }
    float *ct = bnn_params(j->cons);
    for (size_t p = 0; p < P; p++)
        ct[p] = (float)j->mean[p];
    /* ||theta_i - mean|| / ||mean||, as sim_fleet_consensus_error. */
    for (int i = 0; i < N; i++) {
        double num = 0.0, den = 0.0;
        for (size_t p = 0; p < P; p++) {
            const double d = j->theta[(size_t)i * P + p] - j->mean[p];
            num += d * d;
            den += j->mean[p] * j->mean[p];
        }
        j->cerr[i] = den > 0.0 ? sqrt(num / den) : 0.0;
    }
    for (int i = 0; i <= N; i++) {
        j->val_loss[i] = NAN;
        if (j->n_val == 0)
            continue;
        bnn_model_t *m = j->cons;
        if (i < N) {
            m = j->scratch; /* holds the last model's network: every model's */
            memcpy(bnn_params(m), j->theta + (size_t)i * P, P * sizeof(float));
        }
        if (bnn_eval_bce(m, j->val, j->n_val, 0, 0, &j->val_loss[i]) != 0) {
            fprintf(stderr, "host_sim maps: validation loss of %s failed\n", i < N ? o->models[i] : "the consensus");
            return -1;
        }
    }
    if (sim_maps_compute(j->cons, &j->plan, o->res, (uint32_t)o->mc, (uint64_t)o->seed, &j->mc, j->err,
                         sizeof j->err) != 0 ||
        sim_maps_compute(j->cons, &j->plan, o->res, 1, (uint64_t)o->seed, &j->single, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim maps: maps: %s\n", j->err);
        return -1;
    }
    if (j->n_post > 0) {
        j->epi = malloc((size_t)j->mc.w * j->mc.h * sizeof *j->epi);
        if (j->epi == NULL || sim_maps_epistemic(j->cons, j->post, &j->plan, &j->mc, j->epi, j->err, sizeof j->err) != 0) {
            fprintf(stderr, "host_sim maps: epistemic map: %s\n", j->epi ? j->err : "out of memory");
            return -1;
        }
    }
    return compute_truth(j) == 0 && choose_thresholds(j) == 0 ? score_nav2(j) : -1;
}

/* Shortest text that reads back as the same double (or float, with is_float). */
static void fmt_num(char *out, size_t cap, double v, int is_float)
{
    if (!isfinite(v)) {
        snprintf(out, cap, "nan");
        return;
    }
    for (int prec = 1; prec <= 17; prec++) {
        snprintf(out, cap, "%.*g", prec, v);
        if (is_float ? strtof(out, NULL) == (float)v : strtod(out, NULL) == v)
            return;
    }
}

/* A growing text buffer. */
typedef struct text {
    char *s;
    size_t len, cap;
    int failed;
} text_t;

__attribute__((format(printf, 2, 3))) static void tprintf(text_t *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (t->failed || n < 0) {
        t->failed = 1;
        return;
    }
    if (t->len + (size_t)n + 1 > t->cap) {
        size_t cap = (t->len + (size_t)n + 1) * 2;
        char *s = realloc(t->s, cap);
        if (s == NULL) {
            t->failed = 1;
            return;
        }
        t->s = s;
        t->cap = cap;
    }
    va_start(ap, fmt);
    vsnprintf(t->s + t->len, t->cap - t->len, fmt, ap);
    va_end(ap);
    t->len += (size_t)n;
}

/* A CSV field: quoted when it holds a comma, a quote or a line break (RFC 4180). */
static void csv_field(text_t *t, const char *s)
{
    if (strpbrk(s, ",\"\r\n") == NULL) {
        tprintf(t, "%s", s);
        return;
    }
    tprintf(t, "\"");
    for (const char *p = s; *p; p++) {
        if (*p == '"')
            tprintf(t, "\"\"");
        else
            tprintf(t, "%c", *p);
    }
    tprintf(t, "\"");
}

/* Starts output k and writes its bytes (charged at once to the writer). 0 or -1 (printed). */
static int stage(job_t *j, int k, const void *data, size_t len)
{
    if (cmd_out_begin("maps", &j->out[k], j->path[k]) != 0)
        return -1;
    j->begun[k] = 1;
    int rc = hal_host_file_write(&j->out[k], data, len);
    if (rc == 0 && fflush(hal_host_file_stream(&j->out[k])) != 0)
        rc = errno ? -errno : -EIO;
    if (rc < 0) {
        fprintf(stderr, "host_sim maps: %s: %s\n", j->path[k], hal_host_file_strerror(rc));
        return -1;
    }
    return 0;
}

static int stage_text(job_t *j, int k, text_t *t)
{
    if (t->failed) {
        fprintf(stderr, "host_sim maps: %s: out of memory\n", j->path[k]);
        return -1;
    }
    return stage(j, k, t->s, t->len);
}

static void put_le32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

/* A NumPy array (format 1.0, C order) of the grid's cells, H x W, row 0 the top (largest y):
 * the grid's rows reversed. float32 ('<f4') from `cells`, or uint8 ('|u1') from `bytes`. */
static int stage_npy(job_t *j, int k, const sim_maps_grid_t *g, const float *cells, const uint8_t *bytes)
{
    char dict[128];
    const size_t esize = bytes ? 1 : 4;
    int dn = snprintf(dict, sizeof dict, "{'descr': '%s', 'fortran_order': False, 'shape': (%d, %d), }",
                      bytes ? "|u1" : "<f4", g->h, g->w);
    /* magic (6) + version (2) + header length (2) + dict padded with spaces and a '\n' to a
       multiple of 64 bytes */
    size_t head = 10 + (size_t)dn + 1;
    head = (head + 63) / 64 * 64;
    const size_t n = (size_t)g->w * g->h, len = head + esize * n;
    uint8_t *b = malloc(len);
    if (b == NULL) {
        fprintf(stderr, "host_sim maps: %s: out of memory\n", j->path[k]);
        return -1;
    }
    memcpy(b, "\x93NUMPY\x01\x00", 8);
    b[8] = (uint8_t)((head - 10) & 0xFF);
    b[9] = (uint8_t)((head - 10) >> 8);
    memset(b + 10, ' ', head - 10);
    memcpy(b + 10, dict, (size_t)dn);
    b[head - 1] = '\n';
    uint8_t *d = b + head;
    for (int R = 0; R < g->h; R++)
        for (int c = 0; c < g->w; c++) {
            const size_t at = (size_t)(g->h - 1 - R) * g->w + c;
            if (bytes) {
                *d++ = bytes[at];
                continue;
            }
            uint32_t u;
            memcpy(&u, &cells[at], 4);
            put_le32(d, u);
            d += 4;
        }
    const int rc = stage(j, k, b, len);
    free(b);
    return rc;
}

/* map_truth.npy: the ground truth at the map's cell centres (compute_truth). */
static int stage_truth(job_t *j)
{
    return stage_npy(j, OUT_TRUTH, &j->mc, NULL, j->truth);
}

/* map.pgm: binary P5, W x H, first row the top; pixel = round(255 (1 - mean)). */
static int stage_pgm(job_t *j)
{
    const sim_maps_grid_t *g = &j->mc;
    char head[64];
    const int hn = snprintf(head, sizeof head, "P5\n%d %d\n255\n", g->w, g->h);
    const size_t n = (size_t)g->w * g->h;
    uint8_t *b = malloc((size_t)hn + n);
    if (b == NULL) {
        fprintf(stderr, "host_sim maps: %s: out of memory\n", j->path[OUT_PGM]);
        return -1;
    }
    memcpy(b, head, (size_t)hn);
    uint8_t *d = b + hn;
    for (int R = 0; R < g->h; R++)
        for (int c = 0; c < g->w; c++)
            *d++ = sim_maps_pgm_pixel(g->mean[(size_t)(g->h - 1 - R) * g->w + c]);
    const int rc = stage(j, OUT_PGM, b, (size_t)hn + n);
    free(b);
    return rc;
}

/* A share as "98.5 %" ("none" when there is no share: no free cell). */
typedef struct pct {
    char s[32];
} pct_t;

static pct_t fp_pct(double v)
{
    pct_t p;
    if (isfinite(v))
        snprintf(p.s, sizeof p.s, "%.1f %%", 100.0 * v);
    else
        snprintf(p.s, sizeof p.s, "none");
    return p;
}

/* Every output but the PNGs written to its temporary file; nothing replaced yet. */
static int stage_all(job_t *j)
{
    const maps_opts_t *o = &j->o;
    const sim_maps_grid_t *g = &j->mc;
    const int N = o->n_models;
    size_t nb = 0;
    if (bnn_ckpt_save_post(j->cons, 0, j->epi ? j->post : NULL, j->buf, BNN_CKPT_MAX_BYTES + 1, &nb) != 0) {
        fprintf(stderr, "host_sim maps: %s: cannot serialise the consensus model\n", j->path[OUT_BNN]);
        return -1;
    }
    if (stage(j, OUT_BNN, j->buf, nb) != 0)
        return -1;
    char a[64], b[64], c[64], d[64];
    text_t t = {0};
    tprintf(&t, "model,file,val_loss,consensus_error\n");
    for (int i = 0; i <= N; i++) {
        if (i < N)
            tprintf(&t, "%d,", i);
        else
            tprintf(&t, "consensus,");
        /* The models as given; the consensus by its name in the folder of this file. */
        csv_field(&t, i < N ? o->models[i] : out_names[OUT_BNN]);
        fmt_num(a, sizeof a, j->val_loss[i], 1);
        fmt_num(b, sizeof b, i < N ? j->cerr[i] : 0.0, 0);
        tprintf(&t, ",%s,%s\n", a, b);
    }
    int rc = stage_text(j, OUT_CSV, &t);
    free(t.s);
    if (rc != 0 || stage_npy(j, OUT_MEAN, g, g->mean, NULL) != 0 || stage_npy(j, OUT_STD, g, g->std, NULL) != 0 ||
        stage_npy(j, OUT_SINGLE, &j->single, j->single.mean, NULL) != 0 || stage_truth(j) != 0 ||
        (j->epi && stage_npy(j, OUT_EPI, g, j->epi, NULL) != 0))
        return -1;
    const double xmax = g->x0 + g->w * g->res, ymax = g->y0 + g->h * g->res;
    char e[64], f[64];
    fmt_num(a, sizeof a, g->res, 0);
    fmt_num(b, sizeof b, g->x0, 0);
    fmt_num(c, sizeof c, g->y0, 0);
    fmt_num(d, sizeof d, xmax, 0);
    fmt_num(e, sizeof e, ymax, 0);
    fmt_num(f, sizeof f, sim_maps_std_max(g), 0);
    char iou[64], fp[64];
    fmt_num(iou, sizeof iou, j->wall_iou, 0);
    fmt_num(fp, sizeof fp, j->free_precision, 0);
    t = (text_t){0};
    tprintf(&t,
            "{\"res\": %s, \"xmin\": %s, \"ymin\": %s, \"xmax\": %s, \"ymax\": %s, \"width\": %d, \"height\": %d, "
            "\"mc\": %lld, \"seed\": %lld, \"std_max\": %s, \"models\": %d, \"occupied_thresh\": %s, "
            "\"free_thresh\": %s, \"thresholds\": \"%s\", \"nav2_occupied\": %zu, \"nav2_free\": %zu, "
            "\"nav2_unknown\": %zu, \"nav2_wall_iou\": %s, \"nav2_free_truly_free\": %s, \"epistemic\": ",
            a, b, c, d, e, g->w, g->h, o->mc, o->seed, f, N, j->th_occ, j->th_free,
            j->th_chosen ? "valset" : "default", j->nav_occ, j->nav_free, j->nav_unknown, iou,
            isfinite(j->free_precision) ? fp : "null");
    if (j->epi)
        tprintf(&t,
                "{\"file\": \"map_epistemic.npy\", \"method\": \"bayesian linear read-out of the SIREN features\", "
                "\"value\": \"share of the prior variance left\", \"models_with_posterior\": %d, \"robots\": %.6g, "
                "\"observations\": %.17g, \"prior_precision\": %g, \"obs_precision\": %g, \"png_floor\": %g}}\n",
                j->n_post, j->post->robots, j->post->n_obs, BNN_POST_LAMBDA0, BNN_POST_BETA, SIM_MAPS_EPI_FLOOR);
    else
        tprintf(&t, "null}\n");
    rc = stage_text(j, OUT_META, &t);
    free(t.s);
    if (rc != 0 || stage_pgm(j) != 0)
        return -1;
    t = (text_t){0};
    tprintf(&t, "image: map.pgm\nmode: trinary\nresolution: %s\norigin: [%s, %s, 0.0]\nnegate: 0\n", a, b, c);
    if (j->th_chosen)
        tprintf(&t,
                "# occupied_thresh and free_thresh chosen on the validation set (%zu points, %zu lidar hits) for\n"
                "# this map's values there (MC mean of %lld passes, seed %lld): occupied_thresh has the best F1 of\n"
                "# the hits, %.3f; free_thresh the best F1 of the free points below it, %.3f.\n",
                j->th.n, j->th.n_hit, o->mc, o->seed, j->th.occ_f1, j->th.free_f1);
    else
        tprintf(&t,
                "# occupied_thresh and free_thresh: ROS map_server's defaults (%s; with one,\n"
                "# host_sim maps --valset chooses them for the model). This map's largest occupancy is %.3f.\n",
                j->th_note, j->level_max);
    tprintf(&t,
            "# As nav2 reads it: %zu occupied, %zu free, %zu unknown cells; against the plan's ground truth\n"
            "# (map_truth.npy) wall IoU %.3f, %s of the free cells truly free.\n",
            j->nav_occ, j->nav_free, j->nav_unknown, j->wall_iou, fp_pct(j->free_precision).s);
    tprintf(&t, "occupied_thresh: %s\nfree_thresh: %s\n", j->th_occ, j->th_free);
    rc = stage_text(j, OUT_YAML, &t);
    free(t.s);
    return rc;
}

/* The outputs: staged whole first, then the PNGs, then each staged file renamed over its
 * target. A failure before the renames replaces nothing. */
static int write_outputs(job_t *j)
{
    if (stage_all(j) != 0)
        return -1;
    if (sim_maps_write_png(&j->mc, &j->plan, NULL, 0, j->png_mean, j->png_std, NULL, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim maps: %s\n", j->err);
        return -1;
    }
    if (j->epi && sim_maps_write_epistemic_png(&j->mc, j->epi, &j->plan, NULL, 0, j->png_epi, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim maps: %s\n", j->err);
        return -1;
    }
    for (int k = 0; k < OUT_N; k++)
        if (j->begun[k] && cmd_out_commit("maps", &j->out[k]) != 0)
            return -1;
    if (!j->epi) { /* no posterior in the models: an earlier run's epistemic map would mislead */
        (void)remove(j->path[OUT_EPI]);
        (void)remove(j->png_epi);
    }
    return 0;
}

static void report(const job_t *j)
{
    const maps_opts_t *o = &j->o;
    const sim_maps_grid_t *g = &j->mc;
    printf("maps: %d model(s) of %zu parameters (preset %s), plan %s\n", o->n_models, j->P, BNN_PRESET_NAME,
           o->plan);
    printf("%-10s %10s %16s  %s\n", "model", "val_loss", "consensus_error", "file");
    for (int i = 0; i <= o->n_models; i++) {
        char idx[16];
        snprintf(idx, sizeof idx, "%d", i);
        printf("%-10s %10.5f %16.6g  %s\n", i < o->n_models ? idx : "consensus", (double)j->val_loss[i],
               i < o->n_models ? j->cerr[i] : 0.0, i < o->n_models ? o->models[i] : j->path[OUT_BNN]);
    }
    printf("map: %d x %d cells of %g m over x [%g, %g], y [%g, %g]; %lld MC passes (seed %lld), max std %.4f\n",
           g->w, g->h, g->res, g->x0, g->x0 + g->w * g->res, g->y0, g->y0 + g->h * g->res, o->mc, o->seed,
           sim_maps_std_max(g));
    if (j->th_chosen)
        printf("map.yaml: occupied_thresh %s (validation set: best F1 of the %zu lidar hits, %.3f), free_thresh %s "
               "(best F1 of the free points below it, %.3f)\n",
               j->th_occ, j->th.n_hit, j->th.occ_f1, j->th_free, j->th.free_f1);
    else
        printf("map.yaml: occupied_thresh %s, free_thresh %s: ROS map_server's defaults (%s); the map's largest "
               "occupancy is %.3f%s\n",
               j->th_occ, j->th_free, j->th_note, j->level_max,
               j->nav_occ == 0 ? ": NO cell is occupied, the map has no walls (--valset chooses thresholds that fit "
                                 "the model)"
                               : "");
    printf("map.yaml as nav2 reads it: %zu occupied, %zu free, %zu unknown cells; against the ground truth: wall IoU "
           "%.3f, %s of the free cells truly free\n",
           j->nav_occ, j->nav_free, j->nav_unknown, j->wall_iou, fp_pct(j->free_precision).s);
    if (j->epi) {
        double known = 0.0;
        for (size_t i = 0; i < (size_t)g->w * g->h; i++)
            known += j->epi[i] < SIM_MAPS_EPI_KNOWN;
        printf("epistemic: the posterior of %d model(s) (%.6g robots' data, %.0f observations); %.1f %% of the map's "
               "cells keep less than %g of their prior variance (known)%s\n",
               j->n_post, j->post->robots, j->post->n_obs, 100.0 * known / ((double)g->w * g->h), SIM_MAPS_EPI_KNOWN,
               j->n_post < o->n_models ? "; the other models carry none" : "");
    } else {
        printf("epistemic: none of the models carries a posterior (checkpoints of an older fleetsim or of a round "
               "before the last): no map_epistemic.npy\n");
    }
    printf("results in %s: consensus.bnn consensus.csv map_mean.npy map_std.npy map_single.npy map_truth.npy map_meta.json "
           "map.pgm map.yaml map_mean.png map_std.png%s\n",
           o->out, j->epi ? " map_epistemic.npy map_epistemic.png" : "");
}

int cmd_maps(int argc, char **argv)
{
    static job_t job; /* one run per process */
    job_t *j = &job;
    memset(j, 0, sizeof *j);
    const int pr = maps_parse(argc, argv, &j->o);
    if (pr != 0) {
        free(j->o.models);
        return pr > 0 ? 0 : 2;
    }
    const int ok = prepare(j) == 0 && compute(j) == 0 && write_outputs(j) == 0;
    if (ok)
        report(j);
    job_free(j);
    return ok ? 0 : 1;
}
