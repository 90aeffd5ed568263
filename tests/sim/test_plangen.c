/* Procedural plans: every generated file parses with the expected structure, is
 * deterministic per seed, and many of them admit collision-free tours; the one-band plans are
 * byte for byte those made before wings existed; wings (more than 16 rooms) are closed, every
 * room reachable from the entrance; the shipped office plan is what its command makes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "sim_grid.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_plangen.h"

static int in_door(const sim_plan_t *p, const sim_grid_t *g, int c, int r)
{
    double x, y;
    sim_grid_cell_centre(g, c, r, &x, &y);
    for (int i = 0; i < p->n_openings; i++)
        if (p->openings[i].kind == SIM_OPENING_DOOR && sim_poly_contains(&p->openings[i].outline, x, y))
            return 1;
    return 0;
}

static void test_round_trip_many_seeds(void **state)
{
    (void)state;
    for (unsigned long seed = 0; seed < 300; seed++) {
        int rooms = SIM_PLANGEN_MIN_ROOMS + (int)(seed % (SIM_PLANGEN_BAND_ROOMS - SIM_PLANGEN_MIN_ROOMS + 1));
        char *svg = NULL;
        assert_int_equal(sim_plangen_svg(seed, rooms, &svg), 0);
        sim_plan_t p;
        char err[256];
        if (sim_plan_parse(svg, "gen.svg", 0.0, &p, err, sizeof err) != 0)
            fail_msg("seed %lu rooms %d: %s", seed, rooms, err);
        assert_int_equal(p.n_rooms, rooms + 1);
        int doors = 0, windows = 0, halls = 0;
        for (int i = 0; i < p.n_openings; i++) {
            const sim_poly_t *o = &p.openings[i].outline;
            double a = fabs(o->p[1].x - o->p[0].x) + fabs(o->p[1].y - o->p[0].y);
            double b = fabs(o->p[2].x - o->p[1].x) + fabs(o->p[2].y - o->p[1].y);
            if (p.openings[i].kind == SIM_OPENING_DOOR) {
                doors++;
                assert_true(fmax(a, b) >= 0.8 - 1e-9);
            } else {
                windows++;
            }
        }
        for (int i = 0; i < p.n_rooms; i++)
            halls += strcmp(p.rooms[i].type, "Hall") == 0;
        assert_int_equal(halls, 1);
        assert_true(doors >= rooms + 1); /* one per room and the entrance */
        assert_int_equal(windows, rooms);
        for (int i = 0; i < p.n_solids; i++)
            assert_int_equal(p.solids[i].is_rect, 1);
        /* The building is closed: no FREE cell next to an OUTSIDE cell except at the entrance. */
        sim_grid_t g;
        assert_int_equal(sim_grid_from_plan(&p, 0.05, &g), 0);
        int leaks = 0;
        for (int r = 0; r < g.h; r++)
            for (int c = 0; c < g.w; c++)
                if (sim_grid_at(&g, c, r) == SIM_CELL_FREE && !in_door(&p, &g, c, r))
                    for (int k = 0; k < 4; k++)
                        leaks += sim_grid_at(&g, c + (k == 0) - (k == 1), r + (k == 2) - (k == 3)) == SIM_CELL_OUTSIDE;
        assert_int_equal(leaks, 0);
        sim_grid_free(&g);
        sim_plan_free(&p);
        free(svg);
    }
}

/* FNV-1a 64 of the text. */
static uint64_t fnv1a(const char *s)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (; *s; s++)
        h = (h ^ (uint8_t)*s) * 0x100000001b3ull;
    return h;
}

/* Plans of one band are the bytes they were before the wings (hashes of the files the
 * generator wrote then): tours and results made from them stay valid. */
static void test_one_band_unchanged(void **state)
{
    (void)state;
    static const struct {
        unsigned long seed;
        int rooms;
        size_t len;
        uint64_t fnv;
    } golden[] = {
        {0, 2, 1540, 0x23702a4e86b1fb25ull},    {1, 6, 3191, 0xeb4c6faf7629cb0bull},
        {7, 16, 7146, 0x0b8b0091ad4e1019ull},   {42, 10, 4812, 0xf014dc22e37eea20ull},
        {1234, 13, 6176, 0xd5db96f4caad40a4ull}, {99, 16, 7360, 0xa41299a04d1b3785ull},
    };
    for (size_t i = 0; i < sizeof golden / sizeof *golden; i++) {
        char *svg = NULL;
        assert_int_equal(sim_plangen_svg(golden[i].seed, golden[i].rooms, &svg), 0);
        if (strlen(svg) != golden[i].len || fnv1a(svg) != golden[i].fnv)
            fail_msg("seed %lu rooms %d: %zu bytes, FNV %016llx; was %zu bytes, %016llx", golden[i].seed,
                     golden[i].rooms, strlen(svg), (unsigned long long)fnv1a(svg), golden[i].len,
                     (unsigned long long)golden[i].fnv);
        free(svg);
    }
}

