/* Fuzz target: the datagram path of the fleet, as gp_fleet runs it on the host. Each datagram
 * meets a keyed fleet's MAC check (hal_host_auth_open: made-up bytes never pass; the same bytes
 * sealed by a member pass, and fail again with any one byte changed), then hal/host's bounds
 * check (hal_host_msg_check) for the type of the channel it came on,
 * then gp_wire's decoder of that channel, and what decodes goes into a gp_pse engine (peer 0 of
 * a fleet of 3, rounds driven like the GP core does): chunk reassembly across datagrams, resend
 * requests, RoundCompletes, beacons, incarnations, skips and timeouts. The input is a sequence
 * of datagrams and ticks (framing in fuzz_config.h).
 *
 * Beyond memory safety it checks what the layers promise each other:
 *   - every datagram gp_wire decodes passes the bounds check of its type (the check never drops
 *     a message the firmware accepts), and encodes back to the same bytes;
 *   - every message the engine sends encodes, passes the bounds check and decodes back to itself
 *     (what we send, the peers accept);
 *   - every neighbour state the engine hands out is whole: its CRC is the one its chunks carried.
 *   - liveness: once the datagrams stop, the engine gives the silent peers up and finishes its
 *     remaining rounds within the timeouts.
 * No state survives an input (fresh_harness). */
#include <errno.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/crc32.h"
#include "fuzz/fuzz_config.h"
#include "gp/gp_pse.h"
#include "gp/gp_wire.h"
#include "hal/hal_net.h"
#include "hal_host_auth.h"
#include "hal_host_msg.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static const hal_host_msg_type_t channel_type[3] = {HAL_HOST_MSG_STATE_CHUNK, HAL_HOST_MSG_ROUND_COMPLETE,
                                                    HAL_HOST_MSG_CHUNK_REQUEST};

typedef struct harness {
    gp_pse_t pse;
    uint8_t mine[FUZZ_WIRE_STATE_BYTES];
    uint8_t out[HAL_NET_MTU_BYTES]; /* what the engine sends, encoded */
} harness_t;

static int same_chunk(const gp_pse_chunk_t *a, const gp_pse_chunk_t *b)
{
    return a->sender == b->sender && a->round == b->round && a->chunk == b->chunk && a->n_chunks == b->n_chunks &&
           a->state_bytes == b->state_bytes && a->crc32 == b->crc32 && memcmp(&a->x_m, &b->x_m, sizeof a->x_m) == 0 &&
           memcmp(&a->y_m, &b->y_m, sizeof a->y_m) == 0 && a->n_bytes == b->n_bytes &&
           a->encoding == b->encoding && a->incarnation == b->incarnation &&
           memcmp(a->data, b->data, a->n_bytes) == 0;
}

static int same_request(const gp_pse_request_t *a, const gp_pse_request_t *b)
{
    return a->requester == b->requester && a->target == b->target && a->round == b->round && a->n == b->n &&
           a->incarnation == b->incarnation && memcmp(a->chunks, b->chunks, sizeof a->chunks[0] * a->n) == 0;
}

