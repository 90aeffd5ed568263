/* host_sim maps, run as a subprocess on checkpoints made here (bnn_init + bnn_ckpt_save):
 * the consensus of one model is that model bit for bit; of two, the element-wise mean with
 * the consensus errors of sim_fleet; the .npy arrays, map_meta.json, map.pgm and map.yaml
 * agree with each other and with sim_maps_compute on the consensus model (row 0 the top);
 * bad inputs (corrupt, truncated or mismatched checkpoints, a bad validation set, bad
 * options, a full disk) exit non-zero with a clear message and leave an earlier output
 * folder byte for byte as it was. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <cmocka.h>

#include "png_read.h"
#include "run_outputs.h"

#include "ai/ai_rng.h"
#include "ai/bnn.h"
#include "ai/bnn_ckpt.h"
#include "ai/bnn_post.h"
#include "sim_grid.h"
#include "sim_maps.h"
#include "sim_palette.h"
#include "sim_plan.h"
#include "sim_samples.h"

#define SHORT_PATH 1024
static char g_bin[SHORT_PATH]; /* build/<config>/bin/host_sim */
static char g_dir[SHORT_PATH]; /* scratch folder of this test */
static char g_plan[PATH_MAX];  /* host_sim/plans/apartment.svg */
static char g_a[PATH_MAX], g_b[PATH_MAX], g_other[PATH_MAX], g_val[PATH_MAX];
static char g_err[1 << 16]; /* stderr of the last run */
static char g_out[1 << 16]; /* stdout of the last run */

static bnn_model_t g_ma, g_mb, g_mo, g_load; /* too large for the stack */

/* Runs host_sim with args (NULL-terminated; args[0] ignored), optionally with the disk-full
 * seam; returns the exit status and keeps stdout and stderr. */
static int hs(long fail_after, const char *const *args)
{
    return test_run(g_bin, args, fail_after, g_dir, g_err, g_out, sizeof g_err);
}

#define HS(fail, ...) hs((fail), (const char *const[]){"host_sim", __VA_ARGS__, NULL})
#define HS_OK(...)                                                                           \
    do {                                                                                     \
        int rc_ = HS(-1, __VA_ARGS__);                                                       \
        if (rc_ != 0)                                                                        \
            fail_msg("host_sim exited %d:\n%s", rc_, g_err);                                 \
    } while (0)

static void path_in(char *out, const char *name)
{
    assert_true(strlen(name) < 64);
    snprintf(out, PATH_MAX, "%.1023s/%.63s", g_dir, name);
}

/* DIR/NAME */
static void path_at(char *out, const char *dir, const char *name)
{
    assert_true(strlen(dir) + strlen(name) + 2 < PATH_MAX);
    snprintf(out, PATH_MAX, "%s/%s", dir, name);
}


