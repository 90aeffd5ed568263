/* The bridge of `host_sim hil` on the fleet's LCM: see sim_hil_bridge.h. */
#include "sim_hil_bridge.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hal_host.h"

#define BRIDGE_QUEUE_DEPTH 256u /* datagrams waiting for the board: two states' chunks and more */

struct sim_hil_lcm_bridge {
    hal_host_net_t *net;
};

static int bridge_publish(void *ctx, const char *channel, const void *data, size_t len)
{
    return hal_host_net_publish(((sim_hil_lcm_bridge_t *)ctx)->net, channel, data, len);
}

static int bridge_subscribe(void *ctx, const char *channel)
{
    return hal_host_net_subscribe(((sim_hil_lcm_bridge_t *)ctx)->net, channel);
}

static int bridge_receive(void *ctx, char channel[HAL_NET_CHANNEL_MAX], uint8_t *buf, size_t cap)
{
    hal_net_rx_info_t info;
    const int r = hal_host_net_receive(((sim_hil_lcm_bridge_t *)ctx)->net, 0, &info, buf, cap);
    if (r != 0)
        return r;
    memcpy(channel, info.channel, HAL_NET_CHANNEL_MAX);
    return (int)info.len;
}

int sim_hil_lcm_bridge_open(const char *url, sim_hil_lcm_bridge_t **out, sim_hil_bridge_t *ops, char *err,
                            size_t errlen)
{
    sim_hil_lcm_bridge_t *b = calloc(1, sizeof *b);
    if (b == NULL) {
        snprintf(err, errlen, "out of memory");
        return -ENOMEM;
    }
    const int r = hal_host_net_open(url, BRIDGE_QUEUE_DEPTH, 0, &b->net);
    if (r != 0) {
        snprintf(err, errlen, "cannot open the fleet's LCM at '%s' (%d)", url, r);
        free(b);
        return r;
    }
    *out = b;
    *ops = (sim_hil_bridge_t){.ctx = b, .publish = bridge_publish, .subscribe = bridge_subscribe,
                              .receive = bridge_receive};
    return 0;
}

void sim_hil_lcm_bridge_stats(const sim_hil_lcm_bridge_t *b, hal_net_stats_t *st)
{
    hal_host_net_get_stats(b->net, st);
}

void sim_hil_lcm_bridge_close(sim_hil_lcm_bridge_t *b)
{
    if (b == NULL)
        return;
    hal_host_net_close(b->net);
    free(b);
}
