/* The hardware-in-the-loop link's payloads (hal/hal_hil_msg.h). */
#include "hal/hal_hil_msg.h"

#include "common/le_bytes.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#define SCAN_HEAD_BYTES 26u
#define PI_F 3.14159275f /* float(pi) rounded up: a heading wrapped to pi passes */
_Static_assert(SCAN_HEAD_BYTES + 4u * (size_t)HAL_LIDAR_MAX_BEAMS == HAL_HIL_SCAN_PAYLOAD_MAX, "scan layout");

static int finite_f(float x)
{
    return isfinite(x) != 0;
}

/* A scan's range: a return, or +inf for none (what the host's lidar writes). */
static int range_ok(float r)
{
    return finite_f(r) || (isinf(r) && r > 0.0f);
}

static int board_name_ok(const char *s, size_t n)
{
    size_t k = 0;
    for (; k < n && s[k] != '\0'; k++)
        if (s[k] < 0x20 || s[k] > 0x7e)
            return 0;
    for (size_t j = k; j < n; j++) /* NUL-padded: nothing after the first NUL */
        if (s[j] != '\0')
            return 0;
    return k > 0;
}

int hal_hil_put_hello(uint8_t *out, size_t cap, const hal_hil_hello_t *m)
{
    size_t n = 0;
    while (n < sizeof m->board && m->board[n] != '\0')
        n++;
    if (n == 0 || n > HAL_HIL_BOARD_NAME_BYTES || !board_name_ok(m->board, n))
        return -EINVAL;
    if (cap < HAL_HIL_HELLO_BYTES)
        return -EMSGSIZE;
    le_put_u32(out, m->robot);
    le_put_u32(out + 4, m->rt_period_us);
    memset(out + 8, 0, HAL_HIL_BOARD_NAME_BYTES);
    memcpy(out + 8, m->board, n);
    return (int)HAL_HIL_HELLO_BYTES;
}

int hal_hil_get_hello(const hal_hil_frame_t *f, hal_hil_hello_t *m)
{
    if (f->type != HAL_HIL_HELLO || f->len != HAL_HIL_HELLO_BYTES ||
        !board_name_ok((const char *)f->payload + 8, HAL_HIL_BOARD_NAME_BYTES) || le_get_u32(f->payload + 4) == 0)
        return -EBADMSG;
    m->robot = le_get_u32(f->payload);
    m->rt_period_us = le_get_u32(f->payload + 4);
    memcpy(m->board, f->payload + 8, HAL_HIL_BOARD_NAME_BYTES);
    m->board[HAL_HIL_BOARD_NAME_BYTES] = '\0';
    return 0;
}

static int scan_head_ok(float amin, float step, float rmin, float rmax, uint32_t count)
{
    return finite_f(amin) && finite_f(step) && finite_f(rmin) && finite_f(rmax) && rmin >= 0.0f && rmin < rmax &&
           count >= 1u && count <= HAL_LIDAR_MAX_BEAMS;
}

int hal_hil_put_scan(uint8_t *out, size_t cap, const hal_lidar_scan_t *m)
{
    if (!scan_head_ok(m->angle_min_rad, m->angle_step_rad, m->range_min_m, m->range_max_m, m->count))
        return -EINVAL;
    for (uint32_t i = 0; i < m->count; i++)
        if (!range_ok(m->ranges_m[i]))
            return -EINVAL;
    const size_t n = SCAN_HEAD_BYTES + 4u * (size_t)m->count;
    if (cap < n)
        return -EMSGSIZE;
    le_put_u64(out, m->stamp_us);
    le_put_f32(out + 8, m->angle_min_rad);
    le_put_f32(out + 12, m->angle_step_rad);
    le_put_f32(out + 16, m->range_min_m);
    le_put_f32(out + 20, m->range_max_m);
    le_put_u16(out + 24, (uint16_t)m->count);
    for (uint32_t i = 0; i < m->count; i++)
        le_put_f32(out + SCAN_HEAD_BYTES + 4u * i, m->ranges_m[i]);
    return (int)n;
}

