/* The firmware's own codec of the fleet messages (firmware/gp/gp_wire.h) against lcm-gen's:
 * the same fingerprints, byte-identical encodings, lcm-gen's bytes decoded; crafted datagrams
 * refused without touching the output; a deterministic fuzz loop that never crashes (run
 * under ASan by make test-asan). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <string.h>
#include <cmocka.h>

#include "gp/gp_wire.h"
#include "lcm/fleetsim_chunk_request_t.h"
#include "lcm/fleetsim_round_complete_t.h"
#include "lcm/fleetsim_state_chunk_t.h"

static uint8_t data[3000], mine[8192], theirs[8192];

static void test_same_as_lcm_gen(void **st)
{
    (void)st;
    assert_int_equal((uint64_t)__fleetsim_state_chunk_t_get_hash(), GP_WIRE_FP_STATE_CHUNK);
    assert_int_equal((uint64_t)__fleetsim_round_complete_t_get_hash(), GP_WIRE_FP_ROUND_COMPLETE);
    assert_int_equal((uint64_t)__fleetsim_chunk_request_t_get_hash(), GP_WIRE_FP_CHUNK_REQUEST);
    for (size_t i = 0; i < sizeof data; i++)
        data[i] = (uint8_t)(i * 13u);
    const gp_pse_chunk_t c = {3, 41, 2, 5, 12000, 0xCAFEBABEu, 1.25, -7.5, 3000, data, 1, 9, GP_PSE_TO_ALL};
    const int n = gp_wire_encode_chunk(&c, mine, sizeof mine);
    fleetsim_state_chunk_t l = {3, 41, 2, 5, 12000, 1, (int32_t)0xCAFEBABEu, 1.25, -7.5, 9, 3000, data};
    assert_int_equal(fleetsim_state_chunk_t_encode(theirs, 0, (int)sizeof theirs, &l), n);
    assert_memory_equal(mine, theirs, (size_t)n);
    gp_pse_chunk_t back;
    assert_int_equal(gp_wire_decode_chunk(theirs, (size_t)n, &back), 0);
    assert_int_equal(back.round, 41);
    assert_int_equal(back.crc32, 0xCAFEBABEu);
    assert_true(back.x_m == 1.25 && back.y_m == -7.5);
    assert_int_equal(back.incarnation, 9);
    assert_memory_equal(back.data, data, 3000);

    const gp_pse_done_t d = {4, 77, 5, 0, 0.0, 0.0};
    fleetsim_round_complete_t ld = {4, 77, 5, 0, 0.0, 0.0};
    const int nd = gp_wire_encode_done(&d, mine, sizeof mine);
    assert_int_equal(fleetsim_round_complete_t_encode(theirs, 0, (int)sizeof theirs, &ld), nd);
    assert_memory_equal(mine, theirs, (size_t)nd);

    gp_pse_request_t r = {1, 2, 8, 3, {0, 4, 6}, 5, 1, 2.5, -1.25, GP_PSE_TO_ALL};
    int32_t ch[3] = {0, 4, 6};
    fleetsim_chunk_request_t lr = {1, 2, 8, 5, 1, 2.5, -1.25, 3, ch};
    const int nr = gp_wire_encode_request(&r, mine, sizeof mine);
    assert_int_equal(fleetsim_chunk_request_t_encode(theirs, 0, (int)sizeof theirs, &lr), nr);
    assert_memory_equal(mine, theirs, (size_t)nr);
    gp_pse_request_t rb;
    assert_int_equal(gp_wire_decode_request(theirs, (size_t)nr, &rb), 0);
    assert_int_equal(rb.n, 3);
    assert_int_equal(rb.chunks[2], 6);
    assert_int_equal(rb.incarnation, 5);
    assert_int_equal(rb.has_position, 1);
    assert_true(rb.x_m == 2.5 && rb.y_m == -1.25);
    gp_pse_done_t db;
    assert_int_equal(gp_wire_decode_done(theirs, 0, &db), -EBADMSG);
    assert_int_equal(fleetsim_round_complete_t_encode(theirs, 0, (int)sizeof theirs, &ld), nd);
    assert_int_equal(gp_wire_decode_done(theirs, (size_t)nd, &db), 0);
    assert_int_equal(db.incarnation, 5);
    assert_int_equal(db.has_next_position, 0);

    /* with the position of the next round */
    const gp_pse_done_t dn = {4, 77, 5, 1, -3.75, 12.5};
    fleetsim_round_complete_t ldn = {4, 77, 5, 1, -3.75, 12.5};
    const int nn = gp_wire_encode_done(&dn, mine, sizeof mine);
    assert_int_equal(nn, nd);
    assert_int_equal(fleetsim_round_complete_t_encode(theirs, 0, (int)sizeof theirs, &ldn), nn);
    assert_memory_equal(mine, theirs, (size_t)nn);
    assert_int_equal(gp_wire_decode_done(theirs, (size_t)nn, &db), 0);
    assert_int_equal(db.has_next_position, 1);
    assert_true(db.next_x_m == -3.75 && db.next_y_m == 12.5);
}

static void put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24), p[1] = (uint8_t)(v >> 16), p[2] = (uint8_t)(v >> 8), p[3] = (uint8_t)v;
}

