/* The Cortex-M scheduler's contract (hal/stdc/hal_stdc_cortex_m_cores.c), on the emulated
 * boards: a bare-metal image of its own, run under QEMU by `make run-board` (boards/cross.mk's
 * `test` for a Cortex-M board). No cmocka for newlib: the checks print cmocka's lines and
 * summary and the image exits 1 on the first failure (QEMU passes the code on).
 *
 * What it holds the scheduler to (hal/hal_core.h and the priorities RT > GP > AI > main):
 *   - a periodic RT core keeps its ticks while the main program never sleeps (preemption);
 *   - cores woken at one instant run in priority order, a lower one only when the higher sleep,
 *     and the RT core preempts the GP core too;
 *   - hal_core_self names each core (-EPERM on the main program); a started core cannot be
 *     started again (-EBUSY); a core that returns never runs again;
 *   - the floating-point registers of a preempted thread survive the switches (s0-s31);
 *   - each core's stack high-water mark is measured, within its size. */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hal_stdc.h"
#include "hal_stdc_target.h"

static int run_n, failed;
static const char *current;

#define CHECK(cond)                                                                              \
    do {                                                                                         \
        if (!(cond)) {                                                                           \
            printf("[  ERROR   ] --- %s:%d: %s\n[  FAILED  ] %s\n", __FILE__, __LINE__, #cond, current); \
            failed = 1;                                                                          \
            return;                                                                              \
        }                                                                                        \
    } while (0)

static uint64_t now_us(void)
{
    return hal_stdc_target_now_us();
}

static void spin_until(uint64_t t_us) /* busy: never sleeps, never yields */
{
    while (now_us() < t_us) {
    }
}

/* ---- the cores ------------------------------------------------------------------------------ */
#define RT_PERIOD_US 1000u

static volatile uint64_t rt_ticks;
static volatile int rt_fpu;             /* 1: every tick fills the FPU registers with its own values */
static volatile hal_core_id_t self_seen[HAL_CORE_COUNT];
static volatile int self_rc[HAL_CORE_COUNT];

/* The wake-up order of the one-shot cores: ids in the order they ran. */
static volatile uint32_t order[8], n_order;
static volatile uint64_t gp_woke, gp_done, ai_woke, oneshot_at;
static volatile uint64_t rt_ticks_in_gp;

static void note_self(hal_core_id_t expect)
{
    hal_core_id_t id = HAL_CORE_COUNT;
    self_rc[expect] = hal_core_self(&id);
    self_seen[expect] = id;
}

/* Sixteen accumulators live at once: the compiler keeps them in s0-s31, which the main
   program's computation uses too. */
static void fpu_noise(uint32_t seed)
{
    float a[16];
    for (int i = 0; i < 16; i++)
        a[i] = (float)(seed + (uint32_t)i) * 1.5f;
    for (int k = 0; k < 50; k++)
        for (int i = 0; i < 16; i++)
            a[i] = a[i] * 0.999f + a[(i + 1) & 15] * 0.001f + 3.0f;
    volatile float sink = 0.0f;
    for (int i = 0; i < 16; i++)
        sink += a[i];
    (void)sink;
}

static void rt_entry(void *arg)
{
    (void)arg;
    note_self(HAL_CORE_RT);
    uint64_t t = now_us();
    for (;;) {
        t += RT_PERIOD_US;
        if (hal_sleep_until_us(t) != 0)
            return;
        rt_ticks++;
        if (rt_fpu)
            fpu_noise((uint32_t)rt_ticks);
    }
}

static void gp_entry(void *arg)
{
    (void)arg;
    note_self(HAL_CORE_GP);
    if (hal_sleep_until_us(oneshot_at) != 0)
        return;
    gp_woke = now_us();
    order[n_order++] = HAL_CORE_GP;
    const uint64_t r0 = rt_ticks;
    spin_until(gp_woke + 5u * RT_PERIOD_US); /* busy for 5 RT periods: the RT core must still tick */
    rt_ticks_in_gp = rt_ticks - r0;
    gp_done = now_us();
    /* returns: the core is done */
}

static void ai_entry(void *arg)
{
    (void)arg;
    note_self(HAL_CORE_AI);
    if (hal_sleep_until_us(oneshot_at) != 0)
        return;
    ai_woke = now_us();
    order[n_order++] = HAL_CORE_AI;
}

/* ---- the checks ----------------------------------------------------------------------------- */
static void test_rt_preempts_a_busy_main(void)
{
    CHECK(hal_core_start(HAL_CORE_RT, rt_entry, NULL) == 0);
    const uint64_t r0 = rt_ticks, t0 = now_us();
    spin_until(t0 + 20u * RT_PERIOD_US);
    const uint64_t n = rt_ticks - r0;
    printf("  RT ticks while the main program spun 20 periods: %llu\n", (unsigned long long)n);
    CHECK(n >= 19 && n <= 21);
}

static void test_priority_order_and_preemption_of_gp(void)
{
    oneshot_at = now_us() + 3u * RT_PERIOD_US + RT_PERIOD_US / 2u; /* between two RT ticks */
    CHECK(hal_core_start(HAL_CORE_AI, ai_entry, NULL) == 0); /* the lower one first */
    CHECK(hal_core_start(HAL_CORE_GP, gp_entry, NULL) == 0);
    spin_until(oneshot_at + 10u * RT_PERIOD_US); /* the main program is the lowest: it waits */
    CHECK(n_order == 2);
    CHECK(order[0] == HAL_CORE_GP && order[1] == HAL_CORE_AI);
    CHECK(gp_woke >= oneshot_at && gp_woke < oneshot_at + 200u); /* at the first tick after */
    CHECK(ai_woke >= gp_done);                                 /* only once GP was done */
    printf("  RT ticks while the GP core spun 5 periods: %llu\n", (unsigned long long)rt_ticks_in_gp);
    CHECK(rt_ticks_in_gp >= 4 && rt_ticks_in_gp <= 6);
}

static void test_self_busy_and_done(void)
{
    for (int i = 0; i < HAL_CORE_COUNT; i++) {
        CHECK(self_rc[i] == 0);
        CHECK(self_seen[i] == (hal_core_id_t)i);
    }
    hal_core_id_t id;
    CHECK(hal_core_self(&id) == -EPERM);
    CHECK(hal_core_start(HAL_CORE_RT, rt_entry, NULL) == -EBUSY);
    CHECK(hal_core_start(HAL_CORE_GP, gp_entry, NULL) == -EBUSY); /* done, still not again */
    const uint32_t n = n_order;
    oneshot_at = now_us(); /* a done core would run again if it could: it must not */
    spin_until(now_us() + 5u * RT_PERIOD_US);
    CHECK(n_order == n);
}

static volatile float fpu_result, fpu_seed = 1.0f; /* volatile: each call does its work */

static float fpu_work(void)
{
    float x = fpu_seed, y = 0.5f, z = 0.25f, w = 2.0f;
    for (int i = 0; i < 400000; i++) {
        x = x * 0.9999f + y * 0.0001f;
        y = y * 0.9998f + z * 0.0002f + 0.001f;
        z = z * 0.9997f + w * 0.0003f;
        w = w * 0.9996f + x * 0.0004f;
    }
    return x + y + z + w;
}

static void test_fpu_registers_survive_preemption(void)
{
    rt_fpu = 0;
    const uint64_t r0 = rt_ticks;
    const float quiet = fpu_work();
    rt_fpu = 1;
    const uint64_t r1 = rt_ticks;
    fpu_result = fpu_work();
    rt_fpu = 0;
    printf("  %llu and %llu RT ticks (the second time with the FPU busy) preempted the same float work\n",
           (unsigned long long)(r1 - r0), (unsigned long long)(rt_ticks - r1));
    CHECK(rt_ticks - r1 > 3);
    CHECK(memcmp((const void *)&fpu_result, &quiet, sizeof quiet) == 0);
}

static void test_stacks_measured(void)
{
    for (int i = 0; i < HAL_CORE_COUNT; i++) {
        size_t used = 0, size = 0;
        CHECK(hal_core_stack_high_water((hal_core_id_t)i, &used, &size) == 0);
        printf("  %s stack: %lu of %lu bytes\n", hal_core_name((hal_core_id_t)i), (unsigned long)used,
               (unsigned long)size);
        CHECK(used > 64 && used < size);
    }
}

static void run(void (*fn)(void), const char *name)
{
    if (failed)
        return;
    current = name;
    printf("[ RUN      ] %s\n", name);
    run_n++;
    fn();
    if (!failed)
        printf("[       OK ] %s\n", name);
}

int main(void)
{
    if (hal_stdc_install("") != 0)
        return 1;
    printf("[==========] hal/cortex_m_cores: running on %s\n", hal_stdc_target_name());
    run(test_rt_preempts_a_busy_main, "test_rt_preempts_a_busy_main");
    run(test_priority_order_and_preemption_of_gp, "test_priority_order_and_preemption_of_gp");
    run(test_self_busy_and_done, "test_self_busy_and_done");
    run(test_fpu_registers_survive_preemption, "test_fpu_registers_survive_preemption");
    run(test_stacks_measured, "test_stacks_measured");
    printf("[==========] %d test(s) run.\n", run_n);
    if (failed) {
        printf("[  FAILED  ] 1 test(s), listed below:\n[  FAILED  ] %s\n\n 1 FAILED TEST(S)\n", current);
        return 1;
    }
    printf("[  PASSED  ] %d test(s).\n", run_n);
    return 0;
}