static void spit(const char *p, const void *data, size_t n)
{
    FILE *f = fopen(p, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

static void expect_err(const char *a, const char *b)
{
    if (strstr(g_err, a) == NULL || (b != NULL && strstr(g_err, b) == NULL))
        fail_msg("stderr lacks '%s'%s%s:\n%s", a, b ? " / " : "", b ? b : "", g_err);
}

static void save_model(const bnn_model_t *m, int with_adam, const char *path)
{
    static uint8_t buf[BNN_CKPT_MAX_BYTES];
    size_t n = 0;
    assert_int_equal(bnn_ckpt_save(m, with_adam, buf, sizeof buf, &n), 0);
    spit(path, buf, n);
}

/* Loads a checkpoint file of the preset's default network into g_load. */
static void load_model(const char *path)
{
    size_t n = 0;
    uint8_t *b = test_slurp(path, &n);
    assert_non_null(b);
    assert_int_equal(bnn_init(&g_load, NULL, 0), 0);
    const char *why = NULL;
    if (bnn_ckpt_load(&g_load, b, n, &why) != 0)
        fail_msg("%s: %s", path, why);
    free(b);
}

static int setup(void **st)
{
    (void)st;
    test_build_program("host_sim", g_bin, sizeof g_bin);
    snprintf(g_dir, sizeof g_dir, "/tmp/fleetsim-maps-XXXXXX");
    assert_non_null(mkdtemp(g_dir));
    assert_non_null(realpath("host_sim/plans/apartment.svg", g_plan));
    assert_true(strlen(g_plan) < SHORT_PATH);
    /* Two models of the preset (different seeds, one trained a step so its Adam state is
       saved too) and one of another network. */
    assert_int_equal(bnn_init(&g_ma, NULL, 11), 0);
    assert_int_equal(bnn_init(&g_mb, NULL, 22), 0);
    ai_sample_t batch[4] = {{-0.5f, -0.5f, 0.0f}, {0.5f, 0.5f, 1.0f}, {0.1f, -0.3f, 0.0f}, {-0.2f, 0.7f, 1.0f}};
    assert_int_equal(bnn_train_step(&g_ma, batch, 4, 1e-4f, 1, 1e-3f, NULL), 0);
    bnn_config_t c = bnn_default_config();
    c.hidden_width = c.hidden_width > 1 ? c.hidden_width / 2 : 2;
    assert_int_equal(bnn_init(&g_mo, &c, 33), 0);
    path_in(g_a, "a.bnn");
    path_in(g_b, "b.bnn");
    path_in(g_other, "other.bnn");
    save_model(&g_ma, 1, g_a);
    save_model(&g_mb, 0, g_b);
    save_model(&g_mo, 0, g_other);
    path_in(g_val, "val.samples");
    HS_OK("valset", "--plan", g_plan, "--out", g_val, "--poses", "3");
    return 0;
}

static int teardown(void **st)
{
    (void)st;
    return test_remove_tree(g_dir);
}

/* consensus.csv: fills val_loss and consensus_error of row `row` (N = the consensus row);
 * checks the header and the row's first two fields. */
static void csv_row(const char *dir, int row, const char *file, double *val, double *cerr)
{
    char p[PATH_MAX];
    path_at(p, dir, "consensus.csv");
    size_t n = 0;
    char *t = (char *)test_slurp(p, &n);
    assert_non_null(t);
    assert_true(strncmp(t, "model,file,val_loss,consensus_error\n", 36) == 0);
    char *line = t + 36;
    for (int r = 0; r < row; r++) {
        line = strchr(line, '\n');
        assert_non_null(line);
        line++;
    }
    char *end = strchr(line, '\n');
    assert_non_null(end);
    *end = '\0';
    char want[PATH_MAX + 32];
    if (file != NULL)
        snprintf(want, sizeof want, "%d,%s,", row, file);
    else
        snprintf(want, sizeof want, "consensus,consensus.bnn,"); /* in DIR, as consensus.csv */
    if (strncmp(line, want, strlen(want)) != 0)
        fail_msg("row %d is '%s', expected it to start with '%s'", row, line, want);
    char *c2 = strrchr(line, ',');
    *c2 = '\0';
    char *c1 = strrchr(line, ',');
    *val = strtod(c1 + 1, NULL);
    *cerr = strtod(c2 + 1, NULL);
    free(t);
}

static double json_num(const char *json, const char *key)
{
    char k[64];
    snprintf(k, sizeof k, "\"%s\": ", key);
    const char *p = strstr(json, k);
    if (p == NULL)
        fail_msg("map_meta.json lacks %s: %s", key, json);
    char *end = NULL;
    double v = strtod(p + strlen(k), &end);
    assert_true(end != p + strlen(k));
    return v;
}

/* A float32 .npy file of format 1.0: its shape and (malloc'd) cells. */
static float *read_npy(const char *path, int *h, int *w)
{
    size_t n = 0;
    uint8_t *b = test_slurp(path, &n);
    if (b == NULL)
        fail_msg("%s missing", path);
    assert_true(n >= 10 && memcmp(b, "\x93NUMPY\x01\x00", 8) == 0);
    const size_t hl = (size_t)b[8] | (size_t)b[9] << 8;
    assert_true((10 + hl) % 64 == 0 && 10 + hl <= n && b[10 + hl - 1] == '\n');
    char head[1024];
    assert_true(hl < sizeof head);
    memcpy(head, b + 10, hl);
    head[hl] = '\0';
    assert_non_null(strstr(head, "'descr': '<f4'"));
    assert_non_null(strstr(head, "'fortran_order': False"));
    const char *s = strstr(head, "'shape': (");
    assert_non_null(s);
    assert_int_equal(sscanf(s, "'shape': (%d, %d)", h, w), 2);
    assert_true(*h > 0 && *w > 0);
    assert_int_equal(n, 10 + hl + 4 * (size_t)*h * *w);
    float *v = malloc(4 * (size_t)*h * *w);
    assert_non_null(v);
    for (size_t i = 0; i < (size_t)*h * *w; i++) {
        const uint8_t *q = b + 10 + hl + 4 * i;
        uint32_t u = (uint32_t)q[0] | (uint32_t)q[1] << 8 | (uint32_t)q[2] << 16 | (uint32_t)q[3] << 24;
        memcpy(&v[i], &u, 4);
    }
    free(b);
    return v;
}

static void test_help_and_usage_errors(void **st)
{
    (void)st;
    char out[PATH_MAX];
    path_in(out, "usage");
    assert_int_equal(HS(-1, "maps", "--help"), 0);
    assert_non_null(strstr(g_out, "usage: host_sim maps"));
    assert_non_null(strstr(g_out, "--valset"));
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--bogus", "x", g_a), 2);
    expect_err("unknown option '--bogus'", NULL);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, g_a, "--bogus"), 2);
    expect_err("unknown option '--bogus'", NULL);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, g_a, "--out"), 2);
    expect_err("option --out needs a value", NULL);
    assert_int_equal(HS(-1, "maps", "--out", out, g_a), 2);
    expect_err("--plan is required", NULL);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, g_a), 2);
    expect_err("--out is required", NULL);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out), 2);
    expect_err("no MODEL.bnn given", NULL);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--mc", "0", g_a), 2);
    expect_err("--mc", NULL);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "abc", g_a), 2);
    expect_err("--res", NULL);
    struct stat sb;
    assert_true(stat(out, &sb) != 0); /* nothing was created */
}

