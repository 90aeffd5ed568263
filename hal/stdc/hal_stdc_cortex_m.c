/* The stdc back end's Cortex-M target (hal_stdc_target.h): start-up, time base, instruction
 * count and stack of a bare-metal image run under semihosting (newlib's librdimon).
 *
 * Start-up: QEMU (or a debug probe) loads every section at its address, so there is nothing
 * to copy; reset_handler enables the FPU, zeroes the NOLOAD RAM, paints the main stack,
 * starts SysTick, opens the semihosting console, runs the C library's constructors, takes
 * argv from the semihosting command line (SYS_GET_CMDLINE) and exits with main's return
 * value, which QEMU passes on as its own exit code. A fault prints its kind and exits 70.
 *
 * Time base: SysTick on the core clock (BOARD_CORE_CLOCK_HZ as the board's model clocks it;
 * 25 MHz on QEMU's MPS2 boards), interrupting HAL_STDC_CM_TICK_HZ times a second, which the
 * interrupt counts to extend it to 64 bits and the scheduler wakes sleeping cores on
 * (hal_stdc_cortex_m_cores.c).
 * Instructions: QEMU does not model cycles; with `-icount shift=0` every instruction
 * advances virtual time by 1 ns, so SysTick ticks count instructions. The ratio is measured
 * at start on a loop of known length (2 instructions per turn); without -icount the ratio is
 * not a whole number and instructions are reported unsupported. */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hal_stdc_cortex_m_cores.h"
#include "hal_stdc_target.h"

#ifndef BOARD_CORE_CLOCK_HZ
#error "a Cortex-M board must define BOARD_CORE_CLOCK_HZ (the SysTick clock of its model)"
#endif

#define SYST ((volatile uint32_t *)0xE000E010u) /* CSR, RVR, CVR, CALIB */
#define CPACR (*(volatile uint32_t *)0xE000ED88u)
#define ICSR (*(volatile uint32_t *)0xE000ED04u)
#define ICSR_PENDSTSET (1u << 26)
#define SHPR3 (*(volatile uint32_t *)0xE000ED20u) /* priorities of PendSV (23:16), SysTick (31:24) */
#define SYST_RELOAD (BOARD_CORE_CLOCK_HZ / HAL_STDC_CM_TICK_HZ - 1u)
#define HANDLER_STACK_WORDS 512u /* 2 KB for the interrupt handlers (the main stack pointer) */
_Static_assert(1000000000u % BOARD_CORE_CLOCK_HZ == 0 && BOARD_CORE_CLOCK_HZ % 1000000u == 0, "whole ns, us per tick");
_Static_assert(BOARD_CORE_CLOCK_HZ % HAL_STDC_CM_TICK_HZ == 0 && SYST_RELOAD <= 0xFFFFFFu, "SysTick reload");
#define STACK_PAINT 0xA5A5A5A5u
#define MAIN_ARGS_MAX 64
#define CMDLINE_MAX 1024

extern uint32_t __stack_top, __stack_limit;           /* the main stack (linker script) */
extern uint32_t __bss_start__, __bss_end__;           /* .bss in the fast RAM */
extern uint32_t __ram_ext_start__, __ram_ext_end__;   /* zeroed statics in the external RAM */
extern void initialise_monitor_handles(void);         /* librdimon */
extern void __libc_init_array(void);
extern int main(int argc, char **argv);

void reset_handler(void);
void systick_handler(void);
void fault_handler(void);

static volatile uint32_t systick_wraps;
static uint32_t insn_per_tick; /* 0: not counting */
/* Lockstep (hal_stdc_target_hold): SysTick ticks held so far, and where the current hold began. */
static uint64_t held_ticks, hold_from;
static int holding;

