/* The host network over ZeroMQ/TCP (hal/host/hal_host_net_zmq.c), on this host's loopback:
 * three robots' networks, each binding its own port and connected to the other two, deliver
 * every datagram of a subscribed channel whole to both others (never to the sender), keep
 * channels nobody subscribed to out, carry a keyed fleet's trailer, refuse bad URLs and a port
 * already bound with the reason, and a peer that closes and opens again on its port is
 * reconnected to by itself. Neighbour-scoped delivery (hal_host_net_set_senders): a robot that
 * wants only some senders is not even sent the others' datagrams (the publishers filter by
 * topic, so its rx_unwanted stays 0 once the subscription reached them), ids match exactly
 * (wanting 1 does not bring 17), NULL brings everyone back, and keyed members filter the same.
 * A datagram is one frame (topic, NUL, bytes): a foreign publisher's frames of another shape
 * (two frames, no NUL, a topic not ours) are counted invalid and never delivered. A subscriber
 * that stops reading costs copies at its publisher's high-water mark, counted at the robot or
 * at the proxy, while the other subscribers still get theirs.
 * The fleet over ZeroMQ as real processes: tests/fleet. */
#define _GNU_SOURCE 1
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <cmocka.h>
#include <zmq.h>

#include "hal/hal.h"
#include "hal_host.h"
#include "hal_host_msg.h"
#include "gp/gp_wire.h"
#include "net_heard.h"

#define N 3
#define CH "fleetsim/9/state"

/* How long a connection or a subscription may take to cross TCP. Bounded by the clock, not by
 * a count of waits: a wait returns as soon as anything arrives, so while other datagrams keep
 * coming 100 waits of 50 ms took far less than 5 s, and on a loaded CI machine they ran out
 * before a subscription change had reached its publisher. */
#define CROSS_MS 20000

static long long now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (long long)t.tv_sec * 1000 + t.tv_nsec / 1000000;
}

/* Three ports per test, all below the kernel's ephemeral range (32768 .. 60999 by default):
 * a port there may be a live connection's local end, and binding it then fails. Blocks of
 * 6,000 from `from`: 2000 .. 7999, 8000 .. 13999, 23000 .. 28999, 26000 .. 31999 (the filter
 * tests take 14000 .. 19999 and the proxy 20000 .. 21999). */
static unsigned ports_from(unsigned from)
{
    return from + (unsigned)(getpid() % 2000) * 3u;
}

static unsigned base_port(void)
{
    return ports_from(23000u);
}

/* The URL of robot i of N on ports base .. base + N - 1. */
static void url_of(char *url, size_t cap, int i, unsigned base)
{
    int k = snprintf(url, cap, "zmq://127.0.0.1:%u?peers=", base + (unsigned)i);
    for (int j = 0, first = 1; j < N; j++)
        if (j != i) {
            k += snprintf(url + k, cap - (size_t)k, "%s127.0.0.1:%u", first ? "" : ",", base + (unsigned)j);
            first = 0;
        }
}

/* 0: the robots form the full mesh; else they all go through the proxy on this port. */
static unsigned g_proxy_port;

static hal_host_net_t *open_robot(int i, unsigned base)
{
    char url[256];
    if (g_proxy_port != 0)
        snprintf(url, sizeof url, "zmq://?proxy=127.0.0.1:%u", g_proxy_port);
    else
        url_of(url, sizeof url, i, base);
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open(url, 256, 0, &n), 0);
    if (g_proxy_port != 0) /* as host_sim does: its own typed datagrams, back from the proxy, dropped */
        assert_int_equal(hal_host_net_set_self(n, (uint32_t)i), 0);
    return n;
}

/* Publishes msg (len >= 1, its first byte replaced by `from`) from `from` until every other
 * robot received a datagram of the channel (the first ones may go before the connections are
 * up: ZeroMQ's slow joiner), at most CROSS_MS. Through the proxy a robot also hears its own
 * (its first byte says whose), which is skipped. */
