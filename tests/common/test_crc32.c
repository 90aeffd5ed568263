/* CRC-32 (firmware/common/crc32): the check value, and the table-driven code of this board
 * (slicing by 8, or nibbles on boards with CRC32_SLICE8 0) against the bitwise definition for
 * every length up to 64 bytes at every alignment, a large random buffer, and pieces fed
 * incrementally; where the build folds (crc32_x86.c: 64-byte steps, 256-byte steps with
 * AVX-512), every length to 1100 bytes at odd alignments, lengths around larger multiples of
 * 256 and the states' sizes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "common/crc32.h"

static uint32_t crc_bitwise(const uint8_t *p, size_t n)
{
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; i++) {
        c ^= p[i];
        for (int k = 0; k < 8; k++)
            c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
    }
    return ~c;
}

static uint8_t buf[1 << 18];

static void fill(void)
{
    uint32_t x = 12345u;
    for (size_t i = 0; i < sizeof buf; i++) {
        x = x * 1664525u + 1013904223u;
        buf[i] = (uint8_t)(x >> 24);
    }
}

static void test_check_value(void **st)
{
    (void)st;
    assert_int_equal(crc32_ieee("123456789", 9), 0xCBF43926u);
    assert_int_equal(crc32_ieee("", 0), 0u);
}

static void test_every_length_and_alignment(void **st)
{
    (void)st;
    fill();
    for (size_t off = 0; off < 8; off++)
        for (size_t n = 0; n <= 64; n++)
            assert_int_equal(crc32_ieee(buf + off, n), crc_bitwise(buf + off, n));
    assert_int_equal(crc32_ieee(buf, sizeof buf), crc_bitwise(buf, sizeof buf));
    /* Past the 64 bytes where a folding implementation starts: every tail of 16-byte blocks
       and bytes, and a state's size. */
    for (size_t off = 0; off < 4; off++)
        for (size_t n = 65; n <= 300; n++)
            assert_int_equal(crc32_ieee(buf + off, n), crc_bitwise(buf + off, n));
    assert_int_equal(crc32_ieee(buf + 3, 33601u), crc_bitwise(buf + 3, 33601u));
}

static void test_long_lengths(void **st)
{
    (void)st;
    fill();
    /* Zero, one or more 256-byte blocks, then every tail of 64- and 16-byte blocks and bytes. */
    static const size_t offs[] = {0, 1, 3, 5, 7, 13};
    for (size_t k = 0; k < sizeof offs / sizeof offs[0]; k++)
        for (size_t n = 0; n <= 1100; n++)
            assert_int_equal(crc32_ieee(buf + offs[k], n), crc_bitwise(buf + offs[k], n));
    static const size_t around[] = {1024, 2048, 4096, 65536};
    for (size_t k = 0; k < sizeof around / sizeof around[0]; k++)
        for (size_t n = around[k] - 33; n <= around[k] + 33; n++)
            assert_int_equal(crc32_ieee(buf + 1, n), crc_bitwise(buf + 1, n));
    /* The small preset's fp32 state (33601 x 4 bytes) and the host's largest chunk (60 KB less
       its header room), at every alignment mod 4. */
    static const size_t sizes[] = {134404, 61376};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++)
        for (size_t off = 0; off < 4; off++)
            assert_int_equal(crc32_ieee(buf + off, sizes[k]), crc_bitwise(buf + off, sizes[k]));
}

static void test_incremental(void **st)
{
    (void)st;
    fill();
    const uint32_t whole = crc32_ieee(buf, sizeof buf);
    static const size_t cuts[] = {1, 3, 7, 8, 13, 1000, 4097, 60000};
    for (size_t k = 0; k < sizeof cuts / sizeof cuts[0]; k++) {
        uint32_t c = crc32_ieee_update(0u, buf, cuts[k]);
        c = crc32_ieee_update(c, buf + cuts[k], sizeof buf - cuts[k]);
        assert_int_equal(c, whole);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_check_value),
        cmocka_unit_test(test_every_length_and_alignment),
        cmocka_unit_test(test_long_lengths),
        cmocka_unit_test(test_incremental),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
