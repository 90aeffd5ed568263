/* LCM's per-sender groups (hal_host_net_group_by_sender, hal_host_net_lcm.c) over real udpm://
 * sockets on this host: a grouped channel reaches a receiver only from the senders it wants,
 * and the others' datagrams are never copied into it (no rx_unwanted: they did not arrive at
 * all, where the URL's one group would have delivered them and the filter dropped them); the
 * wanted set can change; what is not grouped still travels on the URL's group; a robot's
 * inbox channel reaches it alone; the misuses are refused. Both ends are in this process (two networks), as two robots on one host are. */
#define _GNU_SOURCE 1
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "hal_host.h"
#include "hal_host_msg.h"
#include "gp/gp_wire.h"
#include "net_heard.h"

#define GCH "fleetsim/groups_test/done"
#define PLAIN "fleetsim/groups_test/other"
#define INBOX "fleetsim/groups_test/inbox/"

static char url[128];

static size_t done_from(uint8_t *buf, size_t cap, uint32_t sender)
{
    const gp_pse_done_t d = {sender, 17, 1, 0, 0.0, 0.0};
    const int len = gp_wire_encode_done(&d, buf, cap);
    assert_true(len > 0);
    return (size_t)len;
}

/* A network typed and grouped alike at every member. */
static hal_host_net_t *member(void)
{
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open(url, 64, 0, &n), 0);
    assert_int_equal(hal_host_net_expect_type(n, GCH, HAL_HOST_MSG_ROUND_COMPLETE), 0);
    assert_int_equal(hal_host_net_group_by_sender(n, GCH), 0);
    return n;
}

/* Publishes one datagram of each of `senders` on GCH every 50 ms until the receiver has
 * `want` of them (bounded: 3 s, datagrams may be lost and a group is joined a moment after
 * the wanted set changed); returns the senders heard as a bit set. */
static uint32_t exchange(hal_host_net_t *tx, hal_host_net_t *rx, const uint32_t *senders, int n, uint32_t want)
{
    uint32_t heard = 0;
    uint8_t b[64];
    for (int round = 0; round < 60 && heard != want; round++) {
        for (int i = 0; i < n; i++)
            assert_int_equal(hal_host_net_publish(tx, GCH, b, done_from(b, sizeof b, senders[i])), 0);
        heard |= net_heard_within(rx, 50, NULL);
    }
    /* A little longer: anything unwanted still on its way would show now. */
    for (int i = 0; i < 4; i++)
        heard |= net_heard_within(rx, 25, NULL);
    return heard;
}

static void test_only_wanted_senders_arrive(void **state)
{
    (void)state;
    hal_host_net_t *tx = member(), *rx = member();
    assert_int_equal(hal_host_net_subscribe(rx, GCH), 0);
    const uint32_t senders[] = {1, 2, 3};
    /* Before any wanted set: no group joined, nothing arrives. */
    assert_int_equal(exchange(tx, rx, senders, 3, 0), 0u);
    const uint8_t w2[1] = {0x04};
    assert_int_equal(hal_host_net_set_senders(rx, GCH, w2, 8), 0);
    assert_int_equal(exchange(tx, rx, senders, 3, 1u << 2), 1u << 2);
    hal_net_stats_t s;
    hal_host_net_get_stats(rx, &s);
    /* The kernel never handed the receiver an unwanted sender's datagram to drop: 1 and 3 sent
       as often as 2, and none of theirs arrived to be filtered. */
    assert_int_equal(s.rx_unwanted, 0);
    /* The set changes: 1 and 3 now, 2 no more. */
    const uint8_t w13[1] = {0x0A};
    assert_int_equal(hal_host_net_set_senders(rx, GCH, w13, 8), 0);
    assert_int_equal(exchange(tx, rx, senders, 3, (1u << 1) | (1u << 3)), (1u << 1) | (1u << 3));
    /* Every sender (NULL, n_ids 4): 0 .. 3. */
    assert_int_equal(hal_host_net_set_senders(rx, GCH, NULL, 4), 0);
    assert_int_equal(exchange(tx, rx, senders, 3, 0x0Eu), 0x0Eu);
    hal_host_net_get_stats(rx, &s);
    /* 2's group stays joined as a spare one after it fell out of the set (the transport keeps
       a few: a sender often comes back), so its datagrams arrive, and the filter drops them
       (none was queued: `heard` never had 2 after the change). */
    assert_true(s.rx_unwanted > 0);
    assert_int_equal(s.rx_dropped_malformed + s.rx_dropped_invalid, 0);
    hal_host_net_close(tx);
    hal_host_net_close(rx);
}

/* A channel not grouped still travels on the URL's group, to every subscriber. */
static void test_other_channels_stay_on_the_url_group(void **state)
{
    (void)state;
    hal_host_net_t *tx = member(), *rx = member();
    assert_int_equal(hal_host_net_subscribe(rx, PLAIN), 0);
    const char msg[] = "beacon";
    int got = 0;
    for (int i = 0; i < 60 && !got; i++) { /* bounded: 3 s */
        assert_int_equal(hal_host_net_publish(tx, PLAIN, msg, sizeof msg), 0);
        assert_int_equal(hal_host_net_wait(rx, 0, 50), 0);
        hal_net_rx_info_t info;
        char b[64];
        while (hal_host_net_receive(rx, 0, &info, b, sizeof b) == 0)
            got |= info.len == sizeof msg && strcmp(info.channel, PLAIN) == 0 && memcmp(b, msg, sizeof msg) == 0;
    }
    assert_true(got);
    hal_host_net_close(tx);
    hal_host_net_close(rx);
}

