/* The fake HAL board of the unit tests: see fake_board.h. */
#include "fake_board.h"

#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

static fake_board_t *fb_of(void *ctx)
{
    return ctx;
}

static int op_now_us(void *ctx, uint64_t *now_us)
{
    *now_us = fb_of(ctx)->now_us;
    return 0;
}

static int op_sleep_until_us(void *ctx, uint64_t wake_us)
{
    fake_board_t *fb = fb_of(ctx);
    if (fb->stopping)
        return -ECANCELED;
    if (wake_us > fb->now_us)
        fb->now_us = wake_us;
    return 0;
}

static int op_core_start(void *ctx, hal_core_id_t id, hal_core_entry_t entry, void *arg)
{
    (void)arg;
    fb_of(ctx)->started[id] = entry;
    return 0;
}

static void op_vlog(void *ctx, hal_log_level_t level, const char *fmt, va_list ap)
{
    fake_board_t *fb = fb_of(ctx);
    vsnprintf(fb->log[fb->n_log % FAKE_LOG_LINES], sizeof fb->log[0], fmt, ap);
    fb->n_log++;
    if ((unsigned)level < 4u)
        fb->n_log_level[level]++;
}

static int op_read_pose(void *ctx, hal_pose_t *pose)
{
    fake_board_t *fb = fb_of(ctx);
    if (fb->pose_rc == 0)
        *pose = fb->pose;
    return fb->pose_rc;
}

static int op_read_scan(void *ctx, hal_lidar_scan_t *scan)
{
    fake_board_t *fb = fb_of(ctx);
    if (fb->lidar_rc == 0)
        *scan = fb->scan;
    return fb->lidar_rc;
}

static int record_motor(fake_board_t *fb, float a, float b, int twist)
{
    if (fb->motor_rc != 0)
        return fb->motor_rc;
    fb->motor[fb->n_motor % FAKE_MOTOR_LOG] = (fake_motor_cmd_t){fb->now_us, a, b, twist};
    fb->n_motor++;
    return 0;
}

static int op_set_wheels(void *ctx, float l, float r)
{
    return record_motor(fb_of(ctx), l, r, 0);
}

static int op_set_twist(void *ctx, float v, float w)
{
    return record_motor(fb_of(ctx), v, w, 1);
}

static int op_publish(void *ctx, const char *channel, const void *data, size_t len)
{
    fake_board_t *fb = fb_of(ctx);
    if (fb->publish_rc != 0) {
        fb->net_stats.tx_rejected++;
        return fb->publish_rc;
    }
    fake_publish_t *p = &fb->pub[fb->n_pub % FAKE_NET_LOG];
    p->t_us = fb->now_us;
    snprintf(p->channel, sizeof p->channel, "%s", channel);
    p->len = len;
    memcpy(p->data, data, len < FAKE_NET_KEEP ? len : FAKE_NET_KEEP);
    fb->n_pub++;
    fb->net_stats.tx_messages++;
    fb->net_stats.tx_bytes += len;
    return 0;
}

static int op_subscribe(void *ctx, const char *channel)
{
    fake_board_t *fb = fb_of(ctx);
    if (fb->n_subscribed >= 8)
        return -ENOSPC;
    snprintf(fb->subscribed[fb->n_subscribed++], HAL_NET_CHANNEL_MAX, "%s", channel);
    return 0;
}

static int op_receive(void *ctx, hal_net_rx_info_t *info, void *buf, size_t cap)
{
    fake_board_t *fb = fb_of(ctx);
    if (fb->rx_fill == 0)
        return -EAGAIN;
    const fake_rx_t *m = &fb->rx[fb->rx_head];
    fb->rx_head = (fb->rx_head + 1u) % FAKE_NET_RX;
    fb->rx_fill--;
    memset(info, 0, sizeof *info);
    snprintf(info->channel, sizeof info->channel, "%s", m->channel);
    info->len = (uint32_t)m->len;
    info->stamp_us = fb->now_us;
    if (m->len > cap) {
        fb->net_stats.rx_dropped_small++;
        return -EMSGSIZE;
    }
    memcpy(buf, m->data, m->len);
    fb->net_stats.rx_messages++;
    fb->net_stats.rx_bytes += m->len;
    return 0;
}

static int op_net_stats(void *ctx, hal_net_stats_t *st)
{
    fake_board_t *fb = fb_of(ctx);
    *st = fb->net_stats;
    st->queue_fill = fb->rx_fill;
    st->queue_depth = FAKE_NET_RX;
    return 0;
}

static fake_file_t *find_file(fake_board_t *fb, const char *name)
{
    for (unsigned i = 0; i < FAKE_FILES; i++)
        if (fb->files[i].used && strcmp(fb->files[i].name, name) == 0)
            return &fb->files[i];
    return NULL;
}

