/* Peers state exchange: Algorithm 1 of the source paper made loss-proof and live, as a state
 * machine with no I/O of its own (docs/architecture.md section 4). The GP core feeds it the
 * messages it received and the time, and it emits the messages to send through a callback; a
 * codec and a transport (hal_net over LCM on the host) sit outside it, so it is tested against
 * any order, loss, duplication, delay, partition, pause and restart one call at a time
 * (tests/gp/test_gp_pse.c, and the seeded simulation tests/gp/test_pse_sim.c).
 *
 * Round k, at peer `self` of a fleet of n_peers:
 *   gp_pse_begin_round(k, state, x, y)  our encoded state (state_bytes, kept unchanged by the
 *                 caller until the round finished) goes out as n_chunks chunks of chunk_bytes
 *                 (the last shorter), each with the round, the state's CRC-32 and our position;
 *   gp_pse_on_chunk/on_done/on_request  every field is validated first (sender inside the
 *                 fleet and not us, sizes equal to the fleet's, chunk bounds, finite position);
 *                 then the sender's incarnation: an older one is dropped, a newer one means the
 *                 peer restarted (what we held of it is forgotten); a peer's chunks reassemble per
 *                 round (two buffers per peer: a peer may already send k+1) and a state counts
 *                 only when its CRC matches; duplicates, stale rounds and rounds beyond k+1 are
 *                 ignored and counted;
 *   gp_pse_poll(now)  sends the rest of our state (send window), asks again for missing chunks
 *                 after resend_after_us without progress, repeats our RoundComplete, says "I am
 *                 in round k" (a beacon: a request naming no chunk) when it sent nothing for
 *                 resend_after_us, and times out silent peers;
 *   gp_pse_states_ready()  every peer delivered its state of round k, left the round, or a
 *                 later round was heard;
 *   gp_pse_neighbours()  the peers whose round-k position is within radius_m of ours (the same
 *                 test as dinno_graph_disk), or all of them with radius_m <= 0, the nearest
 *                 GP_PSE_MAX_NEIGHBOURS of them when there are more (ties by id): it depends on
 *                 the positions only, never on arrival times. It hands out the reassembly
 *                 buffers themselves, and from then on round k's states are frozen (the
 *                 contract below);
 *   gp_pse_complete(next, now)  after the node update: RoundComplete(k) goes out (and again
 *                 every resend_after_us until the next round begins), with our position of
 *                 round k + 1 when the caller knows it already (`next`; NULL: not known): every
 *                 peer then places us in k + 1 from it, and round k + 1 opens without a beacon;
 *   gp_pse_round_finished()  every peer in the round completed k, or a later round was heard;
 *   gp_pse_next_round(now)  the round to begin next: k + 1, or the round a live peer is in
 *                 when that is further (a robot that fell behind skips to the fleet);
 *   gp_pse_leave(now)  the last round finished: from now on poll says "I am past round k" (a
 *                 beacon of round k + 1) every resend_after_us / 4, which ends the wait of a peer
 *                 that missed our RoundComplete, and still answers requests for our state.
 *
 * Liveness (the rule docs/architecture.md states): a peer is kept in round k only by progress,
 * i.e. a message of round k or later, or its RoundComplete of k - 1 (it is on its way to k);
 * a peer that shows none for its timeout (join_timeout_us before it was ever heard, counted
 * from the round's start or from the last time any peer was first heard, whichever is later:
 * while newcomers keep coming the fleet is still starting, as 256 processes on 2 cores take
 * minutes to; one that never starts costs one join timeout after the last) while we
 * wait for it leaves the round, and stays out until a round boundary where it is heard in the
 * round before or later. Its timeout is peer_timeout_us, stretched for a peer whose signs of
 * progress come irregularly (RFC 6298's srtt + 4 rttvar of the gaps between them) up to
 * GP_PSE_TIMEOUT_STRETCH x peer_timeout_us; and time we did not run (a gap between two of our
 * polls beyond a resend period: a busy CPU) does not count, since our peers' messages waited
 * for us meanwhile. Every live peer sends at least one message per resend_after_us, also
 * before its first round ("on my way to round 0", no position), so only a crashed, paused or
 * cut-off peer times out. A message of a later round ends our
 * waiting at once: the sender finished round k, so every peer still in it had completed it or
 * was given up (with loss alone this never happens before our own state set was complete, so
 * the models stay those of the lossless run). A robot therefore finishes every round at most
 * one peer_timeout_us after the last progress of the peers it waits for.
 *
 * Fleets larger than the neighbour slots: the fleet has up to GP_PSE_MAX_FLEET ids (the board's
 * BOARD_MAX_FLEET), but a round keeps the states of GP_PSE_MAX_NEIGHBOURS peers at most (the
 * board's BOARD_MAX_PEERS, DiNNO's slots). A round opens with a beacon that carries its
 * sender's position (so do its requests and every chunk), so the first word of a peer in a
 * round places it; a RoundComplete of k that carries the position of k + 1 places its sender
 * for k + 1 before it begins that round, and the sender then opens k + 1 without the beacon
 * (one fleet-wide message per robot and round fewer: 64 robots each received 63 of them a
 * round, docs/scaling.md). Our own list of k + 1 is ranked against our own announced position,
 * so the network keeps the right chunks of k + 1 before we begin it. Where the RoundComplete
 * was lost, the sender's next beacon or a position ask places it, as for any unplaced peer.
 * gp_pse_wanted() tells the GP core whose chunks it may keep: its network drops the others'
 * before they cost anything (hal_net_set_senders; ZeroMQ never sends them).
 * Each round keeps a list of its nearest peers within the radius, sorted by (squared distance,
 * id), and only those own a state buffer; a nearer peer heard later takes the buffer of the
 * farthest (an eviction). Chunks of round k + 1 are ranked against our announced position of
 * k + 1 (else our position of round k) until round k + 1 begins and the list is ranked again;
 * a peer that got in only then is asked for its chunks. A round's states are ready when every
 * live peer's position of the round is known and every listed peer delivered. A peer never heard in the round is asked where it is (a position ask, once a
 * beacon period of the round passed without its repeated beacon), unless
 * its last word was "on my way to this round" (a beacon without a position): it has not begun
 * it, and its first word of the round will place it. In a round from cfg.same_position_from on
 * every member gives the same position, so every peer is placed when the round begins (a dead
 * one too: a listed peer that crashed keeps its slot and times out like any listed peer; the
 * round goes on with the states that came) and nobody is asked where it is: with 256 robots
 * whose neighbours were all the lowest 32 ids, those asks were 878 MB of copies from robot 0.
 *
 * The handed-out buffers (the contract the zero-copy path rests on): the state buffers
 * gp_pse_neighbours() returns for round k are not written by gp_pse (no eviction by a nearer
 * peer heard late, no re-ranking after a restart or a moved position, no duplicate or late
 * chunk, no re-use for another round) until the caller begins round k + 1 with
 * gp_pse_begin_round(). Until then chunks of round k are still validated and tell where and
 * in which round their sender is (liveness is unchanged), but their bytes are dropped
 * (stats.after_taken). In exchange the caller may rewrite a handed-out buffer in place (the
 * GP core expands a quantised state to fp32 there: every buffer holds GP_PSE_MAX_STATE_BYTES and
 * is 64-byte aligned, readable as floats) and must be done with it before it begins k + 1.
 * Round k + 1's chunks go to the other pool meanwhile.
 *
 * Memory: everything is inside gp_pse_t (static in the image): a table of GP_PSE_MAX_FLEET
 * peers (about 140 bytes each) and a pool of 2 x GP_PSE_MAX_NEIGHBOURS state buffers of the
 * preset's state size; no allocation. One thread (the GP core). */
