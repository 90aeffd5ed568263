/* The LCM transport of the host network (hal_host_net_transport.h).
 *
 * LCM publishes. Over udpm:// the URL's group is received on a socket of our own, joined as LCM
 * joins it and read in batches by the receiver thread (hal_host_net_udpm.h), not through LCM's
 * reader thread, ring and notification pipe; other providers (memq://) and the per-sender and
 * inbox groups below receive through LCM.
 *
 * By default every datagram goes to the URL's one multicast group, which hands every datagram
 * to every socket. Neighbour-scoped delivery is then a kernel filter on the robot's socket
 * (hal_host_net_kfilter.h, Linux): an unwanted sender's datagram on a filtered channel, and any
 * datagram on a channel the robot does not receive (another robot's own channels, in an
 * addressed fleet), is dropped before it is queued, so it costs no copy into the process and
 * no wake-up. Where no filter could be put, hal_host_net.c's check on arrival drops it after the
 * kernel's copy.
 *
 * Per-sender groups (hal_host_net_group_by_sender, udpm:// only): one channel (the fleet's
 * state chunks) is carried per sender instead. Sender s publishes it to group BASE + 1 + s on
 * port PORT + 1 + s (BASE:PORT the URL's group, the URL's options kept), and a receiver joins
 * the groups of the senders it wants (hal_host_net_set_senders) and no others, so the kernel
 * never copies an unwanted sender's chunks into it: the bytes a robot is delivered grow with
 * its neighbours, not with the fleet. A port per sender, not only a group: Linux hands a
 * socket bound to a port every datagram to that port for any group joined on the host
 * (IP_MULTICAST_ALL), so on one host the port is what separates senders; on a switched LAN the
 * group lets IGMP snooping keep the bytes off the wire too. Everything else (beacons,
 * requests, RoundCompletes) stays on the URL's group, and a channel is carried one way by the
 * whole fleet: every member groups it, or none (the publisher cannot know who listens where).
 *
 * Inboxes (hal_host_net_group_by_receiver): what is for one robot alone (a request naming its
 * chunks, the chunks it asked for again) goes on that robot's own channels, PREFIX<id>, and
 * those are carried on the robot's inbox group, BASE + 1 + GROUP_SPAN + id on port PORT + 1 +
 * GROUP_SPAN + id, which only it joins: a copy for one robot costs the others nothing, as over
 * ZeroMQ, where a multicast resend was delivered to every robot that keeps the sender (most of
 * what a 64-robot fleet's robots were delivered: duplicates).
 *
 * A group is an LCM instance of its own (LCM 1.3: a socket, a reader thread, a 200 KB ring,
 * 2,000 receive buffers): a robot holds one per wanted sender (its nearest of three rounds,
 * about 40) and SPARE_GROUPS more that fell out of the set last, its inbox, one to publish into
 * its own sender group and one for each of the TO_MAX robots it last sent something for alone
 * (publishing only: a socket, no thread). Setting up a receiving instance blocks (LCM's self
 * test: a datagram sent to the group and waited for, up to 10 s; at 256 robots on 2 cores it
 * held a robot's receiving still for 63 s in all when the receiver thread did it), so sender
 * groups are joined and destroyed by a joiner thread of their own, one at a time; the receiver
 * thread (handle) adopts what the joiner made, hands back what it no longer wants, and polls
 * every instance's descriptor. `senders` and `subscribe` (the caller's thread) record what is
 * wanted under `mu` and wake both. A sender newly wanted is joined a moment later: what it sent
 * before is missed, and asked for again like any loss. */
#include "hal_host.h"
#include "hal_host_net_kfilter.h"
#include "hal_host_net_transport.h"
#include "hal_host_net_udpm.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <lcm/lcm.h>
#include <poll.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define URL_MAX 512u
/* What LCM may hold of one channel for our receiver thread (subscribe_exact): 128 datagrams,
   4 s of a 256-robot fleet's beacons, and at most 8 MB of chunks. LCM's ring grows to hold
   what it holds (by half again each time it fills): with our queue's whole bound instead,
   the bench's 128 processes peaked at 75 MB median and 101 MB at most, against 57 and 75 with 128. */
#define LCM_QUEUE_MAX 128u
/* Sender s's group is the URL's + 1 + s, robot r's inbox the URL's + 1 + GROUP_SPAN + r: one
   layout for every build of a fleet, whatever its board's BOARD_MAX_FLEET. */
