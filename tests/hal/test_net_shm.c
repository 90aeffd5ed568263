/* The host network over shared memory (hal/host/hal_host_net_shm.c, its rings
 * hal_host_net_shm_seg.c): robots of one host deliver every datagram of a subscribed channel
 * whole to the others (never to the sender) and nothing of a channel they did not subscribe
 * to; a robot that wants some senders only is not even handed the others' (its rx_unwanted
 * stays 0: the writer marks what each reader wants); a reader its writer lapped gets the
 * writer's current lap whole and counts the loss with the queue's drops; a robot asleep in a
 * wait is woken by the first datagram it wants; a keyed fleet's datagrams go without the
 * trailer; bad names and a segment of another layout are refused with the reason, and one
 * another process scribbled on is read within its bounds; two real
 * processes exchange datagrams. The ring's checked read (lap, padding, a header out of bounds)
 * is tested on a ring of its own. The fleet over shm:// as real processes: tests/fleet. */
#define _GNU_SOURCE 1
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include <cmocka.h>

#include "hal/hal.h"
#include "hal_host.h"
#include "hal_host_msg.h"
#include "hal_host_net_shm_seg.h"
#include "gp/gp_wire.h"
#include "net_heard.h"

#define CH "fleetsim/9/state"
#define FCH "fleetsim/9/done"
#define WAIT_MS 20000 /* a bound, never reached when the transport works */

static char g_name[64];

/* A segment name of this test alone; removed after it. */
static int setup(void **st)
{
    (void)st;
    static int k;
    snprintf(g_name, sizeof g_name, "test-%d-%d", (int)getpid(), k++);
    return 0;
}

static int teardown(void **st)
{
    (void)st;
    char path[96];
    snprintf(path, sizeof path, "/fleetsim.%s", g_name);
    (void)shm_unlink(path);
    return 0;
}

static hal_host_net_t *open_robot(void)
{
    char url[96];
    snprintf(url, sizeof url, "shm://%s", g_name);
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open(url, 256, 0, &n), 0);
    return n;
}

static hal_net_stats_t stats_of(hal_host_net_t *n)
{
    hal_net_stats_t s;
    hal_host_net_get_stats(n, &s);
    return s;
}

static void fill(uint8_t *b, size_t len, unsigned seed)
{
    for (size_t i = 0; i < len; i++)
        b[i] = (uint8_t)(i * 13u + seed * 7u + 1u);
}

/* Receives one datagram into buf, waiting up to WAIT_MS; its length, or -1 when none came. */
static long receive_one(hal_host_net_t *n, hal_net_rx_info_t *info, uint8_t *buf, size_t cap)
{
    struct timespec t0, t;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (;;) {
        if (hal_host_net_receive(n, 0, info, buf, cap) == 0)
            return (long)info->len;
        clock_gettime(CLOCK_MONOTONIC, &t);
        const long ms = (t.tv_sec - t0.tv_sec) * 1000L + (t.tv_nsec - t0.tv_nsec) / 1000000L;
        if (ms >= WAIT_MS)
            return -1;
        assert_int_equal(hal_host_net_wait(n, 0, (int)(WAIT_MS - ms)), 0);
    }
}

static void test_three_robots_exchange(void **st)
{
    (void)st;
    hal_host_net_t *net[3];
    for (int i = 0; i < 3; i++) {
        net[i] = open_robot();
        assert_int_equal(hal_host_net_subscribe(net[i], CH), 0);
    }
    static uint8_t msg[HAL_NET_MTU_BYTES], buf[HAL_NET_MTU_BYTES];
    const size_t lens[] = {HAL_NET_MTU_BYTES, 1, 0, SHM_SMALL_MAX, SHM_SMALL_MAX + 1u};
    for (int from = 0; from < 3; from++)
        for (size_t k = 0; k < sizeof lens / sizeof lens[0]; k++) {
            fill(msg, lens[k], (unsigned)(from * 10 + (int)k));
            assert_int_equal(hal_host_net_publish(net[from], CH, msg, lens[k]), 0);
            for (int i = 0; i < 3; i++) {
                if (i == from)
                    continue;
                hal_net_rx_info_t info;
                assert_int_equal(receive_one(net[i], &info, buf, sizeof buf), (long)lens[k]);
                assert_string_equal(info.channel, CH);
                assert_memory_equal(buf, msg, lens[k]);
            }
        }
    for (int i = 0; i < 3; i++) {
        hal_net_rx_info_t info;
        assert_int_equal(hal_host_net_receive(net[i], 0, &info, buf, sizeof buf), -EAGAIN); /* not its own */
        assert_int_equal(stats_of(net[i]).rx_messages, 10u);
        hal_host_net_close(net[i]);
    }
}

