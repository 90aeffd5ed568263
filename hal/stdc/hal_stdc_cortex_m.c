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
 * 25 MHz on QEMU's MPS2 boards), reloaded at 2^24 and extended to 64 bits by its interrupt.
 * Instructions: QEMU does not model cycles; with `-icount shift=0` every instruction
 * advances virtual time by 1 ns, so SysTick ticks count instructions. The ratio is measured
 * at start on a loop of known length (2 instructions per turn); without -icount the ratio is
 * not a whole number and instructions are reported unsupported. */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hal_stdc_target.h"

#ifndef BOARD_CORE_CLOCK_HZ
#error "a Cortex-M board must define BOARD_CORE_CLOCK_HZ (the SysTick clock of its model)"
#endif

#define SYST ((volatile uint32_t *)0xE000E010u) /* CSR, RVR, CVR, CALIB */
#define CPACR (*(volatile uint32_t *)0xE000ED88u)
#define SYST_RELOAD 0xFFFFFFu
#define STACK_PAINT 0xA5A5A5A5u
#define MAIN_ARGS_MAX 16
#define CMDLINE_MAX 512

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
    fault_handler, /* PendSV */
    systick_handler,
};

static int semihost(int op, void *arg)
{
    register int r0 __asm__("r0") = op;
    register void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void systick_handler(void)
{
    systick_wraps++;
}

static uint64_t systick_ticks(void)
{
    uint32_t w, v;
    do {
        w = systick_wraps;
        v = SYST[2];
    } while (w != systick_wraps);
    return ((uint64_t)w << 24) + (SYST_RELOAD - v);
}

void fault_handler(void)
{
    uint32_t ipsr;
    __asm__ volatile("mrs %0, ipsr" : "=r"(ipsr));
    static const char *const kind[] = {"", "", "NMI", "HardFault", "MemManage", "BusFault", "UsageFault"};
    const char *k = (ipsr & 0x1FFu) < 7u ? kind[ipsr & 0x1FFu] : "exception";
    char msg[64];
    snprintf(msg, sizeof msg, "FAULT: %s (exception %lu)\n", k, (unsigned long)(ipsr & 0x1FFu));
    semihost(0x04 /* SYS_WRITE0 */, msg);
    _Exit(70);
}

/* Instructions per SysTick tick, measured on 2 x 2^20 instructions. */
static uint32_t calibrate(void)
{
    uint32_t n = 1u << 20;
    uint64_t t0 = systick_ticks();
    __asm__ volatile("1: subs %0, %0, #1\n bne 1b" : "+r"(n) : : "cc");
    uint64_t dt = systick_ticks() - t0;
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
    for (char *p = strtok(buf, " "); p != NULL && argc < MAIN_ARGS_MAX; p = strtok(NULL, " "))
        argv[argc++] = p;
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
    SYST[1] = SYST_RELOAD;
    SYST[2] = 0;
    SYST[0] = 7u; /* enable, interrupt on wrap, core clock */
    initialise_monitor_handles();
    __libc_init_array();
    insn_per_tick = calibrate();
    static char cmdline[CMDLINE_MAX];
    static char *argv[MAIN_ARGS_MAX + 1];
    int argc = cmdline_argv(cmdline, sizeof cmdline, argv);
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

uint64_t hal_stdc_target_now_us(void)
{
    return systick_ticks() / (BOARD_CORE_CLOCK_HZ / 1000000u);
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