#define GROUP_SPAN 1024u
_Static_assert(BOARD_MAX_FLEET <= GROUP_SPAN, "every robot id has a group and an inbox");
#define PREFIX_MAX 4u
/* Inboxes a robot keeps an instance open for, the ones it sent to last: every LCM instance holds
   a socket with a port of the host's ephemeral range (about 28,000 on Linux), and 256 robots
   with one per peer ran the host out of ports ("connect: Resource temporarily unavailable"). */
#define TO_MAX 8u
/* Groups handed back to the joiner between two of its turns: at most every joined one and the
   one it made meanwhile; twice that for room. */
#define RETIRE_MAX (2u * BOARD_MAX_FLEET)
/* Groups kept joined beyond the wanted ones, those that fell out of the set last: the nearest
   change every round, and a sender often comes back a round later; a join costs a socket, a
   thread and LCM's self test, an unwanted sender's datagram only its copy (dropped on arrival
   by hal_host_net.c's filter). */
#define SPARE_GROUPS 8u

typedef struct lcm_ctx {
    int lcm_queue_cap; /* LCM's per-subscription message bound (subscribe_exact) */
    lcm_t *lcm;
    hal_host_net_t *n;
    /* udpm://: the URL group's socket, read by the receiver thread itself (hal_host_net_udpm.h);
       LCM's instance only publishes there. NULL: LCM receives (memq:// and the like). */
    udpm_rx_t *rx;
    uint32_t n_subs;
    lcm_subscription_t *sub[HAL_HOST_NET_MAX_SUBS];
    /* Per-sender groups: the URL's group, port and options ('?' included, or ""). */
    int udpm;
    uint32_t base_addr; /* host order */
    uint32_t base_port;
    char opts[URL_MAX / 2u];
    /* Set up before the fleet publishes (hal_host_net_group_by_*), read-only after. */
    char grouped[HAL_NET_CHANNEL_MAX]; /* "" until hal_host_net_group_by_sender */
    uint32_t n_prefix;
    char prefix[PREFIX_MAX][HAL_NET_CHANNEL_MAX]; /* hal_host_net_group_by_receiver */
    /* The publishing thread's. */
    lcm_t *own;                        /* its sender's group */
    int64_t own_sender;                /* -1 before the first grouped publish */
    lcm_t *to[BOARD_MAX_FLEET];        /* robot r's inbox, the TO_MAX used last */
    uint64_t to_used[BOARD_MAX_FLEET]; /* when (publish count) */
    uint64_t n_published;
    uint32_t n_to;
    pthread_mutex_t mu;                /* want, dirty, the inbox subscriptions, the joiner's state */
    int wake[2];                       /* a byte written: what to join changed */
    int dirty;                         /* the wanted set changed or a group was made */
    uint8_t want[HAL_HOST_NET_SENDER_BYTES];
    uint32_t n_inbox;                  /* inbox channels subscribed (under mu) ... */
    char inbox_ch[HAL_HOST_NET_MAX_SUBS][HAL_NET_CHANNEL_MAX];
    uint32_t inbox_id[HAL_HOST_NET_MAX_SUBS];
    /* The joiner thread (started with the grouped channel) sets up what is wanted and not had;
       the receiver adopts it, and hands back what it no longer wants (under mu). */
    pthread_t joiner;
    int joiner_on, joiner_stop;
    pthread_cond_t joiner_cv;          /* something to make or to retire, or stop */
    uint8_t have[HAL_HOST_NET_SENDER_BYTES];   /* the senders whose group the receiver polls */
    uint8_t failed[HAL_HOST_NET_SENDER_BYTES]; /* could not be joined: not tried while wanted */
    int64_t making;                    /* the sender being joined now, or -1 */
    lcm_t *made[BOARD_MAX_FLEET];      /* joined, not yet adopted */
    lcm_t *retire[RETIRE_MAX];         /* for the joiner to destroy */
    uint32_t n_retire;
    int warned_join;                   /* the joiner's */
    lcm_t *gone[RETIRE_MAX];           /* the joiner's: the retired it destroys now */
    /* The receiver thread's. */
    uint32_t n_inbox_done;             /* ... of them joined */
    lcm_t *inbox[HAL_HOST_NET_MAX_SUBS]; /* one instance per inbox id (NULL: shares an earlier one) */
    lcm_t *joined[BOARD_MAX_FLEET];    /* one instance per wanted sender, and some unwanted */
    uint64_t unwanted_since[BOARD_MAX_FLEET]; /* apply_groups' turn it fell out of the set, or 0 */
    uint64_t turn;
    uint32_t n_joined;
    int warned_inbox;
    /* The kernel filter (hal_host_net_kfilter.h) on the URL group's socket: its descriptor, or
       -1 (not udpm), and the filtered channels (under mu). */
    hal_host_net_kfilter_t kf;
    int kf_warned;
    struct pollfd pfd[BOARD_MAX_FLEET + HAL_HOST_NET_MAX_SUBS + 2u];
    lcm_t *pfd_lcm[BOARD_MAX_FLEET + HAL_HOST_NET_MAX_SUBS + 2u];
} lcm_ctx_t;

