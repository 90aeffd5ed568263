/* hal_net over LCM. Subscriptions deliver into one bounded queue of fixed-size slots that
 * the GP core polls; the queue is allocated once at open, so receiving never allocates in
 * our code (LCM's own buffers are its business). */
#include "hal_host.h"
#include "hal_host_msg.h"

#include <errno.h>
#include <lcm/lcm.h>
#include <stdio.h>
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
};

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
    for (uint32_t i = 0; i < n->n_typed; i++)
        if (strcmp(n->typed_channel[i], channel) == 0) {
            n->typed[i] = (hal_host_msg_type_t)type;
            return 0;
        }
    if (n->n_typed == HAL_HOST_NET_MAX_SUBS)
        return -ENOSPC;
    memcpy(n->typed_channel[n->n_typed], channel, strlen(channel) + 1u);
    n->typed[n->n_typed++] = (hal_host_msg_type_t)type;
    return 0;
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
    for (uint32_t i = 0; i < n->n_subs; i++)
        (void)lcm_unsubscribe(n->lcm, n->sub[i]);
    lcm_destroy(n->lcm);
    free(n->slots);
    free(n);
}

int hal_host_net_publish(hal_host_net_t *n, const char *channel, const void *data, size_t len)
{
    if (n == NULL || !hal_net_channel_valid(channel) || (data == NULL && len > 0)) {
        if (n != NULL)
            n->stats.tx_rejected++;
        return -EINVAL;
    }
    if (len > HAL_NET_MTU_BYTES) {
        n->stats.tx_rejected++;
        return -EMSGSIZE;
    }
    if (n->drop_every != 0 && ++n->publishes % n->drop_every == 0) {
        n->stats.tx_messages++; /* lost on the way: the sender cannot tell */
        n->stats.tx_bytes += len;
        return 0;
    }
    /* LCM wants a non-NULL pointer even for an empty message. */
    static const uint8_t empty;
    if (lcm_publish(n->lcm, channel, len > 0 ? data : &empty, (unsigned)len) != 0) {
        n->stats.tx_rejected++;
        return -EIO;
    }
    n->stats.tx_messages++;
    n->stats.tx_bytes += len;
    return 0;
}

/* LCM handler: everything from the wire is checked before it is queued. */
static void net_on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    hal_host_net_t *n = user;
    if (rbuf == NULL || !hal_net_channel_valid(channel) || rbuf->data_size > HAL_NET_MTU_BYTES ||
        (rbuf->data == NULL && rbuf->data_size > 0)) {
        n->stats.rx_dropped_invalid++;
        return;
    }
    /* Typed channels: the bytes are checked here, before anything can decode them. */
    if (hal_host_msg_check(channel_type(n, channel), rbuf->data, rbuf->data_size) != HAL_HOST_MSG_OK) {
        n->stats.rx_dropped_malformed++;
        return;
    }
    if (n->fill == n->depth) {
        n->stats.rx_dropped_full++;
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
    return 0;
}

/* Delivers everything LCM has ready, without waiting, as a receiver thread running all along
 * would have: what does not fit in the queue is dropped and counted. At most
 * 4 * depth + 64 deliveries per call, so a flood cannot hold the caller forever. */
static int net_pump(hal_host_net_t *n, uint64_t stamp_us, int first_timeout_ms)
{
    n->pump_stamp_us = stamp_us;
    for (uint32_t i = 0; i < 4u * n->depth + 64u; i++) {
        int r = lcm_handle_timeout(n->lcm, i == 0 ? first_timeout_ms : 0);
        if (r < 0)
            return -EIO;
        if (r == 0)
            break;
    }
    return 0;
}

int hal_host_net_wait(hal_host_net_t *n, uint64_t stamp_us, int timeout_ms)
{
    if (n == NULL || timeout_ms < 0)
        return -EINVAL;
    return net_pump(n, stamp_us, timeout_ms);
}

int hal_host_net_receive(hal_host_net_t *n, uint64_t stamp_us, hal_net_rx_info_t *info,
                         void *buf, size_t cap)
{
    if (n == NULL || info == NULL || (buf == NULL && cap > 0))
        return -EINVAL;
    if (n->n_subs > 0) {
        int r = net_pump(n, stamp_us, 0);
        if (r != 0)
            return r;
    }
    if (n->fill == 0)
        return -EAGAIN;
    net_slot_t *s = &n->slots[n->head];
    *info = s->info;
    n->head = (n->head + 1u) % n->depth;
    n->fill--;
    if (info->len > cap) {
        n->stats.rx_dropped_small++;
        return -EMSGSIZE;
    }
    if (info->len > 0)
        memcpy(buf, s->data, info->len);
    n->stats.rx_messages++;
    n->stats.rx_bytes += info->len;
    return 0;
}

uint32_t hal_host_net_queued(const hal_host_net_t *n)
{
    return n != NULL ? n->fill : 0u;
}

void hal_host_net_get_stats(const hal_host_net_t *n, hal_net_stats_t *stats)
{
    if (n == NULL || stats == NULL)
        return;
    *stats = n->stats;
    stats->queue_fill = n->fill;
}
