/* Peers state exchange: see gp_pse.h. The nearest peers of a round, their buffers and
   gp_pse_neighbours()/gp_pse_wanted() are in gp_pse_near.c; where the fleet is (a round over for
   everyone, the round to begin next) in gp_pse_where.c (both share gp_pse_internal.h). */
#include "gp/gp_pse.h"
#include "gp/gp_pse_internal.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "common/crc32.h"

_Static_assert(GP_PSE_MAX_CHUNK_BYTES >= GP_PSE_MIN_CHUNK_BYTES &&
                   GP_PSE_MAX_CHUNK_BYTES + GP_PSE_CHUNK_HEADER_ROOM <= BOARD_NET_MTU_BYTES,
               "a chunk and its header fit one datagram of the board");
_Static_assert(GP_PSE_MAX_CHUNKS <= 0xFFFFu, "chunk indices stay small");

static uint32_t chunk_len(const gp_pse_t *p, uint32_t chunk)
{
    const uint32_t off = chunk * p->cfg.chunk_bytes;
    const uint32_t left = p->cfg.state_bytes - off;
    return left < p->cfg.chunk_bytes ? left : p->cfg.chunk_bytes;
}

/* sent_us is the last message every peer hears: a chunk is not one (a peer that does not keep
   our state has its network drop our chunks, gp_pse_wanted), nor is an addressed request, so a
   robot busy re-sending or asking still beacons every resend period, or the peers that do not
   get those would see it silent. */
static void send_msg(gp_pse_t *p, gp_pse_kind_t kind, const void *msg, uint64_t now_us)
{
    if (p->cfg.send(p->cfg.send_ctx, kind, msg) != 0)
        p->stats.send_failures++;
    if (kind == GP_PSE_DONE || (kind == GP_PSE_REQUEST && ((const gp_pse_request_t *)msg)->to == GP_PSE_TO_ALL))
        p->sent_us = now_us;
}

/* Who a message that is for peer `peer` alone (a request naming its chunks, a chunk it asked
   for) goes to: that peer in an addressed fleet, else everyone. */
static uint32_t to_peer(const gp_pse_t *p, uint32_t peer)
{
    return p->cfg.addressed ? peer : GP_PSE_TO_ALL;
}

/* Chunk `chunk` of our state to `to` (GP_PSE_TO_ALL: every peer). */
static void send_chunk(gp_pse_t *p, uint32_t chunk, uint32_t to, uint64_t now_us)
{
    const uint32_t n = chunk_len(p, chunk);
    const gp_pse_chunk_t c = {p->cfg.self, p->round, chunk, p->n_chunks, p->cfg.state_bytes, p->my_crc32,
                              p->x_m, p->y_m, n, p->mine + (size_t)chunk * p->cfg.chunk_bytes,
                              p->cfg.encoding, p->cfg.incarnation, to};
    send_msg(p, GP_PSE_CHUNK, &c, now_us);
    p->stats.chunks_sent++;
    p->stats.bytes_sent += n;
}

static void send_done(gp_pse_t *p, uint64_t now_us)
{
    gp_pse_done_t d = {p->cfg.self, p->round, p->cfg.incarnation, 0, 0.0, 0.0};
    if (p->next_known) {
        d.has_next_position = 1;
        d.next_x_m = p->next_x_m;
        d.next_y_m = p->next_y_m;
    }
    send_msg(p, GP_PSE_DONE, &d, now_us);
    p->done_sent_us = now_us;
}

int gp_pse_init(gp_pse_t *p, const gp_pse_cfg_t *c)
{
    if (p == NULL || c == NULL || c->send == NULL || c->n_peers < 1 || c->n_peers > GP_PSE_MAX_FLEET ||
        c->self >= c->n_peers || c->state_bytes < 1 || c->state_bytes > GP_PSE_MAX_STATE_BYTES ||
        c->chunk_bytes < GP_PSE_MIN_CHUNK_BYTES || c->chunk_bytes > GP_PSE_MAX_CHUNK_BYTES ||
        !isfinite(c->radius_m) || c->resend_after_us == 0 || c->peer_timeout_us <= c->resend_after_us ||
        (c->join_timeout_us != 0 && c->join_timeout_us < c->peer_timeout_us) ||
        c->encoding >= GP_PSE_ENCODINGS || c->addressed > 1u || c->ordered > 1u)
        return -EINVAL;
    memset(&p->stats, 0, sizeof p->stats);
    p->cfg = *c;
    p->n_chunks = (c->state_bytes + c->chunk_bytes - 1u) / c->chunk_bytes;
    p->round = 0;
    p->in_round = p->completed = p->later_heard = p->ready_noted = p->leaving = p->taken = 0;
    p->leave_said = 0;
    p->sent_us = p->pos_sent_us = p->polled_us = p->newcomer_us = 0;
    p->mine = NULL;
    p->x_m = p->y_m = 0.0;
    p->next_known = 0;
    p->next_x_m = p->next_y_m = 0.0;
    memset(p->near, 0, sizeof p->near);
    for (uint32_t par = 0; par < 2u; par++)
        for (uint32_t s = 0; s < GP_PSE_MAX_NEIGHBOURS; s++)
            p->pool[par][s].used = 0;
    memset(p->peer, 0, sizeof(gp_pse_peer_t) * c->n_peers);
    for (uint32_t i = 0; i < c->n_peers; i++)
        p->peer[i].buf[0] = p->peer[i].buf[1] = GP_PSE_NO_BUF;
    return 0;
}

