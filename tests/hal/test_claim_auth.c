/* An exploration claim (fleetsim.goal_claim_t) on a keyed fleet's channel: sealed by a member it
 * opens and passes the bounds check and the decoder; under another key, or moved to another
 * channel, its tag fails and the HAL drops it before anything reads it (hal_host_auth.h); the
 * bounds check of its typed channel refuses truncated and oversized bytes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "hal_host_auth.h"
#include "hal_host_msg.h"
#include "gp/gp_wire.h"

#define CH "fleetsim/3/goal"

static void test_claim_sealed_and_checked(void **st)
{
    (void)st;
    assert_int_equal(hal_host_auth_init(), 0);
    hal_host_auth_t me, stranger;
    memset(me.key, 7, sizeof me.key);
    memset(stranger.key, 8, sizeof stranger.key);
    me.run_id = stranger.run_id = 1000;
    const gp_goal_claim_t c = {2, 17, 8.5, 4.5, 3.0, 5000000u};
    uint8_t wire[GP_WIRE_CLAIM_BYTES + 1u + HAL_HOST_AUTH_TRAILER_BYTES], forged[sizeof wire];
    const int n = gp_wire_encode_claim(&c, wire, sizeof wire);
    assert_int_equal(n, GP_WIRE_CLAIM_BYTES);
    memcpy(forged, wire, (size_t)n);
    hal_host_auth_seal(&me, CH, wire, (size_t)n);
    hal_host_auth_seal(&stranger, CH, forged, (size_t)n);
    const size_t total = (size_t)n + HAL_HOST_AUTH_TRAILER_BYTES;
    size_t len = 0;
    assert_int_equal(hal_host_auth_open(&me, CH, forged, total, &len), HAL_HOST_AUTH_BAD_TAG);
    assert_int_equal(hal_host_auth_open(&me, "fleetsim/3/state", wire, total, &len), HAL_HOST_AUTH_BAD_TAG);
    /* A forger changing the goal of a genuine claim breaks its tag. */
    memcpy(forged, wire, total);
    forged[20] ^= 1u;
    assert_int_equal(hal_host_auth_open(&me, CH, forged, total, &len), HAL_HOST_AUTH_BAD_TAG);
    assert_int_equal(hal_host_auth_open(&me, CH, wire, total, &len), HAL_HOST_AUTH_OK);
    assert_int_equal(len, GP_WIRE_CLAIM_BYTES);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_GOAL_CLAIM, wire, len), HAL_HOST_MSG_OK);
    gp_goal_claim_t back;
    assert_int_equal(gp_wire_decode_claim(wire, len, &back), 0);
    assert_memory_equal(&back, &c, sizeof c);
    /* The typed channel's bounds check: truncated, trailing bytes, another type. */
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_GOAL_CLAIM, wire, len - 1u), HAL_HOST_MSG_SHORT);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_GOAL_CLAIM, wire, len + 1u), HAL_HOST_MSG_TRAILING);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_ROUND_COMPLETE, wire, len), HAL_HOST_MSG_FINGERPRINT);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_claim_sealed_and_checked),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
