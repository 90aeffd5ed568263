/* Explicit little-endian (de)serialisation: the struct layout of one compiler never
 * reaches the wire. */
#include "gp/gp_telemetry.h"
#include "common/le_bytes.h"

#include <errno.h>
#include <math.h>
#include <string.h>

static int loss_ok(float l)
{
    return isnan(l) || (isfinite(l) && l >= 0.0f);
}

static int fields_ok(const gp_telemetry_t *t)
{
    const float pi = 3.14159275f; /* float(pi) rounds up: accept exactly +-float(pi) */
    return isfinite(t->x_m) && isfinite(t->y_m) && isfinite(t->heading_rad) &&
           t->heading_rad >= -pi && t->heading_rad <= pi && loss_ok(t->loss_train) &&
           loss_ok(t->loss_val) && t->pool_fill <= t->pool_capacity && t->neighbours <= 255u;
}

int gp_telemetry_encode(const gp_telemetry_t *t, uint8_t *buf, size_t cap)
{
    if (t == NULL || buf == NULL || cap < GP_TELEMETRY_WIRE_BYTES || !fields_ok(t))
        return -EINVAL;
    le_put_u32(buf + 0, GP_TELEMETRY_MAGIC);
    le_put_u16(buf + 4, GP_TELEMETRY_VERSION);
    le_put_u16(buf + 6, GP_TELEMETRY_WIRE_BYTES);
    le_put_u32(buf + 8, t->robot_id);
    le_put_u32(buf + 12, t->round);
    le_put_u64(buf + 16, t->stamp_us);
    le_put_f32(buf + 24, t->x_m);
    le_put_f32(buf + 28, t->y_m);
    le_put_f32(buf + 32, t->heading_rad);
    le_put_f32(buf + 36, t->loss_train);
    le_put_f32(buf + 40, t->loss_val);
    le_put_u32(buf + 44, t->pool_fill);
    le_put_u32(buf + 48, t->pool_capacity);
    le_put_u32(buf + 52, t->ring_drops);
    le_put_u32(buf + 56, t->net_drops);
    le_put_u32(buf + 60, t->neighbours);
    return 0;
}

int gp_telemetry_decode(const uint8_t *buf, size_t len, gp_telemetry_t *t)
{
    if (buf == NULL || t == NULL)
        return -EINVAL;
    if (len != GP_TELEMETRY_WIRE_BYTES || le_get_u32(buf) != GP_TELEMETRY_MAGIC ||
        le_get_u16(buf + 4) != GP_TELEMETRY_VERSION || le_get_u16(buf + 6) != GP_TELEMETRY_WIRE_BYTES)
        return -EBADMSG;
    gp_telemetry_t r;
    r.robot_id = le_get_u32(buf + 8);
    r.round = le_get_u32(buf + 12);
    r.stamp_us = le_get_u64(buf + 16);
    r.x_m = le_get_f32(buf + 24);
    r.y_m = le_get_f32(buf + 28);
    r.heading_rad = le_get_f32(buf + 32);
    r.loss_train = le_get_f32(buf + 36);
    r.loss_val = le_get_f32(buf + 40);
    r.pool_fill = le_get_u32(buf + 44);
    r.pool_capacity = le_get_u32(buf + 48);
    r.ring_drops = le_get_u32(buf + 52);
    r.net_drops = le_get_u32(buf + 56);
    r.neighbours = le_get_u32(buf + 60);
    if (!fields_ok(&r))
        return -EBADMSG;
    *t = r;
    return 0;
}