/* How often to repeat what every member hears, `base_us` in a fleet of GP_PSE_CHATTY_FLEET or
   fewer (gp_pse.h). With 64 processes on one core every robot used to receive about 18,000 small
   datagrams a round, most of them RoundCompletes repeated while the fleet waited for its slowest
   member: the CPU that cost is what made the slowest member slow. */
static uint64_t repeat_every(const gp_pse_t *p, uint64_t base_us)
{
    const uint32_t n = p->cfg.n_peers;
    if (n <= GP_PSE_CHATTY_FLEET)
        return base_us;
    const uint64_t every = base_us * n / GP_PSE_CHATTY_FLEET, most = p->cfg.peer_timeout_us / 4u;
    return every < most ? every : base_us > most ? base_us : most;
}

/* The beacon period: how often a robot says which round it is in (and where) when it has
   nothing else to send, so a peer silent this long in a round was not only between beacons. */
static uint64_t beacon_period(const gp_pse_t *p)
{
    return repeat_every(p, p->cfg.resend_after_us);
}

/* The wait before asking for what a state misses: one resend period, doubled per request that
   brought nothing. On an ordered link (cfg.ordered) the first wait is two of the sender's beacon
   periods instead: its chunks may only be queued behind a busy CPU, and whatever it says to
   everyone next (its RoundComplete, or a beacon, at most a beacon period later) comes after
   them, so what is still missing then is lost and asked for at once (sender_state_sent). Over
   ZeroMQ a 128-robot fleet's timer asks were half of them for chunks still on their way.
   Later waits double up to GP_PSE_BACKOFF_MAX periods, GP_PSE_BACKOFF_MAX_ORDERED there. */
uint64_t gp_pse_ask_after(const gp_pse_t *p, uint32_t backoff)
{
    if (backoff == 0 && p->cfg.ordered) {
        const uint64_t word = 2u * beacon_period(p);
        return word > p->cfg.resend_after_us ? word : p->cfg.resend_after_us;
    }
    const uint32_t most = p->cfg.ordered ? GP_PSE_BACKOFF_MAX_ORDERED : GP_PSE_BACKOFF_MAX;
    return p->cfg.resend_after_us << (backoff < most ? backoff : most);
}

static int state_complete(const gp_pse_t *p, uint32_t i, uint32_t round)
{
    const gp_pse_buf_t *b = gp_pse_cbuf_of(p, i, round);
    return b != NULL && b->complete;
}


/* Our next `burst` chunks (all of them without a burst). */
static void send_window(gp_pse_t *p, uint64_t now_us)
{
    const uint32_t end = p->cfg.burst == 0 || p->n_chunks - p->next_send < p->cfg.burst ? p->n_chunks
                                                                                        : p->next_send + p->cfg.burst;
    for (; p->next_send < end; p->next_send++)
        send_chunk(p, p->next_send, GP_PSE_TO_ALL, now_us);
}

/* "I am in round `round`", with our position when it is the round we are in. */
static void send_beacon(gp_pse_t *p, uint32_t round, uint64_t now_us)
{
    gp_pse_request_t beacon = {p->cfg.self, p->cfg.self, round, 0, {0}, p->cfg.incarnation, 0, 0.0, 0.0, GP_PSE_TO_ALL};
    if (p->in_round && round == p->round) {
        beacon.has_position = 1;
        beacon.x_m = p->x_m;
        beacon.y_m = p->y_m;
        p->pos_sent_us = now_us | 1u;
    }
    send_msg(p, GP_PSE_REQUEST, &beacon, now_us);
    p->stats.beacons_sent++;
}

/* A round where every member gives the same position (cfg.same_position_from): peer i is where
   we are, known without a word from it. Its own word, when it comes, says the same (or counts
   as invalid, gp_pse_note_position). */
static void place_at_ours(gp_pse_t *p, uint32_t i, uint32_t round)
{
    gp_pse_peer_t *q = &p->peer[i];
    if (i == p->cfg.self || p->cfg.same_position_from == 0 || round < p->cfg.same_position_from ||
        gp_pse_pos_known(q, round))
        return;
    gp_pse_set_position(q, round & 1u, round, p->x_m, p->y_m);
}

