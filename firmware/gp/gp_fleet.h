/* The robot's membership of a fleet: Algorithm 1 (gp_pse) over hal_net, with the firmware's
 * own codec (gp_wire), plugged into the GP core as its peers hooks (gp_peers_ops_t).
 *
 * Channels of fleet F: GP_FLEET_CHANNEL_PREFIX "<F>/state" (state_chunk_t), ".../done"
 * (round_complete_t) and ".../request" (chunk_request_t). Every datagram is decoded with every
 * length checked (gp_wire) and then validated by the protocol (gp_pse); what fails is counted.
 *
 * Time. The network lives in real time (hal_net_clock_us), the robot in its core clock: on the
 * host the lockstep's simulated time, which stands still while the GP core waits for its peers
 * inside one tick (hal_net_wait). So a round costs no simulated time for the network, and the
 * simulated timeline of every robot is the same however fast the other processes run.
 *
 * A round k as the GP core drives it: the round's logic (when to begin, when the states are
 * there, the skip-ahead, leaving after the last round) is the I/O-free driver gp_round, the
 * one the protocol simulation runs; this file only feeds it and waits:
 *   exchange(k)     (AI published state(k)) gp_round_want(k), then receive and step the driver
 *                   (waiting at most poll_us at a time) until it says BEGIN: encode our state
 *                   (dinno_codec: fp32, or int8 / 4-bit with per-row scales) and begin with our position
 *                   of round k (offline: the point at fraction k / rounds of the tour, as the
 *                   in-process reference; online: the robot's pose); then until READY: point
 *                   the view at the neighbours' states (disk radius on the carried positions,
 *                   or every peer) where gp_pse reassembled them: fp32 read in place, the
 *                   quantised codecs expanded in place once (only the row scales need room
 *                   of their own: qscales);
 *   round_done(k)   (AI's checkpoint of k) gp_round_node_done; after the last round, receive
 *                   and step until the driver says DONE (every peer finished, we left);
 *   next_round(k)   the driver's skip-ahead;
 *   service()       every tick: receive, answer resend requests, resend ours.
 * The waits end by the protocol's timeouts: a peer silent too long leaves the round.
 *
 * Per-round records (traffic, waiting time, neighbours, disagreement) go into a ring the host
 * reads between lockstep slices, like the GP core's round log.
 *
 * Storage: gp_fleet_t is static (the image owns it: fw_robot_fleet()); sized from
 * BOARD_MAX_FLEET (the largest fleet), BOARD_MAX_PEERS (the neighbours one round takes in), the
 * preset
 * and the board's datagram. No allocation. Little-endian boards (fp32 states travel as raw
 * IEEE-754 little-endian words). */
#ifndef GP_GP_FLEET_H
#define GP_GP_FLEET_H

#include <stdatomic.h>
#include <stdint.h>

#include "ai/bnn.h"
#include "ai/bnn_quant.h"
#include "ai/dinno_codec.h"
#include "gp/gp_core.h"
#include "gp/gp_goal.h"
#include "gp/gp_pse.h"
#include "gp/gp_round.h"
#include "hal/hal_net.h"
#include "rt/rt_follow.h"

#define GP_FLEET_CHANNEL_PREFIX "fleetsim/"
#define GP_FLEET_LOG_ROUNDS 1024u
/* Chunks sent per turn of the wait loop (between two receives): a large state (the paper
 * preset's 36 chunks) goes out in windows, so that 7 peers sending at once do not overrun
 * each other's receive buffers (LCM's own is about 1 MB). */
#define GP_FLEET_SEND_BURST 4u
#define GP_FLEET_MAX_TOUR RT_CORE_MAX_WAYPOINTS

/* A fleet's states travel in one of the exchange codecs (ai/dinno_codec.h); the names before
 * them, kept for callers elsewhere, are aliases with the same values. */
typedef dinno_codec_t gp_fleet_encoding_t;
#define GP_FLEET_FP32 DINNO_CODEC_FP32
#define GP_FLEET_INT8 DINNO_CODEC_INT8

/* The protocol's defaults (gp_fleet_default_cfg), named once: host_sim run's options start from
 * them and `host_sim defaults` prints them for the launchers (tools/fleet). 10 s / 50 ms: a live
 * peer speaks at least once per resend period, so it is not timed out for a few lost datagrams;
 * 120 s before a peer is first heard: the others may still be starting up (offline: driving
 * their tours first). */
#define GP_FLEET_ENCODING_DEFAULT DINNO_CODEC_FP32
#define GP_FLEET_RESEND_AFTER_US_DEFAULT 50000u     /* 50 ms */
#define GP_FLEET_PEER_TIMEOUT_US_DEFAULT 10000000u  /* 10 s */
#define GP_FLEET_JOIN_TIMEOUT_US_DEFAULT 120000000u /* 120 s */
#define GP_FLEET_POLL_US_DEFAULT 2000u              /* 2 ms */
#define GP_FLEET_CHUNK_BYTES_DEFAULT 0u             /* 0: GP_PSE_MAX_CHUNK_BYTES */
_Static_assert(GP_FLEET_PEER_TIMEOUT_US_DEFAULT > 2u * GP_FLEET_RESEND_AFTER_US_DEFAULT,
               "a live peer speaks once per resend period: the timeout must exceed two");
