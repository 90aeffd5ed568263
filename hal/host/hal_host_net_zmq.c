/* The ZeroMQ transport of the host network (hal_host_net_transport.h): the source paper's
 * "direct TCP connections", peer to peer, no broker in the data path; or, for fleets of
 * hundreds, every robot through one forwarder (the proxy at the end of this file).
 *
 * URL: "zmq://BIND?peers=HOST:PORT,HOST:PORT,..." (host_sim run --transport zmq --peers builds
 * it). The process binds one PUB socket on tcp://BIND (e.g. "*:7701") and connects one SUB
 * socket to every peer's PUB. Or "zmq://?proxy=HOST:PORT" (--zmq-proxy): the PUB connects to
 * the proxy's PORT, the SUB to its PORT + 1, and everything below holds as over the mesh,
 * except that a robot hears its own datagrams of the topics it subscribes to.
 * Every datagram goes out as one frame, the topic, a NUL, then its bytes, to every connected
 * peer that subscribed to its topic (a prefix of the frame). One frame, not two: libzmq 4.3
 * aborts a subscriber whose connection drops while half of a multipart message is in its pipe
 * (an assertion in its session's clean-up, zeromq/libzmq#3442),
 * which killed a robot of a 128-robot fleet as its peers exited. PUB/SUB carries what is for
 * everyone (states, beacons, RoundCompletes) as LCM's multicast did, and what is for one robot
 * (a request naming chunks, the chunks sent again) on that robot's own channel, which only it
 * subscribes to, so the publisher sends it down one connection; no socket needs a reply (REQ/REP
 * would block a robot on a peer that is gone). Each connection keeps its sender's order, which
 * the protocol uses (gp_fleet_cfg_t.ordered).
 *
 * Topics and neighbour-scoped delivery. The topic is the channel, '#', then the sender
 * as 8 lower-case hex digits when the datagram names one (a typed channel: hal_host_net.c
 * passes typed_sender()), else nothing: "fleetsim/3/state#0000002a", "fleetsim/3/telemetry#".
 * '#' is no channel character, so the topic ends the channel exactly, and the fixed width
 * makes every sender's topic no prefix of another's (sender 1 is "...#00000001", never a
 * prefix of 17's "...#00000011"). ZeroMQ's PUB filters by topic prefix AT THE PUBLISHER: the
 * SUB subscribes to "CHANNEL#" for each subscribed channel (every sender), and for a channel
 * narrowed by hal_host_net_set_senders to one topic "CHANNEL#%08x" per wanted sender instead,
 * so an unwanted sender's bytes never cross TCP. A change subscribes the topics new to the set
 * before it unsubscribes the ones gone (no gap for senders in both), and only those. The
 * receiver splits the frame at its first NUL and strips the topic back to the channel ('#' and
 * 8 hex digits, or '#' alone; anything else, or no NUL within a topic's length, is counted
 * invalid). A process of a build before these topics is not heard (one fleet,
 * one build), and a channel must be typed (hal_host_net_expect_type) at its publishers as at
 * its receivers, or its datagrams carry no sender and a narrowed receiver never gets them
 * (host_sim types the fleet channels on every robot alike; a robot's resend channel is typed
 * at that robot only, and never narrowed, so "CHANNEL#" reaches it from every publisher).
 * Subscriptions cross TCP
 * asynchronously: for a moment after a change what was in flight still arrives (hal_host_net.c's
 * filter drops it) and a newly wanted sender's datagrams may be missed (recovered like any
 * loss).
 *
 * Thread safety: a ZeroMQ socket belongs to one thread. The SUB is the receiver thread's
 * (zmq_handle); subscribe and senders come from the caller's thread, so they only record the
 * wanted state under `mu` and write a byte to a pipe that zmq_handle polls beside the SUB: it
 * wakes at once and applies the difference on the receiver thread (ZMQ_SUBSCRIBE and
 * ZMQ_UNSUBSCRIBE). The PUB is the publishing thread's (hal_host_net.c serialises publish).
 *
 * Chosen on purpose, because the protocol recovers what the transport loses but must never
 * block or grow without bound:
 *   - ZMQ_SNDHWM / ZMQ_RCVHWM 1000 messages per peer: a peer that does not keep up (stopped,
 *     slow) has its messages dropped past that, as a lossy link drops them; its chunks are
 *     asked for again when it is back. 1000 x 60 KB bounds the memory held per peer at 60 MB.
 *   - ZMQ_RECONNECT_IVL 100 ms (up to ZMQ_RECONNECT_IVL_MAX 2 s): a peer that restarts on its
 *     port is reconnected to by itself; what it missed meanwhile is asked for again.
 *   - ZMQ_MAXMSGSIZE: a peer sending a frame larger than a datagram can be is disconnected.
 *   - ZMQ_LINGER 0: closing never waits for unsent messages (a stopping robot must stop).
 * Messages published before a peer's SUB connected are lost (ZeroMQ's "slow joiner"): the
 * protocol's beacons and resend requests cover that like any loss. */
