/* Peers state exchange: see gp_pse.h. */
#include "gp/gp_pse.h"

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

static void send_msg(gp_pse_t *p, gp_pse_kind_t kind, const void *msg)
{
    if (p->cfg.send(p->cfg.send_ctx, kind, msg) != 0)
        p->stats.send_failures++;
}

static void send_chunk(gp_pse_t *p, uint32_t chunk)
{
    const uint32_t n = chunk_len(p, chunk);
    const gp_pse_chunk_t c = {p->cfg.self, p->round, chunk, p->n_chunks, p->cfg.state_bytes, p->my_crc32,
                              p->x_m, p->y_m, n, p->mine + (size_t)chunk * p->cfg.chunk_bytes,
                              p->cfg.encoding, p->cfg.incarnation};
    send_msg(p, GP_PSE_CHUNK, &c);
    p->stats.chunks_sent++;
    p->stats.bytes_sent += n;
}

int gp_pse_init(gp_pse_t *p, const gp_pse_cfg_t *c)
{
    if (p == NULL || c == NULL || c->send == NULL || c->n_peers < 1 || c->n_peers > GP_PSE_MAX_PEERS ||
        c->self >= c->n_peers || c->state_bytes < 1 || c->state_bytes > GP_PSE_MAX_STATE_BYTES ||
        c->chunk_bytes < GP_PSE_MIN_CHUNK_BYTES || c->chunk_bytes > GP_PSE_MAX_CHUNK_BYTES ||
        !isfinite(c->radius_m) || c->resend_after_us == 0 || c->peer_timeout_us <= c->resend_after_us ||
        (c->join_timeout_us != 0 && c->join_timeout_us < c->peer_timeout_us) ||
        c->encoding > 1)
        return -EINVAL;
    memset(&p->stats, 0, sizeof p->stats);
    p->cfg = *c;
    p->n_chunks = (c->state_bytes + c->chunk_bytes - 1u) / c->chunk_bytes;
    p->round = 0;
    p->in_round = p->completed = p->later_heard = 0;
    p->mine = NULL;
    for (uint32_t i = 0; i < GP_PSE_MAX_PEERS; i++) {
        gp_pse_peer_t *q = &p->peer[i];
        q->buf[0].used = q->buf[1].used = 0;
        q->heard = q->has_done = q->absent = 0;
    }
    return 0;
}

static void buf_reset(gp_pse_buf_t *b, uint32_t round, uint32_t n_chunks, uint64_t now_us)
{
    b->round = round;
    b->used = 1;
    b->complete = 0;
    b->got = 0;
    b->progress_us = now_us;
    memset(b->have, 0, n_chunks);
}

/* Our next `burst` chunks (all of them without a burst). */
static void send_window(gp_pse_t *p)
{
    const uint32_t end = p->cfg.burst == 0 || p->n_chunks - p->next_send < p->cfg.burst ? p->n_chunks
                                                                                        : p->next_send + p->cfg.burst;
    for (; p->next_send < end; p->next_send++)
        send_chunk(p, p->next_send);
}

int gp_pse_begin_round(gp_pse_t *p, uint32_t round, const uint8_t *state, double x_m, double y_m, uint64_t now_us)
{
    if (p == NULL || state == NULL || !isfinite(x_m) || !isfinite(y_m) || (p->in_round && round != p->round + 1u))
        return -EINVAL;
    p->round = round;
    p->in_round = 1;
    p->completed = 0;
    p->later_heard = 0;
    p->round_start_us = now_us;
    p->mine = state;
    p->my_crc32 = crc32_ieee(state, p->cfg.state_bytes);
    p->x_m = x_m;
    p->y_m = y_m;
    memset(p->resent_at, 0, sizeof p->resent_at);
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        gp_pse_peer_t *q = &p->peer[i];
        gp_pse_buf_t *b = &q->buf[round & 1u];
        if (!b->used || b->round != round) /* an older round's buffer: free for this one */
            buf_reset(b, round, p->n_chunks, now_us);
        b->progress_us = now_us;
        /* A peer that left stays out of the next rounds until it is heard again (heard()),
           so a crashed peer costs one timeout, not one per round. */
        /* A RoundComplete of this round or later already heard still says the peer is ahead. */
        p->later_heard |= q->has_done && q->done_round > round;
    }
    p->next_send = 0;
    send_window(p);
    return 0;
}

