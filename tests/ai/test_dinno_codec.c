/* The exchange codecs (ai/dinno_codec.h): for every codec, on states of the preset and of a
 * small odd-sized configuration (rows of mixed magnitudes, zeros, an all-zero row, a row of
 * subnormals, odd rows for the 4-bit padding): dinno_codec_channel gives the floats of encode +
 * decode_inplace bit for bit (also in place), the in-place decode those of bnn_quant's
 * out-of-place unpack, each element within half its row's step, no allocation; the sizes (int4
 * about half of int8 plus the scales); bad input refused, the buffer untouched; names and
 * parse. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "ai/ai_rng.h"
#include "ai/bnn_quant.h"
#include "ai/dinno_codec.h"

static const dinno_codec_t all_codecs[DINNO_CODEC_COUNT] = {DINNO_CODEC_FP32, DINNO_CODEC_INT8, DINNO_CODEC_INT8_EF,
                                                            DINNO_CODEC_INT4_EF};

static float v[BNN_N_PARAMS], got[BNN_N_PARAMS], chan[BNN_N_PARAMS], ref[BNN_N_PARAMS];
static float wire[DINNO_CODEC_MAX_BYTES / 4u]; /* encoded bytes, decoded in place */
static uint8_t keep[DINNO_CODEC_MAX_BYTES];
static float scales[BNN_QUANT_MAX_ROWS];

static size_t n_params(const bnn_config_t *c)
{
    return BNN_N_MU_OF(c->siren_width, c->hidden_width, c->n_bayes) +
           BNN_N_RHO_OF(c->siren_width, c->hidden_width, c->n_bayes);
}

static size_t rows_of(const bnn_tensor_t *t)
{
    return t->is_bias ? 1u : t->rows;
}

static size_t cols_of(const bnn_tensor_t *t)
{
    return t->is_bias ? (size_t)t->rows * t->cols : t->cols;
}

/* A state with rows of mixed magnitudes (1e-6 .. 1e3, by row), about one value in 16 zero, row 3
   of every tensor all zeros, row 5 of the first weight tensor subnormal. */
static void fill_state(const bnn_config_t *c, uint64_t seed)
{
    const size_t P = n_params(c);
    ai_rng_normal_fill(seed, 1, 0, v, P);
    static float u[BNN_N_PARAMS];
    ai_rng_uniform_fill(seed, 2, 0, u, P);
    bnn_tensor_t T[BNN_MAX_TENSORS];
    const size_t nt = bnn_tensors_cfg(c, T, BNN_MAX_TENSORS);
    for (size_t t = 0; t < nt; t++) {
        const size_t R = rows_of(&T[t]), C = cols_of(&T[t]);
        for (size_t r = 0; r < R; r++) {
            const float mag = powf(10.0f, (float)((int)((t * 7u + r * 3u) % 10u) - 6));
            float *x = v + T[t].offset + r * C;
            for (size_t k = 0; k < C; k++) {
                const float uk = u[T[t].offset + r * C + k];
                x[k] = uk < 0.0625f ? 0.0f : mag * x[k];
                if (r == 3)
                    x[k] = 0.0f;
                if (t == 0 && r == 5)
                    x[k] = 1e-40f * (uk - 0.5f);
            }
        }
    }
}

/* Every element of y within half its row's quantisation step of v (qmax 127 or 7). */
static void check_bound(const bnn_config_t *c, const float *y, float qmax)
{
    bnn_tensor_t T[BNN_MAX_TENSORS];
    const size_t nt = bnn_tensors_cfg(c, T, BNN_MAX_TENSORS);
    for (size_t t = 0; t < nt; t++) {
        const size_t R = rows_of(&T[t]), C = cols_of(&T[t]);
        for (size_t r = 0; r < R; r++) {
            const size_t o = T[t].offset + r * C;
            float amax = 0.0f;
            for (size_t k = 0; k < C; k++)
                amax = fmaxf(amax, fabsf(v[o + k]));
            const double step = (double)amax / qmax;
            for (size_t k = 0; k < C; k++) {
                const double e = fabs((double)v[o + k] - y[o + k]);
                if (step >= 1e-37)
                    assert_true(e <= 0.5 * step * (1.0 + 1e-5));
                else /* a row of subnormals quantises to 0 (bnn_quant.c, row_inv) */
                    assert_true(e <= amax);
            }
        }
    }
}

