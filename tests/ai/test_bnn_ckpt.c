/* Checkpoints: round trip (with and without Adam state), and rejection of truncated,
 * bit-flipped, wrong-magic, wrong-version and other-configuration buffers, each leaving the
 * model byte-for-byte unchanged; CRC-32 known answers. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "ai/ai_rng.h"
#include "ai/bnn_ckpt.h"
#include "common/crc32.h"

static bnn_model_t a, b;
static uint8_t buf[BNN_CKPT_MAX_BYTES];
static ai_sample_t batch[64];

static void train_a_bit(bnn_model_t *m)
{
    float u[3 * 64];
    ai_rng_uniform_fill(3, 3, 0, u, 3 * 64);
    for (int i = 0; i < 64; i++)
        batch[i] = (ai_sample_t){2 * u[3 * i] - 1, 2 * u[3 * i + 1] - 1, u[3 * i + 2] > 0.7f};
    for (int s = 0; s < 3; s++)
        assert_int_equal(bnn_train_step(m, batch, 64, 1e-3f, (uint64_t)s, 1e-3f, NULL), 0);
}

static bnn_config_t tiny(void)
{
    bnn_config_t c = bnn_default_config();
    c.siren_width = c.siren_width < 32 ? c.siren_width : 32;
    c.hidden_width = c.hidden_width < 16 ? c.hidden_width : 16;
    c.n_bayes = 2;
    c.max_batch = 64;
    return c;
}

static void test_crc32(void **state)
{
    (void)state;
    assert_int_equal(crc32_ieee("123456789", 9), 0xCBF43926u);
    assert_int_equal(crc32_ieee("", 0), 0u);
    assert_int_equal(crc32_ieee("The quick brown fox jumps over the lazy dog", 43), 0x414FA339u);
    uint32_t c = crc32_ieee_update(0, "1234", 4);
    assert_int_equal(crc32_ieee_update(c, "56789", 5), 0xCBF43926u);
}

static void test_round_trip(void **state)
{
    (void)state;
    bnn_config_t c = tiny();
    assert_int_equal(bnn_init(&a, &c, 11), 0);
    train_a_bit(&a);
    size_t n = 0;
    assert_int_equal(bnn_ckpt_save(&a, 1, buf, 10, &n), -ENOSPC);
    alloc_count_reset();
    assert_int_equal(bnn_ckpt_save(&a, 1, buf, sizeof buf, &n), 0);
    assert_int_equal(n, bnn_ckpt_size(&a, 1));
    assert_int_equal(bnn_init(&b, &c, 999), 0);
    const char *why = NULL;
    assert_int_equal(bnn_ckpt_load(&b, buf, n, &why), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_memory_equal(bnn_params(&a), bnn_params(&b), bnn_n_params(&a) * sizeof(float));
    assert_true(a.seed == b.seed);
    assert_int_equal(a.adam[0].t, b.adam[0].t);
    /* continued training is identical, Adam state included */
    train_a_bit(&a);
    train_a_bit(&b);
    assert_memory_equal(bnn_params(&a), bnn_params(&b), bnn_n_params(&a) * sizeof(float));
    /* without Adam */
    assert_int_equal(bnn_ckpt_save(&a, 0, buf, sizeof buf, &n), 0);
    assert_int_equal(n, BNN_CKPT_HEADER_BYTES + 4 * bnn_n_params(&a));
    assert_int_equal(bnn_ckpt_load(&b, buf, n, &why), 0);
    assert_memory_equal(bnn_params(&a), bnn_params(&b), bnn_n_params(&a) * sizeof(float));
    assert_int_equal(b.adam[0].t, 0);
}

/* Every corrupt load fails with the expected code and leaves b untouched. */
static void expect_reject(const uint8_t *p, size_t len, int code)
{
    static bnn_model_t before;
    memcpy(&before, &b, sizeof b);
    const char *why = NULL;
    int rc = bnn_ckpt_load(&b, p, len, &why);
    print_message("  rejected (%d): %s\n", rc, why ? why : "(null)");
    assert_int_equal(rc, code);
    assert_true(why != NULL && strlen(why) > 5);
    assert_memory_equal(&before, &b, sizeof b);
}

static void test_rejects_bad_buffers(void **state)
{
    (void)state;
    bnn_config_t c = tiny();
    assert_int_equal(bnn_init(&a, &c, 21), 0);
    train_a_bit(&a);
    assert_int_equal(bnn_init(&b, &c, 22), 0);
    size_t n = 0;
    assert_int_equal(bnn_ckpt_save(&a, 1, buf, sizeof buf, &n), 0);
    /* truncated: inside the header, inside the payload, one byte short */
    expect_reject(buf, 10, -ENODATA);
    expect_reject(buf, n / 2, -ENODATA);
    expect_reject(buf, n - 1, -ENODATA);
    /* bit flips: payload, header fingerprint-free fields, the CRC itself */
    const size_t flips[] = {BNN_CKPT_HEADER_BYTES + 5, n - 1, 33, 41, 57};
    for (size_t f = 0; f < sizeof flips / sizeof flips[0]; f++) {
        buf[flips[f]] ^= 0x10;
        expect_reject(buf, n, -EILSEQ);
        buf[flips[f]] ^= 0x10;
    }
    buf[0] = 'X';
    expect_reject(buf, n, -EBADMSG);
    buf[0] = 'B';
    buf[4] = 9;
    expect_reject(buf, n, -EPROTONOSUPPORT);
    buf[4] = 1;
    /* other configuration (as a checkpoint of another preset would be) */
    bnn_config_t c2 = c;
    c2.hidden_width = c.hidden_width - 1;
    static bnn_model_t other;
    assert_int_equal(bnn_init(&other, &c2, 1), 0);
    size_t n2 = 0;
    assert_int_equal(bnn_ckpt_save(&other, 0, buf, sizeof buf, &n2), 0);
    expect_reject(buf, n2, -ENOEXEC);
    /* the original still loads */
    assert_int_equal(bnn_ckpt_save(&a, 1, buf, sizeof buf, &n), 0);
    const char *why;
    assert_int_equal(bnn_ckpt_load(&b, buf, n, &why), 0);
    assert_int_equal(bnn_ckpt_load(NULL, buf, n, &why), -EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_crc32),
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_rejects_bad_buffers),
    };
    return cmocka_run_group_tests_name("ai/bnn_ckpt", tests, NULL, NULL);
}
