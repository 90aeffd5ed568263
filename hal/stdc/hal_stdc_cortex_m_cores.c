/* The Cortex-M target's cores (hal_stdc_target.h): the image's three cores as threads of one
 * bare-metal processor, without an RTOS.
 *
 * Threads and priorities, fixed: RT > GP > AI > the main program > idle. A thread runs until it
 * sleeps (hal_sleep_until_us) or a thread above it wakes; threads of one priority do not
 * exist, so there is no time slicing. The idle thread waits for an interrupt (WFI).
 * Time: the SysTick interrupt, HAL_STDC_CM_TICK_HZ per second of the target's clock, wakes every
 * thread whose time came (hal_stdc_cm_tick) and asks for a switch when one outranks the thread
 * running. A core therefore wakes at the first tick at or after its time: up to one tick period
 * late, plus the switch; that lateness is what the profile measures (tools/board/board_train.c
 * --rt-hz).
 * Switching: PendSV, at the lowest priority, so it runs once no other handler does. Every thread
 * (the main program too, which reset_handler moved onto the process stack) keeps its context on
 * its own stack: the processor stacks r0-r3, r12, lr, pc, xPSR (and s0-s15 when the thread used
 * the FPU), PendSV stacks r4-r11, its EXC_RETURN (which says whether the FPU frame is there) and
 * then s16-s31 when it is.
 * Stacks: static, BOARD_STACK_<core>_BYTES each, painted before the core starts; the deepest
 * word no longer painted gives the high-water mark. A fault names the thread it hit
 * (hal_stdc_cm_thread_name). */
#include <errno.h>
#include <stdint.h>
#include <string.h>

#include "hal_stdc_target.h"
#include "hal_stdc_cortex_m_cores.h"

#define ICSR (*(volatile uint32_t *)0xE000ED04u)
#define ICSR_PENDSVSET (1u << 28)
#define STACK_PAINT 0xA5A5A5A5u
#define IDLE_STACK_WORDS 128u
#define EXC_RETURN_THREAD_PSP 0xFFFFFFFDu /* thread mode, process stack, no FPU frame */
#define XPSR_THUMB 0x01000000u

enum { T_FREE, T_READY, T_ASLEEP, T_DONE };
enum { MAIN = HAL_CORE_COUNT, IDLE, THREADS }; /* after the cores, in priority order */

typedef struct thread {
    uint32_t *sp;        /* saved context (when not running) */
    volatile uint8_t state;
    uint64_t wake_us;
    uint32_t *stack;     /* lowest word (NULL: the main program's, measured by the target) */
    size_t stack_words;
    hal_core_entry_t entry;
    void *arg;
} thread_t;

static uint32_t stack_rt[BOARD_STACK_RT_BYTES / 4u] __attribute__((aligned(8)));
static uint32_t stack_gp[BOARD_STACK_GP_BYTES / 4u] __attribute__((aligned(8)));
static uint32_t stack_ai[BOARD_STACK_AI_BYTES / 4u] __attribute__((aligned(8)));
static uint32_t stack_idle[IDLE_STACK_WORDS] __attribute__((aligned(8)));
static uint32_t *const core_stack[HAL_CORE_COUNT] = {stack_rt, stack_gp, stack_ai};
static const size_t core_words[HAL_CORE_COUNT] = {sizeof stack_rt / 4u, sizeof stack_gp / 4u, sizeof stack_ai / 4u};
_Static_assert(HAL_CORE_RT == 0 && HAL_CORE_GP == 1 && HAL_CORE_AI == 2, "the cores' ids are their priorities");

static thread_t thread[THREADS];
static volatile uint32_t running = MAIN;
static int started; /* a core was started: sleeping switches threads */

static void irq_off(void)
{
    __asm__ volatile("cpsid i" ::: "memory");
}

static void irq_on(void)
{
    __asm__ volatile("cpsie i" ::: "memory");
}

/* The highest thread ready to run (idle always is). */
static uint32_t pick(void)
{
    uint32_t t = 0;
    while (t < IDLE && thread[t].state != T_READY)
        t++;
    return t;
}

/* Called by PendSV with the stack pointer of the thread that ran (its context saved below it):
   returns the one to run next. */
uint32_t *hal_stdc_cm_switch(uint32_t *sp);
uint32_t *hal_stdc_cm_switch(uint32_t *sp)
{
    thread[running].sp = sp;
    running = pick();
    return thread[running].sp;
}

