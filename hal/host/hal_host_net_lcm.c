/* The LCM transport of the host network (hal_host_net_transport.h).
 *
 * No sender filter of its own (no `senders`): UDP multicast hands every datagram of the group
 * to every socket anyway, and LCM channels keep their names (recordings and tests rely on
 * them), so neighbour-scoped delivery is hal_host_net.c's check on arrival: an unwanted
 * sender's datagram costs one channel lookup and a read of its sender field, no tag check and
 * no copy into the queue. */
#include "hal_host.h"
#include "hal_host_net_transport.h"

#include <errno.h>
#include <lcm/lcm.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct lcm_ctx {
    lcm_t *lcm;
    hal_host_net_t *n;
    uint32_t n_subs;
    lcm_subscription_t *sub[HAL_HOST_NET_MAX_SUBS];
} lcm_ctx_t;

static void on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    lcm_ctx_t *c = user;
    /* A missing buffer arrives as a datagram without data but with a length: counted invalid. */
    hal_host_net_on_datagram(c->n, channel, rbuf != NULL ? rbuf->data : NULL, rbuf != NULL ? rbuf->data_size : 1u);
}

static int lcm_open(hal_host_net_t *n, const char *url, void **ctx)
{
    lcm_ctx_t *c = calloc(1, sizeof *c);
    if (c == NULL)
        return -ENOMEM;
    c->n = n;
    c->lcm = lcm_create(url[0] != '\0' ? url : HAL_HOST_NET_URL_DEFAULT);
    if (c->lcm == NULL) {
        fprintf(stderr, "hal_host_net: cannot create LCM on '%s' (for udpm:// on one host, "
                        "loopback needs multicast: see tests/hal/test_net.c)\n",
                url[0] != '\0' ? url : HAL_HOST_NET_URL_DEFAULT);
        free(c);
        return -EIO;
    }
    *ctx = c;
    return 0;
}

static void lcm_close(void *ctx)
{
    lcm_ctx_t *c = ctx;
    for (uint32_t i = 0; i < c->n_subs; i++)
        (void)lcm_unsubscribe(c->lcm, c->sub[i]);
    lcm_destroy(c->lcm);
    free(c);
}

static int lcm_pub(void *ctx, const char *channel, const void *data, size_t len, int64_t sender)
{
    lcm_ctx_t *c = ctx;
    (void)sender; /* every datagram goes to the whole group */
    static const uint8_t empty; /* LCM wants a non-NULL pointer even for an empty message */
    return lcm_publish(c->lcm, channel, len > 0 ? data : &empty, (unsigned)len) != 0 ? -EIO : 0;
}

static int lcm_sub(void *ctx, const char *channel)
{
    lcm_ctx_t *c = ctx;
    if (c->n_subs == HAL_HOST_NET_MAX_SUBS)
        return -ENOSPC;
    /* LCM channel arguments are regular expressions; a valid channel name may contain '.',
     * so escape it to match exactly that channel. */
    char re[2u * HAL_NET_CHANNEL_MAX + 1u];
    size_t k = 0;
    for (const char *p = channel; *p != '\0'; p++) {
        if (*p == '.')
            re[k++] = '\\';
        re[k++] = *p;
    }
    re[k] = '\0';
    lcm_subscription_t *sub = lcm_subscribe(c->lcm, re, on_message, c);
    if (sub == NULL)
        return -EIO;
    c->sub[c->n_subs++] = sub;
    return 0;
}

static int lcm_handle_for(void *ctx, int timeout_ms)
{
    lcm_ctx_t *c = ctx;
    return lcm_handle_timeout(c->lcm, timeout_ms) < 0 ? -EIO : 0;
}

const hal_host_net_transport_t hal_host_net_lcm = {"lcm", lcm_open, lcm_close, lcm_pub, lcm_sub, lcm_handle_for, NULL};