static int op_st_write(void *ctx, const char *name, const void *data, size_t len)
{
    fake_board_t *fb = fb_of(ctx);
    if (fb->storage_fail_count > 0) {
        fb->storage_fail_count--;
        return fb->storage_fail_rc;
    }
    if (len > FAKE_FILE_MAX)
        return -ENOSPC;
    fake_file_t *f = find_file(fb, name);
    for (unsigned i = 0; f == NULL && i < FAKE_FILES; i++)
        if (!fb->files[i].used)
            f = &fb->files[i];
    if (f == NULL)
        return -ENOSPC;
    f->used = 1;
    snprintf(f->name, sizeof f->name, "%s", name);
    f->len = len;
    memcpy(f->data, data, len);
    fb->n_writes++;
    return 0;
}

static int op_st_read(void *ctx, const char *name, void *buf, size_t cap, size_t *len)
{
    fake_file_t *f = find_file(fb_of(ctx), name);
    if (f == NULL)
        return -ENOENT;
    *len = f->len;
    if (f->len > cap)
        return -EMSGSIZE;
    memcpy(buf, f->data, f->len);
    return 0;
}

static int op_st_remove(void *ctx, const char *name)
{
    fake_file_t *f = find_file(fb_of(ctx), name);
    if (f == NULL)
        return -ENOENT;
    f->used = 0;
    return 0;
}

static const hal_clock_ops_t fake_clock = {.now_us = op_now_us, .sleep_until_us = op_sleep_until_us};
static const hal_core_ops_t fake_core = {.start = op_core_start};
static const hal_log_ops_t fake_log = {.vlog = op_vlog};
static const hal_pose_ops_t fake_pose = {.read_pose = op_read_pose};
static const hal_lidar_ops_t fake_lidar = {.read_scan = op_read_scan};
static const hal_motor_ops_t fake_motor = {.set_wheels = op_set_wheels, .set_twist = op_set_twist};
static const hal_net_ops_t fake_net = {
    .publish = op_publish, .subscribe = op_subscribe, .receive = op_receive, .stats = op_net_stats};
static const hal_storage_ops_t fake_storage = {.write = op_st_write, .read = op_st_read, .remove = op_st_remove};

/* A broken contract (HAL_ASSERT) is a cmocka assertion: expect_assert_failure() catches it. */
static void op_fault(void *ctx, const char *file, int line, const char *what)
{
    (void)ctx;
    mock_assert(0, what, file, line);
}

void fake_board_init(fake_board_t *fb)
{
    memset(fb, 0, sizeof *fb);
    fb->board = (hal_board_t){.name = "fake",
                              .ctx = fb,
                              .clock = &fake_clock,
                              .core = &fake_core,
                              .log = &fake_log,
                              .lidar = &fake_lidar,
                              .pose = &fake_pose,
                              .motor = &fake_motor,
                              .net = &fake_net,
                              .storage = &fake_storage,
                              .fault = op_fault};
    fb->pose_rc = -EAGAIN;
    fb->lidar_rc = -EAGAIN;
    fb->storage_fail_rc = -EIO;
}

void fake_board_install(fake_board_t *fb)
{
    assert_int_equal(hal_board_install(&fb->board), 0);
}

const fake_motor_cmd_t *fake_board_motor(const fake_board_t *fb, unsigned i)
{
    if (i >= fb->n_motor || i >= FAKE_MOTOR_LOG)
        return NULL;
    return &fb->motor[(fb->n_motor - 1u - i) % FAKE_MOTOR_LOG];
}

const fake_file_t *fake_board_file(const fake_board_t *fb, const char *name)
{
    return find_file((fake_board_t *)fb, name);
}

const fake_publish_t *fake_board_publish(const fake_board_t *fb, unsigned i)
{
    if (i >= fb->n_pub || i >= FAKE_NET_LOG)
        return NULL;
    return &fb->pub[(fb->n_pub - 1u - i) % FAKE_NET_LOG];
}

int fake_board_push_rx(fake_board_t *fb, const char *channel, const void *data, size_t len)
{
    if (fb->rx_fill == FAKE_NET_RX || len > FAKE_NET_RX_MAX)
        return -ENOSPC;
    fake_rx_t *m = &fb->rx[(fb->rx_head + fb->rx_fill) % FAKE_NET_RX];
    snprintf(m->channel, sizeof m->channel, "%s", channel);
    m->len = len;
    memcpy(m->data, data, len);
    fb->rx_fill++;
    return 0;
}

int fake_board_logged(const fake_board_t *fb, const char *text)
{
    return fb->n_log > 0 && strstr(fb->log[(fb->n_log - 1u) % FAKE_LOG_LINES], text) != NULL;
}
