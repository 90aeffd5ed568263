/* gp_telemetry: wire round trip, exact layout, and rejection of every malformed input. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "gp/gp_telemetry.h"

static gp_telemetry_t sample(void)
{
    gp_telemetry_t t = {.robot_id = 3, .round = 1234, .stamp_us = 0x0102030405060708ull,
                        .x_m = 4.25f, .y_m = -1.5f, .heading_rad = 3.0f, .loss_train = 0.5f,
                        .loss_val = NAN, .pool_fill = 900, .pool_capacity = 1024,
                        .ring_drops = 7, .net_drops = 2, .neighbours = 6};
    return t;
}

static void test_round_trip_and_layout(void **state)
{
    (void)state;
    gp_telemetry_t t = sample(), back;
    uint8_t buf[GP_TELEMETRY_WIRE_BYTES];
    alloc_count_reset();
    assert_int_equal(gp_telemetry_encode(&t, buf, sizeof(buf)), 0);
    assert_int_equal(gp_telemetry_decode(buf, sizeof(buf), &back), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_int_equal(back.robot_id, 3);
    assert_int_equal(back.round, 1234);
    assert_true(back.stamp_us == t.stamp_us);
    assert_true(back.x_m == 4.25f && back.y_m == -1.5f && back.heading_rad == 3.0f);
    assert_true(back.loss_train == 0.5f && isnan(back.loss_val));
    assert_int_equal(back.pool_fill, 900);
    assert_int_equal(back.pool_capacity, 1024);
    assert_int_equal(back.ring_drops, 7);
    assert_int_equal(back.net_drops, 2);
    assert_int_equal(back.neighbours, 6);
    /* Little-endian, fixed offsets. */
    static const uint8_t head[] = {'F', 'T', 'L', 'M', 1, 0, 64, 0, 3, 0, 0, 0, 0xD2, 0x04, 0, 0,
                                   8, 7, 6, 5, 4, 3, 2, 1};
    assert_memory_equal(buf, head, sizeof(head));
    assert_int_equal(buf[60], 6);
}

static void test_rejects_malformed(void **state)
{
    (void)state;
    gp_telemetry_t t = sample(), back;
    uint8_t buf[GP_TELEMETRY_WIRE_BYTES], bad[GP_TELEMETRY_WIRE_BYTES];
    assert_int_equal(gp_telemetry_encode(&t, buf, sizeof(buf) - 1), -EINVAL);
    assert_int_equal(gp_telemetry_encode(NULL, buf, sizeof(buf)), -EINVAL);
    assert_int_equal(gp_telemetry_encode(&t, buf, sizeof(buf)), 0);
    assert_int_equal(gp_telemetry_decode(buf, sizeof(buf) - 1, &back), -EBADMSG);
    assert_int_equal(gp_telemetry_decode(NULL, sizeof(buf), &back), -EINVAL);
    const size_t offsets[] = {0, 4, 6};
    for (size_t i = 0; i < 3; i++) {
        memcpy(bad, buf, sizeof(buf));
        bad[offsets[i]] ^= 0x40;
        assert_int_equal(gp_telemetry_decode(bad, sizeof(bad), &back), -EBADMSG);
    }
    /* Out-of-range fields, each encoded by hand past the encoder's own check. */
    gp_telemetry_t f = t;
    f.pool_fill = 2000;
    assert_int_equal(gp_telemetry_encode(&f, buf, sizeof(buf)), -EINVAL);
    f = t;
    f.heading_rad = 4.0f;
    assert_int_equal(gp_telemetry_encode(&f, buf, sizeof(buf)), -EINVAL);
    f = t;
    f.loss_train = -1.0f;
    assert_int_equal(gp_telemetry_encode(&f, buf, sizeof(buf)), -EINVAL);
    assert_int_equal(gp_telemetry_encode(&t, buf, sizeof(buf)), 0);
    memcpy(bad, buf, sizeof(buf));
    const float inf = INFINITY;
    memcpy(bad + 24, &inf, 4); /* x = +inf (host is little-endian) */
    assert_int_equal(gp_telemetry_decode(bad, sizeof(bad), &back), -EBADMSG);
    memcpy(bad, buf, sizeof(buf));
    bad[60] = 0;
    bad[61] = 1; /* 256 neighbours */
    assert_int_equal(gp_telemetry_decode(bad, sizeof(bad), &back), -EBADMSG);
    memcpy(bad, buf, sizeof(buf));
    bad[47] = 0x7F; /* pool_fill > capacity */
    assert_int_equal(gp_telemetry_decode(bad, sizeof(bad), &back), -EBADMSG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_and_layout),
        cmocka_unit_test(test_rejects_malformed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