/* Peer i's RoundComplete said where it is in `round` and came while we were two rounds behind
   (busy: 64 robots on 2 cores), when it could not be placed yet: placed now, without a word.
   Else it would wait a beacon period to be placed, its own beacon not sent (gp_pse_complete). */
static void place_announced(gp_pse_t *p, uint32_t i, uint32_t round)
{
    gp_pse_peer_t *q = &p->peer[i];
    if (i == p->cfg.self || !q->has_ahead || q->ahead_round != round || gp_pse_pos_known(q, round))
        return;
    gp_pse_set_position(q, round & 1u, round, q->ahead_x_m, q->ahead_y_m);
    p->stats.placed_ahead++;
}

int gp_pse_begin_round(gp_pse_t *p, uint32_t round, const uint8_t *state, double x_m, double y_m, uint64_t now_us)
{
    if (p == NULL || state == NULL || !isfinite(x_m) || !isfinite(y_m) || (p->in_round && round <= p->round))
        return -EINVAL;
    if (p->in_round && round > p->round + 1u)
        p->stats.rounds_skipped += round - p->round - 1u;
    /* Our RoundComplete of the round before said where we are in this one: every peer that
       heard it placed us already. */
    const int announced = p->in_round && p->next_known && round == p->round + 1u && p->next_x_m == x_m &&
                          p->next_y_m == y_m;
    p->next_known = 0;
    p->round = round;
    p->in_round = 1;
    p->completed = 0;
    p->later_heard = 0;
    p->ready_noted = 0;
    p->taken = 0; /* round k-1's buffers are free again (gp_pse.h, the handed-out buffers) */
    p->round_start_us = now_us;
    p->mine = state;
    p->my_crc32 = crc32_ieee(state, p->cfg.state_bytes);
    p->x_m = x_m;
    p->y_m = y_m;
    memset(p->resent_at, 0, sizeof p->resent_at);
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        place_at_ours(p, i, round);
        place_announced(p, i, round);
    }
    /* Chunks of this round that came early were ranked against our previous position. */
    gp_pse_near_rank(p, round, now_us);
    for (uint32_t m = 0; m < p->near[round & 1u].n; m++) {
        gp_pse_buf_t *b = gp_pse_buf_of(p, p->near[round & 1u].id[m], round);
        if (b->got > 0) /* its chunks are coming: ask a resend period from now */
            b->progress_us = now_us;
    }
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        if (i == p->cfg.self)
            continue;
        gp_pse_peer_t *q = &p->peer[i];
        q->pos_backoff = 0;
        /* A peer that left comes back only here, at a round boundary, and only when it was
           heard lately in the round before this one or later: it is on its way to this round.
           So a crashed peer costs one timeout, not one per round, and a peer that keeps
           failing cannot make the others wait again within a round. */
        if (q->absent && gp_pse_heard_within(p, q, now_us) && q->has_round && q->at_round + 1u >= round) {
            q->absent = 0;
            p->stats.rejoins++;
        }
        /* A peer already in a later round (its chunks or RoundComplete came first) says this
           round is over for the fleet: we take what we have. */
        if (q->has_round && q->at_round > round)
            p->later_heard = 1;
    }
    /* Where we are this round, first and in a few bytes: a peer that does not take our state
       (beyond its radius or its nearest, and told its network so) still needs our position.
       Not when our RoundComplete said it: a peer that missed every copy of that places us from
       our next beacon (a beacon period on) or asks, as it would a peer whose beacon was lost. */
    if (announced)
        p->stats.openings_announced++;
    else
        send_beacon(p, round, now_us);
    p->next_send = 0;
    send_window(p, now_us);
    return 0;
}

/* Forgets what we held of a peer that restarted: its buffers may hold chunks of a state its new
   incarnation will never finish, and its rounds start again where it resumed. */
static void peer_restarted(gp_pse_t *p, uint32_t i, uint64_t now_us)
{
    gp_pse_peer_t *q = &p->peer[i];
    q->has_round = q->has_done = 0;
    q->has_pos[0] = q->has_pos[1] = q->has_ahead = 0;
    if (p->in_round)
        place_at_ours(p, i, p->round);
    for (uint32_t par = 0; par < 2u; par++)
        if (p->near[par].valid && !(p->taken && p->near[par].round == p->round)) /* the next nearest takes its place */
            gp_pse_near_rank(p, p->near[par].round, now_us); /* (a handed-out round stays as it is) */
    p->stats.restarts++;
}

/* What a valid message of `round` from `sender` tells (see the liveness rule in gp_pse.h).
   `done`: a RoundComplete. -ESTALE for an earlier incarnation (dropped), else 0. */
