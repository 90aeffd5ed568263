/* Peers state exchange, the nearest peers of a round (see gp_pse.h, "Fleets larger than the
   neighbour slots"): where each peer said it is, the GP_PSE_MAX_NEIGHBOURS nearest of them and
   their reassembly buffers, what gp_pse_neighbours() hands out and gp_pse_wanted() tells the
   network. Split from gp_pse.c to keep each file under the house limit of 800 lines; the two
   share gp_pse_internal.h. */
#include "gp/gp_pse.h"
#include "gp/gp_pse_internal.h"

#include <string.h>

void gp_pse_buf_reset(gp_pse_buf_t *b, uint32_t round, uint32_t n_chunks, uint64_t now_us)
{
    b->round = round;
    b->used = 1;
    b->complete = 0;
    b->got = 0;
    b->progress_us = now_us;
    b->backoff = 0;
    memset(b->have, 0, n_chunks);
}

/* ---- the nearest peers of a round and their buffers ----------------------------------------- */

static void buf_release(gp_pse_t *p, uint32_t par, uint32_t i)
{
    const uint32_t s = p->peer[i].buf[par];
    if (s != GP_PSE_NO_BUF) {
        p->pool[par][s].used = 0;
        p->peer[i].buf[par] = GP_PSE_NO_BUF;
    }
}

/* A free buffer of the round's parity for peer i. One always exists for a listed peer: the
   list holds GP_PSE_MAX_NEIGHBOURS peers at most and only listed peers own buffers. */
static void buf_attach(gp_pse_t *p, uint32_t i, uint32_t round, uint64_t now_us)
{
    const uint32_t par = round & 1u;
    for (uint32_t s = 0; s < GP_PSE_MAX_NEIGHBOURS; s++) {
        gp_pse_buf_t *b = &p->pool[par][s];
        if (b->used)
            continue;
        gp_pse_buf_reset(b, round, p->n_chunks, now_us);
        b->owner = i;
        p->peer[i].buf[par] = (uint16_t)s;
        return;
    }
}

/* Squared distance of peer i's position of the list's round to ours, and whether it is within
   the radius: the test of dinno_graph_disk. In a round where every member gives the same
   position (cfg.same_position_from) it is 0 for everyone, known before we begin the round: the
   early chunks of a posterior round were ranked against our last training position, out of
   reach of many, and each of those was then asked for again, a copy per asker (the lowest ids
   of 128 robots sent 17-35 MB each in 3 posterior rounds). */
static int in_reach(const gp_pse_t *p, uint32_t i, uint32_t par, double *d2)
{
    const uint32_t round = p->near[par].round;
    if (p->cfg.same_position_from != 0 && round >= p->cfg.same_position_from) {
        *d2 = 0.0;
        return 1;
    }
    /* ours of that round: the one our RoundComplete announced for k + 1 (gp_pse_complete) */
    const int ahead = p->next_known && p->in_round && round == p->round + 1u;
    const double ox = ahead ? p->next_x_m : p->x_m, oy = ahead ? p->next_y_m : p->y_m;
    const double dx = p->peer[i].x_m[par] - ox, dy = p->peer[i].y_m[par] - oy;
    *d2 = dx * dx + dy * dy;
    return p->cfg.radius_m <= 0.0 || *d2 <= p->cfg.radius_m * p->cfg.radius_m;
}

static int nearer(double d2a, uint32_t a, double d2b, uint32_t b)
{
    return d2a < d2b || (d2a == d2b && a < b);
}

/* Puts peer i (its position of the list's round known) into the list when it is among the
   nearest; a peer pushed out is returned in *out (else GP_PSE_NO_BUF). 1 when i is listed. */
static int near_insert(gp_pse_t *p, uint32_t par, uint32_t i, uint32_t *out)
{
    gp_pse_nearest_t *nr = &p->near[par];
    double d2;
    *out = GP_PSE_NO_BUF;
    if (!in_reach(p, i, par, &d2))
        return 0;
    if (nr->n == GP_PSE_MAX_NEIGHBOURS) {
        if (!nearer(d2, i, nr->d2[nr->n - 1u], nr->id[nr->n - 1u]))
            return 0;
        *out = nr->id[--nr->n];
    }
    uint32_t at = nr->n;
    for (; at > 0 && nearer(d2, i, nr->d2[at - 1u], nr->id[at - 1u]); at--) {
        nr->d2[at] = nr->d2[at - 1u];
        nr->id[at] = nr->id[at - 1u];
    }
    nr->d2[at] = d2;
    nr->id[at] = i;
    nr->n++;
    return 1;
}