__attribute__((section(".vectors"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(uintptr_t)&__stack_top, /* initial SP */
    reset_handler,
    fault_handler, /* NMI */
    fault_handler, /* HardFault */
    fault_handler, /* MemManage */
    fault_handler, /* BusFault */
    fault_handler, /* UsageFault */
    0, 0, 0, 0,
    fault_handler, /* SVCall */
    fault_handler, /* DebugMonitor */
    0,
    hal_stdc_cm_pendsv,
    systick_handler,
};

static int semihost(int op, void *arg)
{
    register int r0 __asm__("r0") = op;
    register void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

static uint64_t systick_ticks(void)
{
    uint32_t w, v, pending;
    do {
        w = systick_wraps;
        v = SYST[2];
        pending = ICSR & ICSR_PENDSTSET;
    } while (w != systick_wraps);
    if (pending && v > SYST_RELOAD / 2u) /* it wrapped, and its interrupt is not taken yet */
        w++;
    return (uint64_t)w * (SYST_RELOAD + 1u) + (SYST_RELOAD - v);
}

void systick_handler(void)
{
    systick_wraps++;
    hal_stdc_cm_tick(hal_stdc_target_now_us());
}

void fault_handler(void)
{
    uint32_t ipsr;
    __asm__ volatile("mrs %0, ipsr" : "=r"(ipsr));
    static const char *const kind[] = {"", "", "NMI", "HardFault", "MemManage", "BusFault", "UsageFault"};
    const char *k = (ipsr & 0x1FFu) < 7u ? kind[ipsr & 0x1FFu] : "exception";
    char msg[96];
    snprintf(msg, sizeof msg, "FAULT: %s (exception %lu) in the %s\n", k, (unsigned long)(ipsr & 0x1FFu),
             hal_stdc_cm_thread_name());
    semihost(0x04 /* SYS_WRITE0 */, msg);
    _Exit(70);
}

/* Instructions per SysTick tick, measured on 2 x 2^20 instructions, before the time base
 * starts: SysTick counts down its whole 24 bits without interrupting (no handler's instructions
 * in the loop's time; 2^21 instructions are 2^21 / 40 ticks at 25 MHz, far from a wrap). */
static uint32_t calibrate(void)
{
    SYST[0] = 0;
    SYST[1] = 0xFFFFFFu;
    SYST[2] = 0;
    SYST[0] = 5u; /* enable, no interrupt, core clock */
    uint32_t n = 1u << 20;
    const uint32_t c0 = SYST[2];
    __asm__ volatile("1: subs %0, %0, #1\n bne 1b" : "+r"(n) : : "cc");
    const uint64_t dt = (c0 - SYST[2]) & 0xFFFFFFu;
    SYST[0] = 0;
    if (dt == 0)
        return 0;
    uint64_t insns = 2ull << 20;
    uint64_t ratio = (insns + dt / 2u) / dt;
    /* A whole ratio within the loop's overhead (a few instructions) means -icount. */
    uint64_t err = ratio * dt > insns ? ratio * dt - insns : insns - ratio * dt;
    return ratio >= 1 && err <= ratio + 16u ? (uint32_t)ratio : 0;
}

static int cmdline_argv(char *buf, size_t cap, char **argv)
{
    struct {
        char *buf;
        int len;
    } blk = {buf, (int)cap};
    if (semihost(0x15 /* SYS_GET_CMDLINE */, &blk) != 0)
        return 0;
    int argc = 0;
    for (char *p = strtok(buf, " "); p != NULL; p = strtok(NULL, " ")) {
        if (argc == MAIN_ARGS_MAX)
            return -1; /* never cut silently: the program would run with other options */
        argv[argc++] = p;
    }
    argv[argc] = NULL;
    return argc;
}

void reset_handler(void)
{
    CPACR |= 0xFu << 20; /* CP10, CP11: full access to the FPU */
    __asm__ volatile("dsb\n isb");
    for (uint32_t *p = &__bss_start__; p < &__bss_end__; p++)
        *p = 0;
    for (uint32_t *p = &__ram_ext_start__; p < &__ram_ext_end__; p++)
        *p = 0;
    uint32_t *sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    for (uint32_t *p = &__stack_limit; p < sp - 16; p++)
        *p = STACK_PAINT;
    /* The program goes on on the process stack (the same memory: nothing moves), the
       interrupts get a stack of their own: every thread of the scheduler then keeps its context
       the same way (hal_stdc_cortex_m_cores.c). */
    static uint32_t handler_stack[HANDLER_STACK_WORDS] __attribute__((aligned(8)));
    __asm__ volatile("mrs r0, msp\n msr psp, r0\n mrs r0, control\n orr r0, r0, #2\n msr control, r0\n isb\n"
                     "msr msp, %0\n"
                     :
                     : "r"(&handler_stack[HANDLER_STACK_WORDS])
                     : "r0", "memory");
    SHPR3 = (SHPR3 & 0x0000FFFFu) | 0xFFu << 16; /* PendSV lowest, SysTick highest */
    insn_per_tick = calibrate();
    SYST[1] = SYST_RELOAD;
    SYST[2] = 0;
    SYST[0] = 7u; /* enable, interrupt on wrap, core clock */
    initialise_monitor_handles();
    __libc_init_array();
    static char cmdline[CMDLINE_MAX];
    static char *argv[MAIN_ARGS_MAX + 1];
    int argc = cmdline_argv(cmdline, sizeof cmdline, argv);
    if (argc < 0) {
        fprintf(stderr, "start-up: more than %d arguments on the semihosting command line\n", MAIN_ARGS_MAX);
        exit(2);
    }
    exit(main(argc, argv));
}

/* The C library's constructor and destructor hooks (crti/crtn are not linked: no crt0). */
void _init(void);
void _fini(void);
void _init(void)
{
}
void _fini(void)
{
}

static uint32_t irq_mask(void)
{
    uint32_t primask;
    __asm__ volatile("mrs %0, primask\n cpsid i" : "=r"(primask)::"memory");
    return primask;
}

static void irq_restore(uint32_t primask)
{
    __asm__ volatile("msr primask, %0" ::"r"(primask) : "memory");
}

/* The board's clock in SysTick ticks: the time base less the holds, read with interrupts masked
   so that a hold's two words are never seen half written. */
static uint64_t board_ticks(void)
{
    const uint32_t m = irq_mask();
    const uint64_t t = (holding ? hold_from : systick_ticks()) - held_ticks;
    irq_restore(m);
    return t;
}

void hal_stdc_target_hold(int on)
{
    const uint32_t m = irq_mask();
    const uint64_t now = systick_ticks();
    if (on && !holding) {
        hold_from = now;
        holding = 1;
    } else if (!on && holding) {
        held_ticks += now - hold_from;
        holding = 0;
    }
    irq_restore(m);
}

uint64_t hal_stdc_target_link_ns(void)
{
    return systick_ticks() * (1000000000u / BOARD_CORE_CLOCK_HZ);
}

uint64_t hal_stdc_target_now_us(void)
{
    return board_ticks() / (BOARD_CORE_CLOCK_HZ / 1000000u);
}

uint64_t hal_stdc_target_now_ns(void)
{
    return board_ticks() * (1000000000u / BOARD_CORE_CLOCK_HZ);
}

int hal_stdc_target_instructions(uint64_t *n)
{
    if (insn_per_tick == 0)
        return -ENOTSUP;
    *n = systick_ticks() * insn_per_tick;
    return 0;
}

void hal_stdc_target_mark(uint32_t id)
{
    (void)id; /* instructions are counted here (hal_stdc_target_instructions) */
}

int hal_stdc_target_rename(const char *from, const char *to)
{
    const uint32_t blk[4] = {(uint32_t)(uintptr_t)from, (uint32_t)strlen(from), (uint32_t)(uintptr_t)to,
                             (uint32_t)strlen(to)};
    return semihost(0x0F /* SYS_RENAME */, (void *)blk) == 0 ? 0 : -1;
}

const char *hal_stdc_target_name(void)
{
    return "cortex-m, bare metal (semihosting)";
}

int hal_stdc_target_stack(size_t *used, size_t *size)
{
    const uint32_t *p = &__stack_limit;
    while (p < &__stack_top && *p == STACK_PAINT)
        p++;
    *used = (size_t)((uintptr_t)&__stack_top - (uintptr_t)p);
    *size = (size_t)((uintptr_t)&__stack_top - (uintptr_t)&__stack_limit);
    return 0;
}