static int note_sender(gp_pse_t *p, uint32_t sender, uint32_t incarnation, uint32_t round, int done, uint64_t now_us)
{
    gp_pse_peer_t *q = &p->peer[sender];
    if (q->has_inc && incarnation < q->incarnation) {
        p->stats.old_incarnation++;
        return -ESTALE;
    }
    if (q->has_inc && incarnation > q->incarnation)
        peer_restarted(p, sender, now_us);
    q->incarnation = incarnation;
    q->has_inc = 1;
    if (!q->has_round || round > q->at_round) {
        q->at_round = round;
        q->has_round = 1;
    }
    const uint32_t k = p->round;
    if (!p->in_round || round >= k || (done && round + 1u == k)) {
        if (q->heard) {
            /* The gaps between its signs of progress, smoothed as RFC 6298 smooths round-trip
               times (gains 1/8 and 1/4): how irregular this peer is, for its timeout. */
            const uint64_t gap = now_us - q->heard_us;
            const uint64_t dev = gap > q->gap_srtt_us ? gap - q->gap_srtt_us : q->gap_srtt_us - gap;
            q->gap_var_us = (3u * q->gap_var_us + dev) / 4u;
            q->gap_srtt_us = (7u * q->gap_srtt_us + gap) / 8u;
        }
        if (!q->heard)
            p->newcomer_us = now_us; /* the fleet is still forming: the join clock restarts */
        q->heard = 1;
        q->heard_us = now_us;
    }
    if (p->in_round && round > k)
        p->later_heard = 1;
    return 0;
}

/* The next poll asks for what b misses, unless it had some of it within a quarter resend
   period or asked already: a request that is out waits for its answer (or its backoff), and
   the signals that call this (a gap, a peer's RoundComplete, repeated every quarter period)
   must not turn into a request each. */
static void ask_soon(const gp_pse_t *p, gp_pse_buf_t *b, uint64_t now_us)
{
    const uint64_t quarter = p->cfg.resend_after_us / 4u;
    if (b->backoff == 0 && now_us - b->progress_us >= quarter)
        b->progress_us = now_us - gp_pse_ask_after(p, 0); /* unsigned: "a wait ago" also near 0 */
}

/* The sender of a RoundComplete or a beacon of our round has sent its whole state already:
   what we miss of it is lost, ask at once. */
static void sender_state_sent(gp_pse_t *p, uint32_t sender, uint32_t round, uint64_t now_us)
{
    if (!p->in_round || round != p->round)
        return;
    gp_pse_buf_t *b = gp_pse_buf_of(p, sender, round);
    if (b != NULL && !b->complete)
        ask_soon(p, b, now_us);
}

/* Round window of a stored message of `round`: 0 inside (k or k + 1), else the reason. */
static int window(gp_pse_t *p, uint32_t round)
{
    const uint32_t k = p->in_round ? p->round : 0u;
    if (round < k) {
        p->stats.stale++;
        return -ESTALE;
    }
    if (round > k + 1u) {
        p->stats.future++;
        return -EAGAIN;
    }
    return 0;
}

int gp_pse_on_chunk(gp_pse_t *p, const gp_pse_chunk_t *c, uint64_t now_us)
{
    if (c == NULL || c->sender >= p->cfg.n_peers || c->sender == p->cfg.self ||
        c->state_bytes != p->cfg.state_bytes || c->n_chunks != p->n_chunks || c->chunk >= p->n_chunks ||
        c->n_bytes != chunk_len(p, c->chunk) || c->data == NULL || !isfinite(c->x_m) || !isfinite(c->y_m) ||
        c->encoding != p->cfg.encoding) {
        p->stats.invalid++;
        return -EBADMSG;
    }
    int rc = note_sender(p, c->sender, c->incarnation, c->round, 0, now_us);
    if (rc == 0) {
        p->peer[c->sender].on_way = 0; /* it has begun c->round: see gp_pse_on_request */
        rc = window(p, c->round);
    }
    if (rc != 0)
        return rc;
    p->stats.chunks_received++;
    const uint32_t par = c->round & 1u;
    if (!p->near[par].valid || p->near[par].round != c->round)
        gp_pse_near_reset(p, c->round); /* the first of this round: the list of round - 2 is done */
    gp_pse_peer_t *q = &p->peer[c->sender];
    if (p->taken && c->round == p->round) {
        /* Round k's states were handed out (gp_pse.h): its buffers are the caller's until round
           k + 1 begins. The chunk still places its sender (no request for its position goes
           out), but neither ranks the round again nor reaches a buffer. */
        if (!gp_pse_pos_known(q, c->round))
            gp_pse_set_position(q, par, c->round, c->x_m, c->y_m);
        p->stats.after_taken++;
        return -EALREADY;
    }
    /* A position that disagrees with the round's earlier word starts its state over, as a CRC
       conflict below does. */
    const int moved = gp_pse_note_position(p, c->sender, c->round, c->x_m, c->y_m, now_us);
    gp_pse_buf_t *b = gp_pse_buf_of(p, c->sender, c->round);
    if (b == NULL) {
        p->stats.not_nearest++; /* beyond the radius or the nearest: its position was what we needed */
        return 0;
    }
    if (moved)
        gp_pse_buf_reset(b, c->round, p->n_chunks, now_us);
    if (b->complete) {
        p->stats.duplicates++;
        return -EALREADY;
    }
    if (b->got > 0 && b->crc32 != c->crc32) {
        /* Chunks of one state disagree (corruption, or bytes forged in an unkeyed fleet; a
           restart changes the incarnation). Which side is right is unknown until a state is
           whole and its CRC checks, so the first chunk must not decide: the newcomer starts the
           state over and what it displaced is asked for again. One forged chunk costs a
           request, never the round. */
        p->stats.invalid++;
        gp_pse_buf_reset(b, c->round, p->n_chunks, now_us);
    } else if (b->have[c->chunk] & GP_PSE_HAVE) {
        p->stats.duplicates++;
        return -EALREADY;
    }
    memcpy(b->bytes + (size_t)c->chunk * p->cfg.chunk_bytes, c->data, c->n_bytes);
    if (b->have[c->chunk] & GP_PSE_ASKED)
        p->stats.chunks_recovered++;
    b->have[c->chunk] = GP_PSE_HAVE;
    b->got++;
    b->crc32 = c->crc32;
    b->progress_us = now_us;
    b->backoff = 0;
    p->stats.bytes_received += c->n_bytes;
    /* Chunks go out in order: a gap below this one is most likely a loss, so the next poll
       asks for it at once instead of a resend period later (a fast retransmit). */
    for (uint32_t i = 0; i < c->chunk; i++)
        if (!(b->have[i] & GP_PSE_HAVE)) {
            ask_soon(p, b, now_us);
            break;
        }
    if (b->got == p->n_chunks) {
        if (crc32_ieee(b->bytes, p->cfg.state_bytes) != b->crc32) {
            p->stats.crc_failures++;
            gp_pse_buf_reset(b, c->round, p->n_chunks, now_us); /* every chunk is asked for again */
            return -EILSEQ;
        }
        b->complete = 1;
    }
    return 0;
}

