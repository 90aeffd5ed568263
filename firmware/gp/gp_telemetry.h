/* Telemetry record the GP core publishes (channel GP_TELEMETRY_CHANNEL_PREFIX + robot id)
 * at its own rate: where the robot is and how its learning goes.
 *
 * Wire layout (GP_TELEMETRY_WIRE_BYTES bytes, little-endian, no padding):
 *   0 u32 magic 'FTLM' (0x4D4C5446)   4 u16 version (1)   6 u16 total size
 *   8 u32 robot_id  12 u32 round  16 u64 stamp_us
 *  24 f32 x_m  28 f32 y_m  32 f32 heading_rad  36 f32 loss_train  40 f32 loss_val
 *  44 u32 pool_fill  48 u32 pool_capacity  52 u32 ring_drops  56 u32 net_drops
 *  60 u32 neighbours
 * Decoding validates every field (a message from the network is untrusted).
 */
#ifndef GP_TELEMETRY_H
#define GP_TELEMETRY_H

#include <stddef.h>
#include <stdint.h>

#define GP_TELEMETRY_MAGIC 0x4D4C5446u
#define GP_TELEMETRY_VERSION 1u
#define GP_TELEMETRY_WIRE_BYTES 64u
#define GP_TELEMETRY_CHANNEL_PREFIX "fleetsim/telemetry/"

typedef struct gp_telemetry {
    uint32_t robot_id;
    uint32_t round;          /* DiNNO communication round */
    uint64_t stamp_us;       /* simulated time of the record */
    float x_m, y_m;          /* pose, world frame (finite) */
    float heading_rad;       /* [-pi, pi] */
    float loss_train;        /* >= 0, or NaN while unknown */
    float loss_val;          /* >= 0, or NaN while unknown */
    uint32_t pool_fill;      /* samples in the AI core's pool, <= pool_capacity */
    uint32_t pool_capacity;
    uint32_t ring_drops;     /* RT->AI samples dropped (ring full) since start */
    uint32_t net_drops;      /* network messages dropped (queue full, invalid or malformed) */
    uint32_t neighbours;     /* neighbours in the current round, <= 255 */
} gp_telemetry_t;

/* Writes the wire form into buf (cap >= GP_TELEMETRY_WIRE_BYTES). 0 or -EINVAL (NULL, small
 * buffer, or a field out of range). */
FS_MUST_CHECK int gp_telemetry_encode(const gp_telemetry_t *t, uint8_t *buf,
                                                            size_t cap);

/* Parses and validates len bytes. 0, -EINVAL (NULL), -EBADMSG (wrong magic, version, size or
 * a field out of range). */
FS_MUST_CHECK int gp_telemetry_decode(const uint8_t *buf, size_t len,
                                                            gp_telemetry_t *t);

#endif /* GP_TELEMETRY_H */
