/* hal_net over LCM: publish / receive of fixed-size messages through the HAL wrappers
 * (memq://), MTU limit, channel validation, caller buffer too small, bounded-queue overflow
 * with drop counting, the queue's byte ring (filled to the byte, wrapped with a skip in FIFO
 * order, the message cap, a buffer too small), neighbour-scoped delivery (hal_net_set_senders: unwanted senders dropped
 * on arrival and counted, before a keyed fleet's tag check), and one test with two real
 * processes over udpm:// on this host (the ZeroMQ side of the filter: test_net_zmq.c).
 *
 * udpm on one host (the set-up the two-process test needs; tools/install-deps.sh does not
 * change the network):
 *   - LCM joins the multicast group on the interface the route to 239.255.76.67 picks and
 *     sends with ttl=0, so datagrams never leave the host and are looped back locally.
 *   - Where the default route's interface (eth0 here) carries multicast, that works as is.
 *   - Where there is no usable route (no default route, a container without eth0 multicast)
 *     loopback must carry it, as root:
 *         ip link set lo multicast on
 *         ip route add 224.0.0.0/4 dev lo
 *   - For 60 KB messages at rate, raise the kernel's cap on receive buffers:
 *         sysctl -w net.core.rmem_max=4194304   (the URL asks for recv_buf_size=4194304)
 * When the message does not arrive, the test prints what it found (lo's flags, the route)
 * and these commands, and fails.
 * Checked on the build machine: works as is (eth0 default route); in a fresh network
 * namespace (`unshare -n`, only lo) LCM refuses to start ("LCM requires a valid multicast
 * route") until the two `ip` commands above are run, then the test passes. */
#define _GNU_SOURCE 1
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "hal/hal.h"
#include "hal_host.h"
#include "hal_host_msg.h"
#include "hal_host_net_transport.h"
#include "gp/gp_wire.h"
#include "lcm/fleetsim_state_chunk_t.h"

static uint8_t big[HAL_NET_MTU_BYTES + 16u];
static uint8_t rx[HAL_NET_MTU_BYTES + 16u];

static hal_host_t *make_board(uint32_t depth)
{
    hal_host_config_t cfg = hal_host_config_default();
    cfg.net_url = "memq://";
    cfg.net_queue_depth = depth;
    hal_host_t *h = NULL;
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    assert_int_equal(hal_board_install(hal_host_board(h)), 0);
    return h;
}

static void fill(uint8_t *p, size_t n, uint32_t seed)
{
    for (size_t i = 0; i < n; i++)
        p[i] = (uint8_t)((i * 131u + seed * 7u) >> 3);
}

/* The host network receives on its own thread: a message published here is queued a moment
 * later. recv_wait() waits (up to 2 s) for one to be queued, then takes it; expect_none()
 * gives the receiver time to queue anything that would come, then checks nothing did. */
static int recv_wait(hal_net_rx_info_t *info, void *buf, size_t cap)
{
    (void)!hal_net_wait(2000000u);
    return hal_net_receive(info, buf, cap);
}

static void expect_none(hal_net_rx_info_t *info, void *buf, size_t cap)
{
    (void)!hal_net_wait(50000u);
    assert_int_equal(hal_net_receive(info, buf, cap), -EAGAIN);
}

static void test_publish_receive_fixed_message(void **state)
{
    (void)state;
    hal_host_t *h = make_board(8);
    hal_net_rx_info_t info;
    expect_none(&info, rx, sizeof(rx));
    assert_int_equal(hal_net_subscribe("fleetsim/state"), 0);
    assert_int_equal(hal_net_subscribe("fleetsim/state"), 0); /* twice: no-op */
    fill(big, 1000, 1);
    assert_int_equal(hal_net_publish("fleetsim/state", big, 1000), 0);
    assert_int_equal(hal_net_publish("fleetsim/other", big, 10), 0); /* not subscribed */
    assert_int_equal(recv_wait(&info, rx, sizeof(rx)), 0);
    assert_string_equal(info.channel, "fleetsim/state");
    assert_int_equal(info.len, 1000);
    assert_memory_equal(rx, big, 1000);
    expect_none(&info, rx, sizeof(rx));

    /* Exactly the MTU passes, one byte more is refused before it reaches the wire. */
    fill(big, HAL_NET_MTU_BYTES, 2);
    assert_int_equal(hal_net_publish("fleetsim/state", big, HAL_NET_MTU_BYTES), 0);
    assert_int_equal(hal_net_publish("fleetsim/state", big, HAL_NET_MTU_BYTES + 1u), -EMSGSIZE);
    assert_int_equal(recv_wait(&info, rx, sizeof(rx)), 0);
    assert_int_equal(info.len, HAL_NET_MTU_BYTES);
    assert_memory_equal(rx, big, HAL_NET_MTU_BYTES);
    expect_none(&info, rx, sizeof(rx));

    /* An empty message is a message. */
    assert_int_equal(hal_net_publish("fleetsim/state", NULL, 0), 0);
    assert_int_equal(recv_wait(&info, rx, sizeof(rx)), 0);
    assert_int_equal(info.len, 0);

    /* A buffer too small: the message is dropped, counted, and its length reported. */
    assert_int_equal(hal_net_publish("fleetsim/state", big, 100), 0);
    assert_int_equal(recv_wait(&info, rx, 99), -EMSGSIZE);
    assert_int_equal(info.len, 100);
    expect_none(&info, rx, sizeof(rx));

    hal_net_stats_t st;
    assert_int_equal(hal_net_get_stats(&st), 0);
    assert_int_equal(st.tx_messages, 5);
    assert_int_equal(st.rx_messages, 3);
    assert_int_equal(st.rx_dropped_small, 1);
    assert_int_equal(st.rx_dropped_full, 0);
    assert_int_equal(st.queue_depth, 8);
    hal_host_destroy(h);
}