static void exchange(hal_host_net_t **net, int from, const uint8_t *msg, size_t len, int *got)
{
    static uint8_t buf[HAL_NET_MTU_BYTES + 64], out[HAL_NET_MTU_BYTES];
    memcpy(out, msg, len);
    out[0] = (uint8_t)from;
    for (const long long end = now_ms() + CROSS_MS; now_ms() < end;) {
        assert_int_equal(hal_host_net_publish(net[from], CH, out, len), 0);
        int all = 1;
        for (int i = 0; i < N; i++) {
            if (i == from)
                continue;
            assert_int_equal(hal_host_net_wait(net[i], 0, 50), 0);
            hal_net_rx_info_t info;
            while (hal_host_net_receive(net[i], 0, &info, buf, sizeof buf) == 0) {
                assert_string_equal(info.channel, CH);
                if (g_proxy_port != 0 && info.len > 0 && buf[0] != out[0])
                    continue; /* another exchange's: its own, back from the proxy */
                assert_int_equal(info.len, len);
                assert_memory_equal(buf, out, len);
                got[i]++;
            }
            all &= got[i] > 0;
        }
        if (all)
            return;
    }
    fail_msg("robot %d's datagrams did not reach every peer within %d ms", from, CROSS_MS);
}

static void test_three_robots_exchange(void **st)
{
    (void)st;
    const unsigned base = base_port();
    hal_host_net_t *net[N];
    for (int i = 0; i < N; i++) {
        net[i] = open_robot(i, base);
        assert_int_equal(hal_host_net_subscribe(net[i], CH), 0);
    }
    static uint8_t msg[HAL_NET_MTU_BYTES];
    for (size_t i = 0; i < sizeof msg; i++)
        msg[i] = (uint8_t)(i * 11u + 3u);
    for (int from = 0; from < N; from++) {
        int got[N] = {0};
        exchange(net, from, msg, from == 0 ? sizeof msg : 1000u + (size_t)from, got);
        if (g_proxy_port == 0) /* never to the sender (through the proxy it hears its own, as over LCM) */
            assert_int_equal(hal_host_net_queued(net[from]), 0);
    }
    /* A channel nobody subscribed to is kept out. */
    assert_int_equal(hal_host_net_publish(net[0], "fleetsim/9/other", msg, 10), 0);
    assert_int_equal(hal_host_net_wait(net[1], 0, 200), 0);
    hal_net_rx_info_t info;
    static uint8_t buf[HAL_NET_MTU_BYTES];
    while (hal_host_net_receive(net[1], 0, &info, buf, sizeof buf) == 0) /* through the proxy: its own, late */
        assert_true(g_proxy_port != 0 && strcmp(info.channel, CH) == 0);
    for (int i = 0; i < N; i++)
        hal_host_net_close(net[i]);
}

/* One raw frame from the test's own PUB; `more`: a second frame follows. */
static void send_raw(void *pub, const void *frame, size_t len, const char *second)
{
    assert_true(zmq_send(pub, frame, len, second != NULL ? ZMQ_SNDMORE : 0) >= 0);
    if (second != NULL)
        assert_true(zmq_send(pub, second, strlen(second), 0) >= 0);
}

static void test_foreign_frames_refused(void **st)
{
    (void)st;
    const unsigned base = base_port();
    hal_host_net_t *n = open_robot(0, base); /* connects to base + 1, where the test publishes */
    assert_int_equal(hal_host_net_subscribe(n, CH), 0);
    void *ctx = zmq_ctx_new(), *pub = zmq_socket(ctx, ZMQ_PUB);
    char ep[64];
    snprintf(ep, sizeof ep, "tcp://127.0.0.1:%u", base + 1u);
    assert_int_equal(zmq_bind(pub, ep), 0);
    static const char two_frames[] = CH "#", no_nul[] = CH "#00000001xyz", bad_topic[] = CH "#zz\0abc";
    static const char good[] = CH "#\0hello";
    static uint8_t buf[HAL_NET_MTU_BYTES];
    int got = 0;
    /* Until a second batch's good frame came: the first may have gone out half before the
       connection was up (ZeroMQ's slow joiner), the second went whole after it. */
    for (const long long end = now_ms() + CROSS_MS; got < 2 && now_ms() < end;) {
        send_raw(pub, two_frames, sizeof two_frames - 1u, "hello");
        send_raw(pub, no_nul, sizeof no_nul - 1u, NULL);
        send_raw(pub, bad_topic, sizeof bad_topic - 1u, NULL);
        send_raw(pub, good, sizeof good - 1u, NULL);
        assert_int_equal(hal_host_net_wait(n, 0, 50), 0);
        hal_net_rx_info_t info;
        while (hal_host_net_receive(n, 0, &info, buf, sizeof buf) == 0) {
            assert_string_equal(info.channel, CH);
            assert_int_equal(info.len, 5);
            assert_memory_equal(buf, "hello", 5);
            got++;
        }
    }
    assert_true(got >= 2);
    hal_net_stats_t s;
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.rx_messages, (uint64_t)got);
    assert_true(s.rx_dropped_invalid >= 3u); /* the three foreign shapes, at least once each */
    zmq_close(pub);
    zmq_ctx_term(ctx);
    hal_host_net_close(n);
}

