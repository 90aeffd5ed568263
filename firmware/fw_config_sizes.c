/* The firmware library's view of the build configuration (see fw_config_sizes.h), and the
 * type-level checks that -imacros cannot carry (common/fw_config.h holds only macros). */
#include "fw_config_sizes.h"

_Static_assert(DINNO_MAX_PEERS == BOARD_MAX_PEERS, "the DiNNO neighbour slots follow the board");
_Static_assert(HAL_NET_MTU_BYTES == (size_t)BOARD_NET_MTU_BYTES, "the HAL MTU is the board's");

const fw_config_sizes_t fw_config_sizes = FW_CONFIG_SIZES_HERE;