static void on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    lcm_ctx_t *c = user;
    /* A missing buffer arrives as a datagram without data but with a length: counted invalid. */
    hal_host_net_on_datagram(c->n, channel, rbuf != NULL ? rbuf->data : NULL, rbuf != NULL ? rbuf->data_size : 1u);
}

/* "udpm://A.B.C.D[:PORT][?OPTIONS]" into the context's base group, port and options. */
static void parse_udpm(lcm_ctx_t *c, const char *url)
{
    if (strncmp(url, "udpm://", 7) != 0)
        return;
    const char *host = url + 7, *q = strchr(host, '?');
    const size_t hl = strcspn(host, ":?");
    char addr[INET_ADDRSTRLEN];
    struct in_addr ia;
    if (hl == 0 || hl >= sizeof addr || (q != NULL && strlen(q) >= sizeof c->opts))
        return;
    memcpy(addr, host, hl);
    addr[hl] = '\0';
    if (inet_pton(AF_INET, addr, &ia) != 1)
        return;
    unsigned long port = 7667u; /* LCM's default */
    if (host[hl] == ':') {
        char *end = NULL;
        port = strtoul(host + hl + 1, &end, 10);
        if (end == host + hl + 1 || (*end != '\0' && *end != '?') || port == 0 || port > 65535u)
            return;
    }
    c->base_addr = ntohl(ia.s_addr);
    c->base_port = (uint32_t)port;
    snprintf(c->opts, sizeof c->opts, "%s", q != NULL ? q : "");
    c->udpm = 1;
}

/* The URL of group g (sender s: s; robot r's inbox: GROUP_SPAN + r) into out: 0, or -ERANGE
   when it leaves the multicast range or the port range. */
static int group_url(const lcm_ctx_t *c, uint32_t g, char *out, size_t cap)
{
    const uint64_t addr = (uint64_t)c->base_addr + 1u + g, port = (uint64_t)c->base_port + 1u + g;
    if ((addr >> 28) != 0xEu || port > 65535u)
        return -ERANGE;
    snprintf(out, cap, "udpm://%u.%u.%u.%u:%u%s", (unsigned)(addr >> 24) & 255u, (unsigned)(addr >> 16) & 255u,
             (unsigned)(addr >> 8) & 255u, (unsigned)addr & 255u, (unsigned)port, c->opts);
    return 0;
}

/* The robot whose inbox carries `channel` (PREFIX<id> of a hal_host_net_group_by_receiver
   prefix, id decimal), or -1. */
static int64_t inbox_of(const lcm_ctx_t *c, const char *channel)
{
    for (uint32_t i = 0; i < c->n_prefix; i++) {
        const size_t pl = strlen(c->prefix[i]);
        if (strncmp(channel, c->prefix[i], pl) != 0)
            continue;
        const char *d = channel + pl;
        uint64_t id = 0;
        size_t k = 0;
        for (; d[k] >= '0' && d[k] <= '9' && k < 5u; k++)
            id = id * 10u + (uint64_t)(d[k] - '0');
        if (k > 0 && d[k] == '\0' && id < BOARD_MAX_FLEET)
            return (int64_t)id;
    }
    return -1;
}

/* The value of option `key` in the URL's options ("?a=1&b=2"), or -1 when absent or not a
   whole number that fits an int. */
static int url_option(const char *opts, const char *key)
{
    const size_t kl = strlen(key);
    for (const char *p = opts; p != NULL && *p != '\0'; p = strchr(p, '&')) {
        p += *p == '?' || *p == '&';
        if (strncmp(p, key, kl) == 0 && p[kl] == '=') {
            char *end = NULL;
            const long v = strtol(p + kl + 1, &end, 10);
            return end != p + kl + 1 && (*end == '\0' || *end == '&') && v >= 0 && v <= 0x7fffffffL ? (int)v : -1;
        }
    }
    return -1;
}

/* A datagram of the URL's group, from its socket (hal_host_net_udpm.h): what hal_host_net.c
   takes, or counted invalid. A long message is more than any subscribed channel may carry:
   invalid when it is on one of ours, LCM's business (ignored) when not. */