/* The engine's send hook: what goes out must come back in, through the same two layers. */
static int on_send(void *ctx, gp_pse_kind_t kind, const void *msg)
{
    harness_t *h = ctx;
    int n;
    switch (kind) {
    case GP_PSE_CHUNK: {
        const gp_pse_chunk_t *c = msg;
        n = gp_wire_encode_chunk(c, h->out, sizeof h->out);
        CHECK(n > 0 && hal_host_msg_check(HAL_HOST_MSG_STATE_CHUNK, h->out, (size_t)n) == HAL_HOST_MSG_OK);
        gp_pse_chunk_t back;
        CHECK(gp_wire_decode_chunk(h->out, (size_t)n, &back) == 0 && same_chunk(c, &back));
        break;
    }
    case GP_PSE_DONE: {
        const gp_pse_done_t *d = msg;
        n = gp_wire_encode_done(d, h->out, sizeof h->out);
        CHECK(n > 0 && hal_host_msg_check(HAL_HOST_MSG_ROUND_COMPLETE, h->out, (size_t)n) == HAL_HOST_MSG_OK);
        gp_pse_done_t back;
        CHECK(gp_wire_decode_done(h->out, (size_t)n, &back) == 0 && back.sender == d->sender &&
              back.round == d->round && back.incarnation == d->incarnation);
        break;
    }
    case GP_PSE_REQUEST: {
        const gp_pse_request_t *r = msg;
        n = gp_wire_encode_request(r, h->out, sizeof h->out);
        CHECK(n > 0 && hal_host_msg_check(HAL_HOST_MSG_CHUNK_REQUEST, h->out, (size_t)n) == HAL_HOST_MSG_OK);
        gp_pse_request_t back;
        CHECK(gp_wire_decode_request(h->out, (size_t)n, &back) == 0 && same_request(r, &back));
        break;
    }
    default:
        CHECK(0);
    }
    return 0;
}

static void fill_state(harness_t *h, uint32_t round)
{
    for (uint32_t i = 0; i < FUZZ_WIRE_STATE_BYTES; i++)
        h->mine[i] = fuzz_wire_state_byte(FUZZ_WIRE_SELF, round, i);
}

/* Every neighbour state handed out is a whole one of this round: its CRC is its chunks'. */
static void check_neighbours(harness_t *h) /* takes the round's states, as the GP core does */
{
    uint32_t ids[GP_PSE_MAX_NEIGHBOURS];
    const uint8_t *states[GP_PSE_MAX_NEIGHBOURS];
    const uint32_t n = gp_pse_neighbours(&h->pse, ids, states);
    CHECK(n < FUZZ_WIRE_PEERS);
    for (uint32_t j = 0; j < n; j++) {
        CHECK(ids[j] < FUZZ_WIRE_PEERS && ids[j] != FUZZ_WIRE_SELF && (j == 0 || ids[j] > ids[j - 1]));
        const uint32_t par = h->pse.round & 1u, slot = h->pse.peer[ids[j]].buf[par];
        CHECK(slot < GP_PSE_MAX_NEIGHBOURS);
        const gp_pse_buf_t *b = &h->pse.pool[par][slot];
        CHECK(b->complete && b->round == h->pse.round && b->owner == ids[j] && states[j] == b->bytes);
        CHECK(crc32_ieee(states[j], FUZZ_WIRE_STATE_BYTES) == b->crc32);
    }
}

/* One tick of the GP core: poll, then move the round on as gp_core and gp_fleet do. */
static void tick(harness_t *h, uint64_t now)
{
    gp_pse_t *p = &h->pse;
    gp_pse_poll(p, now);
    if (p->leaving)
        return;
    if (!p->completed) {
        if (gp_pse_states_ready(p)) {
            check_neighbours(h);
            /* says where it goes next, as gp_fleet does offline: round + 1 at (2 + round, 2) */
            const double next_xy[2] = {2.0 + p->round, 2.0};
            CHECK(gp_pse_complete(p, next_xy, now) == 0);
        }
        return;
    }
    if (!gp_pse_round_finished(p))
        return;
    const uint32_t next = gp_pse_next_round(p, now);
    CHECK(next > p->round);
    if (next >= FUZZ_WIRE_ROUNDS) {
        gp_pse_leave(p, now);
        return;
    }
    fill_state(h, next);
    CHECK(gp_pse_begin_round(p, next, h->mine, 1.0 + next, 2.0, now) == 0);
    CHECK(p->round == next);
}

/* One datagram on channel `what`: every layer sees it as on the host, the engine only what the
 * host would hand it. The decoders also see what the bounds check refused (a board without
 * hal/host calls them on raw datagrams). */
static const char *const channel_name[3] = {"fleetsim/0/state", "fleetsim/0/done", "fleetsim/0/request"};