static void test_channel_names_and_arguments(void **state)
{
    (void)state;
    hal_host_t *h = make_board(4);
    char longname[HAL_NET_CHANNEL_MAX + 1];
    memset(longname, 'a', sizeof(longname));
    longname[HAL_NET_CHANNEL_MAX - 1] = '\0'; /* 63 characters: the longest valid */
    assert_int_equal(hal_net_subscribe(longname), 0);
    longname[HAL_NET_CHANNEL_MAX - 1] = 'a';
    longname[HAL_NET_CHANNEL_MAX] = '\0'; /* 64: too long */
    assert_int_equal(hal_net_subscribe(longname), -EINVAL);
    assert_int_equal(hal_net_publish(longname, big, 1), -EINVAL);
    assert_int_equal(hal_net_publish("", big, 1), -EINVAL);
    assert_int_equal(hal_net_publish("has space", big, 1), -EINVAL);
    assert_int_equal(hal_net_publish(".*", big, 1), -EINVAL);
    assert_int_equal(hal_net_subscribe(NULL), -EINVAL);
    assert_int_equal(hal_net_publish("ok", NULL, 5), -EINVAL);
    hal_net_rx_info_t info;
    assert_int_equal(hal_net_receive(NULL, rx, 1), -EINVAL);
    assert_int_equal(hal_net_receive(&info, NULL, 1), -EINVAL);
    /* '.' is literal, not a regular-expression wildcard: "a.b" does not hear "axb". */
    assert_int_equal(hal_net_subscribe("a.b"), 0);
    assert_int_equal(hal_net_publish("axb", big, 3), 0);
    expect_none(&info, rx, sizeof(rx));
    assert_int_equal(hal_net_publish("a.b", big, 3), 0);
    assert_int_equal(recv_wait(&info, rx, sizeof(rx)), 0);
    assert_string_equal(info.channel, "a.b");
    /* The subscription table is bounded. */
    char name[16];
    int r = 0;
    for (unsigned i = 0; i < HAL_HOST_NET_MAX_SUBS + 1u && r == 0; i++) {
        snprintf(name, sizeof(name), "sub%u", i);
        r = hal_net_subscribe(name);
    }
    assert_int_equal(r, -ENOSPC);
    hal_host_destroy(h);
    /* No board at all. */
    assert_int_equal(hal_net_publish("ok", big, 1), -ENODEV);
}

static void test_queue_overflow_drops_and_counts(void **state)
{
    (void)state;
    hal_host_t *h = make_board(4);
    assert_int_equal(hal_net_subscribe("q"), 0);
    for (uint32_t i = 0; i < 10; i++) {
        uint32_t v = i;
        assert_int_equal(hal_net_publish("q", &v, sizeof(v)), 0);
    }
    /* The first four fit; the other six are dropped as they arrive. */
    hal_net_stats_t sst;
    for (int t = 0; t < 2000; t++) {
        assert_int_equal(hal_net_get_stats(&sst), 0);
        if (sst.rx_dropped_full + sst.queue_fill >= 10)
            break;
        const struct timespec ms = {0, 1000000L};
        nanosleep(&ms, NULL);
    }
    hal_net_rx_info_t info;
    for (uint32_t i = 0; i < 4; i++) {
        uint32_t v = 99;
        assert_int_equal(recv_wait(&info, &v, sizeof(v)), 0);
        assert_int_equal(v, i);
    }
    expect_none(&info, rx, sizeof(rx));
    hal_net_stats_t st;
    assert_int_equal(hal_net_get_stats(&st), 0);
    assert_int_equal(st.rx_messages, 4);
    assert_int_equal(st.rx_dropped_full, 6);
    assert_int_equal(st.queue_fill, 0);
    /* After the overflow the queue works again, and receiving allocates nothing here. */
    alloc_count_reset();
    for (uint32_t i = 0; i < 3; i++) {
        uint32_t v = 100 + i;
        assert_int_equal(hal_net_publish("q", &v, sizeof(v)), 0);
        assert_int_equal(recv_wait(&info, &v, sizeof(v)), 0);
        assert_int_equal(v, 100 + i);
    }
    assert_int_equal(alloc_count_allocations(), 0);
    hal_host_destroy(h);
}

/* ---- neighbour-scoped delivery ---------------------------------------------------------- */
#define FCH "fleetsim/filter/done"

/* A RoundComplete of `sender` (a typed datagram: fingerprint, then the sender). */
static size_t done_from(uint8_t *buf, size_t cap, uint32_t sender)
{
    const gp_pse_done_t d = {sender, 17, 1, 0, 0.0, 0.0};
    const int len = gp_wire_encode_done(&d, buf, cap);
    assert_true(len > 0);
    return (size_t)len;
}

static void publish_from(const uint32_t *senders, int n)
{
    uint8_t b[64];
    for (int i = 0; i < n; i++)
        assert_int_equal(hal_net_publish(FCH, b, done_from(b, sizeof b, senders[i])), 0);
}