static void on_udpm(void *user, const udpm_datagram_t *g)
{
    lcm_ctx_t *c = user;
    if (g->kind == UDPM_MESSAGE) {
        hal_host_net_on_datagram(c->n, g->channel, g->payload, g->len);
    } else if (g->kind == UDPM_INVALID) {
        hal_host_net_on_datagram(c->n, NULL, NULL, 0);
    } else if (g->kind == UDPM_TOO_LONG) {
        pthread_mutex_lock(&c->mu);
        int ours = 0;
        for (uint32_t i = 0; i < c->kf.n_received && !ours; i++)
            ours = strcmp(c->kf.received[i], g->channel) == 0;
        pthread_mutex_unlock(&c->mu);
        if (ours)
            hal_host_net_on_datagram(c->n, g->channel, NULL, 1u); /* no data, a length: invalid */
    }
}

static int lcm_open(hal_host_net_t *n, const char *url, void **ctx)
{
    lcm_ctx_t *c = calloc(1, sizeof *c);
    if (c == NULL)
        return -ENOMEM;
    c->n = n;
    c->own_sender = -1;
    c->wake[0] = c->wake[1] = -1;
    hal_net_stats_t st;
    hal_host_net_get_stats(n, &st);
    c->lcm_queue_cap = (int)(st.queue_depth < LCM_QUEUE_MAX ? st.queue_depth : LCM_QUEUE_MAX); /* depth >= 1: open */
    const char *u = url[0] != '\0' ? url : HAL_HOST_NET_URL_DEFAULT;
    c->lcm = lcm_create(u);
    if (c->lcm == NULL) {
        fprintf(stderr, "hal_host_net: cannot create LCM on '%s' (for udpm:// on one host, "
                        "loopback needs multicast: see tests/hal/test_net.c)\n", u);
        free(c);
        return -EIO;
    }
    parse_udpm(c, u);
    if (c->udpm) {
        const int rcvbuf = url_option(c->opts, "recv_buf_size"); /* -1: the kernel's default */
        const int rc = udpm_rx_open(c->base_addr, c->base_port, rcvbuf > 0 ? rcvbuf : 0, &c->rx);
        if (rc != 0) {
            lcm_destroy(c->lcm);
            free(c);
            return -EIO;
        }
    }
    hal_host_net_kfilter_init(&c->kf, c->udpm ? udpm_rx_fd(c->rx) : -1, 1);
    pthread_mutex_init(&c->mu, NULL);
    pthread_cond_init(&c->joiner_cv, NULL);
    c->making = -1;
    *ctx = c;
    return 0;
}

static void lcm_close(void *ctx)
{
    lcm_ctx_t *c = ctx;
    if (c->joiner_on) {
        pthread_mutex_lock(&c->mu);
        c->joiner_stop = 1;
        pthread_cond_signal(&c->joiner_cv);
        pthread_mutex_unlock(&c->mu);
        pthread_join(c->joiner, NULL); /* it finishes the join it is in (10 s at most) */
    }
    for (uint32_t i = 0; i < c->n_retire; i++)
        lcm_destroy(c->retire[i]);
    for (uint32_t i = 0; i < c->n_subs; i++)
        if (c->sub[i] != NULL)
            (void)lcm_unsubscribe(c->lcm, c->sub[i]);
    lcm_destroy(c->lcm);
    udpm_rx_close(c->rx);
    hal_host_net_kfilter_close(&c->kf);
    for (uint32_t s = 0; s < BOARD_MAX_FLEET; s++) {
        if (c->joined[s] != NULL)
            lcm_destroy(c->joined[s]);
        if (c->made[s] != NULL)
            lcm_destroy(c->made[s]);
        if (c->to[s] != NULL)
            lcm_destroy(c->to[s]);
    }
    for (uint32_t i = 0; i < c->n_inbox_done; i++)
        if (c->inbox[i] != NULL)
            lcm_destroy(c->inbox[i]);
    if (c->own != NULL)
        lcm_destroy(c->own);
    for (int k = 0; k < 2; k++)
        if (c->wake[k] >= 0)
            close(c->wake[k]);
    pthread_cond_destroy(&c->joiner_cv);
    pthread_mutex_destroy(&c->mu);
    free(c);
}

/* The publishing thread: an instance for robot r's inbox, the one used longest ago closed
   when TO_MAX are open. 0 or -EIO (said). */
