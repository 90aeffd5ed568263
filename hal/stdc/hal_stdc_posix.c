/* The stdc back end's Linux target (hal_stdc_target.h): an ordinary process. Time from
 * CLOCK_MONOTONIC. Instructions are counted from outside: marks are a system call that does not
 * exist, which QEMU's plugin (tools/board/qemu_insn.c) sees with the count so far; on a real
 * board `perf stat -e instructions` counts the whole program. The stack grows on demand and
 * is not measured. */
#define _DEFAULT_SOURCE 1 /* clock_gettime, syscall */
#include <errno.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <time.h>
#include <unistd.h>

#include "hal_stdc_target.h"

uint64_t hal_stdc_target_link_ns(void)
{
    static uint64_t t0;
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    uint64_t t = (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
    if (t0 == 0)
        t0 = t;
    return t - t0;
}

/* Lockstep (hal_stdc_target_hold): the time held so far, and, while held, the board's time it
   stands at (+ 1; 0: not held). Only the link's owner writes them, held_ns before frozen_at
   goes back to 0, so a reader on another thread sees the clock either standing or going on,
   never a jump. */
static _Atomic uint64_t held_ns, frozen_at;

void hal_stdc_target_hold(int on)
{
    const uint64_t now = hal_stdc_target_link_ns();
    static uint64_t from; /* the owner's alone */
    if (on && atomic_load(&frozen_at) == 0) {
        from = now;
        atomic_store(&frozen_at, now - atomic_load(&held_ns) + 1u);
    } else if (!on && atomic_load(&frozen_at) != 0) {
        atomic_store(&held_ns, atomic_load(&held_ns) + (now - from));
        atomic_store(&frozen_at, 0);
    }
}

uint64_t hal_stdc_target_now_ns(void)
{
    const uint64_t f = atomic_load(&frozen_at);
    return f != 0 ? f - 1u : hal_stdc_target_link_ns() - atomic_load(&held_ns);
}

uint64_t hal_stdc_target_now_us(void)
{
    return hal_stdc_target_now_ns() / 1000u;
}

int hal_stdc_target_instructions(uint64_t *n)
{
    (void)n;
    return -ENOTSUP;
}

void hal_stdc_target_mark(uint32_t id)
{
    (void)syscall(HAL_STDC_MARK_SYSCALL, (long)id);
}

int hal_stdc_target_rename(const char *from, const char *to)
{
    return rename(from, to) == 0 ? 0 : -1;
}

const char *hal_stdc_target_name(void)
{
    return "linux process";
}

int hal_stdc_target_stack(size_t *used, size_t *size)
{
    (void)used, (void)size;
    return -ENOTSUP;
}

int hal_stdc_target_core_start(hal_core_id_t id, hal_core_entry_t entry, void *arg)
{
    (void)id, (void)entry, (void)arg;
    return -ENOTSUP; /* a Linux board runs the host HAL's threads */
}

int hal_stdc_target_core_stack(hal_core_id_t id, size_t *used, size_t *size)
{
    (void)id, (void)used, (void)size;
    return -ENOTSUP;
}

int hal_stdc_target_core_self(hal_core_id_t *id)
{
    (void)id;
    return -ENOTSUP;
}

void hal_stdc_target_sleep_until(uint64_t wake_us)
{
    while (hal_stdc_target_now_us() < wake_us) {
        /* One thread, nothing else to run: wait on the time base. */
    }
}
