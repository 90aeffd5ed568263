/* Host board: the core threads, each on a static stack, started SLEEPING for the scheduler's
 * first release. See hal_host_priv.h for the states.
 *
 * Stack high-water marks by page residency, not by painting: painting a stack makes all of it
 * resident (9.4 MB per process for the three host stacks, of which a few hundred KB are ever
 * used). Instead, before a core starts, its stack's pages are dropped (MADV_DONTNEED: the
 * next touch maps a fresh page) and kept out of transparent huge pages (MADV_NOHUGEPAGE: one
 * touch must fault in one 4 KB page, not 2 MB); a page becomes resident only when the thread
 * touches it (reads or writes it). mincore() then finds the deepest resident page, and the
 * high-water mark is the bytes from the stack's top down to the start of that page: exact
 * to a page (it over-states the deepest byte touched by less than one page, never
 * under-states it, as long as no stack page has been swapped out: mincore() does not count a
 * page that is only in swap). */
#define _DEFAULT_SOURCE /* mincore(), MADV_NOHUGEPAGE */
#include "hal_host_priv.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

_Thread_local host_core_t *hal_host_tls_core;

/* The arrays' alignment: the page size of the hosts built for (x86-64; aarch64 with 4 KB
 * pages), as pthread_attr_setstack() and madvise() want. */
#define STACK_PAGE 4096u
static _Alignas(STACK_PAGE) uint8_t stack_rt[BOARD_STACK_RT_BYTES + STACK_RESERVE];
static _Alignas(STACK_PAGE) uint8_t stack_gp[BOARD_STACK_GP_BYTES + STACK_RESERVE];
static _Alignas(STACK_PAGE) uint8_t stack_ai[BOARD_STACK_AI_BYTES + STACK_RESERVE];
static uint8_t *const core_stack[HAL_CORE_COUNT] = {stack_rt, stack_gp, stack_ai};
static const size_t core_stack_size[HAL_CORE_COUNT] = {BOARD_STACK_RT_BYTES + STACK_RESERVE,
                                                       BOARD_STACK_GP_BYTES + STACK_RESERVE,
                                                       BOARD_STACK_AI_BYTES + STACK_RESERVE};
static const size_t core_board_stack[HAL_CORE_COUNT] = {
    BOARD_STACK_RT_BYTES, BOARD_STACK_GP_BYTES, BOARD_STACK_AI_BYTES};
/* Which hal_host_t owns the static stacks (between its first core start and its stop). */
static _Atomic(hal_host_t *) stacks_owner;

/* ---- stacks ------------------------------------------------------------------------------ */

/* Before a start: no page of the stack resident, none to be faulted in as a huge page.
 * The arrays are page-aligned, page-sized .bss (private anonymous memory), so dropped pages
 * come back zero-filled. */
static void stack_reset(uint8_t *s, size_t n)
{
    (void)madvise(s, n, MADV_NOHUGEPAGE); /* fails only without THP support: nothing to undo */
    (void)madvise(s, n, MADV_DONTNEED);
}

/* Stacks grow down: the bytes from the top to the start of the lowest resident page. */
static size_t stack_used(const uint8_t *s, size_t n)
{
    const size_t page = (size_t)sysconf(_SC_PAGESIZE);
    unsigned char vec[256]; /* one byte per page, a chunk at a time: nothing allocated */
    for (size_t off = 0; off < n; off += sizeof vec * page) {
        size_t len = n - off < sizeof vec * page ? n - off : sizeof vec * page;
        if (mincore((void *)(uintptr_t)(s + off), len, vec) != 0)
            return n; /* cannot tell: report the whole stack as used */
        for (size_t i = 0; i < (len + page - 1) / page; i++)
            if (vec[i] & 1u)
                return n - (off + i * page);
    }
    return 0;
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
    hal_host_name_thread(hal_core_name(c->id));
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
    stack_reset(core_stack[id], core_stack_size[id]);
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