/* The MAC check on the datagram as it came, and on it sealed by a member. */
static void mac_check(unsigned what, const uint8_t *d, size_t len)
{
    static uint8_t sealed[HAL_NET_MTU_BYTES + HAL_HOST_AUTH_TRAILER_BYTES];
    static const hal_host_auth_t member = {{1, 2, 3, 4, 5, 6, 7, 8}, 42};
    size_t n = 0;
    const hal_host_auth_verdict_t v = hal_host_auth_open(&member, channel_name[what], d, len, &n);
    CHECK(v != HAL_HOST_AUTH_OK);
    CHECK(hal_host_auth_verdict_name(v) != NULL);
    if (len > HAL_NET_MTU_BYTES)
        return;
    memcpy(sealed, d, len);
    hal_host_auth_seal(&member, channel_name[what], sealed, len);
    const size_t wire = len + HAL_HOST_AUTH_TRAILER_BYTES;
    CHECK(hal_host_auth_open(&member, channel_name[what], sealed, wire, &n) == HAL_HOST_AUTH_OK && n == len);
    const size_t at = (len > 0 ? d[0] : 0u) * 131u % wire; /* one byte the input chooses */
    sealed[at] ^= 0x5a;
    CHECK(hal_host_auth_open(&member, channel_name[what], sealed, wire, &n) != HAL_HOST_AUTH_OK);
    sealed[at] ^= 0x5a;
    CHECK(hal_host_auth_open(&member, channel_name[(what + 1u) % 3u], sealed, wire, &n) == HAL_HOST_AUTH_BAD_TAG);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    return hal_host_auth_init();
}

static void datagram(harness_t *h, unsigned what, const uint8_t *d, size_t len, uint64_t now)
{
    mac_check(what, d, len);
    hal_host_msg_reject_t ok[3];
    int accepted = 0;
    for (unsigned t = 0; t < 3; t++) {
        ok[t] = hal_host_msg_check(channel_type[t], d, len);
        CHECK(hal_host_msg_reject_name(ok[t]) != NULL);
        accepted += ok[t] == HAL_HOST_MSG_OK;
    }
    CHECK(accepted <= 1); /* the fingerprints tell the types apart */
    CHECK(hal_host_msg_check(HAL_HOST_MSG_ANY, d, len) == HAL_HOST_MSG_OK);
    CHECK(hal_host_msg_check(HAL_HOST_MSG_TYPE_COUNT, d, len) != HAL_HOST_MSG_OK);

    gp_pse_chunk_t c;
    gp_pse_done_t dn;
    gp_pse_request_t r;
    const int c_ok = gp_wire_decode_chunk(d, len, &c) == 0;
    const int d_ok = gp_wire_decode_done(d, len, &dn) == 0;
    const int r_ok = gp_wire_decode_request(d, len, &r) == 0;
    /* What the firmware decodes, the bounds check lets through, and it encodes back as it came. */
    if (c_ok) {
        CHECK(ok[0] == HAL_HOST_MSG_OK);
        CHECK(c.data == d + GP_WIRE_CHUNK_HEADER_BYTES);
        CHECK(gp_wire_encode_chunk(&c, h->out, sizeof h->out) == (int)len && memcmp(h->out, d, len) == 0);
    }
    if (d_ok) {
        CHECK(ok[1] == HAL_HOST_MSG_OK);
        CHECK(gp_wire_encode_done(&dn, h->out, sizeof h->out) == (int)len && memcmp(h->out, d, len) == 0);
    }
    if (r_ok) {
        CHECK(ok[2] == HAL_HOST_MSG_OK);
        CHECK(gp_wire_encode_request(&r, h->out, sizeof h->out) == (int)len && memcmp(h->out, d, len) == 0);
    }

    if (ok[what] != HAL_HOST_MSG_OK)
        return; /* dropped by the receiver (rx_dropped_malformed) */
    gp_pse_t *p = &h->pse;
    const gp_pse_stats_t before = p->stats;
    int rc = 0;
    switch (what) {
    case FUZZ_WIRE_STATE:
        if (!c_ok || c.sender == FUZZ_WIRE_SELF)
            return; /* undecodable, or our own echo */
        rc = gp_pse_on_chunk(p, &c, now);
        break;
    case FUZZ_WIRE_DONE:
        if (!d_ok || dn.sender == FUZZ_WIRE_SELF)
            return;
        rc = gp_pse_on_done(p, &dn, now);
        break;
    default:
        if (!r_ok || r.requester == FUZZ_WIRE_SELF)
            return;
        rc = gp_pse_on_request(p, &r, now);
        break;
    }
    CHECK(rc == 0 || rc == -EALREADY || rc == -ESTALE || rc == -EAGAIN || rc == -EBADMSG || rc == -EILSEQ);
    if (rc == -EBADMSG)
        CHECK(p->stats.invalid == before.invalid + 1u);
}

