/* Host board: lockstep scheduler, core threads on painted static stacks, clock, log, and the
 * adapters from the HAL operation tables to the world binding, LCM and the storage dir.
 *
 * Scheduler state (all under h->mu): each core is UNUSED, SLEEPING (blocked, waiting for
 * `wake_us`), RUNNING (released; it runs until it blocks again) or DONE. The controlling
 * thread waits on h->sched_cv until no core is RUNNING, then advances time and releases the
 * next core(s); a core waits on its own condition variable. Releasing exactly one core at a
 * time (serial mode) makes the interleaving of cores a pure function of simulated time. */
#include "hal_host.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>


#define STACK_PAINT 0xA5u

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
static _Alignas(4096) uint8_t stack_rt[BOARD_STACK_RT_BYTES + STACK_RESERVE];
static _Alignas(4096) uint8_t stack_gp[BOARD_STACK_GP_BYTES + STACK_RESERVE];
static _Alignas(4096) uint8_t stack_ai[BOARD_STACK_AI_BYTES + STACK_RESERVE];
static uint8_t *const core_stack[HAL_CORE_COUNT] = {stack_rt, stack_gp, stack_ai};
static const size_t core_stack_size[HAL_CORE_COUNT] = {BOARD_STACK_RT_BYTES + STACK_RESERVE,
                                                       BOARD_STACK_GP_BYTES + STACK_RESERVE,
                                                       BOARD_STACK_AI_BYTES + STACK_RESERVE};
static const size_t core_board_stack[HAL_CORE_COUNT] = {
    BOARD_STACK_RT_BYTES, BOARD_STACK_GP_BYTES, BOARD_STACK_AI_BYTES};
/* Which hal_host_t owns the static stacks (between its first core start and its stop). */
static _Atomic(hal_host_t *) stacks_owner;

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

/* The core the calling thread runs, for the log and for sleep_until. */
static _Thread_local host_core_t *tls_core;

hal_host_config_t hal_host_config_default(void)
{
    hal_host_config_t c;
    memset(&c, 0, sizeof(c));
    c.sched = HAL_HOST_SCHED_SERIAL;
    c.log_level = HAL_LOG_INFO;
    return c;
}

uint64_t hal_host_now_us(const hal_host_t *h)
{
    return h == NULL ? 0 : atomic_load_explicit(&((hal_host_t *)h)->now_us, memory_order_acquire);
}

uint64_t hal_host_world_steps(const hal_host_t *h)
{
    if (h == NULL)
        return 0;
    hal_host_t *m = (hal_host_t *)h;
    pthread_mutex_lock(&m->mu);
    uint64_t s = m->world_steps;
    pthread_mutex_unlock(&m->mu);
    return s;
}

/* ---- stacks ------------------------------------------------------------------------------
 * Painting and scanning touch bytes that sanitizers may consider another thread's live
 * stack frames (redzones); they are plain memory here, so the checks are turned off for
 * these two functions only. */
__attribute__((no_sanitize_address, no_sanitize_thread)) static void stack_paint(uint8_t *s,
                                                                                  size_t n)
{
    volatile uint8_t *p = s;
    for (size_t i = 0; i < n; i++)
        p[i] = STACK_PAINT;
}

/* Stacks grow down: the untouched part is the low end. */
__attribute__((no_sanitize_address, no_sanitize_thread)) static size_t stack_used(const uint8_t *s,
                                                                                   size_t n)
{
    const volatile uint8_t *p = s;
    size_t i = 0;
    while (i < n && p[i] == STACK_PAINT)
        i++;
    return n - i;
}

/* The core's own use (below its first frame) and its board stack size; h->mu held. */
static void core_stack_figures(const host_core_t *c, size_t *used, size_t *size)
{
    size_t all = stack_used(core_stack[c->id], core_stack_size[c->id]);
    *used = all > c->stack_top_bytes ? all - c->stack_top_bytes : 0;
    *size = core_board_stack[c->id]; /* the reserve is the host's, not the core's */
}

static uint64_t ts_ns(const struct timespec *t)
{
    return (uint64_t)t->tv_sec * 1000000000ull + (uint64_t)t->tv_nsec;
}

/* ---- clock ------------------------------------------------------------------------------ */
static int op_now_us(void *ctx, uint64_t *now_us)
{
    *now_us = hal_host_now_us(ctx);
    return 0;
}

