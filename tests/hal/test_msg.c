/* The bounds check of fleet datagrams (hal/host/hal_host_msg.h): what lcm-gen's encoder writes
 * passes and decodes; every crafted datagram that would crash or overread lcm-gen 1.3.1's
 * decoder (n_bytes = -1, n_chunks = INT_MAX, lengths past the end, truncation, another type,
 * trailing bytes) is refused with its reason; and a deterministic fuzz loop feeds the
 * generated decoder only what the check passed (run under ASan by make test-asan). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <limits.h>
#include <string.h>
#include <cmocka.h>

#include "hal/hal_net.h"
#include "hal_host_msg.h"
#include "lcm/fleetsim_chunk_request_t.h"
#include "lcm/fleetsim_round_complete_t.h"
#include "lcm/fleetsim_state_chunk_t.h"

static uint8_t buf[HAL_NET_MTU_BYTES + 64];

static int encode_chunk(int32_t n_bytes_field, int32_t real_bytes)
{
    static uint8_t data[4096];
    for (int i = 0; i < (int)sizeof data; i++)
        data[i] = (uint8_t)(i * 7);
    fleetsim_state_chunk_t m = {1, 5, 0, 2, 8000, 0, 0x1234567, 1.5, -2.0, 0, real_bytes, data};
    int n = fleetsim_state_chunk_t_encode(buf, 0, (int)sizeof buf, &m);
    assert_true(n > 0);
    /* n_bytes sits after the hash (8) and ten fields (7 x 4 + 1 + 2 x 8). */
    const int at = 8 + 7 * 4 + 1 + 2 * 8;
    buf[at] = (uint8_t)((uint32_t)n_bytes_field >> 24);
    buf[at + 1] = (uint8_t)((uint32_t)n_bytes_field >> 16);
    buf[at + 2] = (uint8_t)((uint32_t)n_bytes_field >> 8);
    buf[at + 3] = (uint8_t)n_bytes_field;
    return n;
}

static void test_valid_messages_pass_and_decode(void **st)
{
    (void)st;
    int n = encode_chunk(1000, 1000);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_STATE_CHUNK, buf, (size_t)n), HAL_HOST_MSG_OK);
    fleetsim_state_chunk_t d;
    assert_int_equal(fleetsim_state_chunk_t_decode(buf, 0, n, &d), n);
    assert_int_equal(d.n_bytes, 1000);
    fleetsim_state_chunk_t_decode_cleanup(&d);
    fleetsim_round_complete_t rc = {3, 9, 1, 0, 0.0, 0.0};
    n = fleetsim_round_complete_t_encode(buf, 0, (int)sizeof buf, &rc);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_ROUND_COMPLETE, buf, (size_t)n), HAL_HOST_MSG_OK);
    int32_t chunks[3] = {0, 4, 7};
    fleetsim_chunk_request_t rq = {1, 2, 9, 1, 1, 0.5, -0.5, 3, chunks};
    n = fleetsim_chunk_request_t_encode(buf, 0, (int)sizeof buf, &rq);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_CHUNK_REQUEST, buf, (size_t)n), HAL_HOST_MSG_OK);
    /* ANY is raw: no check. */
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_ANY, "x", 1), HAL_HOST_MSG_OK);
}

