/* The hardware-in-the-loop link's payloads (the frames are hal_hil_frame.h's), every field
 * little-endian, floats as their IEEE-754 bits. Every decoder checks the whole payload before
 * it writes its output: a wrong length, a non-finite value where the robot would act on it, or
 * a count past the board's arrays is -EBADMSG, never a partial record.
 *
 *   HELLO     robot u32, rt_period_us u32, board name 16 bytes (NUL-padded, printable)
 *   SCAN      stamp_us u64, angle_min f32, angle_step f32, range_min f32, range_max f32,
 *             count u16 (1 .. HAL_LIDAR_MAX_BEAMS), count x range f32 (finite or +inf: no return)
 *   POSE      stamp_us u64, x f32, y f32, heading f32 (in [-pi, pi])
 *   WHEELS    stamp_us u64, left f32, right f32 (rad/s)
 *   DATAGRAM  channel length u8, channel (hal_net_channel_valid, no NUL), the datagram's bytes
 *             (at most HAL_NET_MTU_BYTES): the board's to the fleet, at any time after its
 *             HELLO; the fleet's to the board, inside a TICK's answer (below)
 *   SUBSCRIBE channel length u8, channel: the board listens to this fleet channel from now on
 *   TICK      stamp_us u64: the board's time; the host steps its world to it (never back);
 *             scan_held u64: the stamp + 1 of the latest scan the board holds (0: none);
 *             datagram_room u32: how many fleet datagrams the board can take now. The answer:
 *             SCAN, only when the world's latest scan is not the one held, then up to
 *             datagram_room DATAGRAMs the fleet sent the board (oldest first), then POSE, the
 *             latest fix, which ends it. A scan crosses the link once, not at every tick
 *             (on a serial line it is most of the bytes), and a lost one is sent again at the
 *             next TICK, which still names the older one.
 *   WORLD     min_x, min_y, max_x, max_y f32 (the plan's box, min < max), step_us u32 (physics),
 *             scan_period_us u32 (both > 0)
 */
#ifndef HAL_HIL_MSG_H
#define HAL_HIL_MSG_H

#include "hal/hal_hil_frame.h"
#include "hal/hal_pose.h"

#define HAL_HIL_BOARD_NAME_BYTES 16u
#define HAL_HIL_HELLO_BYTES (8u + HAL_HIL_BOARD_NAME_BYTES)
#define HAL_HIL_POSE_BYTES 20u
#define HAL_HIL_WHEELS_BYTES 16u
#define HAL_HIL_TICK_BYTES 20u
#define HAL_HIL_WORLD_BYTES 24u

typedef struct hal_hil_hello {
    uint32_t robot;
    uint32_t rt_period_us;
    char board[HAL_HIL_BOARD_NAME_BYTES + 1u]; /* NUL-terminated */
} hal_hil_hello_t;

typedef struct hal_hil_wheels {
    uint64_t stamp_us;
    float left_rad_s, right_rad_s;
} hal_hil_wheels_t;

typedef struct hal_hil_world {
    float min_x, min_y, max_x, max_y;
    uint32_t step_us, scan_period_us;
} hal_hil_world_t;

/* A bridged datagram as decoded: the bytes point into the payload. */
typedef struct hal_hil_datagram {
    char channel[HAL_NET_CHANNEL_MAX];
    const uint8_t *data;
    size_t len;
} hal_hil_datagram_t;

/* Encoders: the payload's length into out[0..cap), or -EINVAL (a value the decoder would
 * refuse), -EMSGSIZE (cap too small). */
int hal_hil_put_hello(uint8_t *out, size_t cap, const hal_hil_hello_t *m);
int hal_hil_put_scan(uint8_t *out, size_t cap, const hal_lidar_scan_t *m);
int hal_hil_put_pose(uint8_t *out, size_t cap, const hal_pose_t *m);
int hal_hil_put_wheels(uint8_t *out, size_t cap, const hal_hil_wheels_t *m);
int hal_hil_put_datagram(uint8_t *out, size_t cap, const char *channel, const void *data, size_t len);
/* A TICK's fields. */
typedef struct hal_hil_tick {
    uint64_t stamp_us, scan_held;
    uint32_t datagram_room;
} hal_hil_tick_t;

int hal_hil_put_tick(uint8_t *out, size_t cap, const hal_hil_tick_t *m);
int hal_hil_put_subscribe(uint8_t *out, size_t cap, const char *channel);
int hal_hil_put_world(uint8_t *out, size_t cap, const hal_hil_world_t *m);

/* Decoders of a frame's payload: 0, or -EBADMSG (wrong type, length or value). */
int hal_hil_get_hello(const hal_hil_frame_t *f, hal_hil_hello_t *m);
int hal_hil_get_scan(const hal_hil_frame_t *f, hal_lidar_scan_t *m);
int hal_hil_get_pose(const hal_hil_frame_t *f, hal_pose_t *m);
int hal_hil_get_wheels(const hal_hil_frame_t *f, hal_hil_wheels_t *m);
int hal_hil_get_datagram(const hal_hil_frame_t *f, hal_hil_datagram_t *m);
int hal_hil_get_tick(const hal_hil_frame_t *f, hal_hil_tick_t *m);
int hal_hil_get_subscribe(const hal_hil_frame_t *f, char channel[HAL_NET_CHANNEL_MAX]);
int hal_hil_get_world(const hal_hil_frame_t *f, hal_hil_world_t *m);

#endif /* HAL_HIL_MSG_H */