#ifndef GP_GP_PSE_H
#define GP_GP_PSE_H

#include <stddef.h>
#include <stdint.h>


/* Fleet ids 0 .. GP_PSE_MAX_FLEET - 1; states kept per round: GP_PSE_MAX_NEIGHBOURS (the board's
 * neighbour slots, which DiNNO's slots match). */
#define GP_PSE_MAX_FLEET BOARD_MAX_FLEET
#define GP_PSE_MAX_NEIGHBOURS BOARD_MAX_PEERS
#define GP_PSE_MAX_STATE_BYTES ((uint32_t)FW_STATE_MAX_BYTES) /* the fp32 state of the preset (fw_config.h) */
#define GP_PSE_MIN_CHUNK_BYTES 1024u
/* A chunk and its header (GP_PSE_CHUNK_HEADER_ROOM bytes at most) fit one datagram of the
 * board, and 60 KB at most (LCM's UDP multicast drops larger messages). */
#define GP_PSE_CHUNK_HEADER_ROOM 64u
#define GP_PSE_MAX_CHUNK_BYTES                                                                 \
    (BOARD_NET_MTU_BYTES - GP_PSE_CHUNK_HEADER_ROOM < 60u * 1024u ? BOARD_NET_MTU_BYTES - GP_PSE_CHUNK_HEADER_ROOM \
                                                                  : 60u * 1024u)
