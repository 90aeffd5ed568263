/* The ROS map of host_sim maps read the way nav2's map_server reads it (nav2_map_server
 * map_io.cpp: loadMapYaml + loadMapFromFile, mode trinary, negate 0), on a model trained here:
 * the occupied cells are the plan's walls (wall IoU above a floor), the free cells are truly
 * free, the thresholds come from the validation set and say so in map.yaml, and without a
 * validation set map.yaml has the documented defaults and says why. Also the threshold rule
 * itself (sim_maps_choose_thresholds) on points whose answer is known.
 *
 * The model: host_sim fleet --inproc --strategy central (one network on the pooled samples
 * of 7 robots' tours of the default plan), ROUNDS rounds, seed 1, the thresholds chosen on a
 * validation set of 100 poses (seed 2); its map as nav2 reads it had wall IoU 0.650 (the best
 * occupied threshold, picked on the ground truth itself, gives 0.697) and 98.9 % of its free
 * cells truly free when this test was written (x86-64, release build; other CPUs and builds
 * round differently, hence the margins of the floors). About 7 s on one core. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <ctype.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "run_outputs.h"

#include "sim_grid.h"
#include "sim_maps.h"
#include "sim_plan.h"

#define ROUNDS "300"
#define WALL_IOU_FLOOR 0.55  /* measured 0.656 */
#define FREE_TRUE_FLOOR 0.95 /* measured 0.988 */

#define SHORT_PATH 1024
static char g_bin[PATH_MAX];
static char g_dir[SHORT_PATH];
static char g_plan[PATH_MAX];
static char g_model[PATH_MAX], g_val[PATH_MAX];
static char g_err[1 << 16], g_out[1 << 16];

static int hs(const char *const *args)
{
    return test_run(g_bin, args, -1, g_dir, g_err, g_out, sizeof g_err);
}

#define HS_OK(...)                                                                           \
    do {                                                                                     \
        int rc_ = hs((const char *const[]){"host_sim", __VA_ARGS__, NULL});                  \
        if (rc_ != 0)                                                                        \
            fail_msg("host_sim exited %d:\n%s", rc_, g_err);                                 \
    } while (0)

static void path_in(char *out, const char *name)
{
    snprintf(out, PATH_MAX, "%.1023s/%.63s", g_dir, name);
}

/* DIR/NAME */
static void path_at(char *out, const char *dir, const char *name)
{
    assert_true(strlen(dir) < 2048 && strlen(name) < 64);
    snprintf(out, PATH_MAX, "%.2047s/%.63s", dir, name);
}

static int setup(void **st)
{
    (void)st;
    test_build_program("host_sim", g_bin, sizeof g_bin);
    snprintf(g_dir, sizeof g_dir, "/tmp/fleetsim-rosmap-XXXXXX");
    assert_non_null(mkdtemp(g_dir));
    assert_non_null(realpath("host_sim/plans/apartment.svg", g_plan));
    char paths[PATH_MAX], fleet[PATH_MAX];
    path_in(paths, "paths");
    path_in(fleet, "fleet");
    HS_OK("paths", "gen", "--plan", g_plan, "--robots", "7", "--seed", "1", "--out", paths);
    HS_OK("fleet", "--inproc", "--plan", g_plan, "--paths", paths, "--robots", "7", "--rounds", ROUNDS, "--strategy",
          "central", "--graph", "full", "--seed", "1", "--val-poses", "10", "--mc", "1", "--metrics-every", ROUNDS,
          "--out", fleet);
    path_at(g_model, fleet, "models/robot_0.bnn");
    /* The validation set the thresholds are chosen on: its own seed, not the training's. */
    path_in(g_val, "val.samples");
    HS_OK("valset", "--plan", g_plan, "--poses", "100", "--seed", "2", "--out", g_val);
    return 0;
}

static int teardown(void **st)
{
    (void)st;
    return test_remove_tree(g_dir);
}