/* Every datagram the receiver thread has dealt with, whatever became of it. */
static uint64_t arrived(const hal_net_stats_t *s)
{
    return s->queue_fill + s->rx_messages + s->rx_dropped_small + s->rx_dropped_full + s->rx_dropped_invalid +
           s->rx_dropped_malformed + s->rx_dropped_unauth + s->rx_dropped_replay + s->rx_own + s->rx_unwanted;
}

/* Waits (at most 2 s) until `more` datagrams more than `before` arrived, then takes what was
 * queued, counting each sender (ids < 64) in got[]. */
static void take_senders(uint64_t before, uint64_t more, int *got)
{
    hal_net_stats_t st;
    for (int t = 0; t < 2000; t++) {
        assert_int_equal(hal_net_get_stats(&st), 0);
        if (arrived(&st) >= before + more)
            break;
        const struct timespec ms = {0, 1000000L};
        nanosleep(&ms, NULL);
    }
    assert_int_equal(arrived(&st), before + more);
    memset(got, 0, 64 * sizeof *got);
    hal_net_rx_info_t info;
    uint8_t b[64];
    while (hal_net_receive(&info, b, sizeof b) == 0) {
        gp_pse_done_t d;
        assert_int_equal(gp_wire_decode_done(b, info.len, &d), 0);
        assert_true(d.sender < 64);
        got[d.sender]++;
    }
}

static void test_senders_filter(void **state)
{
    (void)state;
    hal_host_t *h = make_board(64); /* robot 0: its own datagrams are dropped as rx_own */
    hal_host_net_t *n = hal_host_get_net(h);
    static uint8_t all[(BOARD_MAX_FLEET + 7u) / 8u];
    memset(all, 0xff, sizeof all);
    /* Not subscribed, then subscribed but untyped: nothing names the sender. */
    assert_int_equal(hal_net_set_senders(FCH, all, 8), -EINVAL);
    assert_int_equal(hal_net_subscribe(FCH), 0);
    assert_int_equal(hal_net_set_senders(FCH, all, 8), -EINVAL);
    assert_int_equal(hal_host_net_expect_type(n, FCH, HAL_HOST_MSG_ROUND_COMPLETE), 0);
    assert_int_equal(hal_net_set_senders("bad name", all, 8), -EINVAL);
    assert_int_equal(hal_net_set_senders(NULL, NULL, 0), -EINVAL);
    assert_int_equal(hal_net_set_senders(FCH, all, BOARD_MAX_FLEET + 1u), -EINVAL);
    assert_int_equal(hal_host_net_set_senders(NULL, FCH, NULL, 0), -EINVAL);
    assert_int_equal(hal_net_set_senders(FCH, all, BOARD_MAX_FLEET), 0); /* everyone, filtered */
    assert_int_equal(hal_net_set_senders(FCH, NULL, BOARD_MAX_FLEET + 1u), 0); /* n_ids ignored */

    /* Wanted: 1 and 3 of n_ids = 4; the bits past n_ids (5, 6, 7) do not count. */
    const uint8_t w13[1] = {0x0a | 0xe0};
    assert_int_equal(hal_net_set_senders(FCH, w13, 4), 0);
    assert_int_equal(hal_net_set_senders(FCH, w13, 4), 0); /* the same again */
    hal_net_stats_t st;
    assert_int_equal(hal_net_get_stats(&st), 0);
    uint64_t before = arrived(&st);
    const uint32_t from[] = {1, 2, 3, 5, 17, 0};
    publish_from(from, 6);
    /* A datagram too short to name its sender passes the filter; the bounds check refuses it. */
    assert_int_equal(hal_net_publish(FCH, "short", 5), 0);
    int got[64];
    take_senders(before, 7, got);
    assert_int_equal(got[1], 1);
    assert_int_equal(got[3], 1);
    assert_int_equal(got[2] + got[5] + got[17] + got[0], 0);
    assert_int_equal(hal_net_get_stats(&st), 0);
    assert_int_equal(st.rx_unwanted, 3); /* 2, 5 and 17 */
    assert_int_equal(st.rx_own, 1);      /* its own, dropped first as before */
    assert_int_equal(st.rx_dropped_malformed, 1);

    /* n_ids = 0: nobody. */
    assert_int_equal(hal_net_set_senders(FCH, w13, 0), 0);
    before = arrived(&st);
    publish_from(from, 3);
    take_senders(before, 3, got);
    assert_int_equal(got[1] + got[2] + got[3], 0);
    assert_int_equal(hal_net_get_stats(&st), 0);
    assert_int_equal(st.rx_unwanted, 6);

    /* NULL: every sender again. */
    assert_int_equal(hal_net_set_senders(FCH, NULL, 0), 0);
    before = arrived(&st);
    publish_from(from, 5);
    take_senders(before, 5, got);
    assert_true(got[1] == 1 && got[2] == 1 && got[3] == 1 && got[5] == 1 && got[17] == 1);
    assert_int_equal(hal_net_get_stats(&st), 0);
    assert_int_equal(st.rx_unwanted, 6);
    hal_host_destroy(h);
    /* No board. */
    assert_int_equal(hal_net_set_senders(FCH, NULL, 0), -ENODEV);
}

/* A keyed member drops an unwanted sender before the tag check: a forged datagram of an
 * unwanted sender is rx_unwanted, not rx_dropped_unauth; the wanted member is heard. The
 * forged ones are handed to the network as its transport would (hal_host_net_on_datagram). */
