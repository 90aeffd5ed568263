/* The fleet's wire bytes, frozen: messages encoded by gp_wire must equal the bytes captured from
 * the hand-written codec this table-driven one replaced (so a peer built before the change and
 * one built after still talk), decode back to the same fields, re-encode to the same bytes, and
 * pass hal/host's bounds check of their type. A change of a .lcm file that changes these bytes
 * changes the protocol: then the fingerprint changes too, and these arrays are re-captured on
 * purpose. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <string.h>
#include <cmocka.h>

#include "gp/gp_wire.h"
#include "hal_host_msg.h"

/* Captured from gp_wire.c as of the hand-written codec (one put32/put64 per field). */
static const uint8_t GOLDEN_CHUNK[73] = {
    0xdf, 0x65, 0x60, 0x2b, 0x2d, 0x04, 0xbf, 0x15, 0x00, 0x00, 0x00, 0x03,
    0x00, 0x00, 0x00, 0x29, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x05,
    0x00, 0x00, 0x2e, 0xe0, 0x01, 0xca, 0xfe, 0xba, 0xbe, 0x3f, 0xf4, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x1e, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x09, 0x00, 0x00, 0x00, 0x10, 0x07, 0x14, 0x21,
    0x2e, 0x3b, 0x48, 0x55, 0x62, 0x6f, 0x7c, 0x89, 0x96, 0xa3, 0xb0, 0xbd,
    0xca,
};
static const uint8_t GOLDEN_CHUNK_EMPTY[57] = {
    0xdf, 0x65, 0x60, 0x2b, 0x2d, 0x04, 0xbf, 0x15, 0x7f, 0xff, 0xff, 0xff,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01,
    0x00, 0x00, 0x00, 0x01, 0x00, 0xff, 0xff, 0xff, 0xff, 0x80, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x44, 0xdf, 0xe1, 0x85, 0xca, 0x57, 0xc5,
    0x17, 0xff, 0xff, 0xff, 0xff, 0x00, 0x00, 0x00, 0x00,
};
/* Re-captured when round_complete_t gained the sender's position of the next round
 * (has_next_position, next_x_m, next_y_m): round k + 1 then opens without a beacon. */
static const uint8_t GOLDEN_DONE[37] = {
    0x4b, 0xae, 0xd4, 0x2f, 0xb1, 0x82, 0x3b, 0xc9, 0x00, 0x00, 0x00, 0x04,
    0x00, 0x00, 0x00, 0x4d, 0x00, 0x00, 0x00, 0x05, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00,
};
static const uint8_t GOLDEN_DONE_EDGE[37] = {
    0x4b, 0xae, 0xd4, 0x2f, 0xb1, 0x82, 0x3b, 0xc9, 0x7f, 0xff, 0xff, 0xff,
    0x12, 0x34, 0x56, 0x78, 0x80, 0x00, 0x00, 0x00, 0x01, 0x80, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x44, 0xdf, 0xe1, 0x85, 0xca, 0x57, 0xc5,
    0x17,
};
/* Re-captured when chunk_request_t gained the requester's position (has_position, x_m, y_m):
 * the beacon that opens a round places its sender for the peers that do not take its state. */
static const uint8_t GOLDEN_REQUEST[57] = {
    0x1a, 0x0e, 0xe5, 0x13, 0x0e, 0x4f, 0xff, 0x0d, 0x00, 0x00, 0x00, 0x01,
    0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00, 0x05,
    0x01, 0x40, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xbf, 0xf4, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x06,
};
static const uint8_t GOLDEN_BEACON[45] = {
    0x1a, 0x0e, 0xe5, 0x13, 0x0e, 0x4f, 0xff, 0x0d, 0x00, 0x00, 0x00, 0x06,
    0x00, 0x00, 0x00, 0x06, 0x00, 0x00, 0x03, 0xe8, 0xde, 0xad, 0xbe, 0xef,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
};

static uint8_t data[16], buf[4096];

static void fill_data(void)
{
    for (int i = 0; i < 16; i++)
        data[i] = (uint8_t)(i * 13 + 7);
}

static int same_chunk(const gp_pse_chunk_t *a, const gp_pse_chunk_t *b)
{
    return a->sender == b->sender && a->round == b->round && a->chunk == b->chunk && a->n_chunks == b->n_chunks &&
           a->state_bytes == b->state_bytes && a->crc32 == b->crc32 && memcmp(&a->x_m, &b->x_m, sizeof a->x_m) == 0 &&
           memcmp(&a->y_m, &b->y_m, sizeof a->y_m) == 0 && a->n_bytes == b->n_bytes && a->encoding == b->encoding &&
           a->incarnation == b->incarnation && memcmp(a->data, b->data, a->n_bytes) == 0;
}

static void check_chunk(const gp_pse_chunk_t *c, const uint8_t *golden, size_t n)
{
    memset(buf, 0xA5, sizeof buf);
    assert_int_equal(gp_wire_encode_chunk(c, buf, sizeof buf), (int)n);
    assert_memory_equal(buf, golden, n);
    assert_int_equal(gp_wire_encode_chunk(c, buf, n - 1), -EMSGSIZE);
    gp_pse_chunk_t back;
    assert_int_equal(gp_wire_decode_chunk(golden, n, &back), 0);
    assert_true(same_chunk(&back, c));
    assert_ptr_equal(back.data, golden + GP_WIRE_CHUNK_HEADER_BYTES); /* into the datagram */
    assert_int_equal(gp_wire_encode_chunk(&back, buf, sizeof buf), (int)n);
    assert_memory_equal(buf, golden, n);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_STATE_CHUNK, golden, n), HAL_HOST_MSG_OK);
}