/* Called with h->mu held by the core `c`: tick accounting at the moment it blocks. */
static void tick_end(host_core_t *c)
{
    if (!c->tick_open)
        return;
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    uint64_t ns = ts_ns(&t) - ts_ns(&c->tick_start);
    hal_host_core_stats_t *s = &c->stats;
    if (s->wall_ticks == 0 || ns < s->wall_min_ns)
        s->wall_min_ns = ns;
    if (ns > s->wall_max_ns)
        s->wall_max_ns = ns;
    s->wall_total_ns += ns;
    s->wall_ticks++;
    c->tick_open = 0;
}

static void tick_begin(host_core_t *c, uint64_t asked_us, uint64_t now_us)
{
    hal_host_core_stats_t *s = &c->stats;
    s->ticks++;
    if (now_us > asked_us) {
        uint64_t late = now_us - asked_us;
        s->late_ticks++;
        s->lateness_total_us += late;
        if (late > s->lateness_max_us)
            s->lateness_max_us = late;
    }
    clock_gettime(CLOCK_MONOTONIC, &c->tick_start);
    c->tick_open = 1;
}

/* Blocks core c (h->mu held) until the scheduler releases it. Returns 0 or -ECANCELED. */
static int core_block(hal_host_t *h, host_core_t *c, uint64_t wake_us)
{
    c->wake_us = wake_us;
    c->state = CORE_SLEEPING;
    pthread_cond_signal(&h->sched_cv);
    while (c->state == CORE_SLEEPING)
        pthread_cond_wait(&c->cv, &h->mu);
    return h->stopping ? -ECANCELED : 0;
}

static int op_sleep_until_us(void *ctx, uint64_t wake_us)
{
    hal_host_t *h = ctx;
    host_core_t *c = tls_core;
    if (c == NULL || c->h != h)
        return -EPERM;
    pthread_mutex_lock(&h->mu);
    tick_end(c);
    if (h->stopping) {
        pthread_mutex_unlock(&h->mu);
        return -ECANCELED;
    }
    uint64_t now = atomic_load_explicit(&h->now_us, memory_order_relaxed);
    int r = 0;
    if (wake_us > now)
        r = core_block(h, c, wake_us);
    if (r == 0)
        tick_begin(c, wake_us, atomic_load_explicit(&h->now_us, memory_order_relaxed));
    pthread_mutex_unlock(&h->mu);
    return r;
}

/* ---- cores ------------------------------------------------------------------------------ */
static void *core_main(void *arg)
{
    host_core_t *c = arg;
    hal_host_t *h = c->h;
    tls_core = c;
    uint8_t *top = core_stack[c->id] + core_stack_size[c->id];
    size_t above = (size_t)(top - (uint8_t *)__builtin_frame_address(0));
    if (above > STACK_RESERVE)
        fprintf(stderr, "hal_host: core %s: %zu bytes of TLS and thread start exceed the "
                        "%u-byte reserve; the core has less than the board's stack\n",
                hal_core_name(c->id), above, (unsigned)STACK_RESERVE);
    pthread_mutex_lock(&h->mu);
    c->stack_top_bytes = above;
    /* Born SLEEPING with wake = start time: wait for the scheduler's first release. */
    while (c->state == CORE_SLEEPING)
        pthread_cond_wait(&c->cv, &h->mu);
    int run = !h->stopping;
    pthread_mutex_unlock(&h->mu);
    if (run)
        c->entry(c->arg);
    pthread_mutex_lock(&h->mu);
    tick_end(c);
    c->state = CORE_DONE;
    c->stats.finished = 1;
    pthread_cond_signal(&h->sched_cv);
    pthread_mutex_unlock(&h->mu);
    return NULL;
}

/* h->mu held. Gives the static stacks back when h has no thread on them. */
static void release_stacks_if_idle(hal_host_t *h)
{
    for (int i = 0; i < HAL_CORE_COUNT; i++)
        if (h->core[i].state != CORE_UNUSED && !h->core[i].joined)
            return;
    hal_host_t *self = h;
    atomic_compare_exchange_strong(&stacks_owner, &self, NULL);
}

