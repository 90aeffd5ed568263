/* hal_net over LCM. Subscriptions deliver into one bounded queue of fixed-size slots that
 * the GP core polls; the queue is allocated once at open, so receiving never allocates in
 * our code (LCM's own buffers are its business).
 *
 * A receiver thread (started with the first subscription) runs LCM's handler all along and
 * moves every datagram into the queue at once, as a board's network interface receives while
 * its cores compute. Without it LCM's own buffer (about 1 MB in LCM 1.3) fills whenever the
 * process is busy, and a fleet of 14 robots lost chunks every round. The queue is the one
 * place both threads touch, under one mutex; what does not fit is dropped and counted. */
#include "hal_host.h"
#include "hal_host_msg.h"

#include <errno.h>
#include <lcm/lcm.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <time.h>
#include <stdlib.h>
#include <string.h>

#define NET_QUEUE_MAX 4096u

typedef struct net_slot {
    hal_net_rx_info_t info;
    uint8_t data[HAL_NET_MTU_BYTES];
} net_slot_t;

struct hal_host_net {
    lcm_t *lcm;
    uint32_t depth;
    uint32_t head; /* next slot to pop */
    uint32_t fill;
    net_slot_t *slots;
    uint32_t n_subs;
    char sub_channel[HAL_HOST_NET_MAX_SUBS][HAL_NET_CHANNEL_MAX];
    lcm_subscription_t *sub[HAL_HOST_NET_MAX_SUBS];
    uint32_t n_typed;
    char typed_channel[HAL_HOST_NET_MAX_SUBS][HAL_NET_CHANNEL_MAX];
    hal_host_msg_type_t typed[HAL_HOST_NET_MAX_SUBS];
    uint64_t pump_stamp_us;
    hal_net_stats_t stats;
    uint64_t drop_every;   /* test seam FLEETSIM_NET_DROP_EVERY: lose every N-th publish */
    uint64_t publishes;
    pthread_mutex_t mu;    /* the queue, its stats, the typed table, pump_stamp_us */
    pthread_cond_t cv;     /* signalled when a message is queued (CLOCK_MONOTONIC) */
    pthread_t rx_thread;
    int rx_started;
    atomic_int rx_stop;
    atomic_int rx_failed;  /* lcm_handle failed: the transport is gone */
};

/* The receiver: LCM's handler all along (net_on_message queues under the mutex). */
static void *rx_main(void *arg)
{
    hal_host_net_t *n = arg;
    while (!atomic_load(&n->rx_stop)) {
        if (lcm_handle_timeout(n->lcm, 50) < 0) {
            atomic_store(&n->rx_failed, 1);
            pthread_mutex_lock(&n->mu);
            pthread_cond_broadcast(&n->cv);
            pthread_mutex_unlock(&n->mu);
            break;
        }
    }
    return NULL;
}

static hal_host_msg_type_t channel_type(const hal_host_net_t *n, const char *channel)
{
    for (uint32_t i = 0; i < n->n_typed; i++)
        if (strcmp(n->typed_channel[i], channel) == 0)
            return n->typed[i];
    return HAL_HOST_MSG_ANY;
}

int hal_host_net_expect_type(hal_host_net_t *n, const char *channel, int type)
{
    if (n == NULL || !hal_net_channel_valid(channel) || type < 0 || type >= HAL_HOST_MSG_TYPE_COUNT)
        return -EINVAL;
    int rc = 0;
    pthread_mutex_lock(&n->mu);
    uint32_t i = 0;
    while (i < n->n_typed && strcmp(n->typed_channel[i], channel) != 0)
        i++;
    if (i < n->n_typed) {
        n->typed[i] = (hal_host_msg_type_t)type;
    } else if (n->n_typed == HAL_HOST_NET_MAX_SUBS) {
        rc = -ENOSPC;
    } else {
        memcpy(n->typed_channel[n->n_typed], channel, strlen(channel) + 1u);
        n->typed[n->n_typed++] = (hal_host_msg_type_t)type;
    }
    pthread_mutex_unlock(&n->mu);
    return rc;
}