#include "hal_host.h"
#include "hal_host_auth.h"
#include "hal_host_net_transport.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zmq.h>

#define ZMQ_HWM 1000
#define ZMQ_PEERS_MAX 1024
#define ENDPOINT_MAX 300

#define SENDER_HEX 8u /* hex digits of the sender in a topic */
#define TOPIC_MAX (HAL_NET_CHANNEL_MAX + 1u + SENDER_HEX) /* channel, '#', sender, NUL */
#define FRAME_MAX (TOPIC_MAX + HAL_NET_MTU_BYTES + HAL_HOST_AUTH_TRAILER_BYTES) /* topic, NUL, datagram */

/* One subscribed channel: what the caller wants (under mu) and what the SUB has (the
   receiver thread's). */
typedef struct zmq_chan {
    char name[HAL_NET_CHANNEL_MAX];
    int dirty;                               /* want differs from have (under mu) */
    int want_filtered;                       /* under mu */
    uint8_t want[HAL_HOST_NET_SENDER_BYTES];
    int have_subscribed, have_filtered;      /* the receiver thread's */
    uint8_t have[HAL_HOST_NET_SENDER_BYTES];
} zmq_chan_t;

typedef struct zmq_ctx {
    void *ctx, *pub, *sub;
    hal_host_net_t *n;
    pthread_mutex_t mu;   /* chans' wanted state, n_chans, dirty */
    int mu_ok;
    int wake[2];          /* a byte written: the wanted subscriptions changed (read end polled) */
    int dirty;
    uint32_t n_chans;
    zmq_chan_t chans[HAL_HOST_NET_MAX_SUBS];
    char tx_topic[TOPIC_MAX];    /* the publishing thread's topic (its frame: topic, NUL, datagram) */
    uint8_t rx[FRAME_MAX];       /* the receiver thread's */
} zmq_ctx_t;

static void zmq_close_all(zmq_ctx_t *c)
{
    if (c->pub != NULL)
        zmq_close(c->pub);
    if (c->sub != NULL)
        zmq_close(c->sub);
    if (c->ctx != NULL)
        zmq_ctx_term(c->ctx);
    for (int k = 0; k < 2; k++)
        if (c->wake[k] >= 0)
            close(c->wake[k]);
    if (c->mu_ok)
        pthread_mutex_destroy(&c->mu);
    free(c);
}

static int set_int(void *sock, int opt, int v)
{
    return zmq_setsockopt(sock, opt, &v, sizeof v);
}

/* "HOST:PORT" with a port 1..65535 and a host of letters, digits, '.', '-', ':' (IPv6 in
   brackets) or '*': into tcp://HOST:PORT. 0 or -1. */
