/* Compile-time check that the selected board (boards/<BOARD>/board.h, on the include path
 * through `make BOARD=...`) defines every setting the firmware is dimensioned from.
 * Include this instead of board.h directly. */
#ifndef COMMON_BOARD_CHECK_H
#define COMMON_BOARD_CHECK_H

#include "board.h"

#ifndef BOARD_NAME
#error "board.h must define BOARD_NAME"
#endif
#if !defined(BOARD_RAM_RT_BYTES) || !defined(BOARD_RAM_GP_BYTES) || !defined(BOARD_RAM_AI_BYTES)
#error "board.h must define BOARD_RAM_RT_BYTES, BOARD_RAM_GP_BYTES and BOARD_RAM_AI_BYTES"
#endif
#if !defined(BOARD_STACK_RT_BYTES) || !defined(BOARD_STACK_GP_BYTES) || !defined(BOARD_STACK_AI_BYTES)
#error "board.h must define BOARD_STACK_RT_BYTES, BOARD_STACK_GP_BYTES and BOARD_STACK_AI_BYTES"
#endif
#ifndef BOARD_NET_MTU_BYTES
#error "board.h must define BOARD_NET_MTU_BYTES"
#endif
#ifndef BOARD_MAX_PEERS
#error "board.h must define BOARD_MAX_PEERS"
#endif

_Static_assert(BOARD_RAM_RT_BYTES > 0 && BOARD_RAM_GP_BYTES > 0 && BOARD_RAM_AI_BYTES > 0,
               "board memory budgets must be positive");
_Static_assert(BOARD_MAX_PEERS >= 1 && BOARD_MAX_PEERS <= 255, "BOARD_MAX_PEERS out of range");

#endif /* COMMON_BOARD_CHECK_H */
