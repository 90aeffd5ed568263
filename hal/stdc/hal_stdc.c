/* The stdc HAL back end: see hal_stdc.h. */
#include "hal_stdc.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "hal_stdc_target.h"

typedef struct stdc_msg {
    char channel[HAL_NET_CHANNEL_MAX];
    uint32_t len;
    uint64_t stamp_us;
    uint8_t data[HAL_NET_MTU_BYTES];
} stdc_msg_t;

typedef struct stdc_board {
    char dir[HAL_STDC_DIR_MAX];
    char sub[HAL_STDC_NET_CHANNELS][HAL_NET_CHANNEL_MAX];
    uint32_t n_sub;
    stdc_msg_t queue[HAL_STDC_NET_QUEUE];
    uint32_t head, fill; /* oldest message, messages waiting */
    hal_net_stats_t stats;
} stdc_board_t;

static stdc_board_t stdc;
static hal_stdc_hil_net_t *link_net; /* the fleet's network over the link, or NULL (loopback) */

static int ring_put(hal_stdc_hil_ring_t *r, const char *channel, const void *data, size_t len, uint32_t subscribe);
static int ring_take(hal_stdc_hil_ring_t *r, hal_stdc_hil_msg_t **m);
static void ring_done(hal_stdc_hil_ring_t *r);
static uint32_t ring_fill(hal_stdc_hil_ring_t *r);

/* ---- clock ---------------------------------------------------------------------------------- */
static int stdc_now_us(void *ctx, uint64_t *now_us)
{
    (void)ctx;
    *now_us = hal_stdc_target_now_us();
    return 0;
}

static int stdc_sleep_until_us(void *ctx, uint64_t wake_us)
{
    (void)ctx;
    hal_stdc_target_sleep_until(wake_us);
    return 0;
}

static const hal_clock_ops_t stdc_clock = {.now_us = stdc_now_us, .sleep_until_us = stdc_sleep_until_us};

/* ---- cores ---------------------------------------------------------------------------------- */
/* The target's scheduler, where it has one (hal_stdc_target.h). */
static int stdc_core_start(void *ctx, hal_core_id_t id, hal_core_entry_t entry, void *arg)
{
    (void)ctx;
    return hal_stdc_target_core_start(id, entry, arg);
}

static int stdc_core_stack(void *ctx, hal_core_id_t id, size_t *used, size_t *size)
{
    (void)ctx;
    return hal_stdc_target_core_stack(id, used, size);
}

static int stdc_core_self(void *ctx, hal_core_id_t *id)
{
    (void)ctx;
    return hal_stdc_target_core_self(id);
}

static const hal_core_ops_t stdc_core = {.start = stdc_core_start, .stack_high_water = stdc_core_stack,
                                         .self = stdc_core_self};

/* ---- log ------------------------------------------------------------------------------------ */
static void stdc_vlog(void *ctx, hal_log_level_t level, const char *fmt, va_list ap)
{
    static const char *const names[] = {"ERROR", "WARN", "INFO", "DEBUG"};
    (void)ctx;
    char line[HAL_LOG_LINE_MAX];
    vsnprintf(line, sizeof line, fmt, ap);
    uint64_t t = hal_stdc_target_now_us();
    fprintf(stderr, "[%6lu.%06lu] %-5s %s\n", (unsigned long)(t / 1000000u),
            (unsigned long)(t % 1000000u), names[level], line);
}

static const hal_log_ops_t stdc_log = {.vlog = stdc_vlog};

/* ---- storage -------------------------------------------------------------------------------- */
/* <dir>/<name><suffix> into buf; -EINVAL when it does not fit. */
static int stdc_path(const char *name, const char *suffix, char *buf, size_t cap)
{
    int n = snprintf(buf, cap, "%s%s%s%s", stdc.dir, stdc.dir[0] ? "/" : "", name, suffix);
    return n > 0 && (size_t)n < cap ? 0 : -EINVAL;
}

