/* Board "host": memory budgets and limits of a Linux PC standing in for the robot's SoC.
 *
 * Every firmware buffer is sized at compile time and checked against these budgets. The build
 * reads this file through firmware/common/fw_config.h, which lists the required settings and
 * the sizes a board may override here (lidar beams, ring and pool capacities, round log).
 * Units: bytes unless the name says otherwise. */
#ifndef BOARD_HOST_BOARD_H
#define BOARD_HOST_BOARD_H

#define BOARD_NAME "host"

/* Static RAM each core may use for its own buffers (arena, pools, rings it owns).
 * The host is generous so that the `paper` preset (527,361 parameters) fits with its
 * gradients, Adam moments, duals, neighbour slots and a 1024-point batch, and the GP core
 * the states of two rounds of BOARD_MAX_PEERS neighbours (gp_pse). The RT core's 4 MB hold
 * its exploration state (rt/rt_explore.h: the 65,536-cell fine grid and the planner's
 * workspace, about 1.6 MB) beside the tour's tables. */
#define BOARD_RAM_RT_BYTES (4u * 1024u * 1024u)
#define BOARD_RAM_GP_BYTES (256u * 1024u * 1024u)
#define BOARD_RAM_AI_BYTES (512u * 1024u * 1024u)

/* Fixed stack per core thread; only its touched pages are resident, and the deepest of them
 * gives the high-water mark (hal/host/hal_host_cores.c). */
#define BOARD_STACK_RT_BYTES (256u * 1024u)
#define BOARD_STACK_GP_BYTES (1024u * 1024u)
#define BOARD_STACK_AI_BYTES (8u * 1024u * 1024u)

/* Largest single network datagram the board's link layer accepts (docs/architecture.md section 4). */
#define BOARD_NET_MTU_BYTES (60u * 1024u)

/* Neighbour states one round keeps (DiNNO's slots; a fleet up to 33 robots uses every state). */
#define BOARD_MAX_PEERS 32u
/* Largest fleet (robot ids 0 .. BOARD_MAX_FLEET - 1): about 140 bytes of GP RAM per robot;
 * each round keeps the states of the BOARD_MAX_PEERS nearest within the radius. */
#define BOARD_MAX_FLEET 1024u

/* Sample pool of the AI core: 2^20 samples (12 MB), more than one tour of the default plan
 * gives (~550,000), so an offline robot trains on every sample it took, as the in-process
 * fleet does. */
#define AI_POOL_CAPACITY (1u << 20)

#endif /* BOARD_HOST_BOARD_H */