/* A valid message from `sender`: it is in the round again if it had left it. */
static void heard(gp_pse_t *p, uint32_t sender, uint64_t now_us)
{
    gp_pse_peer_t *q = &p->peer[sender];
    q->heard = 1;
    q->heard_us = now_us;
    if (q->absent) {
        q->absent = 0;
        p->stats.rejoins++;
    }
}

/* Round window of a message of `round`: 0 inside (k or k + 1), else the reason. */
static int window(gp_pse_t *p, uint32_t round)
{
    const uint32_t k = p->in_round ? p->round : 0u;
    if (round < k) {
        p->stats.stale++;
        return -ESTALE;
    }
    if (round > k + 1u) {
        p->stats.future++;
        p->later_heard = p->in_round;
        return -EAGAIN;
    }
    if (round > k && p->in_round)
        p->later_heard = 1;
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
    int rc = window(p, c->round);
    heard(p, c->sender, now_us);
    if (rc != 0)
        return rc;
    p->stats.chunks_received++;
    gp_pse_buf_t *b = &p->peer[c->sender].buf[c->round & 1u];
    if (!b->used || b->round != c->round)
        buf_reset(b, c->round, p->n_chunks, now_us);
    if (b->complete || b->have[c->chunk]) {
        p->stats.duplicates++;
        return -EALREADY;
    }
    if (b->got > 0 && (b->crc32 != c->crc32 || b->x_m != c->x_m || b->y_m != c->y_m)) {
        /* Chunks of one state disagree: a peer that restarted its round, or corruption. */
        p->stats.invalid++;
        return -EBADMSG;
    }
    memcpy(b->bytes + (size_t)c->chunk * p->cfg.chunk_bytes, c->data, c->n_bytes);
    b->have[c->chunk] = 1;
    b->got++;
    b->crc32 = c->crc32;
    b->x_m = c->x_m;
    b->y_m = c->y_m;
    b->progress_us = now_us;
    p->stats.bytes_received += c->n_bytes;
    if (b->got == p->n_chunks) {
        if (crc32_ieee(b->bytes, p->cfg.state_bytes) != b->crc32) {
            p->stats.crc_failures++;
            buf_reset(b, c->round, p->n_chunks, now_us); /* every chunk is asked for again */
            return -EILSEQ;
        }
        b->complete = 1;
    }
    return 0;
}

int gp_pse_on_done(gp_pse_t *p, const gp_pse_done_t *d, uint64_t now_us)
{
    if (d == NULL || d->sender >= p->cfg.n_peers || d->sender == p->cfg.self) {
        p->stats.invalid++;
        return -EBADMSG;
    }
    gp_pse_peer_t *q = &p->peer[d->sender];
    int rc = window(p, d->round);
    heard(p, d->sender, now_us);
    if (!q->has_done || d->round > q->done_round) {
        q->done_round = d->round;
        q->has_done = 1;
    }
    return rc == -EAGAIN ? 0 : rc; /* a round further ahead still tells where the peer is */
}

int gp_pse_on_request(gp_pse_t *p, const gp_pse_request_t *r, uint64_t now_us)
{
    if (r == NULL || r->requester >= p->cfg.n_peers || r->requester == p->cfg.self || r->target != p->cfg.self ||
        r->n > GP_PSE_MAX_REQUEST) {
        p->stats.invalid++;
        return -EBADMSG;
    }
    for (uint32_t i = 0; i < r->n; i++)
        if (r->chunks[i] >= p->n_chunks) {
            p->stats.invalid++;
            return -EBADMSG;
        }
    heard(p, r->requester, now_us);
    if (!p->in_round || r->round != p->round) {
        p->stats.stale++;
        return -ESTALE; /* only the current round's state is kept */
    }
    /* A resend reaches every peer (multicast): one per chunk per half resend period serves
       all the peers that asked for it meanwhile, instead of a storm of copies. */
    for (uint32_t i = 0; i < r->n; i++) {
        const uint32_t c = r->chunks[i];
        if (p->resent_at[c] != 0 && now_us - p->resent_at[c] < p->cfg.resend_after_us / 2u) {
            p->stats.resends_merged++;
            continue;
        }
        p->resent_at[c] = now_us | 1u;
        send_chunk(p, c);
        p->stats.chunks_resent++;
    }
    p->stats.requests_answered++;
    return 0;
}