static int stdc_write(void *ctx, const char *name, const void *data, size_t len)
{
    (void)ctx;
    char tmp[HAL_STDC_DIR_MAX + HAL_STORAGE_NAME_MAX + 8], path[sizeof tmp];
    if (stdc_path(name, ".tmp", tmp, sizeof tmp) < 0 || stdc_path(name, "", path, sizeof path) < 0)
        return -EINVAL;
    FILE *f = fopen(tmp, "wb");
    if (f == NULL)
        return -EIO;
    size_t put = len > 0 ? fwrite(data, 1, len, f) : 0;
    if (fclose(f) != 0 || put != len) {
        remove(tmp);
        return -EIO;
    }
    /* POSIX rename() replaces the old blob atomically (semihosting passes it to the host's);
     * C leaves renaming onto an existing file to the implementation, so where it refuses,
     * clear the way and rename again (not atomic there). */
    if (hal_stdc_target_rename(tmp, path) == 0)
        return 0;
    remove(path);
    if (hal_stdc_target_rename(tmp, path) == 0)
        return 0;
    remove(tmp);
    return -EIO;
}

static int stdc_read(void *ctx, const char *name, void *buf, size_t cap, size_t *len)
{
    (void)ctx;
    char path[HAL_STDC_DIR_MAX + HAL_STORAGE_NAME_MAX + 8];
    if (stdc_path(name, "", path, sizeof path) < 0)
        return -EINVAL;
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return -ENOENT;
    long size = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1L;
    if (size < 0 || fseek(f, 0, SEEK_SET) != 0) {
        fclose(f);
        return -EIO;
    }
    *len = (size_t)size;
    if ((size_t)size > cap) {
        fclose(f);
        return -EMSGSIZE;
    }
    size_t got = size > 0 ? fread(buf, 1, (size_t)size, f) : 0;
    fclose(f);
    return got == (size_t)size ? 0 : -EIO;
}

static int stdc_remove(void *ctx, const char *name)
{
    (void)ctx;
    char path[HAL_STDC_DIR_MAX + HAL_STORAGE_NAME_MAX + 8];
    if (stdc_path(name, "", path, sizeof path) < 0)
        return -EINVAL;
    return remove(path) == 0 ? 0 : -ENOENT;
}

static const hal_storage_ops_t stdc_storage = {.write = stdc_write, .read = stdc_read, .remove = stdc_remove};

/* ---- net: RAM loopback ---------------------------------------------------------------------- */
static int stdc_subscribed(const char *channel)
{
    for (uint32_t i = 0; i < stdc.n_sub; i++)
        if (strcmp(stdc.sub[i], channel) == 0)
            return 1;
    return 0;
}

/* Over the link, a core other than the RT core (which alone empties the rings, at each of its
   ticks) may wait for the rings: it sleeps in steps of HAL_STDC_HIL_WAIT_STEP_US while the other
   threads run. The RT core, and a program without cores, never wait (nobody else would empty
   them). */
#define HAL_STDC_HIL_WAIT_STEP_US 1000u
#define HAL_STDC_HIL_PUBLISH_WAIT_US 100000u /* five RT periods of 20 ms: the out ring's room */

static int link_may_wait(void)
{
    hal_core_id_t self;
    return link_net != NULL && hal_stdc_target_core_self(&self) == 0 && self != HAL_CORE_RT;
}

/* Sleeps until cond() holds or the board's time reaches deadline_us; whether it holds. */
static int link_wait_for(int (*cond)(void), uint64_t deadline_us)
{
    for (;;) {
        if (cond())
            return 1;
        const uint64_t now = hal_stdc_target_now_us();
        if (now >= deadline_us)
            return 0;
        hal_stdc_target_sleep_until(deadline_us - now > HAL_STDC_HIL_WAIT_STEP_US ? now + HAL_STDC_HIL_WAIT_STEP_US
                                                                                   : deadline_us);
    }
}

static int out_has_room(void)
{
    return ring_fill(&link_net->out) < HAL_STDC_HIL_QUEUE;
}

static int in_has_one(void)
{
    return ring_fill(&link_net->in) > 0;
}

static int stdc_publish(void *ctx, const char *channel, const void *data, size_t len)
{
    (void)ctx;
    /* Over the link: to the fleet, when the RT core next talks to the world. A full out ring is
       waited for (as a socket's send buffer), within a bound; then the datagram is refused. */
    if (link_net != NULL && !out_has_room() && link_may_wait())
        (void)link_wait_for(out_has_room, hal_stdc_target_now_us() + HAL_STDC_HIL_PUBLISH_WAIT_US);
    if (link_net != NULL && ring_put(&link_net->out, channel, data, len, 0) != 0) {
        stdc.stats.tx_rejected++;
        return -EIO;
    }
    stdc.stats.tx_messages++;
    stdc.stats.tx_bytes += len;
    if (link_net != NULL)
        return 0;
    if (!stdc_subscribed(channel))
        return 0; /* nobody listens: gone, as on a radio */
    if (stdc.fill == HAL_STDC_NET_QUEUE) {
        stdc.stats.rx_dropped_full++;
        return 0;
    }
    stdc_msg_t *m = &stdc.queue[(stdc.head + stdc.fill) % HAL_STDC_NET_QUEUE];
    strcpy(m->channel, channel); /* length checked by the wrapper */
    m->len = (uint32_t)len;
    m->stamp_us = hal_stdc_target_now_us();
    if (len > 0)
        memcpy(m->data, data, len);
    stdc.fill++;
    return 0;
}

