/* The build configuration of a firmware image: the one place every setting that sizes a type
 * or a buffer is decided. The Makefile hands it to every translation unit (firmware, HAL back
 * end, host_sim, tests, benchmarks; C and C++) with `-imacros`, so no file can see another
 * value than its neighbours: a board that changes HAL_LIDAR_MAX_BEAMS changes hal_lidar_scan_t
 * everywhere at once.
 *
 * Order: the board's own boards/<BOARD>/board.h first (required settings, and any default
 * below it wants to change), then the defaults for what it left out, then the checks. Only
 * macros survive -imacros, so every check here is a preprocessor #if / #error. The checks that
 * need types are _Static_asserts elsewhere: that the firmware's own constants follow the board
 * (DINNO_MAX_PEERS, HAL_NET_MTU_BYTES) in firmware/fw_config_sizes.c, each core's state
 * against its RAM in its core file (rt/rt_core.c, gp/gp_core.c, ai/ai_core.c, fw_link.c;
 * ai/bnn.h, ai/dinno.h), the GEMM panels against the AI stack in ai/kernels/la_ref.c and
 * ai/kernels/la_bf16_ref.c; tests/common/test_config.c checks that every file saw one
 * configuration (`make check-config`).
 * Units: bytes unless the name says otherwise. Do not include this file; the build does. */
#ifndef COMMON_FW_CONFIG_H
#define COMMON_FW_CONFIG_H

#include "board.h"

/* ---- required from the board ------------------------------------------------------------ */
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
#error "board.h must define BOARD_NET_MTU_BYTES (the largest datagram of its network)"
#endif
#ifndef BOARD_MAX_PEERS
#error "board.h must define BOARD_MAX_PEERS (the neighbour states one round keeps: DiNNO's slots)"
#endif
#ifndef BOARD_MAX_FLEET
#error "board.h must define BOARD_MAX_FLEET (the largest fleet: ids 0 .. BOARD_MAX_FLEET - 1)"
#endif

/* ---- defaults a board may override in its board.h ---------------------------------------- */
/* Lidar beams per scan the HAL scan record holds. */
#ifndef HAL_LIDAR_MAX_BEAMS
#define HAL_LIDAR_MAX_BEAMS 360u
#endif
/* Waypoints of the RT core's tour table. */
#ifndef RT_CORE_MAX_WAYPOINTS
#define RT_CORE_MAX_WAYPOINTS 512
#endif
/* Samples one scan may give (n_beams * points_per_beam). */
#ifndef RT_CORE_MAX_SCAN_SAMPLES
#define RT_CORE_MAX_SCAN_SAMPLES 2048
#endif
/* RT -> AI sample ring: 16 scans of 20 x 25 samples. The AI core drains it every 100 ms while
 * the RT core adds one scan (500 samples) per 100 ms. Power of two. */
#ifndef FW_LINK_RING_CAPACITY
#define FW_LINK_RING_CAPACITY 8192u
#endif
/* AI core sample pool, in samples, from the network preset (one scan gives 500). */
#ifndef AI_POOL_CAPACITY
#if defined(BNN_PRESET_PAPER)
#define AI_POOL_CAPACITY (1u << 18)
#elif defined(BNN_PRESET_MCU)
#define AI_POOL_CAPACITY (1u << 12)
#else
#define AI_POOL_CAPACITY (1u << 17)
#endif
#endif
/* CRC-32 by slicing 8 bytes at a time (8 KB of tables, ~8x faster) or by nibbles (64 bytes). */
#ifndef CRC32_SLICE8
#define CRC32_SLICE8 1
#endif
/* Blocks of the pure-C GEMM (ai/kernels/la_ref.c): its packed panels, (MC + NC) x KC floats,
 * live on the calling core's stack (32 KB with these); boards with small stacks take smaller
 * blocks. */
#ifndef LA_REF_KC
#define LA_REF_KC 128
#endif
#ifndef LA_REF_MC
#define LA_REF_MC 32
#endif
#ifndef LA_REF_NC
#define LA_REF_NC 32
#endif
/* Round records the GP core keeps (a ring of the latest; the host reads them as they come). */
#ifndef GP_CORE_LOG_ROUNDS
#define GP_CORE_LOG_ROUNDS 1024u
#endif
/* The RT core's occupancy grid (rt/rt_grid.h, the exploration grid and the planner's
 * workspace: about 24 bytes a cell): cells in all, and per side (at most 1024). */