#define GP_PSE_MAX_CHUNKS ((GP_PSE_MAX_STATE_BYTES + GP_PSE_MIN_CHUNK_BYTES - 1u) / GP_PSE_MIN_CHUNK_BYTES)
#define GP_PSE_MAX_REQUEST 64u /* chunk indices one resend request names */
/* State encodings 0 .. GP_PSE_ENCODINGS - 1: ai/dinno_codec.h's codecs (fp32, int8, int8-ef,
 * int4-ef; gp_fleet.c asserts the count). The protocol only carries the number and refuses a
 * chunk of another encoding than the fleet's. */
#define GP_PSE_ENCODINGS 4u

typedef enum gp_pse_kind { GP_PSE_CHUNK = 0, GP_PSE_DONE = 1, GP_PSE_REQUEST = 2 } gp_pse_kind_t;

/* One piece of a peer's state (fleetsim.state_chunk_t). */
typedef struct gp_pse_chunk {
    uint32_t sender, round;
    uint32_t chunk, n_chunks;
    uint32_t state_bytes;
    uint32_t crc32;          /* of the whole state */
    double x_m, y_m;         /* the sender's position for round `round` */
    uint32_t n_bytes;
    const uint8_t *data;
    uint8_t encoding;        /* the fleet's (from gp_pse_cfg_t) */
    uint32_t incarnation;    /* the sender's start count (from gp_pse_cfg_t) */
    uint32_t to;             /* GP_PSE_TO_ALL, or the one peer a resend is for (with
                                cfg.addressed). Not on the wire: the transport carries it
                                (gp_fleet: the requester's own resend channel) */
} gp_pse_chunk_t;

#define GP_PSE_TO_ALL UINT32_MAX

/* RoundComplete (fleetsim.round_complete_t). */
typedef struct gp_pse_done {
    uint32_t sender, round;
    uint32_t incarnation;    /* the sender's */
    uint8_t has_next_position; /* 1: next_x_m, next_y_m are the sender's position for round + 1 */
    double next_x_m, next_y_m;
} gp_pse_done_t;

/* "Send again these chunks of your state of `round`" (fleetsim.chunk_request_t). With n = 0 it
 * is a beacon, "the requester is in round `round`", for every peer (target is the requester);
 * with has_position it also says where the requester is in that round. With n = 0 and another
 * target it asks that target where it is in `round` (a position ask): answered by the
 * target's positioned beacon, a few dozen bytes, not by a chunk of its state. */
typedef struct gp_pse_request {
    uint32_t requester, target, round, n;
    uint32_t chunks[GP_PSE_MAX_REQUEST];
    uint32_t incarnation;    /* the requester's */
    uint8_t has_position;    /* 1: x_m, y_m are the requester's position for `round` */
    double x_m, y_m;
    uint32_t to;             /* GP_PSE_TO_ALL, or the target alone (a request naming chunks, or
                                a position ask, with cfg.addressed). Not on the wire, as for a
                                chunk (gp_fleet: the target's own request channel) */
} gp_pse_request_t;

/* Sends one message (msg points to the struct of `kind`). 0, or a negative code (counted:
 * a lost message is what the protocol is built for). */
typedef int (*gp_pse_send_fn)(void *ctx, gp_pse_kind_t kind, const void *msg);

/* A peer's timeout adapts to what the fleet shows (gp_pse_poll), within 1 .. this many of the
 * configured peer timeouts: the bound on what a crashed peer costs. */
