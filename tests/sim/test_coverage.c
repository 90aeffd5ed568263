/* Coverage grid (sim_coverage): rays mark what they cross and nothing behind a wall, coverage is
 * monotone in time and within [0, 1], merge is the union, the file round-trips byte for byte
 * and every damaged file is refused with a reason, and the same scans give the same bytes. */
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

#include "common/crc32.h"
#include "sim_coverage.h"
#include "sim_grid.h"

#define PI 3.14159265358979323846

/* Two rooms on a 0.1 m grid of 30 x 20 cells: walls on rows 0 and 19 and columns 0, 19, 29;
 * room A columns 1..18 (x 0.1 .. 1.9 m), room B columns 20..28 behind the wall column 19. */
static void two_rooms(sim_grid_t *g)
{
    assert_int_equal(sim_grid_init(g, 0.1, 0.0, 0.0, 30, 20), 0);
    for (int r = 0; r < 20; r++)
        for (int c = 0; c < 30; c++) {
            const int wall = r == 0 || r == 19 || c == 0 || c == 19 || c == 29;
            g->cells[r * 30 + c] = wall ? SIM_CELL_WALL : SIM_CELL_FREE;
        }
}

static sim_coverage_t cov_new(void)
{
    sim_grid_t g;
    two_rooms(&g);
    sim_coverage_t c;
    assert_int_equal(sim_coverage_from_grid(&c, &g), 0);
    sim_grid_free(&g);
    return c;
}

static hal_lidar_scan_t scan_cfg(uint32_t n)
{
    hal_lidar_scan_t s;
    memset(&s, 0, sizeof s);
    s.count = n;
    s.angle_min_rad = 0.0f;
    s.angle_step_rad = (float)(2.0 * PI / n);
    s.range_min_m = 0.12f;
    s.range_max_m = 3.5f;
    return s;
}

/* A full scan from (x, y) in room A whose ranges are the true distances to its inner faces. */
static void scan_room_a(sim_coverage_t *c, double t, double x, double y)
{
    static hal_lidar_scan_t s;
    s = scan_cfg(360);
    for (uint32_t i = 0; i < s.count; i++) {
        const double a = (double)i * (double)s.angle_step_rad, ca = cos(a), sa = sin(a);
        double r = INFINITY;
        if (ca > 1e-12) r = fmin(r, (1.9 - x) / ca);
        if (ca < -1e-12) r = fmin(r, (0.1 - x) / ca);
        if (sa > 1e-12) r = fmin(r, (1.9 - y) / sa);
        if (sa < -1e-12) r = fmin(r, (0.1 - y) / sa);
        s.ranges_m[i] = (float)r;
    }
    assert_int_equal(sim_coverage_add_scan(c, t, x, y, 0.0, &s), 0);
}

static float at(const sim_coverage_t *c, int col, int row)
{
    return c->first_seen[row * c->w + col];
}

static void test_room_scan_marks_crossed_cells_only(void **state)
{
    (void)state;
    sim_coverage_t c = cov_new();
    assert_int_equal((int)c.n_free, 18 * 18 + 9 * 18);
    assert_true(at(&c, 5, 5) == INFINITY && at(&c, 0, 0) == SIM_COVERAGE_NOT_FREE);
    scan_room_a(&c, 2.5, 1.0, 1.0);
    int seen_a = 0;
    for (int r = 1; r <= 18; r++) {
        for (int col = 1; col <= 18; col++)
            seen_a += at(&c, col, r) == 2.5f;
        for (int col = 20; col <= 28; col++) /* behind the wall: never */
            if (at(&c, col, r) != INFINITY)
                fail_msg("cell (%d, %d) behind the wall is seen at %g", col, r, (double)at(&c, col, r));
    }
    for (int r = 0; r < 20; r++) /* walls stay walls */
        assert_true(at(&c, 19, r) == SIM_COVERAGE_NOT_FREE && at(&c, 0, r) == SIM_COVERAGE_NOT_FREE);
    /* 360 beams from the middle cross every cell of the 1.8 m room (1 degree is 2.2 cm at 1.27 m). */
    assert_int_equal(seen_a, 18 * 18);
    assert_true(fabs(sim_coverage_at(&c, 2.5) - (18.0 * 18.0) / (18.0 * 18.0 + 9.0 * 18.0)) < 1e-12);
    assert_true(sim_coverage_at(&c, 2.4) == 0.0);
    assert_true(c.t_end == 2.5);
    sim_coverage_free(&c);
}

