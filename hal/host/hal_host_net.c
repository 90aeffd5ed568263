/* hal_net on the host, over LCM, ZeroMQ or shared memory (the transports:
 * hal_host_net_transport.h; the URL chooses). Subscriptions deliver into one bounded queue that the GP core polls: a byte ring
 * allocated once at open, so receiving never allocates in our code (the transports' own
 * buffers are their business).
 *
 * Neighbour-scoped delivery (hal_host_net_set_senders): each subscription of a typed channel
 * may carry a fixed bitmap of wanted senders (BOARD_MAX_FLEET bits, in this struct, nothing
 * allocated). hal_host_net_on_datagram checks it right after the subscription match and the
 * own-echo check, before the tag check, the bounds check and any copy: an unwanted sender's
 * datagram costs the channel lookup and a read of its sender field (rx_unwanted). A datagram
 * too short to name a sender passes, and the checks after refuse it. The transport is told
 * too (its optional `senders`): ZeroMQ then filters at the publisher, so most unwanted bytes
 * never arrive at all; LCM with a kernel filter on its socket (hal_host_net_kfilter.h) or
 * per-sender groups (hal_host_net_group_by_sender); where neither could be had, this check is
 * the filter.
 *
 * The receiving side (the queue, the receiver thread or the inline receive, wait and receive)
 * is hal_host_net_rx.c; what both halves share, hal_host_net_internal.h. */
#include "hal_host_net_internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

hal_host_msg_type_t hal_host_net_channel_type(const hal_host_net_t *n, const char *channel)
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

size_t hal_host_net_queue_bytes_default(uint32_t queue_depth)
{
    const size_t want = (size_t)queue_depth * 4096u, least = 4u * HAL_HOST_NET_ENTRY_BYTES(HAL_NET_MTU_BYTES);
    return want > least ? want : least;
}

int hal_host_net_open(const char *url, uint32_t queue_depth, size_t queue_bytes, hal_host_net_t **out)
{
    if (url == NULL || out == NULL || queue_depth == 0 || queue_depth > NET_QUEUE_MAX)
        return -EINVAL;
    if (queue_bytes == 0)
        queue_bytes = hal_host_net_queue_bytes_default(queue_depth);
    queue_bytes = (queue_bytes + 7u) & ~(size_t)7u;
    if (queue_bytes < HAL_HOST_NET_ENTRY_BYTES(HAL_NET_MTU_BYTES) || queue_bytes > HAL_HOST_NET_QUEUE_BYTES_MAX)
        return -EINVAL;
    *out = NULL;
    hal_host_net_t *n = calloc(1, sizeof(*n));
    if (n == NULL)
        return -ENOMEM;
    /* calloc: the pages are mapped when first written, so the ring costs RSS only up to the
       high-water mark of what it held. */
    n->ring = calloc(1, queue_bytes);
    if (n->ring == NULL) {
        free(n);
        return -ENOMEM;
    }
    n->ring_cap = queue_bytes;
    n->depth = queue_depth;
    n->stats.queue_depth = queue_depth;
    n->stats.queue_bytes_cap = queue_bytes;
    n->t0_us = hal_host_net_mono_us();
    n->inline_fd = n->inline_next = -1;
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_mutex_init(&n->mu, NULL);
    pthread_mutex_init(&n->tx_mu, NULL);
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
    /* "zmq://..." is ZeroMQ over TCP, "shm://..." shared memory; anything else an LCM URL ("" for
       the default). */
    n->tp = strncmp(url, "zmq://", 6) == 0   ? &hal_host_net_zmq
            : strncmp(url, "shm://", 6) == 0 ? &hal_host_net_shm
                                             : &hal_host_net_lcm;
    const int rc = n->tp->open(n, url, &n->tp_ctx);
    if (rc != 0) {
        pthread_cond_destroy(&n->cv);
        pthread_mutex_destroy(&n->tx_mu);
        pthread_mutex_destroy(&n->mu);
        free(n->ring);
        free(n);
        return rc;
    }
    *out = n;
    return 0;
}

void hal_host_net_close(hal_host_net_t *n)
{
    if (n == NULL)
        return;
    hal_host_net_rx_stop(n);
    n->tp->close(n->tp_ctx);
    pthread_cond_destroy(&n->cv);
    pthread_mutex_destroy(&n->tx_mu);
    pthread_mutex_destroy(&n->mu);
    hal_host_netfault_hold_free(&n->hold); /* what is still held is lost with the process */
    hal_host_auth_wipe(&n->auth);
    free(n->tx_wire);
    free(n->ring);
    free(n);
}

