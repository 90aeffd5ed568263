/* Host back end of the HAL: the firmware image's three cores as POSIX threads, run in
 * LOCKSTEP with simulated time against a world (host_sim) reached through callbacks.
 *
 * Lockstep (a deterministic discrete-event scheduler over real threads)
 * - The simulated clock only advances when every started core is blocked in
 *   hal_sleep_until_us() (or has returned from its entry). It then advances to the earliest
 *   wake-up time t: first the world's advance_to_us(t) runs (physics), then the cores
 *   waiting for t are released. A core's computation therefore takes zero simulated time,
 *   every tick starts exactly at the time it asked for (lateness 0), and results do not
 *   depend on how the OS schedules the threads or how loaded the machine is.
 * - HAL_HOST_SCHED_SERIAL (default): cores due at the same instant are released one at a
 *   time in core-id order (RT, GP, AI), the next when the previous blocks again. Everything
 *   the cores exchange (rings, mailboxes) is then ordered identically in every run, so two
 *   runs with the same inputs are bit-identical. HAL_HOST_SCHED_PARALLEL releases them
 *   together (faster on a multi-core machine; simulated time is still lockstep, but the
 *   order of events within one instant is up to the OS).
 * - The scheduler runs on the thread that calls hal_host_run_until() (the host's main).
 *
 * Threads and memory
 * - Each core runs on a pthread whose stack is a static array of BOARD_STACK_<core>_BYTES
 *   (pthread_attr_setstack), whose pages are dropped (MADV_DONTNEED) before the start; the
 *   high-water mark is the bytes from the top down to the start of the deepest page the thread
 *   touched (resident, by mincore()): exact to a page, over by less than 4 KB, never under
 *   (unless a stack page was swapped out). Unlike painting, this keeps the untouched part of
 *   the stacks out of RSS. Because the stacks are static, at most one
 *   hal_host_t can have started cores at a time (-EBUSY otherwise).
 * - hal_host_create() allocates everything (network queue included); nothing allocates in
 *   this back end once the cores run.
 * - The clock is for simulation; clock_gettime(CLOCK_MONOTONIC) is used only to profile the
 *   wall time spent per tick.
 *
 * Thread-safety: hal_host_create/run_until/stop/destroy from one controlling thread (not a
 * core). hal_host_core_stats() from any thread.
 */
#ifndef HAL_HOST_H
#define HAL_HOST_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "hal/hal.h"
#include "hal_host_auth.h"
#include "hal_host_netfault.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The world, as the host back end sees it. host_sim's world plugs in through an adapter that
 * fills this struct. `robot` is the config's robot_id. The back end serialises every call
 * (one mutex), and advance_to_us() only runs while every core is blocked, so the world needs
 * no locking of its own. Every callback returns 0 or a negative errno code. */
typedef struct hal_host_world {
    void *ctx;
    /* Required. Advance physics to simulated time t_us (strictly increasing between calls,
     * first call > 0). A failure stops hal_host_run_until() with that code. */
    int (*advance_to_us)(void *ctx, uint64_t t_us);
    /* Optional (no lidar interface without it). The robot's current scan, stamped. */
    int (*read_scan)(void *ctx, uint32_t robot, hal_lidar_scan_t *scan);
    /* Optional (no pose interface without it). The robot's current pose, stamped. */
    int (*read_pose)(void *ctx, uint32_t robot, hal_pose_t *pose);
    /* Optional (no motor interface without it). Wheel angular velocities in rad/s. */
    int (*set_wheels)(void *ctx, uint32_t robot, float left_rad_s, float right_rad_s);
} hal_host_world_t;

typedef enum hal_host_sched {
    HAL_HOST_SCHED_SERIAL = 0,
    HAL_HOST_SCHED_PARALLEL = 1
} hal_host_sched_t;

/* Default network URL: LCM UDP multicast, never leaving the host (ttl=0), with a large
 * receive buffer (the kernel caps it at net.core.rmem_max: raise that with sysctl for
 * 60 KB messages at rate: a round of 7 robots of the paper preset sends 15 MB at once). */