/* Starts the list of `round` afresh (an older round's list and buffers are free). */
void gp_pse_near_reset(gp_pse_t *p, uint32_t round)
{
    const uint32_t par = round & 1u;
    gp_pse_nearest_t *nr = &p->near[par];
    for (uint32_t s = 0; s < GP_PSE_MAX_NEIGHBOURS; s++) {
        gp_pse_buf_t *b = &p->pool[par][s];
        if (b->used) {
            p->peer[b->owner].buf[par] = GP_PSE_NO_BUF;
            b->used = 0;
        }
    }
    nr->round = round;
    nr->valid = 1;
    nr->n = 0;
}

/* Peer i's position of `round` became known: it takes a buffer when it is among the nearest,
   the peer it pushed out gives its own up. */
static void near_place(gp_pse_t *p, uint32_t i, uint32_t round, uint64_t now_us)
{
    const uint32_t par = round & 1u;
    uint32_t out;
    if (!near_insert(p, par, i, &out))
        return;
    if (out != GP_PSE_NO_BUF) {
        const gp_pse_buf_t *b = gp_pse_cbuf_of(p, out, round);
        if (b != NULL && b->got > 0) /* a state given up; an empty buffer only changes hands */
            p->stats.evictions++;
        buf_release(p, par, out);
    }
    buf_attach(p, i, round, now_us);
}

/* Ranks the list of `round` again from every known position (ours moved, or a peer's): the
   listed peers keep what they hold, the others give their buffers up, a peer newly listed
   gets one and is asked soon for what it already sent. */
void gp_pse_near_rank(gp_pse_t *p, uint32_t round, uint64_t now_us)
{
    const uint32_t par = round & 1u;
    gp_pse_nearest_t *nr = &p->near[par];
    if (!nr->valid || nr->round != round) {
        gp_pse_near_reset(p, round);
    } else {
        nr->n = 0;
    }
    uint32_t out; /* nobody gives a buffer up in the loop: that is settled below */
    for (uint32_t i = 0; i < p->cfg.n_peers; i++)
        if (i != p->cfg.self && gp_pse_pos_known(&p->peer[i], round))
            (void)near_insert(p, par, i, &out);
    for (uint32_t s = 0; s < GP_PSE_MAX_NEIGHBOURS; s++) {
        gp_pse_buf_t *b = &p->pool[par][s];
        if (!b->used)
            continue;
        int keep = 0;
        for (uint32_t m = 0; m < nr->n && !keep; m++)
            keep = nr->id[m] == b->owner;
        if (!keep) {
            p->peer[b->owner].buf[par] = GP_PSE_NO_BUF;
            b->used = 0;
        }
    }
    for (uint32_t m = 0; m < nr->n; m++) {
        const uint32_t i = nr->id[m];
        if (p->peer[i].buf[par] != GP_PSE_NO_BUF)
            continue;
        buf_attach(p, i, round, now_us);
        /* Its chunks came before it was listed and were not kept: it sent them already, so
           the next poll asks for them (unsigned time: "a wait ago" also near 0). */
        gp_pse_buf_t *b = gp_pse_buf_of(p, i, round);
        if (b != NULL)
            b->progress_us = now_us - gp_pse_ask_after(p, 0);
    }
}

/* Peer i's position of `round` (par = its parity), without ranking anything. */
void gp_pse_set_position(gp_pse_peer_t *q, uint32_t par, uint32_t round, double x_m, double y_m)
{
    q->x_m[par] = x_m;
    q->y_m[par] = y_m;
    q->pos_round[par] = round;
    q->has_pos[par] = 1;
}

/* Peer i said where it is in `round` (a chunk, or a beacon with its position). The first word
   places it among the nearest; another position for the same round (corruption, or bytes
   forged in an unkeyed fleet; a restart changes the incarnation) ranks the round again and
   counts as invalid. 1 when it moved, else 0. */
int gp_pse_note_position(gp_pse_t *p, uint32_t i, uint32_t round, double x_m, double y_m, uint64_t now_us)
{
    gp_pse_peer_t *q = &p->peer[i];
    const uint32_t par = round & 1u;
    if (!gp_pse_pos_known(q, round)) {
        gp_pse_set_position(q, par, round, x_m, y_m);
        near_place(p, i, round, now_us);
        return 0;
    }
    if (q->x_m[par] == x_m && q->y_m[par] == y_m)
        return 0;
    p->stats.invalid++;
    gp_pse_set_position(q, par, round, x_m, y_m);
    gp_pse_near_rank(p, round, now_us);
    return 1;
}

/* A word that says where peer i is in round k or k + 1 places it (gp_pse.h, "Fleets larger
   than the neighbour slots"), as its chunk 0 would. */