#define GP_PSE_TIMEOUT_STRETCH 4u
/* What every member hears (RoundCompletes repeated, beacons) is repeated less often in a fleet of
 * more than this many members, in proportion to its size, as RTCP does (RFC 3550, 6.2): a robot
 * receives every member's, so the rate it receives stays that of a fleet of this size. Never
 * less often than four times a peer timeout, so a live robot is always heard in time. */
#define GP_PSE_CHATTY_FLEET 8u
/* Bytes of a set of fleet ids, one bit per id (gp_pse_wanted). */
#define GP_PSE_WANTED_BYTES ((GP_PSE_MAX_FLEET + 7u) / 8u)

/* A round waits for a peer at most this many of its timeouts (peer or join) from the round's
 * start, progress or not: the bound on a round that no peer can lift. */
#define GP_PSE_ROUND_CAP 4u

typedef struct gp_pse_cfg {
    uint32_t self, n_peers;     /* self < n_peers <= GP_PSE_MAX_FLEET: our id, the fleet's size */
    uint32_t state_bytes;       /* 1 .. GP_PSE_MAX_STATE_BYTES, the same for the whole fleet */
    uint32_t chunk_bytes;       /* GP_PSE_MIN_CHUNK_BYTES .. GP_PSE_MAX_CHUNK_BYTES, same for all */
    double radius_m;            /* neighbours within it; <= 0: every peer (full mesh) */
    uint64_t resend_after_us;   /* > 0: ask again for missing chunks after this without progress */
    uint64_t peer_timeout_us;   /* > resend_after_us: a peer silent this long leaves the round */
    uint64_t join_timeout_us;   /* the same for a peer never heard yet (start-up); 0: peer_timeout_us,
                                   else >= peer_timeout_us */
    gp_pse_send_fn send;
    void *send_ctx;
    uint8_t encoding;           /* of every state in the fleet: < GP_PSE_ENCODINGS (dinno_codec_t) */
    uint32_t incarnation;       /* ours, carried in our chunks */
    uint32_t burst;             /* chunks sent by begin_round, then as many by each poll (a send
                                   window that lets the receivers keep up); 0: all at once */
    uint8_t addressed;          /* 1: a request naming chunks goes to its target alone and
                                   the chunks sent again to the peer that asked alone (their
                                   `to`), for a point-to-point transport (ZeroMQ), where a copy
                                   for everyone is one copy per connection and the others would
                                   only drop it; what every peer must hear (beacons, positions,
                                   RoundCompletes) still goes to everyone, and as often, since
                                   an addressed request does not count as speaking to the fleet.
                                   0: everything to everyone, one resend per chunk per half
                                   resend period answering all who asked meanwhile (multicast:
                                   LCM, one datagram for all) */
    uint8_t ordered;            /* 1: the transport delivers each sender's messages in the order
                                   sent (TCP: ZeroMQ), so a state's first request waits for the
                                   sender's next word to everyone rather than one resend period
                                   (gp_pse_ask_after); 0: datagrams may come in any order (UDP) */
    uint32_t same_position_from; /* > 0: from this round on every member gives the same position
                                   (gp_fleet's posterior rounds), so a round begins with every
                                   peer placed at ours, none asked where it is; its neighbours
                                   are the lowest ids. 0: none */
} gp_pse_cfg_t;