int hal_hil_get_scan(const hal_hil_frame_t *f, hal_lidar_scan_t *m)
{
    if (f->type != HAL_HIL_SCAN || f->len < SCAN_HEAD_BYTES)
        return -EBADMSG;
    const uint8_t *p = f->payload;
    const uint32_t count = le_get_u16(p + 24);
    if (f->len != SCAN_HEAD_BYTES + 4u * (size_t)count ||
        !scan_head_ok(le_get_f32(p + 8), le_get_f32(p + 12), le_get_f32(p + 16), le_get_f32(p + 20), count))
        return -EBADMSG;
    for (uint32_t i = 0; i < count; i++)
        if (!range_ok(le_get_f32(p + SCAN_HEAD_BYTES + 4u * i)))
            return -EBADMSG;
    m->stamp_us = le_get_u64(p);
    m->angle_min_rad = le_get_f32(p + 8);
    m->angle_step_rad = le_get_f32(p + 12);
    m->range_min_m = le_get_f32(p + 16);
    m->range_max_m = le_get_f32(p + 20);
    m->count = count;
    for (uint32_t i = 0; i < count; i++)
        m->ranges_m[i] = le_get_f32(p + SCAN_HEAD_BYTES + 4u * i);
    return 0;
}

static int pose_ok(float x, float y, float h)
{
    return finite_f(x) && finite_f(y) && finite_f(h) && h >= -PI_F && h <= PI_F;
}

int hal_hil_put_pose(uint8_t *out, size_t cap, const hal_pose_t *m)
{
    if (!pose_ok(m->x_m, m->y_m, m->heading_rad))
        return -EINVAL;
    if (cap < HAL_HIL_POSE_BYTES)
        return -EMSGSIZE;
    le_put_u64(out, m->stamp_us);
    le_put_f32(out + 8, m->x_m);
    le_put_f32(out + 12, m->y_m);
    le_put_f32(out + 16, m->heading_rad);
    return (int)HAL_HIL_POSE_BYTES;
}

int hal_hil_get_pose(const hal_hil_frame_t *f, hal_pose_t *m)
{
    const uint8_t *p = f->payload;
    if (f->type != HAL_HIL_POSE || f->len != HAL_HIL_POSE_BYTES ||
        !pose_ok(le_get_f32(p + 8), le_get_f32(p + 12), le_get_f32(p + 16)))
        return -EBADMSG;
    m->stamp_us = le_get_u64(p);
    m->x_m = le_get_f32(p + 8);
    m->y_m = le_get_f32(p + 12);
    m->heading_rad = le_get_f32(p + 16);
    return 0;
}

int hal_hil_put_wheels(uint8_t *out, size_t cap, const hal_hil_wheels_t *m)
{
    if (!finite_f(m->left_rad_s) || !finite_f(m->right_rad_s))
        return -EINVAL;
    if (cap < HAL_HIL_WHEELS_BYTES)
        return -EMSGSIZE;
    le_put_u64(out, m->stamp_us);
    le_put_f32(out + 8, m->left_rad_s);
    le_put_f32(out + 12, m->right_rad_s);
    return (int)HAL_HIL_WHEELS_BYTES;
}

int hal_hil_get_wheels(const hal_hil_frame_t *f, hal_hil_wheels_t *m)
{
    const uint8_t *p = f->payload;
    if (f->type != HAL_HIL_WHEELS || f->len != HAL_HIL_WHEELS_BYTES || !finite_f(le_get_f32(p + 8)) ||
        !finite_f(le_get_f32(p + 12)))
        return -EBADMSG;
    m->stamp_us = le_get_u64(p);
    m->left_rad_s = le_get_f32(p + 8);
    m->right_rad_s = le_get_f32(p + 12);
    return 0;
}

int hal_hil_put_datagram(uint8_t *out, size_t cap, const char *channel, const void *data, size_t len)
{
    if (!hal_net_channel_valid(channel) || (data == NULL && len > 0))
        return -EINVAL;
    const size_t cl = strlen(channel);
    if (len > HAL_NET_MTU_BYTES || cap < 1u + cl + len)
        return -EMSGSIZE;
    out[0] = (uint8_t)cl;
    memcpy(out + 1, channel, cl);
    if (len > 0)
        memcpy(out + 1 + cl, data, len);
    return (int)(1u + cl + len);
}

/* The channel a DATAGRAM or SUBSCRIBE payload starts with, into ch: its length in the payload
   (1 + the name's), or -EBADMSG. */