static void test_keyed_over_zmq(void **st)
{
    (void)st;
    const unsigned base = ports_from(26000u);
    hal_host_auth_t a;
    memset(a.key, 5, sizeof a.key);
    a.run_id = 77;
    hal_host_net_t *net[N];
    for (int i = 0; i < N; i++) {
        net[i] = open_robot(i, base);
        if (i < 2) /* robot 2 holds no key */
            assert_int_equal(hal_host_net_set_auth(net[i], &a), 0);
        assert_int_equal(hal_host_net_subscribe(net[i], CH), 0);
    }
    const uint8_t msg[64] = {1, 2, 3};
    int got[N] = {0};
    static uint8_t buf[HAL_NET_MTU_BYTES];
    for (const long long end = now_ms() + CROSS_MS; got[1] == 0 && now_ms() < end;) {
        assert_int_equal(hal_host_net_publish(net[0], CH, msg, sizeof msg), 0);
        assert_int_equal(hal_host_net_publish(net[2], CH, msg, sizeof msg), 0); /* not a member */
        assert_int_equal(hal_host_net_wait(net[1], 0, 50), 0);
        hal_net_rx_info_t info;
        while (hal_host_net_receive(net[1], 0, &info, buf, sizeof buf) == 0) {
            assert_int_equal(info.len, sizeof msg); /* the member's, its trailer stripped */
            got[1]++;
        }
    }
    assert_true(got[1] > 0);
    hal_net_stats_t s;
    for (const long long end = now_ms() + CROSS_MS; now_ms() < end;) {
        hal_host_net_get_stats(net[1], &s);
        if (s.rx_dropped_unauth > 0)
            break;
        assert_int_equal(hal_host_net_publish(net[2], CH, msg, sizeof msg), 0);
        assert_int_equal(hal_host_net_wait(net[1], 0, 50), 0);
    }
    assert_true(s.rx_dropped_unauth > 0);
    for (int i = 0; i < N; i++)
        hal_host_net_close(net[i]);
}

static void test_bad_urls_and_a_taken_port(void **st)
{
    (void)st;
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open("zmq://127.0.0.1:7000", 8, 0, &n), -EINVAL); /* no peers= */
    assert_int_equal(hal_host_net_open("zmq://127.0.0.1?peers=", 8, 0, &n), -EINVAL);
    assert_int_equal(hal_host_net_open("zmq://127.0.0.1:70000?peers=", 8, 0, &n), -EINVAL);
    assert_int_equal(hal_host_net_open("zmq://127.0.0.1:7000?peers=a b:1", 8, 0, &n), -EINVAL);
    assert_int_equal(hal_host_net_open("zmq://127.0.0.1:7000?peers=host", 8, 0, &n), -EINVAL);
    assert_null(n);
    char url[128];
    const unsigned port = ports_from(8000u);
    snprintf(url, sizeof url, "zmq://127.0.0.1:%u?peers=", port);
    hal_host_net_t *a = NULL, *b = NULL;
    assert_int_equal(hal_host_net_open(url, 8, 0, &a), 0); /* a fleet of one: no peers */
    assert_int_equal(hal_host_net_open(url, 8, 0, &b), -EIO); /* the port is taken */
    hal_host_net_close(a);
}

