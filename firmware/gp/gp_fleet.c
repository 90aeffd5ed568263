/* The robot in a fleet: see gp_fleet.h. */
#include "gp/gp_fleet.h"

#include <inttypes.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ai/bnn_quant.h"
#include "ai/dinno_codec.h"
#include "gp/gp_wire.h"
#include "hal/hal.h"
#include "rt/rt_path.h"

_Static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "fp32 states travel as little-endian words");
/* Every codec's state fits the state buffers (ours and gp_pse's reassembly buffers), and a
   quantised one expands there in place to the fp32 state. */
_Static_assert(DINNO_CODEC_MAX_BYTES <= GP_PSE_MAX_STATE_BYTES, "every codec's state fits the state buffers");
_Static_assert(BNN_QUANT_MAX_BYTES <= GP_PSE_MAX_STATE_BYTES, "an int8 state fits the state buffers");
_Static_assert(BNN_QUANT4_MAX_BYTES <= GP_PSE_MAX_STATE_BYTES, "a 4-bit state fits the state buffers");
_Static_assert(BNN_N_PARAMS * sizeof(float) <= GP_PSE_MAX_STATE_BYTES, "a decoded state fits the state buffers");
_Static_assert(GP_PSE_ENCODINGS == DINNO_CODEC_COUNT, "the protocol takes every codec, and no other");
_Static_assert(GP_PSE_MAX_CHUNK_BYTES + GP_WIRE_CHUNK_HEADER_BYTES <= HAL_NET_MTU_BYTES,
               "a chunk and its header fit one datagram");
_Static_assert(GP_WIRE_REQUEST_BYTES(GP_PSE_MAX_REQUEST) <= HAL_NET_MTU_BYTES, "a request fits one datagram");

static const char *const channel_suffix[GP_FLEET_CHANNELS] = {"state", "done", "request", "claim", "resend", "ask"};

gp_fleet_cfg_t gp_fleet_default_cfg(void)
{
    gp_fleet_cfg_t c;
    memset(&c, 0, sizeof c);
    c.n_peers = 1;
    c.rounds = 1;
    c.encoding = GP_FLEET_ENCODING_DEFAULT;
    c.chunk_bytes = GP_FLEET_CHUNK_BYTES_DEFAULT;
    c.resend_after_us = GP_FLEET_RESEND_AFTER_US_DEFAULT;
    c.peer_timeout_us = GP_FLEET_PEER_TIMEOUT_US_DEFAULT;
    c.join_timeout_us = GP_FLEET_JOIN_TIMEOUT_US_DEFAULT;
    c.poll_us = GP_FLEET_POLL_US_DEFAULT;
    return c;
}

int gp_fleet_channel_name(uint32_t fleet_id, gp_fleet_channel_t which, char *buf, size_t cap)
{
    if (buf == NULL || (unsigned)which > GP_FLEET_CH_CLAIM)
        return -EINVAL;
    int n = snprintf(buf, cap, "%s%" PRIu32 "/%s", GP_FLEET_CHANNEL_PREFIX, fleet_id, channel_suffix[which]);
    return n > 0 && (size_t)n < cap && hal_net_channel_valid(buf) ? 0 : -EINVAL;
}

int gp_fleet_robot_channel(uint32_t fleet_id, gp_fleet_channel_t which, uint32_t robot, char *buf, size_t cap)
{
    if (buf == NULL || (which != GP_FLEET_CH_RESEND && which != GP_FLEET_CH_ASK))
        return -EINVAL;
    int n = snprintf(buf, cap, "%s%" PRIu32 "/%s/%" PRIu32, GP_FLEET_CHANNEL_PREFIX, fleet_id, channel_suffix[which],
                     robot);
    return n > 0 && (size_t)n < cap && hal_net_channel_valid(buf) ? 0 : -EINVAL;
}

int gp_fleet_channel_of(const gp_fleet_cfg_t *cfg, gp_fleet_channel_t which, char *buf, size_t cap)
{
    if (cfg == NULL)
        return -EINVAL;
    if ((which == GP_FLEET_CH_CLAIM && !cfg->claims) ||
        ((which == GP_FLEET_CH_RESEND || which == GP_FLEET_CH_ASK) && !cfg->addressed))
        return -ENOENT;
    return which == GP_FLEET_CH_RESEND || which == GP_FLEET_CH_ASK
               ? gp_fleet_robot_channel(cfg->fleet_id, which, cfg->self, buf, cap)
               : gp_fleet_channel_name(cfg->fleet_id, which, buf, cap);
}