static int inbox_open(lcm_ctx_t *c, uint32_t r)
{
    if (c->n_to == TO_MAX) {
        uint32_t old = UINT32_MAX;
        for (uint32_t i = 0; i < BOARD_MAX_FLEET; i++)
            if (c->to[i] != NULL && (old == UINT32_MAX || c->to_used[i] < c->to_used[old]))
                old = i;
        lcm_destroy(c->to[old]);
        c->to[old] = NULL;
        c->n_to--;
    }
    char u[URL_MAX];
    if (group_url(c, GROUP_SPAN + r, u, sizeof u) == 0)
        c->to[r] = lcm_create(u);
    if (c->to[r] == NULL) {
        fprintf(stderr, "hal_host_net: cannot create LCM for robot %u's inbox\n", r);
        return -EIO;
    }
    c->n_to++;
    return 0;
}

static int lcm_pub(void *ctx, const char *channel, const void *data, size_t len, int64_t sender)
{
    lcm_ctx_t *c = ctx;
    static const uint8_t empty; /* LCM wants a non-NULL pointer even for an empty message */
    lcm_t *to = c->lcm;
    /* grouped[] is written once, before the fleet publishes on it (hal_host_net_group_by_sender) */
    if (c->grouped[0] != '\0' && sender >= 0 && sender < (int64_t)BOARD_MAX_FLEET &&
        strcmp(channel, c->grouped) == 0) {
        if (sender != c->own_sender) {
            char u[URL_MAX];
            if (c->own != NULL)
                lcm_destroy(c->own);
            c->own = NULL;
            c->own_sender = sender;
            if (group_url(c, (uint32_t)sender, u, sizeof u) == 0)
                c->own = lcm_create(u);
            if (c->own == NULL)
                fprintf(stderr, "hal_host_net: cannot create LCM for sender %lld's group\n", (long long)sender);
        }
        if (c->own == NULL)
            return -EIO;
        to = c->own;
    } else if (c->n_prefix > 0) {
        const int64_t r = inbox_of(c, channel);
        if (r >= 0) {
            if (c->to[r] == NULL && inbox_open(c, (uint32_t)r) != 0)
                return -EIO;
            c->to_used[r] = ++c->n_published;
            to = c->to[r];
        }
    }
    return lcm_publish(to, channel, len > 0 ? data : &empty, (unsigned)len) != 0 ? -EIO : 0;
}

/* LCM channel arguments are regular expressions; a valid channel name may contain '.', so it
   is escaped to match exactly that channel. */
static lcm_subscription_t *subscribe_exact(lcm_ctx_t *c, lcm_t *lcm, const char *channel)
{
    char re[2u * HAL_NET_CHANNEL_MAX + 1u];
    size_t k = 0;
    for (const char *p = channel; *p != '\0'; p++) {
        if (*p == '.')
            re[k++] = '\\';
        re[k++] = *p;
    }
    re[k] = '\0';
    lcm_subscription_t *sub = lcm_subscribe(lcm, re, on_message, c);
    /* LCM drops a channel's datagram, silently, once 31 of that channel wait in its own queue
       for lcm_handle (lcm.c: 30 by default): whenever its reader thread got ahead of ours by
       that much, as it does on a CPU shared by 128 robots. In a storm of requests beacons
       were lost that way, uncounted, and live peers timed out. The bound is now LCM_QUEUE_MAX
       (or the queue's depth when smaller). */
    if (sub != NULL)
        (void)lcm_subscription_set_queue_capacity(sub, c->lcm_queue_cap);
    return sub;
}

static void wake_receiver(lcm_ctx_t *c)
{
    const uint8_t b = 1;
    (void)!write(c->wake[1], &b, 1); /* a full pipe already wakes the receiver */
}

static void filter_said(lcm_ctx_t *c, int r);

static int lcm_sub(void *ctx, const char *channel)
{
    lcm_ctx_t *c = ctx;
    const int64_t r = c->n_prefix > 0 ? inbox_of(c, channel) : -1;
    if (r >= 0) { /* joined on the receiver thread (apply_groups) */
        pthread_mutex_lock(&c->mu);
        const int full = c->n_inbox == HAL_HOST_NET_MAX_SUBS;
        if (!full) {
            snprintf(c->inbox_ch[c->n_inbox], sizeof c->inbox_ch[0], "%s", channel);
            c->inbox_id[c->n_inbox++] = (uint32_t)r;
            c->dirty = 1;
        }
        pthread_mutex_unlock(&c->mu);
        if (full)
            return -ENOSPC;
        wake_receiver(c);
        return 0;
    }
    if (c->n_subs == HAL_HOST_NET_MAX_SUBS)
        return -ENOSPC;
    if (c->rx == NULL) { /* over udpm:// the channels are told apart above (hal_host_net.c) */
        lcm_subscription_t *sub = subscribe_exact(c, c->lcm, channel);
        if (sub == NULL)
            return -EIO;
        c->sub[c->n_subs] = sub;
    }
    c->n_subs++;
    pthread_mutex_lock(&c->mu); /* the kernel drops the channels we do not receive */
    filter_said(c, hal_host_net_kfilter_receive(&c->kf, channel));
    pthread_mutex_unlock(&c->mu);
    return 0;
}

