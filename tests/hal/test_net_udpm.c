/* The udpm:// receiving side read by the host network itself (hal_host_net_udpm.h): LCM's
 * wire format parsed without reading past a datagram, whatever its bytes; and over a real
 * multicast socket, what LCM publishes arrives whole and in order however many wait at once
 * (the batches), while crafted datagrams on the same port (a long message's fragments on a
 * subscribed channel, another magic, a channel without its NUL) are counted, never queued.
 * Where the socket's kernel buffer holds the queue's bytes, no receiver thread runs from the
 * first wait on: the waiting thread takes what arrives (inline); else the thread does, and both
 * deliver alike. */
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
#include <dirent.h>
#include <sys/socket.h>
#include <unistd.h>
#include <cmocka.h>

#include "hal_host.h"
#include "hal_host_net_udpm.h"

#define CH "fleetsim/udpm_test/data"

static char url[128];
static unsigned port;

/* ---- the parser ------------------------------------------------------------------------- */
static void test_short_message(void **state)
{
    (void)state;
    const uint8_t d[] = {'L', 'C', '0', '2', 0, 0, 0, 9, 'a', '/', 'b', 0, 1, 2, 3};
    const udpm_datagram_t g = udpm_parse(d, sizeof d);
    assert_int_equal(g.kind, UDPM_MESSAGE);
    assert_string_equal(g.channel, "a/b");
    assert_ptr_equal(g.payload, d + 12);
    assert_int_equal(g.len, 3);
    /* An empty payload is a message too. */
    const udpm_datagram_t e = udpm_parse(d, 12);
    assert_int_equal(e.kind, UDPM_MESSAGE);
    assert_int_equal(e.len, 0);
}

static void test_fragments(void **state)
{
    (void)state;
    uint8_t d[32] = {'L', 'C', '0', '3', 0, 0, 0, 1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 'c', 'h', 0, 7};
    udpm_datagram_t g = udpm_parse(d, 24);
    assert_int_equal(g.kind, UDPM_TOO_LONG);
    assert_string_equal(g.channel, "ch");
    d[17] = 1; /* a later fragment: names no channel */
    g = udpm_parse(d, 24);
    assert_int_equal(g.kind, UDPM_IGNORED);
    assert_null(g.channel);
    d[17] = 0;
    assert_int_equal(udpm_parse(d, 19).kind, UDPM_INVALID); /* its header cut short */
    assert_int_equal(udpm_parse(d, 22).kind, UDPM_INVALID); /* the channel's NUL cut off */
}

static void test_not_lcm(void **state)
{
    (void)state;
    uint8_t d[16] = {'L', 'C', '0', '2', 0, 0, 0, 1, 'x', 'y', 'z'};
    assert_int_equal(udpm_parse(NULL, 16).kind, UDPM_INVALID);
    assert_int_equal(udpm_parse(d, 7).kind, UDPM_INVALID);     /* shorter than the header */
    assert_int_equal(udpm_parse(d, 8).kind, UDPM_INVALID);     /* no channel at all */
    assert_int_equal(udpm_parse(d, 11).kind, UDPM_INVALID);    /* no NUL within the datagram */
    d[8] = 0;
    assert_int_equal(udpm_parse(d, 16).kind, UDPM_INVALID);    /* an empty channel name */
    d[8] = 'x';
    d[3] = '4';
    assert_int_equal(udpm_parse(d, 16).kind, UDPM_INVALID);    /* another magic */
}

/* Every length of every prefix of a valid datagram, and every byte flipped: never a read past
   the end (ASan says), and a message's parts always within the datagram. */
static void test_every_cut_and_flip(void **state)
{
    (void)state;
    uint8_t d[40] = {'L', 'C', '0', '2', 0, 0, 0, 3, 'f', '/', 'g', 0};
    for (size_t i = 12; i < sizeof d; i++)
        d[i] = (uint8_t)i;
    for (size_t flip = 0; flip <= sizeof d; flip++)
        for (size_t len = 0; len <= sizeof d; len++) {
            uint8_t c[40];
            memcpy(c, d, sizeof c);
            if (flip < sizeof d)
                c[flip] ^= 0xFF;
            const udpm_datagram_t g = udpm_parse(c, len);
            if (g.kind == UDPM_MESSAGE) {
                assert_true(g.payload >= c && g.payload + g.len == c + len);
                assert_true((const uint8_t *)g.channel > c && (const uint8_t *)g.channel < g.payload);
            }
        }
}