#define HAL_HOST_NET_URL_DEFAULT "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=33554432"
#define HAL_HOST_NET_QUEUE_DEFAULT 64u
/* The network's receive queue is a byte ring (hal_host_net.c): a message takes a
 * HAL_HOST_NET_ENTRY_HEADER-byte header and its bytes rounded up to 8. It holds at most
 * net_queue_depth messages (HAL_HOST_NET_QUEUE_MAX at most) and net_queue_bytes bytes. */
#define HAL_HOST_NET_QUEUE_MAX 16384u
#define HAL_HOST_NET_ENTRY_HEADER 16u
#define HAL_HOST_NET_ENTRY_BYTES(len) ((size_t)HAL_HOST_NET_ENTRY_HEADER + (((size_t)(len) + 7u) & ~(size_t)7u))
#define HAL_HOST_NET_QUEUE_BYTES_MIN (2u * HAL_HOST_NET_ENTRY_BYTES(HAL_NET_MTU_BYTES)) /* a configuration's */
#define HAL_HOST_NET_QUEUE_BYTES_MAX ((size_t)256u << 20)
#define HAL_HOST_NET_MAX_SUBS 16u

typedef struct hal_host_config {
    const char *board_name;     /* NULL: BOARD_NAME */
    uint32_t robot_id;          /* passed to the world callbacks */
    const hal_host_world_t *world; /* NULL: no world (no lidar, pose, motors; physics idle) */
    hal_host_sched_t sched;
    /* Geometry for hal_motor_set_twist(); both > 0 to offer it, else it is -ENOTSUP. */
    float wheel_radius_m;
    float wheel_separation_m;
    /* Network: NULL for none, "" for HAL_HOST_NET_URL_DEFAULT, else an LCM URL
     * (memq:// in tests). */
    const char *net_url;
    uint32_t net_queue_depth;   /* messages: 0: HAL_HOST_NET_QUEUE_DEFAULT; at most HAL_HOST_NET_QUEUE_MAX */
    /* Bytes of the receive ring: 0: hal_host_net_queue_bytes_default(depth), else
     * HAL_HOST_NET_QUEUE_BYTES_MIN .. HAL_HOST_NET_QUEUE_BYTES_MAX (two MTU-sized datagrams
     * at least: one being read while the next arrives). */
    size_t net_queue_bytes;
    /* Faults injected into what this board receives (hal_host_netfault.h spec; NULL or "":
     * none; needs net_url). Its random stream: the spec's seed= or else net_faults_seed (the
     * run seed), mixed with robot_id. */
    const char *net_faults;
    uint64_t net_faults_seed;
    /* A keyed fleet (hal_host_auth.h): the key and run id, copied; NULL: unkeyed. */
    const hal_host_auth_t *net_auth;
    /* Storage: NULL for none, else a directory (created if missing, one level). */
    const char *storage_dir;
    hal_log_level_t log_level;  /* messages above this level are dropped */
    /* Wall-clock watchdog for debugging firmware: when a core runs this many milliseconds
     * of wall time without sleeping, a line naming it goes to stderr (again after each
     * further period). 0 turns it off. It never changes the simulation. */
    uint32_t watchdog_ms;
    int log_fd;                 /* where log lines go; 0 means stderr (fd 2) */
} hal_host_config_t;

/* The defaults: serial lockstep, no world, net, storage; log INFO to stderr. */
hal_host_config_t hal_host_config_default(void);

typedef struct hal_host hal_host_t;

/* Creates a host board from cfg (validated: -EINVAL with a message on stderr) and opens the
 * network (-EIO when LCM cannot be created on the URL) and storage (-EIO). Does not install
 * it: call hal_board_install(hal_host_board(h)). */
FS_MUST_CHECK int hal_host_create(const hal_host_config_t *cfg,
                                                        hal_host_t **out);