typedef struct gp_pse_stats {
    uint64_t chunks_sent, chunks_received, chunks_resent;
    uint64_t duplicates, stale, future, invalid, crc_failures;
    uint64_t requests_sent, requests_answered;
    uint64_t chunks_requested;  /* chunk indices named in our requests (lost or late chunks) */
    uint64_t positions_asked;   /* position asks sent (peers not heard in a round for a beacon period) */
    uint64_t placed_ahead;      /* peers placed in round k + 1 by their RoundComplete of k */
    uint64_t openings_announced; /* rounds we opened without a beacon: our RoundComplete said where */
    uint64_t done_resent;       /* our RoundComplete sent again while waiting for the others */
    uint64_t resends_merged;    /* requested chunks not sent again: one went out just before */
    uint64_t send_failures;
    uint64_t timeouts;          /* peers that left a round */
    uint64_t rejoins;           /* peers taken back at a round boundary after leaving */
    uint64_t bytes_sent, bytes_received; /* state bytes */
    uint64_t beacons_sent;      /* "I am in round k": nothing else was sent for a while */
    uint64_t old_incarnation;   /* messages of a peer's earlier incarnation, dropped */
    uint64_t restarts;          /* peers heard with a newer incarnation (restarted) */
    uint64_t chunks_recovered;  /* chunks that arrived only after we asked for them */
    uint64_t states_missed;     /* peers' states of a round we went on without (never complete) */
    uint64_t chunks_lost;       /* their chunks never received */
    uint64_t rounds_cut;        /* rounds whose waiting a later round ended */
    uint64_t rounds_skipped;    /* rounds jumped over to catch up with the fleet */
    uint64_t not_nearest;       /* chunks of peers beyond the radius or the nearest: position noted */
    uint64_t evictions;         /* states given up for a nearer peer's (its chunks came later) */
    uint64_t after_taken;       /* chunks of a round whose states were handed out: not stored */
    uint64_t stalled_us;        /* time we did not run (gaps between polls beyond a resend
                                   period): not counted as our peers' silence */
    uint64_t timeout_longest_us; /* the longest adapted timeout a heard peer was given */
} gp_pse_stats_t;

/* One state being reassembled: a slot of the buffer pool, owned by one of the nearest peers of
 * its round (see "Fleets larger than the neighbour slots" above). */
typedef struct gp_pse_buf {
    uint32_t round, owner;
    int used, complete;
    uint32_t got;
    uint32_t crc32;
    uint64_t progress_us;       /* last chunk or request: when to ask again */
    uint32_t backoff;           /* requests since its last chunk (the wait doubles, see below) */
    uint8_t have[GP_PSE_MAX_CHUNKS]; /* GP_PSE_HAVE, GP_PSE_ASKED (missing, asked for) or 0 */
    union { /* the state as it arrived (bytes), or as fp32 words once handed out (see above) */
        _Alignas(64) uint8_t bytes[GP_PSE_MAX_STATE_BYTES];
        float words[GP_PSE_MAX_STATE_BYTES / 4u];
    };
} gp_pse_buf_t;
_Static_assert(GP_PSE_MAX_STATE_BYTES % 4u == 0u, "a state buffer holds whole fp32 words");

/* A request that brought nothing doubles the wait before the next one to the same peer, up to
 * 2^GP_PSE_BACKOFF_MAX resend periods (400 ms with the defaults, far inside a peer timeout):
 * a peer or a network too busy to answer is not buried under more requests, whose answers
 * every robot of the fleet receives. A chunk of the state starts over at one period. */
#define GP_PSE_BACKOFF_MAX 1u
/* On an ordered link (cfg.ordered: TCP) up to 2^GP_PSE_BACKOFF_MAX_ORDERED periods: there an
 * answer is lost only when a receive queue overflowed, and is far more often still queued
 * behind a busy CPU or a proxy; each request that outruns it costs one more copy of the chunk
 * to the asker. 128 robots through one ZeroMQ proxy on 2 cores, capped at 2 periods, asked
 * for every chunk about 15 times in round 0 (docs/scaling.md). */
#define GP_PSE_BACKOFF_MAX_ORDERED 4u

#define GP_PSE_HAVE 1u
#define GP_PSE_ASKED 2u
#define GP_PSE_NO_BUF 0xFFFFu

/* What we know of one fleet member (every id of the fleet has one; about 140 bytes). Positions
 * and buffers are kept by round parity: rounds k and k + 1. */
typedef struct gp_pse_peer {
    uint64_t heard_us;          /* last progress from it (see the liveness rule above) */
    uint64_t asked_us;          /* last position ask to it */
    uint32_t pos_backoff;       /* such requests this round (the wait doubles as for a state) */
    uint64_t gap_srtt_us, gap_var_us; /* its gaps between signs of progress, smoothed */
    double x_m[2], y_m[2];      /* its position of round pos_round[parity] (with has_pos) */
    uint32_t pos_round[2];
    uint32_t incarnation;       /* newest seen (with has_inc) */
    uint32_t at_round;          /* the highest round it is known to be in (with has_round) */
    uint32_t done_round;        /* highest RoundComplete (with has_done) */
    uint16_t buf[2];            /* its slot of pool[parity], or GP_PSE_NO_BUF */
    uint8_t heard, has_inc, has_round, has_done;
    uint8_t absent;             /* left the current round (silent past the timeout) */
    uint8_t has_pos[2];
    uint8_t on_way;             /* its last word: "on my way to round on_way_round", no position */
    uint32_t on_way_round;
    uint8_t has_ahead;          /* its RoundComplete said where it is in round ahead_round, */
    uint32_t ahead_round;       /* perhaps before we began the round before that one: placed */
    double ahead_x_m, ahead_y_m; /* when we begin it */
} gp_pse_peer_t;