static void test_single_beams(void **state)
{
    (void)state;
    sim_coverage_t c = cov_new();
    hal_lidar_scan_t s = scan_cfg(1);
    s.ranges_m[0] = 0.3f; /* from (1.05, 1.05) along +x: x up to 1.35, columns 10..13 of row 10 */
    assert_int_equal(sim_coverage_add_scan(&c, 1.0, 1.05, 1.05, 0.0, &s), 0);
    for (int col = 10; col <= 13; col++)
        assert_true(at(&c, col, 10) == 1.0f);
    assert_true(at(&c, 14, 10) == INFINITY && at(&c, 9, 10) == INFINITY && at(&c, 11, 11) == INFINITY);
    assert_int_equal((int)sim_coverage_seen(&c, 1.0), 4);
    /* No return: free up to range_max (0.4 m along +y from (0.55, 0.15): rows 1..5). */
    s.ranges_m[0] = INFINITY;
    s.range_max_m = 0.4f;
    assert_int_equal(sim_coverage_add_scan(&c, 2.0, 0.55, 0.15, PI / 2, &s), 0);
    for (int r = 1; r <= 5; r++)
        assert_true(at(&c, 5, r) == 2.0f);
    assert_true(at(&c, 5, 6) == INFINITY);
    /* Dropouts and returns closer than range_min see nothing; a later scan never moves a time. */
    s.ranges_m[0] = NAN;
    assert_int_equal(sim_coverage_add_scan(&c, 3.0, 1.55, 1.55, 0.0, &s), 0);
    s.ranges_m[0] = 0.05f;
    assert_int_equal(sim_coverage_add_scan(&c, 3.0, 1.55, 1.55, 0.0, &s), 0);
    assert_true(at(&c, 15, 15) == INFINITY);
    s.ranges_m[0] = 0.3f;
    s.range_max_m = 3.5f;
    assert_int_equal(sim_coverage_add_scan(&c, 4.0, 1.05, 1.05, 0.0, &s), 0);
    assert_true(at(&c, 12, 10) == 1.0f);
    assert_int_equal((int)sim_coverage_seen(&c, 1e9), 9);
    /* Bad input: refused, nothing marked. */
    assert_int_equal(sim_coverage_add_scan(&c, NAN, 1.0, 1.0, 0.0, &s), -EINVAL);
    assert_int_equal(sim_coverage_add_scan(&c, -1.0, 1.0, 1.0, 0.0, &s), -EINVAL);
    assert_int_equal(sim_coverage_add_scan(&c, 1.0, INFINITY, 1.0, 0.0, &s), -EINVAL);
    s.count = 0;
    assert_int_equal(sim_coverage_add_scan(&c, 1.0, 1.0, 1.0, 0.0, &s), -EINVAL);
    assert_int_equal((int)sim_coverage_seen(&c, 1e9), 9);
    sim_coverage_free(&c);
}

static void test_monotone_in_time(void **state)
{
    (void)state;
    sim_coverage_t c = cov_new();
    scan_room_a(&c, 0.0, 0.4, 0.4);
    scan_room_a(&c, 3.0, 1.6, 1.6);
    scan_room_a(&c, 7.5, 1.0, 0.3);
    double prev = 0.0;
    assert_true(sim_coverage_at(&c, -1.0) == 0.0);
    for (double t = 0.0; t <= 10.0; t += 0.25) {
        const double v = sim_coverage_at(&c, t);
        assert_true(v >= prev && v >= 0.0 && v <= 1.0);
        prev = v;
    }
    assert_true(sim_coverage_at(&c, 0.0) > 0.0);
    /* The CSV: its header, a row a second, the last at t_end, and the same values. */
    FILE *f = tmpfile();
    assert_non_null(f);
    assert_int_equal(sim_coverage_write_csv(&c, 3, 1.0, f), 0);
    rewind(f);
    char line[256];
    assert_non_null(fgets(line, sizeof line, f));
    assert_string_equal(line, SIM_COVERAGE_CSV_HEADER);
    int rows = 0;
    double t = -1, rs = 0, v = 0, last = 0;
    while (fgets(line, sizeof line, f) != NULL) {
        double tt;
        assert_int_equal(sscanf(line, "%lf,%lf,%lf", &tt, &rs, &v), 3);
        assert_true(tt > t && fabs(rs - 3.0 * tt) < 1e-6 && v >= last && v <= 1.0);
        assert_true(fabs(v - sim_coverage_at(&c, tt)) < 1e-6);
        t = tt;
        last = v;
        rows++;
    }
    assert_int_equal(rows, 9); /* 0, 1, ..., 7 and 7.5 */
    assert_true(t == 7.5);
    fclose(f);
    sim_coverage_free(&c);
}