/* The engine is a pool of 2 x BOARD_MAX_PEERS buffers of the preset's whole state (8.6 MB for
   `small`): allocating it per input costs ten times the fuzzing. So it lives here, and every
   input starts by zeroing all of it an input can reach (the engine's own fields, the peer
   table of a fleet of FUZZ_WIRE_PEERS, and the first FUZZ_WIRE_STATE_BYTES of each buffer), as
   a fresh calloc would: nothing of an input reaches the next one, and a crash replays alone. */
static harness_t *fresh_harness(void)
{
    static harness_t h;
    memset(&h.pse, 0, offsetof(gp_pse_t, pool));
    for (int par = 0; par < 2; par++)
        for (uint32_t s = 0; s < GP_PSE_MAX_NEIGHBOURS; s++)
            memset(&h.pse.pool[par][s], 0, offsetof(gp_pse_buf_t, bytes) + FUZZ_WIRE_STATE_BYTES);
    memset(h.pse.peer, 0, sizeof h.pse.peer[0] * FUZZ_WIRE_PEERS);
    memset(&h.pse.stats, 0, sizeof h.pse.stats);
    return &h;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    harness_t *h = fresh_harness();
    const gp_pse_cfg_t cfg = {
        .self = FUZZ_WIRE_SELF,
        .n_peers = FUZZ_WIRE_PEERS,
        .state_bytes = FUZZ_WIRE_STATE_BYTES,
        .chunk_bytes = FUZZ_WIRE_CHUNK_BYTES,
        .radius_m = FUZZ_WIRE_RADIUS_M,
        .resend_after_us = FUZZ_WIRE_RESEND_US,
        .peer_timeout_us = FUZZ_WIRE_TIMEOUT_US,
        .join_timeout_us = 2u * FUZZ_WIRE_TIMEOUT_US,
        .send = on_send,
        .send_ctx = h,
        .encoding = 0,
        .incarnation = 1,
        .burst = 2,
    };
    uint64_t now = FUZZ_WIRE_T0_US;
    CHECK(gp_pse_init(&h->pse, &cfg) == 0);
    fill_state(h, 0);
    CHECK(gp_pse_begin_round(&h->pse, 0, h->mine, 1.0, 2.0, now) == 0);

    size_t at = 0;
    while (at < size) {
        const uint8_t op = data[at++];
        const unsigned what = op & 3u, dt = op >> 2;
        now += (uint64_t)dt * dt * 1000u;
        if (what == FUZZ_WIRE_TICK) {
            tick(h, now);
            continue;
        }
        if (size - at < 2)
            break;
        const size_t len = (size_t)data[at] << 8 | data[at + 1];
        at += 2;
        if (size - at < len)
            break;
        if (len <= HAL_NET_MTU_BYTES) /* larger ones never arrive */
            datagram(h, what, data + at, len, now);
        at += len;
    }
    /* Liveness: with nobody speaking any more, the engine gives the silent peers up and goes
       through its remaining rounds, each within the timeouts, then leaves. */
    for (unsigned i = 0; i < 16u * FUZZ_WIRE_ROUNDS && !h->pse.leaving; i++) {
        now += FUZZ_WIRE_TIMEOUT_US / 2u;
        tick(h, now);
    }
    CHECK(h->pse.leaving);
    return 0;
}