/* ---- a reader of map.yaml + map.pgm after nav2's map_io ---------------------------------- */

enum { NAV_FREE = 0, NAV_OCCUPIED = 100, NAV_UNKNOWN = -1 };

typedef struct nav_map {
    /* loadMapYaml */
    char image[2 * PATH_MAX + 2]; /* a folder and a name, each up to PATH_MAX */
    double resolution, origin[3], occupied_thresh, free_thresh;
    int negate, trinary;
    /* loadMapFromFile: data[width * (height - y - 1) + x] for image row y, so data row 0 is
       the image's BOTTOM row and cell (x, r) has its centre at origin + ((x, r) + 0.5) res */
    int width, height;
    int8_t *data;
    double *occ; /* the occupancy before thresholding, same order */
} nav_map_t;

/* The value of `key: value` in a YAML mapping of plain scalars (comments and blank lines
 * skipped), copied into out; 0, or -1 when the key is missing. */
static int yaml_value(const char *yaml, const char *key, char *out, size_t cap)
{
    const size_t kl = strlen(key);
    for (const char *line = yaml; line && *line; line = strchr(line, '\n') ? strchr(line, '\n') + 1 : NULL) {
        if (line[0] == '#' || strncmp(line, key, kl) != 0 || line[kl] != ':')
            continue;
        const char *v = line + kl + 1;
        while (*v == ' ')
            v++;
        size_t n = strcspn(v, "\n");
        while (n > 0 && (v[n - 1] == ' ' || v[n - 1] == '\r'))
            n--;
        const char *hash = memchr(v, '#', n); /* a trailing comment */
        if (hash && hash > v && hash[-1] == ' ')
            n = (size_t)(hash - v - 1);
        assert_true(n < cap);
        memcpy(out, v, n);
        out[n] = '\0';
        return 0;
    }
    return -1;
}

static double yaml_double(const char *yaml, const char *key)
{
    char v[256];
    if (yaml_value(yaml, key, v, sizeof v) != 0)
        fail_msg("map.yaml lacks %s:\n%s", key, yaml);
    char *end = NULL;
    const double d = strtod(v, &end);
    if (end == v || *end != '\0' || !isfinite(d))
        fail_msg("map.yaml: %s: '%s' is not a number", key, v);
    return d;
}

/* PGM header token: skips whitespace and '#' comments; an unsigned decimal. */
static long pgm_number(const uint8_t *b, size_t n, size_t *at)
{
    for (;;) {
        while (*at < n && isspace(b[*at]))
            (*at)++;
        if (*at < n && b[*at] == '#') {
            while (*at < n && b[*at] != '\n')
                (*at)++;
            continue;
        }
        break;
    }
    long v = 0;
    const size_t start = *at;
    while (*at < n && isdigit(b[*at]) && v < 100000)
        v = v * 10 + (b[(*at)++] - '0');
    if (*at == start)
        fail_msg("map.pgm: a number expected at byte %zu", start);
    return v;
}

