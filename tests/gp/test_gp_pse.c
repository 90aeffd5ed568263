/* The peers state exchange (firmware/gp/gp_pse.h) against scripted message orders: three
 * engines joined by an in-memory multicast "network" that can lose, duplicate, reorder and
 * corrupt messages and let one peer run a round ahead. Every peer ends each round with every
 * other peer's state bit for bit (or without a peer that went silent), whatever the order. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "ai/dinno_graph.h"
#include "alloc_count.h"
#include "common/crc32.h"
#include "gp/gp_pse.h"

#define N 3
#define STATE_BYTES 5000u /* 5 chunks of 1024 */
#define CHUNK 1024u
#define RESEND 100000u
#define TIMEOUT 1000000u

static gp_pse_t eng[N];
static uint8_t state[N][2][STATE_BYTES]; /* per peer, per round parity */

/* The network: a queue of messages with their payload copied (so they can be corrupted). */
typedef struct msg {
    int from;
    gp_pse_kind_t kind;
    gp_pse_chunk_t chunk;
    gp_pse_done_t done;
    gp_pse_request_t req;
    uint8_t data[CHUNK];
} msg_t;
#define QMAX 256
static msg_t q[QMAX];
static int qn;
static int sender_id[N] = {0, 1, 2};

static int net_send(void *ctx, gp_pse_kind_t kind, const void *m)
{
    const int from = *(const int *)ctx;
    assert_true(qn < QMAX);
    msg_t *x = &q[qn++];
    memset(x, 0, sizeof *x);
    x->from = from;
    x->kind = kind;
    if (kind == GP_PSE_CHUNK) {
        x->chunk = *(const gp_pse_chunk_t *)m;
        memcpy(x->data, x->chunk.data, x->chunk.n_bytes);
        x->chunk.data = x->data;
    } else if (kind == GP_PSE_DONE) {
        x->done = *(const gp_pse_done_t *)m;
    } else {
        x->req = *(const gp_pse_request_t *)m;
    }
    return 0;
}

static void deliver_one(const msg_t *m, int to, uint64_t now)
{
    if (m->kind == GP_PSE_CHUNK) {
        gp_pse_chunk_t c = m->chunk;
        c.data = m->data; /* this copy's payload (the queue slot may be reused meanwhile) */
        (void)gp_pse_on_chunk(&eng[to], &c, now);
    } else if (m->kind == GP_PSE_DONE)
        (void)gp_pse_on_done(&eng[to], &m->done, now);
    else
        (void)gp_pse_on_request(&eng[to], &m->req, now);
}

/* 1 when message m goes to peer `to`: everyone, or its one addressee (an addressed fleet). */
static int addressed_to(const msg_t *m, int to)
{
    const uint32_t only = m->kind == GP_PSE_CHUNK ? m->chunk.to : m->kind == GP_PSE_REQUEST ? m->req.to : GP_PSE_TO_ALL;
    return only == GP_PSE_TO_ALL || only == (uint32_t)to;
}

/* Delivers what is queued (and what that makes the peers send) to every other peer, unless
 * drop(m, to) says the copy to `to` is lost. */
typedef int (*drop_fn)(const msg_t *m, int to);
static void deliver(uint64_t now, drop_fn drop)
{
    static msg_t batch[QMAX];
    while (qn > 0) {
        const int n = qn;
        memcpy(batch, q, sizeof(msg_t) * (size_t)n);
        qn = 0;
        for (int i = 0; i < n; i++)
            for (int to = 0; to < N; to++)
                if (to != batch[i].from && !(drop && drop(&batch[i], to)) && addressed_to(&batch[i], to))
                    deliver_one(&batch[i], to, now);
    }
}

static int chunk2_dropped; /* drop_chunk2_of_1's count */
static void start(double radius)
{
    qn = 0;
    chunk2_dropped = 0;
    for (int i = 0; i < N; i++) {
        gp_pse_cfg_t c = {(uint32_t)i, N, STATE_BYTES, CHUNK, radius, RESEND, TIMEOUT, 0, net_send, &sender_id[i], 0, 0, 0, 0, 0, 0};
        assert_int_equal(gp_pse_init(&eng[i], &c), 0);
        for (int r = 0; r < 2; r++)
            for (uint32_t b = 0; b < STATE_BYTES; b++)
                state[i][r][b] = (uint8_t)(b * 31u + (uint32_t)i * 7u + (uint32_t)r * 101u);
    }
}

static void begin(int i, uint32_t round, uint64_t now)
{
    assert_int_equal(gp_pse_begin_round(&eng[i], round, state[i][round & 1u], 1.0 * i, 0.0, now), 0);
}

/* start() with every engine's transport flags set (gp_pse_cfg_t), then round 0 begun by all. */
static void start_round0_over(uint8_t addressed, uint8_t ordered)
{
    start(0.0);
    for (int i = 0; i < N; i++) {
        gp_pse_cfg_t c = eng[i].cfg;
        c.addressed = addressed;
        c.ordered = ordered;
        assert_int_equal(gp_pse_init(&eng[i], &c), 0);
        begin(i, 0, 0);
    }
}