static void test_senders_filter_before_the_tag(void **state)
{
    (void)state;
    hal_host_auth_t a;
    memset(a.key, 9, sizeof a.key);
    a.run_id = 5;
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open("memq://", 16, 0, &n), 0);
    assert_int_equal(hal_host_net_set_self(n, 0), 0);
    assert_int_equal(hal_host_net_set_auth(n, &a), 0);
    assert_int_equal(hal_host_net_expect_type(n, FCH, HAL_HOST_MSG_ROUND_COMPLETE), 0);
    assert_int_equal(hal_host_net_subscribe(n, FCH), 0);
    const uint8_t w2[1] = {0x04};
    assert_int_equal(hal_host_net_set_senders(n, FCH, w2, 8), 0);
    uint8_t b[64 + HAL_HOST_AUTH_TRAILER_BYTES];
    /* Unsealed (forged or not a member): sender 1 unwanted, sender 2 wanted. */
    size_t len = done_from(b, sizeof b, 1);
    memset(b + len, 0, HAL_HOST_AUTH_TRAILER_BYTES);
    hal_host_net_on_datagram(n, FCH, b, len + HAL_HOST_AUTH_TRAILER_BYTES);
    len = done_from(b, sizeof b, 2);
    memset(b + len, 0, HAL_HOST_AUTH_TRAILER_BYTES);
    hal_host_net_on_datagram(n, FCH, b, len + HAL_HOST_AUTH_TRAILER_BYTES);
    hal_net_stats_t s;
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.rx_unwanted, 1);
    assert_int_equal(s.rx_dropped_unauth, 1);
    /* Sealed by the member itself (memq delivers them back): 2 is heard, 1 is not. */
    assert_int_equal(hal_host_net_publish(n, FCH, b, done_from(b, sizeof b, 1)), 0);
    assert_int_equal(hal_host_net_publish(n, FCH, b, done_from(b, sizeof b, 2)), 0);
    int heard = 0;
    for (int tries = 0; tries < 40 && (heard < 1 || s.rx_unwanted < 2); tries++) { /* bounded: 2 s */
        assert_int_equal(hal_host_net_wait(n, 0, 50), 0);
        hal_net_rx_info_t info;
        while (hal_host_net_receive(n, 0, &info, b, sizeof b) == 0) {
            gp_pse_done_t d;
            assert_int_equal(gp_wire_decode_done(b, info.len, &d), 0);
            assert_int_equal(d.sender, 2);
            heard++;
        }
        hal_host_net_get_stats(n, &s);
    }
    assert_int_equal(heard, 1);
    assert_int_equal(s.rx_unwanted, 2);
    assert_int_equal(s.rx_dropped_unauth, 1);
    hal_host_net_close(n);
}

/* ---- the receive queue's byte ring (hal_host_net.c) ------------------------------------- */
#define RING_CH "fleetsim/ring"
#define E(len) HAL_HOST_NET_ENTRY_BYTES(len)

/* A datagram's bytes: a pattern of its sequence number, so every byte is checked. */
static void ring_fill(uint8_t *b, uint32_t len, uint32_t seq)
{
    for (uint32_t i = 0; i < len; i++)
        b[i] = (uint8_t)(seq * 131u + i * 7u + (i >> 8));
}

static void ring_expect(const uint8_t *b, uint32_t len, uint32_t seq)
{
    for (uint32_t i = 0; i < len; i++)
        if (b[i] != (uint8_t)(seq * 131u + i * 7u + (i >> 8)))
            fail_msg("datagram %u: byte %u of %u differs", seq, i, len);
}

static hal_host_net_t *ring_open(uint32_t depth, size_t bytes)
{
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open("memq://", depth, bytes, &n), 0);
    assert_int_equal(hal_host_net_subscribe(n, RING_CH), 0);
    return n;
}

/* Returns 1 when the datagram was queued, 0 when it was dropped as full. */
static int ring_push(hal_host_net_t *n, uint32_t len, uint32_t seq)
{
    hal_net_stats_t a, b;
    hal_host_net_get_stats(n, &a);
    ring_fill(big, len, seq);
    hal_host_net_on_datagram(n, RING_CH, big, len);
    hal_host_net_get_stats(n, &b);
    assert_int_equal(b.rx_dropped_invalid, a.rx_dropped_invalid);
    return b.rx_dropped_full == a.rx_dropped_full;
}

static void ring_pop_expect(hal_host_net_t *n, uint32_t len, uint32_t seq)
{
    hal_net_rx_info_t info;
    memset(rx, 0xEE, sizeof rx);
    assert_int_equal(hal_host_net_receive(n, 0, &info, rx, sizeof rx), 0);
    assert_string_equal(info.channel, RING_CH);
    assert_int_equal(info.len, len);
    ring_expect(rx, len, seq);
}

/* Mixed sizes (an MTU-sized datagram, a mid one, a small one, an empty one) fill the ring to
 * its last byte; the next datagram, even an empty one, is dropped and counted; the ring and its
 * high-water mark say so; everything comes out in order, byte for byte. One byte more than an
 * MTU is invalid, never queued. */