int gp_pse_on_done(gp_pse_t *p, const gp_pse_done_t *d, uint64_t now_us)
{
    if (d == NULL || d->sender >= p->cfg.n_peers || d->sender == p->cfg.self || d->has_next_position > 1u ||
        (d->has_next_position &&
         (d->round == UINT32_MAX || !isfinite(d->next_x_m) || !isfinite(d->next_y_m)))) {
        p->stats.invalid++;
        return -EBADMSG;
    }
    if (note_sender(p, d->sender, d->incarnation, d->round, 1, now_us) != 0)
        return -ESTALE;
    p->peer[d->sender].on_way = 0;
    sender_state_sent(p, d->sender, d->round, now_us);
    gp_pse_peer_t *q = &p->peer[d->sender];
    if (!q->has_done || d->round > q->done_round) {
        q->done_round = d->round;
        q->has_done = 1;
    }
    /* Where it will be in the round after (gp_pse.h): placed there now, as its beacon opening
       that round would place it. */
    if (d->has_next_position && (!q->has_ahead || d->round + 1u >= q->ahead_round)) {
        q->has_ahead = 1;
        q->ahead_round = d->round + 1u;
        q->ahead_x_m = d->next_x_m;
        q->ahead_y_m = d->next_y_m;
        if (gp_pse_place(p, d->sender, d->round + 1u, d->next_x_m, d->next_y_m, now_us))
            p->stats.placed_ahead++;
    }
    if (p->in_round && d->round < p->round) {
        p->stats.stale++;
        return -ESTALE;
    }
    return 0; /* a round further ahead still tells where the peer is */
}

