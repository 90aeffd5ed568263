/* The board registry of the HAL (hal/include/hal/hal_board.h), shared by every board port: a
 * port provides operation tables, not the registry. Like firmware/, it sees only the C library
 * and hal/include (tools/check-layering.sh), so it builds for bare-metal boards as it is. */
#include "hal/hal.h"

const hal_board_t *hal_board_current;

void hal_fault(const char *file, int line, const char *what)
{
    const hal_board_t *b = hal_board_current;
    if (b != NULL && b->fault != NULL)
        b->fault(b->ctx, file, line, what);
    /* No handler, or one that returned: stop here rather than run on a broken contract. */
    __builtin_trap();
}

const char *hal_core_name(hal_core_id_t id)
{
    switch (id) {
    case HAL_CORE_RT: return "RT";
    case HAL_CORE_GP: return "GP";
    case HAL_CORE_AI: return "AI";
    default: return "?";
    }
}

int hal_board_install(const hal_board_t *board)
{
    if (board == NULL) {
        hal_board_current = NULL;
        return 0;
    }
    if (board->name == NULL || board->clock == NULL || board->core == NULL || board->log == NULL)
        return -EINVAL;
    if (board->clock->now_us == NULL || board->clock->sleep_until_us == NULL ||
        board->core->start == NULL || board->log->vlog == NULL)
        return -EINVAL;
    if (board->lidar != NULL && board->lidar->read_scan == NULL)
        return -EINVAL;
    if (board->pose != NULL && board->pose->read_pose == NULL)
        return -EINVAL;
    /* A motor interface must offer at least one way to command. */
    if (board->motor != NULL && board->motor->set_wheels == NULL && board->motor->set_twist == NULL)
        return -EINVAL;
    if (board->net != NULL && (board->net->publish == NULL || board->net->subscribe == NULL ||
                               board->net->receive == NULL))
        return -EINVAL;
    if (board->storage != NULL && (board->storage->write == NULL || board->storage->read == NULL))
        return -EINVAL;
    hal_board_current = board;
    return 0;
}