/* ---- over a socket ----------------------------------------------------------------------- */
/* What cannot be a udpm group or port is refused, said, and nothing is left open. */
static void test_open_refused(void **state)
{
    (void)state;
    udpm_rx_t *r = (udpm_rx_t *)(uintptr_t)1;
    assert_int_equal(udpm_rx_open(0x7F000001u, port, 0, &r), -EINVAL); /* 127.0.0.1 */
    assert_null(r);
    assert_int_equal(udpm_rx_open(0xEFFF4C47u, 0, 0, &r), -EINVAL);
    assert_int_equal(udpm_rx_open(0xEFFF4C47u, 70000, 0, &r), -EINVAL);
    assert_int_equal(udpm_rx_open(0xEFFF4C47u, port, -1, &r), -EINVAL);
    assert_int_equal(udpm_rx_open(0xEFFF4C47u, port, 0, NULL), -EINVAL);
    assert_int_equal(udpm_rx_handle(NULL, 0, NULL, NULL), -EINVAL);
    assert_int_equal(udpm_rx_drain(NULL, NULL, NULL), -EINVAL);
    assert_int_equal(udpm_rx_fd(NULL), -1);
    udpm_rx_close(NULL);
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open("udpm://127.0.0.1:7667?ttl=0", 4, 0, &n), -EIO);
    assert_null(n);
}

static hal_host_net_t *open_rx(void)
{
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open(url, 256, 4u << 20, &n), 0); /* 40 MTUs and more */
    assert_int_equal(hal_host_net_subscribe(n, CH), 0);
    return n;
}

/* Receives until `want` messages came or 3 s passed; their first bytes (the index) into seen. */
static uint32_t receive_all(hal_host_net_t *n, uint32_t want, uint8_t *seen)
{
    static uint8_t b[HAL_NET_MTU_BYTES];
    uint32_t got = 0;
    for (int i = 0; i < 60 && got < want; i++) {
        assert_int_equal(hal_host_net_wait(n, 0, 50), 0);
        hal_net_rx_info_t info;
        while (got < want && hal_host_net_receive(n, 0, &info, b, sizeof b) == 0) {
            assert_string_equal(info.channel, CH);
            seen[got++] = b[0];
        }
    }
    return got;
}

/* Forty messages of up to the network's MTU published at once: more than a batch waits on the
   socket; every one arrives, whole, in the order sent. */
static void test_many_at_once_in_order(void **state)
{
    (void)state;
    hal_host_net_t *rx = open_rx(), *tx = NULL;
    assert_int_equal(hal_host_net_open(url, 4, 0, &tx), 0);
    static uint8_t m[HAL_NET_MTU_BYTES];
    enum { N = 40 };
    for (uint32_t i = 0; i < N; i++) {
        memset(m, (int)i, sizeof m);
        const size_t len = i % 2 == 0 ? sizeof m : 100u + i;
        assert_int_equal(hal_host_net_publish(tx, CH, m, len), 0);
    }
    uint8_t seen[N];
    const uint32_t got = receive_all(rx, N, seen);
    hal_net_stats_t s;
    hal_host_net_get_stats(rx, &s);
    if (got != N)
        printf("# %u of %u: queue drops %llu, invalid %llu\n", got, N, (unsigned long long)s.rx_dropped_full,
               (unsigned long long)s.rx_dropped_invalid);
    assert_int_equal(got, N);
    for (uint32_t i = 0; i < N; i++)
        assert_int_equal(seen[i], i);
    assert_int_equal(s.rx_messages, N);
    assert_int_equal(s.rx_dropped_invalid + s.rx_dropped_full, 0);
    hal_host_net_close(tx);
    hal_host_net_close(rx);
}

/* Whether this process has a thread named "net-rx" (hal_host_net_rx.c's receiver). */
static int receiver_thread_runs(void)
{
    DIR *d = opendir("/proc/self/task");
    assert_non_null(d);
    int found = 0;
    for (struct dirent *e; !found && (e = readdir(d)) != NULL;) {
        char path[300], name[32] = "";
        snprintf(path, sizeof path, "/proc/self/task/%s/comm", e->d_name);
        FILE *f = fopen(path, "r");
        if (f == NULL)
            continue;
        found = fgets(name, sizeof name, f) != NULL && strncmp(name, "net-rx", 6) == 0;
        fclose(f);
    }
    closedir(d);
    return found;
}

/* A queue of queue_bytes: 4 messages of the MTU and 20 small ones published at once arrive
   whole and in order (within the kernel's default buffer: the inline case's queue). */
