/* Seeded network fault injection for the host network (hal_host_net.c): a lossy radio
 * between the robots' processes, on demand and repeatable.
 *
 * A spec is comma-separated key=value pairs (host_sim run --net-faults SPEC):
 *   drop=P        probability a datagram is lost
 *   dup=P         probability it is delivered twice
 *   reorder=P     probability it is held back until 1 .. HAL_HOST_NETFAULT_REORDER_MAX later
 *                 datagrams passed it, or hold_ms passed when no later one came
 *   hold_ms=H     that bound, 1 .. HAL_HOST_NETFAULT_MAX_DELAY_MS ms (default
 *                 HAL_HOST_NETFAULT_REORDER_HOLD_MS); a longer one keeps the reordering when
 *                 a busy machine stalls the receiver between datagrams
 *   delay_ms=D    each datagram delayed by a uniform 0 .. D ms
 *   seed=S        base of the injector's random stream (default: the run seed); every robot
 *                 mixes in its own id, so the robots differ and a run repeats
 *   partition=A/B two groups of robot ids, '.'-separated (partition=0.1/2.3.4): every
 *                 datagram from a robot of one group to a robot of the other is lost while
 *   from=T1       the partition is active: from T1 (default 0) until T2 (default: forever)
 *   until=T2      seconds of the network clock since the process opened its network
 * The empty spec injects nothing.
 *
 * Where it acts: on the RECEIVE side, where a datagram enters this process's queue. A drop by
 * one robot's injector hides the datagram from that robot only, as a lossy radio does (the
 * kernel's own multicast drops at the sender, tests/faults/test_faults_procs.c, are the other,
 * correlated case). The partition needs the sender's id: every fleet message on a typed
 * channel starts, after the 8-byte fingerprint, with its sender as a big-endian int32, read
 * only after the bounds check accepted the datagram; untyped channels have no known sender
 * and are never partitioned.
 *
 * Three pieces, each testable alone (tests/hal/test_netfault.c):
 * - the parser (clear messages naming the bad key or value);
 * - hal_host_netfault_decide(): a pure function of (spec, seed, datagram number, sender,
 *   receiver, time); no rand(), no state: the draws of datagram n are the splitmix64 stream
 *   of the seed at positions 6n .. 6n+5, so the same seed makes the same decisions;
 * - the holding area for delayed and reordered datagrams: a fixed number of MTU-sized slots
 *   allocated once (no allocation per datagram). Nothing leaves it except by release: when it
 *   is full the caller releases the entry due first early (_oldest) to make room, so only
 *   the injector's own decisions lose datagrams.
 * Not thread-safe: hal_host_net.c calls it under its queue mutex. */
#ifndef HAL_HOST_NETFAULT_H
#define HAL_HOST_NETFAULT_H

#include <stddef.h>
#include <stdint.h>

#include "hal/hal_net.h"