static void test_crafted_refused(void **st)
{
    (void)st;
    const gp_pse_chunk_t c = {3, 41, 2, 5, 12000, 1, 0.0, 0.0, 100, data, 0, 0, GP_PSE_TO_ALL};
    const int n = gp_wire_encode_chunk(&c, mine, sizeof mine);
    gp_pse_chunk_t out;
    memset(&out, 0x5A, sizeof out);
    const gp_pse_chunk_t before = out;
    const size_t at_n = GP_WIRE_CHUNK_HEADER_BYTES - 4; /* n_bytes */
    memcpy(theirs, mine, (size_t)n);
    put32(theirs + at_n, 0xFFFFFFFFu); /* n_bytes = -1 */
    assert_int_equal(gp_wire_decode_chunk(theirs, (size_t)n, &out), -EBADMSG);
    put32(theirs + at_n, 0x7FFFFFFFu); /* far past the datagram */
    assert_int_equal(gp_wire_decode_chunk(theirs, (size_t)n, &out), -EBADMSG);
    put32(theirs + at_n, 101); /* one byte past */
    assert_int_equal(gp_wire_decode_chunk(theirs, (size_t)n, &out), -EBADMSG);
    memcpy(theirs, mine, (size_t)n);
    put32(theirs + 8 + 8, 5); /* chunk = n_chunks */
    assert_int_equal(gp_wire_decode_chunk(theirs, (size_t)n, &out), -EBADMSG);
    put32(theirs + 8 + 8, 2);
    put32(theirs + 8 + 12, 0xFFFFFFFFu); /* n_chunks = -1 */
    assert_int_equal(gp_wire_decode_chunk(theirs, (size_t)n, &out), -EBADMSG);
    assert_int_equal(gp_wire_decode_chunk(mine, (size_t)n - 1, &out), -EBADMSG);   /* truncated */
    assert_int_equal(gp_wire_decode_chunk(mine, 7, &out), -EBADMSG);
    mine[0] ^= 1;                                                                    /* another type */
    assert_int_equal(gp_wire_decode_chunk(mine, (size_t)n, &out), -EBADMSG);
    mine[0] ^= 1;
    assert_memory_equal(&out, &before, sizeof out); /* untouched by every refusal */
    gp_pse_request_t r = {1, 2, 8, 1, {3}, 0, 0, 0.0, 0.0, GP_PSE_TO_ALL};
    const int nr = gp_wire_encode_request(&r, mine, sizeof mine);
    put32(mine + 41, 0x7FFFFFFFu); /* n_chunks = INT_MAX (after the fingerprint, 4 ints and the position) */
    gp_pse_request_t rb;
    assert_int_equal(gp_wire_decode_request(mine, (size_t)nr, &rb), -EBADMSG);
    gp_pse_done_t d = {1, 1, 0, 0, 0.0, 0.0};
    const int nd = gp_wire_encode_done(&d, mine, sizeof mine);
    gp_pse_done_t db;
    assert_int_equal(gp_wire_decode_done(mine, (size_t)nd + 1, &db), -EBADMSG); /* trailing byte */
    const size_t at_has = 8 + 12; /* has_next_position: after the fingerprint and 3 ints */
    mine[at_has] = 2;
    assert_int_equal(gp_wire_decode_done(mine, (size_t)nd, &db), -EBADMSG);
    mine[at_has] = 1;
    memset(mine + at_has + 1, 0xFF, 8); /* next_x_m: a NaN */
    assert_int_equal(gp_wire_decode_done(mine, (size_t)nd, &db), -EBADMSG);
    memset(mine + at_has + 1, 0, 8);
    assert_int_equal(gp_wire_decode_done(mine, (size_t)nd, &db), 0);
    assert_true(db.has_next_position == 1 && db.next_x_m == 0.0);
}

static void test_fuzz(void **st)
{
    (void)st;
    uint64_t x = 0x243F6A8885A308D3ull;
    int passed = 0;
    const gp_pse_chunk_t c = {1, 2, 0, 3, 300, 5, 0.5, 0.5, 100, data, 0, 1, GP_PSE_TO_ALL};
    const int n = gp_wire_encode_chunk(&c, mine, sizeof mine);
    for (int it = 0; it < 30000; it++) {
        memcpy(theirs, mine, (size_t)n);
        for (int f = 0; f < 1 + it % 3; f++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            theirs[x % (uint64_t)n] ^= (uint8_t)(1u << ((x >> 40) % 8));
        }
        const size_t len = (size_t)n - (it % 7 == 0 ? (size_t)(x % 9) : 0);
        gp_pse_chunk_t out;
        gp_pse_done_t d;
        gp_pse_request_t r;
        if (gp_wire_decode_chunk(theirs, len, &out) == 0) {
            passed++;
            volatile uint8_t sink = out.data[out.n_bytes ? out.n_bytes - 1 : 0]; /* inside the buffer */
            (void)sink;
        }
        (void)!gp_wire_decode_done(theirs, len, &d);
        (void)!gp_wire_decode_request(theirs, len, &r);
    }
    print_message("fuzz: %d of 30000 mutated chunks decoded\n", passed);
    assert_true(passed > 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_same_as_lcm_gen),
        cmocka_unit_test(test_crafted_refused),
        cmocka_unit_test(test_fuzz),
    };
    return cmocka_run_group_tests_name("gp/wire", tests, NULL, NULL);
}