static int op_core_start(void *ctx, hal_core_id_t id, hal_core_entry_t entry, void *arg)
{
    hal_host_t *h = ctx;
    if ((unsigned)id >= (unsigned)HAL_CORE_COUNT || entry == NULL)
        return -EINVAL;
    hal_host_t *expected = NULL;
    if (!atomic_compare_exchange_strong(&stacks_owner, &expected, h) && expected != h)
        return -EBUSY; /* another host board holds the static stacks */
    pthread_mutex_lock(&h->mu);
    host_core_t *c = &h->core[id];
    if (c->state != CORE_UNUSED || h->stopping) {
        int code = h->stopping ? -ECANCELED : -EBUSY;
        release_stacks_if_idle(h);
        pthread_mutex_unlock(&h->mu);
        return code;
    }
    stack_paint(core_stack[id], core_stack_size[id]);
    c->entry = entry;
    c->arg = arg;
    c->state = CORE_SLEEPING;
    c->wake_us = atomic_load_explicit(&h->now_us, memory_order_relaxed);
    memset(&c->stats, 0, sizeof(c->stats));
    c->stats.started = 1;
    c->stats.stack_size_bytes = core_board_stack[id];
    c->stack_top_bytes = 0;
    pthread_attr_t attr;
    int r = pthread_attr_init(&attr);
    if (r == 0)
        r = pthread_attr_setstack(&attr, core_stack[id], core_stack_size[id]);
    if (r == 0)
        r = pthread_create(&c->thread, &attr, core_main, c);
    pthread_attr_destroy(&attr);
    if (r != 0) {
        c->state = CORE_UNUSED;
        c->stats.started = 0;
        release_stacks_if_idle(h);
        pthread_mutex_unlock(&h->mu);
        return -EAGAIN;
    }
    c->joined = 0;
    pthread_cond_signal(&h->sched_cv);
    pthread_mutex_unlock(&h->mu);
    return 0;
}

static int op_stack_high_water(void *ctx, hal_core_id_t id, size_t *used, size_t *size)
{
    hal_host_t *h = ctx;
    pthread_mutex_lock(&h->mu);
    int started = h->core[id].stats.started;
    if (started)
        core_stack_figures(&h->core[id], used, size);
    pthread_mutex_unlock(&h->mu);
    return started ? 0 : -ESRCH;
}

static int op_core_self(void *ctx, hal_core_id_t *id)
{
    host_core_t *c = tls_core;
    if (c == NULL || c->h != ctx)
        return -EPERM;
    *id = c->id;
    return 0;
}

/* ---- log -------------------------------------------------------------------------------- */
static void op_vlog(void *ctx, hal_log_level_t level, const char *fmt, va_list ap)
{
    static const char *const names[] = {"ERROR", "WARN", "INFO", "DEBUG"};
    hal_host_t *h = ctx;
    if (level > h->cfg.log_level)
        return;
    uint64_t now = hal_host_now_us(h);
    host_core_t *c = tls_core;
    const char *who = (c != NULL && c->h == h) ? hal_core_name(c->id) : "host";
    char line[HAL_LOG_LINE_MAX + 64u];
    int n = snprintf(line, sizeof(line), "[%6llu.%06llu] %-4s %-5s ",
                     (unsigned long long)(now / 1000000u), (unsigned long long)(now % 1000000u),
                     who, names[level]);
    if (n < 0)
        return;
    size_t head = (size_t)n;
    int m = vsnprintf(line + head, HAL_LOG_LINE_MAX, fmt, ap);
    if (m < 0)
        return;
    size_t len = head + ((size_t)m < HAL_LOG_LINE_MAX ? (size_t)m : HAL_LOG_LINE_MAX - 1u);
    line[len++] = '\n';
    /* One write per line, so lines of different cores never interleave. */
    ssize_t w = write(h->cfg.log_fd > 0 ? h->cfg.log_fd : 2, line, len);
    (void)w;
}

/* ---- world ------------------------------------------------------------------------------ */
static int op_read_scan(void *ctx, hal_lidar_scan_t *scan)
{
    hal_host_t *h = ctx;
    pthread_mutex_lock(&h->world_mu);
    int r = h->cfg.world->read_scan(h->cfg.world->ctx, h->cfg.robot_id, scan);
    pthread_mutex_unlock(&h->world_mu);
    if (r == 0 && (scan->count == 0 || scan->count > HAL_LIDAR_MAX_BEAMS))
        return -EIO; /* the world broke the scan contract */
    return r;
}

static int op_read_pose(void *ctx, hal_pose_t *pose)
{
    hal_host_t *h = ctx;
    pthread_mutex_lock(&h->world_mu);
    int r = h->cfg.world->read_pose(h->cfg.world->ctx, h->cfg.robot_id, pose);
    pthread_mutex_unlock(&h->world_mu);
    return r;
}

static int op_set_wheels(void *ctx, float left, float right)
{
    hal_host_t *h = ctx;
    pthread_mutex_lock(&h->world_mu);
    int r = h->cfg.world->set_wheels(h->cfg.world->ctx, h->cfg.robot_id, left, right);
    pthread_mutex_unlock(&h->world_mu);
    return r;
}