/* Every peer has every other peer's state of `round`, byte for byte. */
static void check_states(uint32_t round)
{
    for (int i = 0; i < N; i++) {
        assert_true(gp_pse_states_ready(&eng[i]));
        uint32_t ids[GP_PSE_MAX_NEIGHBOURS];
        const uint8_t *st[GP_PSE_MAX_NEIGHBOURS];
        assert_int_equal(gp_pse_neighbours(&eng[i], ids, st), N - 1);
        for (int k = 0; k < N - 1; k++)
            assert_memory_equal(st[k], state[ids[k]][round & 1u], STATE_BYTES);
    }
}

static void complete_all(uint64_t now)
{
    for (int i = 0; i < N; i++)
        assert_int_equal(gp_pse_complete(&eng[i], NULL, now), 0);
}

static void test_no_loss_two_rounds(void **st)
{
    (void)st;
    start(0.0);
    alloc_count_reset();
    for (uint32_t round = 0; round < 2; round++) {
        for (int i = 0; i < N; i++)
            begin(i, round, 1000 * round);
        deliver(1000 * round, NULL);
        check_states(round);
        complete_all(1000 * round);
        deliver(1000 * round, NULL);
        for (int i = 0; i < N; i++)
            assert_true(gp_pse_round_finished(&eng[i]));
    }
    assert_int_equal(alloc_count_allocations(), 0);
    assert_int_equal(eng[0].stats.chunks_sent, 2 * 5);
    assert_int_equal(eng[0].stats.chunks_received, 2 * 2 * 5);
    assert_int_equal(eng[0].stats.requests_sent + eng[0].stats.duplicates + eng[0].stats.invalid, 0);
}

static int drop_chunk2_of_1(const msg_t *m, int to)
{
    (void)to;
    if (m->kind == GP_PSE_CHUNK && m->from == 1 && m->chunk.chunk == 2 && chunk2_dropped < 2) {
        chunk2_dropped++;
        return 1;
    }
    return 0;
}

static void test_lost_chunk_is_asked_for_again(void **st)
{
    (void)st;
    start(0.0);
    for (int i = 0; i < N; i++)
        begin(i, 0, 0);
    deliver(0, drop_chunk2_of_1);
    assert_false(gp_pse_states_ready(&eng[0]));
    assert_false(gp_pse_states_ready(&eng[2]));
    for (int i = 0; i < N; i++)
        gp_pse_poll(&eng[i], RESEND - 1); /* too early to ask */
    assert_int_equal(qn, 0);
    for (int i = 0; i < N; i++)
        gp_pse_poll(&eng[i], RESEND);
    assert_int_equal(eng[0].stats.requests_sent, 1);
    deliver(RESEND, NULL);
    check_states(0);
    assert_true(eng[1].stats.requests_answered >= 1 && eng[1].stats.chunks_resent >= 1);
}

/* A caller that polls only when gp_pse_idle_us says (or when a message comes) loses nothing:
 * while a send window holds chunks back the bound is 0, then an eighth of a resend period, and
 * a lost chunk is still asked for within that eighth of the time it is due. */
static void test_idle_bound_keeps_the_timers(void **st)
{
    (void)st;
    start(0.0);
    for (int i = 0; i < N; i++) {
        gp_pse_cfg_t c = eng[i].cfg;
        c.burst = 2; /* 5 chunks: 2 at the start, 2 and 1 at the next polls */
        assert_int_equal(gp_pse_init(&eng[i], &c), 0);
    }
    for (int i = 0; i < N; i++)
        assert_int_equal(gp_pse_idle_us(&eng[i]), RESEND / 8u); /* not in a round: beacons only */
    uint64_t now = 0;
    for (int i = 0; i < N; i++)
        begin(i, 0, now);
    for (; gp_pse_idle_us(&eng[0]) == 0; now++) {
        assert_true(now < 3);
        deliver(now, drop_chunk2_of_1);
        for (int i = 0; i < N; i++)
            gp_pse_poll(&eng[i], now + 1);
    }
    deliver(now, drop_chunk2_of_1);
    assert_int_equal(eng[0].next_send, 5u);
    assert_false(gp_pse_states_ready(&eng[0]));
    const uint64_t sent_last = now, idle = gp_pse_idle_us(&eng[0]);
    assert_int_equal(idle, RESEND / 8u);
    while (eng[0].stats.requests_sent == 0) {
        now += idle;
        assert_true(now < sent_last + RESEND + idle);
        for (int i = 0; i < N; i++)
            gp_pse_poll(&eng[i], now);
    }
    deliver(now, NULL);
    check_states(0);
}

static void test_duplicated_and_reordered(void **st)
{
    (void)st;
    start(0.0);
    for (int i = 0; i < N; i++)
        begin(i, 0, 0);
    /* Every message twice, in reverse order. */
    static msg_t copy[QMAX];
    const int n = qn;
    memcpy(copy, q, sizeof(msg_t) * (size_t)n);
    qn = 0;
    for (int rep = 0; rep < 2; rep++)
        for (int i = n - 1; i >= 0; i--)
            for (int to = 0; to < N; to++)
                if (to != copy[i].from)
                    deliver_one(&copy[i], to, 0);
    check_states(0);
    assert_int_equal(eng[0].stats.duplicates, 2 * 5);
}

static int drop_done_of_2_to_0(const msg_t *m, int to)
{
    return m->kind == GP_PSE_DONE && m->from == 2 && to == 0;
}

