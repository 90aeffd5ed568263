/* The peers state exchange in a fleet larger than its neighbour slots (firmware/gp/gp_pse.h):
 * one engine, robot 0 of GP_PSE_MAX_NEIGHBOURS + 6 robots, fed chunks by hand. It keeps the
 * states of its nearest peers only (ties by id), gives a state up for a nearer peer's, ranks
 * early chunks of the next round again once that round begins and asks for what it dropped,
 * and asks a peer it never heard in the round for the chunk that places it, but not a peer that
 * says it is still on its way to the round. In rounds where every member gives the same position
 * (the posterior rounds) every peer is placed when the round begins: nobody is asked where it
 * is, and a listed peer that never speaks costs one timeout. A RoundComplete that says where its
 * sender is next places it a round ahead, and its sender opens that round without a beacon. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "ai/dinno_graph.h"
#include "common/crc32.h"
#include "gp/gp_pse.h"

#define K GP_PSE_MAX_NEIGHBOURS
#define N (K + 6u)
#define STATE_BYTES 1500u /* 2 chunks */
#define CHUNK 1024u
#define RESEND 100000u
#define TIMEOUT 1000000u

static gp_pse_t eng;
static uint8_t mine[STATE_BYTES], theirs[STATE_BYTES];
static gp_pse_request_t asked[4 * N]; /* the requests the engine sent (position asks too) */
static uint32_t n_asked;
static gp_pse_request_t beacon_sent;   /* its last beacon, and how many it sent */
static uint32_t n_beacons, n_chunks_sent;
static gp_pse_done_t done_sent;        /* its last RoundComplete */

static int capture(void *ctx, gp_pse_kind_t kind, const void *m)
{
    (void)ctx;
    const gp_pse_request_t *r = m;
    if (kind == GP_PSE_CHUNK)
        n_chunks_sent++;
    else if (kind == GP_PSE_DONE)
        done_sent = *(const gp_pse_done_t *)m;
    else if (kind == GP_PSE_REQUEST && r->n == 0 && r->target == r->requester) {
        beacon_sent = *r;
        n_beacons++;
    } else if (kind == GP_PSE_REQUEST && n_asked < 4 * N)
        asked[n_asked++] = *r;
    return 0;
}

static void start_from(double radius, uint32_t same_position_from)
{
    const gp_pse_cfg_t c = {0, N, STATE_BYTES, CHUNK, radius, RESEND, TIMEOUT, 0, capture, NULL, 0, 0, 0, 0, 0,
                            same_position_from};
    assert_int_equal(gp_pse_init(&eng, &c), 0);
    n_asked = n_beacons = n_chunks_sent = 0;
    memset(mine, 7, sizeof mine);
    memset(theirs, 9, sizeof theirs);
}

static void start(double radius)
{
    start_from(radius, 0);
}

/* Peer i's chunk `chunk` of `round`, sent from (x, 0). */
static int chunk_from(uint32_t i, uint32_t round, uint32_t chunk, double x, uint64_t now)
{
    const uint32_t off = chunk * CHUNK, n = STATE_BYTES - off < CHUNK ? STATE_BYTES - off : CHUNK;
    const gp_pse_chunk_t c = {i, round, chunk, 2, STATE_BYTES, crc32_ieee(theirs, STATE_BYTES), x, 0.0, n,
                              theirs + off, 0, 0, GP_PSE_TO_ALL};
    return gp_pse_on_chunk(&eng, &c, now);
}

static void whole_state_from(uint32_t i, uint32_t round, double x, uint64_t now)
{
    assert_int_equal(chunk_from(i, round, 0, x, now), 0);
    assert_int_equal(chunk_from(i, round, 1, x, now), 0);
}

/* The engine's neighbours are exactly `want` (ascending). */
static void expect_neighbours(const uint32_t *want, uint32_t n_want)
{
    uint32_t ids[K];
    const uint8_t *st[K];
    assert_int_equal(gp_pse_neighbours(&eng, ids, st), n_want);
    for (uint32_t j = 0; j < n_want; j++) {
        assert_int_equal(ids[j], want[j]);
        assert_memory_equal(st[j], theirs, STATE_BYTES);
    }
}

