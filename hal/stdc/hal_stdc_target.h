/* What one target gives the stdc back end (hal_stdc.h): its time base and, where the target
 * can count them, the instructions it retired. One implementation per target:
 * hal_stdc_cortex_m.c (bare metal under semihosting) and hal_stdc_posix.c (Linux). */
#ifndef HAL_STDC_TARGET_H
#define HAL_STDC_TARGET_H

#include <stddef.h>
#include <stdint.h>

#include "hal/hal_core.h"

/* Monotonic microseconds since the program started. */
uint64_t hal_stdc_target_now_us(void);

/* The same in nanoseconds, at the time base's resolution (40 ns: SysTick at 25 MHz on QEMU's
 * MPS2 boards), for measuring what is shorter than a microsecond. */
uint64_t hal_stdc_target_now_ns(void);

/* Lockstep with a world (hardware in the loop, as PX4's lockstep simulation): while held, the
 * target's clock (now_us, now_ns, and the scheduler's wake-ups, which follow it) stands still,
 * so the time the board spends waiting for the world's answer is not the board's: its timeline
 * is its own work alone, the same on a fast host as on a slow one. Held and released by the one
 * thread that owns the link (hal_stdc_install_hil); a reader on another thread or in an
 * interrupt sees a consistent clock. */
void hal_stdc_target_hold(int on);

/* The time base without the holds, in nanoseconds: what the link's own timeouts count. */
uint64_t hal_stdc_target_link_ns(void);

/* Instructions retired since the program started, into *n. 0, or -ENOTSUP where the target
 * cannot count them. */
int hal_stdc_target_instructions(uint64_t *n);

/* Marks a point of the program for an instruction counter outside it (on Linux boards QEMU's
 * plugin tools/board/qemu_insn.c logs "insn_mark <id> <instructions so far>"); a no-op where the
 * target counts instructions itself. */
#define HAL_STDC_MARK_SYSCALL 4085 /* no such system call: the kernel answers ENOSYS, harmless */
void hal_stdc_target_mark(uint32_t id);

/* rename(from, to) of the target's files: 0 or -1. On a Cortex-M the semihosting call itself
 * (newlib 3.3's librdimon answers ENOSYS to rename() under QEMU 7.2, whose SYS_RENAME works). */
int hal_stdc_target_rename(const char *from, const char *to);

/* The target's name for logs and profiles ("cortex-m (QEMU -icount)", "linux"). */
const char *hal_stdc_target_name(void);

/* Deepest use of the program's main stack so far, and its size, in bytes. 0 or -ENOTSUP. */
int hal_stdc_target_stack(size_t *used, size_t *size);

/* Cores as threads of the target (hal_core.h's contract), where it has a scheduler: the Cortex-M
 * target's (hal_stdc_cortex_m_cores.c: fixed priorities RT > GP > AI > main, preemptive, on the
 * SysTick). 0, -EBUSY (started before), -ENOTSUP (no scheduler: the Linux target, whose boards
 * run the host HAL's threads instead). */
int hal_stdc_target_core_start(hal_core_id_t id, hal_core_entry_t entry, void *arg);

/* Deepest use so far of a started core's stack, and its size. 0, -ESRCH (not started), -ENOTSUP. */
int hal_stdc_target_core_stack(hal_core_id_t id, size_t *used, size_t *size);

/* The core the caller runs on. 0, -EPERM (the main program), -ENOTSUP. */
int hal_stdc_target_core_self(hal_core_id_t *id);

/* Until the target's time reaches wake_us: the caller sleeps and the other threads run (a core
 * wakes at the first scheduler tick at or after wake_us), or, without a scheduler, waits on the
 * time base. */
void hal_stdc_target_sleep_until(uint64_t wake_us);

#endif /* HAL_STDC_TARGET_H */
