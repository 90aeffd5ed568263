/* The sizes one firmware library was compiled with, so that a program can check that every
 * part of it agrees on the build configuration (common/fw_config.h). A mismatch means a file
 * was built with other settings than its neighbours: the structures the cores share would then
 * have two layouts in one image. tests/common/test_config.c compares the library's view with
 * its own, for the default board and for boards/host_alt (other sizes).
 * FW_CONFIG_SIZES_HERE is the view of the file that expands it. */
#ifndef FW_CONFIG_SIZES_H
#define FW_CONFIG_SIZES_H

#include <stddef.h>
#include <stdint.h>

#include "ai/ai_core.h"
#include "fw_link.h"
#include "gp/gp_core.h"
#include "hal/hal_lidar.h"
#include "hal/hal_net.h"
#include "rt/rt_core.h"

typedef struct fw_config_sizes {
    size_t lidar_scan_bytes;  /* sizeof(hal_lidar_scan_t) */
    size_t rt_core_bytes;     /* sizeof(rt_core_t) */
    size_t ai_core_bytes;     /* sizeof(ai_core_t) */
    size_t gp_core_bytes;     /* sizeof(gp_core_t) */
    size_t link_bytes;        /* sizeof(fw_link_t) */
    size_t net_mtu_bytes;     /* HAL_NET_MTU_BYTES */
    uint32_t lidar_beams;     /* HAL_LIDAR_MAX_BEAMS */
    uint32_t max_peers;       /* BOARD_MAX_PEERS (= DINNO_MAX_PEERS) */
    uint32_t max_fleet;       /* BOARD_MAX_FLEET (= GP_PSE_MAX_FLEET) */
    uint32_t ring_capacity;   /* FW_LINK_RING_CAPACITY */
    uint32_t pool_capacity;   /* AI_POOL_CAPACITY */
    uint32_t log_rounds;      /* GP_CORE_LOG_ROUNDS */
    uint32_t max_waypoints;   /* RT_CORE_MAX_WAYPOINTS */
    uint32_t max_scan_samples;/* RT_CORE_MAX_SCAN_SAMPLES */
} fw_config_sizes_t;

#define FW_CONFIG_SIZES_HERE                                                                  \
    ((fw_config_sizes_t){sizeof(hal_lidar_scan_t), sizeof(rt_core_t), sizeof(ai_core_t),      \
                         sizeof(gp_core_t), sizeof(fw_link_t), HAL_NET_MTU_BYTES,             \
                         HAL_LIDAR_MAX_BEAMS, BOARD_MAX_PEERS, BOARD_MAX_FLEET,               \
                         FW_LINK_RING_CAPACITY,                                               \
                         AI_POOL_CAPACITY, GP_CORE_LOG_ROUNDS, RT_CORE_MAX_WAYPOINTS,         \
                         RT_CORE_MAX_SCAN_SAMPLES})

/* The library's view (compiled in firmware/fw_config_sizes.c). */
extern const fw_config_sizes_t fw_config_sizes;

#endif /* FW_CONFIG_SIZES_H */
