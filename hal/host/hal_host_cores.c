/* Host board: the core threads, each on a painted static stack (high-water marks), started
 * SLEEPING for the scheduler's first release. See hal_host_priv.h for the states. */
#include "hal_host_priv.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

_Thread_local host_core_t *hal_host_tls_core;

#define STACK_PAINT 0xA5u

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


/* ---- cores ------------------------------------------------------------------------------ */
static void *core_main(void *arg)
{
    host_core_t *c = arg;
    hal_host_t *h = c->h;
    hal_host_tls_core = c;
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
    hal_host_tick_end(c);
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
    host_core_t *c = hal_host_tls_core;
    if (c == NULL || c->h != ctx)
        return -EPERM;
    *id = c->id;
    return 0;
}

const hal_core_ops_t hal_host_core_ops = {
    .start = op_core_start, .stack_high_water = op_stack_high_water, .self = op_core_self};

void hal_host_stacks_release(hal_host_t *h)
{
    hal_host_t *self = h;
    atomic_compare_exchange_strong(&stacks_owner, &self, NULL);
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