static void test_one_model_is_its_own_consensus(void **st)
{
    (void)st;
    char out[PATH_MAX], p[PATH_MAX];
    path_in(out, "one");
    HS_OK("maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", g_a);
    assert_non_null(strstr(g_out, "consensus"));
    path_at(p, out, "consensus.bnn");
    load_model(p);
    assert_int_equal(bnn_n_params(&g_load), bnn_n_params(&g_ma));
    assert_memory_equal(bnn_params_const(&g_load), bnn_params_const(&g_ma), bnn_n_params(&g_ma) * sizeof(float));
    assert_true(g_load.seed == g_ma.seed);
    assert_int_equal(g_load.adam[BNN_GROUP_MU].t, 0); /* no optimiser state */
    double val = 0, cerr = -1;
    csv_row(out, 0, g_a, &val, &cerr);
    assert_true(isnan(val));
    assert_true(cerr == 0.0);
    csv_row(out, 1, NULL, &val, &cerr);
    assert_true(isnan(val) && cerr == 0.0);
}

static void test_two_models_mean_and_errors(void **st)
{
    (void)st;
    char out[PATH_MAX], p[PATH_MAX];
    path_in(out, "two");
    HS_OK("maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", "--seed", "5", "--valset", g_val,
          g_a, g_b);
    path_at(p, out, "consensus.bnn");
    load_model(p);
    const size_t P = bnn_n_params(&g_ma);
    const float *a = bnn_params_const(&g_ma), *b = bnn_params_const(&g_mb), *c = bnn_params_const(&g_load);
    double num_a = 0, num_b = 0, den = 0;
    for (size_t i = 0; i < P; i++) {
        const double m = ((double)a[i] + (double)b[i]) / 2.0;
        if (c[i] != (float)m)
            fail_msg("theta[%zu] = %.9g, mean %.9g", i, (double)c[i], m);
        num_a += (a[i] - m) * (a[i] - m);
        num_b += (b[i] - m) * (b[i] - m);
        den += m * m;
    }
    double val[3], cerr[3];
    csv_row(out, 0, g_a, &val[0], &cerr[0]);
    csv_row(out, 1, g_b, &val[1], &cerr[1]);
    csv_row(out, 2, NULL, &val[2], &cerr[2]);
    assert_true(cerr[0] > 0.0 && fabs(cerr[0] - sqrt(num_a / den)) <= 1e-12 * cerr[0]);
    assert_true(fabs(cerr[1] - sqrt(num_b / den)) <= 1e-12 * cerr[1]);
    assert_true(cerr[2] == 0.0);
    for (int i = 0; i < 3; i++)
        assert_true(isfinite(val[i]) && val[i] > 0.0);
    /* Each model's validation loss is the one bnn_eval_bce gives it (mean weights). */
    sim_samples_header_t hdr;
    ai_sample_t *vs = NULL;
    char err[4096];
    assert_int_equal(sim_samples_read(g_val, &hdr, &vs, err, sizeof err), 0);
    bnn_model_t *m[3] = {&g_ma, &g_mb, &g_load};
    for (int i = 0; i < 3; i++) {
        float want = NAN;
        assert_int_equal(bnn_eval_bce(m[i], vs, (size_t)hdr.count, 0, 0, &want), 0);
        if ((float)val[i] != want)
            fail_msg("val_loss of row %d: %.9g, bnn_eval_bce %.9g", i, val[i], (double)want);
    }
    free(vs);
}