static void test_later_round_first(void **st)
{
    (void)st;
    start(0.0);
    for (int i = 0; i < N; i++)
        begin(i, 0, 0);
    deliver(0, NULL);
    complete_all(0);
    deliver(0, drop_done_of_2_to_0); /* peer 0 never hears that peer 2 completed round 0 */
    assert_false(gp_pse_round_finished(&eng[0]));
    /* Peer 2 moves on: its round-1 state reaches peer 0 first, which finishes round 0 on it
       and already holds that state when it begins round 1. */
    begin(2, 1, 10);
    deliver(10, NULL);
    assert_true(gp_pse_round_finished(&eng[0]));
    begin(0, 1, 20);
    begin(1, 1, 20);
    deliver(20, NULL);
    check_states(1);
    assert_int_equal(eng[0].stats.stale + eng[0].stats.invalid, 0);
}

static int corrupt_one(const msg_t *m, int to)
{
    static int done;
    if (!done && m->kind == GP_PSE_CHUNK && m->from == 1 && to == 0 && m->chunk.chunk == 3) {
        done = 1;
        ((msg_t *)m)->data[17] ^= 0x40; /* flipped in transit (the copy to peer 0 and after) */
    }
    return 0;
}

static void test_corrupted_chunk(void **st)
{
    (void)st;
    start(0.0);
    for (int i = 0; i < N; i++)
        begin(i, 0, 0);
    deliver(0, corrupt_one);
    assert_int_equal(eng[0].stats.crc_failures, 1);
    assert_false(gp_pse_states_ready(&eng[0]));
    gp_pse_poll(&eng[0], RESEND);
    deliver(RESEND, NULL);
    check_states(0);
}

static int silence_2(const msg_t *m, int to)
{
    (void)to;
    return m->from == 2;
}

/* Robot 1 starts at 1.5 peer timeouts (its messages before that do not exist), robot 2 never. */
static uint64_t robot1_starts;
static int slow_start(const msg_t *m, int to)
{
    (void)m;
    return to == 2 || (to == 1 && robot1_starts != 0);
}

/* A fleet still forming: a never-heard peer's join timeout runs from the last newcomer, so a
   robot that starts after the first one's join timeout is not given up, and one that never
   starts costs one join timeout after the last newcomer. */
static void test_join_timeout_restarts_at_each_newcomer(void **st)
{
    (void)st;
    start(0.0);
    const uint64_t join = 2u * TIMEOUT;
    for (int i = 0; i < N; i++)
        eng[i].cfg.join_timeout_us = join;
    robot1_starts = 3u * TIMEOUT / 2u;
    begin(0, 0, 0);
    uint64_t t = RESEND;
    for (; t < robot1_starts; t += RESEND) {
        gp_pse_poll(&eng[0], t);
        deliver(t, slow_start);
    }
    qn = 0; /* what robot 1 would have heard before it started */
    begin(1, 0, t);
    robot1_starts = 0;
    const uint64_t joined = t;
    for (t += RESEND; t < joined + join; t += RESEND) {
        gp_pse_poll(&eng[0], t);
        gp_pse_poll(&eng[1], t);
        deliver(t, slow_start);
    }
    /* Past the first robot's own join timeout, short of one after the newcomer: nobody given up. */
    assert_true(t > join);
    assert_int_equal(eng[0].stats.timeouts, 0);
    assert_int_equal(eng[1].stats.timeouts, 0);
    assert_false(gp_pse_states_ready(&eng[0]));
    for (; t <= joined + join + 2u * RESEND; t += RESEND) {
        gp_pse_poll(&eng[0], t);
        gp_pse_poll(&eng[1], t);
        deliver(t, slow_start);
    }
    /* Robot 2 cost one join timeout after the newcomer, to both. */
    for (int i = 0; i < 2; i++) {
        assert_int_equal(eng[i].stats.timeouts, 1);
        assert_true(gp_pse_states_ready(&eng[i]));
        uint32_t ids[GP_PSE_MAX_NEIGHBOURS];
        const uint8_t *s[GP_PSE_MAX_NEIGHBOURS];
        assert_int_equal(gp_pse_neighbours(&eng[i], ids, s), 1);
        assert_int_equal(ids[0], (uint32_t)(1 - i));
    }
}