static void test_chunk_bytes(void **st)
{
    (void)st;
    fill_data();
    const gp_pse_chunk_t c1 = {3, 41, 2, 5, 12000, 0xCAFEBABEu, 1.25, -7.5, 16, data, 1, 9, GP_PSE_TO_ALL};
    check_chunk(&c1, GOLDEN_CHUNK, sizeof GOLDEN_CHUNK);
    const gp_pse_chunk_t c2 = {0x7FFFFFFFu, 0, 0, 1, 1, 0xFFFFFFFFu, -0.0, 6.02214076e23, 0, data, 0, 0xFFFFFFFFu, GP_PSE_TO_ALL};
    check_chunk(&c2, GOLDEN_CHUNK_EMPTY, sizeof GOLDEN_CHUNK_EMPTY);
}

static void check_done(const gp_pse_done_t *d, const uint8_t *golden, size_t n)
{
    assert_int_equal(gp_wire_encode_done(d, buf, sizeof buf), (int)n);
    assert_memory_equal(buf, golden, n);
    assert_int_equal(gp_wire_encode_done(d, buf, n - 1), -EMSGSIZE);
    gp_pse_done_t back;
    assert_int_equal(gp_wire_decode_done(golden, n, &back), 0);
    assert_true(back.sender == d->sender && back.round == d->round && back.incarnation == d->incarnation &&
                back.has_next_position == d->has_next_position &&
                memcmp(&back.next_x_m, &d->next_x_m, sizeof back.next_x_m) == 0 &&
                memcmp(&back.next_y_m, &d->next_y_m, sizeof back.next_y_m) == 0);
    assert_int_equal(gp_wire_encode_done(&back, buf, sizeof buf), (int)n);
    assert_memory_equal(buf, golden, n);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_ROUND_COMPLETE, golden, n), HAL_HOST_MSG_OK);
}

static void test_done_bytes(void **st)
{
    (void)st;
    const gp_pse_done_t d1 = {4, 77, 5, 0, 0.0, 0.0};
    check_done(&d1, GOLDEN_DONE, sizeof GOLDEN_DONE);
    const gp_pse_done_t d2 = {0x7FFFFFFFu, 0x12345678u, 0x80000000u, 1, -0.0, 6.02214076e23};
    check_done(&d2, GOLDEN_DONE_EDGE, sizeof GOLDEN_DONE_EDGE);
}

static void check_request(const gp_pse_request_t *r, const uint8_t *golden, size_t n)
{
    assert_int_equal(gp_wire_encode_request(r, buf, sizeof buf), (int)n);
    assert_memory_equal(buf, golden, n);
    assert_int_equal(n, GP_WIRE_REQUEST_BYTES(r->n));
    assert_int_equal(gp_wire_encode_request(r, buf, n - 1), -EMSGSIZE);
    gp_pse_request_t back;
    memset(&back, 0, sizeof back);
    assert_int_equal(gp_wire_decode_request(golden, n, &back), 0);
    assert_int_equal(back.requester, r->requester);
    assert_int_equal(back.target, r->target);
    assert_int_equal(back.round, r->round);
    assert_int_equal(back.incarnation, r->incarnation);
    assert_int_equal(back.n, r->n);
    assert_int_equal(back.has_position, r->has_position);
    assert_true(back.x_m == r->x_m && back.y_m == r->y_m);
    assert_memory_equal(back.chunks, r->chunks, sizeof r->chunks[0] * r->n);
    assert_int_equal(gp_wire_encode_request(&back, buf, sizeof buf), (int)n);
    assert_memory_equal(buf, golden, n);
    assert_int_equal(hal_host_msg_check(HAL_HOST_MSG_CHUNK_REQUEST, golden, n), HAL_HOST_MSG_OK);
}

static void test_request_bytes(void **st)
{
    (void)st;
    const gp_pse_request_t r1 = {1, 2, 8, 3, {0, 4, 6}, 5, 1, 2.5, -1.25, GP_PSE_TO_ALL};
    check_request(&r1, GOLDEN_REQUEST, sizeof GOLDEN_REQUEST);
    const gp_pse_request_t r2 = {6, 6, 1000, 0, {0}, 0xDEADBEEFu, 0, 0.0, 0.0, GP_PSE_TO_ALL};
    check_request(&r2, GOLDEN_BEACON, sizeof GOLDEN_BEACON);
}

/* The sizes gp_wire.h promises its callers, against the golden messages. */
static void test_sizes(void **st)
{
    (void)st;
    assert_int_equal(GP_WIRE_CHUNK_HEADER_BYTES, sizeof GOLDEN_CHUNK_EMPTY);
    assert_int_equal(GP_WIRE_DONE_BYTES, sizeof GOLDEN_DONE);
    assert_int_equal(GP_WIRE_REQUEST_BYTES(0), sizeof GOLDEN_BEACON);
    assert_int_equal(GP_WIRE_REQUEST_BYTES(3), sizeof GOLDEN_REQUEST);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_chunk_bytes),
        cmocka_unit_test(test_done_bytes),
        cmocka_unit_test(test_request_bytes),
        cmocka_unit_test(test_sizes),
    };
    return cmocka_run_group_tests_name("gp/wire_golden", tests, NULL, NULL);
}