int hal_host_net_open(const char *url, uint32_t queue_depth, hal_host_net_t **out)
{
    if (url == NULL || out == NULL || queue_depth == 0 || queue_depth > NET_QUEUE_MAX)
        return -EINVAL;
    *out = NULL;
    hal_host_net_t *n = calloc(1, sizeof(*n));
    if (n == NULL)
        return -ENOMEM;
    n->slots = calloc(queue_depth, sizeof(net_slot_t));
    if (n->slots == NULL) {
        free(n);
        return -ENOMEM;
    }
    n->depth = queue_depth;
    n->stats.queue_depth = queue_depth;
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_mutex_init(&n->mu, NULL);
    pthread_cond_init(&n->cv, &ca);
    pthread_condattr_destroy(&ca);
    /* The loss seam of the fleet tests: every N-th datagram "sent" is silently lost, as UDP
       may lose it, so the protocol's recovery runs between real processes. */
    const char *drop = getenv("FLEETSIM_NET_DROP_EVERY");
    if (drop != NULL) {
        char *end = NULL;
        unsigned long long v = strtoull(drop, &end, 10);
        if (end != drop && *end == '\0' && v >= 2)
            n->drop_every = v;
        else
            fprintf(stderr, "hal_host_net: FLEETSIM_NET_DROP_EVERY='%s' ignored (a whole number >= 2)\n", drop);
    }
    n->lcm = lcm_create(url[0] != '\0' ? url : HAL_HOST_NET_URL_DEFAULT);
    if (n->lcm == NULL) {
        fprintf(stderr, "hal_host_net: cannot create LCM on '%s' (for udpm:// on one host, "
                        "loopback needs multicast: see tests/hal/test_net.c)\n",
                url[0] != '\0' ? url : HAL_HOST_NET_URL_DEFAULT);
        pthread_cond_destroy(&n->cv);
        pthread_mutex_destroy(&n->mu);
        free(n->slots);
        free(n);
        return -EIO;
    }
    *out = n;
    return 0;
}

void hal_host_net_close(hal_host_net_t *n)
{
    if (n == NULL)
        return;
    if (n->rx_started) {
        atomic_store(&n->rx_stop, 1);
        pthread_join(n->rx_thread, NULL);
    }
    for (uint32_t i = 0; i < n->n_subs; i++)
        (void)lcm_unsubscribe(n->lcm, n->sub[i]);
    lcm_destroy(n->lcm);
    pthread_cond_destroy(&n->cv);
    pthread_mutex_destroy(&n->mu);
    free(n->slots);
    free(n);
}

/* Counts a publish outcome (the receiver thread reads nothing of it, but the stats are one
 * record under the mutex). */
static int tx_count(hal_host_net_t *n, int rc, size_t len)
{
    pthread_mutex_lock(&n->mu);
    if (rc == 0) {
        n->stats.tx_messages++;
        n->stats.tx_bytes += len;
    } else {
        n->stats.tx_rejected++;
    }
    pthread_mutex_unlock(&n->mu);
    return rc;
}

int hal_host_net_publish(hal_host_net_t *n, const char *channel, const void *data, size_t len)
{
    if (n == NULL)
        return -EINVAL;
    if (!hal_net_channel_valid(channel) || (data == NULL && len > 0))
        return tx_count(n, -EINVAL, len);
    if (len > HAL_NET_MTU_BYTES)
        return tx_count(n, -EMSGSIZE, len);
    if (n->drop_every != 0 && ++n->publishes % n->drop_every == 0)
        return tx_count(n, 0, len); /* lost on the way: the sender cannot tell */
    /* LCM wants a non-NULL pointer even for an empty message. */
    static const uint8_t empty;
    return tx_count(n, lcm_publish(n->lcm, channel, len > 0 ? data : &empty, (unsigned)len) != 0 ? -EIO : 0, len);
}

/* LCM handler: everything from the wire is checked before it is queued. */
static void net_on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    hal_host_net_t *n = user;
    pthread_mutex_lock(&n->mu);
    if (rbuf == NULL || !hal_net_channel_valid(channel) || rbuf->data_size > HAL_NET_MTU_BYTES ||
        (rbuf->data == NULL && rbuf->data_size > 0)) {
        n->stats.rx_dropped_invalid++;
        pthread_mutex_unlock(&n->mu);
        return;
    }
    /* Typed channels: the bytes are checked here, before anything can decode them. */
    if (hal_host_msg_check(channel_type(n, channel), rbuf->data, rbuf->data_size) != HAL_HOST_MSG_OK) {
        n->stats.rx_dropped_malformed++;
        pthread_mutex_unlock(&n->mu);
        return;
    }
    if (n->fill == n->depth) {
        n->stats.rx_dropped_full++;
        pthread_mutex_unlock(&n->mu);
        return;
    }
    net_slot_t *s = &n->slots[(n->head + n->fill) % n->depth];
    memset(&s->info, 0, sizeof(s->info));
    memcpy(s->info.channel, channel, strlen(channel) + 1u);
    s->info.len = rbuf->data_size;
    s->info.stamp_us = n->pump_stamp_us;
    if (rbuf->data_size > 0)
        memcpy(s->data, rbuf->data, rbuf->data_size);
    n->fill++;
    pthread_cond_broadcast(&n->cv);
    pthread_mutex_unlock(&n->mu);
}