/* Peer i stands at x = 100 - i: the higher the id, the nearer to robot 0 at x = 0. Peers 20
 * and 21 stand at the same distance. Every state arrives, farthest first: each of the last
 * N - 1 - K peers pushes the farthest kept one out. */
static double x_of(uint32_t i)
{
    return i == 21u ? 100.0 - 20.0 : 100.0 - (double)i;
}

static void test_keeps_the_nearest(void **st)
{
    (void)st;
    start(0.0); /* every peer in reach */
    assert_int_equal(gp_pse_begin_round(&eng, 0, mine, 0.0, 0.0, 0), 0);
    for (uint32_t i = 1; i < N; i++) {
        assert_false(gp_pse_states_ready(&eng)); /* a peer not heard yet may be nearer */
        whole_state_from(i, 0, x_of(i), 10);
    }
    assert_true(gp_pse_states_ready(&eng));
    /* The nearest by (distance, id) with the same rule as the in-process reference. */
    double xy[2 * N];
    for (uint32_t i = 0; i < N; i++) {
        xy[2 * i] = i == 0 ? 0.0 : x_of(i);
        xy[2 * i + 1] = 0.0;
    }
    static dinno_graph_t g;
    assert_int_equal(dinno_graph_disk(&g, N, xy, 1e9), 0);
    assert_int_equal(g.deg[0], K);
    uint32_t want[K];
    for (uint32_t j = 0; j < K; j++)
        want[j] = g.nb[0][j];
    expect_neighbours(want, K);
    /* Peers 20 and 21 tie and both stay; peers 1 .. 5, the farthest, were pushed out. */
    assert_true(dinno_graph_has_edge(&g, 0, 20) && dinno_graph_has_edge(&g, 0, 21));
    assert_int_equal(eng.stats.evictions, N - 1u - K);
    assert_int_equal(eng.stats.not_nearest, 0); /* every chunk came while its sender was kept */
}

static void test_a_tie_at_the_last_slot_goes_to_the_lower_id(void **st)
{
    (void)st;
    start(0.0);
    assert_int_equal(gp_pse_begin_round(&eng, 0, mine, 0.0, 0.0, 0), 0);
    /* K - 1 peers near, then peers N-1 and N-2 at the same distance, higher id first. */
    for (uint32_t i = 1; i < K; i++)
        whole_state_from(i, 0, 1.0 + 0.01 * i, 10);
    whole_state_from(N - 1u, 0, 50.0, 10);
    assert_int_equal(chunk_from(N - 2u, 0, 0, 50.0, 10), 0);
    assert_int_equal(chunk_from(N - 2u, 0, 1, 50.0, 10), 0);
    for (uint32_t i = K; i < N - 2u; i++)
        assert_int_equal(chunk_from(i, 0, 0, 90.0, 10), 0); /* far: only placed */
    assert_true(gp_pse_states_ready(&eng));
    uint32_t want[K];
    for (uint32_t j = 0; j + 1u < K; j++)
        want[j] = j + 1u;
    want[K - 1u] = N - 2u;
    expect_neighbours(want, K);
    assert_int_equal(eng.stats.evictions, 1);
    assert_int_equal(eng.stats.not_nearest, N - 2u - K);
}

