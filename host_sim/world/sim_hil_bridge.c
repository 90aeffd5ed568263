/* The bridge of `host_sim hil` on the fleet's LCM: see sim_hil_bridge.h. */
#include "sim_hil_bridge.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hal_host.h"

/* Datagrams waiting for the board, which takes at most its in ring's room per TICK (16 at 50 Hz
   over Ethernet, fewer over a UART): a round's states of the board's neighbours (about 200 chunks
   each on the `small` network) with their resends must wait here rather than be dropped and asked
   for again, which would only bring more of them. */
#define BRIDGE_QUEUE_DEPTH 4096u
/* LCM hands a member its own datagrams back; the board must not get its own across the link,
   whose room is the scarce thing. The fingerprints of the latest ones it sent are kept (an echo
   comes back within milliseconds; the board sends at most a few hundred a second). */
#define BRIDGE_ECHO_MEMORY 1024u

struct sim_hil_lcm_bridge {
    hal_host_net_t *net;
    uint64_t sent[BRIDGE_ECHO_MEMORY]; /* fingerprints of the board's latest datagrams, a ring */
    uint32_t next;
    uint64_t echoes;                   /* its own datagrams LCM brought back, not sent to it */
};

/* FNV-1a of the channel and the bytes: a datagram's fingerprint (the fleet's datagrams name
   their sender, so another robot's never has the board's). */
static uint64_t fingerprint(const char *channel, const uint8_t *data, size_t len)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (const char *c = channel; *c != '\0'; c++)
        h = (h ^ (uint8_t)*c) * 0x100000001b3ull;
    h = (h ^ 0xFFu) * 0x100000001b3ull; /* the channel's end */
    for (size_t i = 0; i < len; i++)
        h = (h ^ data[i]) * 0x100000001b3ull;
    return h;
}

static int bridge_publish(void *ctx, const char *channel, const void *data, size_t len)
{
    sim_hil_lcm_bridge_t *b = ctx;
    b->sent[b->next++ % BRIDGE_ECHO_MEMORY] = fingerprint(channel, data, len);
    return hal_host_net_publish(b->net, channel, data, len);
}

static int is_echo(const sim_hil_lcm_bridge_t *b, uint64_t f)
{
    for (uint32_t i = 0; i < BRIDGE_ECHO_MEMORY; i++)
        if (b->sent[i] == f && f != 0)
            return 1;
    return 0;
}

static int bridge_subscribe(void *ctx, const char *channel)
{
    return hal_host_net_subscribe(((sim_hil_lcm_bridge_t *)ctx)->net, channel);
}

static int bridge_receive(void *ctx, char channel[HAL_NET_CHANNEL_MAX], uint8_t *buf, size_t cap)
{
    sim_hil_lcm_bridge_t *b = ctx;
    for (;;) {
        hal_net_rx_info_t info;
        const int r = hal_host_net_receive(b->net, 0, &info, buf, cap);
        if (r != 0)
            return r;
        if (is_echo(b, fingerprint(info.channel, buf, info.len))) {
            b->echoes++;
            continue;
        }
        memcpy(channel, info.channel, HAL_NET_CHANNEL_MAX);
        return (int)info.len;
    }
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

void sim_hil_lcm_bridge_stats(const sim_hil_lcm_bridge_t *b, hal_net_stats_t *st, uint64_t *echoes)
{
    hal_host_net_get_stats(b->net, st);
    *echoes = b->echoes;
}

void sim_hil_lcm_bridge_close(sim_hil_lcm_bridge_t *b)
{
    if (b == NULL)
        return;
    hal_host_net_close(b->net);
    free(b);
}