_Static_assert(GP_FLEET_JOIN_TIMEOUT_US_DEFAULT >= GP_FLEET_PEER_TIMEOUT_US_DEFAULT, "gp_pse's check");
typedef enum gp_fleet_channel {
    GP_FLEET_CH_STATE = 0,
    GP_FLEET_CH_DONE = 1,
    GP_FLEET_CH_REQUEST = 2,
    GP_FLEET_CH_CLAIM = 3, /* exploring fleets only (gp_fleet_cfg_t.claims) */
    /* A robot's own channels, in addressed fleets only (gp_fleet_cfg_t.addressed), named
       PREFIX<fleet>/<suffix>/<robot> (gp_fleet_robot_channel): */
    GP_FLEET_CH_RESEND = 4, /* chunks re-sent to this robot alone */
    GP_FLEET_CH_ASK = 5,    /* requests for this robot's chunks */
} gp_fleet_channel_t;
#define GP_FLEET_CHANNELS 6

typedef struct gp_fleet_cfg {
    uint32_t fleet_id;
    uint32_t self, n_peers;          /* self < n_peers <= GP_PSE_MAX_FLEET */
    uint32_t rounds;                 /* DiNNO rounds of the run (tour fractions) */
    uint32_t post_rounds;            /* then the epistemic posterior's rounds (ai_core.h): every
                                        robot at one position (the whole fleet its neighbours), no
                                        disagreement; fp32 states only */
    double radius_m;                 /* disk graph radius; <= 0: every peer */
    dinno_codec_t encoding;          /* every member's the same (the chunks carry it) */
    uint32_t incarnation;
    uint32_t chunk_bytes;            /* 0: GP_PSE_MAX_CHUNK_BYTES */
    uint32_t resend_after_us;        /* ask again for missing chunks (GP_FLEET_RESEND_AFTER_US_DEFAULT) */
    uint32_t peer_timeout_us;        /* a silent peer leaves the round (GP_FLEET_PEER_TIMEOUT_US_DEFAULT) */
    uint32_t join_timeout_us;        /* the same before a peer was ever heard (..._JOIN_TIMEOUT_...) */
    uint32_t poll_us;                /* longest single hal_net_wait while our state goes out
                                        (GP_FLEET_POLL_US_DEFAULT); else gp_pse_idle_us, if longer */
    int positions_from_tour;         /* 1: round k at fraction k / rounds of the tour (offline);
                                        0: the robot's pose when the round starts (online) */
    const rt_waypoint_t *tour;       /* copied; needed with positions_from_tour */
    int32_t n_tour;
    int claims;                      /* 1: exploring with goal claims: the claim channel is used.
                                        Our claim of round k (seq = k) goes out ahead of chunk 0
                                        of our state of k and of each positioned beacon of k, sent
                                        or sent again: whatever places us reaches a peer after it
                                        (each sender's order holds). Received ones are kept per
                                        peer (gp_goal_inbox_t) and handed over at our round k for
                                        seq <= k, each once. */
    int addressed;                   /* 1: a request goes to the robot asked alone and a chunk
                                        sent again to the robot that asked alone, each on that
                                        robot's own channel (gp_pse_cfg_t's), for a point-to-
                                        point transport (ZeroMQ). 0: to every robot, on the
                                        request and state channels (multicast: LCM) */
    int ordered;                     /* 1: the transport keeps each sender's order (TCP:
                                        ZeroMQ), so a missing chunk is asked for on the
                                        sender's next word rather than a timer (gp_pse_cfg_t) */
} gp_fleet_cfg_t;

/* One round as this robot saw it (traffic counts are the round's own). */
typedef struct gp_fleet_round {
    uint32_t round;
    uint32_t neighbours;
    float disagreement;              /* ||theta - mean of neighbours|| / ||mean||; NaN without */
    uint64_t wait_us;                /* real time the GP core waited for the peers */
    uint64_t wall_us;                /* real time from the round's start to the next one's */
    uint64_t bytes_sent, bytes_received;
    uint64_t chunks_sent, chunks_received, chunks_resent, chunks_requested;
    uint64_t duplicates, stale, timeouts, rejoins, crc_failures, invalid;
    uint64_t chunks_recovered;       /* chunks that came only after we asked again */
    uint64_t states_missed;          /* peers' states the round went on without */
    uint64_t chunks_lost;            /* their chunks never received */
    uint64_t beacons_sent, restarts, old_incarnation, rounds_skipped;
} gp_fleet_round_t;