static void test_unsubscribed_channel_never_arrives(void **st)
{
    (void)st;
    hal_host_net_t *a = open_robot(), *b = open_robot();
    assert_int_equal(hal_host_net_subscribe(a, CH), 0);
    assert_int_equal(hal_host_net_subscribe(b, "fleetsim/9/other"), 0); /* b listens elsewhere */
    const uint8_t msg[100] = {1};
    for (int k = 0; k < 20; k++)
        assert_int_equal(hal_host_net_publish(a, "fleetsim/9/other2", msg, sizeof msg), 0);
    assert_int_equal(hal_host_net_publish(a, "fleetsim/9/other", msg, sizeof msg), 0);
    uint8_t buf[128];
    hal_net_rx_info_t info;
    assert_int_equal(receive_one(b, &info, buf, sizeof buf), 100);
    assert_string_equal(info.channel, "fleetsim/9/other");
    assert_int_equal(stats_of(b).rx_arrived_bytes, 100u); /* the 20 others never reached it */
    hal_host_net_close(a);
    hal_host_net_close(b);
}

/* Robot 2 publishes as senders 2 and 17, then robot 1 as 1, the marker; robot 0 counts per
 * sender what it took by the marker and after it (two writers' rings: no order between them). */
static void round_of_dones(hal_host_net_t **net, int *got)
{
    net_publish_done(net[2], FCH, 2);
    net_publish_done(net[2], FCH, 17);
    net_publish_done(net[1], FCH, 1);
    uint8_t b[64];
    hal_net_rx_info_t info;
    for (int marker = 0; !marker || hal_host_net_receive(net[0], 0, &info, b, sizeof b) == 0;) {
        if (!marker) /* every writer's was written before the marker: all there with it */
            assert_true(receive_one(net[0], &info, b, sizeof b) > 0);
        gp_pse_done_t d;
        assert_int_equal(gp_wire_decode_done(b, info.len, &d), 0);
        assert_true(d.sender < 32);
        got[d.sender]++;
        marker |= d.sender == 1;
    }
}

static void test_senders_filtered_at_the_writer(void **st)
{
    (void)st;
    hal_host_net_t *net[3];
    for (int i = 0; i < 3; i++) {
        net[i] = open_robot();
        assert_int_equal(hal_host_net_expect_type(net[i], FCH, HAL_HOST_MSG_ROUND_COMPLETE), 0);
        assert_int_equal(hal_host_net_subscribe(net[i], FCH), 0);
    }
    uint8_t only1[4] = {0x02, 0, 0, 0};
    assert_int_equal(hal_host_net_set_senders(net[0], FCH, only1, 32), 0);
    int got[32] = {0};
    round_of_dones(net, got);
    assert_int_equal(got[1], 1);
    assert_int_equal(got[2] + got[17], 0);
    assert_int_equal(stats_of(net[0]).rx_unwanted, 0u); /* never handed over at all */
    assert_int_equal(hal_host_net_set_senders(net[0], FCH, NULL, 0), 0);
    memset(got, 0, sizeof got);
    round_of_dones(net, got);
    assert_int_equal(got[1] + got[2] + got[17], 3);
    for (int i = 0; i < 3; i++)
        hal_host_net_close(net[i]);
}

static void test_lapped_reader_resumes_and_counts(void **st)
{
    (void)st;
    hal_host_net_t *w = open_robot(), *r = open_robot();
    assert_int_equal(hal_host_net_subscribe(r, CH), 0);
    assert_int_equal(hal_host_net_wait(r, 0, 0), 0); /* inline from here: nothing reads but us */
    static uint8_t msg[50000], buf[HAL_NET_MTU_BYTES];
    const int count = (int)(3u * SHM_RING_BULK / sizeof msg); /* three laps */
    for (int k = 0; k < count; k++) {
        fill(msg, sizeof msg, (unsigned)k);
        memcpy(msg, &k, sizeof k);
        assert_int_equal(hal_host_net_publish(w, CH, msg, sizeof msg), 0);
    }
    int got = 0, last = -1;
    hal_net_rx_info_t info;
    while (hal_host_net_receive(r, 0, &info, buf, sizeof buf) == 0) {
        int k;
        memcpy(&k, buf, sizeof k);
        assert_true(k > last && k < count); /* in order, each whole */
        fill(msg, sizeof msg, (unsigned)k);
        memcpy(msg, &k, sizeof k);
        assert_memory_equal(buf, msg, sizeof msg);
        last = k;
        got++;
    }
    assert_int_equal(last, count - 1);                     /* the newest arrived */
    assert_true(got > 0 && got <= (int)(SHM_RING_BULK / sizeof msg));
    assert_true(stats_of(r).rx_dropped_full >= 1u);       /* and the loss is counted */
    const uint64_t drops = stats_of(r).rx_dropped_full;
    fill(msg, 100, 5);
    assert_int_equal(hal_host_net_publish(w, CH, msg, 100), 0); /* then delivery goes on */
    assert_int_equal(receive_one(r, &info, buf, sizeof buf), 100);
    assert_memory_equal(buf, msg, 100);
    assert_int_equal(stats_of(r).rx_dropped_full, drops);
    hal_host_net_close(w);
    hal_host_net_close(r);
}