/* One codec on the state in v: encode, decode in place, channel (out of place and in place),
   bnn_quant's out-of-place unpack; returns the encoded bytes. */
static size_t round_trip(const bnn_config_t *c, dinno_codec_t codec)
{
    const size_t P = n_params(c), bytes = dinno_codec_bytes(c, codec);
    assert_true(bytes > 0 && bytes <= DINNO_CODEC_MAX_BYTES);
    size_t written = 0;
    alloc_count_reset();
    assert_int_equal(dinno_codec_encode(c, codec, v, (uint8_t *)wire, sizeof wire, &written), 0);
    assert_int_equal(written, bytes);
    memcpy(keep, wire, bytes);
    assert_int_equal(dinno_codec_decode_inplace(c, codec, wire, bytes, scales, BNN_QUANT_MAX_ROWS), 0);
    assert_int_equal(dinno_codec_channel(c, codec, v, chan), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    memcpy(got, wire, P * sizeof(float));
    assert_memory_equal(chan, got, P * sizeof(float)); /* bit for bit */
    memcpy(chan, v, P * sizeof(float));
    assert_int_equal(dinno_codec_channel(c, codec, chan, chan), 0);
    assert_memory_equal(chan, got, P * sizeof(float));
    switch (codec) {
    case DINNO_CODEC_FP32:
        assert_memory_equal(got, v, P * sizeof(float));
        assert_int_equal(bytes, 4u * P);
        break;
    case DINNO_CODEC_INT8:
    case DINNO_CODEC_INT8_EF:
        assert_int_equal(bnn_quant_unpack_theta(c, BNN_GROUP_ALL, keep, bytes, ref), 0);
        assert_memory_equal(ref, got, P * sizeof(float));
        check_bound(c, got, 127.0f);
        break;
    case DINNO_CODEC_INT4_EF:
        assert_int_equal(bnn_quant_unpack_theta4(c, BNN_GROUP_ALL, keep, bytes, ref), 0);
        assert_memory_equal(ref, got, P * sizeof(float));
        check_bound(c, got, 7.0f);
        break;
    }
    return bytes;
}

static bnn_config_t odd_cfg(void)
{
    bnn_config_t c = bnn_default_config();
    c.siren_width = 7; /* b0: a row of 7 */
    c.hidden_width = 5; /* rows of 7 and 5, biases of 5, w_out 1 x 5 */
    c.n_bayes = 2;
    return c;
}

static void test_round_trips(void **state)
{
    (void)state;
    const bnn_config_t cfgs[2] = {bnn_default_config(), odd_cfg()};
    for (int ci = 0; ci < 2; ci++)
        for (uint64_t seed = 1; seed <= 3; seed++) {
            fill_state(&cfgs[ci], seed + 10u * (uint64_t)ci);
            for (unsigned k = 0; k < DINNO_CODEC_COUNT; k++)
                (void)round_trip(&cfgs[ci], all_codecs[k]);
        }
}

/* The 4-bit in-place decode of arbitrary value bytes (every nibble, 8 = -8 included) is the
   out-of-place one's, bit for bit. */
static void test_int4_any_nibbles(void **state)
{
    (void)state;
    const bnn_config_t cfgs[2] = {bnn_default_config(), odd_cfg()};
    for (int ci = 0; ci < 2; ci++) {
        const bnn_config_t *c = &cfgs[ci];
        const size_t P = n_params(c), bytes = dinno_codec_bytes(c, DINNO_CODEC_INT4_EF);
        fill_state(c, 7);
        size_t written = 0;
        assert_int_equal(dinno_codec_encode(c, DINNO_CODEC_INT4_EF, v, keep, sizeof keep, &written), 0);
        /* the values' bytes replaced, the scales kept */
        bnn_tensor_t T[BNN_MAX_TENSORS];
        const size_t nt = bnn_tensors_cfg(c, T, BNN_MAX_TENSORS);
        size_t at = 0;
        uint32_t x = 12345u;
        for (size_t t = 0; t < nt; t++) {
            const size_t R = rows_of(&T[t]), D = R * ((cols_of(&T[t]) + 1u) / 2u);
            at += 4u * R;
            for (size_t b = 0; b < D; b++) {
                x = x * 1664525u + 1013904223u;
                keep[at + b] = (uint8_t)(x >> 24);
            }
            at += D;
        }
        assert_int_equal(at, bytes);
        assert_int_equal(bnn_quant_unpack_theta4(c, BNN_GROUP_ALL, keep, bytes, ref), 0);
        memcpy(wire, keep, bytes);
        assert_int_equal(dinno_codec_decode_inplace(c, DINNO_CODEC_INT4_EF, wire, bytes, scales, BNN_QUANT_MAX_ROWS), 0);
        assert_memory_equal(wire, ref, P * sizeof(float));
    }
}

static size_t rows_total(const bnn_config_t *c)
{
    bnn_tensor_t T[BNN_MAX_TENSORS];
    const size_t nt = bnn_tensors_cfg(c, T, BNN_MAX_TENSORS);
    size_t rows = 0;
    for (size_t t = 0; t < nt; t++)
        rows += rows_of(&T[t]);
    return rows;
}

static void test_sizes(void **state)
{
    (void)state;
    const bnn_config_t cfgs[2] = {bnn_default_config(), odd_cfg()};
    for (int ci = 0; ci < 2; ci++) {
        const bnn_config_t *c = &cfgs[ci];
        const size_t P = n_params(c), rows = rows_total(c);
        size_t b[DINNO_CODEC_COUNT];
        for (unsigned k = 0; k < DINNO_CODEC_COUNT; k++)
            b[k] = dinno_codec_bytes(c, all_codecs[k]);
        assert_int_equal(b[DINNO_CODEC_FP32], 4u * P);
        assert_int_equal(b[DINNO_CODEC_INT8], P + 4u * rows);
        assert_int_equal(b[DINNO_CODEC_INT8_EF], b[DINNO_CODEC_INT8]);
        /* the values in half the bytes (at most half a byte more per row), the same scales */
        const size_t v8 = b[DINNO_CODEC_INT8] - 4u * rows, v4 = b[DINNO_CODEC_INT4_EF] - 4u * rows;
        assert_true(2u * v4 >= v8 && 2u * v4 <= v8 + rows);
        assert_int_equal(b[DINNO_CODEC_INT4_EF], bnn_quant_packed_size4_cfg(c, BNN_GROUP_ALL));
        if (ci == 0) {
            assert_true(b[DINNO_CODEC_INT8] <= BNN_QUANT_MAX_BYTES);
            assert_true(b[DINNO_CODEC_INT4_EF] <= BNN_QUANT4_MAX_BYTES);
            assert_true(rows <= BNN_QUANT_MAX_ROWS);
            print_message("preset %s: %zu parameters, %zu rows; bytes per state: fp32 %zu, int8 %zu, int8-ef %zu, "
                          "int4-ef %zu (%.2fx fewer than fp32, %.2fx fewer than int8)\n",
                          BNN_PRESET_NAME, P, rows, b[0], b[1], b[2], b[3], (double)b[0] / (double)b[3],
                          (double)b[1] / (double)b[3]);
        }
    }
}

static void test_refused(void **state)
{
    (void)state;
    const bnn_config_t c = bnn_default_config();
    const size_t P = n_params(&c);
    fill_state(&c, 5);
    size_t w = 0;
    const dinno_codec_t bad_codec = (dinno_codec_t)DINNO_CODEC_COUNT;
    bnn_config_t bad_cfg = c;
    bad_cfg.n_bayes = BNN_LAYERS_MAX + 1u;
    assert_int_equal(dinno_codec_bytes(&c, bad_codec), 0);
    assert_int_equal(dinno_codec_bytes(NULL, DINNO_CODEC_FP32), 0);
    assert_int_equal(dinno_codec_bytes(&bad_cfg, DINNO_CODEC_INT8), 0);
    for (unsigned k = 0; k < DINNO_CODEC_COUNT; k++) {
        const dinno_codec_t cd = all_codecs[k];
        const size_t n = dinno_codec_bytes(&c, cd);
        /* encode */
        assert_int_equal(dinno_codec_encode(NULL, cd, v, keep, sizeof keep, &w), -EINVAL);
        assert_int_equal(dinno_codec_encode(&bad_cfg, cd, v, keep, sizeof keep, &w), -EINVAL);
        assert_int_equal(dinno_codec_encode(&c, cd, NULL, keep, sizeof keep, &w), -EINVAL);
        assert_int_equal(dinno_codec_encode(&c, cd, v, NULL, sizeof keep, &w), -EINVAL);
        assert_int_equal(dinno_codec_encode(&c, cd, v, keep, sizeof keep, NULL), -EINVAL);
        assert_int_equal(dinno_codec_encode(&c, cd, v, keep, n - 1u, &w), -ENOSPC);
        /* channel */
        assert_int_equal(dinno_codec_channel(NULL, cd, v, chan), -EINVAL);
        assert_int_equal(dinno_codec_channel(&c, cd, NULL, chan), -EINVAL);
        assert_int_equal(dinno_codec_channel(&c, cd, v, NULL), -EINVAL);
        /* decode: a good state, then spoiled; refused with the buffer untouched */
        assert_int_equal(dinno_codec_encode(&c, cd, v, keep, sizeof keep, &w), 0);
        memcpy(wire, keep, n);
        assert_int_equal(dinno_codec_decode_inplace(NULL, cd, wire, n, scales, BNN_QUANT_MAX_ROWS), -EINVAL);
        assert_int_equal(dinno_codec_decode_inplace(&c, cd, NULL, n, scales, BNN_QUANT_MAX_ROWS), -EINVAL);
        assert_int_equal(dinno_codec_decode_inplace(&c, cd, wire, n - 1u, scales, BNN_QUANT_MAX_ROWS), -EBADMSG);
        assert_int_equal(dinno_codec_decode_inplace(&c, cd, wire, n + 1u, scales, BNN_QUANT_MAX_ROWS), -EBADMSG);
        assert_memory_equal(wire, keep, n);
        if (cd == DINNO_CODEC_FP32) {
            for (int s = 0; s < 3; s++) { /* NaN, +inf, -inf anywhere */
                const float bad = s == 0 ? NAN : (s == 1 ? INFINITY : -INFINITY);
                const size_t at = (size_t)s * 7919u % P;
                memcpy((uint8_t *)wire + 4u * at, &bad, 4);
                memcpy(keep, wire, n);
                assert_int_equal(dinno_codec_decode_inplace(&c, cd, wire, n, NULL, 0), -EBADMSG);
                assert_memory_equal(wire, keep, n);
                memcpy(chan, v, P * sizeof(float));
                chan[at] = bad;
                assert_int_equal(dinno_codec_channel(&c, cd, chan, got), -EINVAL);
                /* fp32 sends anything: the receivers refuse it */
                assert_int_equal(dinno_codec_encode(&c, cd, chan, keep, sizeof keep, &w), 0);
                memcpy(wire, keep, n);
            }
            assert_int_equal(dinno_codec_decode_inplace(&c, cd, wire, n, NULL, 0), -EBADMSG);
        } else {
            assert_int_equal(dinno_codec_decode_inplace(&c, cd, wire, n, NULL, BNN_QUANT_MAX_ROWS), -EINVAL);
            assert_int_equal(dinno_codec_decode_inplace(&c, cd, wire, n, scales, 3), -EINVAL);
            assert_memory_equal(wire, keep, n);
            const float bad_scales[4] = {NAN, INFINITY, -1.0f, -INFINITY};
            for (int s = 0; s < 4; s++) {
                memcpy(wire, keep, n);
                memcpy((uint8_t *)wire + 4u * (size_t)(s + 1), &bad_scales[s], 4); /* a row of W0 */
                memcpy(ref, wire, n);
                assert_int_equal(dinno_codec_decode_inplace(&c, cd, wire, n, scales, BNN_QUANT_MAX_ROWS), -EBADMSG);
                assert_memory_equal(wire, ref, n);
            }
            memcpy(wire, keep, n);
            /* a non-finite value: refused by encode and channel */
            const float nf[3] = {NAN, INFINITY, -INFINITY};
            for (int s = 0; s < 3; s++) {
                memcpy(chan, v, P * sizeof(float));
                chan[(size_t)(s + 1) * 4001u % P] = nf[s];
                assert_int_equal(dinno_codec_encode(&c, cd, chan, keep, sizeof keep, &w), -EINVAL);
                assert_int_equal(dinno_codec_channel(&c, cd, chan, got), -EINVAL);
            }
        }
    }
    assert_int_equal(dinno_codec_encode(&c, bad_codec, v, keep, sizeof keep, &w), -EINVAL);
    assert_int_equal(dinno_codec_encode(&c, (dinno_codec_t)-1, v, keep, sizeof keep, &w), -EINVAL);
    assert_int_equal(dinno_codec_decode_inplace(&c, bad_codec, wire, 4u * P, scales, BNN_QUANT_MAX_ROWS), -EINVAL);
    assert_int_equal(dinno_codec_channel(&c, bad_codec, v, chan), -EINVAL);
    assert_int_equal(bnn_quant_round_trip_theta(&c, 5u, v, chan), -EINVAL);
}

static void test_names(void **state)
{
    (void)state;
    const char *const want[DINNO_CODEC_COUNT] = {"fp32", "int8", "int8-ef", "int4-ef"};
    for (unsigned k = 0; k < DINNO_CODEC_COUNT; k++) {
        dinno_codec_t p = DINNO_CODEC_FP32;
        assert_string_equal(dinno_codec_name(all_codecs[k]), want[k]);
        assert_int_equal(dinno_codec_parse(dinno_codec_name(all_codecs[k]), &p), 0);
        assert_int_equal(p, all_codecs[k]);
        assert_int_equal(dinno_codec_is_ef(all_codecs[k]), k >= 2u);
    }
    dinno_codec_t p = DINNO_CODEC_INT8;
    const char *const bad[] = {"", "int4", "INT8", "fp32 ", "int8ef", "?"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        assert_int_equal(dinno_codec_parse(bad[i], &p), -EINVAL);
    assert_int_equal(p, DINNO_CODEC_INT8);
    assert_int_equal(dinno_codec_parse(NULL, &p), -EINVAL);
    assert_int_equal(dinno_codec_parse("fp32", NULL), -EINVAL);
    assert_string_equal(dinno_codec_name((dinno_codec_t)DINNO_CODEC_COUNT), "?");
    assert_int_equal(dinno_codec_is_ef((dinno_codec_t)DINNO_CODEC_COUNT), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trips),
        cmocka_unit_test(test_int4_any_nibbles),
        cmocka_unit_test(test_sizes),
        cmocka_unit_test(test_refused),
        cmocka_unit_test(test_names),
    };
    return cmocka_run_group_tests_name("ai/dinno_codec", tests, NULL, NULL);
}
