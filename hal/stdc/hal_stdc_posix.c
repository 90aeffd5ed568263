/* The stdc back end's Linux target (hal_stdc_target.h): an ordinary process. Time from
 * CLOCK_MONOTONIC. Instructions are counted from outside: marks are a system call that does not
 * exist, which QEMU's plugin (tools/board/qemu_insn.c) sees with the count so far; on a real
 * board `perf stat -e instructions` counts the whole program. The stack grows on demand and
 * is not measured. */
#define _DEFAULT_SOURCE 1 /* clock_gettime, syscall */
#include <errno.h>
#include <stdint.h>
#include <time.h>
#include <unistd.h>

#include "hal_stdc_target.h"

uint64_t hal_stdc_target_now_us(void)
{
    static uint64_t t0;
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    uint64_t t = (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
    if (t0 == 0)
        t0 = t;
    return t - t0;
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

const char *hal_stdc_target_name(void)
{
    return "linux process";
}

int hal_stdc_target_stack(size_t *used, size_t *size)
{
    (void)used, (void)size;
    return -ENOTSUP;
}