int gp_pse_on_request(gp_pse_t *p, const gp_pse_request_t *r, uint64_t now_us)
{
    if (r == NULL || r->requester >= p->cfg.n_peers || r->requester == p->cfg.self || r->target >= p->cfg.n_peers ||
        r->n > GP_PSE_MAX_REQUEST) {
        p->stats.invalid++;
        return -EBADMSG;
    }
    for (uint32_t i = 0; i < r->n; i++)
        if (r->chunks[i] >= p->n_chunks) {
            p->stats.invalid++;
            return -EBADMSG;
        }
    if (r->has_position > 1u || (r->has_position && (!isfinite(r->x_m) || !isfinite(r->y_m)))) {
        p->stats.invalid++;
        return -EBADMSG;
    }
    if (note_sender(p, r->requester, r->incarnation, r->round, 0, now_us) != 0)
        return -ESTALE;
    gp_pse_request_position(p, r, now_us);
    /* A beacon without a position: its sender has not begun that round (it is on its way to
       it, gp_pse_poll), whether we had begun it or not when it came. Its position comes with
       its first word of the round: no request for it while it keeps saying so. (Asking anyway
       was the storm of a 128-robot fleet whose robots start minutes apart: the robots in the
       round asked the peers still driving their tours, each up to once a second, and every
       robot was handed some 1,300 requests a second.) */
    p->peer[r->requester].on_way = r->n == 0 && !r->has_position;
    p->peer[r->requester].on_way_round = r->round;
    const int position_ask = r->n == 0 && r->target != r->requester;
    if (r->n == 0 && !position_ask)
        sender_state_sent(p, r->requester, r->round, now_us);
    /* Asked where we are: our positioned beacon (to everyone, as a beacon goes: the peers that
       asked meanwhile want the same), at most one per half resend period. A chunk would say it
       too, at the cost of a chunk to a peer that mostly keeps the states of others (256 robots
       asked each of their 255 peers three or four times in round 0, each answered by a 15 KB
       chunk for the asker alone: docs/scaling.md). */
    if (position_ask && r->target == p->cfg.self && p->in_round && r->round == p->round &&
        now_us - p->pos_sent_us >= p->cfg.resend_after_us / 2u)
        send_beacon(p, p->round, now_us);
    if (r->n == 0 || r->target != p->cfg.self)
        return 0; /* a beacon, a position ask, or a request to another peer: it told us where its sender is */
    if (!p->in_round || r->round != p->round) {
        p->stats.stale++;
        return -ESTALE; /* only the current round's state is kept */
    }
    /* Asked for chunk 0 (what a peer asks when it does not know where we are): our positioned
       beacon goes first, since a peer that does not take our state never sees the chunk. */
    if (r->chunks[0] == 0u && now_us - p->pos_sent_us >= p->cfg.resend_after_us / 2u)
        send_beacon(p, p->round, now_us);
    /* Multicast: a resend reaches every peer, so one per chunk per half resend period serves
       all the peers that asked for it meanwhile, instead of a storm of copies. Addressed: each
       requester gets its own (its requests are paced by its backoff), and nobody else one. */
    for (uint32_t i = 0; i < r->n; i++) {
        const uint32_t c = r->chunks[i];
        if (!p->cfg.addressed) {
            if (p->resent_at[c] != 0 && now_us - p->resent_at[c] < p->cfg.resend_after_us / 2u) {
                p->stats.resends_merged++;
                continue;
            }
            p->resent_at[c] = now_us | 1u;
        }
        send_chunk(p, c, to_peer(p, r->requester), now_us);
        p->stats.chunks_resent++;
    }
    p->stats.requests_answered++;
    return 0;
}

/* What we still wait for from peer i in round k: its position, its state when it is among the
   nearest, then (once we completed) its RoundComplete; nothing once a later round was heard. */
static int waiting_for(const gp_pse_t *p, uint32_t i)
{
    const gp_pse_peer_t *q = &p->peer[i];
    if (p->later_heard)
        return 0;
    if (!gp_pse_pos_known(q, p->round))
        return 1;
    const gp_pse_buf_t *b = gp_pse_cbuf_of(p, i, p->round);
    return (b != NULL && !b->complete) || (p->completed && !(q->has_done && q->done_round >= p->round));
}

/* Asks peer i for the chunks of its round-k state we still miss. */
static void ask_again(gp_pse_t *p, uint32_t i, gp_pse_buf_t *b, uint64_t now_us)
{
    gp_pse_request_t r = {p->cfg.self, i, p->round, 0, {0}, p->cfg.incarnation, 1, p->x_m, p->y_m, to_peer(p, i)};
    for (uint32_t k = 0; k < p->n_chunks && r.n < GP_PSE_MAX_REQUEST; k++)
        if (!(b->have[k] & GP_PSE_HAVE)) {
            b->have[k] = GP_PSE_ASKED;
            r.chunks[r.n++] = k;
        }
    send_msg(p, GP_PSE_REQUEST, &r, now_us);
    p->stats.requests_sent++;
    p->stats.chunks_requested += r.n;
    b->progress_us = now_us;
    if (b->backoff < GP_PSE_BACKOFF_MAX_ORDERED) /* ask_after caps it per link */
        b->backoff++;
}


void gp_pse_leave(gp_pse_t *p, uint64_t now_us)
{
    if (p == NULL || !p->in_round || p->leaving)
        return;
    p->leaving = 1;
    send_beacon(p, p->round + 1u, now_us);
    p->leave_said = 1;
}

/* How long peer q may show no progress while we wait for it (the liveness rule, gp_pse.h):
   the configured timeout, stretched for a peer whose messages come irregularly (RFC 6298's
   srtt + 4 rttvar of its gaps), never beyond GP_PSE_TIMEOUT_STRETCH timeouts. A peer never
   heard has the join timeout. */
static uint64_t silence_allowed(const gp_pse_t *p, const gp_pse_peer_t *q)
{
    if (!q->heard && p->cfg.join_timeout_us != 0)
        return p->cfg.join_timeout_us;
    const uint64_t rto = q->gap_srtt_us + 4u * q->gap_var_us, cap = GP_PSE_TIMEOUT_STRETCH * p->cfg.peer_timeout_us;
    return rto <= p->cfg.peer_timeout_us ? p->cfg.peer_timeout_us : rto < cap ? rto : cap;
}