/* Differential-drive inverse kinematics. */
static int op_set_twist(void *ctx, float v, float omega)
{
    hal_host_t *h = ctx;
    float r = h->cfg.wheel_radius_m, sep = h->cfg.wheel_separation_m;
    return op_set_wheels(ctx, (v - omega * sep * 0.5f) / r, (v + omega * sep * 0.5f) / r);
}

/* ---- net and storage -------------------------------------------------------------------- */
static int op_net_publish(void *ctx, const char *channel, const void *data, size_t len)
{
    return hal_host_net_publish(((hal_host_t *)ctx)->net, channel, data, len);
}

static int op_net_subscribe(void *ctx, const char *channel)
{
    return hal_host_net_subscribe(((hal_host_t *)ctx)->net, channel);
}

static int op_net_receive(void *ctx, hal_net_rx_info_t *info, void *buf, size_t cap)
{
    hal_host_t *h = ctx;
    return hal_host_net_receive(h->net, hal_host_now_us(h), info, buf, cap);
}

static int op_net_stats(void *ctx, hal_net_stats_t *stats)
{
    hal_host_net_get_stats(((hal_host_t *)ctx)->net, stats);
    return 0;
}

static int op_st_write(void *ctx, const char *name, const void *data, size_t len)
{
    return hal_host_storage_write(((hal_host_t *)ctx)->storage, name, data, len);
}

static int op_st_read(void *ctx, const char *name, void *buf, size_t cap, size_t *len)
{
    return hal_host_storage_read(((hal_host_t *)ctx)->storage, name, buf, cap, len);
}

static int op_st_remove(void *ctx, const char *name)
{
    return hal_host_storage_remove(((hal_host_t *)ctx)->storage, name);
}

/* A broken contract in the firmware: say where, then stop the process (a board would reset). */
static void op_fault(void *ctx, const char *file, int line, const char *what)
{
    (void)ctx;
    fprintf(stderr, "%s:%d: contract broken: %s\n", file, line, what);
    fflush(stderr);
    abort();
}

/* The operation tables: read-only, one per interface (two for the motors: with and without
 * twist), shared by every hal_host_t; the instance travels in the board's ctx. */
static const hal_clock_ops_t host_clock_ops = {.now_us = op_now_us, .sleep_until_us = op_sleep_until_us};
static const hal_core_ops_t host_core_ops = {
    .start = op_core_start, .stack_high_water = op_stack_high_water, .self = op_core_self};
static const hal_log_ops_t host_log_ops = {.vlog = op_vlog};
static const hal_lidar_ops_t host_lidar_ops = {.read_scan = op_read_scan};
static const hal_pose_ops_t host_pose_ops = {.read_pose = op_read_pose};
static const hal_motor_ops_t host_motor_ops_wheels = {.set_wheels = op_set_wheels};
static const hal_motor_ops_t host_motor_ops_twist = {.set_wheels = op_set_wheels, .set_twist = op_set_twist};
static const hal_net_ops_t host_net_ops = {
    .publish = op_net_publish, .subscribe = op_net_subscribe, .receive = op_net_receive, .stats = op_net_stats};
static const hal_storage_ops_t host_storage_ops = {.write = op_st_write, .read = op_st_read, .remove = op_st_remove};

/* ---- life cycle ------------------------------------------------------------------------- */
static int config_error(const char *what)
{
    fprintf(stderr, "hal_host: invalid configuration: %s\n", what);
    return -EINVAL;
}