/* Inboxes: PREFIX<id> reaches robot id alone. Two receivers, robots 7 and 8, each subscribed
 * to its own channel; a datagram for 7 many times over: 7 hears it, 8's network is never handed
 * one (nothing queued, nothing dropped, nothing counted). */
static uint64_t handed(const hal_net_stats_t *s)
{
    return s->queue_fill + s->rx_messages + s->rx_dropped_small + s->rx_dropped_full + s->rx_dropped_invalid +
           s->rx_dropped_malformed + s->rx_own + s->rx_unwanted;
}

static void test_inbox_reaches_its_robot_alone(void **state)
{
    (void)state;
    hal_host_net_t *tx = member(), *r7 = member(), *r8 = member();
    assert_int_equal(hal_host_net_group_by_receiver(tx, INBOX), 0);
    assert_int_equal(hal_host_net_group_by_receiver(r7, INBOX), 0);
    assert_int_equal(hal_host_net_group_by_receiver(r8, INBOX), 0);
    assert_int_equal(hal_host_net_subscribe(r7, INBOX "7"), 0);
    assert_int_equal(hal_host_net_subscribe(r8, INBOX "8"), 0);
    const char msg[] = "for robot 7";
    int got = 0;
    for (int i = 0; i < 60 && !got; i++) { /* bounded: 3 s (a group is joined a moment later) */
        assert_int_equal(hal_host_net_publish(tx, INBOX "7", msg, sizeof msg), 0);
        assert_int_equal(hal_host_net_wait(r7, 0, 50), 0);
        hal_net_rx_info_t info;
        char b[64];
        while (hal_host_net_receive(r7, 0, &info, b, sizeof b) == 0)
            got |= info.len == sizeof msg && strcmp(info.channel, INBOX "7") == 0 && memcmp(b, msg, sizeof msg) == 0;
    }
    assert_true(got);
    for (int i = 0; i < 10; i++)
        assert_int_equal(hal_host_net_publish(tx, INBOX "7", msg, sizeof msg), 0);
    assert_int_equal(hal_host_net_wait(r8, 0, 200), 0);
    hal_net_stats_t s;
    hal_host_net_get_stats(r8, &s);
    assert_int_equal(handed(&s), 0);
    hal_host_net_close(tx);
    hal_host_net_close(r7);
    hal_host_net_close(r8);
}

static void test_refused(void **state)
{
    (void)state;
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open("memq://", 8, 0, &n), 0);
    assert_int_equal(hal_host_net_expect_type(n, GCH, HAL_HOST_MSG_ROUND_COMPLETE), 0);
    assert_int_equal(hal_host_net_group_by_sender(n, GCH), -ENOTSUP); /* not multicast */
    hal_host_net_close(n);
    n = member();
    assert_int_equal(hal_host_net_group_by_sender(n, PLAIN), -EINVAL);       /* untyped: no sender */
    assert_int_equal(hal_host_net_group_by_sender(n, "bad name"), -EINVAL);
    assert_int_equal(hal_host_net_group_by_sender(NULL, GCH), -EINVAL);
    assert_int_equal(hal_host_net_group_by_sender(n, GCH), 0); /* again: the same */
    assert_int_equal(hal_host_net_expect_type(n, PLAIN, HAL_HOST_MSG_ROUND_COMPLETE), 0);
    assert_int_equal(hal_host_net_group_by_sender(n, PLAIN), -ENOSPC); /* one grouped channel */
    for (int i = 0; i < 4; i++) { /* four prefixes, the same one again costs nothing */
        char p[64];
        snprintf(p, sizeof p, "%s%d/", INBOX, i);
        assert_int_equal(hal_host_net_group_by_receiver(n, p), 0);
        assert_int_equal(hal_host_net_group_by_receiver(n, p), 0);
    }
    assert_int_equal(hal_host_net_group_by_receiver(n, INBOX "x/"), -ENOSPC);
    assert_int_equal(hal_host_net_group_by_receiver(n, "bad prefix"), -EINVAL);
    assert_int_equal(hal_host_net_subscribe(n, GCH), 0);
    assert_int_equal(hal_host_net_group_by_sender(n, GCH), -EBUSY); /* too late: subscribed */
    assert_int_equal(hal_host_net_group_by_receiver(n, INBOX), -EBUSY);
    hal_host_net_close(n);
}

int main(void)
{
    /* Ports of our own (the URL's and one per sender after it), so that concurrent runs and
       other fleets on this host do not cross. */
    snprintf(url, sizeof url, "udpm://239.255.76.67:%u?ttl=0", 20000u + 2100u * (unsigned)(getpid() % 20));
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_only_wanted_senders_arrive),
        cmocka_unit_test(test_other_channels_stay_on_the_url_group),
        cmocka_unit_test(test_inbox_reaches_its_robot_alone),
        cmocka_unit_test(test_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