static void test_ring_fills_to_the_byte(void **state)
{
    (void)state;
    const uint32_t lens[4] = {(uint32_t)HAL_NET_MTU_BYTES, 1001u, 24u, 0u};
    size_t cap = 0;
    for (int i = 0; i < 4; i++)
        cap += E(lens[i]);
    hal_host_net_t *n = ring_open(100, cap);
    hal_net_stats_t s;
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.queue_bytes_cap, cap);
    assert_int_equal(s.queue_depth, 100);
    for (uint32_t i = 0; i < 4; i++)
        assert_true(ring_push(n, lens[i], i));
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.queue_bytes, cap);
    assert_int_equal(s.queue_fill, 4);
    assert_false(ring_push(n, 0, 99));
    assert_false(ring_push(n, 8, 99));
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.rx_dropped_full, 2);
    assert_int_equal(s.queue_fill, 4);
    hal_host_net_on_datagram(n, RING_CH, big, HAL_NET_MTU_BYTES + 1u);
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.rx_dropped_invalid, 1);
    for (uint32_t i = 0; i < 4; i++)
        ring_pop_expect(n, lens[i], i);
    hal_net_rx_info_t info;
    assert_int_equal(hal_host_net_receive(n, 0, &info, rx, sizeof rx), -EAGAIN);
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.queue_bytes, 0);
    assert_int_equal(s.queue_bytes_max, cap);
    assert_int_equal(s.queue_fill_max, 4); /* the messages' high-water mark, kept once drained */
    assert_int_equal(s.rx_messages, 4);
    /* Empty again: the whole ring is free, an MTU-sized datagram and the rest fit again. */
    for (uint32_t i = 0; i < 4; i++)
        assert_true(ring_push(n, lens[i], 10u + i));
    assert_false(ring_push(n, 0, 99));
    for (uint32_t i = 0; i < 4; i++)
        ring_pop_expect(n, lens[i], 10u + i);
    hal_host_net_close(n);
}

/* Many cycles of mixed sizes through a ring of an odd size, pushes and pops interleaved at
 * random (10000 each, about): every queued datagram comes out in FIFO order with its bytes; entries wrapped with a
 * skip (padding counted in the bytes in use); a drop only when the free bytes could not hold it
 * in one piece (less than twice its entry, the end and the start together). */
static void test_ring_wraps_in_order(void **state)
{
    (void)state;
    const size_t cap = 3u * E(HAL_NET_MTU_BYTES) + 4104u;
    const uint32_t depth = 200;
    hal_host_net_t *n = ring_open(depth, cap);
    enum { FIFO = 256 };
    uint32_t q_len[FIFO], q_seq[FIFO];
    uint32_t q_head = 0, q_fill = 0, seq = 0, popped = 0, dropped = 0;
    size_t q_bytes = 0;
    int padded = 0;
    uint64_t r = 0x9E3779B97F4A7C15ull;
    for (int step = 0; step < 20000; step++) {
        r ^= r << 13;
        r ^= r >> 7;
        r ^= r << 17;
        if ((r & 1u) != 0 || q_fill == 0) { /* push, 1 time in 2 */
            const uint32_t k = (uint32_t)(r >> 8) % 100u;
            uint32_t len = k < 70u ? 20u + (uint32_t)(r >> 20) % 281u /* small */
                           : k < 95u ? (uint32_t)(r >> 20) % 8192u
                                     : (uint32_t)(r >> 20) % ((uint32_t)HAL_NET_MTU_BYTES + 1u);
            if (k == 99u)
                len = (uint32_t)HAL_NET_MTU_BYTES;
            hal_net_stats_t s;
            hal_host_net_get_stats(n, &s);
            const uint64_t in_use = s.queue_bytes;
            if (ring_push(n, len, seq)) {
                assert_true(q_fill < FIFO);
                q_len[(q_head + q_fill) % FIFO] = len;
                q_seq[(q_head + q_fill) % FIFO] = seq;
                q_fill++;
                q_bytes += E(len);
            } else {
                assert_true(q_fill == depth || cap - in_use < 2u * E(len));
                dropped++;
            }
            seq++;
            hal_host_net_get_stats(n, &s);
            assert_int_equal(s.queue_fill, q_fill);
            assert_true(s.queue_bytes >= q_bytes && s.queue_bytes <= cap);
            padded |= s.queue_bytes > q_bytes;
        } else {
            ring_pop_expect(n, q_len[q_head], q_seq[q_head]);
            q_bytes -= E(q_len[q_head]);
            q_head = (q_head + 1u) % FIFO;
            q_fill--;
            popped++;
        }
    }
    while (q_fill > 0) {
        ring_pop_expect(n, q_len[q_head], q_seq[q_head]);
        q_head = (q_head + 1u) % FIFO;
        q_fill--;
        popped++;
    }
    hal_net_stats_t s;
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.queue_bytes, 0);
    assert_int_equal(s.rx_messages, popped);
    assert_int_equal(s.rx_dropped_full, dropped);
    assert_true(padded);
    assert_true(popped > 5000u && dropped > 0u);
    print_message("# ring: %u datagrams through %zu B, %u dropped full, high-water mark %llu B\n", popped, cap,
                  dropped, (unsigned long long)s.queue_bytes_max);
    hal_host_net_close(n);
}

/* The message cap holds whatever the bytes: depth 4 of a roomy ring takes 4 small datagrams. A
 * buffer too small consumes the entry (-EMSGSIZE, rx_dropped_small, its length told) and the
 * next one comes out whole. The open's and the configuration's bounds. */