static int stdc_subscribe(void *ctx, const char *channel)
{
    (void)ctx;
    if (stdc_subscribed(channel))
        return 0;
    if (stdc.n_sub == HAL_STDC_NET_CHANNELS)
        return -ENOSPC;
    if (link_net != NULL && ring_put(&link_net->out, channel, NULL, 0, 1) != 0)
        return -EIO;
    strcpy(stdc.sub[stdc.n_sub++], channel);
    return 0;
}

static int stdc_receive(void *ctx, hal_net_rx_info_t *info, void *buf, size_t cap)
{
    (void)ctx;
    if (link_net != NULL) {
        hal_stdc_hil_msg_t *m;
        if (ring_take(&link_net->in, &m) != 0)
            return -EAGAIN;
        memcpy(info->channel, m->channel, sizeof info->channel);
        info->len = m->len;
        info->stamp_us = m->stamp_us;
        const int r = m->len > cap ? -EMSGSIZE : 0;
        if (r == 0 && m->len > 0)
            memcpy(buf, m->data, m->len);
        ring_done(&link_net->in);
        if (r != 0)
            stdc.stats.rx_dropped_small++;
        else {
            stdc.stats.rx_messages++;
            stdc.stats.rx_bytes += info->len;
        }
        return r;
    }
    if (stdc.fill == 0)
        return -EAGAIN;
    const stdc_msg_t *m = &stdc.queue[stdc.head];
    stdc.head = (stdc.head + 1u) % HAL_STDC_NET_QUEUE;
    stdc.fill--;
    memcpy(info->channel, m->channel, sizeof info->channel);
    info->len = m->len;
    info->stamp_us = m->stamp_us;
    if (m->len > cap) {
        stdc.stats.rx_dropped_small++;
        return -EMSGSIZE;
    }
    if (m->len > 0)
        memcpy(buf, m->data, m->len);
    stdc.stats.rx_messages++;
    stdc.stats.rx_bytes += m->len;
    return 0;
}

static int stdc_net_stats(void *ctx, hal_net_stats_t *s)
{
    (void)ctx;
    *s = stdc.stats;
    s->queue_fill = link_net != NULL ? ring_fill(&link_net->in) : stdc.fill;
    s->queue_depth = link_net != NULL ? HAL_STDC_HIL_QUEUE : HAL_STDC_NET_QUEUE;
    return 0;
}

/* Over the link, from a core that may wait (link_may_wait): until the in ring holds a datagram.
   Anywhere else -ENOTSUP, and the GP core asks again at its next tick. */
static int stdc_net_wait(void *ctx, uint32_t timeout_us)
{
    (void)ctx;
    if (!link_may_wait())
        return -ENOTSUP;
    return link_wait_for(in_has_one, hal_stdc_target_now_us() + timeout_us) ? 0 : -EAGAIN;
}

static int stdc_net_clock(void *ctx, uint64_t *now_us)
{
    return stdc_now_us(ctx, now_us);
}

/* No `senders`: hal_net_set_senders() is -ENOTSUP here and every sender is delivered (a RAM
 * loopback hears only its own node; a per-channel bitmap of BOARD_MAX_FLEET bits would cost
 * the small boards RAM for nothing). */
static const hal_net_ops_t stdc_net = {.publish = stdc_publish,
                                       .subscribe = stdc_subscribe,
                                       .receive = stdc_receive,
                                       .stats = stdc_net_stats,
                                       .wait = stdc_net_wait,
                                       .clock_us = stdc_net_clock};