typedef struct {
    hal_host_net_t *n;
    int queued;
} sleeper_t;

static void *sleeper(void *arg)
{
    sleeper_t *s = arg;
    assert_int_equal(hal_host_net_wait(s->n, 0, WAIT_MS), 0);
    s->queued = (int)hal_host_net_queued(s->n);
    return NULL;
}

static void test_sleeping_reader_is_woken(void **st)
{
    (void)st;
    hal_host_net_t *w = open_robot(), *r = open_robot();
    assert_int_equal(hal_host_net_subscribe(r, CH), 0);
    assert_int_equal(hal_host_net_wait(r, 0, 0), 0); /* inline, armed */
    for (int round = 0; round < 3; round++) {
        sleeper_t s = {r, 0};
        pthread_t t;
        assert_int_equal(pthread_create(&t, NULL, sleeper, &s), 0);
        const struct timespec pause = {0, 20 * 1000000L};
        nanosleep(&pause, NULL);
        const uint8_t msg[64] = {(uint8_t)round};
        assert_int_equal(hal_host_net_publish(w, CH, msg, sizeof msg), 0);
        assert_int_equal(pthread_join(t, NULL), 0);
        assert_int_equal(s.queued, 1); /* woken with it, not timed out without it */
        uint8_t buf[64];
        hal_net_rx_info_t info;
        assert_int_equal(hal_host_net_receive(r, 0, &info, buf, sizeof buf), 0);
        assert_int_equal(buf[0], round);
    }
    hal_host_net_close(w);
    hal_host_net_close(r);
}

static void test_keyed_fleet_goes_without_trailer(void **st)
{
    (void)st;
    hal_host_auth_t a;
    memset(&a, 0, sizeof a);
    memset(a.key, 3, sizeof a.key);
    hal_host_net_t *w = open_robot(), *r = open_robot();
    assert_int_equal(hal_host_net_set_auth(w, &a), 0);
    assert_int_equal(hal_host_net_set_auth(r, &a), 0);
    assert_int_equal(hal_host_net_subscribe(r, CH), 0);
    uint8_t msg[300], buf[400];
    fill(msg, sizeof msg, 9);
    assert_int_equal(hal_host_net_publish(w, CH, msg, sizeof msg), 0);
    hal_net_rx_info_t info;
    assert_int_equal(receive_one(r, &info, buf, sizeof buf), (long)sizeof msg);
    assert_memory_equal(buf, msg, sizeof msg);
    assert_int_equal(stats_of(w).tx_bytes, sizeof msg);
    hal_host_net_close(w);
    hal_host_net_close(r);
}

