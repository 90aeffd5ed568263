/* What the RT core publishes on its links (fw_link.h): its status record, and the samples of
 * its sample ring (ai/ai_sample.h). The RT core owns this header: it writes these links. */
#ifndef RT_RT_LINK_H
#define RT_RT_LINK_H

#include <stdint.h>

#include "ai/ai_sample.h"
#include "common/mbox.h"
#include "common/ring.h"

typedef struct rt_status {
    uint64_t stamp_us;       /* simulated time of the RT tick that wrote it */
    float x_m, y_m, heading_rad; /* latest GPS + compass fix */
    float distance_m;        /* odometry: integral of |commanded v| dt since start */
    float progress_m;        /* arc length of the path covered (monotone, <= path_length_m) */
    float path_length_m;     /* total arc length of the waypoint path */
    uint32_t waypoint;       /* index aimed at (== n when finished) */
    uint32_t finished;       /* 1 once the last waypoint was reached */
    uint32_t scans;          /* scans turned into samples */
    uint32_t samples;        /* samples pushed into the ring (accepted) */
    uint32_t ring_drops;     /* samples dropped because the ring was full */
    uint32_t errors;         /* HAL calls that failed (pose, lidar, motor) */
    uint32_t sample_errors;  /* scans rt_samples refused, and samples the ring refused for any
                                reason but full (a contract broken: never expected) */
} rt_status_t;

/* Static bytes of the RT core's links: the sample ring and both status mailboxes. */
#define RT_LINK_BYTES                                                                         \
    (RING_STORAGE_BYTES(sizeof(ai_sample_t), FW_LINK_RING_CAPACITY) +                          \
     2u * MBOX_STORAGE_BYTES(sizeof(rt_status_t)))

#endif /* RT_RT_LINK_H */