static void test_merge_is_union(void **state)
{
    (void)state;
    sim_coverage_t a = cov_new(), b = cov_new(), u = cov_new();
    scan_room_a(&a, 1.0, 0.4, 0.4);
    scan_room_a(&b, 2.0, 1.6, 1.6);
    scan_room_a(&b, 0.5, 1.7, 0.3);
    assert_int_equal(sim_coverage_merge(&u, &a), 0);
    assert_int_equal(sim_coverage_merge(&u, &b), 0);
    uint64_t either = 0;
    for (int i = 0; i < a.w * a.h; i++) {
        assert_true(u.first_seen[i] == fminf(a.first_seen[i], b.first_seen[i]));
        either += a.first_seen[i] >= 0 && (isfinite(a.first_seen[i]) || isfinite(b.first_seen[i]));
    }
    assert_true(sim_coverage_seen(&u, 1e9) == either);
    assert_true(sim_coverage_at(&u, 5.0) >= sim_coverage_at(&a, 5.0));
    assert_true(sim_coverage_at(&u, 5.0) >= sim_coverage_at(&b, 5.0));
    assert_true(u.t_end == 2.0);
    /* Another grid: refused, dst unchanged. */
    sim_grid_t g;
    assert_int_equal(sim_grid_init(&g, 0.1, 0.0, 0.0, 30, 21), 0);
    sim_coverage_t other;
    assert_int_equal(sim_coverage_from_grid(&other, &g), 0);
    sim_grid_free(&g);
    const uint64_t before = sim_coverage_seen(&u, 1e9);
    assert_int_equal(sim_coverage_merge(&u, &other), -EINVAL);
    assert_true(sim_coverage_seen(&u, 1e9) == before);
    b.first_seen[0] = INFINITY; /* a wall free in one, not in the other */
    assert_int_equal(sim_coverage_merge(&a, &b), -EINVAL);
    sim_coverage_free(&other);
    sim_coverage_free(&a);
    sim_coverage_free(&b);
    sim_coverage_free(&u);
}

static void test_file_round_trip_and_determinism(void **state)
{
    (void)state;
    sim_coverage_t a = cov_new(), b = cov_new(), r;
    scan_room_a(&a, 0.1, 0.4, 0.4);
    scan_room_a(&a, 0.2, 1.6, 1.6);
    scan_room_a(&b, 0.1, 0.4, 0.4);
    scan_room_a(&b, 0.2, 1.6, 1.6);
    uint8_t *ba = NULL, *bb = NULL;
    size_t la = 0, lb = 0;
    assert_int_equal(sim_coverage_encode(&a, &ba, &la), 0);
    assert_int_equal(sim_coverage_encode(&b, &bb, &lb), 0);
    assert_true(la == SIM_COVERAGE_HEADER_BYTES + 4u * 30u * 20u && la == lb);
    assert_memory_equal(ba, bb, la);
    char dir[] = "/tmp/test_coverage_XXXXXX", path[128], err[256];
    assert_non_null(mkdtemp(dir));
    snprintf(path, sizeof path, "%s/coverage.bin", dir);
    assert_int_equal(sim_coverage_write(&a, path, err, sizeof err), 0);
    assert_int_equal(sim_coverage_read(&r, path, err, sizeof err), 0);
    assert_true(r.w == a.w && r.h == a.h && r.res == a.res && r.origin.x == a.origin.x &&
                r.origin.y == a.origin.y && r.t_end == a.t_end && r.n_free == a.n_free);
    assert_memory_equal(r.first_seen, a.first_seen, sizeof(float) * 600u);
    uint8_t *br = NULL;
    size_t lr = 0;
    assert_int_equal(sim_coverage_encode(&r, &br, &lr), 0);
    assert_true(lr == la);
    assert_memory_equal(br, ba, la);
    free(br);
    sim_coverage_free(&r);
    unlink(path);
    rmdir(dir);
    free(ba);
    free(bb);
    sim_coverage_free(&a);
    sim_coverage_free(&b);
}