uint32_t gp_fleet_state_bytes(dinno_codec_t enc)
{
    const bnn_config_t c = bnn_default_config();
    return (uint32_t)dinno_codec_bytes(&c, enc);
}

static void update_senders(gp_fleet_t *f);

/* ---- sending: the protocol's callback ---------------------------------------------------- */
/* Our claim of the round, ahead of every message that may be the first to place us in it: chunk 0
   of our state (sent or sent again) and our positioned beacon. A peer cannot end the round
   before it placed us, and each sender's datagrams arrive in order on the transports here, so
   the claim is in every peer's inbox before its round ends, even a peer that started after
   the state first went out (gp_fleet_cfg_t.claims). A lost claim is the one case left. */
static void send_claim_before(gp_fleet_t *f, gp_pse_kind_t kind, const void *msg)
{
    if (!f->claim_out_held)
        return;
    uint32_t round;
    if (kind == GP_PSE_CHUNK && ((const gp_pse_chunk_t *)msg)->chunk == 0)
        round = ((const gp_pse_chunk_t *)msg)->round;
    else if (kind == GP_PSE_REQUEST && ((const gp_pse_request_t *)msg)->has_position)
        round = ((const gp_pse_request_t *)msg)->round;
    else
        return;
    if (round != f->claim_out.seq)
        return;
    uint8_t buf[GP_WIRE_CLAIM_BYTES];
    const int n = gp_wire_encode_claim(&f->claim_out, buf, sizeof buf);
    if (n < 0 || hal_net_publish(f->channel[GP_FLEET_CH_CLAIM], buf, (size_t)n) != 0)
        f->stats.tx_failed++;
    else
        f->stats.claims_sent++;
}

static int fleet_send(void *ctx, gp_pse_kind_t kind, const void *msg)
{
    gp_fleet_t *f = ctx;
    int n;
    const char *ch;
    uint32_t to = GP_PSE_TO_ALL;
    send_claim_before(f, kind, msg);
    switch (kind) {
    case GP_PSE_CHUNK:
        n = gp_wire_encode_chunk(msg, f->tx, sizeof f->tx);
        ch = f->channel[GP_FLEET_CH_STATE];
        to = ((const gp_pse_chunk_t *)msg)->to;
        break;
    case GP_PSE_DONE:
        n = gp_wire_encode_done(msg, f->tx, sizeof f->tx);
        ch = f->channel[GP_FLEET_CH_DONE];
        break;
    case GP_PSE_REQUEST:
        n = gp_wire_encode_request(msg, f->tx, sizeof f->tx);
        ch = f->channel[GP_FLEET_CH_REQUEST];
        to = ((const gp_pse_request_t *)msg)->to;
        break;
    default:
        return -EINVAL;
    }
    if (to != GP_PSE_TO_ALL) { /* for one robot alone: on its own channel of the kind */
        if (gp_fleet_robot_channel(f->cfg.fleet_id, kind == GP_PSE_CHUNK ? GP_FLEET_CH_RESEND : GP_FLEET_CH_ASK, to,
                                   f->channel_to, sizeof f->channel_to) != 0)
            return -EINVAL;
        ch = f->channel_to;
    }
    if (n < 0)
        return n;
    int r = hal_net_publish(ch, f->tx, (size_t)n);
    if (r != 0)
        f->stats.tx_failed++;
    return r;
}