static void test_bad_names_and_foreign_segments(void **st)
{
    (void)st;
    hal_host_net_t *n = NULL;
    const char *bad[] = {"shm://", "shm://a/b", "shm://a b", "shm://0123456789012345678901234567890123456789012345678"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        assert_int_equal(hal_host_net_open(bad[i], 16, 0, &n), -EINVAL);
    char path[96], url[96];
    snprintf(path, sizeof path, "/fleetsim.%s", g_name);
    snprintf(url, sizeof url, "shm://%s", g_name);
    int fd = shm_open(path, O_RDWR | O_CREAT, 0600); /* another layout's size */
    assert_true(fd >= 0);
    assert_int_equal(ftruncate(fd, 4096), 0);
    close(fd);
    assert_int_equal(hal_host_net_open(url, 16, 0, &n), -EIO);
    assert_int_equal(shm_unlink(path), 0);
    fd = shm_open(path, O_RDWR | O_CREAT, 0600); /* the size, but another build's magic */
    assert_true(fd >= 0);
    assert_int_equal(ftruncate(fd, (off_t)SHM_SEGMENT_BYTES), 0);
    const uint64_t other = 0x1234;
    assert_int_equal(pwrite(fd, &other, sizeof other, 0), (ssize_t)sizeof other);
    close(fd);
    assert_int_equal(hal_host_net_open(url, 16, 0, &n), -EIO);
    assert_null(n);
}

/* Another process of this user may write anything into the segment: a slot count past the
 * layout, a subscription count past the table, marks pointing anywhere. Nothing reads outside
 * the segment or the tables, and delivery goes on (the first datagram after a bad mark may be
 * lost, as a lost datagram is). */
static void test_corrupt_segment_tolerated(void **st)
{
    (void)st;
    hal_host_net_t *w = open_robot(), *r = open_robot(); /* slots 0 and 1 of a new segment */
    assert_int_equal(hal_host_net_subscribe(r, CH), 0);
    assert_int_equal(hal_host_net_wait(r, 0, 0), 0);
    char path[96];
    snprintf(path, sizeof path, "/fleetsim.%s", g_name);
    const int fd = shm_open(path, O_RDWR, 0600);
    assert_true(fd >= 0);
    uint8_t *m = mmap(NULL, SHM_MAPPED_BYTES, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    assert_true(m != MAP_FAILED);
    close(fd);
    shm_header_t *h = (shm_header_t *)m;
    shm_slot_t *slot = (shm_slot_t *)(m + sizeof(shm_header_t));
    atomic_store(&h->hi, UINT32_MAX);
    atomic_store(&slot[0].n_subs, 1000u);
    atomic_store(&slot[1].n_subs, 1000u);
    atomic_store(&slot[1].first[0][0], UINT64_MAX);
    atomic_store(&slot[1].first[1][0], 12345u);
    uint8_t msg[100], buf[128];
    hal_net_rx_info_t info;
    for (int k = 0; k < 3; k++) {
        fill(msg, sizeof msg, (unsigned)k);
        assert_int_equal(hal_host_net_publish(w, CH, msg, sizeof msg), 0);
        const int rc = hal_host_net_receive(r, 0, &info, buf, sizeof buf);
        assert_true(rc == 0 || rc == -EAGAIN); /* this one may be lost */
    }
    fill(msg, sizeof msg, 7);
    assert_int_equal(hal_host_net_publish(w, CH, msg, sizeof msg), 0);
    assert_int_equal(receive_one(r, &info, buf, sizeof buf), (long)sizeof msg);
    assert_memory_equal(buf, msg, sizeof msg);
    assert_int_equal(hal_host_net_subscribe(r, "fleetsim/9/more"), 0); /* its own count, not the segment's */
    munmap(m, SHM_MAPPED_BYTES);
    hal_host_net_close(w);
    hal_host_net_close(r);
}

/* Two processes: the child publishes 40 datagrams of every size class, the parent checks each
 * and answers; the child exits 0 once it heard the answer. Forked before either opens the
 * network (no thread yet: a process forked with threads may not start any under TSan); the
 * child begins once the parent is subscribed (a byte on a pipe). */
static void test_two_processes(void **st)
{
    (void)st;
    int go[2];
    assert_int_equal(pipe(go), 0);
    const pid_t child = fork();
    assert_true(child >= 0);
    if (child == 0) {
        alarm(WAIT_MS / 1000 + 10); /* a child that cannot finish dies, and the parent sees it */
        char b;
        close(go[1]);
        if (read(go[0], &b, 1) != 1)
            _exit(5);
        hal_host_net_t *c = open_robot();
        if (hal_host_net_subscribe(c, "fleetsim/9/ack") != 0)
            _exit(2);
        static uint8_t msg[HAL_NET_MTU_BYTES], buf[64];
        for (int k = 0; k < 40; k++) {
            const size_t len = (size_t)k * 1531u; /* < HAL_NET_MTU_BYTES */
            fill(msg, len, (unsigned)k);
            if (hal_host_net_publish(c, CH, msg, len) != 0)
                _exit(3);
        }
        hal_net_rx_info_t info;
        const long got = receive_one(c, &info, buf, sizeof buf);
        hal_host_net_close(c);
        _exit(got == 3 ? 0 : 4);
    }
    close(go[0]);
    hal_host_net_t *p = open_robot();
    assert_int_equal(hal_host_net_subscribe(p, CH), 0);
    assert_int_equal(write(go[1], "g", 1), 1);
    close(go[1]);
    static uint8_t msg[HAL_NET_MTU_BYTES], buf[HAL_NET_MTU_BYTES];
    int seen[40] = {0};
    for (int i = 0; i < 40; i++) {
        hal_net_rx_info_t info;
        const long len = receive_one(p, &info, buf, sizeof buf);
        assert_true(len >= 0 && len % 1531 == 0 && len / 1531 < 40); /* k x 1531 bytes: datagram k */
        const int k = (int)(len / 1531);
        seen[k]++;
        fill(msg, (size_t)len, (unsigned)k);
        assert_memory_equal(buf, msg, (size_t)len);
    }
    for (int k = 0; k < 40; k++) /* each once; the small and the bulk ring keep no order between them */
        assert_int_equal(seen[k], 1);
    assert_int_equal(hal_host_net_publish(p, "fleetsim/9/ack", "ok", 3), 0);
    int status = 0;
    assert_int_equal(waitpid(child, &status, 0), child);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    hal_host_net_close(p);
}

/* The ring alone: a ring of a memfd and its control block. */
static void test_ring_checked_read(void **st)
{
    (void)st;
    const int fd = memfd_create("ring", MFD_CLOEXEC);
    assert_true(fd >= 0);
    assert_int_equal(ftruncate(fd, (off_t)SHM_RING_SMALL), 0);
    shm_ring_ctl_t ctl;
    memset(&ctl, 0, sizeof ctl);
    shm_entry_t e, got;
    memset(&e, 0, sizeof e);
    strcpy(e.channel, CH);
    e.chan_hash = shm_chan_hash(CH);
    e.sender = 7;
    static uint8_t data[SHM_SMALL_MAX], back[SHM_DATAGRAM_MAX];
    fill(data, sizeof data, 1);
    uint64_t at, prev = 0;
    e.len = SHM_SMALL_MAX;
    /* Entries until one does not fit at the ring's end: padding, then offset 0. */
    for (;;) {
        assert_int_equal(shm_ring_write(&ctl, fd, 0, 0, &e, data, &at), 0);
        if (at % SHM_RING_SMALL == 0 && at != 0)
            break;
        prev = at;
    }
    assert_int_equal(shm_ring_read(&ctl, fd, 0, 0, prev, &got, back), SHM_READ_OK);
    assert_int_equal(got.len, SHM_SMALL_MAX);
    assert_int_equal(got.sender, 7);
    assert_memory_equal(back, data, SHM_SMALL_MAX);
    const uint64_t pad = prev + SHM_ENTRY_BYTES(SHM_SMALL_MAX);
    assert_int_equal(shm_ring_read(&ctl, fd, 0, 0, pad, &got, NULL), SHM_READ_SKIP);
    assert_int_equal(shm_ring_read(&ctl, fd, 0, 0, at, &got, back), SHM_READ_OK);
    /* The first entry was overwritten by the last: lapped, and the resume point reads. */
    assert_int_equal(shm_ring_read(&ctl, fd, 0, 0, 0, &got, back), SHM_READ_LAPPED);
    const uint64_t head = atomic_load(&ctl.head);
    assert_int_equal(shm_ring_resume(head, 0), at);
    /* A header out of bounds is no entry. */
    e.len = SHM_DATAGRAM_MAX + 1u;
    assert_int_equal(pwrite(fd, &e, sizeof e, (off_t)(at % SHM_RING_SMALL)), (ssize_t)sizeof e);
    assert_int_equal(shm_ring_read(&ctl, fd, 0, 0, at, &got, back), SHM_READ_INVALID);
    close(fd);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_three_robots_exchange, setup, teardown),
        cmocka_unit_test_setup_teardown(test_unsubscribed_channel_never_arrives, setup, teardown),
        cmocka_unit_test_setup_teardown(test_senders_filtered_at_the_writer, setup, teardown),
        cmocka_unit_test_setup_teardown(test_lapped_reader_resumes_and_counts, setup, teardown),
        cmocka_unit_test_setup_teardown(test_sleeping_reader_is_woken, setup, teardown),
        cmocka_unit_test_setup_teardown(test_keyed_fleet_goes_without_trailer, setup, teardown),
        cmocka_unit_test_setup_teardown(test_bad_names_and_foreign_segments, setup, teardown),
        cmocka_unit_test_setup_teardown(test_corrupt_segment_tolerated, setup, teardown),
        cmocka_unit_test_setup_teardown(test_two_processes, setup, teardown),
        cmocka_unit_test(test_ring_checked_read),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