/* The nearest peers of one round within the radius, at most GP_PSE_MAX_NEIGHBOURS, sorted by
 * (squared distance, id): the peers whose states that round keeps. */
typedef struct gp_pse_nearest {
    uint32_t round;
    int valid;
    uint32_t n;
    uint32_t id[GP_PSE_MAX_NEIGHBOURS];
    double d2[GP_PSE_MAX_NEIGHBOURS];
} gp_pse_nearest_t;

typedef struct gp_pse {
    gp_pse_cfg_t cfg;
    uint32_t n_chunks;          /* of every state */
    uint32_t round;             /* k */
    int in_round, completed, later_heard, ready_noted, leaving;
    uint32_t leave_said;        /* "past the last round" beacons sent while leaving */
    int taken;                  /* round k's states were handed out: frozen until round k + 1 */
    uint64_t round_start_us, completed_us, done_sent_us, sent_us;
    uint64_t pos_sent_us;       /* our last beacon with our position (| 1: 0 is never) */
    uint64_t polled_us;         /* our last poll (for the time we did not run) */
    uint64_t newcomer_us;       /* when the latest newcomer (a peer never heard before) was heard; 0: none yet */
    const uint8_t *mine;
    uint32_t next_send;         /* our next chunk not sent yet this round (the send window) */
    uint32_t my_crc32;
    double x_m, y_m;            /* ours of round k (before the first round: 0, 0) */
    int next_known;             /* our RoundComplete of k said where we are in k + 1: */
    double next_x_m, next_y_m;  /* there (until round k + 1 begins) */
    uint64_t resent_at[GP_PSE_MAX_CHUNKS]; /* when each chunk of ours was last re-sent (0: never) */
    gp_pse_nearest_t near[2];   /* by round parity */
    gp_pse_buf_t pool[2][GP_PSE_MAX_NEIGHBOURS]; /* by round parity */
    gp_pse_peer_t peer[GP_PSE_MAX_FLEET];
    gp_pse_stats_t stats;
} gp_pse_t;

/* Validates cfg and resets pse. 0 or -EINVAL. */
FS_MUST_CHECK int gp_pse_init(gp_pse_t *pse, const gp_pse_cfg_t *cfg);

/* Starts round k (the first call any k, then previous + 1) and sends our state. 0, -EINVAL. */
FS_MUST_CHECK int gp_pse_begin_round(gp_pse_t *pse, uint32_t round, const uint8_t *state, double x_m, double y_m,
                                     uint64_t now_us);

/* A received message: 0 when it was used, or a negative code saying why it was not (-EALREADY
 * duplicate, -ESTALE an old round or an earlier incarnation, -EAGAIN a round beyond k + 1,
 * -EBADMSG a field out of range or inconsistent, -EILSEQ a CRC mismatch); every case is
 * counted. A request to another peer is taken for what it tells of its sender (0). */
int gp_pse_on_chunk(gp_pse_t *pse, const gp_pse_chunk_t *c, uint64_t now_us);
int gp_pse_on_done(gp_pse_t *pse, const gp_pse_done_t *d, uint64_t now_us);
int gp_pse_on_request(gp_pse_t *pse, const gp_pse_request_t *r, uint64_t now_us);

/* Resend requests and timeouts; call every tick of the round. */
void gp_pse_poll(gp_pse_t *pse, uint64_t now_us);

/* How long the caller may go without a poll when no message comes: 0 while chunks of our state
 * wait for the send window (the next poll sends them), else an eighth of the resend period.
 * Every timer of the poll is a quarter of a resend period or longer, so each then fires within
 * an eighth of a period of its time; a message is handled, and the poll run, as it comes. */