int gp_fleet_init(gp_fleet_t *f, const gp_fleet_cfg_t *cfg)
{
    if (f == NULL || cfg == NULL || cfg->rounds < 1 || (unsigned)cfg->encoding >= DINNO_CODEC_COUNT ||
        cfg->post_rounds > UINT32_MAX - cfg->rounds || (cfg->post_rounds > 0 && cfg->encoding != DINNO_CODEC_FP32) ||
        cfg->poll_us == 0 || (cfg->positions_from_tour &&
                              (cfg->tour == NULL || cfg->n_tour < 1 || cfg->n_tour > (int32_t)GP_FLEET_MAX_TOUR)))
        return -EINVAL;
    memset(&f->cfg, 0, sizeof f->cfg);
    f->cfg = *cfg;
    f->bnn = bnn_default_config();
    f->state_bytes = gp_fleet_state_bytes(cfg->encoding);
    memset(&f->stats, 0, sizeof f->stats);
    f->final_done = 0;
    f->view_filled = 0;
    f->senders_all = 1; /* hal_net's default */
    f->senders_off = 0;
    f->have_cur = 0;
    atomic_store(&f->n_log, 0u);
    if (cfg->positions_from_tour) {
        memcpy(f->tour, cfg->tour, sizeof(rt_waypoint_t) * (size_t)cfg->n_tour);
        f->cfg.tour = f->tour;
    } else {
        f->cfg.tour = NULL;
        f->cfg.n_tour = 0;
    }
    gp_pse_cfg_t pc = {
        .self = cfg->self,
        .n_peers = cfg->n_peers,
        .state_bytes = f->state_bytes,
        .chunk_bytes = cfg->chunk_bytes ? cfg->chunk_bytes : GP_PSE_MAX_CHUNK_BYTES,
        .radius_m = cfg->radius_m > 0.0 ? cfg->radius_m : 0.0,
        .resend_after_us = cfg->resend_after_us,
        .peer_timeout_us = cfg->peer_timeout_us,
        .join_timeout_us = cfg->join_timeout_us,
        .send = fleet_send,
        .send_ctx = f,
        .encoding = (uint8_t)cfg->encoding,
        .incarnation = cfg->incarnation,
        .burst = GP_FLEET_SEND_BURST,
        .addressed = cfg->addressed != 0,
        .ordered = cfg->ordered != 0,
        .same_position_from = cfg->post_rounds > 0 ? cfg->rounds : 0u, /* begin(): the posterior rounds */
    };
    int r = gp_round_init(&f->drv, &pc, cfg->rounds + cfg->post_rounds);
    if (r != 0)
        return r;
    memset(&f->mark, 0, sizeof f->mark);
    memset(f->claim_in, 0, sizeof f->claim_in);
    f->claim_out_held = 0;
    f->claims_handed_any = 0;
    f->claims_handed_upto = 0;
    for (int c = 0; c < GP_FLEET_CHANNELS; c++) {
        r = gp_fleet_channel_of(cfg, (gp_fleet_channel_t)c, f->channel[c], sizeof f->channel[c]);
        if (r == -ENOENT) {
            f->channel[c][0] = '\0'; /* names no channel: nothing received matches it */
            continue;
        }
        if (r != 0 || (r = hal_net_subscribe(f->channel[c])) != 0)
            return r;
    }
    update_senders(f); /* an addressed fleet takes no chunk before it placed the sender */
    return 0;
}

/* ---- receiving ---------------------------------------------------------------------------- */
static uint64_t net_now(void)
{
    uint64_t t = 0;
    return hal_net_clock_us(&t) == 0 ? t : 0;
}

/* Messages taken per drain: between two batches the protocol polls, so a robot fed faster than
   it reads still sends its beacons and requests (a drain that ran until the queue was empty
   could go on as long as the peers kept sending, silent meanwhile, and be timed out). */
#define GP_FLEET_DRAIN_BATCH 64u

/* A peer's claim, kept until our round reaches its seq (gp_fleet_cfg_t.claims, gp_goal_inbox_t);
   gp_goal_on_claim checks the rest when it is handed over. */
static void take_claim(gp_fleet_t *f, size_t len)
{
    gp_goal_claim_t c;
    if (gp_wire_decode_claim(f->rx, len, &c) != 0 || c.sender >= f->cfg.n_peers) {
        f->stats.rx_undecodable++;
        return;
    }
    if (c.sender == f->cfg.self) {
        f->stats.own_echoes++;
        return;
    }
    f->stats.claims_received++;
    if (f->claims_handed_any && c.seq <= f->claims_handed_upto)
        return; /* a copy of one handed over already (sent again for a late peer) */
    gp_goal_inbox_put(&f->claim_in[c.sender], &c);
}