int hal_host_net_set_faults(hal_host_net_t *n, const hal_host_netfault_cfg_t *cfg, uint64_t seed, uint32_t self)
{
    if (n == NULL || cfg == NULL)
        return -EINVAL;
    /* Before the receiver thread exists, so the holding area is in place before any datagram. */
    if (n->rx_started || n->faults_on)
        return -EBUSY;
    if (!hal_host_netfault_active(cfg))
        return 0;
    if (cfg->delay_ms > 0 || cfg->reorder > 0.0) {
        int rc = hal_host_netfault_hold_init(&n->hold, n->depth < NET_HOLD_MAX ? n->depth : NET_HOLD_MAX);
        if (rc != 0)
            return rc;
    }
    pthread_mutex_lock(&n->mu);
    n->fault = *cfg;
    n->fault_seed = seed;
    n->fault_self = self;
    n->faults_on = 1;
    pthread_mutex_unlock(&n->mu);
    return 0;
}

int hal_host_net_set_self(hal_host_net_t *n, uint32_t self)
{
    if (n == NULL)
        return -EINVAL;
    pthread_mutex_lock(&n->mu);
    const int busy = n->rx_started;
    if (!busy) {
        n->self = self;
        n->has_self = 1;
    }
    pthread_mutex_unlock(&n->mu);
    return busy ? -EBUSY : 0;
}

int hal_host_net_set_auth(hal_host_net_t *n, const hal_host_auth_t *auth)
{
    if (n == NULL || auth == NULL)
        return -EINVAL;
    if (n->rx_started || n->keyed) /* before the first datagram can arrive, once */
        return -EBUSY;
    if (n->tp->trusted_host) /* the segment's mode is the membership check (hal_host_net_shm.c) */
        return 0;
    if (hal_host_auth_init() != 0)
        return -EIO;
    n->tx_wire = malloc(HAL_NET_MTU_BYTES + HAL_HOST_AUTH_TRAILER_BYTES);
    if (n->tx_wire == NULL)
        return -ENOMEM;
    pthread_mutex_lock(&n->mu);
    n->auth = *auth;
    n->keyed = 1;
    pthread_mutex_unlock(&n->mu);
    return 0;
}

/* Counts a publish outcome (the receiver thread reads nothing of it, but the stats are one
 * record under the mutex). */
static int tx_count(hal_host_net_t *n, int rc, size_t len)
{
    pthread_mutex_lock(&n->mu);
    if (rc >= 0) {
        n->stats.tx_messages++;
        n->stats.tx_bytes += len;
        n->stats.tx_overflows += rc > 0; /* sent, but a receiver's queue overflowed */
        rc = 0;
    } else {
        n->stats.tx_rejected++;
    }
    pthread_mutex_unlock(&n->mu);
    return rc;
}

/* The sender a datagram names, for a transport that filters by it (-1 for the others: no
 * lookup under the mutex). */
static int64_t publish_sender(hal_host_net_t *n, const char *channel, const void *data, size_t len)
{
    if (n->tp->senders == NULL)
        return -1;
    pthread_mutex_lock(&n->mu);
    const hal_host_msg_type_t type = hal_host_net_channel_type(n, channel);
    pthread_mutex_unlock(&n->mu);
    return hal_host_net_typed_sender(type, data, len);
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
    const int64_t sender = publish_sender(n, channel, data, len);
    if (n->keyed) {
        /* The message and its trailer in one datagram (the wire buffer is the one copy). */
        pthread_mutex_lock(&n->tx_mu);
        if (len > 0)
            memcpy(n->tx_wire, data, len);
        hal_host_auth_seal(&n->auth, channel, n->tx_wire, len);
        const size_t wire = len + HAL_HOST_AUTH_TRAILER_BYTES;
        const int rc = n->tp->publish(n->tp_ctx, channel, n->tx_wire, wire, sender);
        pthread_mutex_unlock(&n->tx_mu);
        return tx_count(n, rc, wire);
    }
    pthread_mutex_lock(&n->tx_mu); /* a transport's sending side is one thread's at a time */
    const int rc = n->tp->publish(n->tp_ctx, channel, data, len, sender);
    pthread_mutex_unlock(&n->tx_mu);
    return tx_count(n, rc, len);
}