static void mixed_in_order(size_t queue_bytes, int want_thread)
{
    hal_host_net_t *rx = NULL, *tx = NULL;
    assert_int_equal(hal_host_net_open(url, 256, queue_bytes, &rx), 0);
    assert_false(receiver_thread_runs());
    assert_int_equal(hal_host_net_subscribe(rx, CH), 0);
    for (int i = 0; i < 100 && !receiver_thread_runs(); i++) /* it names itself */
        usleep(10000);
    assert_true(receiver_thread_runs()); /* until the first wait, in both cases */
    assert_int_equal(hal_host_net_wait(rx, 0, 0), 0);
    assert_int_equal(receiver_thread_runs(), want_thread);
    assert_int_equal(hal_host_net_open(url, 4, 0, &tx), 0);
    static uint8_t m[HAL_NET_MTU_BYTES];
    enum { N = 24 };
    for (uint32_t i = 0; i < N; i++) {
        memset(m, (int)i, sizeof m);
        assert_int_equal(hal_host_net_publish(tx, CH, m, i % 6 == 0 ? sizeof m : 100u + i), 0);
    }
    uint8_t seen[N];
    assert_int_equal(receive_all(rx, N, seen), N);
    for (uint32_t i = 0; i < N; i++)
        assert_int_equal(seen[i], i);
    hal_net_stats_t s;
    hal_host_net_get_stats(rx, &s);
    assert_int_equal(s.rx_messages, N);
    assert_int_equal(s.rx_dropped_invalid + s.rx_dropped_full, 0);
    hal_host_net_close(tx);
    hal_host_net_close(rx);
    assert_false(receiver_thread_runs());
}

/* A queue smaller than the socket's kernel buffer (every Linux default holds 128 KB): inline
   from the first wait on. */
static void test_inline_when_the_kernel_buffers_the_queue(void **state)
{
    (void)state;
    mixed_in_order((size_t)128u << 10, 0);
}

/* A queue larger than any buffer the kernel grants here (32 MB): the receiver thread. */
static void test_a_thread_when_the_queue_is_larger(void **state)
{
    (void)state;
    mixed_in_order((size_t)64u << 20, 1);
}

static void send_raw(int fd, const void *d, size_t len)
{
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    assert_int_equal(inet_pton(AF_INET, "239.255.76.71", &a.sin_addr), 1);
    assert_int_equal(sendto(fd, d, len, 0, (struct sockaddr *)&a, sizeof a), (ssize_t)len);
}

/* Crafted datagrams on the group's port: counted invalid when they claim a channel of ours or
   are not LCM's, ignored when they are a long message's later fragment or another channel's;
   the message after them arrives. */
static void test_crafted_datagrams_counted(void **state)
{
    (void)state;
    hal_host_net_t *rx = open_rx();
    const int tx = socket(AF_INET, SOCK_DGRAM, 0);
    assert_true(tx >= 0);
    const unsigned char ttl = 0, loop = 1;
    assert_int_equal(setsockopt(tx, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl), 0);
    assert_int_equal(setsockopt(tx, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop), 0);
    uint8_t d[128] = {'L', 'C', '0', '3', 0, 0, 0, 1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2};
    memcpy(d + 20, CH, sizeof CH);
    send_raw(tx, d, 20 + sizeof CH + 8); /* fragment 0 of a long message on our channel: invalid */
    memcpy(d + 20, "other/channel", 14);
    send_raw(tx, d, 20 + 14 + 8);        /* on another channel: LCM's business */
    d[17] = 1;
    send_raw(tx, d, 40);                 /* a later fragment: ignored */
    send_raw(tx, "garbage!", 8);         /* not LCM's: invalid */
    /* (A short message whose channel lacks its NUL never gets here: the kernel filter, given
       the channels received, drops it; test_not_lcm has the parser's side.) */
    uint8_t s[64] = {'L', 'C', '0', '2', 0, 0, 0, 2};
    memcpy(s + 8, CH, sizeof CH);
    s[8 + sizeof CH] = 42;
    send_raw(tx, s, 8 + sizeof CH + 1);  /* a valid one */
    uint8_t seen[1];
    assert_int_equal(receive_all(rx, 1, seen), 1);
    assert_int_equal(seen[0], 42);
    hal_net_stats_t st;
    hal_host_net_get_stats(rx, &st);
    assert_int_equal(st.rx_dropped_invalid, 2);
    assert_int_equal(st.rx_messages, 1);
    close(tx);
    hal_host_net_close(rx);
}

int main(void)
{
    /* A group and ports of our own, so that concurrent runs and fleets on this host do not
       cross. */
    port = 13000u + 2u * (unsigned)(getpid() % 500);
    snprintf(url, sizeof url, "udpm://239.255.76.71:%u?ttl=0&recv_buf_size=8388608", port);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_short_message),
        cmocka_unit_test(test_fragments),
        cmocka_unit_test(test_not_lcm),
        cmocka_unit_test(test_every_cut_and_flip),
        cmocka_unit_test(test_open_refused),
        cmocka_unit_test(test_many_at_once_in_order),
        cmocka_unit_test(test_crafted_datagrams_counted),
        cmocka_unit_test(test_inline_when_the_kernel_buffers_the_queue),
        cmocka_unit_test(test_a_thread_when_the_queue_is_larger),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