static void test_silent_peer_leaves_and_rejoins(void **st)
{
    (void)st;
    start(0.0);
    for (int i = 0; i < N; i++)
        begin(i, 0, 0);
    deliver(0, silence_2);
    for (uint64_t t = RESEND; t <= TIMEOUT; t += RESEND) {
        gp_pse_poll(&eng[0], t);
        gp_pse_poll(&eng[1], t);
        deliver(t, silence_2);
    }
    assert_true(gp_pse_states_ready(&eng[0]));
    assert_int_equal(eng[0].stats.timeouts, 1);
    uint32_t ids[GP_PSE_MAX_NEIGHBOURS];
    const uint8_t *s[GP_PSE_MAX_NEIGHBOURS];
    assert_int_equal(gp_pse_neighbours(&eng[0], ids, s), 1);
    assert_int_equal(ids[0], 1);
    /* Peer 2 speaks again within the round: it is not taken back before the round boundary,
       so the others finish round 0 without waiting for it again. */
    assert_int_equal(gp_pse_complete(&eng[2], NULL, TIMEOUT + 10), 0);
    deliver(TIMEOUT + 10, NULL);
    assert_int_equal(eng[0].stats.rejoins, 0);
    assert_int_equal(gp_pse_complete(&eng[0], NULL, TIMEOUT + 20), 0);
    assert_int_equal(gp_pse_complete(&eng[1], NULL, TIMEOUT + 20), 0);
    deliver(TIMEOUT + 20, NULL);
    for (int i = 0; i < N; i++)
        assert_true(gp_pse_round_finished(&eng[i]));
    /* Round 1: heard lately in round 0, it is back, and every state goes everywhere. */
    for (int i = 0; i < N; i++)
        begin(i, 1, TIMEOUT + 30);
    assert_int_equal(eng[0].stats.rejoins, 1);
    deliver(TIMEOUT + 30, NULL);
    check_states(1);
    /* Silent through the rest of round 1 after completing: the others finish without it. */
    const uint64_t t1 = TIMEOUT + 40;
    assert_int_equal(gp_pse_complete(&eng[0], NULL, t1), 0);
    assert_int_equal(gp_pse_complete(&eng[1], NULL, t1), 0);
    deliver(t1, NULL);
    assert_false(gp_pse_round_finished(&eng[0])); /* still waiting for peer 2's RoundComplete */
    /* Polled all along (time it did not run would not count). Its timeout may be stretched by
       its irregular gaps (RFC 6298's estimate), within GP_PSE_TIMEOUT_STRETCH timeouts; it is
       never less than one. */
    uint64_t t = t1;
    while (!gp_pse_round_finished(&eng[0]) && t < t1 + GP_PSE_TIMEOUT_STRETCH * TIMEOUT) {
        t += RESEND;
        gp_pse_poll(&eng[0], t);
    }
    assert_true(gp_pse_round_finished(&eng[0]));
    assert_true(t >= t1 + TIMEOUT);
    assert_int_equal(eng[0].stats.timeouts, 2);
}

static void test_invalid_messages_change_nothing(void **st)
{
    (void)st;
    start(0.0);
    begin(0, 0, 0);
    qn = 0;
    static uint8_t junk[CHUNK];
    const gp_pse_chunk_t good = {1, 0, 0, 5, STATE_BYTES, 123, 1.0, 0.0, CHUNK, junk, 0, 0, GP_PSE_TO_ALL};
    gp_pse_chunk_t c = good;
    c.sender = N;
    assert_int_equal(gp_pse_on_chunk(&eng[0], &c, 0), -EBADMSG);
    c = good;
    c.sender = 0; /* ourselves */
    assert_int_equal(gp_pse_on_chunk(&eng[0], &c, 0), -EBADMSG);
    c = good;
    c.state_bytes = STATE_BYTES + 1;
    assert_int_equal(gp_pse_on_chunk(&eng[0], &c, 0), -EBADMSG);
    c = good;
    c.chunk = 5;
    assert_int_equal(gp_pse_on_chunk(&eng[0], &c, 0), -EBADMSG);
    c = good;
    c.n_bytes = CHUNK - 1;
    assert_int_equal(gp_pse_on_chunk(&eng[0], &c, 0), -EBADMSG);
    c = good;
    c.x_m = NAN;
    assert_int_equal(gp_pse_on_chunk(&eng[0], &c, 0), -EBADMSG);
    c = good;
    c.round = 5; /* beyond k + 1 */
    assert_int_equal(gp_pse_on_chunk(&eng[0], &c, 0), -EAGAIN);
    gp_pse_request_t r = {1, N, 0, 1, {0}, 0, 0, 0.0, 0.0, GP_PSE_TO_ALL};
    assert_int_equal(gp_pse_on_request(&eng[0], &r, 0), -EBADMSG); /* to a peer outside the fleet */
    r.target = 0;
    r.chunks[0] = 99;
    assert_int_equal(gp_pse_on_request(&eng[0], &r, 0), -EBADMSG);
    gp_pse_done_t d = {7, 0, 0, 0, 0.0, 0.0};
    assert_int_equal(gp_pse_on_done(&eng[0], &d, 0), -EBADMSG);
    assert_int_equal(eng[0].stats.invalid, 9);
    assert_int_equal(eng[0].stats.future, 1);
    assert_int_equal(eng[0].stats.chunks_received, 0);
    assert_int_equal(qn, 0); /* nothing was answered */
}

/* Every encoding of GP_PSE_ENCODINGS (ai/dinno_codec.h's codecs) is a fleet's, no other; an
 * engine sends its own in every chunk and refuses a chunk of any other as invalid (members of
 * different encodings do not take each other's states). */