int hal_host_create(const hal_host_config_t *cfg, hal_host_t **out)
{
    if (cfg == NULL || out == NULL)
        return -EINVAL;
    *out = NULL;
    if (cfg->sched != HAL_HOST_SCHED_SERIAL && cfg->sched != HAL_HOST_SCHED_PARALLEL)
        return config_error("sched must be HAL_HOST_SCHED_SERIAL or _PARALLEL");
    if ((unsigned)cfg->log_level > (unsigned)HAL_LOG_DEBUG)
        return config_error("log_level out of range");
    if (cfg->log_fd < 0)
        return config_error("log_fd is negative");
    if (cfg->net_queue_depth > 4096u)
        return config_error("net_queue_depth above 4096");
    if (cfg->world != NULL && cfg->world->advance_to_us == NULL)
        return config_error("world without advance_to_us");
    if (!(cfg->wheel_radius_m >= 0.0f) || !(cfg->wheel_separation_m >= 0.0f))
        return config_error("wheel geometry negative or NaN");

    hal_host_t *h = calloc(1, sizeof(*h));
    if (h == NULL)
        return -ENOMEM;
    h->cfg = *cfg;
    pthread_mutex_init(&h->mu, NULL);
    pthread_mutex_init(&h->world_mu, NULL);
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC); /* the watchdog's clock */
    pthread_cond_init(&h->sched_cv, &ca);
    pthread_condattr_destroy(&ca);
    for (int i = 0; i < HAL_CORE_COUNT; i++) {
        h->core[i].h = h;
        h->core[i].id = (hal_core_id_t)i;
        pthread_cond_init(&h->core[i].cv, NULL);
    }
    int r = 0;
    if (cfg->net_url != NULL)
        r = hal_host_net_open(cfg->net_url,
                              cfg->net_queue_depth ? cfg->net_queue_depth
                                                   : HAL_HOST_NET_QUEUE_DEFAULT,
                              &h->net);
    if (r == 0 && cfg->storage_dir != NULL)
        r = hal_host_storage_open(cfg->storage_dir, &h->storage);
    if (r != 0) {
        hal_host_destroy(h);
        return r;
    }

    h->board.name = cfg->board_name != NULL ? cfg->board_name : BOARD_NAME;
    h->board.ctx = h;
    h->board.fault = op_fault;
    h->board.clock = &host_clock_ops;
    h->board.core = &host_core_ops;
    h->board.log = &host_log_ops;
    const hal_host_world_t *w = cfg->world;
    if (w != NULL && w->read_scan != NULL) {
        h->board.lidar = &host_lidar_ops;
    }
    if (w != NULL && w->read_pose != NULL) {
        h->board.pose = &host_pose_ops;
    }
    if (w != NULL && w->set_wheels != NULL) {
        /* Twist needs the wheel geometry; without it the board offers wheels only. */
        const int twist = cfg->wheel_radius_m > 0.0f && cfg->wheel_separation_m > 0.0f;
        h->board.motor = twist ? &host_motor_ops_twist : &host_motor_ops_wheels;
    }
    if (h->net != NULL) {
        h->board.net = &host_net_ops;
    }
    if (h->storage != NULL) {
        h->board.storage = &host_storage_ops;
    }
    *out = h;
    return 0;
}

const hal_board_t *hal_host_board(const hal_host_t *h)
{
    return h == NULL ? NULL : &h->board;
}

static int any_running(const hal_host_t *h)
{
    for (int i = 0; i < HAL_CORE_COUNT; i++)
        if (h->core[i].state == CORE_RUNNING)
            return 1;
    return 0;
}

static void wait_all_blocked(hal_host_t *h)
{
    while (any_running(h)) {
        if (h->cfg.watchdog_ms == 0) {
            pthread_cond_wait(&h->sched_cv, &h->mu);
            continue;
        }
        /* sched_cv runs on CLOCK_MONOTONIC (see hal_host_create). */
        struct timespec dl;
        clock_gettime(CLOCK_MONOTONIC, &dl);
        uint64_t ns = (uint64_t)dl.tv_nsec + (uint64_t)h->cfg.watchdog_ms * 1000000u;
        dl.tv_sec += (time_t)(ns / 1000000000u);
        dl.tv_nsec = (long)(ns % 1000000000u);
        if (pthread_cond_timedwait(&h->sched_cv, &h->mu, &dl) != ETIMEDOUT)
            continue;
        for (int i = 0; i < HAL_CORE_COUNT; i++) {
            if (h->core[i].state != CORE_RUNNING)
                continue;
            h->watchdog_reports++;
            fprintf(stderr, "hal_host: watchdog: core %s has run for more than %u ms of wall "
                            "time at t=%llu us without sleeping\n",
                    hal_core_name((hal_core_id_t)i), (unsigned)h->cfg.watchdog_ms,
                    (unsigned long long)atomic_load_explicit(&h->now_us, memory_order_relaxed));
        }
    }
}

uint64_t hal_host_watchdog_reports(const hal_host_t *h)
{
    if (h == NULL)
        return 0;
    hal_host_t *m = (hal_host_t *)h;
    pthread_mutex_lock(&m->mu);
    uint64_t n = m->watchdog_reports;
    pthread_mutex_unlock(&m->mu);
    return n;
}