static void test_ring_depth_cap_and_small_buffer(void **state)
{
    (void)state;
    hal_host_net_t *n = ring_open(4, 0);
    hal_net_stats_t s;
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.queue_bytes_cap, hal_host_net_queue_bytes_default(4));
    assert_true(s.queue_bytes_cap >= 4u * E(HAL_NET_MTU_BYTES));
    for (uint32_t i = 0; i < 4; i++)
        assert_true(ring_push(n, i == 0 ? 100u : 10u, i));
    assert_false(ring_push(n, 1, 4));
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.rx_dropped_full, 1);
    assert_int_equal(s.queue_bytes, E(100) + 3u * E(10));
    hal_net_rx_info_t info;
    assert_int_equal(hal_host_net_receive(n, 0, &info, rx, 50), -EMSGSIZE);
    assert_int_equal(info.len, 100);
    assert_string_equal(info.channel, RING_CH);
    hal_host_net_get_stats(n, &s);
    assert_int_equal(s.rx_dropped_small, 1);
    assert_int_equal(s.queue_fill, 3);
    assert_int_equal(s.queue_bytes, 3u * E(10));
    assert_true(ring_push(n, 7, 5)); /* room for one again */
    for (uint32_t i = 1; i < 4; i++)
        ring_pop_expect(n, 10u, i);
    ring_pop_expect(n, 7u, 5);
    hal_host_net_close(n);

    hal_host_net_t *m = NULL;
    assert_int_equal(hal_host_net_open("memq://", 8, E(HAL_NET_MTU_BYTES) - 8u, &m), -EINVAL);
    assert_int_equal(hal_host_net_open("memq://", 8, HAL_HOST_NET_QUEUE_BYTES_MAX + 8u, &m), -EINVAL);
    assert_int_equal(hal_host_net_open("memq://", HAL_HOST_NET_QUEUE_MAX + 1u, 0, &m), -EINVAL);
    assert_int_equal(hal_host_net_open("memq://", HAL_HOST_NET_QUEUE_MAX, 0, &m), 0);
    hal_host_net_close(m);
    hal_host_config_t cfg = hal_host_config_default();
    cfg.net_url = "memq://";
    hal_host_t *h = NULL;
    cfg.net_queue_bytes = HAL_HOST_NET_QUEUE_BYTES_MIN - 8u;
    assert_int_equal(hal_host_create(&cfg, &h), -EINVAL);
    cfg.net_queue_bytes = HAL_HOST_NET_QUEUE_BYTES_MAX + 1u;
    assert_int_equal(hal_host_create(&cfg, &h), -EINVAL);
    cfg.net_queue_bytes = 0;
    cfg.net_queue_depth = HAL_HOST_NET_QUEUE_MAX + 1u;
    assert_int_equal(hal_host_create(&cfg, &h), -EINVAL);
    cfg.net_queue_depth = 16;
    cfg.net_queue_bytes = HAL_HOST_NET_QUEUE_BYTES_MIN;
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    hal_host_destroy(h);
}

/* ---- two processes over udpm:// ---------------------------------------------------------- */
#define UDPM_CHANNEL "fleetsim/udpm_test"
#define UDPM_LEN 30000u

static int wait_byte(int fd, int timeout_ms, char *out)
{
    struct pollfd p = {.fd = fd, .events = POLLIN};
    int r = poll(&p, 1, timeout_ms);
    if (r <= 0)
        return -ETIMEDOUT;
    return read(fd, out, 1) == 1 ? 0 : -EIO;
}

static void child_receiver(const char *url, int ready_fd, int result_fd)
{
    hal_host_net_t *n = NULL;
    char c = 'E';
    if (hal_host_net_open(url, 8, 0, &n) != 0 || hal_host_net_subscribe(n, UDPM_CHANNEL) != 0) {
        (void)!write(ready_fd, &c, 1);
        _exit(2);
    }
    c = 'R';
    (void)!write(ready_fd, &c, 1);
    static uint8_t buf[HAL_NET_MTU_BYTES];
    static uint8_t want[UDPM_LEN];
    fill(want, UDPM_LEN, 9);
    for (int i = 0; i < 60; i++) { /* up to 6 s */
        if (hal_host_net_wait(n, 0, 100) != 0)
            break;
        hal_net_rx_info_t info;
        int r = hal_host_net_receive(n, 0, &info, buf, sizeof(buf));
        if (r == 0) {
            c = (info.len == UDPM_LEN && memcmp(buf, want, UDPM_LEN) == 0 &&
                 strcmp(info.channel, UDPM_CHANNEL) == 0) ? 'K' : 'B';
            (void)!write(result_fd, &c, 1);
            hal_host_net_close(n);
            _exit(c == 'K' ? 0 : 3);
        }
    }
    c = 'T';
    (void)!write(result_fd, &c, 1);
    hal_host_net_close(n);
    _exit(4);
}

static void explain_udpm(const char *url, const char *what)
{
    char flags[32] = "?";
    FILE *f = fopen("/sys/class/net/lo/flags", "r");
    if (f != NULL) {
        if (fgets(flags, sizeof(flags), f) == NULL)
            strcpy(flags, "?");
        fclose(f);
    }
    flags[strcspn(flags, "\n")] = '\0';
    unsigned long fl = strtoul(flags, NULL, 16);
    printf("# udpm test on %s: %s\n"
           "# lo flags %s (MULTICAST %s). Multicast on this host needs a route for 239.0.0.0/8\n"
           "# on an interface with multicast. As root:\n"
           "#     ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo\n"
           "#     sysctl -w net.core.rmem_max=4194304\n",
           url, what, flags, (fl & 0x1000u) ? "on" : "off");
    fflush(stdout);
    int r = system("echo '# ip route get 239.255.76.67:'; ip route get 239.255.76.67 2>&1 | sed 's/^/#   /'");
    (void)r;
}