static void nav_load(const char *yaml_path, nav_map_t *m)
{
    memset(m, 0, sizeof *m);
    size_t n = 0;
    char *yaml = (char *)test_slurp(yaml_path, &n);
    if (yaml == NULL)
        fail_msg("%s missing", yaml_path);
    /* loadMapYaml */
    char v[PATH_MAX];
    assert_int_equal(yaml_value(yaml, "image", v, sizeof v), 0);
    assert_true(v[0] != '\0');
    if (v[0] == '/') {
        snprintf(m->image, sizeof m->image, "%s", v);
    } else {
        char dir[PATH_MAX];
        snprintf(dir, sizeof dir, "%s", yaml_path);
        char *slash = strrchr(dir, '/');
        if (slash)
            *slash = '\0';
        else
            snprintf(dir, sizeof dir, ".");
        assert_true(strlen(dir) + strlen(v) + 2 < sizeof m->image);
        snprintf(m->image, sizeof m->image, "%s/%s", dir, v);
    }
    m->resolution = yaml_double(yaml, "resolution");
    assert_int_equal(yaml_value(yaml, "origin", v, sizeof v), 0);
    if (sscanf(v, "[%lf , %lf , %lf ]", &m->origin[0], &m->origin[1], &m->origin[2]) != 3)
        fail_msg("map.yaml: origin '%s' is not 3 numbers", v);
    m->free_thresh = yaml_double(yaml, "free_thresh");
    m->occupied_thresh = yaml_double(yaml, "occupied_thresh");
    m->trinary = yaml_value(yaml, "mode", v, sizeof v) != 0 || strcmp(v, "trinary") == 0;
    m->negate = (int)yaml_double(yaml, "negate");
    free(yaml);
    /* loadMapFromFile: the image (a binary PGM here: magic, width, height, maxval, one
       whitespace byte, the raster). shade = value / maxval, occ = 1 - shade (negate 0). */
    uint8_t *b = test_slurp(m->image, &n);
    if (b == NULL)
        fail_msg("%s missing", m->image);
    assert_true(n > 2 && b[0] == 'P' && b[1] == '5');
    size_t at = 2;
    m->width = (int)pgm_number(b, n, &at);
    m->height = (int)pgm_number(b, n, &at);
    const long maxval = pgm_number(b, n, &at);
    assert_true(m->width > 0 && m->height > 0 && maxval > 0 && maxval < 256);
    assert_true(at < n && isspace(b[at]));
    at++;
    assert_int_equal(n - at, (size_t)m->width * m->height);
    m->data = malloc((size_t)m->width * m->height);
    m->occ = malloc((size_t)m->width * m->height * sizeof *m->occ);
    assert_true(m->data != NULL && m->occ != NULL);
    for (int y = 0; y < m->height; y++)
        for (int x = 0; x < m->width; x++) {
            const double shade = b[at + (size_t)y * m->width + x] / (double)maxval;
            const double occ = m->negate ? shade : 1.0 - shade;
            int8_t cell;
            if (m->occupied_thresh < occ)
                cell = NAV_OCCUPIED;
            else if (occ < m->free_thresh)
                cell = NAV_FREE;
            else
                cell = NAV_UNKNOWN;
            m->data[(size_t)m->width * (m->height - y - 1) + x] = cell;
            m->occ[(size_t)m->width * (m->height - y - 1) + x] = occ;
        }
    free(b);
}

/* The map against the plan's ground truth (sim_grid_from_plan at the map's resolution, each
 * map cell looked up at its centre in world coordinates). */
typedef struct nav_score {
    size_t occupied, free_cells, unknown;
    size_t walls, occ_wall, occ_known, free_known, free_free;
    double wall_iou, free_true;
} nav_score_t;