#ifndef RT_GRID_MAX_CELLS
#define RT_GRID_MAX_CELLS 65536
#endif
#ifndef RT_GRID_MAX_SIDE
#define RT_GRID_MAX_SIDE 1024
#endif

/* The model state the peers exchange, from the network preset (BNN_PRESET_*, set by the
 * Makefile): its fp32 parameters and bytes. The GP core sizes its state buffers with it without
 * knowing the network; the AI core checks it against the network (ai/ai_link.h). The count is
 * ai/bnn.h's BNN_N_PARAMS for SIREN width S, Bayesian width H and L Bayesian layers:
 * 3S + 2 (SH + H + (L - 1)(H^2 + H)) + H + 1. */
#if defined(BNN_PRESET_PAPER)
#define FW_STATE_S_ 256u
#define FW_STATE_H_ 256u
#define FW_STATE_L_ 4u
#elif defined(BNN_PRESET_MCU)
#define FW_STATE_S_ 64u
#define FW_STATE_H_ 48u
#define FW_STATE_L_ 3u
#else
#define FW_STATE_S_ 128u
#define FW_STATE_H_ 64u
#define FW_STATE_L_ 3u
#endif
#define FW_STATE_MAX_PARAMS                                                                    \
    (3u * FW_STATE_S_ +                                                                        \
     2u * (FW_STATE_S_ * FW_STATE_H_ + FW_STATE_H_ + (FW_STATE_L_ - 1u) * (FW_STATE_H_ * FW_STATE_H_ + FW_STATE_H_)) + \
     FW_STATE_H_ + 1u)
#define FW_STATE_MAX_BYTES (FW_STATE_MAX_PARAMS * 4u)

/* ---- toolchain --------------------------------------------------------------------------- */
/* The one check-return marker: a function that can fail (0 or a negative errno) carries it,
 * and the compiler makes every caller look at the result. */
#define FS_MUST_CHECK __attribute__((warn_unused_result))

/* ---- checks -------------------------------------------------------------------------------- */
#if BOARD_RAM_RT_BYTES <= 0 || BOARD_RAM_GP_BYTES <= 0 || BOARD_RAM_AI_BYTES <= 0
#error "board memory budgets must be positive"
#endif
#if BOARD_MAX_PEERS < 1 || BOARD_MAX_PEERS > 255
#error "BOARD_MAX_PEERS must be 1 .. 255"
#endif
#if BOARD_MAX_FLEET < 1 || BOARD_MAX_FLEET > 65535
#error "BOARD_MAX_FLEET must be 1 .. 65535"
#endif
#if BOARD_NET_MTU_BYTES < 1024
#error "BOARD_NET_MTU_BYTES must be at least 1024"
#endif
#if HAL_LIDAR_MAX_BEAMS < 1 || HAL_LIDAR_MAX_BEAMS > 4096
#error "HAL_LIDAR_MAX_BEAMS must be 1 .. 4096"
#endif
#if RT_CORE_MAX_WAYPOINTS < 2 || RT_CORE_MAX_SCAN_SAMPLES < 1
#error "RT_CORE_MAX_WAYPOINTS must be >= 2 and RT_CORE_MAX_SCAN_SAMPLES >= 1"
#endif
#if FW_LINK_RING_CAPACITY < 2 || (FW_LINK_RING_CAPACITY & (FW_LINK_RING_CAPACITY - 1)) != 0
#error "FW_LINK_RING_CAPACITY must be a power of two >= 2"
#endif
#if AI_POOL_CAPACITY < 1 || AI_POOL_CAPACITY > 0xFFFFFFFF
#error "AI_POOL_CAPACITY must be 1 .. 2^32 - 1"
#endif
#if GP_CORE_LOG_ROUNDS < 1
#error "GP_CORE_LOG_ROUNDS must be >= 1"
#endif
#if RT_GRID_MAX_SIDE < 1 || RT_GRID_MAX_SIDE > 1024 || RT_GRID_MAX_CELLS < 1 || \
    RT_GRID_MAX_CELLS > RT_GRID_MAX_SIDE * RT_GRID_MAX_SIDE
#error "RT_GRID_MAX_SIDE must be 1 .. 1024 and RT_GRID_MAX_CELLS 1 .. RT_GRID_MAX_SIDE^2"
#endif

#endif /* COMMON_FW_CONFIG_H */