/* Robot 1 goes away and comes back on its port: robot 0 hears it again without doing anything. */
static void test_peer_restart_reconnects(void **st)
{
    (void)st;
    const unsigned base = ports_from(2000u);
    hal_host_net_t *net[N];
    for (int i = 0; i < N; i++) {
        net[i] = open_robot(i, base);
        assert_int_equal(hal_host_net_subscribe(net[i], CH), 0);
    }
    const uint8_t msg[32] = {9};
    int got[N] = {0};
    exchange(net, 1, msg, sizeof msg, got);
    hal_host_net_close(net[1]);
    net[1] = open_robot(1, base);
    assert_int_equal(hal_host_net_subscribe(net[1], CH), 0);
    memset(got, 0, sizeof got);
    exchange(net, 1, msg, sizeof msg, got);
    for (int i = 0; i < N; i++)
        hal_host_net_close(net[i]);
}

/* ---- neighbour-scoped delivery ------------------------------------------------------------ */
#define FCH "fleetsim/9/done"

/* One step: robot 1 publishes as sender 1, robot 2 as senders 2 and 17; robot 0 waits up to
 * 50 ms and counts what it took per sender (got[0..31]). */
static void step(hal_host_net_t **net, int *got)
{
    net_publish_done(net[1], FCH, 1);
    net_publish_done(net[2], FCH, 2);
    net_publish_done(net[2], FCH, 17);
    assert_int_equal(hal_host_net_wait(net[0], 0, 50), 0);
    uint8_t b[64];
    hal_net_rx_info_t info;
    while (hal_host_net_receive(net[0], 0, &info, b, sizeof b) == 0) {
        gp_pse_done_t d;
        if (g_proxy_port != 0 && strcmp(info.channel, CH) == 0)
            continue; /* its own exchange's datagrams, back from the proxy */
        assert_string_equal(info.channel, FCH);
        assert_int_equal(gp_wire_decode_done(b, info.len, &d), 0);
        assert_true(d.sender < 32);
        got[d.sender]++;
    }
}

static uint64_t unwanted_at(hal_host_net_t *n)
{
    hal_net_stats_t s;
    hal_host_net_get_stats(n, &s);
    return s.rx_unwanted;
}