/* The board to install. Valid until hal_host_destroy(). */
const hal_board_t *hal_host_board(const hal_host_t *h);
typedef struct hal_host_net hal_host_net_t;
/* The network of h (NULL without one), e.g. to type its channels (hal_host_net_expect_type). */
hal_host_net_t *hal_host_get_net(hal_host_t *h);

/* Runs the lockstep scheduler until simulated time t_end_us: every wake-up at a time
 * <= t_end_us is processed, then the world is advanced to t_end_us and the clock reads
 * t_end_us. May be called repeatedly with growing t_end_us. Returns 0, -EINVAL
 * (t_end_us < now), -ECANCELED (already stopped), -EINTR (a stop was requested,
 * hal_host_stop.h: it returns as soon as every core is blocked, the clock short of t_end_us;
 * stop the board then) or the world's error. While a stop is requested the network's wait
 * (hal_net_wait) returns -ECANCELED at once, so a core waiting for peers blocks soon. */
FS_MUST_CHECK int hal_host_run_until(hal_host_t *h, uint64_t t_end_us);

/* Stops the cores: each blocked core's hal_sleep_until_us() returns -ECANCELED (serial mode:
 * one at a time in core-id order), every later call too; waits for every entry to return
 * and joins the threads. A core that was started but never released does not run. */
void hal_host_stop(hal_host_t *h);

/* Stops if needed, uninstalls the board if it is installed, closes and frees. NULL is a
 * no-op. */
void hal_host_destroy(hal_host_t *h);

/* Simulated now, microseconds. */
uint64_t hal_host_now_us(const hal_host_t *h);

/* Names the calling thread for top, perf and gdb ("RT", "GP", "AI", "net-rx", ...: at most 15
 * characters); a no-op where the OS has no such name. */
void hal_host_name_thread(const char *name);

typedef struct hal_host_core_stats {
    int started;               /* 1 once hal_core_start() succeeded for this core */
    int finished;              /* 1 once its entry returned */
    uint64_t ticks;            /* returns of hal_sleep_until_us() with 0 */
    uint64_t late_ticks;       /* ticks that started after the time asked for */
    uint64_t lateness_max_us;  /* max of (time the tick started - time asked for) */
    uint64_t lateness_total_us;
    /* Wall time from a tick's start to the core's next hal_sleep_until_us() (profiling
     * only; the simulation never reads it). Over `ticks` ticks that ended. */
    uint64_t wall_ticks;
    uint64_t wall_min_ns;
    uint64_t wall_max_ns;
    uint64_t wall_total_ns;
    size_t stack_used_bytes;   /* high-water mark now */
    size_t stack_size_bytes;
} hal_host_core_stats_t;

/* Per-core figures. 0 or -EINVAL. */
FS_MUST_CHECK int hal_host_core_stats(hal_host_t *h, hal_core_id_t id,
                                                            hal_host_core_stats_t *stats);

/* Times the watchdog reported a core (see hal_host_config_t.watchdog_ms). */
uint64_t hal_host_watchdog_reports(const hal_host_t *h);

/* Physics steps run so far (calls of advance_to_us), for tests and profiling. */
uint64_t hal_host_world_steps(const hal_host_t *h);

/* ---- pieces, usable on their own (tests, tools) --------------------------------------- */

/* Network over LCM. A receiver thread (from the first subscription on) moves datagrams into
 * the bounded queue as they arrive; the calls below may come from one other thread. The queue
 * holds at most queue_depth messages (1 .. HAL_HOST_NET_QUEUE_MAX) in a byte ring of
 * queue_bytes bytes (rounded up to 8), allocated here once: 0 for
 * hal_host_net_queue_bytes_default(queue_depth), else from one MTU-sized entry
 * (HAL_HOST_NET_ENTRY_BYTES(HAL_NET_MTU_BYTES)) to HAL_HOST_NET_QUEUE_BYTES_MAX; -EINVAL
 * outside. A datagram whose entry does not fit the free bytes is dropped (rx_dropped_full). */