static void test_next_round_is_ranked_again_when_it_begins(void **st)
{
    (void)st;
    start(0.0);
    assert_int_equal(gp_pse_begin_round(&eng, 0, mine, 0.0, 0.0, 0), 0);
    /* Round 1's states come early, ranked against our round-0 position at x = 0: peers at
       x = i are kept, the 5 farthest dropped. */
    for (uint32_t i = 1; i < N; i++)
        whole_state_from(i, 1, (double)i, 10);
    assert_int_equal(eng.stats.not_nearest, 2u * (N - 1u - K));
    /* Round 1 begins at x = N: now the far end is the nearest; what was dropped is asked for. */
    for (uint32_t i = 1; i < N; i++)
        whole_state_from(i, 0, (double)i, 20);
    assert_int_equal(gp_pse_complete(&eng, NULL, 30), 0);
    assert_int_equal(gp_pse_begin_round(&eng, 1, mine, (double)N, 0.0, 40), 0);
    assert_false(gp_pse_states_ready(&eng));
    n_asked = 0;
    gp_pse_poll(&eng, 50);
    uint32_t targets = 0;
    for (uint32_t a = 0; a < n_asked; a++) {
        assert_true(asked[a].target >= K + 1u && asked[a].round == 1 && asked[a].n == 2);
        targets++;
    }
    assert_int_equal(targets, N - 1u - K); /* at once: they sent their state already */
    for (uint32_t i = K + 1u; i < N; i++)
        whole_state_from(i, 1, (double)i, 60);
    assert_true(gp_pse_states_ready(&eng));
    uint32_t want[K];
    for (uint32_t j = 0; j < K; j++)
        want[j] = N - K + j; /* the K nearest of x = N: ids N-K .. N-1 */
    expect_neighbours(want, K);
}

static void test_a_peer_never_heard_is_asked_where_it_is(void **st)
{
    (void)st;
    start(5.0);
    assert_int_equal(gp_pse_begin_round(&eng, 0, mine, 0.0, 0.0, 0), 0);
    for (uint32_t i = 2; i < N; i++)
        whole_state_from(i, 0, 100.0, 10); /* all out of reach */
    /* Peer 1 is in round 0 (its request to peer 2, which does not say where it is), but its
       positioned beacon and every chunk of it were lost. */
    const gp_pse_request_t other = {1, 2, 0, 1, {0}, 0, 0, 0.0, 0.0, GP_PSE_TO_ALL};
    assert_int_equal(gp_pse_on_request(&eng, &other, 10), 0);
    /* Its beacon is repeated every beacon period (N / 8 resend periods, at most a quarter
       timeout): not asked before one passed. */
    const uint64_t period = TIMEOUT / 4u;
    gp_pse_poll(&eng, period - 1u);
    assert_int_equal(n_asked, 0);
    assert_false(gp_pse_states_ready(&eng));
    gp_pse_poll(&eng, period);
    assert_int_equal(n_asked, 1); /* a position ask: no chunk named */
    assert_true(asked[0].target == 1 && asked[0].round == 0 && asked[0].n == 0 && asked[0].has_position);
    assert_int_equal(eng.stats.positions_asked, 1);
    gp_pse_poll(&eng, period + 10u);
    assert_int_equal(n_asked, 1); /* once per resend period */
    /* Its positioned beacon answers and places it in reach: its state is asked for at once
       (sent already, and lost). */
    const gp_pse_request_t beacon = {1, 1, 0, 0, {0}, 0, 1, 1.0, 0.0, GP_PSE_TO_ALL};
    assert_int_equal(gp_pse_on_request(&eng, &beacon, period + 20u), 0);
    gp_pse_poll(&eng, period + 30u);
    assert_int_equal(n_asked, 2);
    assert_true(asked[1].target == 1 && asked[1].n == 2);
    assert_int_equal(chunk_from(1, 0, 0, 1.0, period + 40u), 0);
    assert_false(gp_pse_states_ready(&eng));
    assert_int_equal(chunk_from(1, 0, 1, 1.0, period + 50u), 0);
    assert_true(gp_pse_states_ready(&eng));
    const uint32_t want[] = {1};
    expect_neighbours(want, 1);
}

/* A late starter: peer 1's RoundComplete of round 0 comes, but its state went out before we
 * listened. What it repeats now says where it will be in round 1, not where it was: asked where
 * it is after one resend period, not a beacon period. */