static void run_filter(unsigned base, int keyed)
{
    hal_host_auth_t a;
    memset(a.key, 3, sizeof a.key);
    a.run_id = 11;
    hal_host_net_t *net[N];
    for (int i = 0; i < N; i++) {
        net[i] = open_robot(i, base);
        if (keyed)
            assert_int_equal(hal_host_net_set_auth(net[i], &a), 0);
        assert_int_equal(hal_host_net_expect_type(net[i], FCH, HAL_HOST_MSG_ROUND_COMPLETE), 0);
        assert_int_equal(hal_host_net_subscribe(net[i], FCH), 0);
        assert_int_equal(hal_host_net_subscribe(net[i], CH), 0);
    }
    /* The connections up, every pair proved by the first test's exchange on CH (with all
       three publishing at once from the start, a robot at times heard only one of its two
       peers for seconds, with the transport before these topics too). */
    static uint8_t m[100];
    for (int from = 0; from < N; from++) {
        int g[N] = {0};
        exchange(net, from, m, sizeof m, g);
    }
    int got[32] = {0};
    /* Everyone heard on FCH: at most CROSS_MS. */
    for (const long long end = now_ms() + CROSS_MS;
         (got[1] == 0 || got[2] == 0 || got[17] == 0) && now_ms() < end;)
        step(net, got);
    assert_true(got[1] > 0 && got[2] > 0 && got[17] > 0);
    assert_int_equal(unwanted_at(net[0]), 0);

    /* Robot 0 wants only sender 1 of 32. Until the change reached both publishers what was in
       flight still arrives and is dropped here (rx_unwanted); then nothing of 2 or 17 is sent
       to it: 10 quiet steps in a row, at most CROSS_MS. */
    static const uint8_t only1[4] = {0x02, 0, 0, 0};
    assert_int_equal(hal_host_net_set_senders(net[0], FCH, only1, 32), 0);
    assert_int_equal(hal_host_net_set_senders(net[0], FCH, only1, 32), 0); /* the same: no work */
    assert_int_equal(hal_host_net_set_senders(net[0], CH, only1, 32), -EINVAL); /* untyped */
    assert_int_equal(hal_host_net_set_senders(net[0], "fleetsim/9/other", only1, 32), -EINVAL);
    int quiet = 0;
    for (const long long end = now_ms() + CROSS_MS; quiet < 10 && now_ms() < end;) {
        const uint64_t u = unwanted_at(net[0]);
        memset(got, 0, sizeof got);
        step(net, got);
        quiet = got[2] == 0 && got[17] == 0 && unwanted_at(net[0]) == u ? quiet + 1 : 0;
    }
    assert_int_equal(quiet, 10);
    /* Now: sender 1 heard, 2 and 17 (17 = 0x11: exact ids, 1's topic is no prefix of it)
       neither heard nor even received (rx_unwanted stays: their publisher sent them nowhere). */
    const uint64_t u0 = unwanted_at(net[0]);
    memset(got, 0, sizeof got);
    for (int t = 0; t < 20; t++)
        step(net, got);
    assert_true(got[1] > 0);
    assert_int_equal(got[2], 0);
    assert_int_equal(got[17], 0);
    assert_int_equal(unwanted_at(net[0]), u0);
    printf("# zmq filter%s: %llu datagrams in flight dropped on arrival while the subscription moved, "
           "then none sent\n", keyed ? " (keyed)" : "", (unsigned long long)u0);
    /* The others still hear everyone: robot 1 hears 2 and 17. */
    uint8_t b[256]; /* through the proxy its own 100-byte datagrams of the exchange come first */
    hal_net_rx_info_t info;
    int heard17 = 0;
    while (hal_host_net_receive(net[1], 0, &info, b, sizeof b) == 0) {
        gp_pse_done_t d;
        heard17 += strcmp(info.channel, FCH) == 0 && gp_wire_decode_done(b, info.len, &d) == 0 && d.sender == 17;
    }
    assert_true(heard17 > 0);

    /* NULL: every sender again, at most CROSS_MS. */
    assert_int_equal(hal_host_net_set_senders(net[0], FCH, NULL, 0), 0);
    memset(got, 0, sizeof got);
    /* All three: two connections (two publishers, or two into the proxy) keep no order between
       them. */
    for (const long long end = now_ms() + CROSS_MS; (got[1] == 0 || got[2] == 0 || got[17] == 0) && now_ms() < end;)
        step(net, got);
    assert_true(got[1] > 0 && got[2] > 0 && got[17] > 0);
    hal_net_stats_t s;
    hal_host_net_get_stats(net[0], &s);
    assert_int_equal(s.rx_dropped_unauth, 0);
    assert_int_equal(s.rx_dropped_invalid, 0);
    for (int i = 0; i < N; i++)
        hal_host_net_close(net[i]);
}

/* Ports 14000 .. 19999: the other tests' are base_port()'s, and the kernel's ephemeral range
 * (from 32768) is avoided. */
static unsigned filter_base(unsigned k)
{
    return 14000u + (unsigned)(getpid() % 1000) * 6u + 3u * k;
}

static void test_senders_filtered_at_the_publisher(void **st)
{
    (void)st;
    run_filter(filter_base(0), 0);
}

static void test_senders_filtered_keyed(void **st)
{
    (void)st;
    run_filter(filter_base(1), 1);
}

/* The proxy (host_sim zmq-proxy) on a thread of this process. */
typedef struct proxy {
    atomic_int stop;
    unsigned port;
    int rc;
    hal_host_zmq_proxy_stats_t last; /* the proxy thread's; read after the join */
    _Atomic uint64_t overflows;      /* last.overflows, for a reader while it runs */
    pthread_t th;
} proxy_t;

static void proxy_seen(const hal_host_zmq_proxy_stats_t *s, void *user)
{
    proxy_t *p = user;
    p->last = *s;
    atomic_store(&p->overflows, s->overflows);
}

static void *proxy_main(void *arg)
{
    proxy_t *p = arg;
    p->rc = hal_host_zmq_proxy_run("127.0.0.1", p->port, &p->stop, proxy_seen, p);
    return NULL;
}