FS_MUST_CHECK int hal_host_net_open(const char *url, uint32_t queue_depth, size_t queue_bytes,
                                                          hal_host_net_t **out);
/* The ring of queue_bytes 0: queue_depth x 4 KB, at least 4 MTU-sized entries. */
size_t hal_host_net_queue_bytes_default(uint32_t queue_depth);
void hal_host_net_close(hal_host_net_t *n);
FS_MUST_CHECK int hal_host_net_publish(hal_host_net_t *n,
                                                             const char *channel,
                                                             const void *data, size_t len);
FS_MUST_CHECK int hal_host_net_subscribe(hal_host_net_t *n,
                                                               const char *channel);
/* Declares that `channel` carries only messages of `type` (hal_host_msg.h): from then on a
 * datagram on it that fails hal_host_msg_check() is dropped before it is queued and counted
 * in rx_dropped_malformed. HAL_HOST_MSG_ANY makes it raw again. 0, -EINVAL or -ENOSPC. */
FS_MUST_CHECK int hal_host_net_expect_type(hal_host_net_t *n, const char *channel,
                                                                 int type);
/* Pops the oldest queued message without waiting (-EAGAIN when none). stamp_us is recorded
 * as the queue time of what arrives next. */
FS_MUST_CHECK int hal_host_net_receive(hal_host_net_t *n, uint64_t stamp_us,
                                                             hal_net_rx_info_t *info, void *buf,
                                                             size_t cap);
/* Waits up to timeout_ms of wall time until a message is queued (returns at once if one is).
 * 0, or -EIO when the transport failed. */
FS_MUST_CHECK int hal_host_net_wait(hal_host_net_t *n, uint64_t stamp_us,
                                                          int timeout_ms);
/* Messages waiting in the queue now. */
uint32_t hal_host_net_queued(const hal_host_net_t *n);
void hal_host_net_get_stats(const hal_host_net_t *n, hal_net_stats_t *stats);
/* Injects the faults of cfg into what n receives from now on (hal_host_netfault.h), with the
 * random stream `seed` (hal_host_netfault_seed) at robot `self`. Before the first subscribe.
 * 0, -EINVAL, -EBUSY (subscribed already, or faults set before), -ENOMEM. */
FS_MUST_CHECK int hal_host_net_set_faults(hal_host_net_t *n, const hal_host_netfault_cfg_t *cfg,
                                          uint64_t seed, uint32_t self);
/* Tells n its fleet id: a datagram on a typed (fleet) channel whose sender field is `self` is
 * this node's own publish come back (LCM multicast delivers those) and is dropped before its
 * tag is checked, which saves 1/N of a keyed member's verifications (rx_own). A forged datagram
 * claiming this id is dropped the same way. Before the first subscribe: 0, -EINVAL, -EBUSY. */
FS_MUST_CHECK int hal_host_net_set_self(hal_host_net_t *n, uint32_t self);
/* Makes n a member of a keyed fleet (hal_host_auth.h): every datagram it publishes carries
 * the trailer, and one it receives without a valid tag of this key and run is dropped before
 * the bounds check (rx_dropped_unauth, rx_dropped_replay). Before the first subscribe; a
 * member's MTU stays HAL_NET_MTU_BYTES (the trailer rides on top). 0, -EINVAL, -EBUSY,
 * -EIO (libsodium), -ENOMEM. */
FS_MUST_CHECK int hal_host_net_set_auth(hal_host_net_t *n, const hal_host_auth_t *auth);
/* Neighbour-scoped delivery (hal_net_set_senders): from now on only datagrams of the typed,
 * subscribed `channel` whose sender's bit is set in `wanted` (n_ids bits; NULL: every sender
 * again) are delivered; the others are dropped on arrival before the tag check and counted
 * (rx_unwanted), and over ZeroMQ not even sent by their publishers once the change reached
 * them (hal_host_net_zmq.c). The same set again does no transport work. One thread at a time
 * (the GP core's). 0, -EINVAL (n or channel bad, n_ids > BOARD_MAX_FLEET, the channel not
 * subscribed or not typed: hal_host_net_expect_type), -EIO (the transport). */