static void *joiner_main(void *arg);

static int lcm_group(void *ctx, const char *channel, int by_receiver)
{
    lcm_ctx_t *c = ctx;
    if (!c->udpm)
        return -ENOTSUP;
    pthread_mutex_lock(&c->mu);
    int rc = 0;
    if (c->wake[0] < 0) {
        if (pipe(c->wake) != 0)
            rc = -EIO;
        for (int k = 0; k < 2 && rc == 0; k++)
            (void)fcntl(c->wake[k], F_SETFL, O_NONBLOCK);
    }
    if (rc == 0 && by_receiver) {
        uint32_t i = 0;
        while (i < c->n_prefix && strcmp(c->prefix[i], channel) != 0)
            i++;
        if (i == c->n_prefix && c->n_prefix == PREFIX_MAX)
            rc = -ENOSPC;
        else if (i == c->n_prefix)
            snprintf(c->prefix[c->n_prefix++], sizeof c->prefix[0], "%s", channel);
    } else if (rc == 0) {
        if (c->grouped[0] != '\0') {
            rc = strcmp(c->grouped, channel) == 0 ? 0 : -ENOSPC; /* one grouped channel */
        } else {
            snprintf(c->grouped, sizeof c->grouped, "%s", channel);
            if (pthread_create(&c->joiner, NULL, joiner_main, c) != 0)
                rc = -EIO;
            c->joiner_on = rc == 0;
        }
    }
    pthread_mutex_unlock(&c->mu);
    return rc;
}

/* mu held: a kernel filter that could not be put leaves hal_host_net.c's check on arrival and
   LCM's on the channel alone (said once). */
static void filter_said(lcm_ctx_t *c, int r)
{
    if (r != 0 && r != -ENOSPC && !c->kf_warned) {
        fprintf(stderr, "hal_host_net: no kernel filter on the LCM socket (%s): unwanted senders' datagrams "
                        "are dropped on arrival instead\n", strerror(-r));
        c->kf_warned = 1;
    }
}

static int lcm_senders(void *ctx, const char *channel, const uint8_t *wanted, uint32_t n_ids)
{
    lcm_ctx_t *c = ctx;
    pthread_mutex_lock(&c->mu);
    if (c->grouped[0] == '\0' || strcmp(channel, c->grouped) != 0) {
        filter_said(c, hal_host_net_kfilter_senders(&c->kf, channel, wanted)); /* carried on the URL's group */
        pthread_mutex_unlock(&c->mu);
        return 0;
    }
    if (wanted != NULL) {
        memcpy(c->want, wanted, sizeof c->want);
    } else { /* every sender of the fleet */
        memset(c->want, 0, sizeof c->want);
        for (uint32_t s = 0; s < n_ids && s < BOARD_MAX_FLEET; s++)
            c->want[s / 8u] |= (uint8_t)(1u << (s % 8u));
    }
    c->dirty = 1;
    pthread_cond_signal(&c->joiner_cv);
    pthread_mutex_unlock(&c->mu);
    wake_receiver(c);
    return 0;
}

/* Group g joined for `channel` (a new instance), or NULL, said once (*warned). Blocks: LCM 1.3
   sets up an instance's receiving side with a self test, a datagram sent to the group and
   waited for, up to 10 s, which is why sender groups are joined on a thread of their own. */
static lcm_t *join(lcm_ctx_t *c, uint32_t g, const char *channel, int *warned)
{
    char u[URL_MAX] = "";
    lcm_t *l = group_url(c, g, u, sizeof u) == 0 ? lcm_create(u) : NULL;
    if (l != NULL && subscribe_exact(c, l, channel) == NULL) {
        lcm_destroy(l);
        l = NULL;
    }
    if (l == NULL && !*warned) {
        fprintf(stderr, "hal_host_net: cannot join the group of %s %u (%s): what it carries is missed\n",
                g >= GROUP_SPAN ? "inbox" : "sender", g % GROUP_SPAN, u);
        *warned = 1;
    }
    return l;
}