/* Hands up to GP_FLEET_DRAIN_BATCH queued messages to the protocol; returns how many it took. */
static uint32_t drain(gp_fleet_t *f)
{
    hal_net_rx_info_t info;
    for (uint32_t taken = 0;; taken++) {
        if (taken == GP_FLEET_DRAIN_BATCH)
            return taken;
        int r = hal_net_receive(&info, f->rx, sizeof f->rx);
        if (r == -EAGAIN || r == -ENODEV || r == -EINVAL)
            return taken;
        if (r != 0) {
            f->stats.rx_undecodable++;
            continue;
        }
        f->stats.rx_messages++;
        const uint64_t now = net_now();
        if (strcmp(info.channel, f->channel[GP_FLEET_CH_STATE]) == 0 ||
            (f->cfg.addressed && strcmp(info.channel, f->channel[GP_FLEET_CH_RESEND]) == 0)) {
            gp_pse_chunk_t c;
            if (gp_wire_decode_chunk(f->rx, info.len, &c) != 0)
                f->stats.rx_undecodable++;
            else if (c.sender == f->cfg.self)
                f->stats.own_echoes++;
            else
                (void)gp_pse_on_chunk(&f->drv.pse, &c, now);
        } else if (strcmp(info.channel, f->channel[GP_FLEET_CH_DONE]) == 0) {
            gp_pse_done_t d;
            if (gp_wire_decode_done(f->rx, info.len, &d) != 0)
                f->stats.rx_undecodable++;
            else if (d.sender == f->cfg.self)
                f->stats.own_echoes++;
            else
                (void)gp_pse_on_done(&f->drv.pse, &d, now);
        } else if (strcmp(info.channel, f->channel[GP_FLEET_CH_REQUEST]) == 0 ||
                   (f->cfg.addressed && strcmp(info.channel, f->channel[GP_FLEET_CH_ASK]) == 0)) {
            gp_pse_request_t q;
            if (gp_wire_decode_request(f->rx, info.len, &q) != 0)
                f->stats.rx_undecodable++;
            else if (q.requester == f->cfg.self)
                f->stats.own_echoes++;
            else /* a request to another peer still tells where its sender is */
                (void)gp_pse_on_request(&f->drv.pse, &q, now);
        } else if (f->cfg.claims && strcmp(info.channel, f->channel[GP_FLEET_CH_CLAIM]) == 0) {
            take_claim(f, info.len);
        } else {
            f->stats.rx_undecodable++;
        }
    }
}

/* Tells the network whose chunks we may keep (gp_pse_wanted), when that changed: the other
   peers' chunks are then dropped on arrival, before they cost a tag check, a copy or a slot of
   the queue. A board that cannot filter delivers everything, as before. */
static void update_senders(gp_fleet_t *f)
{
    if (f->senders_off)
        return;
    uint8_t bits[GP_PSE_WANTED_BYTES];
    const uint32_t n = gp_pse_wanted(&f->drv.pse, bits);
    const int all = n + 1u >= f->cfg.n_peers;
    if (all ? f->senders_all : !f->senders_all && memcmp(bits, f->senders, sizeof bits) == 0)
        return;
    const int r = hal_net_set_senders(f->channel[GP_FLEET_CH_STATE], all ? NULL : bits, f->cfg.n_peers);
    if (r == -ENOTSUP) {
        f->senders_off = 1;
        return;
    }
    if (r != 0)
        return; /* tried again at the next change */
    f->senders_all = all;
    memcpy(f->senders, bits, sizeof bits);
    f->stats.senders_set++;
}

/* The longest single wait for a message: poll_us while our state goes out, else the protocol's
 * idle bound when that is longer. A 64-robot fleet's robots used to wake every 2 ms while
 * they waited for their peers, with nothing to do: up to 32,000 wake-ups a second on 2 cores
 * (docs/scaling.md). */
static uint32_t wait_us(const gp_fleet_t *f)
{
    const uint64_t idle = gp_pse_idle_us(&f->drv.pse);
    return idle <= f->cfg.poll_us ? f->cfg.poll_us : idle < UINT32_MAX ? (uint32_t)idle : UINT32_MAX;
}