static void test_map_files_agree(void **st)
{
    (void)st;
    char out[PATH_MAX], p[PATH_MAX];
    path_in(out, "files");
    HS_OK("maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", "--seed", "7", g_a, g_b);
    /* map_meta.json */
    path_at(p, out, "map_meta.json");
    size_t n = 0;
    char *json = (char *)test_slurp(p, &n);
    assert_non_null(json);
    const double res = json_num(json, "res"), xmin = json_num(json, "xmin"), ymin = json_num(json, "ymin");
    const double xmax = json_num(json, "xmax"), ymax = json_num(json, "ymax");
    const int W = (int)json_num(json, "width"), H = (int)json_num(json, "height");
    assert_true(res == 0.2);
    assert_int_equal((int)json_num(json, "mc"), 3);
    assert_int_equal((int)json_num(json, "seed"), 7);
    assert_int_equal((int)json_num(json, "models"), 2);
    char err[4096];
    sim_plan_t plan;
    assert_int_equal(sim_plan_load(g_plan, 0, &plan, err, sizeof err), 0);
    assert_true(xmin == plan.min.x && ymin == plan.min.y);
    assert_int_equal(W, (int)ceil((plan.max.x - plan.min.x) / res));
    assert_int_equal(H, (int)ceil((plan.max.y - plan.min.y) / res));
    assert_true(fabs(xmax - (xmin + W * res)) < 1e-9 && fabs(ymax - (ymin + H * res)) < 1e-9);
    assert_true(xmax >= plan.max.x && ymax >= plan.max.y);
    /* The arrays: shape of the meta, and the cells of sim_maps_compute on the consensus model
       with row 0 the top (largest y). */
    int h[3], w[3];
    const char *names[3] = {"map_mean.npy", "map_std.npy", "map_single.npy"};
    float *v[3];
    for (int k = 0; k < 3; k++) {
        path_at(p, out, names[k]);
        v[k] = read_npy(p, &h[k], &w[k]);
        assert_int_equal(h[k], H);
        assert_int_equal(w[k], W);
    }
    path_at(p, out, "consensus.bnn");
    load_model(p);
    sim_maps_grid_t mc, one;
    assert_int_equal(sim_maps_compute(&g_load, &plan, res, 3, 7, &mc, err, sizeof err), 0);
    assert_int_equal(sim_maps_compute(&g_load, &plan, res, 1, 7, &one, err, sizeof err), 0);
    assert_int_equal(mc.w, W);
    assert_int_equal(mc.h, H);
    double smax = 0;
    for (int r = 0; r < H; r++)
        for (int c = 0; c < W; c++) {
            const size_t i = (size_t)r * W + c, g = (size_t)(H - 1 - r) * W + c;
            assert_true(v[0][i] == mc.mean[g] && v[1][i] == mc.std[g] && v[2][i] == one.mean[g]);
            assert_true(v[0][i] >= 0.0f && v[0][i] <= 1.0f && v[1][i] >= 0.0f);
            smax = fmax(smax, v[1][i]);
        }
    assert_true(smax > 0.0 && fabs(json_num(json, "std_max") - smax) <= 1e-12);
    /* map_truth.npy: uint8, the plan's class at every cell centre, same orientation. */
    path_at(p, out, "map_truth.npy");
    uint8_t *tb = test_slurp(p, &n);
    assert_non_null(tb);
    const size_t thl = (size_t)tb[8] | (size_t)tb[9] << 8;
    char thead[256];
    assert_true(thl < sizeof thead && n == 10 + thl + (size_t)W * H);
    memcpy(thead, tb + 10, thl);
    thead[thl] = '\0';
    assert_non_null(strstr(thead, "'descr': '|u1'"));
    size_t walls = 0, free_cells = 0;
    for (int r = 0; r < H; r++)
        for (int c = 0; c < W; c++) {
            const int cls = sim_plan_classify_point(&plan, xmin + (c + 0.5) * res, ymin + (H - 1 - r + 0.5) * res);
            const int want = cls == SIM_CELL_WALL ? 1 : cls == SIM_CELL_FREE ? 0 : 255;
            assert_int_equal(tb[10 + thl + (size_t)r * W + c], want);
            walls += want == 1;
            free_cells += want == 0;
        }
    assert_true(walls > 0 && free_cells > walls);
    free(tb);
    /* map.pgm: P5, W x H, 255, pixel = round(255 (1 - mean)), same orientation as the arrays. */
    path_at(p, out, "map.pgm");
    uint8_t *pgm = test_slurp(p, &n);
    assert_non_null(pgm);
    char head[64];
    const int hn = snprintf(head, sizeof head, "P5\n%d %d\n255\n", W, H);
    assert_true(n == (size_t)hn + (size_t)W * H && memcmp(pgm, head, (size_t)hn) == 0);
    int lo = 255, hi = 0;
    for (size_t i = 0; i < (size_t)W * H; i++) {
        const int px = pgm[hn + i];
        assert_int_equal(px, (int)lround(255.0 * (1.0 - v[0][i])));
        lo = px < lo ? px : lo;
        hi = px > hi ? px : hi;
    }
    assert_true(lo >= 0 && hi <= 255 && lo < hi);
    /* map.yaml */
    path_at(p, out, "map.yaml");
    char *yaml = (char *)test_slurp(p, &n);
    assert_non_null(yaml);
    const char *o = strstr(yaml, "origin: [");
    double ox = NAN, oy = NAN;
    assert_non_null(o);
    assert_int_equal(sscanf(o, "origin: [%lf, %lf, 0.0]", &ox, &oy), 2);
    assert_true(ox == xmin && oy == ymin);
    const char *rs = strstr(yaml, "\nresolution: ");
    assert_non_null(rs);
    assert_true(strtod(rs + 13, NULL) == res);
    assert_true(strncmp(yaml, "image: map.pgm\nmode: trinary\n", 29) == 0);
    assert_non_null(strstr(yaml, "\nnegate: 0\n"));
    assert_non_null(strstr(yaml, "\noccupied_thresh: 0.65\n"));
    assert_non_null(strstr(yaml, "\nfree_thresh: 0.196\n"));
    /* The pictures: y up like map.pgm (host_sim/maps/sim_figure.h); at 0.2 m one pixel per cell, so
       map_mean.png is map.pgm's picture pixel for pixel. */
    struct stat sb;
    path_at(p, out, "map_mean.png");
    int pw = 0, ph = 0;
    uint8_t *png = tpng_read_rgb(p, &pw, &ph);
    assert_non_null(png);
    assert_true(pw == W && ph == H);
    for (size_t i = 0; i < (size_t)W * H; i++)
        if (png[3 * i] != pgm[hn + i] || png[3 * i + 1] != pgm[hn + i] || png[3 * i + 2] != pgm[hn + i])
            fail_msg("map_mean.png pixel (%zu, %zu) is not map.pgm's", i % (size_t)W, i / (size_t)W);
    free(png);
    path_at(p, out, "map_std.png");
    assert_true(stat(p, &sb) == 0 && sb.st_size > 0);
    free(yaml);
    free(pgm);
    for (int k = 0; k < 3; k++)
        free(v[k]);
    sim_maps_grid_free(&mc);
    sim_maps_grid_free(&one);
    sim_plan_free(&plan);
    free(json);
}

