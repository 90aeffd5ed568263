/* Host board: the lockstep scheduler and the clock. Simulated time advances only while every
 * core is blocked, to the earliest wake-up; the world steps to it; then the core(s) due are
 * released. See hal_host_priv.h for the states. */
#include "hal_host_priv.h"
#include "hal_host_stop.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

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
void hal_host_tick_end(host_core_t *c)
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

/* Blocks core c (h->mu held) until the scheduler releases it. Returns 0 or -ECANCELED. With
 * work registered by hal_clock_while_asleep, the core wakes every asleep_every_us of real time
 * to do it (the mutex released meanwhile: the scheduler may release the core during it, which
 * the loop then sees). */
static int core_block(hal_host_t *h, host_core_t *c, uint64_t wake_us)
{
    c->wake_us = wake_us;
    c->state = CORE_SLEEPING;
    pthread_cond_signal(&h->sched_cv);
    while (c->state == CORE_SLEEPING) {
        if (c->asleep_fn == NULL) {
            pthread_cond_wait(&c->cv, &h->mu);
            continue;
        }
        struct timespec dl;
        clock_gettime(CLOCK_MONOTONIC, &dl);
        const uint64_t ns = ts_ns(&dl) + (uint64_t)c->asleep_every_us * 1000u;
        dl.tv_sec = (time_t)(ns / 1000000000u);
        dl.tv_nsec = (long)(ns % 1000000000u);
        if (pthread_cond_timedwait(&c->cv, &h->mu, &dl) == ETIMEDOUT && c->state == CORE_SLEEPING &&
            !h->stopping) {
            pthread_mutex_unlock(&h->mu);
            c->asleep_fn(c->asleep_arg);
            pthread_mutex_lock(&h->mu);
        }
    }
    return h->stopping ? -ECANCELED : 0;
}

static int op_while_asleep(void *ctx, void (*fn)(void *arg), void *arg, uint32_t every_us)
{
    hal_host_t *h = ctx;
    host_core_t *c = hal_host_tls_core;
    if (c == NULL || c->h != h)
        return -EPERM;
    if (fn != NULL && every_us == 0)
        return -EINVAL;
    pthread_mutex_lock(&h->mu);
    c->asleep_fn = fn;
    c->asleep_arg = arg;
    c->asleep_every_us = every_us;
    pthread_mutex_unlock(&h->mu);
    return 0;
}

static int op_sleep_until_us(void *ctx, uint64_t wake_us)
{
    hal_host_t *h = ctx;
    host_core_t *c = hal_host_tls_core;
    if (c == NULL || c->h != h)
        return -EPERM;
    pthread_mutex_lock(&h->mu);
    hal_host_tick_end(c);
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

const hal_clock_ops_t hal_host_clock_ops = {
    .now_us = op_now_us, .sleep_until_us = op_sleep_until_us, .while_asleep = op_while_asleep};

/* ---- scheduler ---------------------------------------------------------------------------- */
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
        /* A stop was asked for (SIGINT/SIGTERM, hal_host_stop.h): every core is blocked now,
           the one place where the image can end in good order, so end here. */
        if (hal_host_stop_signal() != 0) {
            r = -EINTR;
            break;
        }
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
    hal_host_stacks_release(h);
}