static void test_a_peer_done_before_we_listened_is_asked_after_a_resend_period(void **st)
{
    (void)st;
    start(5.0);
    assert_int_equal(gp_pse_begin_round(&eng, 0, mine, 0.0, 0.0, 0), 0);
    for (uint32_t i = 2; i < N; i++)
        whole_state_from(i, 0, 100.0, 10); /* all out of reach */
    const gp_pse_done_t d = {1, 0, 0, 1, 100.0, 0.0}; /* round 1 far away: says nothing of round 0 */
    assert_int_equal(gp_pse_on_done(&eng, &d, 10), 0);
    gp_pse_poll(&eng, RESEND - 1u);
    assert_int_equal(n_asked, 0);
    gp_pse_poll(&eng, RESEND);
    assert_int_equal(n_asked, 1); /* a position ask, a beacon period (TIMEOUT / 4) early */
    assert_true(asked[0].target == 1 && asked[0].round == 0 && asked[0].n == 0 && asked[0].has_position);
    assert_true(RESEND < TIMEOUT / 4u);
    /* Placed in reach by its answer: its lost state is asked for at once. */
    const gp_pse_request_t beacon = {1, 1, 0, 0, {0}, 0, 1, 1.0, 0.0, GP_PSE_TO_ALL};
    assert_int_equal(gp_pse_on_request(&eng, &beacon, RESEND + 10u), 0);
    gp_pse_poll(&eng, RESEND + 20u);
    assert_int_equal(n_asked, 2);
    assert_true(asked[1].target == 1 && asked[1].n == 2);
}

/* Asked where it is, a robot answers with its positioned beacon, never a chunk of its state
 * (the asker mostly keeps other states: 256 robots asked each of their peers three to four
 * times in round 0), at most one per half resend period however many ask; a position ask to
 * another robot is not answered. */
static void test_a_position_ask_is_answered_by_a_beacon(void **st)
{
    (void)st;
    start(5.0);
    assert_int_equal(gp_pse_begin_round(&eng, 0, mine, 2.0, 3.0, 0), 0);
    const uint32_t beacons = n_beacons, chunks = n_chunks_sent;
    gp_pse_request_t ask = {1, 0, 0, 0, {0}, 0, 1, 1.0, 0.0, GP_PSE_TO_ALL};
    assert_int_equal(gp_pse_on_request(&eng, &ask, RESEND), 0);
    assert_int_equal(n_beacons, beacons + 1u);
    assert_true(beacon_sent.has_position && beacon_sent.x_m == 2.0 && beacon_sent.y_m == 3.0 && beacon_sent.round == 0);
    ask.requester = 2;
    assert_int_equal(gp_pse_on_request(&eng, &ask, RESEND + RESEND / 4u), 0); /* within half a period */
    ask.requester = 3;
    ask.target = 4; /* to another robot */
    assert_int_equal(gp_pse_on_request(&eng, &ask, 2u * RESEND), 0);
    assert_int_equal(n_beacons, beacons + 1u);
    assert_int_equal(n_chunks_sent, chunks);
    assert_int_equal(eng.stats.requests_answered, 0);
}

/* A peer still driving its tour says "on my way to round 0" (a beacon without a position),
 * heard here before this robot began the round too: it is not asked where it is, however long
 * it takes (asking was a storm: every robot asked every late peer once a second). Its word of
 * the round places it; a peer that went quiet after a positioned word is asked as before. */
static void test_a_peer_on_its_way_is_not_asked_where_it_is(void **st)
{
    (void)st;
    start(5.0);
    const gp_pse_request_t on_way = {1, 1, 0, 0, {0}, 0, 0, 0.0, 0.0, GP_PSE_TO_ALL};
    assert_int_equal(gp_pse_on_request(&eng, &on_way, 5), 0); /* before our round 0 */
    assert_int_equal(gp_pse_begin_round(&eng, 0, mine, 0.0, 0.0, 10), 0);
    for (uint32_t i = 2; i < N; i++)
        whole_state_from(i, 0, 100.0, 20); /* all out of reach */
    for (uint64_t t = RESEND; t <= 8u * RESEND; t += RESEND / 2u) {
        gp_pse_poll(&eng, t);
        if (t % (2u * RESEND) == 0) /* it keeps saying so, a beacon period apart */
            assert_int_equal(gp_pse_on_request(&eng, &on_way, t), 0);
    }
    assert_int_equal(n_asked, 0);
    assert_false(gp_pse_states_ready(&eng));
    /* It began round 0: its chunk 0 places it in reach; the rest of its state is asked for. */
    assert_int_equal(chunk_from(1, 0, 0, 1.0, 8u * RESEND + 10u), 0);
    gp_pse_poll(&eng, 10u * RESEND);
    assert_int_equal(n_asked, 1);
    assert_true(asked[0].target == 1 && asked[0].n == 1 && asked[0].chunks[0] == 1);
    assert_int_equal(chunk_from(1, 0, 1, 1.0, 10u * RESEND + 10u), 0);
    assert_true(gp_pse_states_ready(&eng));
}