#ifdef __cplusplus
extern "C" {
#endif

#define HAL_HOST_NETFAULT_MAX_ID 256u          /* robot ids 0 .. 255 in a partition */
#define HAL_HOST_NETFAULT_MAX_DELAY_MS 10000u
#define HAL_HOST_NETFAULT_REORDER_MAX 3u       /* a reordered datagram waits for 1 .. 3 later ones */
#define HAL_HOST_NETFAULT_REORDER_HOLD_MS 20u  /* ... or this long by default, when no later one comes */
#define HAL_HOST_NETFAULT_DRAWS 6u             /* random draws per datagram */

typedef struct hal_host_netfault_cfg {
    double drop, dup, reorder;   /* probabilities, 0 .. 1 */
    uint32_t delay_ms;           /* 0 .. HAL_HOST_NETFAULT_MAX_DELAY_MS */
    uint32_t hold_ms;            /* a reordered datagram's longest hold, 1 .. HAL_HOST_NETFAULT_MAX_DELAY_MS */
    int has_seed;
    uint64_t seed;
    int has_partition;
    uint64_t group[2][HAL_HOST_NETFAULT_MAX_ID / 64u]; /* bit i: robot i is in group A / B */
    double from_s, until_s;      /* active while from_s <= t < until_s (until_s: +inf) */
} hal_host_netfault_cfg_t;

/* 1 when cfg injects anything (an empty spec does not). */
int hal_host_netfault_active(const hal_host_netfault_cfg_t *cfg);

/* Parses `spec` (NULL or "" : nothing injected) into *cfg. 0, or -EINVAL with the reason in
 * err (e.g. "drop=1.5: a probability is 0 .. 1", "unknown key 'lose'"). */
FS_MUST_CHECK int hal_host_netfault_parse(const char *spec, hal_host_netfault_cfg_t *cfg, char *err, size_t errlen);

/* The injector's seed of robot `self`: base (cfg->seed when given, else the run seed) mixed
 * with the robot id. */
uint64_t hal_host_netfault_seed(uint64_t base, uint32_t self);

/* The raw draw k (0 .. HAL_HOST_NETFAULT_DRAWS-1) of datagram `seq` (exposed for tests). */
uint64_t hal_host_netfault_draw(uint64_t seed, uint64_t seq, uint32_t k);

typedef struct hal_host_netfault_decision {
    int partitioned;          /* lost: sender and receiver on two sides of the partition */
    int dropped;              /* lost at random (drop=P) */
    uint32_t copies;          /* 0 when lost, 2 when duplicated, else 1 */
    int reordered;            /* held until `passes` later datagrams were delivered */
    uint32_t passes;          /* 1 .. HAL_HOST_NETFAULT_REORDER_MAX when reordered, else 0 */
    uint32_t delay_us[2];     /* per copy: 0 .. delay_ms * 1000 */
} hal_host_netfault_decision_t;

/* What happens to datagram number `seq` (0, 1, ... in arrival order) from robot `sender`
 * (negative: unknown) at robot `self`, t_us after the network opened. Pure. */
void hal_host_netfault_decide(const hal_host_netfault_cfg_t *cfg, uint64_t seed, uint64_t seq, int32_t sender,
                              uint32_t self, uint64_t t_us, hal_host_netfault_decision_t *d);

/* ---- the holding area ----------------------------------------------------------------- */
typedef struct hal_host_netfault_held {
    int used;
    uint64_t seq;            /* order it was held in (ties of due time release in this order) */
    uint64_t due_us;         /* not released before */
    uint64_t deadline_us;    /* reordered: released by then even if no later datagram came */
    uint32_t passes;         /* reordered: later datagrams still to be delivered before it */
    hal_net_rx_info_t info;  /* channel and len (stamp_us is the queue's business) */
    uint8_t *data;           /* HAL_NET_MTU_BYTES of the area's storage */
} hal_host_netfault_held_t;

typedef struct hal_host_netfault_hold {
    uint32_t cap, fill;
    uint64_t next_seq;
    hal_host_netfault_held_t *e;
    uint8_t *bytes;
} hal_host_netfault_hold_t;

/* Allocates cap slots (1 .. 4096). 0, -EINVAL, -ENOMEM. */
FS_MUST_CHECK int hal_host_netfault_hold_init(hal_host_netfault_hold_t *h, uint32_t cap);
/* Frees the slots (what is still held is discarded). A zeroed or freed area is a no-op. */
void hal_host_netfault_hold_free(hal_host_netfault_hold_t *h);

/* Holds a copy of `len` bytes of `channel`: released at due_us or later, and when passes > 0
 * only after that many later datagrams were delivered (hal_host_netfault_hold_passed) or at
 * deadline_us. 0, -ENOSPC (full: release hal_host_netfault_hold_oldest() first), -EINVAL. */
FS_MUST_CHECK int hal_host_netfault_hold_put(hal_host_netfault_hold_t *h, const char *channel, const void *data, uint32_t len,
                               uint64_t due_us, uint32_t passes, uint64_t deadline_us);
/* The entry to release now (the releasable one due first), or NULL. */
hal_host_netfault_held_t *hal_host_netfault_hold_next(hal_host_netfault_hold_t *h, uint64_t now_us);
/* The entry that becomes releasable first whatever the time (to make room), or NULL. */
hal_host_netfault_held_t *hal_host_netfault_hold_oldest(hal_host_netfault_hold_t *h);
/* Frees an entry returned by _next or _oldest (after the caller copied it out). */
void hal_host_netfault_hold_release(hal_host_netfault_hold_t *h, hal_host_netfault_held_t *e);
/* One datagram was delivered: every held reordered entry waits for one fewer. */
void hal_host_netfault_hold_passed(hal_host_netfault_hold_t *h);
/* The earliest time an entry becomes releasable by time alone (UINT64_MAX when empty). */
uint64_t hal_host_netfault_hold_wake_us(const hal_host_netfault_hold_t *h);

#ifdef __cplusplus
}
#endif

#endif /* HAL_HOST_NETFAULT_H */