/* Receives and steps the driver until it has something to say. The protocol's timeouts end
 * every wait; a board without hal_net_wait gets -EAGAIN (the GP core asks again next tick). */
static int next_event(gp_fleet_t *f, gp_round_event_t *ev)
{
    const uint64_t t0 = net_now();
    int rc = 0;
    for (;;) {
        (void)drain(f);
        *ev = gp_round_step(&f->drv, net_now());
        update_senders(f);
        if (*ev != GP_ROUND_WAIT)
            break;
        int r = hal_net_wait(wait_us(f));
        if (r != 0 && r != -EAGAIN) {
            rc = -EAGAIN; /* cannot block here: come back next tick */
            break;
        }
    }
    const uint64_t waited = net_now() - t0;
    f->stats.wait_us += waited;
    f->cur.wait_us += waited;
    return rc;
}

/* ---- the round log ------------------------------------------------------------------------ */
#define DELTA(field) (s->field - f->mark.field)

/* Closes the record of the round in progress with the traffic since it began. */
static void close_record(gp_fleet_t *f)
{
    if (!f->have_cur)
        return;
    const gp_pse_stats_t *s = &f->drv.pse.stats;
    gp_fleet_round_t *r = &f->cur;
    r->bytes_sent = DELTA(bytes_sent);
    r->bytes_received = DELTA(bytes_received);
    r->chunks_sent = DELTA(chunks_sent);
    r->chunks_received = DELTA(chunks_received);
    r->chunks_resent = DELTA(chunks_resent);
    r->chunks_requested = DELTA(chunks_requested);
    r->duplicates = DELTA(duplicates);
    r->stale = DELTA(stale);
    r->timeouts = DELTA(timeouts);
    r->rejoins = DELTA(rejoins);
    r->crc_failures = DELTA(crc_failures);
    r->invalid = DELTA(invalid);
    r->chunks_recovered = DELTA(chunks_recovered);
    r->states_missed = DELTA(states_missed);
    r->chunks_lost = DELTA(chunks_lost);
    r->rounds_skipped = DELTA(rounds_skipped);
    r->beacons_sent = DELTA(beacons_sent);
    r->restarts = DELTA(restarts);
    r->old_incarnation = DELTA(old_incarnation);
    r->wall_us = net_now() - f->cur_started_us;
    const uint32_t n = atomic_load_explicit(&f->n_log, memory_order_relaxed);
    f->log[n % GP_FLEET_LOG_ROUNDS] = *r;
    atomic_store_explicit(&f->n_log, n + 1u, memory_order_release);
    f->have_cur = 0;
}
#undef DELTA

uint32_t gp_fleet_rounds_logged(gp_fleet_t *f)
{
    return atomic_load_explicit(&f->n_log, memory_order_acquire);
}

const gp_fleet_round_t *gp_fleet_round(gp_fleet_t *f, uint32_t i)
{
    const uint32_t n = gp_fleet_rounds_logged(f);
    return i < n && n - i <= GP_FLEET_LOG_ROUNDS ? &f->log[i % GP_FLEET_LOG_ROUNDS] : NULL;
}

/* ---- the hooks ---------------------------------------------------------------------------- */
/* Our state in the fleet's codec (for the -ef codecs the AI core hands us a difference vector:
   the same to us). */
static int encode_state(gp_fleet_t *f, const float *theta, uint32_t n_params)
{
    if (n_params != BNN_N_PARAMS)
        return -EINVAL;
    size_t written = 0;
    int r = dinno_codec_encode(&f->bnn, f->cfg.encoding, theta, f->mine, sizeof f->mine, &written);
    return r != 0 ? r : (written == f->state_bytes ? 0 : -EINVAL);
}

/* A neighbour's state of the round, in its reassembly buffer (handed out by gp_pse_neighbours,
   so ours until the next round begins): fp32 is read where it arrived, the quantised codecs
   are expanded there once, in place (the buffer holds a whole fp32 state; the row scales go to
   f->qscales). A whole fp32 state in the buffer or none: -EBADMSG for a non-finite fp32
   element or a bad scale (dinno_codec_decode_inplace checks before anything moves). */