/* A copy of the good bytes with one change, decoded: must fail with a reason, c left empty. */
static void expect_refused(const uint8_t *buf, size_t len, const char *reason_part)
{
    sim_coverage_t c;
    const char *why = NULL;
    assert_int_equal(sim_coverage_decode(&c, buf, len, &why), -EINVAL);
    assert_non_null(why);
    if (strstr(why, reason_part) == NULL)
        fail_msg("reason '%s' does not say '%s'", why, reason_part);
    assert_null(c.first_seen);
}

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void test_damaged_files_refused(void **state)
{
    (void)state;
    sim_coverage_t a = cov_new();
    scan_room_a(&a, 1.0, 1.0, 1.0);
    uint8_t *good = NULL;
    size_t len = 0;
    assert_int_equal(sim_coverage_encode(&a, &good, &len), 0);
    uint8_t *b = malloc(len + 8);
    assert_non_null(b);
    expect_refused(good, 10, "truncated");
    expect_refused(good, len - 1, "truncated");
    memcpy(b, good, len);
    memset(b + len, 0, 8);
    expect_refused(b, len + 8, "trailing");
    memcpy(b, good, len);
    b[0] = 'X';
    expect_refused(b, len, "magic");
    memcpy(b, good, len);
    put32(b + 8, 2);
    expect_refused(b, len, "version");
    memcpy(b, good, len);
    put32(b + 12, 31); /* wrong dims: the size no longer matches */
    expect_refused(b, len, "truncated");
    memcpy(b, good, len);
    put32(b + 16, 0);
    expect_refused(b, len, "dimensions");
    memcpy(b, good, len);
    put32(b + 12, 0xffffffffu);
    expect_refused(b, len, "dimensions");
    memcpy(b, good, len);
    b[SIM_COVERAGE_HEADER_BYTES + 4 * 45] ^= 0x10;
    expect_refused(b, len, "CRC");
    memcpy(b, good, len); /* a NaN cell with a matching CRC */
    put32(b + SIM_COVERAGE_HEADER_BYTES + 4 * 45, 0x7fc00000u);
    put32(b + 20, crc32_ieee(b + SIM_COVERAGE_HEADER_BYTES, len - SIM_COVERAGE_HEADER_BYTES));
    expect_refused(b, len, "NaN");
    memcpy(b, good, len); /* a time after t_end */
    const float late = 100.0f;
    uint32_t u;
    memcpy(&u, &late, 4);
    put32(b + SIM_COVERAGE_HEADER_BYTES + 4 * 45, u);
    put32(b + 20, crc32_ieee(b + SIM_COVERAGE_HEADER_BYTES, len - SIM_COVERAGE_HEADER_BYTES));
    expect_refused(b, len, "out of range");
    memcpy(b, good, len);
    b[56] ^= 1; /* the free-cell count */
    expect_refused(b, len, "free-cell");
    /* Through files: a truncated one, an empty one, a folder, a missing one; the error names the
       path. */
    char dir[] = "/tmp/test_coverage_XXXXXX", path[128], err[256];
    assert_non_null(mkdtemp(dir));
    snprintf(path, sizeof path, "%s/coverage.bin", dir);
    const size_t cuts[] = {len - 4, 40, 0};
    for (size_t k = 0; k < 3; k++) {
        FILE *f = fopen(path, "wb");
        assert_non_null(f);
        assert_int_equal(fwrite(good, 1, cuts[k], f), cuts[k]);
        fclose(f);
        sim_coverage_t c;
        err[0] = '\0';
        assert_true(sim_coverage_read(&c, path, err, sizeof err) < 0);
        assert_non_null(strstr(err, path));
        assert_non_null(strstr(err, "truncated"));
        assert_null(c.first_seen);
    }
    unlink(path);
    sim_coverage_t c;
    assert_true(sim_coverage_read(&c, path, err, sizeof err) < 0);
    assert_non_null(strstr(err, path));
    assert_true(sim_coverage_read(&c, dir, err, sizeof err) < 0);
    rmdir(dir);
    free(b);
    free(good);
    sim_coverage_free(&a);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_room_scan_marks_crossed_cells_only),
        cmocka_unit_test(test_single_beams),
        cmocka_unit_test(test_monotone_in_time),
        cmocka_unit_test(test_merge_is_union),
        cmocka_unit_test(test_file_round_trip_and_determinism),
        cmocka_unit_test(test_damaged_files_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