/* The picture convention (host_sim/maps/sim_figure.h): a dark cell near the plan's top-left in
 * metres (small x, large y) is drawn top-left in both map PNGs, and each tour in its robot's
 * sim_palette.h colour: robot 0's near (small x, large y) top-left, robot 1's bottom-right. */
static void test_map_png_y_up(void **st)
{
    (void)st;
    sim_plan_t plan;
    memset(&plan, 0, sizeof plan);
    plan.min = (sim_vec2_t){0.0, 0.0};
    plan.max = (sim_vec2_t){4.0, 3.0};
    enum { W = 20, H = 15 }; /* 0.2 m cells: zoom 1, one pixel per cell */
    float mean[W * H], sd[W * H];
    for (int i = 0; i < W * H; i++) {
        mean[i] = 0.0f;
        sd[i] = 0.0f;
    }
    const int c0 = 2, r0 = 13; /* cell centre (0.5, 2.7) m */
    mean[r0 * W + c0] = 1.0f;
    sd[r0 * W + c0] = 0.5f;
    sim_maps_grid_t g = {W, H, 0.2, 0.0, 0.0, mean, sd};
    sim_vec2_t a[2] = {{1.5, 2.5}, {1.9, 2.5}}, b[2] = {{3.5, 0.3}, {3.1, 0.3}};
    sim_path_t paths[2] = {{2, a, -1, NULL}, {2, b, -1, NULL}};
    char mp[PATH_MAX], sp[PATH_MAX], err[256];
    path_in(mp, "yup_mean.png");
    path_in(sp, "yup_std.png");
    assert_int_equal(sim_maps_write_png(&g, &plan, paths, 2, mp, sp, NULL, err, sizeof err), 0);
    for (int k = 0; k < 2; k++) {
        int w = 0, h = 0;
        uint8_t *rgb = tpng_read_rgb(k == 0 ? mp : sp, &w, &h);
        assert_non_null(rgb);
        assert_true(w == W && h == H);
        /* The marked cell: black in the mean, yellow (the ramp's top) in the std. */
        const uint8_t *px = rgb + 3 * ((size_t)(H - 1 - r0) * W + c0);
        if (k == 0)
            assert_true(px[0] == 0 && px[1] == 0 && px[2] == 0);
        else
            assert_true(px[0] == 253 && px[1] == 231 && px[2] == 37);
        double fx = -1.0, fy = -1.0;
        assert_true(tpng_find(rgb, w, h, sim_palette_rgb(0), 0, &fx, &fy) > 0);
        assert_true(fx < 0.5 && fy < 0.3);
        assert_true(tpng_find(rgb, w, h, sim_palette_rgb(1), 0, &fx, &fy) > 0);
        assert_true(fx > 0.7 && fy > 0.8);
        free(rgb);
    }
    unlink(mp);
    unlink(sp);
}

