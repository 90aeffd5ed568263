/* State shared by the files of the host board (hal_host.c: life cycle and adapters,
 * hal_host_sched.c: the lockstep scheduler and the clock, hal_host_cores.c: core threads on
 * static stacks, hal_host_log.c: the log). Not part of the board's API.
 *
 * Scheduler state (all under h->mu): each core is UNUSED, SLEEPING (blocked, waiting for
 * `wake_us`), RUNNING (released; it runs until it blocks again) or DONE. The controlling
 * thread waits on h->sched_cv until no core is RUNNING, then advances time and releases the
 * next core(s); a core waits on its own condition variable. Releasing exactly one core at a
 * time (serial mode) makes the interleaving of cores a pure function of simulated time. */
#ifndef HAL_HOST_PRIV_H
#define HAL_HOST_PRIV_H

#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <time.h>

#include "hal_host.h"

/* Static stacks: page-aligned as pthread_attr_setstack() wants. glibc places the thread's
 * control block and static TLS at the top of a caller-provided stack, so each array holds
 * the board's stack plus a reserve for them; the high-water mark and the size reported
 * count only what lies below the core thread's first frame. ThreadSanitizer keeps about
 * 1 MB of per-thread state in static TLS, hence the larger reserve in that build. */
#if defined(__SANITIZE_THREAD__)
#define STACK_RESERVE (2u * 1024u * 1024u)
#else
#define STACK_RESERVE (64u * 1024u)
#endif

typedef enum { CORE_UNUSED = 0, CORE_SLEEPING, CORE_RUNNING, CORE_DONE } core_state_t;

typedef struct host_core {
    hal_host_t *h;
    hal_core_id_t id;
    hal_core_entry_t entry;
    void *arg;
    pthread_t thread;
    pthread_cond_t cv;
    /* under h->mu */
    core_state_t state;
    int joined;
    uint64_t wake_us;
    hal_host_core_stats_t stats;
    /* owned by the core's thread */
    struct timespec tick_start;
    int tick_open;
    void (*asleep_fn)(void *arg); /* hal_clock_while_asleep: real-time work while it sleeps */
    void *asleep_arg;
    uint32_t asleep_every_us;
    /* bytes above the core's first frame (TCB, TLS, thread start): set by the core before
     * its first release, read after (ordered by h->mu) */
    size_t stack_top_bytes;
} host_core_t;

struct hal_host {
    hal_host_config_t cfg;
    hal_board_t board;

    pthread_mutex_t mu;
    pthread_cond_t sched_cv;
    _Atomic uint64_t now_us; /* written under mu while every core is blocked */
    int stopping;
    int stopped;
    uint64_t world_steps;
    uint64_t watchdog_reports;
    host_core_t core[HAL_CORE_COUNT];

    pthread_mutex_t world_mu; /* serialises world callbacks (parallel mode) */
    hal_host_net_t *net;
    hal_host_storage_t *storage;
};

/* The core the calling thread runs (NULL on other threads), for the log and sleep_until. */
extern _Thread_local host_core_t *hal_host_tls_core;

extern const hal_clock_ops_t hal_host_clock_ops; /* hal_host_sched.c */
extern const hal_core_ops_t hal_host_core_ops;   /* hal_host_cores.c */
extern const hal_log_ops_t hal_host_log_ops;     /* hal_host_log.c */

/* h->mu held by core c: tick accounting at the moment it blocks (hal_host_sched.c). */
void hal_host_tick_end(host_core_t *c);
/* Gives the static stacks back once h has stopped (hal_host_cores.c). */
void hal_host_stacks_release(hal_host_t *h);

#endif /* HAL_HOST_PRIV_H */
