/* Deterministic simulation of the fleet protocol (after FoundationDB's simulation testing).
 *
 * Because gp_pse is an I/O-free state machine, N real engines run here in one process on one
 * virtual clock, over a simulated multicast network that drops, duplicates, delays (and so
 * reorders), corrupts and partitions datagrams, with robots that pause (their datagrams wait,
 * as in a kernel socket buffer), crash, and restart from their last completed round with a
 * newer incarnation, and fleets whose robots start one by one over several join timeouts (as
 * hundreds of processes on two cores do). Each robot runs the image's own round driver (gp_round, the object the
 * image links) as gp_fleet runs it: want round k, begin it when the driver says so, read the
 * neighbours when it says they are there and ask it for the next round (its skip-ahead),
 * "train" (a deterministic mix of its model and its neighbours' states, taking virtual time),
 * say the node update is done, and after the last round let the driver finish and leave.
 * Only the transport and the clock are the simulation's.
 *
 * One seed draws a whole schedule (fleet size, rounds, radius, faults) and drives it; every
 * schedule asserts
 *   liveness: every robot not left crashed finishes its last round, and no robot stays in one
 *             round longer than the liveness rule allows: one peer timeout (the join timeout
 *             in its first round since it started) + slack, its own pause not counted;
 *   safety:   every neighbour state a robot trains on is the sender's state of that very
 *             round, whole (an oracle header and hash inside each state);
 *   and with loss alone (drops, duplicates, delays, corruption; no pause, crash or
 *   partition): no timeout fired and every final model equals the lossless schedule's.
 * A failing schedule prints its seed; FLEETSIM_PSE_SIM_SEED=S replays exactly that one, and
 * FLEETSIM_PSE_SIM_SCHEDULES=N runs N schedules (default 400; `make test-faults` runs more);
 * FLEETSIM_PSE_SIM_TRACE=1 prints each robot's rounds, FLEETSIM_PSE_SIM_DEBUG=1 its neighbour list
 * when that differs from the reference's. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "ai/dinno_graph.h"
#include "gp/gp_pse.h"
#include "gp/gp_round.h"

#define SMALL_N 7         /* most schedules: 2 .. SMALL_N robots */
#define BIG_N_MIN (GP_PSE_MAX_NEIGHBOURS + 1) /* one in 32: more robots than neighbour slots */
#define MAXN (BIG_N_MIN + 7)
#define MAXR 24
#define STATE_BYTES 2600u /* 3 chunks of 1024 */
#define CHUNK 1024u
#define N_CHUNKS 3u
#define HDR 12u           /* oracle header: sender, round, hash of the rest */
#define TICK_US 1000u
#define RESEND_US 5000u  /* peer_timeout / resend_after = 50: tighter than the defaults' 200 (gp_fleet.h: 10 s / 50 ms) */
#define TIMEOUT_US 250000u
#define JOIN_US 500000u
#define LATE_MAX_US (2u * TIMEOUT_US) /* a late datagram arrives up to this much later */
#define QCAP 32768