/* The outputs a good run leaves in DIR: a failed run must keep every one of them. */

/* The epistemic map: two robots' posteriors (one saw the plan's left half, the other its right
 * half) summed into the map of the consensus model, written as map_epistemic.npy like the
 * other arrays (sim_maps_epistemic of consensus.bnn and the posterior it carries); models
 * without one write none and remove an earlier one; posteriors over other features refuse. */
static bnn_post_t g_pa, g_pb, g_pc;
static void test_epistemic_map(void **st)
{
    (void)st;
    char out[PATH_MAX], p[PATH_MAX], fa[PATH_MAX], fb[PATH_MAX], fc[PATH_MAX];
    static uint8_t buf[BNN_CKPT_MAX_BYTES];
    static float xy[2 * 2000];
    size_t n = 0;
    assert_int_equal(bnn_init(&g_load, NULL, 11), 0); /* g_ma's initial SIREN layer */
    assert_int_equal(bnn_post_init(&g_pa, &g_load), 0);
    assert_int_equal(bnn_post_init(&g_pb, &g_load), 0);
    assert_int_equal(bnn_init(&g_load, NULL, 22), 0);
    assert_int_equal(bnn_post_init(&g_pc, &g_load), 0);
    ai_rng_uniform_fill(4, 4, 0, xy, 2 * 2000);
    for (int k = 0; k < 2000; k++) {
        xy[2 * k] = xy[2 * k] - 1.0f; /* x in [-1, 0): the left half */
        xy[2 * k + 1] = 2.0f * xy[2 * k + 1] - 1.0f;
    }
    assert_int_equal(bnn_post_observe(&g_pa, &g_load, xy, 2000), 0);
    assert_int_equal(bnn_post_observe(&g_pc, &g_load, xy, 2000), 0);
    for (int k = 0; k < 2000; k++)
        xy[2 * k] += 1.0f; /* the right half */
    assert_int_equal(bnn_post_observe(&g_pb, &g_load, xy, 1000), 0);
    path_in(fa, "post_a.bnn");
    path_in(fb, "post_b.bnn");
    path_in(fc, "post_c.bnn");
    assert_int_equal(bnn_ckpt_save_post(&g_ma, 0, &g_pa, buf, sizeof buf, &n), 0);
    spit(fa, buf, n);
    assert_int_equal(bnn_ckpt_save_post(&g_ma, 0, &g_pb, buf, sizeof buf, &n), 0);
    spit(fb, buf, n);
    assert_int_equal(bnn_ckpt_save_post(&g_ma, 0, &g_pc, buf, sizeof buf, &n), 0);
    spit(fc, buf, n);

    path_in(out, "epi");
    HS_OK("maps", "--plan", g_plan, "--out", out, "--res", "0.25", "--mc", "2", fa, fb);
    if (strstr(g_out, "epistemic: the posterior of 2 model(s)") == NULL)
        fail_msg("stdout:\n%s", g_out);
    path_at(p, out, "map_meta.json");
    char *json = (char *)test_slurp(p, &n);
    assert_non_null(json);
    const int W = (int)json_num(json, "width"), H = (int)json_num(json, "height");
    assert_non_null(strstr(json, "\"models_with_posterior\": 2"));
    free(json);
    int h = 0, w = 0;
    path_at(p, out, "map_epistemic.npy");
    float *epi = read_npy(p, &h, &w);
    assert_int_equal(h, H);
    assert_int_equal(w, W);
    /* the same cells from consensus.bnn and the posterior it carries (the sum of the two) */
    path_at(p, out, "consensus.bnn");
    uint8_t *b = test_slurp(p, &n);
    assert_non_null(b);
    const char *why = NULL;
    assert_int_equal(bnn_init(&g_load, NULL, 0), 0);
    if (bnn_ckpt_load_post(&g_load, &g_pc, b, n, &why) != 0)
        fail_msg("consensus.bnn: %s", why);
    free(b);
    assert_true(fabs(g_pc.n_obs - 3000.0) < 1e-9 && fabs(g_pc.robots - 2.0) < 1e-12);
    char err[4096];
    sim_plan_t plan;
    assert_int_equal(sim_plan_load(g_plan, 0, &plan, err, sizeof err), 0);
    sim_maps_grid_t g = {.w = W, .h = H, .res = 0.25, .x0 = plan.min.x, .y0 = plan.min.y};
    float *want = malloc((size_t)W * H * sizeof *want);
    assert_non_null(want);
    assert_int_equal(sim_maps_epistemic(&g_load, &g_pc, &plan, &g, want, err, sizeof err), 0);
    for (int r = 0; r < H; r++)
        for (int c = 0; c < W; c++) {
            const float v = epi[(size_t)r * W + c]; /* row 0 the top: grid row H - 1 - r */
            assert_true(v > 0.0f && v <= 1.0f);
            assert_true(v == want[(size_t)(H - 1 - r) * W + c]);
        }
    free(want);
    free(epi);
    sim_plan_free(&plan);
    path_at(p, out, "map_epistemic.png");
    assert_int_equal(access(p, F_OK), 0);

    /* models without a posterior: none, and the earlier one goes */
    HS_OK("maps", "--plan", g_plan, "--out", out, "--res", "0.25", "--mc", "2", g_a, g_b);
    assert_non_null(strstr(g_out, "none of the models carries a posterior"));
    path_at(p, out, "map_epistemic.npy");
    assert_int_equal(access(p, F_OK), -1);
    /* posteriors over another SIREN layer (another seed's fleet) do not add up */
    path_in(out, "epi_bad");
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.25", "--mc", "2", fa, fc), 1);
    expect_err("post_c.bnn", "other features");
}

