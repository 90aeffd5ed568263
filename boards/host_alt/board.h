/* Board "host_alt": the host's budgets with every overridable size changed, so that a file
 * which does not take its sizes from the build configuration shows up as a mismatch in
 * tests/common/test_config.c. */
#ifndef BOARD_HOST_ALT_BOARD_H
#define BOARD_HOST_ALT_BOARD_H

#define BOARD_NAME "host_alt"
#define BOARD_HOST_ALT 1

#define BOARD_RAM_RT_BYTES (4u * 1024u * 1024u)
#define BOARD_RAM_GP_BYTES (64u * 1024u * 1024u)
#define BOARD_RAM_AI_BYTES (512u * 1024u * 1024u)
#define BOARD_STACK_RT_BYTES (256u * 1024u)
#define BOARD_STACK_GP_BYTES (1024u * 1024u)
#define BOARD_STACK_AI_BYTES (8u * 1024u * 1024u)

#define BOARD_NET_MTU_BYTES (8u * 1024u)
#define BOARD_MAX_PEERS 8u
/* Largest fleet (robot ids 0 .. BOARD_MAX_FLEET - 1): about 140 bytes of GP RAM per robot;
 * each round keeps the states of the BOARD_MAX_PEERS nearest within the radius. */
#define BOARD_MAX_FLEET 64u

/* Every default of firmware/common/fw_config.h, changed. */
#define HAL_LIDAR_MAX_BEAMS 180u
#define RT_CORE_MAX_WAYPOINTS 256
#define RT_CORE_MAX_SCAN_SAMPLES 1024
#define FW_LINK_RING_CAPACITY 4096u
#define AI_POOL_CAPACITY (1u << 15)
#define GP_CORE_LOG_ROUNDS 64u
#define RT_GRID_MAX_CELLS 16384
#define RT_GRID_MAX_SIDE 256
#define CRC32_SLICE8 0

#endif /* BOARD_HOST_ALT_BOARD_H */