/* Round 1 on, every robot at one position: the round begins with every peer placed, so the
 * network is told to keep the lowest K ids at once, nobody is asked where it is (37 asks for
 * chunk 0 without it), the listed peers heard in the round are asked for their states, and
 * listed peer 5, never heard, is waited for one timeout, then the round goes on without it. */
static void test_one_position_for_all_places_every_peer(void **st)
{
    (void)st;
    start_from(5.0, 1);
    assert_int_equal(gp_pse_begin_round(&eng, 1, mine, 0.0, 0.0, 0), 0);
    uint8_t bits[GP_PSE_WANTED_BYTES];
    assert_int_equal(gp_pse_wanted(&eng, bits), K);
    for (uint32_t i = 0; i < N; i++)
        assert_int_equal((bits[i / 8u] >> (i % 8u)) & 1u, i >= 1u && i <= K);
    for (uint32_t i = 1; i < N; i++)
        if (i != 5u) { /* in round 1: a request to another peer, which does not say where it is */
            const gp_pse_request_t word = {i, i == 1u ? 2u : 1u, 1, 1, {0}, 0, 0, 0.0, 0.0, GP_PSE_TO_ALL};
            assert_int_equal(gp_pse_on_request(&eng, &word, 10), 0);
        }
    gp_pse_poll(&eng, RESEND + 20);
    assert_int_equal(n_asked, K - 1u);
    for (uint32_t j = 0; j < n_asked; j++)
        assert_true(asked[j].target >= 1u && asked[j].target <= K && asked[j].target != 5u && asked[j].n == 2);
    for (uint32_t i = 1; i <= K; i++)
        if (i != 5u)
            whole_state_from(i, 1, 0.0, RESEND + 30);
    assert_false(gp_pse_states_ready(&eng)); /* listed peer 5 may still come */
    for (uint64_t t = RESEND + 40u; t <= TIMEOUT + RESEND; t += RESEND / 2u) /* polled as gp_fleet polls */
        gp_pse_poll(&eng, t);
    assert_int_equal(eng.stats.timeouts, 1);
    assert_true(gp_pse_states_ready(&eng));
    uint32_t want[K - 1u];
    for (uint32_t j = 0, i = 1; i <= K; i++)
        if (i != 5u)
            want[j++] = i;
    expect_neighbours(want, K - 1u);
}

/* A RoundComplete of round 0 that says where its sender is in round 1 places it there (every
 * peer, before anyone began round 1), our own list of round 1 is ranked against the position our
 * RoundComplete announced, and round 1 opens without our beacon: nobody is asked where it is, the
 * network keeps the right senders of round 1 before it begins. A round begun elsewhere than
 * announced opens with its beacon; a RoundComplete with a bad position is refused. */
