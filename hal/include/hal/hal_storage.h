/* Non-volatile storage of named blobs (checkpoints, maps).
 *
 * Contract
 * - Names: 1 .. HAL_STORAGE_NAME_MAX-1 characters from [A-Za-z0-9_.-], not starting with
 *   '.', not containing "..". Anything else is -EINVAL (so a name can never leave the
 *   storage area).
 * - hal_storage_write() replaces the blob atomically: after a crash or power loss at any
 *   point, a read returns either the whole old blob or the whole new one.
 * - Blocking: writes and reads block the caller for the duration of the I/O, so only the
 *   GP core may call them (never the RT core).
 */
#ifndef HAL_STORAGE_H
#define HAL_STORAGE_H

#include "hal/hal_board.h"

#define HAL_STORAGE_NAME_MAX 64u /* bytes, terminating NUL included */

typedef struct hal_storage_ops {
    /* Required. */
    int (*write)(void *ctx, const char *name, const void *data, size_t len);
    int (*read)(void *ctx, const char *name, void *buf, size_t cap, size_t *len);
    /* Optional. */
    int (*remove)(void *ctx, const char *name);
} hal_storage_ops_t;

/* 1 when `name` is a valid blob name, else 0. */
static inline int hal_storage_name_valid(const char *name)
{
    if (name == NULL || name[0] == '.' || name[0] == '\0')
        return 0;
    for (size_t n = 0; name[n] != '\0'; n++) {
        char c = name[n];
        int ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                 c == '_' || c == '.' || c == '-';
        if (!ok || n + 1u >= HAL_STORAGE_NAME_MAX)
            return 0;
        if (c == '.' && name[n + 1] == '.')
            return 0;
    }
    return 1;
}

/* Stores `len` bytes under `name`, replacing any blob of that name atomically.
 * 0, -EINVAL, -ENOSPC, -EIO, -ENODEV. */
FS_MUST_CHECK static inline int hal_storage_write(const char *name, const void *data, size_t len)
{
    const hal_board_t *b = hal_board_current;
    if (!hal_storage_name_valid(name) || (data == NULL && len > 0))
        return -EINVAL;
    if (b == NULL || b->storage == NULL)
        return -ENODEV;
    return b->storage->write(b->ctx, name, data, len);
}

/* Reads blob `name` into buf (cap bytes); *len receives its length. 0, -ENOENT,
 * -EMSGSIZE (blob longer than cap: *len tells the size, buf is unspecified), -EINVAL,
 * -EIO, -ENODEV. */
FS_MUST_CHECK static inline int hal_storage_read(const char *name, void *buf, size_t cap, size_t *len)
{
    const hal_board_t *b = hal_board_current;
    if (!hal_storage_name_valid(name) || len == NULL || (buf == NULL && cap > 0))
        return -EINVAL;
    if (b == NULL || b->storage == NULL)
        return -ENODEV;
    return b->storage->read(b->ctx, name, buf, cap, len);
}

/* Deletes blob `name`. 0, -ENOENT, -EINVAL, -EIO, -ENOTSUP, -ENODEV. */
FS_MUST_CHECK static inline int hal_storage_remove(const char *name)
{
    const hal_board_t *b = hal_board_current;
    if (!hal_storage_name_valid(name))
        return -EINVAL;
    if (b == NULL || b->storage == NULL)
        return -ENODEV;
    if (b->storage->remove == NULL)
        return -ENOTSUP;
    return b->storage->remove(b->ctx, name);
}

#endif /* HAL_STORAGE_H */