static int decode_state(gp_fleet_t *f, const uint8_t *bytes, const float **theta)
{
    float *words = (float *)(uintptr_t)bytes; /* gp_pse_buf_t.words: the same storage */
    int r = dinno_codec_decode_inplace(&f->bnn, f->cfg.encoding, words, f->state_bytes, f->qscales,
                                       BNN_QUANT_MAX_ROWS);
    if (r != 0)
        return r;
    *theta = words;
    return 0;
}

/* ||theta - mean of the neighbours|| / ||mean||: how far this robot is from its neighbours. */
/* Parameters per block of the neighbours' mean: 1 KB of the GP core's stack. */
#define GP_FLEET_MEAN_BLOCK 128u

static float disagreement(const float *theta, const dinno_nbrs_t *nbrs)
{
    const uint32_t n = nbrs->count;
    if (n == 0)
        return NAN;
    /* A block of means at a time, neighbour by neighbour (a pass the compiler vectorises):
       each mean still sums its neighbours in ascending id, and num and den still run over the
       parameters in order, so the figure is the same to the bit. */
    double num = 0.0, den = 0.0, m[GP_FLEET_MEAN_BLOCK];
    for (uint32_t p0 = 0; p0 < BNN_N_PARAMS; p0 += GP_FLEET_MEAN_BLOCK) {
        const uint32_t len = BNN_N_PARAMS - p0 < GP_FLEET_MEAN_BLOCK ? BNN_N_PARAMS - p0 : GP_FLEET_MEAN_BLOCK;
        for (uint32_t i = 0; i < len; i++)
            m[i] = 0.0;
        for (uint32_t j = 0; j < n; j++) {
            const float *t = nbrs->theta[j] + p0;
            for (uint32_t i = 0; i < len; i++)
                m[i] += t[i];
        }
        for (uint32_t i = 0; i < len; i++) {
            const double mean = m[i] / (double)n;
            const double d = (double)theta[p0 + i] - mean;
            num += d * d;
            den += mean * mean;
        }
    }
    return den > 0.0 ? (float)sqrt(num / den) : 0.0f;
}

/* Round k's neighbour states are all there: points the view at them, in ascending robot id
   (the order the in-process fleet uses, so DiNNO's sums run in the same order), decoded once
   and not copied. A state that does not decode is left out and counted, as before. Returns
   the number of neighbours. */
static int fill_slots(gp_fleet_t *f, uint32_t round, const float *own_theta, dinno_nbrs_t *out)
{
    /* Asked again for the round whose view was filled (the GP core could not publish ready
       and comes back): the view still points at the same states, and a quantised state must
       not be expanded twice. */
    if (f->view_filled && out->round == round)
        return (int)out->count;
    uint32_t ids[GP_PSE_MAX_NEIGHBOURS];
    const uint8_t *states[GP_PSE_MAX_NEIGHBOURS];
    const uint32_t n = gp_pse_neighbours(&f->drv.pse, ids, states);
    uint32_t k = 0;
    for (uint32_t j = 0; j < n && k < DINNO_MAX_PEERS; j++) {
        if (decode_state(f, states[j], &out->theta[k]) != 0) {
            f->stats.decode_failures++;
            continue;
        }
        out->id[k] = ids[j];
        out->inc[k] = gp_pse_peer_incarnation(&f->drv.pse, ids[j]);
        k++;
    }
    out->round = round;
    out->count = k;
    f->cur.neighbours = k;
    /* posteriors have none; nor do the EF codecs, whose views hold differences (the AI core
       turns them into the neighbours' public copies) */
    f->cur.disagreement = round < f->cfg.rounds && !dinno_codec_is_ef(f->cfg.encoding) ? disagreement(own_theta, out)
                                                                                        : NAN;
    f->view_filled = 1;
    return (int)k;
}

/* Our position of `round` when the round alone says it: 1 and *x, *y; 0 when it is where the
   RT core has us then (the AI core's request says); -EINVAL for a tour that has none. */
static int scheduled_position(const gp_fleet_t *f, uint32_t round, double *x, double *y)
{
    if (round >= f->cfg.rounds) {
        /* a posterior round: every robot gives the same position, so that the disk graph is the
           whole fleet (the nearest GP_PSE_MAX_NEIGHBOURS by id) and one round of the 1/N
           average reaches the fleet's sum (ai_core.h) */
        *x = *y = 0.0;
        return 1;
    }
    if (!f->cfg.positions_from_tour)
        return 0;
    return rt_path_point_frac(f->tour, f->cfg.n_tour, round, f->cfg.rounds, x, y) != 0 ? -EINVAL : 1;
}