int gp_pse_place(gp_pse_t *p, uint32_t i, uint32_t round, double x_m, double y_m, uint64_t now_us)
{
    const uint32_t k = p->in_round ? p->round : 0u;
    if (round < k || round > k + 1u)
        return 0;
    const uint32_t par = round & 1u;
    if (!p->near[par].valid || p->near[par].round != round)
        gp_pse_near_reset(p, round);
    gp_pse_peer_t *q = &p->peer[i];
    if (p->taken && round == p->round) { /* frozen (gp_pse.h): noted, not ranked */
        if (!gp_pse_pos_known(q, round))
            gp_pse_set_position(q, par, round, x_m, y_m);
        return 1;
    }
    const int moved = gp_pse_note_position(p, i, round, x_m, y_m, now_us);
    gp_pse_buf_t *b = gp_pse_buf_of(p, i, round); /* placed among the nearest, or NULL */
    if (b == NULL)
        return 1;
    if (moved)
        gp_pse_buf_reset(b, round, p->n_chunks, now_us); /* its state starts over, as for a chunk */
    /* Placed after we asked where it is: it began the round a beacon period ago at least, so
       its state went out and missed us; asked for at the next poll, not a wait later. */
    if (q->pos_backoff > 0 && round == k && b->got == 0 && b->backoff == 0)
        b->progress_us = now_us - gp_pse_ask_after(p, 0);
    return 1;
}

void gp_pse_request_position(gp_pse_t *p, const gp_pse_request_t *r, uint64_t now_us)
{
    if (r->has_position)
        (void)gp_pse_place(p, r->requester, r->round, r->x_m, r->y_m, now_us);
}

uint32_t gp_pse_neighbours(gp_pse_t *p, uint32_t ids[GP_PSE_MAX_NEIGHBOURS],
                           const uint8_t *states[GP_PSE_MAX_NEIGHBOURS])
{
    if (!p->in_round)
        return 0;
    p->taken = 1; /* from here until begin_round(k + 1), round k's buffers are frozen */
    /* The list is by distance; the caller gets ascending ids (DiNNO sums its slots in that
       order, as the in-process fleet does). */
    const gp_pse_nearest_t *nr = &p->near[p->round & 1u];
    uint32_t n = 0;
    for (uint32_t m = 0; m < nr->n; m++) {
        const uint32_t i = nr->id[m];
        const gp_pse_buf_t *b = gp_pse_cbuf_of(p, i, p->round);
        if (b == NULL || !b->complete)
            continue;
        uint32_t at = n;
        for (; at > 0 && ids[at - 1u] > i; at--) {
            ids[at] = ids[at - 1u];
            states[at] = states[at - 1u];
        }
        ids[at] = i;
        states[at] = b->bytes;
        n++;
    }
    return n;
}

uint32_t gp_pse_wanted(const gp_pse_t *p, uint8_t bits[GP_PSE_WANTED_BYTES])
{
    memset(bits, 0, GP_PSE_WANTED_BYTES);
    for (uint32_t par = 0; par < 2u; par++) {
        const gp_pse_nearest_t *nr = &p->near[par];
        if (!nr->valid || nr->round + 1u < p->round) /* older than round k - 1: no guide */
            continue;
        for (uint32_t m = 0; m < nr->n; m++)
            bits[nr->id[m] / 8u] |= (uint8_t)(1u << (nr->id[m] % 8u));
    }
    /* A round of one position for all (cfg.same_position_from) has the lowest ids for
       neighbours, known before any word from them: wanted from the round before it on, when
       its first chunks may come. Otherwise they were dropped as those of unplaced peers, and in
       an addressed fleet each robot then asked for them alone (256 robots: robot 0 re-sent
       878 MB of its posterior). */
    if (p->cfg.same_position_from != 0 && p->round + 1u >= p->cfg.same_position_from)
        for (uint32_t i = 0, k = 0; i < p->cfg.n_peers && k < GP_PSE_MAX_NEIGHBOURS; i++)
            if (i != p->cfg.self) {
                bits[i / 8u] |= (uint8_t)(1u << (i % 8u));
                k++;
            }
    uint32_t n = 0;
    for (uint32_t i = 0; i < p->cfg.n_peers; i++) {
        const gp_pse_peer_t *q = &p->peer[i];
        if (!p->cfg.addressed && (!p->in_round || (!q->has_pos[0] && !q->has_pos[1]))) /* never placed: maybe near */
            bits[i / 8u] |= (uint8_t)(1u << (i % 8u));
        if (i == p->cfg.self)
            bits[i / 8u] &= (uint8_t)~(1u << (i % 8u));
        n += (bits[i / 8u] >> (i % 8u)) & 1u;
    }
    return n;
}