int hal_host_net_subscribe(hal_host_net_t *n, const char *channel)
{
    if (n == NULL || !hal_net_channel_valid(channel))
        return -EINVAL;
    for (uint32_t i = 0; i < n->n_subs; i++)
        if (strcmp(n->sub_channel[i], channel) == 0)
            return 0;
    if (n->n_subs == HAL_HOST_NET_MAX_SUBS)
        return -ENOSPC;
    /* LCM channel arguments are regular expressions; a valid channel name may contain '.',
     * so escape it to match exactly that channel. */
    char re[2u * HAL_NET_CHANNEL_MAX + 1u];
    size_t k = 0;
    for (const char *c = channel; *c != '\0'; c++) {
        if (*c == '.')
            re[k++] = '\\';
        re[k++] = *c;
    }
    re[k] = '\0';
    lcm_subscription_t *sub = lcm_subscribe(n->lcm, re, net_on_message, n);
    if (sub == NULL)
        return -EIO;
    memcpy(n->sub_channel[n->n_subs], channel, strlen(channel) + 1u);
    n->sub[n->n_subs++] = sub;
    if (!n->rx_started) {
        if (pthread_create(&n->rx_thread, NULL, rx_main, n) != 0)
            return -EIO;
        n->rx_started = 1;
    }
    return 0;
}

/* Waits (the mutex held) until a message is queued or timeout_ms passed. */
static void wait_queued(hal_host_net_t *n, int timeout_ms)
{
    struct timespec dl;
    clock_gettime(CLOCK_MONOTONIC, &dl);
    const uint64_t ns = (uint64_t)dl.tv_nsec + (uint64_t)timeout_ms * 1000000u;
    dl.tv_sec += (time_t)(ns / 1000000000u);
    dl.tv_nsec = (long)(ns % 1000000000u);
    while (n->fill == 0 && !atomic_load(&n->rx_failed))
        if (pthread_cond_timedwait(&n->cv, &n->mu, &dl) == ETIMEDOUT)
            break;
}

int hal_host_net_wait(hal_host_net_t *n, uint64_t stamp_us, int timeout_ms)
{
    if (n == NULL || timeout_ms < 0)
        return -EINVAL;
    pthread_mutex_lock(&n->mu);
    n->pump_stamp_us = stamp_us;
    if (n->rx_started)
        wait_queued(n, timeout_ms);
    pthread_mutex_unlock(&n->mu);
    return atomic_load(&n->rx_failed) ? -EIO : 0;
}

int hal_host_net_receive(hal_host_net_t *n, uint64_t stamp_us, hal_net_rx_info_t *info,
                         void *buf, size_t cap)
{
    if (n == NULL || info == NULL || (buf == NULL && cap > 0))
        return -EINVAL;
    pthread_mutex_lock(&n->mu);
    n->pump_stamp_us = stamp_us;
    if (n->fill == 0) {
        pthread_mutex_unlock(&n->mu);
        return atomic_load(&n->rx_failed) ? -EIO : -EAGAIN;
    }
    net_slot_t *s = &n->slots[n->head];
    *info = s->info;
    int rc = 0;
    if (info->len > cap) {
        n->stats.rx_dropped_small++;
        rc = -EMSGSIZE;
    } else {
        if (info->len > 0)
            memcpy(buf, s->data, info->len);
        n->stats.rx_messages++;
        n->stats.rx_bytes += info->len;
    }
    n->head = (n->head + 1u) % n->depth;
    n->fill--;
    pthread_mutex_unlock(&n->mu);
    return rc;
}

uint32_t hal_host_net_queued(const hal_host_net_t *n)
{
    if (n == NULL)
        return 0u;
    hal_host_net_t *m = (hal_host_net_t *)n; /* the mutex is not part of the value */
    pthread_mutex_lock(&m->mu);
    const uint32_t f = m->fill;
    pthread_mutex_unlock(&m->mu);
    return f;
}

void hal_host_net_get_stats(const hal_host_net_t *n, hal_net_stats_t *stats)
{
    if (n == NULL || stats == NULL)
        return;
    hal_host_net_t *m = (hal_host_net_t *)n;
    pthread_mutex_lock(&m->mu);
    *stats = m->stats;
    stats->queue_fill = m->fill;
    pthread_mutex_unlock(&m->mu);
}