/* mu held, every core blocked: the world may run. */
static int world_advance(hal_host_t *h, uint64_t t_us)
{
    if (h->cfg.world == NULL)
        return 0;
    pthread_mutex_lock(&h->world_mu);
    int r = h->cfg.world->advance_to_us(h->cfg.world->ctx, t_us);
    pthread_mutex_unlock(&h->world_mu);
    if (r == 0)
        h->world_steps++;
    return r;
}

int hal_host_run_until(hal_host_t *h, uint64_t t_end_us)
{
    if (h == NULL)
        return -EINVAL;
    pthread_mutex_lock(&h->mu);
    if (h->stopping) {
        pthread_mutex_unlock(&h->mu);
        return -ECANCELED;
    }
    uint64_t now = atomic_load_explicit(&h->now_us, memory_order_relaxed);
    if (t_end_us < now) {
        pthread_mutex_unlock(&h->mu);
        return -EINVAL;
    }
    int r = 0;
    for (;;) {
        wait_all_blocked(h);
        /* The earliest wake-up; ties go to the lowest core id. */
        int next = -1;
        for (int i = 0; i < HAL_CORE_COUNT; i++) {
            host_core_t *c = &h->core[i];
            if (c->state == CORE_SLEEPING && (next < 0 || c->wake_us < h->core[next].wake_us))
                next = i;
        }
        if (next < 0 || h->core[next].wake_us > t_end_us)
            break;
        uint64_t t = h->core[next].wake_us;
        if (t > now) {
            r = world_advance(h, t);
            if (r != 0)
                break;
            now = t;
            atomic_store_explicit(&h->now_us, now, memory_order_release);
        }
        for (int i = next; i < HAL_CORE_COUNT; i++) {
            host_core_t *c = &h->core[i];
            if (c->state == CORE_SLEEPING && c->wake_us <= now) {
                c->state = CORE_RUNNING;
                pthread_cond_signal(&c->cv);
                if (h->cfg.sched == HAL_HOST_SCHED_SERIAL)
                    break;
            }
        }
    }
    if (r == 0 && t_end_us > now) {
        r = world_advance(h, t_end_us);
        if (r == 0)
            atomic_store_explicit(&h->now_us, t_end_us, memory_order_release);
    }
    pthread_mutex_unlock(&h->mu);
    return r;
}

void hal_host_stop(hal_host_t *h)
{
    if (h == NULL)
        return;
    pthread_mutex_lock(&h->mu);
    h->stopping = 1;
    for (;;) {
        wait_all_blocked(h);
        int released = 0;
        for (int i = 0; i < HAL_CORE_COUNT; i++) {
            host_core_t *c = &h->core[i];
            if (c->state == CORE_SLEEPING) {
                c->state = CORE_RUNNING;
                pthread_cond_signal(&c->cv);
                released = 1;
                if (h->cfg.sched == HAL_HOST_SCHED_SERIAL)
                    break;
            }
        }
        if (!released)
            break;
    }
    pthread_mutex_unlock(&h->mu);
    for (int i = 0; i < HAL_CORE_COUNT; i++) {
        host_core_t *c = &h->core[i];
        if (c->state == CORE_DONE && !c->joined) {
            pthread_join(c->thread, NULL);
            c->joined = 1;
        }
    }
    h->stopped = 1;
    hal_host_t *self = h;
    atomic_compare_exchange_strong(&stacks_owner, &self, NULL);
}

void hal_host_destroy(hal_host_t *h)
{
    if (h == NULL)
        return;
    hal_host_stop(h);
    if (hal_board_current == &h->board) {
        int r = hal_board_install(NULL); /* uninstalling cannot fail */
        (void)r;
    }
    hal_host_net_close(h->net);
    hal_host_storage_close(h->storage);
    for (int i = 0; i < HAL_CORE_COUNT; i++)
        pthread_cond_destroy(&h->core[i].cv);
    pthread_cond_destroy(&h->sched_cv);
    pthread_mutex_destroy(&h->world_mu);
    pthread_mutex_destroy(&h->mu);
    free(h);
}

int hal_host_core_stats(hal_host_t *h, hal_core_id_t id, hal_host_core_stats_t *stats)
{
    if (h == NULL || stats == NULL || (unsigned)id >= (unsigned)HAL_CORE_COUNT)
        return -EINVAL;
    pthread_mutex_lock(&h->mu);
    *stats = h->core[id].stats;
    if (stats->started)
        core_stack_figures(&h->core[id], &stats->stack_used_bytes, &stats->stack_size_bytes);
    pthread_mutex_unlock(&h->mu);
    return 0;
}