void gp_pse_poll(gp_pse_t *p, uint64_t now_us)
{
    if (!p->in_round)
        return;
    send_window(p);
    /* Waiting for the others' RoundComplete: ours again, in case it was lost (the last round
       has no later State to tell a peer that we finished). */
    if (p->completed && !gp_pse_round_finished(p) && now_us - p->done_sent_us >= p->cfg.resend_after_us) {
        const gp_pse_done_t d = {p->cfg.self, p->round};
        send_msg(p, GP_PSE_DONE, &d);
        p->done_sent_us = now_us;
        p->stats.done_resent++;
    }
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        if (i == p->cfg.self)
            continue;
        gp_pse_peer_t *q = &p->peer[i];
        gp_pse_buf_t *b = &q->buf[p->round & 1u];
        /* What we wait for from this peer: its state until it is complete, then (once we
           completed) its RoundComplete. The clock runs from the later of that wait's start
           and the last time we heard it. */
        const int waiting = !b->complete || (p->completed && !(q->has_done && q->done_round >= p->round));
        uint64_t last = p->completed && b->complete ? p->completed_us : p->round_start_us;
        if (q->heard && q->heard_us > last)
            last = q->heard_us;
        const uint64_t timeout = q->heard || p->cfg.join_timeout_us == 0 ? p->cfg.peer_timeout_us
                                                                          : p->cfg.join_timeout_us;
        if (!q->absent && waiting && now_us - last >= timeout) {
            /* Silent too long: the round goes on without it (a state it already delivered is
               still used; only what is missing is no longer waited for). */
            q->absent = 1;
            p->stats.timeouts++;
        }
        if (q->absent || b->complete || now_us - b->progress_us < p->cfg.resend_after_us)
            continue;
        gp_pse_request_t r = {p->cfg.self, i, p->round, 0, {0}};
        for (uint32_t k = 0; k < p->n_chunks && r.n < GP_PSE_MAX_REQUEST; k++)
            if (!b->have[k])
                r.chunks[r.n++] = k;
        send_msg(p, GP_PSE_REQUEST, &r);
        p->stats.requests_sent++;
        p->stats.chunks_requested += r.n;
        b->progress_us = now_us;
    }
}

int gp_pse_states_ready(const gp_pse_t *p)
{
    if (!p->in_round)
        return 0;
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        const gp_pse_peer_t *q = &p->peer[i];
        const gp_pse_buf_t *b = &q->buf[p->round & 1u];
        if (i != p->cfg.self && !q->absent && !(b->used && b->round == p->round && b->complete))
            return 0;
    }
    return 1;
}

uint32_t gp_pse_neighbours(const gp_pse_t *p, uint32_t ids[GP_PSE_MAX_PEERS], const uint8_t *states[GP_PSE_MAX_PEERS])
{
    uint32_t n = 0;
    const double r2 = p->cfg.radius_m * p->cfg.radius_m;
    for (uint32_t i = 0; i < p->cfg.n_peers && p->in_round; i++) {
        const gp_pse_buf_t *b = &p->peer[i].buf[p->round & 1u];
        if (i == p->cfg.self || !b->used || b->round != p->round || !b->complete)
            continue;
        /* The test of dinno_graph_disk, on the positions both ends carried in this round. */
        const double dx = b->x_m - p->x_m, dy = b->y_m - p->y_m;
        if (p->cfg.radius_m > 0.0 && !(dx * dx + dy * dy <= r2))
            continue;
        ids[n] = i;
        states[n] = b->bytes;
        n++;
    }
    return n;
}

int gp_pse_complete(gp_pse_t *p, uint64_t now_us)
{
    if (p == NULL || !p->in_round)
        return -EINVAL;
    const gp_pse_done_t d = {p->cfg.self, p->round};
    send_msg(p, GP_PSE_DONE, &d);
    p->completed = 1;
    p->completed_us = now_us;
    p->done_sent_us = now_us;
    return 0;
}

int gp_pse_round_finished(const gp_pse_t *p)
{
    if (!p->in_round || !p->completed)
        return 0;
    if (p->later_heard)
        return 1;
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        const gp_pse_peer_t *q = &p->peer[i];
        if (i != p->cfg.self && !q->absent && !(q->has_done && q->done_round >= p->round))
            return 0;
    }
    return 1;
}