static int bit(const uint8_t *set, uint32_t s)
{
    return (set[s / 8u] >> (s % 8u)) & 1u;
}

static void set_bit(uint8_t *set, uint32_t s, int on)
{
    if (on)
        set[s / 8u] |= (uint8_t)(1u << (s % 8u));
    else
        set[s / 8u] &= (uint8_t)~(1u << (s % 8u));
}

/* mu held: the lowest sender wanted whose group nobody has, makes or failed to make, or -1. */
static int64_t next_missing(const lcm_ctx_t *c)
{
    for (uint32_t s = 0; s < BOARD_MAX_FLEET; s++)
        if (bit(c->want, s) && !bit(c->have, s) && !bit(c->failed, s) && c->made[s] == NULL &&
            (int64_t)s != c->making)
            return (int64_t)s;
    return -1;
}

/* The joiner thread: retires what the receiver handed back, joins what is wanted and missing,
   one group at a time, and wakes the receiver to adopt it. */
static void *joiner_main(void *arg)
{
    lcm_ctx_t *c = arg;
    hal_host_name_thread("lcm-join");
    pthread_mutex_lock(&c->mu);
    for (;;) {
        int64_t s;
        while (!c->joiner_stop && c->n_retire == 0 && (s = next_missing(c)) < 0)
            pthread_cond_wait(&c->joiner_cv, &c->mu);
        if (c->joiner_stop)
            break;
        const uint32_t n_gone = c->n_retire;
        memcpy(c->gone, c->retire, n_gone * sizeof c->gone[0]);
        c->n_retire = 0;
        s = next_missing(c);
        c->making = s;
        pthread_mutex_unlock(&c->mu);
        for (uint32_t i = 0; i < n_gone; i++)
            lcm_destroy(c->gone[i]);
        lcm_t *l = s >= 0 ? join(c, (uint32_t)s, c->grouped, &c->warned_join) : NULL;
        pthread_mutex_lock(&c->mu);
        c->making = -1;
        if (s >= 0) {
            c->made[s] = l;
            set_bit(c->failed, (uint32_t)s, l == NULL);
            c->dirty = 1;
        }
        pthread_mutex_unlock(&c->mu);
        if (l != NULL)
            wake_receiver(c);
        pthread_mutex_lock(&c->mu);
    }
    pthread_mutex_unlock(&c->mu);
    return NULL;
}

/* The receiver thread: the inboxes subscribed since the last call joined (once, at the start:
   blocking is harmless then), the groups the joiner made adopted while still wanted, and the
   ones no longer wanted handed to the joiner to destroy. Never blocks on a join. A group that
   cannot be joined is reported once and left out (what it carries is then asked for and missed
   like losses: the protocol times that peer out of our neighbours in the end). */
static void apply_groups(lcm_ctx_t *c)
{
    char drain[64];
    while (read(c->wake[0], drain, sizeof drain) > 0) {
    }
    pthread_mutex_lock(&c->mu);
    const uint32_t n_inbox = c->n_inbox;
    pthread_mutex_unlock(&c->mu);
    for (; c->n_inbox_done < n_inbox; c->n_inbox_done++) { /* inbox_* [< n_inbox] stay as they are */
        const uint32_t i = c->n_inbox_done;
        uint32_t j = 0;
        while (j < i && (c->inbox_id[j] != c->inbox_id[i] || c->inbox[j] == NULL))
            j++;
        c->inbox[i] = NULL;
        if (j < i) /* this robot's inbox is joined already: one more channel on it */
            (void)subscribe_exact(c, c->inbox[j], c->inbox_ch[i]);
        else
            c->inbox[i] = join(c, GROUP_SPAN + c->inbox_id[i], c->inbox_ch[i], &c->warned_inbox);
    }
    if (!c->joiner_on)
        return;
    pthread_mutex_lock(&c->mu);
    if (!c->dirty) { /* nothing made, nothing wanted anew since the last look */
        pthread_mutex_unlock(&c->mu);
        return;
    }
    int work = 0;
    uint32_t n_want = 0;
    c->turn++;
    for (uint32_t s = 0; s < BOARD_MAX_FLEET; s++) {
        const int w = bit(c->want, s);
        n_want += (uint32_t)w;
        if (c->made[s] != NULL) {
            if (w && c->joined[s] == NULL) {
                c->joined[s] = c->made[s];
                c->n_joined++;
                c->made[s] = NULL;
            } else if (c->n_retire < RETIRE_MAX) {
                c->retire[c->n_retire++] = c->made[s];
                c->made[s] = NULL;
            }
        }
        if (c->joined[s] != NULL)
            c->unwanted_since[s] = w ? 0 : c->unwanted_since[s] != 0 ? c->unwanted_since[s] : c->turn;
        if (!w)
            set_bit(c->failed, s, 0); /* tried again once it is wanted again */
        work |= w && c->joined[s] == NULL;
    }
    /* Beyond the spare ones, the groups unwanted the longest go (else next time). */
    while (c->n_joined > n_want + SPARE_GROUPS && c->n_retire < RETIRE_MAX) {
        uint32_t old = UINT32_MAX;
        for (uint32_t s = 0; s < BOARD_MAX_FLEET; s++)
            if (c->joined[s] != NULL && c->unwanted_since[s] != 0 &&
                (old == UINT32_MAX || c->unwanted_since[s] < c->unwanted_since[old]))
                old = s;
        if (old == UINT32_MAX)
            break;
        c->retire[c->n_retire++] = c->joined[old];
        c->joined[old] = NULL;
        c->n_joined--;
    }
    for (uint32_t s = 0; s < BOARD_MAX_FLEET; s++)
        set_bit(c->have, s, c->joined[s] != NULL);
    c->dirty = 0;
    if (work || c->n_retire > 0)
        pthread_cond_signal(&c->joiner_cv);
    pthread_mutex_unlock(&c->mu);
}