/* Round k began for us: a new record, our state encoded (our buffer of round k - 1 is free now,
   the driver said so) and sent with our position of round k. */
static int begin(gp_fleet_t *f, const gp_exchange_req_t *req)
{
    close_record(f);
    int r = encode_state(f, req->theta, req->n_params);
    if (r != 0)
        return r;
    double x = req->x_m, y = req->y_m;
    if (scheduled_position(f, req->round, &x, &y) < 0)
        return -EINVAL;
    f->mark = f->drv.pse.stats;
    memset(&f->cur, 0, sizeof f->cur);
    f->cur.round = req->round;
    f->cur.disagreement = NAN;
    f->cur_started_us = net_now();
    f->have_cur = 1;
    f->view_filled = 0;
    /* our claim of the round as it stands now, sent ahead of the state (send_claim_before) */
    f->claim_out_held = f->cfg.claims && req->claim != NULL && req->claim->seq == req->round;
    if (f->claim_out_held)
        f->claim_out = *req->claim;
    return gp_round_begin(&f->drv, f->mine, x, y, net_now());
}

static int fleet_exchange(void *ctx, const gp_exchange_req_t *req, dinno_nbrs_t *slots)
{
    gp_fleet_t *f = ctx;
    int r = gp_round_want(&f->drv, req->round, net_now());
    if (r != 0)
        return r;
    for (gp_round_event_t ev;;) {
        if (next_event(f, &ev) != 0)
            return -EAGAIN;
        if (ev == GP_ROUND_READY)
            break;
        if (ev != GP_ROUND_BEGIN)
            return -EINVAL;
        if ((r = begin(f, req)) != 0)
            return r;
    }
    return fill_slots(f, req->round, req->theta, slots);
}

static void fleet_round_done(void *ctx, uint32_t round, int final)
{
    gp_fleet_t *f = ctx;
    /* Where we will be in round + 1, when the schedule says: our RoundComplete carries it, and
       round + 1 then opens without a beacon to everyone (gp_pse.h). */
    double next[2];
    const int known = !final && round < UINT32_MAX && scheduled_position(f, round + 1u, &next[0], &next[1]) == 1;
    if (gp_round_node_done(&f->drv, round, final, known ? next : NULL, net_now()) != 0 || !final)
        return;
    /* The last round: stay until the fleet no longer needs us (gp_round.h), within the
       protocol's timeouts. */
    gp_round_event_t ev;
    while (next_event(f, &ev) == 0 && ev != GP_ROUND_DONE) {
    }
    close_record(f);
    f->final_done = 1;
}

static uint32_t fleet_next_round(void *ctx, uint32_t round)
{
    gp_fleet_t *f = ctx;
    return gp_round_next_round(&f->drv, round, net_now());
}

static uint32_t fleet_claims(void *ctx, uint32_t round, gp_goal_claim_t *out, uint32_t max)
{
    gp_fleet_t *f = ctx;
    uint32_t n = 0;
    for (uint32_t p = 0; f->cfg.claims && p < f->cfg.n_peers && n < max; p++)
        n += (uint32_t)gp_goal_inbox_take(&f->claim_in[p], round, &out[n]);
    if (f->cfg.claims && (!f->claims_handed_any || round > f->claims_handed_upto)) {
        f->claims_handed_upto = round;
        f->claims_handed_any = 1;
    }
    f->stats.claims_handed += n;
    return n;
}

static void fleet_service(void *ctx)
{
    gp_fleet_t *f = ctx;
    while (drain(f) == GP_FLEET_DRAIN_BATCH)
        gp_pse_poll(&f->drv.pse, net_now());
    gp_pse_poll(&f->drv.pse, net_now());
    update_senders(f);
}

const gp_peers_ops_t gp_fleet_peers_ops = {
    .exchange = fleet_exchange,
    .round_done = fleet_round_done,
    .service = fleet_service,
    .next_round = fleet_next_round,
    .claims = fleet_claims,
};
