/* The kernel filter on the LCM socket (hal_host_net_kfilter.h), over real udpm:// sockets on
 * this host: on the URL's one group, a typed channel's unwanted senders are dropped by the
 * kernel, before the network sees them (no rx_unwanted: hal_host_net.c's check on arrival
 * would count each one it dropped), the wanted set can change, other channels pass, and two
 * robots in one process each filter their own socket; given the channels received, the
 * program drops every other channel (on a socket of the test's own, datagram by datagram); the
 * eBPF program decides as the classic one through changing sets, with no new program each. */
#define _GNU_SOURCE 1
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>
#include <cmocka.h>

#include "hal_host.h"
#include "hal_host_msg.h"
#include "hal_host_net_kfilter.h"
#include "gp/gp_wire.h"
#include "net_heard.h"

#define TCH "fleetsim/kfilter_test/done"
#define PLAIN "fleetsim/kfilter_test/other"

static char url[128];

static hal_host_net_t *member(void)
{
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open(url, 64, 0, &n), 0);
    assert_int_equal(hal_host_net_expect_type(n, TCH, HAL_HOST_MSG_ROUND_COMPLETE), 0);
    assert_int_equal(hal_host_net_subscribe(n, TCH), 0);
    assert_int_equal(hal_host_net_subscribe(n, PLAIN), 0);
    return n;
}

/* One RoundComplete of each of senders 1, 2 and 3 and one datagram on PLAIN every 50 ms until
 * every receiver has heard what it wants (bounded: 3 s), then a little longer; the bit sets
 * heard into out. */
static void exchange(hal_host_net_t *tx, hal_host_net_t **rx, const uint32_t *want, uint32_t *out, int n_rx)
{
    memset(out, 0, sizeof *out * (size_t)n_rx);
    uint8_t b[64];
    for (int round = 0, done = 0; round < 60 && !done; round++) {
        for (uint32_t s = 1; s <= 3; s++) {
            const gp_pse_done_t d = {s, 17, 1, 0, 0.0, 0.0};
            const int len = gp_wire_encode_done(&d, b, sizeof b);
            assert_true(len > 0);
            assert_int_equal(hal_host_net_publish(tx, TCH, b, (size_t)len), 0);
        }
        assert_int_equal(hal_host_net_publish(tx, PLAIN, "x", 1), 0);
        done = 1;
        for (int i = 0; i < n_rx; i++) {
            out[i] |= net_heard_within(rx[i], 50 / n_rx, PLAIN);
            done &= out[i] == want[i];
        }
    }
    for (int k = 0; k < 4; k++) /* anything unwanted still on its way would show now */
        for (int i = 0; i < n_rx; i++)
            out[i] |= net_heard_within(rx[i], 25, PLAIN);
}

static void test_kernel_drops_unwanted_senders(void **state)
{
    (void)state;
    hal_host_net_t *tx = member(), *rx = member();
    const uint32_t all = 0x0Eu | 1u << 31;
    uint32_t heard;
    exchange(tx, &rx, &all, &heard, 1);
    assert_int_equal(heard, all); /* no filter yet: everyone */
    const uint8_t w2[1] = {0x04};
    assert_int_equal(hal_host_net_set_senders(rx, TCH, w2, 8), 0);
    hal_net_stats_t before, after;
    hal_host_net_get_stats(rx, &before);
    const uint32_t want2 = 1u << 2 | 1u << 31;
    exchange(tx, &rx, &want2, &heard, 1);
    assert_int_equal(heard, want2);
    hal_host_net_get_stats(rx, &after);
    /* 1 and 3 sent as often as 2: none of theirs reached the network to be dropped there. */
    assert_int_equal(after.rx_unwanted, before.rx_unwanted);
    const uint8_t w13[1] = {0x0A};
    assert_int_equal(hal_host_net_set_senders(rx, TCH, w13, 8), 0);
    const uint32_t want13 = 1u << 1 | 1u << 3 | 1u << 31;
    exchange(tx, &rx, &want13, &heard, 1);
    assert_int_equal(heard, want13);
    assert_int_equal(hal_host_net_set_senders(rx, TCH, NULL, 4), 0); /* every sender again */
    exchange(tx, &rx, &all, &heard, 1);
    assert_int_equal(heard, all);
    hal_host_net_get_stats(rx, &after);
    assert_int_equal(after.rx_unwanted, before.rx_unwanted);
    assert_int_equal(after.rx_dropped_malformed + after.rx_dropped_invalid, 0);
    hal_host_net_close(tx);
    hal_host_net_close(rx);
}