/* Time we did not run is not our peers' silence: a robot that waited for the CPU finds its
   peers' messages queued, and on a busy machine they waited as long. A gap between two polls
   beyond one resend period moves every peer's last progress and the round's start forward by
   the excess. */
static void discount_stall(gp_pse_t *p, uint64_t now_us)
{
    const uint64_t last = p->polled_us;
    p->polled_us = now_us;
    if (last == 0 || now_us - last <= p->cfg.resend_after_us)
        return;
    const uint64_t gap = now_us - last - p->cfg.resend_after_us;
    p->stats.stalled_us += gap;
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        gp_pse_peer_t *q = &p->peer[i];
        if (q->heard)
            q->heard_us = now_us - q->heard_us > gap ? q->heard_us + gap : now_us;
    }
    p->round_start_us = now_us - p->round_start_us > gap ? p->round_start_us + gap : now_us;
    if (p->newcomer_us != 0)
        p->newcomer_us = now_us - p->newcomer_us > gap ? p->newcomer_us + gap : now_us;
}

/* How long into a round to wait for peer q's word of where it is before asking. A beacon
   period when q may still say it: its chunk 0 or its beacon, repeated every period. One resend
   period when its RoundComplete of the round came already: its state went out before we
   listened (a robot that started late), and what it repeats now, its RoundComplete, says where
   it will be next round, not in this one. A 64-robot fleet's late starters waited two seconds
   of a beacon period (256 ms x 64 / 8) for those asks, every robot idle. */
static uint64_t position_wait(const gp_pse_t *p, const gp_pse_peer_t *q)
{
    return q->has_done && q->done_round >= p->round ? gp_pse_ask_after(p, 0) : beacon_period(p);
}

void gp_pse_poll(gp_pse_t *p, uint64_t now_us)
{
    if (!p->in_round) {
        /* Not begun yet (starting, or driving the tour first): "on my way to round 0", without
           a position, every resend period, so that the peers already waiting can tell a robot
           that is slow to start (a busy CPU) from one that never will. */
        if (now_us - p->sent_us >= beacon_period(p))
            send_beacon(p, p->round, now_us);
        return;
    }
    discount_stall(p, now_us);
    send_window(p, now_us);
    if (p->leaving) {
        /* After the last round: "I am past it" often, so a peer that missed our RoundComplete
           ends its wait at once (a later round heard); requests for our state are still
           answered (on_request). */
        if (now_us - p->sent_us >= repeat_every(p, p->cfg.resend_after_us / 4u)) {
            send_beacon(p, p->round + 1u, now_us);
            p->leave_said++;
        }
        return;
    }
    /* Completed: our RoundComplete again until the next round begins, every quarter resend
       period while the round is not finished for us (a lost one is what the peers still wait
       for: it is 20 bytes), then every resend period, so that the peers already in the next
       round know we are on our way. */
    const uint64_t done_every =
        repeat_every(p, gp_pse_round_finished(p) ? p->cfg.resend_after_us : p->cfg.resend_after_us / 4u);
    if (p->completed && now_us - p->done_sent_us >= done_every) {
        send_done(p, now_us);
        p->stats.done_resent++;
    }
    const uint64_t begun = p->newcomer_us > p->round_start_us ? p->newcomer_us : p->round_start_us;
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        if (i == p->cfg.self)
            continue;
        gp_pse_peer_t *q = &p->peer[i];
        if (q->absent || !waiting_for(p, i))
            continue;
        /* The clock runs from the peer's last progress (a live peer speaks every resend
           period), or from the round's start when that is later. Not from the start of the
           wait for its RoundComplete: a peer cut off after its state would be timed out a
           second time in the same round. */
        const uint64_t last = !q->heard                          ? begun /* a fleet still forming (gp_pse.h) */
                              : q->heard_us > p->round_start_us ? q->heard_us
                                                                : p->round_start_us;
        const uint64_t timeout = silence_allowed(p, q);
        if (q->heard && timeout > p->stats.timeout_longest_us)
            p->stats.timeout_longest_us = timeout;
        /* Progress keeps a peer in the round, but not forever: whatever seems to come from it
           (a link that delivers a chunk a minute, or bytes forged in its name in an unkeyed
           fleet) cannot hold the round past GP_PSE_ROUND_CAP timeouts from its start (or from
           the last newcomer's arrival, while the fleet forms). */
        if (now_us - last >= timeout || now_us - begun >= GP_PSE_ROUND_CAP * timeout) {
            /* Silent too long: the round goes on without it (a state it already delivered is
               still used; only what is missing is no longer waited for). */
            q->absent = 1;
            p->stats.timeouts++;
            continue;
        }
        /* Ask again for missing chunks, once the peer is known to be in this round (asking a
           peer that has not begun it yet only adds traffic: its state comes by itself); for a
           peer not heard in the round at all, its chunk 0 tells where it is. */
        if (!q->has_round || q->at_round < p->round)
            continue;
        gp_pse_buf_t *b = gp_pse_buf_of(p, i, p->round);
        if (b != NULL && !b->complete && now_us - b->progress_us >= gp_pse_ask_after(p, b->backoff)) {
            ask_again(p, i, b, now_us);
        } else if (!gp_pse_pos_known(q, p->round) && !(q->on_way && q->on_way_round == p->round) &&
                   now_us - p->round_start_us >= position_wait(p, q) &&
                   (q->pos_backoff == 0 || now_us - q->asked_us >= gp_pse_ask_after(p, q->pos_backoff))) {
            /* Where it is unknown after the wait: asked (gp_pse_request_t: a position ask). */
            const gp_pse_request_t r = {p->cfg.self, i, p->round, 0, {0}, p->cfg.incarnation, 1, p->x_m, p->y_m,
                                        to_peer(p, i)};
            send_msg(p, GP_PSE_REQUEST, &r, now_us);
            p->stats.requests_sent++;
            p->stats.positions_asked++;
            q->asked_us = now_us;
            q->pos_backoff++;
        }
    }
    if (!p->ready_noted && gp_pse_states_ready(p)) {
        p->ready_noted = 1;
        for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
            /* A listed peer whose state did not arrive, or a peer not heard in the round (its
               state might have been one we needed). */
            const gp_pse_buf_t *b = gp_pse_cbuf_of(p, i, p->round);
            if (i != p->cfg.self && ((b != NULL && !b->complete) || !gp_pse_pos_known(&p->peer[i], p->round))) {
                p->stats.states_missed++;
                p->stats.chunks_lost += p->n_chunks - (b != NULL ? b->got : 0u);
            }
        }
        if (p->later_heard && p->stats.states_missed > 0)
            p->stats.rounds_cut++;
    }
    /* Nothing sent for a resend period (computing, or waiting with nothing to ask): say which
       round we are in, so that the peers ahead keep us and the peers behind catch up. */
    if (now_us - p->sent_us >= beacon_period(p))
        send_beacon(p, p->round, now_us);
}