/* ---- sensors and wheels over the hardware-in-the-loop link (hal_stdc_install_hil) ----------- */
/* A TICK's time is the board's time floored to the RT period (the client's rt_period_us): the
   release of the RT tick that reads, as long as the core does not overrun, so the world steps to
   the same instants whatever the core and the link took, and every reading of one RT tick
   (its pose, then its scan) is one TICK's. It is counted from the first TICK's release (the
   world's time 0), so the world's timeline is the RT core's ticks, as a host robot's lockstep
   is, whenever after boot the core started. */

static struct {
    hal_hil_client_t *client;
    int ticked, sensed, lockstep;
    uint64_t origin_us;           /* the board's time of the first TICK: the world's 0 */
    uint64_t tick_us, sensed_ns;  /* the board's time of the latest TICK's release */
    hal_stdc_hil_stats_t st;
} hil;

static void timing_add(hal_stdc_timing_t *t, uint64_t ns)
{
    t->count++;
    t->sum_ns += ns;
    if (ns > t->max_ns)
        t->max_ns = ns;
}

/* ---- the rings between the GP core and the link (hal_stdc_hil_ring_t) ---- */
static uint32_t ring_fill(hal_stdc_hil_ring_t *r)
{
    return atomic_load_explicit(&r->put, memory_order_acquire) - atomic_load_explicit(&r->take, memory_order_acquire);
}

static int ring_put(hal_stdc_hil_ring_t *r, const char *channel, const void *data, size_t len, uint32_t subscribe)
{
    const uint32_t put = atomic_load_explicit(&r->put, memory_order_relaxed);
    if (put - atomic_load_explicit(&r->take, memory_order_acquire) >= HAL_STDC_HIL_QUEUE || len > HAL_NET_MTU_BYTES)
        return -ENOSPC;
    hal_stdc_hil_msg_t *m = &r->msg[put % HAL_STDC_HIL_QUEUE];
    strcpy(m->channel, channel); /* length checked by the wrapper */
    m->len = (uint32_t)len;
    m->subscribe = subscribe;
    m->stamp_us = hal_stdc_target_now_us();
    if (len > 0)
        memcpy(m->data, data, len);
    atomic_store_explicit(&r->put, put + 1u, memory_order_release);
    return 0;
}

/* The oldest message, left in place until ring_done. 0, or -EAGAIN when none. */
static int ring_take(hal_stdc_hil_ring_t *r, hal_stdc_hil_msg_t **m)
{
    const uint32_t take = atomic_load_explicit(&r->take, memory_order_relaxed);
    if (atomic_load_explicit(&r->put, memory_order_acquire) == take)
        return -EAGAIN;
    *m = &r->msg[take % HAL_STDC_HIL_QUEUE];
    return 0;
}

static void ring_done(hal_stdc_hil_ring_t *r)
{
    atomic_store_explicit(&r->take, atomic_load_explicit(&r->take, memory_order_relaxed) + 1u, memory_order_release);
}

/* A fleet datagram in a TICK's answer (hal_hil_client's sink): into the in ring, which the
   TICK said had room. */
static void hil_on_datagram(void *ctx, const hal_hil_datagram_t *d)
{
    (void)ctx;
    if (ring_put(&link_net->in, d->channel, d->data, d->len, 0) != 0)
        stdc.stats.rx_dropped_full++;
}

/* What the GP core queued for the fleet, out through the link (the RT core owns it). */
static void hil_send_out(void)
{
    hal_stdc_hil_msg_t *m;
    while (ring_take(&link_net->out, &m) == 0) {
        const int r = m->subscribe ? hal_hil_client_subscribe(hil.client, m->channel)
                                   : hal_hil_client_datagram(hil.client, m->channel, m->data, m->len);
        if (r != 0)
            hil.st.link_errors++;
        ring_done(&link_net->out);
    }
    hil.client->datagram_room = HAL_STDC_HIL_QUEUE - ring_fill(&link_net->in);
}