/* Two robots of one process on one URL: each filter is on its own robot's socket. */
static void test_each_robot_filters_its_own_socket(void **state)
{
    (void)state;
    hal_host_net_t *tx = member(), *rx[2] = {member(), member()};
    const uint8_t w1[1] = {0x02}, w3[1] = {0x08};
    assert_int_equal(hal_host_net_set_senders(rx[0], TCH, w1, 8), 0);
    assert_int_equal(hal_host_net_set_senders(rx[1], TCH, w3, 8), 0);
    const uint32_t want[2] = {1u << 1 | 1u << 31, 1u << 3 | 1u << 31};
    uint32_t heard[2];
    exchange(tx, rx, want, heard, 2);
    assert_int_equal(heard[0], want[0]);
    assert_int_equal(heard[1], want[1]);
    for (int i = 0; i < 2; i++) {
        hal_net_stats_t s;
        hal_host_net_get_stats(rx[i], &s);
        assert_int_equal(s.rx_unwanted, 0);
        hal_host_net_close(rx[i]);
    }
    hal_host_net_close(tx);
}

/* An LCM short message on `channel` (its payload: an 8-byte fingerprint, then `sender`) sent
   to fd's address: 1 when it came through fd's filter, 0 when it did not. */
static int passes(int tx, int fd, const char *channel, uint32_t sender)
{
    uint8_t d[128] = {'L', 'C', '0', '2', 0, 0, 0, 1};
    const size_t cl = strlen(channel) + 1u;
    memcpy(d + 8, channel, cl);
    uint8_t *pl = d + 8 + cl;
    memset(pl, 0xAB, 8);
    pl[8] = (uint8_t)(sender >> 24), pl[9] = (uint8_t)(sender >> 16), pl[10] = (uint8_t)(sender >> 8);
    pl[11] = (uint8_t)sender;
    struct sockaddr_in a;
    socklen_t al = sizeof a;
    assert_int_equal(getsockname(fd, (struct sockaddr *)&a, &al), 0);
    assert_int_equal(sendto(tx, d, 8 + cl + 12, 0, (struct sockaddr *)&a, al), (ssize_t)(8 + cl + 12));
    struct pollfd p = {.fd = fd, .events = POLLIN};
    if (poll(&p, 1, 100) != 1) /* loopback delivers at once: 100 ms is plenty */
        return 0;
    uint8_t in[128];
    return recv(fd, in, sizeof in, 0) == (ssize_t)(8 + cl + 12);
}

/* Given the channels received, the program drops every other channel's short messages in the
   kernel (another robot's own channels over one group), keeps a rule's sender check, and passes
   what is not an LCM short message; without them, every channel passes as before. */