/* Every robot through one proxy instead of the full mesh: the same exchange (each robot's
 * datagrams whole at both others) and the same neighbour-scoped delivery (a robot that wants
 * only sender 1 is not even sent 2's or 17's: the proxy's XPUB filters by topic, as the
 * publishers do in the mesh). The proxy counts what it forwarded, refuses a port taken and
 * bad arguments, and stops when asked. Ports 20000 .. 21999 (the others' are elsewhere). */
static void test_through_the_proxy(void **st)
{
    (void)st;
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open("zmq://?proxy=", 8, 0, &n), -EINVAL);
    assert_int_equal(hal_host_net_open("zmq://?proxy=host", 8, 0, &n), -EINVAL);
    assert_int_equal(hal_host_net_open("zmq://?proxy=127.0.0.1:65535", 8, 0, &n), -EINVAL); /* no PORT + 1 */
    assert_null(n);
    static proxy_t p;
    atomic_init(&p.stop, 0);
    p.port = 20000u + (unsigned)(getpid() % 1000) * 2u;
    assert_int_equal(hal_host_zmq_proxy_run("127.0.0.1", 0, &p.stop, NULL, NULL), -EINVAL);
    assert_int_equal(hal_host_zmq_proxy_run("a b", p.port, &p.stop, NULL, NULL), -EINVAL);
    assert_int_equal(pthread_create(&p.th, NULL, proxy_main, &p), 0);
    g_proxy_port = p.port;
    test_three_robots_exchange(st);
    run_filter(0, 0);
    g_proxy_port = 0;
    atomic_int no = 0;
    /* Bound already by the thread's proxy (it binds before its first poll, and the exchange
       above went through it). */
    assert_int_equal(hal_host_zmq_proxy_run("127.0.0.1", p.port, &no, NULL, NULL), -EIO);
    atomic_store(&p.stop, 1);
    assert_int_equal(pthread_join(p.th, NULL), 0);
    assert_int_equal(p.rc, 0);
    assert_true(p.last.frames > 0);
    assert_true(p.last.subscriptions > 0);
    printf("# zmq proxy: %llu datagrams (%llu bytes) and %llu subscription changes forwarded\n",
           (unsigned long long)p.last.frames, (unsigned long long)p.last.bytes,
           (unsigned long long)p.last.subscriptions);
}

/* A raw SUB of the test's on `ep`, wanting every topic; `lazy`: it never reads, and holds one
 * message (its high-water mark) and a small socket buffer, so its publisher's queue fills. */
static void *raw_sub(void *ctx, const char *ep, int lazy)
{
    void *sub = zmq_socket(ctx, ZMQ_SUB);
    const int one = 1, small = 4096;
    assert_non_null(sub);
    if (lazy) {
        assert_int_equal(zmq_setsockopt(sub, ZMQ_RCVHWM, &one, sizeof one), 0);
        assert_int_equal(zmq_setsockopt(sub, ZMQ_RCVBUF, &small, sizeof small), 0);
    }
    assert_int_equal(zmq_setsockopt(sub, ZMQ_SUBSCRIBE, "", 0), 0);
    assert_int_equal(zmq_connect(sub, ep), 0);
    return sub;
}

/* Publishes 4 KB datagrams from n until `count` says a copy was dropped, then 100 more, at most
 * 2 x CROSS_MS. Paced by the reading SUB (each publish waits up to 50 ms for it to receive), so
 * that the queue that fills is the lazy subscriber's, not one on the way (a proxy slower than
 * the publisher, under a sanitizer, filled the robot's own first). Returns how many the reader
 * received after the first drop. */
static int publish_until_dropped(hal_host_net_t *n, void *reader, uint64_t (*count)(void *), void *arg)
{
    static uint8_t msg[4096], buf[8192];
    int after = 0, more = -1;
    for (const long long end = now_ms() + 2 * CROSS_MS; now_ms() < end && (more < 100 || after < 10);) {
        assert_int_equal(hal_host_net_publish(n, CH, msg, sizeof msg), 0);
        more += more >= 0 || count(arg) > 0;
        zmq_pollitem_t it = {reader, 0, ZMQ_POLLIN, 0};
        assert_true(zmq_poll(&it, 1, 50) >= 0);
        while (zmq_recv(reader, buf, sizeof buf, ZMQ_DONTWAIT) >= 0)
            after += more >= 0;
    }
    assert_true(more >= 100);
    return after;
}