/* ---- seeded randomness --------------------------------------------------------------- */
static uint64_t rng_s;
static uint64_t rnd(void)
{
    uint64_t z = (rng_s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
static double rnd01(void) { return (double)(rnd() >> 11) * (1.0 / 9007199254740992.0); }
static uint64_t rnd_below(uint64_t n) { return n ? rnd() % n : 0; }

/* ---- one schedule ------------------------------------------------------------------------ */
typedef struct schedule {
    uint64_t seed;
    int n, rounds;
    double radius;
    double drop, dup, corrupt, late;
    uint64_t delay_us;
    int partition;              /* robots < split vs the others, during [p_from, p_until) */
    int split;
    uint64_t p_from, p_until;
    int pause_robot;            /* -1: none */
    uint64_t pause_from, pause_len;
    int crash_robot;            /* -1: none */
    uint64_t crash_at, restart_after; /* restart_after 0: stays down */
    uint64_t stagger_us;        /* robot i starts i x this late (a fleet whose processes take
                                   longer to start than the join timeout); 0: all at once */
    uint8_t addressed;          /* 1: requests go to their target, resends to their requester
                                   alone, and each sender's datagrams reach a robot in the order
                                   sent (point to point over TCP: the engines are `ordered`) */
    uint32_t same_from;         /* > 0: from this round on every robot gives the same position
                                   (the posterior rounds), placed by all without a word */
    uint8_t announce;           /* whose RoundComplete says where it is next (offline tours: known
                                   ahead), so that it opens the next round without a beacon:
                                   0 nobody, 1 every robot, 2 the odd ids (a fleet of both) */
} schedule_t;

/* From the first robot's start to the last one's: a first round may wait that much longer. */
static uint64_t start_span(const schedule_t *s)
{
    return (uint64_t)(s->n - 1) * s->stagger_us + 50000u;
}

static int loss_only(const schedule_t *s)
{
    return !s->partition && s->pause_robot < 0 && s->crash_robot < 0;
}

typedef enum { R_DRIVE, R_EXCHANGE, R_COMPUTE, R_FINISH, R_EXITED, R_DOWN } rphase_t;

typedef struct robot {
    gp_round_t drv;             /* the image's round driver, with the protocol inside */
    int id;
    rphase_t phase;
    uint32_t round;
    uint32_t next;              /* the round after this one (the driver's skip-ahead) */
    uint32_t incarnation;
    uint64_t wake_us;           /* R_DRIVE / R_COMPUTE: when that ends */
    int timing;                 /* a round begun and not finished yet: */
    uint64_t round_begin_us;    /* when it began */
    uint64_t paused_in_round;   /* virtual time paused since */
    uint64_t stalled_mark;      /* the engine's stalled_us when it began */
    uint8_t model[STATE_BYTES];
    uint8_t mine[STATE_BYTES];  /* the state sent this round (stable until the round ends) */
    uint8_t ckpt[STATE_BYTES];  /* model after the last completed round (for a restart) */
    int32_t ckpt_round;         /* -1: none */
    uint64_t max_round_us;      /* the longest round past its allowance ... */
    uint64_t max_allowed_us;    /* ... and that allowance */
    int first_round;            /* the first round since (re)start: peers not heard yet */
    int used_states;
} robot_t;

static robot_t rob[MAXN];
static int rob_ctx[MAXN];
static uint64_t fifo_at[MAXN][MAXN]; /* addressed: the latest arrival queued from a robot to one */

/* A datagram in flight to one receiver. */
typedef struct dgram {
    uint64_t at;
    uint32_t seq;
    int from, to;
    gp_pse_kind_t kind;
    gp_pse_chunk_t chunk;
    gp_pse_done_t done;
    gp_pse_request_t req;
    uint8_t data[CHUNK];
} dgram_t;

static dgram_t q[QCAP];
static int qn;
static uint32_t seq;
static uint64_t now_us;
static const schedule_t *cur;

typedef struct totals {
    uint64_t schedules, loss_only, sent, dropped, duplicated, corrupted, late, partitioned, overflow;
    uint64_t pauses, crashes, restarts, timeouts, rejoins, skipped, cut, missed, crc, old_inc, used;
    uint64_t big, nearest_checked, beyond_slots, evictions, staggered, addressed, same;
    uint64_t announcing, openings_announced, placed_ahead;
} totals_t;
static totals_t tot;

static uint32_t hash32(const uint8_t *p, size_t n)
{
    uint32_t h = 2166136261u;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 16777619u;
    return h;
}

static void put32(uint8_t *p, uint32_t v) { memcpy(p, &v, 4); }
static uint32_t get32(const uint8_t *p)
{
    uint32_t v;
    memcpy(&v, p, 4);
    return v;
}

static int partitioned(int a, int b)
{
    return cur->partition && now_us >= cur->p_from && now_us < cur->p_until && (a < cur->split) != (b < cur->split);
}

static void enqueue(const dgram_t *d)
{
    if (qn == QCAP) {
        tot.overflow++; /* a full network loses datagrams too */
        return;
    }
    q[qn++] = *d;
}

/* The robots' send callback: one copy per other robot, each with its own fate. */
static int net_send(void *ctx, gp_pse_kind_t kind, const void *m)
{
    const int from = *(const int *)ctx;
    const uint32_t only = kind == GP_PSE_CHUNK     ? ((const gp_pse_chunk_t *)m)->to
                          : kind == GP_PSE_REQUEST ? ((const gp_pse_request_t *)m)->to
                                                   : GP_PSE_TO_ALL; /* addressed: one robot's */
    tot.sent++;
    for (int to = 0; to < cur->n; to++) {
        if (to == from || (only != GP_PSE_TO_ALL && only != (uint32_t)to))
            continue;
        if (partitioned(from, to)) {
            tot.partitioned++;
            continue;
        }
        if (rnd01() < cur->drop) {
            tot.dropped++;
            continue;
        }
        dgram_t d;
        memset(&d, 0, offsetof(dgram_t, data));
        d.from = from;
        d.to = to;
        d.kind = kind;
        if (kind == GP_PSE_CHUNK) {
            d.chunk = *(const gp_pse_chunk_t *)m;
            memcpy(d.data, d.chunk.data, d.chunk.n_bytes);
            if (rnd01() < cur->corrupt) {
                d.data[rnd_below(d.chunk.n_bytes)] ^= (uint8_t)(1u + rnd_below(255));
                tot.corrupted++;
            }
        } else if (kind == GP_PSE_DONE) {
            d.done = *(const gp_pse_done_t *)m;
        } else {
            d.req = *(const gp_pse_request_t *)m;
        }
        const int copies = rnd01() < cur->dup ? 2 : 1;
        tot.duplicated += (uint64_t)(copies - 1);
        for (int c = 0; c < copies; c++) {
            d.at = now_us + TICK_US + rnd_below(cur->delay_us + 1u);
            if (rnd01() < cur->late) { /* held up somewhere: it arrives rounds later */
                d.at += rnd_below(LATE_MAX_US);
                tot.late++;
            }
            if (cur->addressed) { /* a connection keeps its order: nothing overtakes (TCP) */
                if (d.at < fifo_at[from][to])
                    d.at = fifo_at[from][to];
                fifo_at[from][to] = d.at;
            }
            d.seq = seq++;
            enqueue(&d);
        }
    }
    return 0;
}

static int is_paused(int i)
{
    return cur->pause_robot == i && now_us >= cur->pause_from && now_us < cur->pause_from + cur->pause_len;
}

static void deliver(robot_t *r, dgram_t *d)
{
    if (d->kind == GP_PSE_CHUNK) {
        d->chunk.data = d->data;
        (void)gp_pse_on_chunk(&r->drv.pse, &d->chunk, now_us);
    } else if (d->kind == GP_PSE_DONE) {
        (void)gp_pse_on_done(&r->drv.pse, &d->done, now_us);
    } else {
        (void)gp_pse_on_request(&r->drv.pse, &d->req, now_us);
    }
}

static int by_time_then_seq(const void *a, const void *b)
{
    const dgram_t *x = a, *y = b;
    if (x->at != y->at)
        return x->at < y->at ? -1 : 1;
    return x->seq < y->seq ? -1 : x->seq > y->seq;
}

/* Everything due by now, in (time, sequence) order, to robots that listen. What a delivery
   sends is due a tick later at the earliest, so the due set is taken out and sorted once. */
static dgram_t due[QCAP];
static void deliver_due(void)
{
    int nd = 0;
    for (int i = 0; i < qn;)
        if (q[i].at <= now_us && !is_paused(q[i].to)) {
            due[nd++] = q[i];
            q[i] = q[--qn];
        } else {
            i++;
        }
    qsort(due, (size_t)nd, sizeof due[0], by_time_then_seq);
    for (int i = 0; i < nd; i++) {
        robot_t *r = &rob[due[i].to];
        if (r->phase != R_DOWN && r->phase != R_EXITED)
            deliver(r, &due[i]);
    }
}

/* ---- the robots ------------------------------------------------------------------------- */
static void position(int id, uint32_t round, double *x, double *y)
{
    if (cur->same_from > 0 && round >= cur->same_from) {
        *x = *y = 0.0;
        return;
    }
    /* Robots on circles that cross: the disk graph changes from round to round. */
    const double a = 0.4 * (double)round + 1.3 * (double)id;
    *x = 5.0 + 4.0 * cos(a) + 0.5 * (double)id;
    *y = 5.0 + 4.0 * sin(a * 0.7);
}

static void init_model(robot_t *r)
{
    for (uint32_t b = 0; b < STATE_BYTES; b++)
        r->model[b] = (uint8_t)(b * 131u + (uint32_t)r->id * 29u + 7u);
}

static void start_engine(robot_t *r)
{
    gp_pse_cfg_t c = {(uint32_t)r->id, (uint32_t)cur->n, STATE_BYTES, CHUNK, cur->radius, RESEND_US, TIMEOUT_US,
                      JOIN_US, net_send, &rob_ctx[r->id], 0, r->incarnation, 1, cur->addressed,
                      cur->addressed, cur->same_from};
    assert_int_equal(gp_round_init(&r->drv, &c, (uint32_t)cur->rounds), 0);
    r->timing = 0;
}

static void begin(robot_t *r)
{
    memcpy(r->mine, r->model, STATE_BYTES);
    put32(r->mine, (uint32_t)r->id);
    put32(r->mine + 4, r->round);
    put32(r->mine + 8, hash32(r->mine + HDR, STATE_BYTES - HDR));
    double x, y;
    position(r->id, r->round, &x, &y);
    assert_int_equal(gp_round_begin(&r->drv, r->mine, x, y, now_us), 0);
    r->timing = 1;
    r->round_begin_us = now_us;
    r->paused_in_round = 0;
    r->stalled_mark = r->drv.pse.stats.stalled_us;
}

/* With loss alone every robot is heard in every round, so a robot's neighbours are exactly
   the in-process reference's: its GP_PSE_MAX_NEIGHBOURS nearest within the radius. */
static void check_nearest(const robot_t *r, const uint32_t *ids, uint32_t n)
{
    double xy[2 * MAXN];
    for (int i = 0; i < cur->n; i++)
        position(i, r->round, &xy[2 * i], &xy[2 * i + 1]);
    static dinno_graph_t g;
    assert_int_equal(dinno_graph_disk(&g, (uint32_t)cur->n, xy, cur->radius > 0.0 ? cur->radius : 1e9), 0);
    tot.nearest_checked++;
    uint32_t in_reach = 0;
    for (int i = 0; i < cur->n; i++) {
        const double dx = xy[2 * i] - xy[2 * r->id], dy = xy[2 * i + 1] - xy[2 * r->id + 1];
        in_reach += i != r->id && (cur->radius <= 0.0 || dx * dx + dy * dy <= cur->radius * cur->radius);
    }
    tot.beyond_slots += in_reach > GP_PSE_MAX_NEIGHBOURS;
    int same = n == g.deg[r->id];
    for (uint32_t j = 0; j < n && same; j++)
        same = ids[j] == g.nb[r->id][j];
    if (!same && getenv("FLEETSIM_PSE_SIM_DEBUG")) {
        const gp_pse_nearest_t *nr = &r->drv.pse.near[r->round & 1u];
        fprintf(stderr, "near round %u valid %d n %u:", nr->round, nr->valid, nr->n);
        for (uint32_t m = 0; m < nr->n; m++)
            fprintf(stderr, " %u(buf %u)", nr->id[m], r->drv.pse.peer[nr->id[m]].buf[r->round & 1u]);
        fprintf(stderr, "\n");
        for (int i = 0; i < cur->n; i++)
            fprintf(stderr, "peer %d: has_pos %d pos_round %u absent %d heard %d at %llu; now %llu start %llu timeouts %llu\n", i, r->drv.pse.peer[i].has_pos[r->round & 1u],
                    r->drv.pse.peer[i].pos_round[r->round & 1u], r->drv.pse.peer[i].absent, r->drv.pse.peer[i].heard,
                    (unsigned long long)r->drv.pse.peer[i].heard_us, (unsigned long long)now_us,
                    (unsigned long long)r->drv.pse.round_start_us, (unsigned long long)r->drv.pse.stats.timeouts);
    }
    if (!same)
        fail_msg("schedule %llu: robot %d of %d took %u neighbour states in round %u, the reference %u (or others) "
                 "(replay: FLEETSIM_PSE_SIM_SEED=%llu)", (unsigned long long)cur->seed, r->id, cur->n, n, r->round,
                 g.deg[r->id], (unsigned long long)cur->seed);
}

/* The "node update": the model mixed with the neighbours' states in id order, after the
   oracle checked that each is the sender's state of this round, whole. */
static void train(robot_t *r)
{
    uint32_t ids[GP_PSE_MAX_NEIGHBOURS];
    const uint8_t *st[GP_PSE_MAX_NEIGHBOURS];
    const uint32_t n = gp_pse_neighbours(&r->drv.pse, ids, st);
    if (loss_only(cur))
        check_nearest(r, ids, n);
    for (uint32_t j = 0; j < n; j++) {
        if (get32(st[j]) != ids[j] || get32(st[j] + 4) != r->round ||
            get32(st[j] + 8) != hash32(st[j] + HDR, STATE_BYTES - HDR))
            fail_msg("schedule %llu: robot %d trained on a state that is not robot %u's of round %u",
                     (unsigned long long)cur->seed, r->id, ids[j], r->round);
        for (uint32_t b = HDR; b < STATE_BYTES; b++)
            r->model[b] = (uint8_t)(r->model[b] * 31u + st[j][b] * (ids[j] + 3u) + (uint8_t)r->round);
        tot.used++;
    }
    for (uint32_t b = HDR; b < STATE_BYTES; b++)
        r->model[b] = (uint8_t)(r->model[b] + (uint8_t)(b ^ r->round));
}

static int trace;
#define TRACE(r, what)                                                                         \
    do {                                                                                       \
        if (trace)                                                                             \
            fprintf(stderr, "%8.3f robot %d round %u: %s (timeouts %llu, later %d)\n", (double)now_us * 1e-6, (r)->id, \
                    (r)->round, what, (unsigned long long)(r)->drv.pse.stats.timeouts, (r)->drv.pse.later_heard); \
    } while (0)

static uint64_t slack_us; /* of the schedule running */

static uint64_t compute_us(void) { return 2000u + rnd_below(12000u); }

/* The round that began at round_begin_us is over for the robot (the driver began the next or
   started leaving): its length, own pauses not counted, against the liveness bound. */
static void round_finished(robot_t *r)
{
    if (!r->timing)
        return;
    const uint64_t took = now_us - r->round_begin_us - r->paused_in_round;
    /* A datagram held back for rounds is progress when it finally arrives: the bound runs
       from the last progress received, so late ones extend it by their delay. */
    /* The timeout adapts (gp_pse.h): the longest the engine applied so far, at most
       GP_PSE_TIMEOUT_STRETCH x TIMEOUT_US; and the time it did not run (computing, paused) is
       not counted against its peers. */
    const gp_pse_stats_t *ps = &r->drv.pse.stats;
    const uint64_t timeout = ps->timeout_longest_us > TIMEOUT_US ? ps->timeout_longest_us : TIMEOUT_US;
    assert_true(timeout <= GP_PSE_TIMEOUT_STRETCH * TIMEOUT_US);
    /* While a fleet starts one robot at a time, any round may wait for a newcomer that waits
       its join timeout in its own first round (for a robot that never started). */
    const int starting = r->first_round || (cur->stagger_us != 0 && r->round_begin_us < start_span(cur) + JOIN_US);
    const uint64_t allowed = (starting ? JOIN_US + start_span(cur) : timeout) + (ps->stalled_us - r->stalled_mark) +
                             (cur->late > 0.0 ? LATE_MAX_US : 0u) + slack_us;
    if (took > allowed && took - allowed > r->max_round_us - r->max_allowed_us) {
        r->max_round_us = took;
        r->max_allowed_us = allowed;
    }
    r->first_round = 0;
    r->timing = 0;
}

/* One tick of a robot, driven as gp_fleet drives the image's: the AI core wants round k
   exchanged, the driver says when to begin it and when the states are there; the node update
   takes virtual time; then RoundComplete, and after the last round the driver's leaving. */
static void step(robot_t *r)
{
    const uint32_t last = (uint32_t)cur->rounds - 1u;
    switch (r->phase) {
    case R_DRIVE:
        if (now_us < r->wake_us)
            break;
        assert_int_equal(gp_round_want(&r->drv, r->round, now_us), 0);
        r->phase = R_EXCHANGE; /* the GP core steps the driver at once */
        /* fall through */
    case R_EXCHANGE:
        for (gp_round_event_t ev; (ev = gp_round_step(&r->drv, now_us)) != GP_ROUND_WAIT;) {
            if (ev == GP_ROUND_BEGIN) {
                round_finished(r);
                begin(r);
                TRACE(r, "begin");
                continue;
            }
            assert_int_equal(ev, GP_ROUND_READY);
            train(r);
            r->next = gp_round_next_round(&r->drv, r->round, now_us);
            TRACE(r, "states ready");
            r->phase = R_COMPUTE;
            r->wake_us = now_us + compute_us();
            break;
        }
        break;
    case R_COMPUTE:
        (void)gp_round_step(&r->drv, now_us); /* the GP core serves the network while the AI trains */
        if (now_us < r->wake_us)
            break;
        double next[2];
        const int announce = cur->announce == 1 || (cur->announce == 2 && (r->id & 1));
        if (announce)
            position(r->id, r->round + 1u, &next[0], &next[1]);
        assert_int_equal(gp_round_node_done(&r->drv, r->round, r->round == last, announce ? next : NULL, now_us), 0);
        memcpy(r->ckpt, r->model, STATE_BYTES);
        r->ckpt_round = (int32_t)r->round;
        TRACE(r, "complete");
        if (r->round == last) {
            r->phase = R_FINISH;
            break;
        }
        r->round = r->next; /* offline: the AI core publishes the next state at once */
        r->phase = R_DRIVE;
        r->wake_us = now_us;
        break;
    case R_FINISH: {
        const gp_round_phase_t was = r->drv.phase;
        const gp_round_event_t ev = gp_round_step(&r->drv, now_us);
        if (was == GP_ROUND_FINISHING && r->drv.phase != GP_ROUND_FINISHING)
            round_finished(r);
        if (ev == GP_ROUND_DONE)
            r->phase = R_EXITED;
        break;
    }
    default:
        break;
    }
}

static void add_stats(const gp_pse_stats_t *s)
{
    tot.timeouts += s->timeouts;
    tot.rejoins += s->rejoins;
    tot.skipped += s->rounds_skipped;
    tot.cut += s->rounds_cut;
    tot.missed += s->states_missed;
    tot.crc += s->crc_failures;
    tot.old_inc += s->old_incarnation;
    tot.evictions += s->evictions;
    tot.openings_announced += s->openings_announced;
    tot.placed_ahead += s->placed_ahead;
}

/* Runs one schedule; the final models land in out (per robot) when it is given. */
static void run(const schedule_t *s, uint8_t out[MAXN][STATE_BYTES], uint64_t *timeouts, uint64_t *cut)
{
    cur = s;
    if (trace)
        fprintf(stderr, "schedule %llu: %d robots, %d rounds, radius %g, drop %g dup %g corrupt %g late %g delay %llu us; "
                        "partition %d (split %d, %.3f..%.3f s); pause robot %d (%.3f s for %.3f s); crash robot %d "
                        "(%.3f s, restart after %.3f s); starts %.3f s apart; resends %s; same position from round %u; "
                        "next position announced by %s\n",
                (unsigned long long)s->seed, s->n, s->rounds, s->radius, s->drop, s->dup, s->corrupt, s->late,
                (unsigned long long)s->delay_us, s->partition, s->split, (double)s->p_from * 1e-6,
                (double)s->p_until * 1e-6, s->pause_robot, (double)s->pause_from * 1e-6, (double)s->pause_len * 1e-6,
                s->crash_robot, (double)s->crash_at * 1e-6, (double)s->restart_after * 1e-6,
                (double)s->stagger_us * 1e-6, s->addressed ? "addressed" : "multicast", s->same_from,
                s->announce == 0 ? "nobody" : s->announce == 1 ? "every robot" : "the odd ids");
    qn = 0;
    seq = 0;
    memset(fifo_at, 0, sizeof fifo_at);
    now_us = 0;
    rng_s = s->seed ^ 0x5EEDF00Dull;
    for (int i = 0; i < s->n; i++) {
        robot_t *r = &rob[i];
        rob_ctx[i] = i;
        r->id = i;
        r->incarnation = 1;
        r->round = 0;
        r->ckpt_round = -1;
        r->max_round_us = r->max_allowed_us = 0;
        r->first_round = 1;
        init_model(r);
        start_engine(r);
        r->phase = R_DRIVE;
        r->wake_us = (uint64_t)i * s->stagger_us + rnd_below(50000u); /* the tours take different times */
    }
    /* Liveness bound per round (the rule in gp_pse.h): one peer timeout (the join timeout in a
       robot's first round), with slack for compute, latency and resends: 20 request periods,
       each up to 2^GP_PSE_BACKOFF_MAX resend periods once requests go unanswered
       (2^GP_PSE_BACKOFF_MAX_ORDERED on the addressed schedules' ordered links). */
    slack_us = 30000u + 4u * s->delay_us +
               20u * (RESEND_US << (s->addressed ? GP_PSE_BACKOFF_MAX_ORDERED : GP_PSE_BACKOFF_MAX));
    const uint64_t bound = JOIN_US + TIMEOUT_US + slack_us;
    const uint64_t deadline =
        (uint64_t)s->rounds * bound + start_span(s) + s->pause_len + s->restart_after + 5000000u;
    int crashed = 0, restarted = 0;
    for (; now_us < deadline; now_us += TICK_US) {
        if (s->crash_robot >= 0 && !crashed && now_us >= s->crash_at && rob[s->crash_robot].phase != R_EXITED) {
            robot_t *r = &rob[s->crash_robot];
            add_stats(&r->drv.pse.stats);
            r->phase = R_DOWN;
            crashed = 1;
            tot.crashes++;
        }
        if (crashed && !restarted && s->restart_after > 0 && now_us >= s->crash_at + s->restart_after) {
            robot_t *r = &rob[s->crash_robot];
            r->incarnation++;
            start_engine(r);
            if (r->ckpt_round >= 0) {
                memcpy(r->model, r->ckpt, STATE_BYTES);
                r->round = (uint32_t)r->ckpt_round + 1u;
            } else {
                init_model(r);
                r->round = 0;
            }
            restarted = 1;
            r->first_round = 1;
            tot.restarts++;
            if (r->round >= (uint32_t)s->rounds) { /* it had finished: nothing to resume */
                r->phase = R_EXITED;
            } else {
                r->phase = R_DRIVE;
                r->wake_us = now_us + 30000u;
            }
        }
        deliver_due();
        int active = 0;
        for (int i = 0; i < s->n; i++) {
            robot_t *r = &rob[i];
            if (r->phase == R_EXITED || r->phase == R_DOWN)
                continue;
            active = 1;
            if (is_paused(i)) {
                if (r->timing)
                    r->paused_in_round += TICK_US;
                continue;
            }
            step(r);
        }
        if (!active)
            break;
    }
    if (s->pause_robot >= 0)
        tot.pauses++;
    for (int i = 0; i < s->n; i++) {
        robot_t *r = &rob[i];
        const int left_down = r->phase == R_DOWN;
        if (!left_down && r->phase != R_EXITED)
            fail_msg("schedule %llu: robot %d still in round %u (phase %d) at the deadline %.1f s: no progress "
                     "(replay: FLEETSIM_PSE_SIM_SEED=%llu)",
                     (unsigned long long)s->seed, i, r->round, (int)r->phase, (double)deadline * 1e-6,
                     (unsigned long long)s->seed);
        if (r->max_round_us > 0)
            fail_msg("schedule %llu: robot %d spent %.3f s in one round, past the liveness bound %.3f s "
                     "(replay: FLEETSIM_PSE_SIM_SEED=%llu)",
                     (unsigned long long)s->seed, i, (double)r->max_round_us * 1e-6, (double)r->max_allowed_us * 1e-6,
                     (unsigned long long)s->seed);
        if (!left_down)
            add_stats(&r->drv.pse.stats);
        if (out)
            memcpy(out[i], r->model, STATE_BYTES);
        if (timeouts)
            *timeouts += r->drv.pse.stats.timeouts;
        if (cut)
            *cut += r->drv.pse.stats.rounds_cut;
    }
}

static void draw(uint64_t seed, schedule_t *s)
{
    rng_s = seed;
    memset(s, 0, sizeof *s);
    s->seed = seed;
    s->n = 2 + (int)rnd_below(SMALL_N - 1);
    s->rounds = 3 + (int)rnd_below(MAXR - 3);
    s->radius = rnd_below(3) == 0 ? 0.0 : 6.0;
    static const double drops[] = {0.0, 0.05, 0.2, 0.4};
    s->drop = drops[rnd_below(4)];
    s->dup = rnd_below(3) == 0 ? 0.1 : 0.0;
    s->corrupt = rnd_below(4) == 0 ? 0.02 : 0.0;
    s->late = rnd_below(4) == 0 ? 0.01 : 0.0;
    s->delay_us = rnd_below(3) == 0 ? 15000u : 2000u; /* above a tick: reordered */
    s->pause_robot = s->crash_robot = -1;
    const uint64_t kind = rnd_below(8);
    const uint64_t t = 20000u + rnd_below((uint64_t)s->rounds * 25000u);
    if (kind == 5) {
        s->partition = 1;
        s->split = 1 + (int)rnd_below((uint64_t)s->n - 1);
        s->p_from = t;
        s->p_until = t + TIMEOUT_US + rnd_below(3u * TIMEOUT_US);
    } else if (kind == 6) {
        s->pause_robot = (int)rnd_below((uint64_t)s->n);
        s->pause_from = t;
        s->pause_len = TIMEOUT_US / 2 + rnd_below(3u * TIMEOUT_US);
    } else if (kind == 7) {
        s->crash_robot = (int)rnd_below((uint64_t)s->n);
        s->crash_at = t;
        s->restart_after = rnd_below(3) == 0 ? 0 : 50000u + rnd_below(3u * TIMEOUT_US);
    }
    /* Drawn last, so the schedules of small fleets stay what they were. */
    if (rnd_below(32) == 0) {
        s->n = BIG_N_MIN + (int)rnd_below(MAXN - BIG_N_MIN + 1);
        s->rounds = 3 + s->rounds / 4; /* a big fleet's round costs ~40 small ones */
    }
    /* One in eight: a fleet that starts slowly, each robot 0.6 join timeouts after the one
       before, so the last starts well past the first one's join timeout (with loss alone
       nobody may be given up: the join clock restarts at every newcomer). Drawn after the
       rest, so the schedules without it stay what they were. */
    if (rnd_below(8) == 0) {
        s->stagger_us = JOIN_US * 3u / 5u;
        /* At most 20 % loss then: the early robots wait seconds, dozens of peer timeouts in
           which a waiting peer is heard only by its periodic beacon (every n / 8 resend periods
           in a big fleet, so about 10 per timeout here against 200 with the defaults), and at
           40 % loss ten lost in a row happen somewhere in a fleet of 38 (seed 15293). */
        if (s->drop > 0.2)
            s->drop = 0.2;
    }
    /* Half of them over a point-to-point network (ZeroMQ): a request goes to its target only,
       a resend to its requester only. Drawn last, as above. */
    s->addressed = (uint8_t)(rnd_below(2) == 0);
    /* A connection keeps its order, so it never holds one datagram for rounds while the others
       pass: what is late there holds up everything behind it (a stall, which the pauses and
       partitions above cover). And it loses a message only when its reader falls behind (a
       high-water mark): at most 20 % then. At 40 % ten beacons in a row to one peer were lost
       in a fleet of 36 (seed 8955) while their sender, asking on its sender's word, took 0.4 s
       for a round: a timeout of a live peer, which the loss-only check rightly refuses. */
    if (s->addressed) {
        s->late = 0.0;
        if (s->drop > 0.2)
            s->drop = 0.2;
    }
    /* One in four: the last rounds at one position for all (gp_fleet's posterior rounds), every
       peer placed when a round begins, crashed ones too. Drawn last, as above. */
    if (rnd_below(4) == 0)
        s->same_from = 1u + (uint32_t)rnd_below((uint64_t)s->rounds);
    s->announce = (uint8_t)rnd_below(3); /* drawn last, as above */
}

static uint64_t env_u64(const char *name, uint64_t dflt)
{
    const char *v = getenv(name);
    if (v == NULL || *v == '\0')
        return dflt;
    char *end = NULL;
    unsigned long long x = strtoull(v, &end, 10);
    if (end == v || *end != '\0')
        fail_msg("%s='%s' is not a whole number", name, v);
    return x;
}

static uint8_t ref_model[MAXN][STATE_BYTES], got_model[MAXN][STATE_BYTES];

static void check_schedule(uint64_t seed)
{
    schedule_t s;
    draw(seed, &s);
    tot.schedules++;
    tot.big += s.n >= (int)BIG_N_MIN;
    tot.staggered += s.stagger_us != 0;
    tot.addressed += s.addressed;
    tot.same += s.same_from > 0;
    tot.announcing += s.announce > 0;
    uint64_t timeouts = 0, cut = 0;
    run(&s, got_model, &timeouts, &cut);
    if (!loss_only(&s))
        return;
    tot.loss_only++;
    if (timeouts != 0 || cut != 0)
        fail_msg("schedule %llu (loss only, drop %.2f): %llu timeouts, %llu cut rounds; expected none "
                 "(replay: FLEETSIM_PSE_SIM_SEED=%llu)",
                 (unsigned long long)seed, s.drop, (unsigned long long)timeouts, (unsigned long long)cut,
                 (unsigned long long)seed);
    schedule_t clean = s;
    clean.drop = clean.dup = clean.corrupt = clean.late = 0.0;
    clean.delay_us = 0;
    run(&clean, ref_model, NULL, NULL);
    for (int i = 0; i < s.n; i++)
        if (memcmp(ref_model[i], got_model[i], STATE_BYTES) != 0)
            fail_msg("schedule %llu (loss only): robot %d's final model differs from the lossless run's "
                     "(replay: FLEETSIM_PSE_SIM_SEED=%llu)",
                     (unsigned long long)seed, i, (unsigned long long)seed);
}

static void test_seeded_schedules(void **st)
{
    (void)st;
    memset(&tot, 0, sizeof tot);
    trace = getenv("FLEETSIM_PSE_SIM_TRACE") != NULL;
    const uint64_t one = env_u64("FLEETSIM_PSE_SIM_SEED", 0);
    const uint64_t n = one ? 1u : env_u64("FLEETSIM_PSE_SIM_SCHEDULES", 400u);
    const uint64_t base = env_u64("FLEETSIM_PSE_SIM_BASE", 1u);
    for (uint64_t i = 0; i < n; i++)
        check_schedule(one ? one : base + i);
    print_message("pse_sim: %llu schedules (%llu loss only, %llu with pauses, %llu crashes, %llu restarts, %llu "
                  "starting one robot at a time, %llu addressed, %llu ending at one position, %llu announcing the next "
                  "position), seeds %llu..%llu\n",
                  (unsigned long long)tot.schedules, (unsigned long long)tot.loss_only, (unsigned long long)tot.pauses,
                  (unsigned long long)tot.crashes, (unsigned long long)tot.restarts, (unsigned long long)tot.staggered,
                  (unsigned long long)tot.addressed, (unsigned long long)tot.same, (unsigned long long)tot.announcing,
                  (unsigned long long)(one ? one : base), (unsigned long long)(one ? one : base + n - 1u));
    print_message("pse_sim: injected: %llu sends, %llu copies dropped, %llu duplicated, %llu corrupted, %llu late, "
                  "%llu cut by partitions, %llu lost to a full network\n",
                  (unsigned long long)tot.sent, (unsigned long long)tot.dropped, (unsigned long long)tot.duplicated,
                  (unsigned long long)tot.corrupted, (unsigned long long)tot.late, (unsigned long long)tot.partitioned,
                  (unsigned long long)tot.overflow);
    print_message("pse_sim: survived: every schedule live and safe; %llu neighbour states trained on; %llu timeouts, "
                  "%llu rejoins, %llu rounds skipped to catch up, %llu rounds cut by a later round\n",
                  (unsigned long long)tot.used, (unsigned long long)tot.timeouts, (unsigned long long)tot.rejoins,
                  (unsigned long long)tot.skipped, (unsigned long long)tot.cut);
    print_message("pse_sim: rejected: %llu CRC failures, %llu messages of an earlier incarnation, %llu states "
                  "missed\n",
                  (unsigned long long)tot.crc, (unsigned long long)tot.old_inc, (unsigned long long)tot.missed);
    print_message("pse_sim: %llu fleets of %d..%d robots (more than the %u neighbour slots); loss only: %llu neighbour "
                  "sets equal to the reference's, %llu of them the nearest of more in reach; %llu states given up "
                  "for a nearer one\n",
                  (unsigned long long)tot.big, BIG_N_MIN, MAXN, (unsigned)GP_PSE_MAX_NEIGHBOURS,
                  (unsigned long long)tot.nearest_checked, (unsigned long long)tot.beyond_slots,
                  (unsigned long long)tot.evictions);
    print_message("pse_sim: %llu rounds opened without a beacon (the RoundComplete before said where), %llu peers "
                  "placed a round ahead by it\n",
                  (unsigned long long)tot.openings_announced, (unsigned long long)tot.placed_ahead);
    if (n >= 50u)
        assert_true(tot.openings_announced > 0 && tot.placed_ahead > 0); /* the path is exercised */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_seeded_schedules),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
