/* The board: one table of HAL interfaces that a back end installs at start-up.
 *
 * A HAL interface is an operations table (a struct of function pointers, like a Zephyr
 * driver API or a FreeRTOS port layer) plus `static inline` wrappers in the interface's
 * header. Firmware calls only the wrappers, never the tables.
 *
 * Contract
 * - A back end fills a hal_board_t (every interface pointer it supports, one `ctx` passed
 *   back to every operation) and calls hal_board_install() once, from the start-up thread,
 *   BEFORE any core is started. The board must stay valid until every core has stopped.
 *   Installing is not synchronised with running cores: the start of a core's thread is the
 *   happens-before edge that publishes the board to it.
 * - Wrappers return 0 or a negative errno code: -ENODEV when no board is installed or the
 *   board lacks the whole interface, -ENOTSUP when the interface lacks an optional operation,
 *   otherwise what the operation returned.
 * - hal_board_install() checks that every REQUIRED operation of every interface present is
 *   non-NULL, so a wrapper for a required operation never meets a NULL pointer.
 * - One board per firmware image, one image per process (firmware storage is static).
 */
#ifndef HAL_BOARD_H
#define HAL_BOARD_H

#include <errno.h>
#include <stddef.h>
#include <stdint.h>


#ifdef __cplusplus
extern "C" {
#endif

/* The three cores of a firmware image. Values index per-core arrays. */
typedef enum hal_core_id {
    HAL_CORE_RT = 0, /* real-time: lidar, pose, motors, scan -> samples; never blocks */
    HAL_CORE_GP = 1, /* general purpose: network, telemetry, checkpoints */
    HAL_CORE_AI = 2, /* AI: BNN training and inference */
    HAL_CORE_COUNT = 3
} hal_core_id_t;

struct hal_clock_ops;
struct hal_lidar_ops;
struct hal_pose_ops;
struct hal_motor_ops;
struct hal_net_ops;
struct hal_storage_ops;
struct hal_core_ops;
struct hal_log_ops;

typedef struct hal_board {
    const char *name;                     /* board name, e.g. BOARD_NAME; non-NULL */
    void *ctx;                            /* passed as first argument to every operation */
    const struct hal_clock_ops *clock;    /* required */
    const struct hal_core_ops *core;      /* required */
    const struct hal_log_ops *log;        /* required */
    const struct hal_lidar_ops *lidar;    /* may be NULL: wrappers then return -ENODEV */
    const struct hal_pose_ops *pose;      /* may be NULL */
    const struct hal_motor_ops *motor;    /* may be NULL */
    const struct hal_net_ops *net;        /* may be NULL */
    const struct hal_storage_ops *storage;/* may be NULL */
    /* Optional: a broken contract (a programmer error, see HAL_ASSERT). Logs or records it
     * and does not return (a board resets, the host aborts); NULL: the core traps. */
    void (*fault)(void *ctx, const char *file, int line, const char *what);
} hal_board_t;

/* The installed board, NULL before hal_board_install(). Read by the wrappers. */
extern const hal_board_t *hal_board_current;

/* Installs `board` (NULL uninstalls). Returns 0, or -EINVAL when the board lacks a name, a
 * required interface (clock, core, log) or a required operation of an interface it has. */
FS_MUST_CHECK int hal_board_install(const hal_board_t *board);

/* Programmer errors (a NULL where the contract forbids it, an impossible state) are not
 * error codes on hot paths: HAL_ASSERT routes them to the board's fault handler, which does
 * not return. Errors the caller can meet at run time (full, empty, I/O) stay return codes. */
__attribute__((noreturn)) void hal_fault(const char *file, int line, const char *what);
#define HAL_ASSERT(cond) ((cond) ? (void)0 : hal_fault(__FILE__, __LINE__, #cond))

/* Short upper-case name of a core ("RT", "GP", "AI"), "?" for an invalid id. */
const char *hal_core_name(hal_core_id_t id);

#ifdef __cplusplus
}
#endif

#endif /* HAL_BOARD_H */