/* A receiving child process on `url`: `child(url, ready_fd, result_fd)` never returns. The
 * parent gets the read ends of the ready and result pipes and the child's pid. */
typedef void (*child_fn)(const char *url, int ready_fd, int result_fd);

typedef struct child {
    pid_t pid;
    int ready, result; /* read ends */
} child_t;

static void child_receiver(const char *url, int ready_fd, int result_fd);
static void child_craft_receiver(const char *url, int ready_fd, int result_fd);

/* The receiver runs in a new process image (this program again, with --child): the host
 * network starts a receiver thread, and a thread started after fork() in a multi-threaded
 * process is not supported by every runtime (ThreadSanitizer refuses it). */
static child_t spawn_receiver(child_fn child, const char *url)
{
    int ready[2], result[2];
    assert_int_equal(pipe(ready), 0);
    assert_int_equal(pipe(result), 0);
    fflush(NULL);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        close(ready[0]);
        close(result[0]);
        char r[16], w[16];
        snprintf(r, sizeof r, "%d", ready[1]);
        snprintf(w, sizeof w, "%d", result[1]);
        const char *which = child == child_receiver ? "receiver" : "craft";
        execl("/proc/self/exe", "test_net", "--child", which, url, r, w, (char *)NULL);
        _exit(127);
    }
    close(ready[1]);
    close(result[1]);
    return (child_t){pid, ready[0], result[0]};
}

/* Reaps the child (killed first unless it succeeded); returns its wait status. */
static int reap(child_t *ch, int ok)
{
    if (!ok)
        kill(ch->pid, SIGKILL);
    int status = 0;
    waitpid(ch->pid, &status, 0);
    close(ch->ready);
    close(ch->result);
    return status;
}