/* FREE cells 4-connected to (x, y), marked in seen (w x h). */
static void flood_free(const sim_grid_t *g, double x, double y, uint8_t *seen)
{
    int c, r;
    assert_int_equal(sim_grid_world_to_cell(g, x, y, &c, &r), 0);
    assert_int_equal(sim_grid_at(g, c, r), SIM_CELL_FREE);
    size_t n = (size_t)g->w * (size_t)g->h;
    int *queue = malloc(n * sizeof *queue);
    assert_non_null(queue);
    int head = 0, tail = 0;
    queue[tail++] = r * g->w + c;
    seen[r * g->w + c] = 1;
    while (head < tail) {
        int i = queue[head++];
        for (int k = 0; k < 4; k++) {
            int cc = i % g->w + (k == 0) - (k == 1), rr = i / g->w + (k == 2) - (k == 3);
            if (sim_grid_at(g, cc, rr) == SIM_CELL_FREE && !seen[rr * g->w + cc]) {
                seen[rr * g->w + cc] = 1;
                queue[tail++] = rr * g->w + cc;
            }
        }
    }
    free(queue);
}

/* Offices of 17..64 rooms: the wings' structure, closed walls, windows in every room, the
 * entrance, and every room reachable from the entrance through free cells. */
static void test_wings(void **state)
{
    (void)state;
    for (unsigned long seed = 0; seed < 8; seed++) {
        int rooms = SIM_PLANGEN_BAND_ROOMS + 1 + (int)(seed * 37 % (SIM_PLANGEN_MAX_ROOMS - SIM_PLANGEN_BAND_ROOMS));
        if (seed == 0)
            rooms = SIM_PLANGEN_MAX_ROOMS;
        int wings = (rooms + SIM_PLANGEN_BAND_ROOMS - 1) / SIM_PLANGEN_BAND_ROOMS;
        char *svg = NULL, *again = NULL;
        assert_int_equal(sim_plangen_svg(seed, rooms, &svg), 0);
        assert_int_equal(sim_plangen_svg(seed, rooms, &again), 0);
        assert_string_equal(svg, again);
        free(again);
        sim_plan_t p;
        char err[256];
        if (sim_plan_parse(svg, "gen.svg", 0.0, &p, err, sizeof err) != 0)
            fail_msg("seed %lu rooms %d: %s", seed, rooms, err);
        free(svg);
        assert_int_equal(p.n_rooms, rooms + wings + 1); /* + a corridor per wing + the spine */
        int halls = 0, doors = 0, windows = 0, entrances = 0;
        for (int i = 0; i < p.n_rooms; i++)
            halls += strcmp(p.rooms[i].type, "Hall") == 0;
        assert_int_equal(halls, wings + 1);
        sim_grid_t g;
        assert_int_equal(sim_grid_from_plan(&p, 0.05, &g), 0);
        for (int i = 0; i < p.n_openings; i++) {
            if (p.openings[i].kind != SIM_OPENING_DOOR) {
                windows++;
                continue;
            }
            doors++;
            /* The entrance: the one door with the outside on one side. */
            const sim_poly_t *o = &p.openings[i].outline;
            double x0 = fmin(o->p[0].x, o->p[2].x), x1 = fmax(o->p[0].x, o->p[2].x);
            double ym = 0.5 * (o->p[0].y + o->p[2].y);
            entrances += sim_plan_classify_point(&p, x1 + 0.1, ym) == SIM_CELL_OUTSIDE ||
                         sim_plan_classify_point(&p, x0 - 0.1, ym) == SIM_CELL_OUTSIDE;
        }
        assert_int_equal(windows, rooms);
        assert_true(doors >= rooms + 1);
        assert_int_equal(entrances, 1);
        for (int i = 0; i < p.n_solids; i++)
            assert_int_equal(p.solids[i].is_rect, 1);
        int leaks = 0;
        for (int r = 0; r < g.h; r++)
            for (int c = 0; c < g.w; c++)
                if (sim_grid_at(&g, c, r) == SIM_CELL_FREE && !in_door(&p, &g, c, r))
                    for (int k = 0; k < 4; k++)
                        leaks += sim_grid_at(&g, c + (k == 0) - (k == 1), r + (k == 2) - (k == 3)) == SIM_CELL_OUTSIDE;
        assert_int_equal(leaks, 0);
        /* Every room reachable from the spine (room 0) through free cells. */
        uint8_t *seen = calloc((size_t)g.w * (size_t)g.h, 1);
        assert_non_null(seen);
        const sim_poly_t *sp = &p.rooms[0].outline;
        flood_free(&g, 0.5 * (sp->p[0].x + sp->p[2].x), 0.5 * (sp->p[0].y + sp->p[2].y), seen);
        for (int k = 0; k < p.n_rooms; k++) {
            const sim_poly_t *o = &p.rooms[k].outline;
            int c, r;
            assert_int_equal(sim_grid_world_to_cell(&g, 0.5 * (o->p[0].x + o->p[2].x), 0.5 * (o->p[0].y + o->p[2].y),
                                                    &c, &r), 0);
            if (!seen[r * g.w + c])
                fail_msg("seed %lu rooms %d: room %d (%s) cannot be reached", seed, rooms, k, p.rooms[k].type);
        }
        free(seen);
        sim_grid_free(&g);
        sim_plan_free(&p);
    }
}