__attribute__((naked)) void hal_stdc_cm_pendsv(void)
{
    __asm__ volatile(
        "mrs r0, psp\n"
#if defined(__ARM_FP)
        "tst lr, #0x10\n" /* EXC_RETURN bit 4 clear: the thread has an FPU frame */
        "it eq\n"
        "vstmdbeq r0!, {s16-s31}\n"
#endif
        "stmdb r0!, {r4-r11, lr}\n"
        "bl hal_stdc_cm_switch\n"
        "ldmia r0!, {r4-r11, lr}\n"
#if defined(__ARM_FP)
        "tst lr, #0x10\n"
        "it eq\n"
        "vldmiaeq r0!, {s16-s31}\n"
#endif
        "msr psp, r0\n"
        "isb\n"
        "bx lr\n");
}

static void ask_switch(void)
{
    ICSR = ICSR_PENDSVSET;
    __asm__ volatile("dsb\n isb" ::: "memory");
}

void hal_stdc_cm_tick(uint64_t now_us)
{
    if (!started)
        return;
    for (uint32_t t = 0; t < MAIN + 1u; t++)
        if (thread[t].state == T_ASLEEP && thread[t].wake_us <= now_us)
            thread[t].state = T_READY;
    if (pick() < running)
        ask_switch();
}

/* Where a core's entry returns to: the core is done, and never runs again. */
static void core_exit(void)
{
    irq_off();
    thread[running].state = T_DONE;
    ask_switch();
    irq_on();
    for (;;) {
    }
}

static void core_trampoline(void)
{
    thread_t *t = &thread[running];
    t->entry(t->arg);
    core_exit();
}

static void idle_loop(void)
{
    for (;;)
        __asm__ volatile("wfi");
}

/* A fresh context at the top of a stack: PendSV pops r4-r11 and EXC_RETURN, the processor the
   rest, and the thread begins at fn. */
static uint32_t *fresh_context(uint32_t *stack, size_t words, void (*fn)(void))
{
    uint32_t *sp = stack + words;
    *--sp = XPSR_THUMB;
    *--sp = (uint32_t)(uintptr_t)fn; /* pc */
    *--sp = (uint32_t)(uintptr_t)core_exit; /* lr */
    for (int r = 0; r < 5; r++)      /* r12, r3, r2, r1, r0 */
        *--sp = 0;
    *--sp = EXC_RETURN_THREAD_PSP;
    for (int r = 0; r < 8; r++)      /* r11 .. r4 */
        *--sp = 0;
    return sp;
}

static void start_scheduler(void)
{
    thread[MAIN].state = T_READY;
    thread[IDLE].stack = stack_idle;
    thread[IDLE].stack_words = IDLE_STACK_WORDS;
    thread[IDLE].sp = fresh_context(stack_idle, IDLE_STACK_WORDS, idle_loop);
    thread[IDLE].state = T_READY;
    started = 1;
}

int hal_stdc_target_core_start(hal_core_id_t id, hal_core_entry_t entry, void *arg)
{
    if ((unsigned)id >= (unsigned)HAL_CORE_COUNT || entry == NULL)
        return -EINVAL;
    thread_t *t = &thread[id];
    if (t->state != T_FREE)
        return -EBUSY;
    for (size_t i = 0; i < core_words[id]; i++)
        core_stack[id][i] = STACK_PAINT;
    irq_off();
    if (!started)
        start_scheduler();
    t->stack = core_stack[id];
    t->stack_words = core_words[id];
    t->entry = entry;
    t->arg = arg;
    t->sp = fresh_context(t->stack, t->stack_words, core_trampoline);
    t->state = T_READY;
    if (pick() < running)
        ask_switch();
    irq_on();
    return 0;
}

int hal_stdc_target_core_stack(hal_core_id_t id, size_t *used, size_t *size)
{
    if ((unsigned)id >= (unsigned)HAL_CORE_COUNT)
        return -EINVAL;
    const thread_t *t = &thread[id];
    if (t->state == T_FREE)
        return -ESRCH;
    size_t i = 0;
    while (i < t->stack_words && t->stack[i] == STACK_PAINT)
        i++;
    *used = (t->stack_words - i) * 4u;
    *size = t->stack_words * 4u;
    return 0;
}

int hal_stdc_target_core_self(hal_core_id_t *id)
{
    if (running >= (uint32_t)HAL_CORE_COUNT)
        return -EPERM;
    *id = (hal_core_id_t)running;
    return 0;
}

void hal_stdc_target_sleep_until(uint64_t wake_us)
{
    while (hal_stdc_target_now_us() < wake_us) {
        if (!started) { /* one thread, nothing else to run: wait for the next tick */
            __asm__ volatile("wfi");
            continue;
        }
        irq_off();
        thread[running].wake_us = wake_us;
        thread[running].state = T_ASLEEP;
        ask_switch(); /* taken when the interrupts are on again: this thread stops here */
        irq_on();
    }
}

const char *hal_stdc_cm_thread_name(void)
{
    static const char *const names[THREADS] = {"RT core", "GP core", "AI core", "main program", "idle"};
    return started ? names[running] : "main program";
}
