/* What one target gives the stdc back end (hal_stdc.h): its time base and, where the target
 * can count them, the instructions it retired. One implementation per target:
 * hal_stdc_cortex_m.c (bare metal under semihosting) and hal_stdc_posix.c (Linux). */
#ifndef HAL_STDC_TARGET_H
#define HAL_STDC_TARGET_H

#include <stddef.h>
#include <stdint.h>

/* Monotonic microseconds since the program started. */
uint64_t hal_stdc_target_now_us(void);

/* Instructions retired since the program started, into *n. 0, or -ENOTSUP where the target
 * cannot count them. */
int hal_stdc_target_instructions(uint64_t *n);

/* Marks a point of the program for an instruction counter outside it (on Linux boards QEMU's
 * plugin tools/board/qemu_insn.c logs "insn_mark <id> <instructions so far>"); a no-op where the
 * target counts instructions itself. */
#define HAL_STDC_MARK_SYSCALL 4085 /* no such system call: the kernel answers ENOSYS, harmless */
void hal_stdc_target_mark(uint32_t id);

/* The target's name for logs and profiles ("cortex-m (QEMU -icount)", "linux"). */
const char *hal_stdc_target_name(void);

/* Deepest use of the program's main stack so far, and its size, in bytes. 0 or -ENOTSUP. */
int hal_stdc_target_stack(size_t *used, size_t *size);

#endif /* HAL_STDC_TARGET_H */