static void test_channels_not_received_are_dropped(void **state)
{
    (void)state;
    const int fd = socket(AF_INET, SOCK_DGRAM, 0), tx = socket(AF_INET, SOCK_DGRAM, 0);
    assert_true(fd >= 0 && tx >= 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    assert_int_equal(bind(fd, (struct sockaddr *)&a, sizeof a), 0);
    kfilter_rule_t r[1];
    memset(r, 0, sizeof r);
    snprintf(r[0].channel, sizeof r[0].channel, "%s", TCH);
    r[0].wanted[0] = 0x04; /* sender 2 */
    char received[3][HAL_NET_CHANNEL_MAX] = {TCH, "fleetsim/kfilter_test/resend/7", PLAIN};
    assert_int_equal(hal_host_net_kfilter_attach(fd, r, 1, NULL, 0), 0);
    assert_true(passes(tx, fd, "fleetsim/kfilter_test/resend/8", 1));
    assert_int_equal(hal_host_net_kfilter_attach(fd, r, 1, (const char (*)[HAL_NET_CHANNEL_MAX])received, 3), 0);
    assert_true(passes(tx, fd, "fleetsim/kfilter_test/resend/7", 1));
    assert_false(passes(tx, fd, "fleetsim/kfilter_test/resend/8", 1));
    assert_false(passes(tx, fd, "fleetsim/kfilter_test/resend/70", 1));
    assert_false(passes(tx, fd, "fleetsim/kfilter_test/resend/", 1));
    assert_true(passes(tx, fd, PLAIN, 5));
    assert_true(passes(tx, fd, TCH, 2));
    assert_false(passes(tx, fd, TCH, 3)); /* the rule's sender check still */
    /* Not an LCM short message (a fragment's magic): passes. */
    const uint8_t frag[16] = {'L', 'C', '0', '3'};
    socklen_t al = sizeof a;
    assert_int_equal(getsockname(fd, (struct sockaddr *)&a, &al), 0);
    assert_int_equal(sendto(tx, frag, sizeof frag, 0, (struct sockaddr *)&a, al), (ssize_t)sizeof frag);
    struct pollfd p = {.fd = fd, .events = POLLIN};
    assert_int_equal(poll(&p, 1, 1000), 1);
    close(fd);
    close(tx);
}

/* A socket's filter kept by hal_host_net_kfilter_t, eBPF (ebpf 1) or classic programs (0): the
   same decisions, datagram by datagram, through the wanted set's changes; over eBPF a change is
   a map update and the program stays. */
static void filter_follows_the_sets(int ebpf)
{
    const int fd = socket(AF_INET, SOCK_DGRAM, 0), tx = socket(AF_INET, SOCK_DGRAM, 0);
    assert_true(fd >= 0 && tx >= 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    assert_int_equal(bind(fd, (struct sockaddr *)&a, sizeof a), 0);
    hal_host_net_kfilter_t k;
    hal_host_net_kfilter_init(&k, fd, ebpf);
    assert_true(passes(tx, fd, TCH, 9)); /* nothing on the socket yet */
    assert_int_equal(hal_host_net_kfilter_receive(&k, TCH), 0);
    assert_int_equal(hal_host_net_kfilter_receive(&k, PLAIN), 0);
    if (ebpf && geteuid() == 0)
        assert_int_equal(k.ebpf, 1); /* root may use bpf(): the eBPF program is on */
    if (!ebpf)
        assert_int_equal(k.ebpf, -1);
    printf("# kernel filter: %s programs\n", k.ebpf == 1 ? "eBPF" : "classic");
    assert_true(passes(tx, fd, PLAIN, 5));
    assert_false(passes(tx, fd, "fleetsim/kfilter_test/resend/8", 1)); /* not received */
    uint8_t w[HAL_HOST_NET_SENDER_BYTES];
    memset(w, 0, sizeof w);
    w[0] = 0x04; /* sender 2 */
    assert_int_equal(hal_host_net_kfilter_senders(&k, TCH, w), 0);
    const uint32_t programs = k.programs;
    assert_true(passes(tx, fd, TCH, 2));
    assert_false(passes(tx, fd, TCH, 3));
    assert_false(passes(tx, fd, TCH, (uint32_t)BOARD_MAX_FLEET)); /* beyond the fleet */
    assert_true(passes(tx, fd, PLAIN, 3));
    /* Sets that change: ids over the whole fleet, the highest included. */
    const uint32_t ids[4] = {0u, 77u, 130u, (uint32_t)BOARD_MAX_FLEET - 1u};
    for (uint32_t i = 0; i < 4; i++) {
        memset(w, 0, sizeof w);
        w[ids[i] / 8u] = (uint8_t)(1u << (ids[i] % 8u));
        assert_int_equal(hal_host_net_kfilter_senders(&k, TCH, w), 0);
        assert_true(passes(tx, fd, TCH, ids[i]));
        assert_false(passes(tx, fd, TCH, ids[i] ^ 1u));
        assert_false(passes(tx, fd, TCH, 2));
    }
    if (k.ebpf == 1) {
        assert_int_equal(k.programs, programs); /* four new sets, no new program */
        assert_int_equal(k.sets, 4);
    } else {
        assert_int_equal(k.programs, programs + 4u);
    }
    assert_int_equal(hal_host_net_kfilter_senders(&k, TCH, NULL), 0); /* every sender again */
    assert_true(passes(tx, fd, TCH, 3));
    assert_true(passes(tx, fd, TCH, (uint32_t)BOARD_MAX_FLEET));
    hal_host_net_kfilter_close(&k);
    close(fd);
    close(tx);
}

static void test_ebpf_filter_follows_the_sets(void **state)
{
    (void)state;
    filter_follows_the_sets(1);
}

static void test_classic_filter_follows_the_sets(void **state)
{
    (void)state;
    filter_follows_the_sets(0);
}

static void test_refused(void **state)
{
    (void)state;
    kfilter_rule_t r[KFILTER_MAX_RULES + 1];
    memset(r, 0, sizeof r);
    for (uint32_t i = 0; i <= KFILTER_MAX_RULES; i++)
        snprintf(r[i].channel, sizeof r[i].channel, "fleetsim/kfilter_test/c%u", i);
    assert_int_equal(hal_host_net_kfilter_attach(-1, r, 1, NULL, 0), -EINVAL);
    assert_int_equal(hal_host_net_kfilter_attach(0, NULL, 1, NULL, 0), -EINVAL);
    assert_int_equal(hal_host_net_kfilter_attach(0, r, KFILTER_MAX_RULES + 1, NULL, 0), -EINVAL);
    /* Not a socket: the kernel's refusal comes back. */
    assert_int_equal(hal_host_net_kfilter_attach(STDIN_FILENO, r, 1, NULL, 0), -ENOTSOCK);
}

int main(void)
{
    /* A group and ports of our own, so that concurrent runs and fleets on this host do not
       cross. */
    snprintf(url, sizeof url, "udpm://239.255.76.69:%u?ttl=0", 12000u + 4u * (unsigned)(getpid() % 500));
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kernel_drops_unwanted_senders),
        cmocka_unit_test(test_each_robot_filters_its_own_socket),
        cmocka_unit_test(test_channels_not_received_are_dropped),
        cmocka_unit_test(test_ebpf_filter_follows_the_sets),
        cmocka_unit_test(test_classic_filter_follows_the_sets),
        cmocka_unit_test(test_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