static const char *const outputs[] = {"consensus.bnn", "consensus.csv", "map_mean.npy", "map_std.npy",
                                      "map_single.npy", "map_truth.npy", "map_meta.json", "map.pgm",
                                      "map.yaml",      "map_mean.png",  "map_std.png"};

/* Every file of DIR, byte for byte, before a run that must fail; the outputs all among them. */
static void snap_outputs(snap_t *s, const char *dir)
{
    snap_take(s, dir);
    for (size_t k = 0; k < sizeof outputs / sizeof outputs[0]; k++)
        if (!snap_has(s, outputs[k]))
            fail_msg("%s/%s is missing", dir, outputs[k]);
}

static void test_bad_inputs_keep_earlier_output(void **st)
{
    (void)st;
    char out[PATH_MAX], bad[PATH_MAX], missing[PATH_MAX];
    path_in(out, "keep");
    HS_OK("maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", "--valset", g_val, g_a, g_b);
    snap_t s;
    snap_outputs(&s, out);
    size_t n = 0;
    uint8_t *ck = test_slurp(g_b, &n);
    assert_non_null(ck);
    path_in(bad, "bad.bnn");
    /* A corrupt checkpoint (one payload bit flipped), as the second model. */
    ck[BNN_CKPT_HEADER_BYTES + 100] ^= 0x10;
    spit(bad, ck, n);
    ck[BNN_CKPT_HEADER_BYTES + 100] ^= 0x10;
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", g_a, bad), 1);
    expect_err(bad, "CRC mismatch");
    snap_check(&s, out);
    /* Truncated. */
    spit(bad, ck, n - 7);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", bad), 1);
    expect_err(bad, "truncated");
    spit(bad, ck, 10);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", bad), 1);
    expect_err(bad, "truncated");
    /* Bytes after its end. */
    uint8_t *longer = malloc(n + 3);
    assert_non_null(longer);
    memcpy(longer, ck, n);
    memset(longer + n, 0xAB, 3);
    spit(bad, longer, n + 3);
    free(longer);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", bad), 1);
    expect_err(bad, "3 bytes after the end");
    /* Not a checkpoint at all, empty, missing, a directory. */
    spit(bad, "hello, world\n", 13);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", bad), 1);
    expect_err(bad, NULL);
    spit(bad, "", 0);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", g_a, bad), 1);
    expect_err(bad, "truncated");
    path_in(missing, "nope.bnn");
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", g_a, missing), 1);
    expect_err(missing, "No such file or directory");
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", g_dir), 1);
    expect_err(g_dir, "Is a directory");
    /* Models of different networks. */
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", g_a, g_other), 1);
    expect_err(g_other, "different networks");
    /* Validation sets: missing, a directory, not a samples file, another plan's. */
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", "--valset",
                        missing, g_a),
                     1);
    expect_err(missing, NULL);
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", "--valset", g_dir,
                        g_a),
                     1);
    expect_err(g_dir, "Is a directory");
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", "--valset", g_a,
                        g_a),
                     1);
    expect_err(g_a, NULL);
    char other_plan[PATH_MAX], other_val[PATH_MAX];
    path_in(other_plan, "other.svg");
    path_in(other_val, "other.samples");
    HS_OK("plan", "gen", "--seed", "3", "--out", other_plan);
    HS_OK("valset", "--plan", other_plan, "--out", other_val, "--poses", "2");
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", "--valset",
                        other_val, g_a),
                     1);
    expect_err(other_val, "its bounding box is not the plan's");
    /* A plan that is not one. */
    assert_int_equal(HS(-1, "maps", "--plan", g_a, "--out", out, "--res", "0.2", "--mc", "3", g_a), 1);
    expect_err(g_a, NULL);
    /* A full disk: 100 more bytes, then none. */
    assert_int_equal(HS(100, "maps", "--plan", g_plan, "--out", out, "--res", "0.2", "--mc", "3", "--seed", "9", g_b),
                     1);
    expect_err(out, "No space left on device");
    snap_check(&s, out);
    /* An --out that is a file. */
    assert_int_equal(HS(-1, "maps", "--plan", g_plan, "--out", g_a, "--res", "0.2", "--mc", "3", g_b), 1);
    expect_err(g_a, "Not a directory");
    free(ck);
    snap_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_help_and_usage_errors),
        cmocka_unit_test(test_one_model_is_its_own_consensus),
        cmocka_unit_test(test_two_models_mean_and_errors),
        cmocka_unit_test(test_map_files_agree),
        cmocka_unit_test(test_bad_inputs_keep_earlier_output),
        cmocka_unit_test(test_map_png_y_up),
        cmocka_unit_test(test_epistemic_map),
    };
    return cmocka_run_group_tests_name("app/maps", tests, setup, teardown);
}