static void test_encodings(void **st)
{
    (void)st;
    static uint8_t junk[CHUNK];
    for (uint32_t e = 0; e <= GP_PSE_ENCODINGS; e++) {
        qn = 0;
        gp_pse_cfg_t c = {0, N, STATE_BYTES, CHUNK, 0.0, RESEND, TIMEOUT, 0, net_send, &sender_id[0], (uint8_t)e, 0, 0, 0, 0, 0};
        if (e == GP_PSE_ENCODINGS) {
            assert_int_equal(gp_pse_init(&eng[0], &c), -EINVAL);
            c.encoding = 255;
            assert_int_equal(gp_pse_init(&eng[0], &c), -EINVAL);
            break;
        }
        assert_int_equal(gp_pse_init(&eng[0], &c), 0);
        begin(0, 0, 0);
        assert_true(qn > 0);
        for (int i = 0; i < qn; i++)
            if (q[i].kind == GP_PSE_CHUNK)
                assert_int_equal(q[i].chunk.encoding, e);
        qn = 0;
        for (uint32_t o = 0; o < GP_PSE_ENCODINGS; o++) {
            const gp_pse_chunk_t ch = {1, 0, o, 5, STATE_BYTES, 123, 1.0, 0.0, CHUNK, junk, (uint8_t)o, 0, GP_PSE_TO_ALL};
            assert_int_equal(gp_pse_on_chunk(&eng[0], &ch, 0), o == e ? 0 : -EBADMSG);
        }
        assert_int_equal(eng[0].stats.invalid, GP_PSE_ENCODINGS - 1u);
        assert_int_equal(eng[0].stats.chunks_received, 1);
    }
}

/* One forged chunk (another CRC) before the genuine ones, and one in the middle of them: the
 * genuine state still arrives whole, byte for byte, in the same round (an unkeyed fleet's
 * defence; a keyed one never lets the forgery in). */
static uint8_t forged_bytes[CHUNK];
static gp_pse_chunk_t forged_chunk(uint32_t chunk)
{
    memset(forged_bytes, 0xA5, sizeof forged_bytes);
    return (gp_pse_chunk_t){1, 0, chunk, 5, STATE_BYTES, 0xdeadbeefu, 1.0, 0.0, CHUNK, forged_bytes, 0, 0, GP_PSE_TO_ALL};
}

/* Lets everything through, but slips a forged chunk 3 of peer 1 to peer 0 just before peer 1's
 * genuine chunk 2 reaches it. */
static int slip_forgery(const msg_t *m, int to)
{
    if (to == 0 && m->from == 1 && m->kind == GP_PSE_CHUNK && m->chunk.chunk == 2) {
        const gp_pse_chunk_t f = forged_chunk(3);
        assert_int_equal(gp_pse_on_chunk(&eng[0], &f, 10), 0); /* nothing tells it apart yet */
    }
    return 0;
}

static void test_forged_chunk_does_not_block_the_state(void **st)
{
    (void)st;
    start(0.0);
    for (int i = 0; i < N; i++)
        begin(i, 0, 0);
    const gp_pse_chunk_t f0 = forged_chunk(0);
    assert_int_equal(gp_pse_on_chunk(&eng[0], &f0, 0), 0); /* before the genuine chunk 0 */
    assert_int_equal(gp_pse_on_chunk(&eng[2], &f0, 0), 0);
    deliver(10, slip_forgery);
    uint64_t t = 10;
    for (int k = 0; k < 20 && !(gp_pse_states_ready(&eng[0]) && gp_pse_states_ready(&eng[2])); k++) {
        t += RESEND;
        for (int i = 0; i < N; i++)
            gp_pse_poll(&eng[i], t);
        deliver(t, NULL);
    }
    assert_true(t < TIMEOUT); /* no peer timed out: the state came in the round */
    complete_all(t);
    check_states(0);
    assert_int_equal(eng[0].stats.invalid, 3); /* f0 vs chunk 0, f3 vs the chunks held, chunk 2 vs f3 */
    assert_int_equal(eng[0].stats.timeouts, 0);
}

static void test_disk_neighbours_match_dinno_graph(void **st)
{
    (void)st;
    start(1.5);
    const double xy[2 * N] = {0.0, 0.0, 1.0, 0.0, 2.6, 0.0};
    for (int i = 0; i < N; i++)
        assert_int_equal(gp_pse_begin_round(&eng[i], 0, state[i][0], xy[2 * i], xy[2 * i + 1], 0), 0);
    deliver(0, NULL);
    dinno_graph_t g;
    assert_int_equal(dinno_graph_disk(&g, N, xy, 1.5), 0);
    for (int i = 0; i < N; i++) {
        uint32_t ids[GP_PSE_MAX_NEIGHBOURS];
        const uint8_t *s[GP_PSE_MAX_NEIGHBOURS];
        const uint32_t n = gp_pse_neighbours(&eng[i], ids, s);
        uint32_t want = 0;
        for (int j = 0; j < N; j++)
            want += j != i && dinno_graph_has_edge(&g, (uint32_t)i, (uint32_t)j);
        assert_int_equal(n, want);
        for (uint32_t k = 0; k < n; k++)
            assert_true(dinno_graph_has_edge(&g, (uint32_t)i, ids[k]));
    }
}

/* Two peers ask for the same chunk of peer 0 within half a resend period: peer 0 sends it
 * once (multicast serves both); a request after that period gets it again. */