static void test_udpm_two_processes(void **state)
{
    (void)state;
    char url[128];
    /* A port of our own, so that concurrent runs (other fleets on this host) do not cross. */
    snprintf(url, sizeof(url), "udpm://239.255.76.67:%u?ttl=0&recv_buf_size=4194304",
             7700u + (unsigned)(getpid() % 250));
    child_t ch = spawn_receiver(child_receiver, url);
    char c = 0;
    int ok = 0;
    const char *what = "the receiver did not start";
    if (wait_byte(ch.ready, 10000, &c) == 0 && c == 'R') {
        hal_host_net_t *n = NULL;
        if (hal_host_net_open(url, 4, 0, &n) == 0) {
            static uint8_t msg[UDPM_LEN];
            fill(msg, UDPM_LEN, 9);
            what = "the message did not arrive within 6 s";
            /* Datagrams may be lost: repeat until the receiver confirms. */
            for (int i = 0; i < 60 && !ok; i++) {
                if (hal_host_net_publish(n, UDPM_CHANNEL, msg, UDPM_LEN) != 0) {
                    what = "publishing failed";
                    break;
                }
                if (wait_byte(ch.result, 100, &c) == 0) {
                    ok = c == 'K';
                    what = c == 'B' ? "a corrupted message arrived" : "receiver gave up";
                    break;
                }
            }
            hal_host_net_close(n);
        } else {
            what = "the publisher could not open LCM";
        }
    } else if (c == 'E') {
        what = "the receiver could not open LCM";
    }
    const int status = reap(&ch, ok);
    if (!ok)
        explain_udpm(url, what);
    else
        printf("# udpm: %u-byte message from one process to another on %s\n", UDPM_LEN, url);
    assert_true(ok);
    assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

/* ---- hostile datagrams over udpm:// ------------------------------------------------------ */
#define CRAFT_CHANNEL "fleetsim/craft_test"
#define CRAFT_KINDS 5

/* A state chunk as lcm-gen encodes it, with its n_bytes field then overwritten. */
static int craft_chunk(uint8_t *b, size_t cap, int32_t n_bytes_field, int32_t real)
{
    static uint8_t data[256];
    fleetsim_state_chunk_t m = {1, 5, 0, 2, 512, 0, 0x1234567, 1.5, -2.0, 0, real, data};
    int n = fleetsim_state_chunk_t_encode(b, 0, (int)cap, &m);
    const int at = 8 + 7 * 4 + 1 + 2 * 8; /* n_bytes, after the hash and ten fields */
    b[at] = (uint8_t)((uint32_t)n_bytes_field >> 24);
    b[at + 1] = (uint8_t)((uint32_t)n_bytes_field >> 16);
    b[at + 2] = (uint8_t)((uint32_t)n_bytes_field >> 8);
    b[at + 3] = (uint8_t)n_bytes_field;
    return n;
}

/* Receives on a typed channel until the one valid chunk arrives, then reports through the
 * pipe how many datagrams the bounds check refused (8 bytes) and exits 0. */
static void child_craft_receiver(const char *url, int ready_fd, int result_fd)
{
    hal_host_net_t *n = NULL;
    char c = 'E';
    if (hal_host_net_open(url, 64, 0, &n) != 0 || hal_host_net_subscribe(n, CRAFT_CHANNEL) != 0 ||
        hal_host_net_expect_type(n, CRAFT_CHANNEL, HAL_HOST_MSG_STATE_CHUNK) != 0) {
        (void)!write(ready_fd, &c, 1);
        _exit(2);
    }
    c = 'R';
    (void)!write(ready_fd, &c, 1);
    static uint8_t b[HAL_NET_MTU_BYTES];
    for (int i = 0; i < 100; i++) { /* up to 10 s */
        if (hal_host_net_wait(n, 0, 100) != 0)
            break;
        hal_net_rx_info_t info;
        while (hal_host_net_receive(n, 0, &info, b, sizeof b) == 0) {
            fleetsim_state_chunk_t d;
            int ok = fleetsim_state_chunk_t_decode(b, 0, (int)info.len, &d) == (int)info.len && d.n_bytes == 200;
            if (ok)
                fleetsim_state_chunk_t_decode_cleanup(&d);
            hal_net_stats_t st;
            hal_host_net_get_stats(n, &st);
            uint64_t rej = st.rx_dropped_malformed;
            c = ok ? 'K' : 'B';
            (void)!write(result_fd, &c, 1);
            (void)!write(result_fd, &rej, sizeof rej);
            hal_host_net_close(n);
            _exit(ok ? 0 : 3);
        }
    }
    c = 'T';
    (void)!write(result_fd, &c, 1);
    hal_host_net_close(n);
    _exit(4);
}

/* A receiving process on a typed channel gets crafted datagrams that would crash or overread
 * the generated decoder, stays up, counts every one, and still takes the valid message. */
static void test_udpm_crafted_datagrams(void **state)
{
    (void)state;
    char url[128];
    snprintf(url, sizeof(url), "udpm://239.255.76.67:%u?ttl=0&recv_buf_size=4194304",
             7960u + (unsigned)(getpid() % 30));
    child_t ch = spawn_receiver(child_craft_receiver, url);
    char c = 0;
    uint64_t rejected = 0;
    int ok = 0, rounds = 0;
    if (wait_byte(ch.ready, 10000, &c) == 0 && c == 'R') {
        hal_host_net_t *n = NULL;
        assert_int_equal(hal_host_net_open(url, 4, 0, &n), 0);
        static uint8_t b[4096];
        for (; rounds < 50 && !ok; rounds++) {
            /* The hostile ones first, then the valid one; repeated until it is confirmed. */
            int len;
            len = craft_chunk(b, sizeof b, -1, 200); /* n_bytes = -1: segfaults the decoder */
            assert_int_equal(hal_host_net_publish(n, CRAFT_CHANNEL, b, (size_t)len), 0);
            len = craft_chunk(b, sizeof b, INT32_MAX, 200); /* reads far past the buffer */
            assert_int_equal(hal_host_net_publish(n, CRAFT_CHANNEL, b, (size_t)len), 0);
            len = craft_chunk(b, sizeof b, 201, 200); /* one byte past the end */
            assert_int_equal(hal_host_net_publish(n, CRAFT_CHANNEL, b, (size_t)len), 0);
            len = craft_chunk(b, sizeof b, 200, 200);
            assert_int_equal(hal_host_net_publish(n, CRAFT_CHANNEL, b, (size_t)len - 10), 0); /* truncated */
            b[0] ^= 0xff; /* another type's fingerprint */
            assert_int_equal(hal_host_net_publish(n, CRAFT_CHANNEL, b, (size_t)len), 0);
            b[0] ^= 0xff;
            assert_int_equal(hal_host_net_publish(n, CRAFT_CHANNEL, b, (size_t)len), 0);
            if (wait_byte(ch.result, 200, &c) == 0) {
                ok = c == 'K' && read(ch.result, &rejected, sizeof rejected) == (ssize_t)sizeof rejected;
                break;
            }
        }
        hal_host_net_close(n);
    }
    const int status = reap(&ch, ok);
    if (!ok)
        explain_udpm(url, "the valid message after the crafted ones did not arrive");
    else
        printf("# udpm: the receiver refused %llu crafted datagrams (%d kinds) and took the valid one\n",
               (unsigned long long)rejected, CRAFT_KINDS);
    assert_true(ok);
    assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    /* Every crafted datagram that reached it was refused; at least one round of them did. */
    assert_true(rejected >= CRAFT_KINDS);
}

int main(int argc, char **argv)
{
    if (argc == 6 && strcmp(argv[1], "--child") == 0) {
        child_fn fn = strcmp(argv[2], "receiver") == 0 ? child_receiver : child_craft_receiver;
        fn(argv[3], atoi(argv[4]), atoi(argv[5]));
        return 5; /* the child functions exit themselves */
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_publish_receive_fixed_message),
        cmocka_unit_test(test_channel_names_and_arguments),
        cmocka_unit_test(test_queue_overflow_drops_and_counts),
        cmocka_unit_test(test_senders_filter),
        cmocka_unit_test(test_senders_filter_before_the_tag),
        cmocka_unit_test(test_ring_fills_to_the_byte),
        cmocka_unit_test(test_ring_wraps_in_order),
        cmocka_unit_test(test_ring_depth_cap_and_small_buffer),
        cmocka_unit_test(test_udpm_two_processes),
        cmocka_unit_test(test_udpm_crafted_datagrams),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
