/* Levelled, printf-like log.
 *
 * Who may call: any core and the start-up thread. Best effort: a message may be cut to the
 * back end's line length or filtered by level; logging never fails the caller, so the
 * result may be ignored. The back end adds the simulated time and the core's name.
 * The host back end writes each line with one write to stderr (this can block the caller
 * for the write in wall time, never in simulated time); a real board would queue it.
 */
#ifndef HAL_LOG_H
#define HAL_LOG_H

#include <stdarg.h>

#include "hal/hal_board.h"

typedef enum hal_log_level {
    HAL_LOG_ERROR = 0,
    HAL_LOG_WARN = 1,
    HAL_LOG_INFO = 2,
    HAL_LOG_DEBUG = 3
} hal_log_level_t;

#define HAL_LOG_LINE_MAX 256u /* bytes of one formatted message; longer ones are cut */

typedef struct hal_log_ops {
    /* Required. */
    void (*vlog)(void *ctx, hal_log_level_t level, const char *fmt, va_list ap);
} hal_log_ops_t;

/* Logs one message. 0, -EINVAL (bad level or NULL fmt), -ENODEV (no board). */
__attribute__((format(printf, 2, 3))) static inline int hal_log(hal_log_level_t level,
                                                                const char *fmt, ...)
{
    const hal_board_t *b = hal_board_current;
    if (fmt == NULL || (unsigned)level > (unsigned)HAL_LOG_DEBUG)
        return -EINVAL;
    if (b == NULL || b->log == NULL)
        return -ENODEV;
    va_list ap;
    va_start(ap, fmt);
    b->log->vlog(b->ctx, level, fmt, ap);
    va_end(ap);
    return 0;
}

#endif /* HAL_LOG_H */