int hal_host_net_subscribe(hal_host_net_t *n, const char *channel)
{
    if (n == NULL || !hal_net_channel_valid(channel))
        return -EINVAL;
    pthread_mutex_lock(&n->mu);
    uint32_t i = 0;
    while (i < n->n_subs && strcmp(n->sub_channel[i], channel) != 0)
        i++;
    const int known = i < n->n_subs, full = n->n_subs == HAL_HOST_NET_MAX_SUBS;
    pthread_mutex_unlock(&n->mu);
    if (known)
        return 0;
    if (full)
        return -ENOSPC;
    const int rc = n->tp->subscribe(n->tp_ctx, channel);
    if (rc != 0)
        return rc;
    pthread_mutex_lock(&n->mu);
    memcpy(n->sub_channel[n->n_subs], channel, strlen(channel) + 1u);
    n->n_subs++;
    pthread_mutex_unlock(&n->mu);
    return n->rx_started ? 0 : hal_host_net_rx_start(n);
}

int hal_host_net_set_senders(hal_host_net_t *n, const char *channel, const uint8_t *wanted, uint32_t n_ids)
{
    if (n == NULL || !hal_net_channel_valid(channel) || (wanted != NULL && n_ids > (uint32_t)BOARD_MAX_FLEET))
        return -EINVAL;
    uint8_t map[HAL_HOST_NET_SENDER_BYTES];
    memset(map, 0, sizeof map);
    if (wanted != NULL) {
        memcpy(map, wanted, n_ids / 8u);
        if (n_ids % 8u != 0)
            map[n_ids / 8u] = (uint8_t)(wanted[n_ids / 8u] & ((1u << (n_ids % 8u)) - 1u));
    }
    pthread_mutex_lock(&n->mu);
    uint32_t i = 0;
    while (i < n->n_subs && strcmp(n->sub_channel[i], channel) != 0)
        i++;
    if (i == n->n_subs || hal_host_net_channel_type(n, channel) == HAL_HOST_MSG_ANY) {
        pthread_mutex_unlock(&n->mu); /* not subscribed, or its datagrams name no sender */
        return -EINVAL;
    }
    const uint8_t filtered = wanted != NULL;
    const int same = n->sub_filtered[i] == filtered && (!filtered || memcmp(n->sub_wanted[i], map, sizeof map) == 0);
    if (!same) {
        n->sub_filtered[i] = filtered;
        memcpy(n->sub_wanted[i], map, sizeof map);
    }
    pthread_mutex_unlock(&n->mu);
    /* The same set again: nothing for the transport to do. Otherwise this node's filter holds
       from now on, and the transport narrows what it carries as soon as it can. */
    if (same || n->tp->senders == NULL)
        return 0;
    return n->tp->senders(n->tp_ctx, channel, filtered ? map : NULL, n_ids);
}

int hal_host_net_group_by_sender(hal_host_net_t *n, const char *channel)
{
    if (n == NULL || !hal_net_channel_valid(channel))
        return -EINVAL;
    pthread_mutex_lock(&n->mu);
    const int typed = hal_host_net_channel_type(n, channel) != HAL_HOST_MSG_ANY;
    pthread_mutex_unlock(&n->mu);
    if (!typed)
        return -EINVAL; /* its datagrams must name their sender */
    if (n->rx_started)
        return -EBUSY;
    return n->tp->group != NULL ? n->tp->group(n->tp_ctx, channel, 0) : -ENOTSUP;
}

int hal_host_net_group_by_receiver(hal_host_net_t *n, const char *prefix)
{
    if (n == NULL || !hal_net_channel_valid(prefix))
        return -EINVAL;
    if (n->rx_started)
        return -EBUSY;
    return n->tp->group != NULL ? n->tp->group(n->tp_ctx, prefix, 1) : -ENOTSUP;
}

void hal_host_net_get_stats(const hal_host_net_t *n, hal_net_stats_t *stats)
{
    if (n == NULL || stats == NULL)
        return;
    hal_host_net_t *m = (hal_host_net_t *)n;
    pthread_mutex_lock(&m->mu);
    *stats = m->stats;
    stats->queue_fill = m->fill;
    stats->queue_bytes = m->used;
    stats->rx_inline = m->rx_started && m->inline_fd >= 0;
    pthread_mutex_unlock(&m->mu);
}