uint64_t gp_pse_idle_us(const gp_pse_t *p)
{
    return p->in_round && p->next_send < p->n_chunks ? 0u : p->cfg.resend_after_us / 8u;
}

int gp_pse_states_ready(const gp_pse_t *p)
{
    if (!p->in_round)
        return 0;
    if (p->later_heard)
        return 1;
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        const gp_pse_peer_t *q = &p->peer[i];
        if (i != p->cfg.self && !q->absent && !gp_pse_pos_known(q, p->round))
            return 0; /* it may be nearer than a listed peer */
    }
    const gp_pse_nearest_t *nr = &p->near[p->round & 1u];
    for (uint32_t m = 0; m < nr->n; m++)
        if (!p->peer[nr->id[m]].absent && !state_complete(p, nr->id[m], p->round))
            return 0;
    return 1;
}

uint32_t gp_pse_peer_incarnation(const gp_pse_t *p, uint32_t id)
{
    return p != NULL && id < GP_PSE_MAX_FLEET && p->peer[id].has_inc ? p->peer[id].incarnation : 0u;
}

int gp_pse_complete(gp_pse_t *p, const double next_xy[2], uint64_t now_us)
{
    if (p == NULL || !p->in_round ||
        (next_xy != NULL && (p->round == UINT32_MAX || !isfinite(next_xy[0]) || !isfinite(next_xy[1]))))
        return -EINVAL;
    if (next_xy != NULL) {
        p->next_known = 1;
        p->next_x_m = next_xy[0];
        p->next_y_m = next_xy[1];
        /* Chunks of k + 1 that came already were ranked against where we are in k. */
        const gp_pse_nearest_t *nr = &p->near[(p->round + 1u) & 1u];
        if (nr->valid && nr->round == p->round + 1u)
            gp_pse_near_rank(p, p->round + 1u, now_us);
    }
    send_done(p, now_us);
    p->completed = 1;
    p->completed_us = now_us;
    return 0;
}

int gp_pse_all_left(const gp_pse_t *p, uint64_t now_us)
{
    if (!p->leaving || p->leave_said < GP_PSE_LEAVE_SAID)
        return 0;
    const uint64_t quiet_us = GP_PSE_LEAVE_SAID * repeat_every(p, p->cfg.resend_after_us / 4u);
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        const gp_pse_peer_t *q = &p->peer[i];
        if (i != p->cfg.self && !q->absent && !(q->has_round && q->at_round > p->round) &&
            !(q->heard && now_us - q->heard_us >= quiet_us))
            return 0;
    }
    return 1;
}