uint64_t gp_pse_idle_us(const gp_pse_t *pse);

/* 1 when every other peer delivered its state of round k or left the round. */
int gp_pse_states_ready(const gp_pse_t *pse);

/* The neighbours of round k (after states_ready): the nearest peers within the radius whose
 * states arrived, at most GP_PSE_MAX_NEIGHBOURS, in ascending id order, with their reassembly
 * buffers (state_bytes each). Returns the count. From this call until gp_pse_begin_round(k + 1)
 * those buffers are the caller's: gp_pse writes none of round k's buffers (see above); a
 * second call in the round returns the same buffers. */
uint32_t gp_pse_neighbours(gp_pse_t *pse, uint32_t ids[GP_PSE_MAX_NEIGHBOURS],
                           const uint8_t *states[GP_PSE_MAX_NEIGHBOURS]);

/* The newest incarnation heard of peer id (0 when none was, or id is out of range). */
uint32_t gp_pse_peer_incarnation(const gp_pse_t *p, uint32_t id);

/* The peers whose state chunks we may keep, as a set of ids (bit i: bits[i / 8] >> (i % 8) & 1):
 * the nearest of rounds k - 1 .. k + 1 as far as they are known, and, in a multicast fleet,
 * every peer never placed yet (before our first round: everyone). The GP core hands it to its
 * network (hal_net_set_senders) so that the chunks of other peers are dropped before they cost
 * anything; what the set misses is asked for again, like a loss, so it changes timing only.
 * An addressed fleet (cfg.addressed) wants no peer before it is placed: there the first state
 * of every member would otherwise cross every connection (in round 0 of 256 robots over
 * ZeroMQ, 255 x 134 KB per robot, which ran a 24 GB machine out of memory), and a state
 * asked for costs one copy. From the round before cfg.same_position_from on, the lowest ids
 * (that round's neighbours) are in it too. Returns the number of ids in the set. */
uint32_t gp_pse_wanted(const gp_pse_t *p, uint8_t bits[GP_PSE_WANTED_BYTES]);

/* Our node update of round k is done: RoundComplete(k) goes out, saying where we will be in
 * round k + 1 when next_xy is not NULL (two finite metres: what gp_pse_begin_round of k + 1
 * will be given; a round begun elsewhere or later opens with its beacon as usual). 0 or
 * -EINVAL. */
FS_MUST_CHECK int gp_pse_complete(gp_pse_t *pse, const double next_xy[2], uint64_t now_us);

/* 1 when round k is over for us: every peer still in the round completed it, or a later round
 * was heard. */
int gp_pse_round_finished(const gp_pse_t *pse);

/* The round to begin after k: k + 1, or the highest round a peer heard within peer_timeout_us
 * is in, when that is further (the caller caps it at its last round). */
uint32_t gp_pse_next_round(const gp_pse_t *pse, uint64_t now_us);

/* The last round finished for us: we linger as a leaver (see above). */
void gp_pse_leave(gp_pse_t *pse, uint64_t now_us);

/* 1 when we are leaving, said so GP_PSE_LEAVE_SAID times, and every other peer still in the
 * round was heard past it too (leaving) or has been silent for GP_PSE_LEAVE_SAID of our
 * leaving beacons' periods: a peer still waiting for us then no longer needs our beacons. The
 * caller lingers until then (and a little more, for the peers to hear our last beacons), or
 * until a peer timeout. The silence rule: a peer that completed the last round and then went
 * quiet has most likely left, its own "past it" beacons lost on the way (64 robots on 2
 * cores: a third of the robots lingered the whole peer timeout at the end of a run for such
 * peers); a live one that still waits for us only waits its own bounded linger in turn, and
 * the models are final by then. */
#define GP_PSE_LEAVE_SAID 3u
int gp_pse_all_left(const gp_pse_t *pse, uint64_t now_us);

/* 1 when we are leaving and every other peer, given up or not, was heard past our round: each
 * finished it (it had our RoundComplete, or gave up on us), so nobody waits for a word of ours
 * and the caller may go at once, without lingering. */
int gp_pse_all_past(const gp_pse_t *pse);

#endif /* GP_GP_PSE_H */