FS_MUST_CHECK int hal_host_net_set_senders(hal_host_net_t *n, const char *channel, const uint8_t *wanted,
                                           uint32_t n_ids);
/* Carries the typed `channel` per sender (LCM udpm:// only, hal_host_net_lcm.c): each sender
 * publishes it to a multicast group and port of its own (the URL's + 1 + its id), and a
 * receiver hears only the senders hal_host_net_set_senders wants (none before the first call):
 * the kernel never copies the others' datagrams. Call it before the first subscription, at
 * every member of the fleet (one fleet, one way); it takes the 1,024 ports after the URL's.
 * 0, -EINVAL (not typed), -ENOTSUP (not udpm://, or ZeroMQ: it scopes by topic), -ENOSPC
 * (another channel is grouped already), -EBUSY (subscribed already), -EIO. */
FS_MUST_CHECK int hal_host_net_group_by_sender(hal_host_net_t *n, const char *channel);
/* The channels `prefix`<id> (id decimal, < BOARD_MAX_FLEET) carried to robot id alone (LCM
 * udpm:// only): on a group and port of its own (the URL's + 1,025 + id), which only a process
 * subscribed to such a channel of that id joins. For what is for one robot (a request naming
 * its chunks, the chunks it asked for). The same rules as hal_host_net_group_by_sender; at most
 * 4 prefixes. */
FS_MUST_CHECK int hal_host_net_group_by_receiver(hal_host_net_t *n, const char *prefix);

/* The ZeroMQ proxy of a fleet too large for the full mesh (host_sim zmq-proxy): binds
 * tcp://HOST:PORT, which the robots' publishers connect to ("zmq://?proxy=HOST:PORT"), and
 * tcp://HOST:PORT+1, which their subscribers connect to, and forwards each datagram to the
 * robots subscribed to its topic (neighbour-scoped delivery holds), subscriptions the other
 * way, until *stop is set (within 200 ms). Each robot then holds 2 connections instead of
 * 2 (N - 1). `progress` (or NULL) is called after every poll with the running counts.
 * 0 when stopped, -EINVAL (a bad host or port), -EIO (cannot bind, or ZeroMQ failed). */
typedef struct hal_host_zmq_proxy_stats {
    uint64_t frames, bytes;             /* datagrams forwarded to subscribers, and their bytes */
    uint64_t overflows;                 /* a subscriber's queue found full (its high-water mark):
                                           its copy dropped, and its next ones until it drained */
    uint64_t subscriptions, sub_bytes;  /* (un)subscriptions forwarded to publishers */
} hal_host_zmq_proxy_stats_t;
FS_MUST_CHECK int hal_host_zmq_proxy_run(const char *host, unsigned port, const atomic_int *stop,
                                         void (*progress)(const hal_host_zmq_proxy_stats_t *s, void *user),
                                         void *user);

/* Storage in a directory. Thread-safe as far as the file system is (one writer per name). */
typedef struct hal_host_storage hal_host_storage_t;
FS_MUST_CHECK int hal_host_storage_open(const char *dir,
                                                              hal_host_storage_t **out);
void hal_host_storage_close(hal_host_storage_t *s);
FS_MUST_CHECK int hal_host_storage_write(hal_host_storage_t *s,
                                                               const char *name,
                                                               const void *data, size_t len);
FS_MUST_CHECK int hal_host_storage_read(hal_host_storage_t *s,
                                                              const char *name, void *buf,
                                                              size_t cap, size_t *len);
FS_MUST_CHECK int hal_host_storage_remove(hal_host_storage_t *s,
                                                                const char *name);

#ifdef __cplusplus
}
#endif

#endif /* HAL_HOST_H */