static void test_a_round_complete_places_its_sender_a_round_ahead(void **st)
{
    (void)st;
    start(5.0);
    assert_int_equal(gp_pse_begin_round(&eng, 0, mine, 0.0, 0.0, 0), 0);
    const uint32_t beacons0 = n_beacons;
    for (uint32_t i = 1; i < N; i++)
        whole_state_from(i, 0, 100.0, 10); /* round 0: all out of reach */
    assert_true(gp_pse_states_ready(&eng));
    /* Round 1: the odd ids next to where we will be (x = 50), the even ones where we are now. */
    for (uint32_t i = 1; i < N; i++) {
        const gp_pse_done_t d = {i, 0, 0, 1, i % 2u ? 51.0 : 0.0, 0.0};
        assert_int_equal(gp_pse_on_done(&eng, &d, 20), 0);
    }
    assert_int_equal(eng.stats.placed_ahead, N - 1u);
    const double next[2] = {50.0, 0.0};
    assert_int_equal(gp_pse_complete(&eng, next, 30), 0);
    assert_true(done_sent.round == 0 && done_sent.has_next_position == 1 && done_sent.next_x_m == 50.0 &&
                done_sent.next_y_m == 0.0);
    uint8_t bits[GP_PSE_WANTED_BYTES];
    (void)gp_pse_wanted(&eng, bits);
    for (uint32_t i = 1; i < N; i++) /* round 1's kept senders: ranked against x = 50, not x = 0 */
        assert_int_equal((bits[i / 8u] >> (i % 8u)) & 1u, i % 2u);
    assert_int_equal(gp_pse_begin_round(&eng, 1, mine, 50.0, 0.0, 40), 0);
    assert_int_equal(n_beacons, beacons0); /* opened without a beacon */
    assert_int_equal(eng.stats.openings_announced, 1);
    for (uint64_t t = 50; t <= TIMEOUT / 4u + RESEND; t += RESEND / 2u) /* past a beacon period */
        gp_pse_poll(&eng, t);
    assert_int_equal(eng.stats.positions_asked, 0); /* every peer placed */
    assert_false(gp_pse_states_ready(&eng));
    const uint64_t t1 = TIMEOUT / 4u + 2u * RESEND;
    for (uint32_t i = 1; i < N; i += 2u)
        whole_state_from(i, 1, 51.0, t1);
    assert_true(gp_pse_states_ready(&eng));
    uint32_t want[N / 2u], n_want = 0;
    for (uint32_t i = 1; i < N; i += 2u)
        want[n_want++] = i;
    expect_neighbours(want, n_want);
    /* Round 2 begun elsewhere than announced: its beacon goes out. */
    const double next2[2] = {60.0, 0.0};
    assert_int_equal(gp_pse_complete(&eng, next2, t1 + 10u), 0);
    const uint32_t beacons1 = n_beacons;
    assert_int_equal(gp_pse_begin_round(&eng, 2, mine, 61.0, 0.0, t1 + 20u), 0);
    assert_int_equal(n_beacons, beacons1 + 1u);
    assert_true(beacon_sent.has_position && beacon_sent.x_m == 61.0 && beacon_sent.round == 2);
    assert_int_equal(eng.stats.openings_announced, 1);
    /* Refused: a flag other than 0 or 1, a position not finite; and nobody announces our NaN. */
    const uint64_t invalid = eng.stats.invalid;
    gp_pse_done_t bad = {1, 2, 0, 2, 1.0, 1.0};
    assert_int_equal(gp_pse_on_done(&eng, &bad, t1 + 30u), -EBADMSG);
    bad.has_next_position = 1;
    bad.next_y_m = NAN;
    assert_int_equal(gp_pse_on_done(&eng, &bad, t1 + 30u), -EBADMSG);
    assert_int_equal(eng.stats.invalid, invalid + 2u);
    assert_int_equal(eng.stats.placed_ahead, N - 1u);
    const double nan_xy[2] = {NAN, 0.0};
    assert_int_equal(gp_pse_complete(&eng, nan_xy, t1 + 40u), -EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_keeps_the_nearest),
        cmocka_unit_test(test_a_tie_at_the_last_slot_goes_to_the_lower_id),
        cmocka_unit_test(test_next_round_is_ranked_again_when_it_begins),
        cmocka_unit_test(test_a_peer_never_heard_is_asked_where_it_is),
        cmocka_unit_test(test_a_peer_done_before_we_listened_is_asked_after_a_resend_period),
        cmocka_unit_test(test_a_position_ask_is_answered_by_a_beacon),
        cmocka_unit_test(test_a_peer_on_its_way_is_not_asked_where_it_is),
        cmocka_unit_test(test_one_position_for_all_places_every_peer),
        cmocka_unit_test(test_a_round_complete_places_its_sender_a_round_ahead),
    };
    return cmocka_run_group_tests_name("gp/pse_nearest", tests, NULL, NULL);
}