typedef struct gp_fleet_stats {
    uint64_t rx_messages;            /* datagrams taken from hal_net */
    uint64_t rx_undecodable;         /* refused by gp_wire (or on an unknown channel) */
    uint64_t own_echoes;             /* our own datagrams delivered back (LCM does) */
    uint64_t tx_failed;              /* publishes refused by hal_net */
    uint64_t decode_failures;        /* neighbour states that did not decode (fp32 values, scales) */
    uint64_t wait_us;                /* total real time spent waiting */
    uint64_t senders_set;            /* the set of peers whose chunks we take, handed to hal_net */
    uint64_t claims_sent, claims_received, claims_handed;
} gp_fleet_stats_t;

typedef struct gp_fleet {
    gp_fleet_cfg_t cfg;
    bnn_config_t bnn;
    gp_round_t drv;                  /* the round driver and the protocol inside it */
    gp_fleet_stats_t stats;
    uint32_t state_bytes;
    int final_done;
    int view_filled;                 /* the neighbour view holds the states of the round begun */
    char channel[GP_FLEET_CHANNELS][HAL_NET_CHANNEL_MAX]; /* CH_RESEND, CH_ASK: our own */
    char channel_to[HAL_NET_CHANNEL_MAX]; /* the channel of the one robot a message goes to */
    gp_goal_inbox_t claim_in[GP_PSE_MAX_FLEET]; /* per peer: its claims not handed over yet */
    uint32_t claims_handed_upto;     /* with claims_handed_any: the round last handed over */
    int claims_handed_any;
    gp_goal_claim_t claim_out;       /* our claim of the round begun, with claim_out_held */
    int claim_out_held;
    /* The peers whose chunks the network delivers (gp_pse_wanted); all of them while
       senders_all, and always when the board cannot filter (senders_off). */
    uint8_t senders[GP_PSE_WANTED_BYTES];
    int senders_all, senders_off;
    gp_pse_stats_t mark;             /* pse counters when the current record began */
    gp_fleet_round_t cur;            /* the record of the round in progress */
    int have_cur;
    uint64_t cur_started_us;
    _Atomic uint32_t n_log;
    gp_fleet_round_t log[GP_FLEET_LOG_ROUNDS];
    rt_waypoint_t tour[GP_FLEET_MAX_TOUR];
    float qscales[BNN_QUANT_MAX_ROWS]; /* a quantised state's row scales while it expands in place */
    _Alignas(64) uint8_t mine[GP_PSE_MAX_STATE_BYTES];
    _Alignas(64) uint8_t tx[HAL_NET_MTU_BYTES];
    _Alignas(64) uint8_t rx[HAL_NET_MTU_BYTES];
} gp_fleet_t;

/* One robot alone, round 1, the GP_FLEET_*_DEFAULT encoding and timings. */
gp_fleet_cfg_t gp_fleet_default_cfg(void);

/* The channel name of `which` (a fleet-wide one: state, done, request, claim) for fleet
   `fleet_id` into buf. 0 or -EINVAL. */
FS_MUST_CHECK int gp_fleet_channel_name(uint32_t fleet_id, gp_fleet_channel_t which, char *buf, size_t cap);
/* Robot `robot`'s own channel `which` (GP_FLEET_CH_RESEND or GP_FLEET_CH_ASK) in fleet
   `fleet_id` into buf. 0 or -EINVAL. */
FS_MUST_CHECK int gp_fleet_robot_channel(uint32_t fleet_id, gp_fleet_channel_t which, uint32_t robot, char *buf,
                                         size_t cap);
/* The name of channel `which` as the robot cfg describes receives it (the fleet's, or its own
   for CH_RESEND and CH_ASK) into buf: 0; -ENOENT when it does not use that channel (the claims
   of a fleet that does not explore, its own channels in a multicast fleet); -EINVAL. */
FS_MUST_CHECK int gp_fleet_channel_of(const gp_fleet_cfg_t *cfg, gp_fleet_channel_t which, char *buf, size_t cap);

/* State bytes of one encoded state of the preset (dinno_codec_bytes; 0 for a bad codec). */
uint32_t gp_fleet_state_bytes(dinno_codec_t enc);

/* Validates cfg, resets f and subscribes to the fleet's channels (the board must be
 * installed). 0, -EINVAL or the HAL's error. */
FS_MUST_CHECK int gp_fleet_init(gp_fleet_t *f, const gp_fleet_cfg_t *cfg);

/* The hooks for gp_core_cfg_t.peers (ctx: the gp_fleet_t). */
extern const gp_peers_ops_t gp_fleet_peers_ops;

/* For the host between lockstep slices (all cores blocked) or after the cores stopped. */
uint32_t gp_fleet_rounds_logged(gp_fleet_t *f);
const gp_fleet_round_t *gp_fleet_round(gp_fleet_t *f, uint32_t i);

#endif /* GP_GP_FLEET_H */
