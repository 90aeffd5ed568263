/* Scan -> samples labelling (firmware rt_samples) and the samples file format (round trip,
 * every corruption rejected with a clear error). */
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

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#include "rt/rt_samples.h"
#include "sim_samples.h"

static rt_samples_cfg_t box_cfg(int beams, int points)
{
    /* Bounding box [-5, 5] x [-2, 8]: normalised x = x / 5, y = (y - 3) / 5. */
    rt_samples_cfg_t c = {beams, points, -5.0f, -2.0f, 5.0f, 8.0f};
    return c;
}

static void test_labelling_hit_and_spacing(void **st)
{
    (void)st;
    /* 4 beams: 0 (hit at 2 m), 90 deg (no hit), 180 (hit at 1 m), 270 (dropout). */
    float ranges[4] = {2.0f, INFINITY, 1.0f, NAN};
    rt_scan_view_t sc = {ranges, 4, 0.0f, (float)(M_PI / 2), 3.5f};
    rt_samples_cfg_t c = box_cfg(4, 5);
    ai_sample_t out[20];
    int32_t n = -1;
    rt_samples_stats_t stt;
    alloc_count_reset();
    assert_int_equal(rt_samples_from_scan(&c, &sc, 0.0f, 3.0f, 0.0f, out, 20, &n, &stt), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_int_equal(n, 15); /* 3 beams x 5 points, the dropout skipped */
    assert_int_equal(stt.beams_used, 3);
    assert_int_equal(stt.beams_hit, 2);
    assert_int_equal(stt.beams_dropped, 1);
    /* Beam 0: points at 0.4, 0.8, 1.2, 1.6, 2.0 m along +x; the last is the hit. */
    for (int k = 0; k < 5; k++) {
        assert_float_equal(out[k].x, 0.4f * (k + 1) / 5.0f, 1e-6);
        assert_float_equal(out[k].y, 0.0f, 1e-6);
        assert_float_equal(out[k].occ, k == 4 ? 1.0f : 0.0f, 0);
    }
    /* Beam 1: no hit -> free points to range_max 3.5 m along +y, all 0. */
    for (int k = 0; k < 5; k++) {
        assert_float_equal(out[5 + k].x, 0.0f, 1e-6);
        assert_float_equal(out[5 + k].y, 3.5f * (k + 1) / 5.0f / 5.0f, 1e-6);
        assert_float_equal(out[5 + k].occ, 0.0f, 0);
    }
    /* Beam 2: hit at 1 m along -x. */
    assert_float_equal(out[14].x, -0.2f, 1e-6);
    assert_float_equal(out[14].occ, 1.0f, 0);
    assert_float_equal(out[10].x, -0.04f, 1e-6);
    assert_float_equal(out[10].occ, 0.0f, 0);
}

static void test_beam_subsampling_and_heading(void **st)
{
    (void)st;
    /* 360-beam scan, 20 beams used: scan indices 0, 18, 36, ...; robot heading 90 deg. */
    float ranges[360];
    for (int i = 0; i < 360; i++)
        ranges[i] = 1.0f + 0.001f * (float)i; /* distinguishable per beam */
    rt_scan_view_t sc = {ranges, 360, 0.0f, (float)(2 * M_PI / 360), 3.5f};
    rt_samples_cfg_t c = box_cfg(20, 25);
    ai_sample_t out[500];
    int32_t n;
    assert_int_equal(rt_samples_from_scan(&c, &sc, 0.0f, 3.0f, (float)(M_PI / 2), out, 500, &n, NULL), 0);
    assert_int_equal(n, 500);
    for (int j = 0; j < 20; j++) {
        int i = j * 18;
        double a = M_PI / 2 + i * 2 * M_PI / 360, d = 1.0 + 0.001 * i;
        const ai_sample_t *hit = &out[j * 25 + 24];
        assert_float_equal(hit->occ, 1.0f, 0);
        assert_float_equal(hit->x, d * cos(a) / 5.0, 1e-5);
        assert_float_equal(hit->y, d * sin(a) / 5.0, 1e-5);
        /* Evenly spaced: consecutive points differ by d / 25 metres. */
        double dx = (out[j * 25 + 1].x - out[j * 25].x) * 5.0, dy = (out[j * 25 + 1].y - out[j * 25].y) * 5.0;
        assert_float_equal(hypot(dx, dy), d / 25.0, 1e-5);
    }
}

static void test_out_of_box_and_errors(void **st)
{
    (void)st;
    float ranges[1] = {INFINITY};
    rt_scan_view_t sc = {ranges, 1, 0.0f, 1.0f, 3.5f};
    rt_samples_cfg_t c = box_cfg(1, 10);
    ai_sample_t out[10];
    int32_t n;
    rt_samples_stats_t stt;
    /* From x = 4 towards +x: points beyond x = 5 leave the box and are dropped. */
    assert_int_equal(rt_samples_from_scan(&c, &sc, 4.0f, 3.0f, 0.0f, out, 10, &n, &stt), 0);
    assert_int_equal(n, 2); /* 4.35 and 4.7; 5.05 .. 7.5 are outside */
    assert_int_equal(stt.points_outside, 8);
    for (int i = 0; i < n; i++)
        assert_true(out[i].x >= -1.0f && out[i].x <= 1.0f);
    assert_int_equal(rt_samples_from_scan(&c, &sc, 0, 3, 0, out, 9, &n, NULL), -ENOSPC);
    c.n_beams = 2; /* more beams than the scan has */
    assert_int_equal(rt_samples_from_scan(&c, &sc, 0, 3, 0, out, 10, &n, NULL), -EINVAL);
    c = box_cfg(1, 10);
    c.max_x = c.min_x;
    assert_int_equal(rt_samples_from_scan(&c, &sc, 0, 3, 0, out, 10, &n, NULL), -EINVAL);
    c = box_cfg(1, 10);
    assert_int_equal(rt_samples_from_scan(&c, &sc, NAN, 3, 0, out, 10, &n, NULL), -EINVAL);
}

/* ---- file format ---- */
static char path_buf[64];

static const char *tmp_path(void)
{
    snprintf(path_buf, sizeof path_buf, "/tmp/test_samples_%d.bin", (int)getpid());
    return path_buf;
}

static void write_file(const char *p, int n)
{
    sim_samples_writer_t w;
    assert_int_equal(sim_samples_open(&w, p, -1.5, -2.0, 10.5, 7.25, 1234, "unit test"), 0);
    for (int i = 0; i < n; i++) {
        ai_sample_t s = {(float)i / n * 2 - 1, (float)(n - i) / n * 2 - 1, (float)(i % 2)};
        assert_int_equal(sim_samples_append(&w, &s, 1), 0);
    }
    assert_int_equal(sim_samples_close(&w), 0);
}

static void test_file_round_trip(void **st)
{
    (void)st;
    const char *p = tmp_path();
    write_file(p, 1000);
    sim_samples_header_t h;
    ai_sample_t *r;
    char err[256];
    assert_int_equal(sim_samples_read(p, &h, &r, err, sizeof err), 0);
    assert_int_equal(h.count, 1000);
    assert_int_equal(h.seed, 1234);
    assert_float_equal(h.min_x, -1.5, 0);
    assert_float_equal(h.max_y, 7.25, 0);
    assert_string_equal(h.source, "unit test");
    for (int i = 0; i < 1000; i++) {
        assert_float_equal(r[i].x, (float)i / 1000 * 2 - 1, 0);
        assert_float_equal(r[i].occ, (float)(i % 2), 0);
    }
    free(r);
    /* Empty file is valid. */
    write_file(p, 0);
    assert_int_equal(sim_samples_read(p, &h, &r, err, sizeof err), 0);
    assert_int_equal(h.count, 0);
    assert_null(r);
    /* The writer refuses out-of-range records. */
    sim_samples_writer_t w;
    assert_int_equal(sim_samples_open(&w, p, 0, 0, 1, 1, 0, NULL), 0);
    ai_sample_t bad = {1.5f, 0, 0};
    assert_int_equal(sim_samples_append(&w, &bad, 1), -EINVAL);
    sim_samples_abort(&w);
    assert_int_equal(sim_samples_open(&w, p, 0, 0, 0, 1, 0, NULL), -EINVAL);
    remove(p);
}

static long file_size(const char *p)
{
    FILE *f = fopen(p, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long s = ftell(f);
    fclose(f);
    return s;
}

static void poke(const char *p, long off, const void *bytes, size_t n)
{
    FILE *f = fopen(p, "r+b");
    assert_non_null(f);
    assert_int_equal(fseek(f, off, SEEK_SET), 0);
    assert_int_equal(fwrite(bytes, 1, n, f), n);
    fclose(f);
}

static void expect_error(const char *p, const char *what)
{
    sim_samples_header_t h;
    ai_sample_t *r = (ai_sample_t *)1;
    char err[256] = "";
    assert_int_equal(sim_samples_read(p, &h, &r, err, sizeof err), -EINVAL);
    assert_null(r);
    if (strstr(err, what) == NULL)
        fail_msg("error '%s' does not mention '%s'", err, what);
}

static void test_file_corruptions(void **st)
{
    (void)st;
    const char *p = tmp_path();
    /* Truncated: cut the last 10 bytes. */
    write_file(p, 100);
    assert_int_equal(truncate(p, file_size(p) - 10), 0);
    expect_error(p, "truncated");
    /* Truncated inside the header. */
    write_file(p, 100);
    assert_int_equal(truncate(p, 100), 0);
    expect_error(p, "truncated header");
    /* Bad magic. */
    write_file(p, 100);
    poke(p, 0, "XX", 2);
    expect_error(p, "bad magic");
    /* Bad count: claim fewer records than stored (header CRC recomputed so only the count
     * is wrong). */
    write_file(p, 100);
    {
        FILE *f = fopen(p, "r+b");
        uint8_t h[SIM_SAMPLES_HEADER_SIZE];
        assert_int_equal(fread(h, 1, sizeof h, f), sizeof h);
        h[24] = 50;
        uint32_t c = sim_crc32_update(0, h, 204);
        for (int i = 0; i < 4; i++)
            h[204 + i] = (uint8_t)(c >> (8 * i));
        fseek(f, 0, SEEK_SET);
        assert_int_equal(fwrite(h, 1, sizeof h, f), sizeof h);
        fclose(f);
    }
    expect_error(p, "bad count");
    /* Header field changed without fixing its CRC. */
    write_file(p, 100);
    poke(p, 64, "\x07", 1);
    expect_error(p, "header CRC");
    /* A flipped bit in a record: data CRC. */
    write_file(p, 100);
    poke(p, SIM_SAMPLES_HEADER_SIZE + 12 * 40 + 1, "\x55", 1);
    expect_error(p, "data CRC");
    /* Unsupported version (with a consistent header CRC). */
    write_file(p, 3);
    {
        FILE *f = fopen(p, "r+b");
        uint8_t h[SIM_SAMPLES_HEADER_SIZE];
        assert_int_equal(fread(h, 1, sizeof h, f), sizeof h);
        h[8] = 9;
        uint32_t c = sim_crc32_update(0, h, 204);
        for (int i = 0; i < 4; i++)
            h[204 + i] = (uint8_t)(c >> (8 * i));
        fseek(f, 0, SEEK_SET);
        assert_int_equal(fwrite(h, 1, sizeof h, f), sizeof h);
        fclose(f);
    }
    expect_error(p, "version");
    /* Missing file: an errno code, not a crash. */
    remove(p);
    sim_samples_header_t h;
    ai_sample_t *r;
    char err[256];
    assert_int_equal(sim_samples_read(p, &h, &r, err, sizeof err), -ENOENT);
    /* Known CRC-32 check value. */
    assert_int_equal(sim_crc32_update(0, "123456789", 9), 0xCBF43926u);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_labelling_hit_and_spacing),
        cmocka_unit_test(test_beam_subsampling_and_heading),
        cmocka_unit_test(test_out_of_box_and_errors),
        cmocka_unit_test(test_file_round_trip),
        cmocka_unit_test(test_file_corruptions),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
