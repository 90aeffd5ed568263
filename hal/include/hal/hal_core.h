/* Core start-up and stack accounting.
 *
 * Each core of the image runs one entry function on a FIXED stack that the board
 * allocates statically (BOARD_STACK_RT_BYTES, BOARD_STACK_GP_BYTES, BOARD_STACK_AI_BYTES).
 * The board prepares the stack before the core starts (the MCU boards paint it; the host
 * drops its pages and later finds the deepest one touched), so the deepest use so far (the
 * high-water mark) can be read at any time.
 *
 * Contract
 * - hal_core_start() is called by the image's start-up code (any thread, before or while
 *   the board runs); each core id may be started once per board run (-EBUSY afterwards).
 *   The core begins at the current simulated time. Its entry function returns when the
 *   core is done (typically after hal_sleep_until_us() returned -ECANCELED).
 * - The entry runs on its own thread of execution; cores share memory only through the
 *   fixed-size buffers of firmware/common (rings, mailboxes).
 */
#ifndef HAL_CORE_H
#define HAL_CORE_H

#include "hal/hal_board.h"

typedef void (*hal_core_entry_t)(void *arg);

typedef struct hal_core_ops {
    /* Required. */
    int (*start)(void *ctx, hal_core_id_t id, hal_core_entry_t entry, void *arg);
    /* Optional. Deepest stack use so far in bytes, and the stack size. */
    int (*stack_high_water)(void *ctx, hal_core_id_t id, size_t *used_bytes,
                            size_t *size_bytes);
    /* Optional. The core the caller runs on; -EPERM when not on a core. */
    int (*self)(void *ctx, hal_core_id_t *id);
} hal_core_ops_t;

/* Starts core `id` running entry(arg). 0, -EINVAL, -EBUSY (already started), -EAGAIN
 * (the back end could not create it), -ENODEV. */
FS_MUST_CHECK static inline int hal_core_start(hal_core_id_t id, hal_core_entry_t entry, void *arg)
{
    const hal_board_t *b = hal_board_current;
    if ((unsigned)id >= (unsigned)HAL_CORE_COUNT || entry == NULL)
        return -EINVAL;
    if (b == NULL || b->core == NULL)
        return -ENODEV;
    return b->core->start(b->ctx, id, entry, arg);
}

/* High-water mark of core `id`'s stack: bytes the core ever used below its entry frame, and
 * the board's stack size for it (BOARD_STACK_<core>_BYTES; a host may keep thread-local
 * storage in a reserve above it, which is not counted). 0, -EINVAL, -ESRCH (never started), -ENOTSUP, -ENODEV. */
FS_MUST_CHECK static inline int hal_core_stack_high_water(hal_core_id_t id, size_t *used_bytes,
                                                    size_t *size_bytes)
{
    const hal_board_t *b = hal_board_current;
    if ((unsigned)id >= (unsigned)HAL_CORE_COUNT || used_bytes == NULL || size_bytes == NULL)
        return -EINVAL;
    if (b == NULL || b->core == NULL)
        return -ENODEV;
    if (b->core->stack_high_water == NULL)
        return -ENOTSUP;
    return b->core->stack_high_water(b->ctx, id, used_bytes, size_bytes);
}

/* The calling core's id. 0, -EINVAL, -EPERM (not called from a core), -ENOTSUP, -ENODEV. */
FS_MUST_CHECK static inline int hal_core_self(hal_core_id_t *id)
{
    const hal_board_t *b = hal_board_current;
    if (id == NULL)
        return -EINVAL;
    if (b == NULL || b->core == NULL)
        return -ENODEV;
    if (b->core->self == NULL)
        return -ENOTSUP;
    return b->core->self(b->ctx, id);
}

#endif /* HAL_CORE_H */