static uint64_t robot_tx_dropped(void *arg)
{
    hal_net_stats_t s;
    hal_host_net_get_stats(arg, &s);
    return s.tx_overflows;
}

static uint64_t proxy_dropped(void *arg)
{
    return atomic_load(&((proxy_t *)arg)->overflows);
}

/* A subscriber that stops reading loses its copies at its publisher's high-water mark, and that
 * overflow is counted, not silent: a robot's publisher (the mesh) counts tx_overflows, the
 * proxy its `overflows`. The publish still succeeds, and a subscriber that reads still gets its copies
 * after the drops began (a lossy link for one, not a stalled sender for all). Ports 22000 ..
 * 22999. */
static void test_full_queues_counted(void **st)
{
    (void)st;
    const unsigned port = 22000u + (unsigned)(getpid() % 333) * 3u;
    char url[128], ep[64];
    void *ctx = zmq_ctx_new();
    assert_non_null(ctx);
    /* The mesh: robot 0 binds `port`, the test's two SUBs connect to it. */
    snprintf(url, sizeof url, "zmq://127.0.0.1:%u?peers=127.0.0.1:%u", port, port + 1u);
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open(url, 256, 0, &n), 0);
    snprintf(ep, sizeof ep, "tcp://127.0.0.1:%u", port);
    void *lazy = raw_sub(ctx, ep, 1), *reader = raw_sub(ctx, ep, 0);
    const int after = publish_until_dropped(n, reader, robot_tx_dropped, n);
    hal_net_stats_t s;
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.tx_rejected, 0);
    assert_true(s.tx_overflows > 0 && s.tx_overflows < s.tx_messages);
    printf("# mesh: %llu overflows in %llu datagrams at the lazy subscriber; the reader got %d after\n",
           (unsigned long long)s.tx_overflows, (unsigned long long)s.tx_messages, after);
    assert_true(after >= 10);
    zmq_close(lazy);
    zmq_close(reader);
    hal_host_net_close(n);
    /* The proxy on port + 1 (and + 2): robot 0 publishes through it. */
    static proxy_t p;
    atomic_init(&p.stop, 0);
    atomic_init(&p.overflows, 0);
    p.port = port + 1u;
    assert_int_equal(pthread_create(&p.th, NULL, proxy_main, &p), 0);
    snprintf(url, sizeof url, "zmq://?proxy=127.0.0.1:%u", p.port);
    assert_int_equal(hal_host_net_open(url, 256, 0, &n), 0);
    snprintf(ep, sizeof ep, "tcp://127.0.0.1:%u", p.port + 1u);
    lazy = raw_sub(ctx, ep, 1);
    reader = raw_sub(ctx, ep, 0);
    const int after_proxy = publish_until_dropped(n, reader, proxy_dropped, &p);
    atomic_store(&p.stop, 1);
    assert_int_equal(pthread_join(p.th, NULL), 0);
    assert_int_equal(p.rc, 0);
    assert_true(p.last.overflows > 0 && p.last.overflows < p.last.frames);
    printf("# proxy: %llu overflows in %llu datagrams at the lazy subscriber; the reader got %d after\n",
           (unsigned long long)p.last.overflows, (unsigned long long)p.last.frames, after_proxy);
    assert_true(after_proxy >= 10);
    zmq_close(lazy);
    zmq_close(reader);
    hal_host_net_close(n);
    zmq_ctx_term(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_three_robots_exchange),
        cmocka_unit_test(test_foreign_frames_refused),
        cmocka_unit_test(test_keyed_over_zmq),
        cmocka_unit_test(test_bad_urls_and_a_taken_port),
        cmocka_unit_test(test_peer_restart_reconnects),
        cmocka_unit_test(test_senders_filtered_at_the_publisher),
        cmocka_unit_test(test_senders_filtered_keyed),
        cmocka_unit_test(test_through_the_proxy),
        cmocka_unit_test(test_full_queues_counted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
