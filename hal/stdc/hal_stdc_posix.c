/* The stdc back end's Linux target (hal_stdc_target.h): an ordinary process. Time from
 * CLOCK_MONOTONIC; instructions and the stack depth are not counted here (on a Linux board
 * `perf stat -e instructions` counts them from outside the program). */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <errno.h>
#include <stdint.h>
#include <time.h>

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

const char *hal_stdc_target_name(void)
{
    return "linux process";
}

int hal_stdc_target_stack(size_t *used, size_t *size)
{
    (void)used, (void)size;
    return -ENOTSUP;
}