static nav_score_t nav_score(const nav_map_t *m, const sim_plan_t *plan, double *best_iou, double *best_at)
{
    sim_grid_t g;
    assert_int_equal(sim_grid_from_plan(plan, m->resolution, &g), 0);
    nav_score_t s = {0};
    /* For the best IoU any occupied threshold gives: walls and others per level. */
    size_t wall_at[256] = {0}, other_at[256] = {0};
    for (int r = 0; r < m->height; r++)
        for (int x = 0; x < m->width; x++) {
            const double wx = m->origin[0] + (x + 0.5) * m->resolution, wy = m->origin[1] + (r + 0.5) * m->resolution;
            int gc, gr;
            const int truth = sim_grid_world_to_cell(&g, wx, wy, &gc, &gr) == 0 ? sim_grid_at(&g, gc, gr)
                                                                                 : SIM_CELL_OUTSIDE;
            const int8_t cell = m->data[(size_t)r * m->width + x];
            const int level = (int)lround(m->occ[(size_t)r * m->width + x] * 255.0);
            assert_true(level >= 0 && level <= 255);
            if (truth == SIM_CELL_WALL)
                wall_at[level]++;
            else if (truth == SIM_CELL_FREE)
                other_at[level]++;
            s.walls += truth == SIM_CELL_WALL;
            if (cell == NAV_OCCUPIED) {
                s.occupied++;
                s.occ_known += truth != SIM_CELL_OUTSIDE;
                s.occ_wall += truth == SIM_CELL_WALL;
            } else if (cell == NAV_FREE) {
                s.free_cells++;
                s.free_known += truth != SIM_CELL_OUTSIDE;
                s.free_free += truth == SIM_CELL_FREE;
            } else {
                s.unknown++;
            }
        }
    sim_grid_free(&g);
    const size_t uni = s.occ_known + s.walls - s.occ_wall;
    s.wall_iou = uni ? (double)s.occ_wall / (double)uni : 0.0;
    s.free_true = s.free_known ? (double)s.free_free / (double)s.free_known : 0.0;
    /* Occupied = level > k, k = 254 down to 0. */
    size_t tp = 0, fp = 0;
    *best_iou = 0.0;
    *best_at = 1.0;
    for (int k = 254; k >= 0; k--) {
        tp += wall_at[k + 1];
        fp += other_at[k + 1];
        const double iou = (double)tp / (double)(s.walls + fp);
        if (iou > *best_iou) {
            *best_iou = iou;
            *best_at = (k + 0.5) / 255.0;
        }
    }
    return s;
}

static double json_num(const char *json, const char *key)
{
    char k[64];
    snprintf(k, sizeof k, "\"%s\": ", key);
    const char *p = strstr(json, k);
    if (p == NULL)
        fail_msg("map_meta.json lacks %s: %s", key, json);
    return strtod(p + strlen(k), NULL);
}

/* ---- the tests ------------------------------------------------------------------------- */