static int hil_sense(void)
{
    const uint64_t now_ns = hal_stdc_target_now_ns(), now = now_ns / 1000u;
    const uint64_t t = now - now % hil.client->rt_period_us;
    if (hil.ticked && t == hil.tick_us)
        return 0;
    if (hil.st.link_down) {
        hil.st.link_errors++;
        return -EIO;
    }
    if (link_net != NULL)
        hil_send_out();
    const uint64_t sent_ns = hal_stdc_target_link_ns();
    if (hil.lockstep)
        hal_stdc_target_hold(1);
    if (!hil.ticked)
        hil.origin_us = t;
    const int r = hal_hil_client_tick(hil.client, t - hil.origin_us);
    if (hil.lockstep)
        hal_stdc_target_hold(0);
    if (r != 0) {
        hil.st.link_errors++;
        hil.st.link_down = ++hil.st.unanswered_in_row >= HAL_STDC_HIL_DOWN_AFTER;
        return -EIO;
    }
    hil.st.unanswered_in_row = 0;
    if (hil.ticked && t != hil.tick_us + hil.client->rt_period_us)
        hil.st.tick_gaps++; /* a period went by without its tick: a deadline missed */
    hil.ticked = hil.sensed = 1;
    hil.tick_us = t;
    hil.sensed_ns = hal_stdc_target_now_ns();
    timing_add(&hil.st.exchange, hal_stdc_target_link_ns() - sent_ns);
    return 0;
}

static int stdc_read_pose(void *ctx, hal_pose_t *pose)
{
    (void)ctx;
    const int r = hil_sense();
    if (r == 0)
        *pose = hil.client->pose;
    return r;
}

static int stdc_read_scan(void *ctx, hal_lidar_scan_t *scan)
{
    (void)ctx;
    const int r = hil_sense();
    if (r == 0)
        *scan = hil.client->scan;
    return r;
}

static int stdc_set_wheels(void *ctx, float left_rad_s, float right_rad_s)
{
    (void)ctx;
    const uint64_t now_ns = hal_stdc_target_now_ns(), now = now_ns / 1000u;
    if (hil.sensed) { /* the first command after the sensors came: the core's response */
        timing_add(&hil.st.response, now_ns - hil.sensed_ns);
        timing_add(&hil.st.release, now_ns - hil.tick_us * 1000u);
        hil.sensed = 0;
    }
    if (hal_hil_client_wheels(hil.client, now, left_rad_s, right_rad_s) != 0) {
        hil.st.link_errors++;
        return -EIO;
    }
    return 0;
}

static const hal_lidar_ops_t stdc_lidar = {.read_scan = stdc_read_scan};
static const hal_pose_ops_t stdc_pose = {.read_pose = stdc_read_pose};
static const hal_motor_ops_t stdc_motor = {.set_wheels = stdc_set_wheels};

/* ---- board ---------------------------------------------------------------------------------- */
static void stdc_fault(void *ctx, const char *file, int line, const char *what)
{
    (void)ctx;
    fprintf(stderr, "FAULT %s:%d: %s\n", file, line, what);
    fflush(stderr);
}

static const hal_board_t stdc_board = {
    .name = BOARD_NAME,
    .ctx = &stdc,
    .clock = &stdc_clock,
    .core = &stdc_core,
    .log = &stdc_log,
    .net = &stdc_net,
    .storage = &stdc_storage,
    .fault = stdc_fault,
};

/* stdc_board with the world's lidar, pose and motors (hal_stdc_install_hil fills it). */
static hal_board_t stdc_board_hil;

int hal_stdc_install_hil(const char *storage_dir, hal_hil_client_t *client, int lockstep, hal_stdc_hil_net_t *net)
{
    if (client == NULL)
        return -EINVAL;
    const int r = hal_stdc_install(storage_dir);
    if (r != 0)
        return r;
    memset(&hil, 0, sizeof hil);
    hil.client = client;
    hil.lockstep = lockstep != 0;
    if (net != NULL) {
        memset(net, 0, sizeof *net);
        client->on_datagram = hil_on_datagram;
        client->datagram_room = HAL_STDC_HIL_QUEUE;
    }
    link_net = net;
    stdc_board_hil = stdc_board;
    stdc_board_hil.lidar = &stdc_lidar;
    stdc_board_hil.pose = &stdc_pose;
    stdc_board_hil.motor = &stdc_motor;
    return hal_board_install(&stdc_board_hil);
}

void hal_stdc_hil_stats(hal_stdc_hil_stats_t *st)
{
    *st = hil.st;
}

int hal_stdc_install(const char *storage_dir)
{
    const char *dir = storage_dir != NULL ? storage_dir : "";
    if (strlen(dir) >= sizeof stdc.dir)
        return -EINVAL;
    memset(&stdc, 0, sizeof stdc);
    strcpy(stdc.dir, dir);
    link_net = NULL;
    return hal_board_install(&stdc_board);
}

void hal_stdc_uninstall(void)
{
    link_net = NULL;
    if (hal_board_install(NULL) != 0) {
        /* Uninstalling cannot fail. */
    }
}
