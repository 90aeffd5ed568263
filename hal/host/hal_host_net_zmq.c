/* The ZeroMQ transport of the host network (hal_host_net_transport.h): the source paper's
 * "direct TCP connections", peer to peer, no broker in the data path.
 *
 * URL: "zmq://BIND?peers=HOST:PORT,HOST:PORT,..." (host_sim run --transport zmq --peers builds
 * it). The process binds one PUB socket on tcp://BIND (e.g. "*:7701") and connects one SUB
 * socket to every peer's PUB. Every datagram goes out as two frames, [channel][bytes], to every
 * connected peer: the fleet's messages are all "to everyone" (states, RoundCompletes, resend
 * requests), so PUB/SUB carries them as LCM's multicast did, and no socket needs a reply.
 * (ROUTER/DEALER would address single peers, which the protocol never does; REQ/REP would
 * block a robot on a peer that is gone.) The SUB subscribes to everything; hal_host_net.c
 * keeps only the channels this process subscribed to.
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
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zmq.h>

#define ZMQ_HWM 1000
#define ZMQ_PEERS_MAX 1024
#define ENDPOINT_MAX 300

typedef struct zmq_ctx {
    void *ctx, *pub, *sub;
    hal_host_net_t *n;
    char channel[HAL_NET_CHANNEL_MAX + 1];
    uint8_t buf[HAL_NET_MTU_BYTES + HAL_HOST_AUTH_TRAILER_BYTES];
} zmq_ctx_t;

static void zmq_close_all(zmq_ctx_t *c)
{
    if (c->pub != NULL)
        zmq_close(c->pub);
    if (c->sub != NULL)
        zmq_close(c->sub);
    if (c->ctx != NULL)
        zmq_ctx_term(c->ctx);
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

static int zmq_open_url(hal_host_net_t *n, const char *url, void **out)
{
    const char *bind = url + 6; /* after "zmq://" */
    const char *q = strstr(bind, "?peers=");
    if (q == NULL) {
        fprintf(stderr, "hal_host_net: '%s' is not zmq://HOST:PORT?peers=HOST:PORT,... (the endpoint this robot "
                        "binds, then its peers')\n", url);
        return -EINVAL;
    }
    char ep[ENDPOINT_MAX];
    if (endpoint_of(bind, (size_t)(q - bind), ep, sizeof ep) != 0) {
        fprintf(stderr, "hal_host_net: zmq: '%.*s' is not HOST:PORT to bind (e.g. *:7701)\n", (int)(q - bind), bind);
        return -EINVAL;
    }
    zmq_ctx_t *c = calloc(1, sizeof *c);
    if (c == NULL)
        return -ENOMEM;
    c->n = n;
    c->ctx = zmq_ctx_new();
    c->pub = c->ctx ? zmq_socket(c->ctx, ZMQ_PUB) : NULL;
    c->sub = c->ctx ? zmq_socket(c->ctx, ZMQ_SUB) : NULL;
    const int64_t max_msg = (int64_t)sizeof c->buf;
    if (c->pub == NULL || c->sub == NULL || set_int(c->pub, ZMQ_SNDHWM, ZMQ_HWM) != 0 ||
        set_int(c->pub, ZMQ_LINGER, 0) != 0 || set_int(c->sub, ZMQ_RCVHWM, ZMQ_HWM) != 0 ||
        set_int(c->sub, ZMQ_LINGER, 0) != 0 || set_int(c->sub, ZMQ_RECONNECT_IVL, 100) != 0 ||
        set_int(c->sub, ZMQ_RECONNECT_IVL_MAX, 2000) != 0 ||
        zmq_setsockopt(c->sub, ZMQ_MAXMSGSIZE, &max_msg, sizeof max_msg) != 0 ||
        zmq_setsockopt(c->sub, ZMQ_SUBSCRIBE, "", 0) != 0) {
        fprintf(stderr, "hal_host_net: zmq: cannot set up the sockets: %s\n", zmq_strerror(zmq_errno()));
        zmq_close_all(c);
        return -EIO;
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

static int zmq_pub(void *ctx, const char *channel, const void *data, size_t len)
{
    zmq_ctx_t *c = ctx;
    /* PUB never blocks: past the high-water mark a peer's copy is dropped (a lossy link). */
    if (zmq_send(c->pub, channel, strlen(channel), ZMQ_SNDMORE) < 0 || zmq_send(c->pub, data, len, 0) < 0)
        return -EIO;
    return 0;
}

static int zmq_sub(void *ctx, const char *channel)
{
    (void)ctx; /* the SUB takes everything; hal_host_net.c keeps what was subscribed */
    (void)channel;
    return 0;
}

/* The rest of a message whose frames do not fit the datagram shape. */
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
    zmq_pollitem_t it = {c->sub, 0, ZMQ_POLLIN, 0};
    const int r = zmq_poll(&it, 1, timeout_ms);
    if (r < 0)
        return zmq_errno() == EINTR ? 0 : -EIO;
    for (int k = 0; k < 256 && r > 0; k++) { /* what is there now, a bounded batch */
        const int cl = zmq_recv(c->sub, c->channel, sizeof c->channel - 1u, ZMQ_DONTWAIT);
        if (cl < 0)
            return zmq_errno() == EAGAIN || zmq_errno() == EINTR ? 0 : -EIO;
        int more = 0;
        size_t sz = sizeof more;
        if (zmq_getsockopt(c->sub, ZMQ_RCVMORE, &more, &sz) != 0 || !more || cl >= (int)sizeof c->channel - 1) {
            drain(c->sub);
            hal_host_net_on_datagram(c->n, NULL, NULL, 0); /* counted as invalid */
            continue;
        }
        c->channel[cl] = '\0';
        const int dl = zmq_recv(c->sub, c->buf, sizeof c->buf, 0);
        if (dl < 0)
            return zmq_errno() == EINTR ? 0 : -EIO;
        if (zmq_getsockopt(c->sub, ZMQ_RCVMORE, &more, &sz) != 0 || more) {
            drain(c->sub);
            hal_host_net_on_datagram(c->n, NULL, NULL, 0);
            continue;
        }
        /* A frame longer than the buffer was cut: its real length says so and it is refused. */
        hal_host_net_on_datagram(c->n, c->channel, c->buf, (size_t)dl);
    }
    return 0;
}

const hal_host_net_transport_t hal_host_net_zmq = {"zmq", zmq_open_url, zmq_close_ctx, zmq_pub, zmq_sub, zmq_handle};