static void test_nav2_sees_the_walls(void **st)
{
    (void)st;
    char out[PATH_MAX], p[PATH_MAX];
    path_in(out, "maps");
    HS_OK("maps", "--plan", g_plan, "--out", out, "--valset", g_val, g_model);
    path_at(p, out, "map.yaml");
    nav_map_t m;
    nav_load(p, &m);
    char err[4096];
    sim_plan_t plan;
    assert_int_equal(sim_plan_load(g_plan, 0, &plan, err, sizeof err), 0);
    /* nav2's conventions, and the map where the plan is. */
    assert_true(m.trinary && m.negate == 0 && m.origin[2] == 0.0);
    assert_true(m.origin[0] == plan.min.x && m.origin[1] == plan.min.y);
    assert_true(m.width * m.resolution >= plan.max.x - plan.min.x);
    assert_true(m.height * m.resolution >= plan.max.y - plan.min.y);
    assert_true(0.0 < m.free_thresh && m.free_thresh < m.occupied_thresh && m.occupied_thresh < 1.0);
    /* Each threshold (about) half-way between two of the PGM's levels k / 255. */
    const double ko = m.occupied_thresh * 255.0, kf = m.free_thresh * 255.0;
    assert_true(fabs(ko - round(ko)) > 0.45 && fabs(kf - round(kf)) > 0.45);
    double best = 0, best_at = 0;
    const nav_score_t s = nav_score(&m, &plan, &best, &best_at);
    print_message("nav2 reads: %zu occupied, %zu free, %zu unknown cells (occupied_thresh %g, free_thresh %g); "
                  "wall IoU %.3f (floor %.2f; the best threshold, %.3f, chosen on the ground truth itself, "
                  "would give %.3f), %.1f %% of the free cells truly free (floor %.0f %%)\n",
                  s.occupied, s.free_cells, s.unknown, m.occupied_thresh, m.free_thresh, s.wall_iou, WALL_IOU_FLOOR,
                  best_at, best, 100.0 * s.free_true, 100.0 * FREE_TRUE_FLOOR);
    assert_true(s.walls > 0 && s.occupied > 0);
    if (s.wall_iou <= WALL_IOU_FLOOR)
        fail_msg("wall IoU %.3f <= %.2f", s.wall_iou, WALL_IOU_FLOOR);
    /* Chosen without the ground truth, nearly as good as the best with it. */
    if (s.wall_iou < 0.85 * best)
        fail_msg("wall IoU %.3f < 0.85 x %.3f, the best any threshold gives", s.wall_iou, best);
    if (s.free_true <= FREE_TRUE_FLOOR)
        fail_msg("%.3f of the free cells truly free <= %.2f", s.free_true, FREE_TRUE_FLOOR);
    /* Most of the map is called free: the walls are thin. */
    assert_true(s.free_cells > 4 * s.occupied);
    /* What host_sim says about its map is what nav2 reads. */
    path_at(p, out, "map_meta.json");
    size_t n = 0;
    char *json = (char *)test_slurp(p, &n);
    assert_non_null(json);
    assert_non_null(strstr(json, "\"thresholds\": \"valset\""));
    assert_true(json_num(json, "occupied_thresh") == m.occupied_thresh);
    assert_true(json_num(json, "free_thresh") == m.free_thresh);
    assert_int_equal((size_t)json_num(json, "nav2_occupied"), s.occupied);
    assert_int_equal((size_t)json_num(json, "nav2_free"), s.free_cells);
    assert_int_equal((size_t)json_num(json, "nav2_unknown"), s.unknown);
    assert_true(fabs(json_num(json, "nav2_wall_iou") - s.wall_iou) < 1e-12);
    assert_true(fabs(json_num(json, "nav2_free_truly_free") - s.free_true) < 1e-12);
    free(json);
    /* The reason in map.yaml, and on stdout. */
    path_at(p, out, "map.yaml");
    char *yaml = (char *)test_slurp(p, &n);
    assert_non_null(yaml);
    if (strstr(yaml, "\n# occupied_thresh and free_thresh chosen on the validation set") == NULL ||
        strstr(yaml, "best F1 of\n# the hits") == NULL)
        fail_msg("map.yaml does not say where its thresholds come from:\n%s", yaml);
    free(yaml);
    assert_non_null(strstr(g_out, "map.yaml: occupied_thresh "));
    assert_non_null(strstr(g_out, "(validation set: best F1"));
    free(m.data);
    free(m.occ);
    sim_plan_free(&plan);
}

static void test_defaults_without_valset(void **st)
{
    (void)st;
    char out[PATH_MAX], p[PATH_MAX];
    path_in(out, "maps-default");
    HS_OK("maps", "--plan", g_plan, "--out", out, "--mc", "5", g_model);
    path_at(p, out, "map.yaml");
    nav_map_t m;
    nav_load(p, &m);
    assert_true(m.occupied_thresh == 0.65 && m.free_thresh == 0.196);
    size_t n = 0;
    char *yaml = (char *)test_slurp(p, &n);
    assert_non_null(yaml);
    assert_non_null(strstr(yaml, "\n# occupied_thresh and free_thresh: ROS map_server's defaults (no validation set"));
    free(yaml);
    assert_non_null(strstr(g_out, "ROS map_server's defaults (no validation set given)"));
    char err[4096];
    sim_plan_t plan;
    assert_int_equal(sim_plan_load(g_plan, 0, &plan, err, sizeof err), 0);
    double best = 0, best_at = 0;
    const nav_score_t s = nav_score(&m, &plan, &best, &best_at);
    /* A map with no walls at the defaults is said to be one. */
    if (s.occupied == 0)
        assert_non_null(strstr(g_out, "NO cell is occupied, the map has no walls"));
    else
        assert_null(strstr(g_out, "NO cell is occupied"));
    free(m.data);
    free(m.occ);
    sim_plan_free(&plan);
}