static void test_crafted_messages_refused(void **st)
{
    (void)st;
    int n = encode_chunk(-1, 100);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_STATE_CHUNK, buf, (size_t)n), HAL_HOST_MSG_BAD_LENGTH);
    n = encode_chunk(INT_MAX, 100);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_STATE_CHUNK, buf, (size_t)n), HAL_HOST_MSG_BAD_LENGTH);
    n = encode_chunk(101, 100); /* one byte past the end */
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_STATE_CHUNK, buf, (size_t)n), HAL_HOST_MSG_SHORT);
    n = encode_chunk(99, 100); /* one byte left over */
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_STATE_CHUNK, buf, (size_t)n), HAL_HOST_MSG_TRAILING);
    n = encode_chunk(100, 100);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_STATE_CHUNK, buf, (size_t)n - 1), HAL_HOST_MSG_SHORT);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_STATE_CHUNK, buf, 7), HAL_HOST_MSG_SHORT);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_ROUND_COMPLETE, buf, (size_t)n), HAL_HOST_MSG_FINGERPRINT);
    buf[3] ^= 1;
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_STATE_CHUNK, buf, (size_t)n), HAL_HOST_MSG_FINGERPRINT);
    /* A chunk request that claims INT_MAX chunks. */
    int32_t chunks[2] = {1, 2};
    fleetsim_chunk_request_t rq = {1, 2, 9, 1, 1, 0.5, -0.5, 2, chunks};
    n = fleetsim_chunk_request_t_encode(buf, 0, (int)sizeof buf, &rq);
    buf[8 + 33] = 0x7f; /* n_chunks: after 4 ints, has_position and the position */
    buf[8 + 34] = buf[8 + 35] = buf[8 + 36] = 0xff;
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_CHUNK_REQUEST, buf, (size_t)n), HAL_HOST_MSG_BAD_LENGTH);
    assert_string_equal(hal_host_msg_reject_name(HAL_HOST_MSG_BAD_LENGTH), "a length field out of range");
}

/* Deterministic mutations of valid datagrams: whatever the check lets through, the generated
 * decoder reads completely and within the buffer. */
static void test_fuzz_decoder_only_sees_checked_bytes(void **st)
{
    (void)st;
    static uint8_t m[8192];
    uint64_t x = 0x9e3779b97f4a7c15ull;
    int passed = 0, refused = 0;
    for (int it = 0; it < 20000; it++) {
        int type = 1 + it % 3;
        int n;
        if (type == HAL_HOST_MSG_STATE_CHUNK) {
            n = encode_chunk(64, 64);
        } else if (type == HAL_HOST_MSG_ROUND_COMPLETE) {
            fleetsim_round_complete_t rc = {1, it, 1, 0, 0.0, 0.0};
            n = fleetsim_round_complete_t_encode(buf, 0, (int)sizeof buf, &rc);
        } else {
            int32_t c[4] = {0, 1, 2, 3};
            fleetsim_chunk_request_t rq = {0, 1, it, 1, 0, 0.0, 0.0, 4, c};
            n = fleetsim_chunk_request_t_encode(buf, 0, (int)sizeof buf, &rq);
        }
        memcpy(m, buf, (size_t)n);
        int flips = 1 + (int)(x % 4);
        for (int f = 0; f < flips; f++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            m[x % (uint64_t)n] ^= (uint8_t)(1u << (x >> 32) % 8);
        }
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        size_t len = (size_t)n - (x % 5 == 0 ? x % 8 : 0); /* sometimes truncated */
        if (hal_host_msg_check((hal_host_msg_type_t)type, m, len) != HAL_HOST_MSG_OK) {
            refused++;
            continue;
        }
        passed++;
        if (type == HAL_HOST_MSG_STATE_CHUNK) {
            fleetsim_state_chunk_t d;
            assert_int_equal(fleetsim_state_chunk_t_decode(m, 0, (int)len, &d), (int)len);
            fleetsim_state_chunk_t_decode_cleanup(&d);
        } else if (type == HAL_HOST_MSG_ROUND_COMPLETE) {
            fleetsim_round_complete_t d;
            assert_int_equal(fleetsim_round_complete_t_decode(m, 0, (int)len, &d), (int)len);
        } else {
            fleetsim_chunk_request_t d;
            assert_int_equal(fleetsim_chunk_request_t_decode(m, 0, (int)len, &d), (int)len);
            fleetsim_chunk_request_t_decode_cleanup(&d);
        }
    }
    print_message("fuzz: %d mutated datagrams passed the check and decoded, %d refused\n", passed, refused);
    assert_true(passed > 1000 && refused > 1000);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_valid_messages_pass_and_decode),
        cmocka_unit_test(test_crafted_messages_refused),
        cmocka_unit_test(test_fuzz_decoder_only_sees_checked_bytes),
    };
    return cmocka_run_group_tests_name("hal/msg", tests, NULL, NULL);
}
