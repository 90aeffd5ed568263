/* Explicit little-endian (de)serialisation: the struct layout of one compiler never
 * reaches the wire. */
#include "gp/gp_telemetry.h"

#include <errno.h>
#include <math.h>
#include <string.h>

static void put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

static void put_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void put_u64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void put_f32(uint8_t *p, float f)
{
    uint32_t v;
    memcpy(&v, &f, sizeof(v));
    put_u32(p, v);
}

static uint16_t get_u16(const uint8_t *p)
{
    return (uint16_t)(p[0] | (p[1] << 8));
}

static uint32_t get_u32(const uint8_t *p)
{
    uint32_t v = 0;
    for (int i = 0; i < 4; i++)
        v |= (uint32_t)p[i] << (8 * i);
    return v;
}

static uint64_t get_u64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; i++)
        v |= (uint64_t)p[i] << (8 * i);
    return v;
}

static float get_f32(const uint8_t *p)
{
    uint32_t v = get_u32(p);
    float f;
    memcpy(&f, &v, sizeof(f));
    return f;
}

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
    put_u32(buf + 0, GP_TELEMETRY_MAGIC);
    put_u16(buf + 4, GP_TELEMETRY_VERSION);
    put_u16(buf + 6, GP_TELEMETRY_WIRE_BYTES);
    put_u32(buf + 8, t->robot_id);
    put_u32(buf + 12, t->round);
    put_u64(buf + 16, t->stamp_us);
    put_f32(buf + 24, t->x_m);
    put_f32(buf + 28, t->y_m);
    put_f32(buf + 32, t->heading_rad);
    put_f32(buf + 36, t->loss_train);
    put_f32(buf + 40, t->loss_val);
    put_u32(buf + 44, t->pool_fill);
    put_u32(buf + 48, t->pool_capacity);
    put_u32(buf + 52, t->ring_drops);
    put_u32(buf + 56, t->net_drops);
    put_u32(buf + 60, t->neighbours);
    return 0;
}

int gp_telemetry_decode(const uint8_t *buf, size_t len, gp_telemetry_t *t)
{
    if (buf == NULL || t == NULL)
        return -EINVAL;
    if (len != GP_TELEMETRY_WIRE_BYTES || get_u32(buf) != GP_TELEMETRY_MAGIC ||
        get_u16(buf + 4) != GP_TELEMETRY_VERSION || get_u16(buf + 6) != GP_TELEMETRY_WIRE_BYTES)
        return -EBADMSG;
    gp_telemetry_t r;
    r.robot_id = get_u32(buf + 8);
    r.round = get_u32(buf + 12);
    r.stamp_us = get_u64(buf + 16);
    r.x_m = get_f32(buf + 24);
    r.y_m = get_f32(buf + 28);
    r.heading_rad = get_f32(buf + 32);
    r.loss_train = get_f32(buf + 36);
    r.loss_val = get_f32(buf + 40);
    r.pool_fill = get_u32(buf + 44);
    r.pool_capacity = get_u32(buf + 48);
    r.ring_drops = get_u32(buf + 52);
    r.net_drops = get_u32(buf + 56);
    r.neighbours = get_u32(buf + 60);
    if (!fields_ok(&r))
        return -EBADMSG;
    *t = r;
    return 0;
}