static int lcm_handle_for(void *ctx, int timeout_ms)
{
    lcm_ctx_t *c = ctx;
    if (c->wake[0] < 0) { /* no grouped channel: the URL's group alone */
        if (c->rx != NULL)
            return udpm_rx_handle(c->rx, timeout_ms, on_udpm, c) < 0 ? -EIO : 0;
        return lcm_handle_timeout(c->lcm, timeout_ms) < 0 ? -EIO : 0;
    }
    apply_groups(c);
    uint32_t k = 0;
    c->pfd[k] = (struct pollfd){.fd = c->wake[0], .events = POLLIN};
    c->pfd_lcm[k++] = NULL;
    c->pfd[k] = (struct pollfd){.fd = c->rx != NULL ? udpm_rx_fd(c->rx) : lcm_get_fileno(c->lcm), .events = POLLIN};
    c->pfd_lcm[k++] = c->lcm;
    for (uint32_t i = 0; i < c->n_inbox_done; i++)
        if (c->inbox[i] != NULL) {
            c->pfd[k] = (struct pollfd){.fd = lcm_get_fileno(c->inbox[i]), .events = POLLIN};
            c->pfd_lcm[k++] = c->inbox[i];
        }
    for (uint32_t s = 0; s < BOARD_MAX_FLEET; s++)
        if (c->joined[s] != NULL) {
            c->pfd[k] = (struct pollfd){.fd = lcm_get_fileno(c->joined[s]), .events = POLLIN};
            c->pfd_lcm[k++] = c->joined[s];
        }
    const int r = poll(c->pfd, k, timeout_ms);
    if (r < 0)
        return errno == EINTR ? 0 : -EIO;
    if ((c->pfd[1].revents & POLLIN) &&
        (c->rx != NULL ? udpm_rx_drain(c->rx, on_udpm, c) : lcm_handle(c->lcm)) < 0)
        return -EIO;
    for (uint32_t i = 2; i < k; i++)
        if (c->pfd[i].revents & POLLIN)
            (void)lcm_handle(c->pfd_lcm[i]); /* a group lost is a sender missed */
    return 0;
}

/* Inline receiving (hal_host_net_transport.h): the URL group's socket, when it is all we
   receive on (no grouped channel, no inbox group: those are LCM instances) and the kernel
   buffers at least the queue's bytes (recv_buf_size within net.core.rmem_max). */
static int lcm_inline_fd(void *ctx, size_t queue_bytes)
{
    lcm_ctx_t *c = ctx;
    if (c->rx == NULL || c->wake[0] >= 0 || udpm_rx_rcvbuf(c->rx) < queue_bytes)
        return -1;
    return udpm_rx_fd(c->rx);
}

static int lcm_take(void *ctx, uint32_t max)
{
    lcm_ctx_t *c = ctx;
    return udpm_rx_take(c->rx, max, on_udpm, c) < 0 ? -EIO : 0;
}

const hal_host_net_transport_t hal_host_net_lcm = {"lcm",          lcm_open,    lcm_close, lcm_pub, lcm_sub,
                                                   lcm_handle_for, lcm_senders, lcm_group, lcm_inline_fd, lcm_take, NULL, 0};