static void test_requests_for_one_chunk_merge(void **st)
{
    (void)st;
    start(0.0);
    for (int i = 0; i < N; i++)
        begin(i, 0, 0);
    qn = 0; /* every chunk of round 0 lost */
    const gp_pse_request_t r1 = {1, 0, 0, 1, {2}, 0, 0, 0.0, 0.0, GP_PSE_TO_ALL},
                           r2 = {2, 0, 0, 1, {2}, 0, 0, 0.0, 0.0, GP_PSE_TO_ALL};
    assert_int_equal(gp_pse_on_request(&eng[0], &r1, 10), 0);
    assert_int_equal(gp_pse_on_request(&eng[0], &r2, 20), 0);
    assert_int_equal(qn, 1);
    assert_int_equal(eng[0].stats.chunks_resent, 1);
    assert_int_equal(eng[0].stats.resends_merged, 1);
    assert_int_equal(gp_pse_on_request(&eng[0], &r2, 20 + RESEND), 0);
    assert_int_equal(qn, 2);
    assert_int_equal(eng[0].stats.chunks_resent, 2);
}

/* An addressed fleet (a point-to-point transport): peers 0 and 2 both lost a chunk of peer 1;
 * each asks peer 1 alone, and peer 1 sends the chunk to each of them on its own, not merged,
 * and to nobody else; both end with the whole state. */
static void test_addressed_requests_and_resends(void **st)
{
    (void)st;
    start_round0_over(1, 0);
    deliver(0, drop_chunk2_of_1);
    for (int i = 0; i < N; i++)
        gp_pse_poll(&eng[i], RESEND);
    assert_int_equal(eng[0].stats.requests_sent + eng[2].stats.requests_sent, 2);
    static msg_t asked[QMAX];
    const int n_asked = qn;
    memcpy(asked, q, sizeof(msg_t) * (size_t)qn);
    qn = 0;
    for (int i = 0; i < n_asked; i++) /* peer 1 hears both requests within a tick */
        if (asked[i].kind == GP_PSE_REQUEST && asked[i].req.n > 0) {
            assert_int_equal(asked[i].req.target, 1);
            assert_int_equal(asked[i].req.to, 1);
            deliver_one(&asked[i], 1, RESEND + (uint64_t)i);
        }
    uint32_t to_seen = 0;
    for (int i = 0; i < qn; i++)
        if (q[i].kind == GP_PSE_CHUNK) {
            assert_int_equal(q[i].chunk.chunk, 2);
            assert_true(q[i].chunk.to == 0u || q[i].chunk.to == 2u);
            to_seen |= 1u << q[i].chunk.to;
        }
    assert_int_equal(to_seen, (1u << 0) | (1u << 2));
    assert_int_equal(eng[1].stats.chunks_resent, 2);
    assert_int_equal(eng[1].stats.resends_merged, 0);
    deliver(RESEND, NULL);
    check_states(0);
    assert_int_equal(eng[0].stats.duplicates + eng[2].stats.duplicates, 0); /* one copy each */
}

/* Peer 1's chunks 2 .. 4 to peer 0 are held (on their way: held_n of them kept in held[]). */
static msg_t held[QMAX];
static int held_n;
static int hold_chunks_of_1_to_0(const msg_t *m, int to)
{
    if (to == 0 && m->kind == GP_PSE_CHUNK && m->from == 1 && m->chunk.chunk >= 2) {
        held[held_n++] = *m;
        return 1;
    }
    return 0;
}

/* An ordered link (cfg.ordered, TCP): a state whose chunks are late is not asked for on the
 * resend timer (it would come twice), but at once when its sender's next word to everyone
 * shows what is missing was lost, and after two beacon periods without that word. Over an
 * unordered link the timer asks after one resend period, as before. */
static void test_ordered_link_asks_on_the_senders_word(void **st)
{
    (void)st;
    for (int ordered = 0; ordered < 2; ordered++)
        for (int lost = 0; lost < 2; lost++) {
            start_round0_over((uint8_t)ordered, (uint8_t)ordered);
            held_n = 0;
            deliver(0, hold_chunks_of_1_to_0);
            assert_int_equal(held_n, 3);
            gp_pse_poll(&eng[0], RESEND + 1u);
            if (!ordered) { /* one resend period: asked, although the chunks are only late */
                assert_int_equal(eng[0].stats.requests_sent, 1);
                continue;
            }
            assert_int_equal(eng[0].stats.requests_sent, 0);
            qn = 0;
            if (!lost) { /* they come: whole, nothing asked, nothing twice */
                for (int i = 0; i < held_n; i++)
                    deliver_one(&held[i], 0, RESEND + 2u);
                assert_true(gp_pse_states_ready(&eng[0]));
                assert_int_equal(eng[0].stats.chunks_received, 2 * 5);
                gp_pse_poll(&eng[0], 3u * RESEND);
                assert_int_equal(eng[0].stats.requests_sent + eng[0].stats.duplicates, 0);
                continue;
            }
            /* Lost: peer 1's beacon, sent after its chunks, says so; asked at the next poll. */
            const gp_pse_request_t beacon = {1, 1, 0, 0, {0}, 0, 1, 1.0, 0.0, GP_PSE_TO_ALL};
            assert_int_equal(gp_pse_on_request(&eng[0], &beacon, RESEND + 2u), 0);
            gp_pse_poll(&eng[0], RESEND + 3u);
            assert_int_equal(eng[0].stats.requests_sent, 1);
            assert_int_equal(eng[0].stats.chunks_requested, 3);
        }
    /* No word at all: the timer still asks, after two beacon periods (N <= 8: resend periods). */
    start_round0_over(0, 1);
    held_n = 0;
    deliver(0, hold_chunks_of_1_to_0);
    gp_pse_poll(&eng[0], 2u * RESEND - 1u);
    assert_int_equal(eng[0].stats.requests_sent, 0);
    gp_pse_poll(&eng[0], 2u * RESEND);
    assert_int_equal(eng[0].stats.requests_sent, 1);
}