/* Points with a known best cut. */
static void test_threshold_rule(void **st)
{
    (void)st;
    enum { N = 1000 };
    static float p[N];
    static ai_sample_t pts[N];
    /* Hits at 0.40 (100), free at 0.10 (850) and at 0.30 (50): every cut from the level of
       0.30 to just below that of 0.40 separates them perfectly (occupied: the smallest, the
       level of 0.30); below it, every free cut from the level of 0.10 up misses the 50 free
       points at 0.30 alike (F1 1700 / 1750: the smallest, the level of 0.10). */
    for (int i = 0; i < N; i++) {
        const int hit = i < 100;
        p[i] = hit ? 0.40f : i < 950 ? 0.10f : 0.30f;
        pts[i] = (ai_sample_t){0.0f, 0.0f, hit ? 1.0f : 0.0f};
    }
    sim_maps_thresh_t t;
    assert_int_equal(sim_maps_choose_thresholds(p, pts, N, &t), 0);
    const int l30 = 255 - sim_maps_pgm_pixel(0.30f), l10 = 255 - sim_maps_pgm_pixel(0.10f);
    assert_int_equal(t.occ_level, l30);
    assert_int_equal(t.free_level, l10);
    assert_true(t.occ_f1 == 1.0 && fabs(t.free_f1 - 1700.0 / 1750.0) < 1e-12);
    assert_true(t.occupied == (t.occ_level + 0.5) / 255.0 && t.free_thresh == (t.free_level + 0.5) / 255.0);
    assert_int_equal(t.n, N);
    assert_int_equal(t.n_hit, 100);
    /* The map's pixel levels: occupancy (255 - pixel) / 255 > occupied iff level > occ_level. */
    assert_true((255 - sim_maps_pgm_pixel(0.40f)) / 255.0 > t.occupied);
    assert_true((255 - sim_maps_pgm_pixel(0.30f)) / 255.0 < t.occupied);
    assert_true((255 - sim_maps_pgm_pixel(0.10f)) / 255.0 < t.free_thresh);
    /* Overlap: a few free points above the hits cost less than losing the hits. */
    for (int i = 950; i < 960; i++)
        p[i] = 0.5f;
    assert_int_equal(sim_maps_choose_thresholds(p, pts, N, &t), 0);
    assert_int_equal(t.occ_level, l30);
    assert_true(t.occ_f1 < 1.0 && t.occ_f1 > 0.9);
    /* A model that calls everything occupied: the cut cannot go below level 1. */
    for (int i = 0; i < N; i++)
        p[i] = 1.0f;
    assert_int_equal(sim_maps_choose_thresholds(p, pts, N, &t), 0);
    assert_true(t.free_level < t.occ_level && t.occ_level >= 1);
    /* NaN and out-of-range values map like the PGM: NaN and p < 0 free, p > 1 occupied. */
    assert_int_equal(sim_maps_pgm_pixel(NAN), 255);
    assert_int_equal(sim_maps_pgm_pixel(-1.0f), 255);
    assert_int_equal(sim_maps_pgm_pixel(2.0f), 0);
    assert_int_equal(sim_maps_pgm_pixel(0.5f), 128); /* lround(127.5) */
    /* No F1 to maximise. */
    for (int i = 0; i < N; i++)
        pts[i].occ = 1.0f;
    assert_int_equal(sim_maps_choose_thresholds(p, pts, N, &t), -EINVAL);
    assert_int_equal(t.occ_level, 0);
    assert_int_equal(sim_maps_choose_thresholds(p, pts, 0, &t), -EINVAL);
    assert_int_equal(sim_maps_choose_thresholds(NULL, pts, N, &t), -EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_threshold_rule),
        cmocka_unit_test(test_nav2_sees_the_walls),
        cmocka_unit_test(test_defaults_without_valset),
    };
    return cmocka_run_group_tests_name("app/rosmap", tests, setup, teardown);
}