static int get_channel(const hal_hil_frame_t *f, char ch[HAL_NET_CHANNEL_MAX])
{
    if (f->len < 1u)
        return -EBADMSG;
    const size_t cl = f->payload[0];
    if (cl == 0 || cl >= HAL_NET_CHANNEL_MAX || f->len < 1u + cl)
        return -EBADMSG;
    memcpy(ch, f->payload + 1, cl);
    ch[cl] = '\0';
    if (memchr(ch, '\0', cl) != NULL || !hal_net_channel_valid(ch)) /* a NUL inside would shorten it */
        return -EBADMSG;
    return (int)(1u + cl);
}

int hal_hil_get_datagram(const hal_hil_frame_t *f, hal_hil_datagram_t *m)
{
    char ch[HAL_NET_CHANNEL_MAX];
    const int at = f->type == HAL_HIL_DATAGRAM ? get_channel(f, ch) : -EBADMSG;
    if (at < 0 || f->len - (size_t)at > HAL_NET_MTU_BYTES)
        return -EBADMSG;
    memcpy(m->channel, ch, (size_t)at);
    m->data = f->payload + at;
    m->len = f->len - (size_t)at;
    return 0;
}

int hal_hil_put_subscribe(uint8_t *out, size_t cap, const char *channel)
{
    return hal_hil_put_datagram(out, cap, channel, NULL, 0);
}

int hal_hil_get_subscribe(const hal_hil_frame_t *f, char channel[HAL_NET_CHANNEL_MAX])
{
    char ch[HAL_NET_CHANNEL_MAX];
    const int at = f->type == HAL_HIL_SUBSCRIBE ? get_channel(f, ch) : -EBADMSG;
    if (at < 0 || (size_t)at != f->len)
        return -EBADMSG;
    memcpy(channel, ch, (size_t)at);
    return 0;
}

int hal_hil_put_tick(uint8_t *out, size_t cap, const hal_hil_tick_t *m)
{
    if (cap < HAL_HIL_TICK_BYTES)
        return -EMSGSIZE;
    le_put_u64(out, m->stamp_us);
    le_put_u64(out + 8, m->scan_held);
    le_put_u32(out + 16, m->datagram_room);
    return (int)HAL_HIL_TICK_BYTES;
}

int hal_hil_get_tick(const hal_hil_frame_t *f, hal_hil_tick_t *m)
{
    if (f->type != HAL_HIL_TICK || f->len != HAL_HIL_TICK_BYTES)
        return -EBADMSG;
    m->stamp_us = le_get_u64(f->payload);
    m->scan_held = le_get_u64(f->payload + 8);
    m->datagram_room = le_get_u32(f->payload + 16);
    return 0;
}

static int world_ok(float x0, float y0, float x1, float y1, uint32_t step, uint32_t scan)
{
    return finite_f(x0) && finite_f(y0) && finite_f(x1) && finite_f(y1) && x0 < x1 && y0 < y1 && step > 0 &&
           scan > 0;
}

int hal_hil_put_world(uint8_t *out, size_t cap, const hal_hil_world_t *m)
{
    if (!world_ok(m->min_x, m->min_y, m->max_x, m->max_y, m->step_us, m->scan_period_us))
        return -EINVAL;
    if (cap < HAL_HIL_WORLD_BYTES)
        return -EMSGSIZE;
    le_put_f32(out, m->min_x);
    le_put_f32(out + 4, m->min_y);
    le_put_f32(out + 8, m->max_x);
    le_put_f32(out + 12, m->max_y);
    le_put_u32(out + 16, m->step_us);
    le_put_u32(out + 20, m->scan_period_us);
    return (int)HAL_HIL_WORLD_BYTES;
}

int hal_hil_get_world(const hal_hil_frame_t *f, hal_hil_world_t *m)
{
    const uint8_t *p = f->payload;
    if (f->type != HAL_HIL_WORLD || f->len != HAL_HIL_WORLD_BYTES ||
        !world_ok(le_get_f32(p), le_get_f32(p + 4), le_get_f32(p + 8), le_get_f32(p + 12), le_get_u32(p + 16),
                  le_get_u32(p + 20)))
        return -EBADMSG;
    m->min_x = le_get_f32(p);
    m->min_y = le_get_f32(p + 4);
    m->max_x = le_get_f32(p + 8);
    m->max_y = le_get_f32(p + 12);
    m->step_us = le_get_u32(p + 16);
    m->scan_period_us = le_get_u32(p + 20);
    return 0;
}