/* Requests that bring nothing: the wait before the next one doubles, up to 2 resend periods
 * over UDP and 16 over an ordered link (its answers are queued, rarely lost): peer 1's chunks
 * never reach robot 0, and robot 0 asks at the times the caps give, never sooner. */
static void test_backoff_caps_per_link(void **st)
{
    (void)st;
    for (int ordered = 0; ordered < 2; ordered++) {
        start_round0_over((uint8_t)ordered, (uint8_t)ordered);
        held_n = 0;
        deliver(0, hold_chunks_of_1_to_0); /* and never delivered */
        const gp_pse_request_t beacon = {1, 1, 0, 0, {0}, 0, 1, 1.0, 0.0, GP_PSE_TO_ALL}; /* all sent */
        uint64_t t = 2u * RESEND;
        assert_int_equal(gp_pse_on_request(&eng[0], &beacon, t - 1u), 0);
        gp_pse_poll(&eng[0], t);
        assert_int_equal(eng[0].stats.requests_sent, 1); /* the first: the sender said it sent all */
        const uint32_t most = ordered ? GP_PSE_BACKOFF_MAX_ORDERED : GP_PSE_BACKOFF_MAX;
        for (uint32_t k = 1; k <= most + 2u; k++) {
            const uint64_t wait = (uint64_t)RESEND << (k < most ? k : most);
            gp_pse_poll(&eng[0], t + wait - 1u);
            assert_int_equal(eng[0].stats.requests_sent, k); /* not sooner */
            t += wait;
            gp_pse_poll(&eng[0], t);
            assert_int_equal(eng[0].stats.requests_sent, k + 1u);
        }
    }
}

/* Whose chunks a robot takes (gp_pse_wanted): over multicast every peer not placed yet (it may
 * be near); in an addressed fleet only the peers placed among the nearest, whatever else asked
 * for once placed. */
static void test_wanted_waits_for_a_position_when_addressed(void **st)
{
    (void)st;
    for (int addressed = 0; addressed < 2; addressed++) {
        start(0.0);
        gp_pse_cfg_t c = eng[0].cfg;
        c.addressed = (uint8_t)addressed;
        assert_int_equal(gp_pse_init(&eng[0], &c), 0);
        uint8_t bits[GP_PSE_WANTED_BYTES];
        assert_int_equal(gp_pse_wanted(&eng[0], bits), addressed ? 0 : N - 1); /* before round 0 */
        begin(0, 0, 0);
        assert_int_equal(gp_pse_wanted(&eng[0], bits), addressed ? 0 : N - 1);
        const gp_pse_request_t beacon = {1, 1, 0, 0, {0}, 0, 1, 1.0, 0.0, GP_PSE_TO_ALL}; /* peer 1 placed */
        assert_int_equal(gp_pse_on_request(&eng[0], &beacon, 10), 0);
        assert_int_equal(gp_pse_wanted(&eng[0], bits), addressed ? 1 : N - 1);
        assert_int_equal(bits[0] & 0x7u, addressed ? 0x2u : 0x6u);
    }
}

/* The handed-out buffers (gp_pse.h): once gp_pse_neighbours() gave round k's states out, no
 * message of round k writes them until round k + 1 begins, although the old rules would have:
 * a nearer peer heard late (after it timed out) took the farthest listed peer's buffer, a
 * listed peer whose chunks moved it had its state started over in place, a restarted peer's
 * buffer went to the next chunk's sender. One engine, robot 0 of GP_PSE_MAX_NEIGHBOURS + 2
 * robots fed by hand: peers 1 .. K deliver (peer i at x = 100 - i), peer K + 1 stays silent. */
#define LONE_K GP_PSE_MAX_NEIGHBOURS
#define LONE_N (LONE_K + 2u)
static gp_pse_t lone;
static uint8_t lone_state[LONE_N][STATE_BYTES], lone_other[STATE_BYTES];

static int lone_send(void *ctx, gp_pse_kind_t kind, const void *m)
{
    (void)ctx;
    (void)kind;
    (void)m;
    return 0;
}

static int lone_chunk(uint32_t from, uint32_t inc, uint32_t round, uint32_t chunk, double x, const uint8_t *bytes,
                      uint64_t now)
{
    const uint32_t n_chunks = (STATE_BYTES + CHUNK - 1u) / CHUNK, off = chunk * CHUNK;
    const uint32_t len = STATE_BYTES - off < CHUNK ? STATE_BYTES - off : CHUNK;
    const gp_pse_chunk_t c = {from, round, chunk, n_chunks, STATE_BYTES, crc32_ieee(bytes, STATE_BYTES), x, 0.0,
                              len, bytes + off, 0, inc, GP_PSE_TO_ALL};
    return gp_pse_on_chunk(&lone, &c, now);
}