/* host_sim/plans/office64.svg is `host_sim plan gen --seed 1 --rooms 64` byte for byte. */
static void test_shipped_office(void **state)
{
    (void)state;
    FILE *f = fopen("host_sim/plans/office64.svg", "rb");
    assert_non_null(f);
    static char file[1 << 20];
    size_t n = fread(file, 1, sizeof file - 1, f);
    fclose(f);
    file[n] = '\0';
    char *svg = NULL;
    assert_int_equal(sim_plangen_svg(1, 64, &svg), 0);
    assert_string_equal(file, svg);
    free(svg);
}

static void test_deterministic(void **state)
{
    (void)state;
    char *a = NULL, *b = NULL, *c = NULL;
    assert_int_equal(sim_plangen_svg(42, 6, &a), 0);
    assert_int_equal(sim_plangen_svg(42, 6, &b), 0);
    assert_int_equal(sim_plangen_svg(43, 6, &c), 0);
    assert_string_equal(a, b);
    assert_true(strcmp(a, c) != 0);
    free(a);
    free(b);
    free(c);
    alloc_count_reset();
    assert_int_equal(sim_plangen_svg(1, SIM_PLANGEN_MIN_ROOMS - 1, &a), -EINVAL);
    assert_null(a);
    assert_int_equal(sim_plangen_svg(1, SIM_PLANGEN_MAX_ROOMS + 1, &a), -EINVAL);
    assert_int_equal(sim_plangen_svg(1, 4, NULL), -EINVAL);
    assert_int_equal(alloc_count_allocations(), 0); /* rejected before any allocation */
}

static void test_write_file(void **state)
{
    (void)state;
    char dir[] = "/tmp/test_plangen_XXXXXX", file[64], err[256];
    assert_non_null(mkdtemp(dir));
    snprintf(file, sizeof file, "%s/p.svg", dir);
    assert_int_equal(sim_plangen_write(file, 7, 5, err, sizeof err), 0);
    sim_plan_t p;
    assert_int_equal(sim_plan_load(file, 0.0, &p, err, sizeof err), 0);
    assert_int_equal(p.n_rooms, 6);
    sim_plan_free(&p);
    unlink(file);
    rmdir(dir);
    assert_true(sim_plangen_write("/dev/null/p.svg", 7, 5, err, sizeof err) < 0);
    assert_non_null(strstr(err, "/dev/null/p.svg: Not a directory"));
}

/* Generated plans are navigable: tours for several robots with clearance and coverage. */
static void test_generated_plans_have_tours(void **state)
{
    (void)state;
    for (unsigned long seed = 100; seed < 108; seed++) {
        int rooms = 3 + (int)(seed % 6);
        char *svg = NULL;
        assert_int_equal(sim_plangen_svg(seed, rooms, &svg), 0);
        sim_plan_t p;
        char err[256];
        assert_int_equal(sim_plan_parse(svg, "gen.svg", 0.0, &p, err, sizeof err), 0);
        free(svg);
        sim_paths_cfg_t cfg;
        sim_paths_cfg_default(&cfg);
        cfg.n_robots = 3;
        cfg.seed = seed;
        sim_path_t paths[3];
        if (sim_paths_generate(&p, &cfg, paths, err, sizeof err) != 0)
            fail_msg("seed %lu: %s", seed, err);
        sim_grid_t g;
        assert_int_equal(sim_grid_from_plan(&p, 0.05, &g), 0);
        double cov = sim_paths_coverage(&g, paths, 3, 1.5);
        if (cov < 0.9)
            fail_msg("seed %lu: coverage %.3f", seed, cov);
        for (int r = 0; r < 3; r++) {
            assert_true(sim_path_min_clearance(&p, &paths[r]) >= cfg.clearance_m);
            sim_path_free(&paths[r]);
        }
        sim_grid_free(&g);
        sim_plan_free(&p);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_many_seeds),
        cmocka_unit_test(test_one_band_unchanged),
        cmocka_unit_test(test_wings),
        cmocka_unit_test(test_shipped_office),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_write_file),
        cmocka_unit_test(test_generated_plans_have_tours),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