static int endpoint_of(const char *s, size_t len, char *out, size_t cap)
{
    if (len == 0 || len >= ENDPOINT_MAX - 7u)
        return -1;
    const char *colon = NULL;
    for (size_t i = 0; i < len; i++)
        if (s[i] == ':')
            colon = s + i;
    if (colon == NULL || colon == s)
        return -1;
    char *end = NULL;
    const long port = strtol(colon + 1, &end, 10);
    if (end != s + len || port < 1 || port > 65535)
        return -1;
    for (const char *p = s; p < colon; p++)
        if (!((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') || *p == '.' ||
              *p == '-' || *p == ':' || *p == '[' || *p == ']' || *p == '*'))
            return -1;
    return snprintf(out, cap, "tcp://%.*s", (int)len, s) < (int)cap ? 0 : -1;
}

/* "HOST:PORT" of a proxy (PORT 1..65534): its two endpoints, PORT for publishers and PORT + 1
   for subscribers. 0 or -1. */
static int proxy_endpoints(const char *s, char *in, char *out)
{
    const char *colon = strrchr(s, ':');
    if (endpoint_of(s, strlen(s), in, ENDPOINT_MAX) != 0 || colon == NULL)
        return -1;
    const long port = strtol(colon + 1, NULL, 10);
    return port < 65535 &&
           snprintf(out, ENDPOINT_MAX, "tcp://%.*s:%ld", (int)(colon - s), s, port + 1) < ENDPOINT_MAX ? 0 : -1;
}

static int zmq_open_url(hal_host_net_t *n, const char *url, void **out)
{
    const char *bind = url + 6; /* after "zmq://" */
    const char *q = strstr(bind, "?peers=");
    const int via_proxy = strncmp(bind, "?proxy=", 7) == 0;
    char ep[ENDPOINT_MAX], ep_sub[ENDPOINT_MAX];
    if (via_proxy) {
        if (proxy_endpoints(bind + 7, ep, ep_sub) != 0) {
            fprintf(stderr, "hal_host_net: zmq: '%s' is not HOST:PORT of a proxy (host_sim zmq-proxy: its port "
                            "and the next)\n", bind + 7);
            return -EINVAL;
        }
    } else if (q == NULL) {
        fprintf(stderr, "hal_host_net: '%s' is not zmq://HOST:PORT?peers=HOST:PORT,... (the endpoint this robot "
                        "binds, then its peers') or zmq://?proxy=HOST:PORT\n", url);
        return -EINVAL;
    } else if (endpoint_of(bind, (size_t)(q - bind), ep, sizeof ep) != 0) {
        fprintf(stderr, "hal_host_net: zmq: '%.*s' is not HOST:PORT to bind (e.g. *:7701)\n", (int)(q - bind), bind);
        return -EINVAL;
    }
    zmq_ctx_t *c = calloc(1, sizeof *c);
    if (c == NULL)
        return -ENOMEM;
    c->n = n;
    c->wake[0] = c->wake[1] = -1;
    c->mu_ok = pthread_mutex_init(&c->mu, NULL) == 0;
    if (!c->mu_ok || pipe(c->wake) != 0 || fcntl(c->wake[0], F_SETFL, O_NONBLOCK) != 0 ||
        fcntl(c->wake[1], F_SETFL, O_NONBLOCK) != 0 || fcntl(c->wake[0], F_SETFD, FD_CLOEXEC) != 0 ||
        fcntl(c->wake[1], F_SETFD, FD_CLOEXEC) != 0) {
        fprintf(stderr, "hal_host_net: zmq: cannot make the wake-up pipe\n");
        zmq_close_all(c);
        return -EIO;
    }
    c->ctx = zmq_ctx_new();
    c->pub = c->ctx ? zmq_socket(c->ctx, ZMQ_PUB) : NULL;
    c->sub = c->ctx ? zmq_socket(c->ctx, ZMQ_SUB) : NULL;
    const int64_t max_msg = (int64_t)FRAME_MAX;
    if (c->pub == NULL || c->sub == NULL || set_int(c->pub, ZMQ_SNDHWM, ZMQ_HWM) != 0 ||
        set_int(c->pub, ZMQ_LINGER, 0) != 0 || set_int(c->pub, ZMQ_XPUB_NODROP, 1) != 0 || set_int(c->sub, ZMQ_RCVHWM, ZMQ_HWM) != 0 ||
        set_int(c->sub, ZMQ_LINGER, 0) != 0 || set_int(c->sub, ZMQ_RECONNECT_IVL, 100) != 0 ||
        set_int(c->sub, ZMQ_RECONNECT_IVL_MAX, 2000) != 0 ||
        zmq_setsockopt(c->sub, ZMQ_MAXMSGSIZE, &max_msg, sizeof max_msg) != 0) {
        fprintf(stderr, "hal_host_net: zmq: cannot set up the sockets: %s\n", zmq_strerror(zmq_errno()));
        zmq_close_all(c);
        return -EIO;
    }
    if (via_proxy) { /* both sockets connect: asynchronous, reconnected by themselves */
        if (set_int(c->pub, ZMQ_RECONNECT_IVL, 100) != 0 || set_int(c->pub, ZMQ_RECONNECT_IVL_MAX, 2000) != 0 ||
            zmq_connect(c->pub, ep) != 0 || zmq_connect(c->sub, ep_sub) != 0) {
            fprintf(stderr, "hal_host_net: zmq: cannot connect to the proxy %s / %s: %s\n", ep, ep_sub,
                    zmq_strerror(zmq_errno()));
            zmq_close_all(c);
            return -EIO;
        }
        *out = c;
        return 0;
    }
    if (zmq_bind(c->pub, ep) != 0) {
        fprintf(stderr, "hal_host_net: zmq: cannot bind %s: %s\n", ep, zmq_strerror(zmq_errno()));
        zmq_close_all(c);
        return -EIO;
    }
    int peers = 0;
    for (const char *p = q + 7; *p != '\0';) {
        const size_t len = strcspn(p, ",");
        char pe[ENDPOINT_MAX];
        if (endpoint_of(p, len, pe, sizeof pe) != 0 || ++peers > ZMQ_PEERS_MAX) {
            fprintf(stderr, "hal_host_net: zmq: peer '%.*s' is not HOST:PORT%s\n", (int)len, p,
                    peers > ZMQ_PEERS_MAX ? " (too many peers)" : "");
            zmq_close_all(c);
            return -EINVAL;
        }
        if (zmq_connect(c->sub, pe) != 0) { /* asynchronous: fails only on a bad endpoint */
            fprintf(stderr, "hal_host_net: zmq: cannot connect to %s: %s\n", pe, zmq_strerror(zmq_errno()));
            zmq_close_all(c);
            return -EIO;
        }
        p += len + (p[len] == ',');
    }
    *out = c;
    return 0;
}

static void zmq_close_ctx(void *ctx)
{
    zmq_close_all(ctx);
}

/* PUB and XPUB never block: past a subscriber's high-water mark its copy is dropped (a lossy
   link). ZeroMQ drops it silently, so the sockets are set ZMQ_XPUB_NODROP, under which a send
   that would drop fails with EAGAIN instead; then it goes out lossy (every other subscriber still
   gets its copy) and says so. That lossy send parks the full subscriber until its queue drains
   below the low-water mark, and what it misses meanwhile is dropped without a word: so this
   counts overflows, each one copy or more lost. The robots' PUB and the proxy's XPUB alike.
   0 sent whole, 1 an overflow, -1 failed (m is still the caller's: zmq_msg_send's rule). */
static int msg_send_counting(void *sock, zmq_msg_t *m, int flags)
{
    if (zmq_msg_send(m, sock, flags | ZMQ_DONTWAIT) >= 0)
        return 0;
    if (zmq_errno() != EAGAIN || set_int(sock, ZMQ_XPUB_NODROP, 0) != 0)
        return -1;
    const int sent = zmq_msg_send(m, sock, flags | ZMQ_DONTWAIT) >= 0;
    (void)set_int(sock, ZMQ_XPUB_NODROP, 1); /* the option just set on this socket: cannot fail */
    return sent ? 1 : -1;
}

/* "CHANNEL#" and, for sender >= 0, its 8 hex digits: the topic's length. */
static int topic_of(char *out, const char *channel, int64_t sender)
{
    return sender >= 0 ? snprintf(out, TOPIC_MAX, "%s#%08x", channel, (unsigned)sender)
                       : snprintf(out, TOPIC_MAX, "%s#", channel);
}

static int zmq_pub(void *ctx, const char *channel, const void *data, size_t len, int64_t sender)
{
    zmq_ctx_t *c = ctx;
    const int tl = topic_of(c->tx_topic, channel, sender <= (int64_t)UINT32_MAX ? sender : -1);
    zmq_msg_t m;
    if (tl < 0 || (size_t)tl >= sizeof c->tx_topic || (size_t)tl + 1u + len > FRAME_MAX ||
        zmq_msg_init_size(&m, (size_t)tl + 1u + len) != 0)
        return -EIO;
    uint8_t *frame = zmq_msg_data(&m);
    memcpy(frame, c->tx_topic, (size_t)tl); /* the topic, then a NUL, then the datagram */
    frame[tl] = '\0';
    if (len > 0)
        memcpy(frame + tl + 1, data, len);
    /* A peer that did not subscribe to the topic gets nothing. */
    const int r = msg_send_counting(c->pub, &m, 0);
    if (r < 0)
        zmq_msg_close(&m); /* not sent: still ours */
    return r < 0 ? -EIO : r;
}

/* Tells the receiver thread that the wanted subscriptions changed (a full pipe has told it). */
static void wake_receiver(zmq_ctx_t *c)
{
    const char b = 1;
    (void)!write(c->wake[1], &b, 1);
}

static int zmq_sub(void *ctx, const char *channel)
{
    zmq_ctx_t *c = ctx;
    int rc = 0;
    pthread_mutex_lock(&c->mu);
    uint32_t i = 0;
    while (i < c->n_chans && strcmp(c->chans[i].name, channel) != 0)
        i++;
    if (i == c->n_chans) {
        if (c->n_chans == HAL_HOST_NET_MAX_SUBS) {
            rc = -ENOSPC;
        } else {
            zmq_chan_t *ch = &c->chans[c->n_chans++];
            memcpy(ch->name, channel, strlen(channel) + 1u);
            ch->dirty = c->dirty = 1; /* every sender: "CHANNEL#" */
        }
    }
    pthread_mutex_unlock(&c->mu);
    if (rc == 0)
        wake_receiver(c);
    return rc;
}

static int zmq_senders(void *ctx, const char *channel, const uint8_t *wanted, uint32_t n_ids)
{
    (void)n_ids; /* NULL is every topic: "CHANNEL#" */
    zmq_ctx_t *c = ctx;
    pthread_mutex_lock(&c->mu);
    uint32_t i = 0;
    while (i < c->n_chans && strcmp(c->chans[i].name, channel) != 0)
        i++;
    if (i == c->n_chans) {
        pthread_mutex_unlock(&c->mu);
        return -EINVAL;
    }
    zmq_chan_t *ch = &c->chans[i];
    ch->want_filtered = wanted != NULL;
    if (wanted != NULL)
        memcpy(ch->want, wanted, sizeof ch->want);
    ch->dirty = c->dirty = 1;
    pthread_mutex_unlock(&c->mu);
    wake_receiver(c);
    return 0;
}

/* The receiver thread, c->mu held: one (un)subscription of the SUB. */
static void sub_topic(zmq_ctx_t *c, int opt, const char *channel, int64_t sender)
{
    char t[TOPIC_MAX];
    const int tl = topic_of(t, channel, sender);
    if (zmq_setsockopt(c->sub, opt, t, (size_t)tl) != 0)
        fprintf(stderr, "hal_host_net: zmq: cannot %ssubscribe %s: %s\n", opt == ZMQ_SUBSCRIBE ? "" : "un", t,
                zmq_strerror(zmq_errno()));
}

/* The receiver thread, c->mu held: one channel's SUB subscriptions brought to what is wanted,
 * the new ones first, then the ones gone; nothing for what stays. */
static void apply_chan(zmq_ctx_t *c, zmq_chan_t *ch)
{
    const int plain_had = ch->have_subscribed && !ch->have_filtered, plain_want = !ch->want_filtered;
    const int ids_had = ch->have_subscribed && ch->have_filtered;
    if (plain_want && !plain_had)
        sub_topic(c, ZMQ_SUBSCRIBE, ch->name, -1);
    for (int pass = 0; pass < 2; pass++) { /* 0: subscribe what is new, 1: unsubscribe what went */
        for (size_t b = 0; b < HAL_HOST_NET_SENDER_BYTES; b++) {
            const unsigned had = ids_had ? ch->have[b] : 0u, want = ch->want_filtered ? ch->want[b] : 0u;
            const unsigned diff = pass == 0 ? want & ~had : had & ~want;
            for (unsigned k = 0; diff != 0 && k < 8u; k++)
                if ((diff >> k) & 1u)
                    sub_topic(c, pass == 0 ? ZMQ_SUBSCRIBE : ZMQ_UNSUBSCRIBE, ch->name, (int64_t)(b * 8u + k));
        }
    }
    if (plain_had && !plain_want)
        sub_topic(c, ZMQ_UNSUBSCRIBE, ch->name, -1);
    ch->have_subscribed = 1;
    ch->have_filtered = ch->want_filtered;
    memcpy(ch->have, ch->want, sizeof ch->have);
    ch->dirty = 0;
}

/* The receiver thread: the wake-up pipe emptied (when it woke us), and what changed applied
 * to the SUB. */
static void apply_pending(zmq_ctx_t *c, int woken)
{
    char b[64];
    while (woken && read(c->wake[0], b, sizeof b) > 0) {
    }
    pthread_mutex_lock(&c->mu);
    if (c->dirty) {
        for (uint32_t i = 0; i < c->n_chans; i++)
            if (c->chans[i].dirty)
                apply_chan(c, &c->chans[i]);
        c->dirty = 0;
    }
    pthread_mutex_unlock(&c->mu);
}

/* A received topic back to its channel, in place: "CHANNEL#" or "CHANNEL#" and 8 hex digits.
 * 0, or -1 when it is neither (the datagram is then refused). */
static int strip_topic(char *topic, int len)
{
    const char *hash = memchr(topic, '#', (size_t)len);
    if (hash == NULL)
        return -1;
    const int at = (int)(hash - topic), digits = len - at - 1;
    if (digits != 0 && digits != (int)SENDER_HEX)
        return -1;
    for (int k = at + 1; k < len; k++)
        if (!((topic[k] >= '0' && topic[k] <= '9') || (topic[k] >= 'a' && topic[k] <= 'f')))
            return -1;
    topic[at] = '\0';
    return 0;
}

/* The rest of a message of several frames (not ours: ours have one). */
static void drain(void *sock)
{
    int more = 1;
    size_t sz = sizeof more;
    while (zmq_getsockopt(sock, ZMQ_RCVMORE, &more, &sz) == 0 && more) {
        zmq_msg_t m;
        zmq_msg_init(&m);
        (void)zmq_msg_recv(&m, sock, ZMQ_DONTWAIT);
        zmq_msg_close(&m);
    }
}

static int zmq_handle(void *ctx, int timeout_ms)
{
    zmq_ctx_t *c = ctx;
    apply_pending(c, 0);
    zmq_pollitem_t it[2] = {{c->sub, 0, ZMQ_POLLIN, 0}, {NULL, c->wake[0], ZMQ_POLLIN, 0}};
    const int r = zmq_poll(it, 2, timeout_ms);
    if (r < 0)
        return zmq_errno() == EINTR ? 0 : -EIO;
    if (it[1].revents & ZMQ_POLLIN)
        apply_pending(c, 1); /* woken by subscribe or senders */
    for (int k = 0; k < 256 && (it[0].revents & ZMQ_POLLIN); k++) { /* what is there now, a bounded batch */
        const int fl = zmq_recv(c->sub, c->rx, sizeof c->rx, ZMQ_DONTWAIT);
        if (fl < 0)
            return zmq_errno() == EAGAIN || zmq_errno() == EINTR ? 0 : -EIO;
        int more = 0;
        size_t sz = sizeof more;
        const uint8_t *nul = memchr(c->rx, '\0', (size_t)fl < TOPIC_MAX ? (size_t)fl : TOPIC_MAX);
        if (zmq_getsockopt(c->sub, ZMQ_RCVMORE, &more, &sz) != 0 || more || fl > (int)sizeof c->rx || nul == NULL) {
            drain(c->sub); /* several frames, one cut (its real length says so), or no topic */
            hal_host_net_on_datagram(c->n, NULL, NULL, 0); /* counted as invalid */
            continue;
        }
        const int tl = (int)(nul - c->rx);
        char *channel = (char *)c->rx; /* the topic, stripped to its channel in place */
        if (strip_topic(channel, tl) != 0)
            channel[0] = '\0'; /* not our topic: refused as such */
        hal_host_net_on_datagram(c->n, channel, c->rx + tl + 1, (size_t)(fl - tl - 1));
    }
    return 0;
}

const hal_host_net_transport_t hal_host_net_zmq = {"zmq",   zmq_open_url, zmq_close_ctx, zmq_pub,
                                                   zmq_sub, zmq_handle,   zmq_senders, NULL, NULL, NULL, NULL, 0};

/* ---- The proxy (host_sim zmq-proxy) ----
 * One XSUB bound on PORT that every robot's PUB connects to, one XPUB on PORT + 1 that every
 * SUB connects to. A subscription (topic) goes up from the XPUB to the XSUB and on to every
 * publisher, so a publisher still sends a topic nobody wants nowhere; the XPUB sends each
 * frame only to the subscribers of its topic, so neighbour-scoped delivery holds. Order per
 * sender is kept (one connection in, one out, one thread between). A subscriber past its
 * high-water mark loses frames, as over the full mesh, and the proxy counts its overflows. Not
 * zmq_proxy(): this loop stops on a flag within PROXY_POLL_MS and counts what it forwards. */
#define PROXY_POLL_MS 200

/* Up to 256 messages (all their frames) from `from` to `to`, none waiting. Adds to frames and
   bytes, and to *overflows (NULL: not counted) each time a subscriber's queue was found full;
   0, or -1 on an error other than "nothing more" / "interrupted". */
static int proxy_move(void *from, void *to, uint64_t *frames, uint64_t *bytes, uint64_t *overflows)
{
    zmq_msg_t m;
    zmq_msg_init(&m);
    int rc = 0;
    for (int k = 0; k < 256; k++) {
        int more = 1;
        while (more) {
            const int got = zmq_msg_recv(&m, from, ZMQ_DONTWAIT);
            if (got < 0) {
                rc = zmq_errno() == EAGAIN || zmq_errno() == EINTR ? 0 : -1;
                goto done;
            }
            more = zmq_msg_more(&m);
            *bytes += (uint64_t)got;
            /* XSUB takes subscriptions at once; the XPUB counts an overflow (msg_send_counting).
               A failure is a frame lost, as on a lossy link. */
            const int r = msg_send_counting(to, &m, more ? ZMQ_SNDMORE : 0);
            if (r > 0 && overflows != NULL)
                (*overflows)++;
            if (r < 0) {
                zmq_msg_close(&m); /* not sent: still ours */
                zmq_msg_init(&m);
            }
        }
        (*frames)++;
    }
done:
    zmq_msg_close(&m);
    return rc;
}

int hal_host_zmq_proxy_run(const char *host, unsigned port, const atomic_int *stop,
                           void (*progress)(const hal_host_zmq_proxy_stats_t *s, void *user), void *user)
{
    char hp[ENDPOINT_MAX], in[ENDPOINT_MAX], out[ENDPOINT_MAX];
    if (port < 1 || port > 65534 || snprintf(hp, sizeof hp, "%s:%u", host, port) >= (int)sizeof hp ||
        proxy_endpoints(hp, in, out) != 0) {
        fprintf(stderr, "hal_host_zmq_proxy: '%s' port %u: not a host to bind and a port 1..65534\n", host, port);
        return -EINVAL;
    }
    void *ctx = zmq_ctx_new();
    void *xsub = ctx ? zmq_socket(ctx, ZMQ_XSUB) : NULL, *xpub = ctx ? zmq_socket(ctx, ZMQ_XPUB) : NULL;
    const int64_t max_msg = (int64_t)FRAME_MAX;
    int rc = -EIO;
    if (xsub == NULL || xpub == NULL || set_int(xsub, ZMQ_RCVHWM, ZMQ_HWM) != 0 || set_int(xsub, ZMQ_LINGER, 0) != 0 ||
        zmq_setsockopt(xsub, ZMQ_MAXMSGSIZE, &max_msg, sizeof max_msg) != 0 ||
        set_int(xpub, ZMQ_SNDHWM, ZMQ_HWM) != 0 || set_int(xpub, ZMQ_LINGER, 0) != 0 ||
        set_int(xpub, ZMQ_XPUB_NODROP, 1) != 0) {
        fprintf(stderr, "hal_host_zmq_proxy: cannot set up the sockets: %s\n", zmq_strerror(zmq_errno()));
        goto out;
    }
    if (zmq_bind(xsub, in) != 0 || zmq_bind(xpub, out) != 0) {
        fprintf(stderr, "hal_host_zmq_proxy: cannot bind %s and %s: %s\n", in, out, zmq_strerror(zmq_errno()));
        goto out;
    }
    hal_host_zmq_proxy_stats_t s = {0};
    zmq_pollitem_t it[2] = {{xsub, 0, ZMQ_POLLIN, 0}, {xpub, 0, ZMQ_POLLIN, 0}};
    rc = 0;
    while (rc == 0 && !atomic_load(stop)) {
        const int r = zmq_poll(it, 2, PROXY_POLL_MS);
        if (r < 0 && zmq_errno() != EINTR)
            rc = -EIO; /* said below, once, as a forwarding failure */
        if (r > 0 && (it[0].revents & ZMQ_POLLIN) && proxy_move(xsub, xpub, &s.frames, &s.bytes, &s.overflows) != 0)
            rc = -EIO;
        if (r > 0 && (it[1].revents & ZMQ_POLLIN) && proxy_move(xpub, xsub, &s.subscriptions, &s.sub_bytes, NULL) != 0)
            rc = -EIO;
        if (progress != NULL)
            progress(&s, user);
    }
    if (rc != 0)
        fprintf(stderr, "hal_host_zmq_proxy: forwarding failed: %s\n", zmq_strerror(zmq_errno()));
out:
    if (xsub != NULL)
        zmq_close(xsub);
    if (xpub != NULL)
        zmq_close(xpub);
    if (ctx != NULL)
        zmq_ctx_term(ctx);
    return rc;
}