static void test_handed_out_buffers_are_not_written(void **st)
{
    (void)st;
    const gp_pse_cfg_t c = {0, LONE_N, STATE_BYTES, CHUNK, 0.0, RESEND, TIMEOUT, 0, lone_send, NULL, 0, 0, 0, 0, 0, 0};
    assert_int_equal(gp_pse_init(&lone, &c), 0);
    const uint32_t n_chunks = (STATE_BYTES + CHUNK - 1u) / CHUNK;
    for (uint32_t i = 0; i < LONE_N; i++)
        for (uint32_t b = 0; b < STATE_BYTES; b++)
            lone_state[i][b] = (uint8_t)(b * 13u + i * 29u);
    memset(lone_other, 0xA5, sizeof lone_other);
    uint8_t mine_[STATE_BYTES] = {0};
    assert_int_equal(gp_pse_begin_round(&lone, 0, mine_, 0.0, 0.0, 0), 0);
    for (uint32_t i = 1; i <= LONE_K; i++)
        for (uint32_t k = 0; k < n_chunks; k++)
            assert_int_equal(lone_chunk(i, 0, 0, k, 100.0 - (double)i, lone_state[i], 10), 0);
    for (uint64_t t = RESEND; t <= 2u * TIMEOUT && !gp_pse_states_ready(&lone); t += RESEND)
        gp_pse_poll(&lone, t); /* peer K + 1 is never heard: it leaves the round */
    assert_true(gp_pse_states_ready(&lone));
    assert_int_equal(lone.stats.timeouts, 1);
    uint32_t ids[GP_PSE_MAX_NEIGHBOURS];
    const uint8_t *got[GP_PSE_MAX_NEIGHBOURS];
    assert_int_equal(gp_pse_neighbours(&lone, ids, got), LONE_K);
    for (uint32_t j = 0; j < LONE_K; j++)
        assert_memory_equal(got[j], lone_state[ids[j]], STATE_BYTES);
    const uint64_t t = 3u * TIMEOUT;
    /* 1. The silent peer after all, nearest of all, with its whole state. */
    for (uint32_t k = 0; k < n_chunks; k++)
        (void)lone_chunk(LONE_K + 1u, 0, 0, k, 0.5, lone_other, t);
    /* 2. A listed peer's chunk from elsewhere, with other bytes. */
    (void)lone_chunk(1, 0, 0, 0, 50.0, lone_other, t + 1);
    /* 3. A listed peer restarted: its new incarnation's state of the round. */
    for (uint32_t k = 0; k < n_chunks; k++)
        (void)lone_chunk(2, 1, 0, k, 100.0 - 2.0, lone_other, t + 2);
    for (uint32_t j = 0; j < LONE_K; j++)
        assert_memory_equal(got[j], lone_state[ids[j]], STATE_BYTES);
    assert_int_equal(lone.stats.restarts, 1);
    assert_int_equal(lone.stats.evictions, 0);
    assert_int_equal(lone.stats.after_taken, 2u * n_chunks + 1u);
    /* The caller may rewrite them (the GP core expands int8 states in place): still its own. */
    memset((uint8_t *)(uintptr_t)got[0], 0, STATE_BYTES);
    (void)lone_chunk(ids[0], ids[0] == 2u ? 1u : 0u, 0, 0, 100.0 - (double)ids[0], lone_state[ids[0]], t + 3);
    for (uint32_t b = 0; b < STATE_BYTES; b++)
        assert_int_equal(got[0][b], 0);
    assert_int_equal(gp_pse_neighbours(&lone, ids, got), LONE_K); /* the same buffers again */
    /* Round 1 begins: the rules are the usual ones again, the nearest peer is kept. */
    assert_int_equal(gp_pse_complete(&lone, NULL, t + 4), 0);
    assert_int_equal(gp_pse_begin_round(&lone, 1, mine_, 0.0, 0.0, t + 5), 0);
    for (uint32_t k = 0; k < n_chunks; k++)
        assert_int_equal(lone_chunk(LONE_K + 1u, 0, 1, k, 0.5, lone_other, t + 6), 0);
    assert_int_equal(lone.stats.after_taken, 2u * n_chunks + 2u);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_requests_for_one_chunk_merge),
        cmocka_unit_test(test_addressed_requests_and_resends),
        cmocka_unit_test(test_wanted_waits_for_a_position_when_addressed),
        cmocka_unit_test(test_no_loss_two_rounds),
        cmocka_unit_test(test_lost_chunk_is_asked_for_again),
        cmocka_unit_test(test_idle_bound_keeps_the_timers),
        cmocka_unit_test(test_duplicated_and_reordered),
        cmocka_unit_test(test_later_round_first),
        cmocka_unit_test(test_corrupted_chunk),
        cmocka_unit_test(test_silent_peer_leaves_and_rejoins),
        cmocka_unit_test(test_join_timeout_restarts_at_each_newcomer),
        cmocka_unit_test(test_invalid_messages_change_nothing),
        cmocka_unit_test(test_ordered_link_asks_on_the_senders_word),
        cmocka_unit_test(test_backoff_caps_per_link),
        cmocka_unit_test(test_encodings),
        cmocka_unit_test(test_forged_chunk_does_not_block_the_state),
        cmocka_unit_test(test_disk_neighbours_match_dinno_graph),
        cmocka_unit_test(test_handed_out_buffers_are_not_written),
    };
    return cmocka_run_group_tests_name("gp/pse", tests, NULL, NULL);
}
