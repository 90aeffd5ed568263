/* `host_sim hil` (host_sim/world/sim_hil_serve.h) as a board meets it: a real process serving
 * the ODE world over UDP on loopback, this test in the board's place, speaking the link's
 * frames (hal/hal_hil_frame.h, hal_hil_msg.h). The round trip: HELLO, TICK -> POSE and SCAN
 * at the path's start, a wheel command that moves the robot as far as it should in a second,
 * nothing before a HELLO or for another robot, replayed and corrupted frames refused while the
 * serving goes on, the same seed giving the same bytes in a second server, and the server
 * ending on its own when the board goes quiet, its last line counting what it refused; and the
 * firmware's RT core (board_hil) driving its tour through the link, and ending on its own when
 * its world stops answering; and the same over the serial
 * link (TCP carrying a serial line's bytes): frames cut anywhere, noise, a second connection
 * refused, a board that hangs up and comes back; over Ethernet frames in datagrams; and the
 * bridge of the fleet's datagrams to LCM. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <arpa/inet.h>
#include <math.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>
#include <cmocka.h>

#include "fleet_procs.h"
#include "hal/hal_hil_msg.h"
#include "hal_host.h"

#define DEADLINE_S 20.0
#define IDLE_S "1.5"

typedef struct board {
    int fd, stream;    /* stream: a serial line's bytes over TCP (--link serial) */
    int ether;         /* Ethernet frames in the datagrams (--link ether) */
    uint16_t port;
    hal_hil_stream_t rx;
    struct sockaddr_in server;
    uint32_t session, seq;
    pid_t pid;
    char log[PATH_MAX];
    hal_hil_guard_t guard;
    uint8_t frame[HAL_HIL_FRAME_MAX];
    uint8_t payload[HAL_HIL_PAYLOAD_MAX];
} board_t;

static board_t b1, b2;

static uint16_t free_port(int type)
{
    const int fd = socket(AF_INET, type, 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    socklen_t al = sizeof a;
    assert_true(fd >= 0 && bind(fd, (struct sockaddr *)&a, sizeof a) == 0 &&
                getsockname(fd, (struct sockaddr *)&a, &al) == 0);
    close(fd);
    return ntohs(a.sin_port);
}

/* The board's socket to the server: a UDP one, or a TCP connection (stream). */
static int board_socket(const board_t *b)
{
    const int fd = socket(AF_INET, b->stream ? SOCK_STREAM : SOCK_DGRAM, 0);
    assert_true(fd >= 0);
    if (b->stream)
        assert_int_equal(connect(fd, (const struct sockaddr *)&b->server, sizeof b->server), 0);
    return fd;
}

typedef enum { LINK_UDP, LINK_SERIAL, LINK_ETHER } link_t;

static const char *server_fleet_lcm; /* the next server's --fleet-lcm (NULL: none) */

/* b afresh, and its server started on `link` and listening: its "serving" line in the log,
   within the deadline. */
static void start_server(board_t *b, const char *name, link_t link)
{
    memset(b, 0, sizeof *b);
    b->stream = link == LINK_SERIAL;
    b->ether = link == LINK_ETHER;
    const uint16_t port = free_port(b->stream ? SOCK_STREAM : SOCK_DGRAM);
    static char listen[32], robot_path[PATH_MAX];
    snprintf(listen, sizeof listen, "127.0.0.1:%u", (unsigned)port);
    snprintf(robot_path, sizeof robot_path, "%s/robot_0.csv", fp_env.paths);
    snprintf(b->log, sizeof b->log, "%s/%s.log", fp_env.dir, name);
    const char *argv[] = {fp_env.bin, "hil", "--plan", fp_env.plan, "--path", robot_path, "--listen", listen,
                          "--idle-timeout", IDLE_S, "--seed", "7", "--link",
                          b->stream ? "serial" : b->ether ? "ether" : "udp",
                          server_fleet_lcm != NULL ? "--fleet-lcm" : NULL, server_fleet_lcm, NULL};
    b->pid = fp_spawn(argv, b->log, NULL, NULL);
    assert_true(b->pid > 0);
    const double t0 = fp_now();
    for (;;) {
        char text[4096] = "";
        FILE *f = fopen(b->log, "r");
        if (f != NULL) {
            text[fread(text, 1, sizeof text - 1, f)] = '\0';
            fclose(f);
        }
        if (strstr(text, "hil: serving") != NULL)
            break;
        const int ended = fp_wait(b->pid, fp_now()); /* not waiting: has it ended already? */
        if (ended != -1) {
            fp_show_log(b->log);
            fail_msg("host_sim hil ended (status %d) before it served", ended);
        }
        if (fp_now() - t0 > DEADLINE_S) {
            fp_show_log(b->log);
            fail_msg("host_sim hil did not start within %g s", DEADLINE_S);
        }
        fp_sleep_ms(20);
    }
    b->port = port;
    b->server = (struct sockaddr_in){.sin_family = AF_INET, .sin_port = htons(port),
                                     .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    b->fd = board_socket(b);
    hal_hil_stream_init(&b->rx);
    b->session = 0xB0A4D000u + (uint32_t)port;
    hal_hil_guard_init(&b->guard);
}

static const uint8_t board_mac[6] = {0x52, 0x54, 0x00, 0x12, 0x34, 0x56};

/* An Ethernet frame to the server: broadcast, from board_mac, padded to 60 bytes. */
static void send_ether(board_t *b, unsigned ethertype, const uint8_t *payload, size_t n)
{
    uint8_t e[14 + HAL_HIL_FRAME_MAX + 60] = {0};
    memset(e, 0xFF, 6);
    memcpy(e + 6, board_mac, 6);
    e[12] = (uint8_t)(ethertype >> 8);
    e[13] = (uint8_t)ethertype;
    memcpy(e + 14, payload, n);
    const size_t len = 14 + n < 60 ? 60 : 14 + n;
    assert_int_equal(sendto(b->fd, e, len, 0, (struct sockaddr *)&b->server, sizeof b->server), (ssize_t)len);
}

/* One frame to the server; its bytes stay in b->frame (to be replayed). */
static int send_frame(board_t *b, hal_hil_type_t type, int len)
{
    assert_true(len >= 0);
    const int n = hal_hil_encode(b->frame, sizeof b->frame, type, b->session, ++b->seq, b->payload, (size_t)len);
    assert_true(n > 0);
    if (b->stream)
        assert_int_equal(send(b->fd, b->frame, (size_t)n, 0), n);
    else if (b->ether)
        send_ether(b, 0x88B5u, b->frame, (size_t)n);
    else
        assert_int_equal(sendto(b->fd, b->frame, (size_t)n, 0, (struct sockaddr *)&b->server, sizeof b->server), n);
    return n;
}

/* A stream's next frame within wait_ms, read a few bytes at a time (a serial line has no
   boundaries): 1 and *f, its bytes copied into buf, or 0. */
static int recv_stream_frame(board_t *b, uint8_t *buf, size_t cap, hal_hil_frame_t *f, int wait_ms)
{
    static uint8_t pending[HAL_HIL_FRAME_MAX];
    static size_t at, n;
    for (;;) {
        while (at < n) {
            int got = 0;
            at += hal_hil_stream_feed(&b->rx, pending + at, n - at, f, &got);
            if (got) {
                const size_t len = HAL_HIL_OVERHEAD_BYTES + f->len;
                assert_true(len <= cap);
                memcpy(buf, f->payload - HAL_HIL_HEADER_BYTES, len); /* the frame; *f's payload then in buf */
                f->payload = buf + HAL_HIL_HEADER_BYTES;
                return 1;
            }
        }
        struct pollfd p = {.fd = b->fd, .events = POLLIN};
        if (poll(&p, 1, wait_ms) != 1)
            return 0;
        const ssize_t r = recv(b->fd, pending, 1 + (size_t)(rand() % 97), 0);
        if (r <= 0)
            return 0;
        at = 0;
        n = (size_t)r;
    }
}

/* The next frame from the server within wait_ms: 1 and *f (payload in buf), or 0. */
static int recv_frame(board_t *b, uint8_t *buf, size_t cap, hal_hil_frame_t *f, int wait_ms)
{
    if (b->stream) {
        if (!recv_stream_frame(b, buf, cap, f, wait_ms))
            return 0;
    } else if (b->ether) { /* to the board's address, our EtherType, maybe padded */
        static uint8_t e[14 + HAL_HIL_FRAME_MAX + 60];
        struct pollfd p = {.fd = b->fd, .events = POLLIN};
        if (poll(&p, 1, wait_ms) != 1)
            return 0;
        const ssize_t n = recv(b->fd, e, sizeof e, 0);
        assert_true(n >= 60 && memcmp(e, board_mac, 6) == 0 && e[12] == 0x88 && e[13] == 0xB5);
        const size_t len = HAL_HIL_OVERHEAD_BYTES + ((size_t)e[14 + 12] | (size_t)e[14 + 13] << 8);
        assert_true(len <= (size_t)n - 14 && len <= cap);
        memcpy(buf, e + 14, len);
        assert_int_equal(hal_hil_parse(buf, len, f), HAL_HIL_OK);
    } else {
        struct pollfd p = {.fd = b->fd, .events = POLLIN};
        if (poll(&p, 1, wait_ms) != 1)
            return 0;
        const ssize_t n = recv(b->fd, buf, cap, 0);
        assert_true(n > 0);
        assert_int_equal(hal_hil_parse(buf, (size_t)n, f), HAL_HIL_OK);
    }
    assert_int_equal(hal_hil_guard_accept(&b->guard, f), 0);
    return 1;
}

static uint8_t in_pose[HAL_HIL_FRAME_MAX], in_scan[HAL_HIL_FRAME_MAX];

/* TICK t, holding no scan: the scan and the pose that answer it (their frames stay in in_scan
   and in_pose). */
static void tick(board_t *b, uint64_t t_us, hal_pose_t *pose, hal_lidar_scan_t *scan)
{
    const hal_hil_tick_t tk = {t_us, 0, 0};
    send_frame(b, HAL_HIL_TICK, hal_hil_put_tick(b->payload, sizeof b->payload, &tk));
    hal_hil_frame_t f;
    assert_int_equal(recv_frame(b, in_scan, sizeof in_scan, &f, 5000), 1);
    assert_int_equal(hal_hil_get_scan(&f, scan), 0);
    assert_int_equal(recv_frame(b, in_pose, sizeof in_pose, &f, 5000), 1);
    assert_int_equal(hal_hil_get_pose(&f, pose), 0);
}

static void hello(board_t *b, uint32_t robot)
{
    const hal_hil_hello_t h = {robot, 20000, "test-board"};
    send_frame(b, HAL_HIL_HELLO, hal_hil_put_hello(b->payload, sizeof b->payload, &h));
}

static void wheels(board_t *b, float l, float r)
{
    const hal_hil_wheels_t w = {0, l, r};
    send_frame(b, HAL_HIL_WHEELS, hal_hil_put_wheels(b->payload, sizeof b->payload, &w));
}

/* HELLO for robot 0, and the world's HELLO and WORLD that open the session. */
static void open_session(board_t *b)
{
    uint8_t buf[HAL_HIL_FRAME_MAX];
    hal_hil_frame_t f;
    hello(b, 0);
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 5000), 1);
    assert_int_equal(f.type, HAL_HIL_HELLO);
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 5000), 1);
    assert_int_equal(f.type, HAL_HIL_WORLD);
}

/* The first waypoint of robot 0's tour (x, y). */
static void tour_start(double *x, double *y)
{
    char p[PATH_MAX];
    snprintf(p, sizeof p, "%s/robot_0.csv", fp_env.paths);
    FILE *f = fopen(p, "r");
    assert_non_null(f);
    char line[256];
    int got = 0;
    while (!got && fgets(line, sizeof line, f) != NULL)
        got = sscanf(line, "%lf,%lf", x, y) == 2;
    fclose(f);
    assert_true(got);
}

/* The board went quiet: the server ends by itself with 0; its log into text, and its last
   line ("hil: served ..."), printed. */
static const char *server_last_line(board_t *b, char *text, size_t cap)
{
    const int status = fp_wait(b->pid, fp_now() + DEADLINE_S);
    if (status != 0)
        fp_show_log(b->log);
    assert_int_equal(status, 0);
    b->pid = 0;
    FILE *lf = fopen(b->log, "r");
    assert_non_null(lf);
    text[fread(text, 1, cap - 1, lf)] = '\0';
    fclose(lf);
    const char *last = strstr(text, "hil: served");
    assert_non_null(last);
    print_message("%s", last);
    return last;
}

static hal_lidar_scan_t scan_a, scan_b;

static void test_round_trip(void **st)
{
    (void)st;
    board_t *b = &b1;
    start_server(b, "hil", LINK_UDP);
    uint8_t buf[HAL_HIL_FRAME_MAX];
    hal_hil_frame_t f;

    /* Before a HELLO, and a HELLO for another robot: nothing comes back. */
    const hal_hil_tick_t t0 = {0, 0, 0};
    send_frame(b, HAL_HIL_TICK, hal_hil_put_tick(b->payload, sizeof b->payload, &t0));
    hello(b, 5);
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 300), 0);

    hello(b, 0);
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 5000), 1);
    hal_hil_hello_t h;
    assert_int_equal(hal_hil_get_hello(&f, &h), 0);
    assert_string_equal(h.board, "host_sim");
    assert_int_equal(h.robot, 0);
    hal_hil_world_t wd;
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 5000), 1);
    assert_int_equal(hal_hil_get_world(&f, &wd), 0);
    assert_true(wd.min_x < wd.max_x && wd.min_y < wd.max_y && wd.step_us == 10000u && wd.scan_period_us == 100000u);

    /* At t = 0: the robot at the tour's start, a whole scan. */
    hal_pose_t p0, p1;
    tick(b, 0, &p0, &scan_a);
    double x0, y0;
    tour_start(&x0, &y0);
    assert_true(fabs(p0.x_m - x0) < 0.05 && fabs(p0.y_m - y0) < 0.05);
    assert_true(scan_a.count > 0 && scan_a.count <= HAL_LIDAR_MAX_BEAMS);

    /* Both wheels at 0.15 m/s for a second: about 0.15 m along the heading. */
    const float w = 0.15f / 0.033f;
    wheels(b, w, w);
    tick(b, 1000000, &p1, &scan_a);
    const double dx = p1.x_m - p0.x_m, dy = p1.y_m - p0.y_m, d = sqrt(dx * dx + dy * dy);
    const double along = dx * cos(p0.heading_rad) + dy * sin(p0.heading_rad);
    print_message("moved %.3f m in 1 s (%.3f along the heading)\n", d, along);
    assert_true(along > 0.10 && along < 0.18);
    assert_true(p1.stamp_us >= 990000u && p1.stamp_us <= 1000000u);

    /* Holding the world's latest scan: the pose alone comes back. */
    const hal_hil_tick_t held = {1000000, scan_a.stamp_us + 1u, 0};
    send_frame(b, HAL_HIL_TICK, hal_hil_put_tick(b->payload, sizeof b->payload, &held));
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 5000), 1);
    assert_int_equal(hal_hil_get_pose(&f, &p1), 0);
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 300), 0);

    /* The last TICK replayed (same session and seq): refused, nothing comes back. */
    const int n = hal_hil_encode(buf, sizeof buf, HAL_HIL_TICK, b->session, b->seq, b->payload, HAL_HIL_TICK_BYTES);
    assert_int_equal(sendto(b->fd, buf, (size_t)n, 0, (struct sockaddr *)&b->server, sizeof b->server), n);
    /* A corrupted frame and noise: refused, nothing comes back. */
    const int m = hal_hil_encode(buf, sizeof buf, HAL_HIL_TICK, b->session, b->seq + 1u, b->payload,
                                 HAL_HIL_TICK_BYTES);
    buf[m - 1] ^= 0x10u;
    assert_int_equal(sendto(b->fd, buf, (size_t)m, 0, (struct sockaddr *)&b->server, sizeof b->server), m);
    assert_int_equal(sendto(b->fd, "garbage", 7, 0, (struct sockaddr *)&b->server, sizeof b->server), 7);
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 300), 0);
    /* ... and the serving goes on. */
    tick(b, 1500000, &p1, &scan_a);

    /* The board goes quiet: the server ends by itself, 0, counting what it refused. */
    static char text[8192];
    const char *last = server_last_line(b, text, sizeof text);
    unsigned long long ticks = 0, refused = 0, replayed = 0, before = 0, bad = 0;
    assert_int_equal(sscanf(last, "hil: served %*f simulated s: %llu ticks", &ticks), 1);
    assert_int_equal(sscanf(strstr(last, "refused"),
                            "refused %llu (bad frames), %*u noise bytes, %llu replayed, %llu before a HELLO", &refused,
                            &replayed, &before),
                     3);
    assert_int_equal(sscanf(strstr(last, "another address or connection,"),
                            "another address or connection, %llu bad payloads", &bad),
                     1);
    assert_int_equal(ticks, 4);
    assert_int_equal(refused, 2); /* the corrupted frame, the noise */
    assert_int_equal(replayed, 1);
    assert_int_equal(bad, 1); /* the HELLO for robot 5 */
    assert_true(strstr(text, "board 'test-board' (robot 0") != NULL);
    (void)before;
    close(b->fd);
}

static void test_same_seed_same_bytes(void **st)
{
    (void)st;
    static uint8_t pose1[HAL_HIL_FRAME_MAX], scan1[HAL_HIL_FRAME_MAX];
    hal_pose_t p;
    board_t *bs[2] = {&b1, &b2};
    for (int k = 0; k < 2; k++) {
        board_t *b = bs[k];
        start_server(b, k == 0 ? "hil_a" : "hil_b", LINK_UDP);
        open_session(b);
        tick(b, 0, &p, k == 0 ? &scan_a : &scan_b);
        wheels(b, 4.0f, 3.0f);
        tick(b, 700000, &p, k == 0 ? &scan_a : &scan_b);
        wheels(b, -1.0f, 2.0f);
        tick(b, 1300000, &p, k == 0 ? &scan_a : &scan_b);
        /* The payloads, past the frames' headers (sessions and seqs differ). */
        if (k == 0) {
            memcpy(pose1, in_pose, sizeof pose1);
            memcpy(scan1, in_scan, sizeof scan1);
        } else {
            assert_memory_equal(pose1 + HAL_HIL_HEADER_BYTES, in_pose + HAL_HIL_HEADER_BYTES, HAL_HIL_POSE_BYTES);
            assert_int_equal(scan_a.count, scan_b.count);
            assert_memory_equal(scan1 + HAL_HIL_HEADER_BYTES, in_scan + HAL_HIL_HEADER_BYTES,
                                26u + 4u * scan_a.count);
        }
        close(b->fd);
        assert_int_equal(fp_wait(b->pid, fp_now() + DEADLINE_S), 0);
        b->pid = 0;
    }
}

/* board_hil (beside host_sim) started on robot 0's tour against b's server, over UDP, with
   `--time time_s` and `extra` (NULL-ended, or NULL), its output into fp_env.dir/<name>.log
   (into log): its pid. The test's own socket to the server is closed first. */
static pid_t start_board_hil(board_t *b, const char *name, const char *time_s, const char *const *extra,
                             char log[PATH_MAX])
{
    static char board_bin[PATH_MAX], tour[PATH_MAX], connect[32];
    snprintf(board_bin, sizeof board_bin, "%.*s/board_hil", (int)(strrchr(fp_env.bin, '/') - fp_env.bin), fp_env.bin);
    snprintf(tour, sizeof tour, "%s/robot_0.csv", fp_env.paths);
    snprintf(connect, sizeof connect, "127.0.0.1:%u", (unsigned)ntohs(b->server.sin_port));
    snprintf(log, PATH_MAX, "%s/%s.log", fp_env.dir, name);
    close(b->fd);
    const char *argv[16] = {board_bin, "--connect", connect, "--tour", tour, "--time", time_s};
    for (int i = 0, n = 7; extra != NULL && extra[i] != NULL && n < 15; i++)
        argv[n++] = extra[i];
    const pid_t pid = fp_spawn(argv, log, NULL, NULL);
    assert_true(pid > 0);
    return pid;
}

/* The firmware's RT core on a board stand-in (board_hil, a process on the stdc back end) in
   the loop with the world: it drives its tour over UDP, every reading a TICK's answer, and
   both ends count the same distance. */
static void test_rt_core_drives_through_the_link(void **st)
{
    (void)st;
    board_t *b = &b1;
    start_server(b, "hil_rt", LINK_UDP);
    char log[PATH_MAX];
    const pid_t pid = start_board_hil(b, "board_hil", "4", NULL, log);
    const int status = fp_wait(pid, fp_now() + DEADLINE_S);
    if (status != 0)
        fp_show_log(log);
    assert_int_equal(status, 0);
    assert_int_equal(fp_wait(b->pid, fp_now() + DEADLINE_S), 0);
    b->pid = 0;
    char text[8192] = "";
    FILE *f = fopen(log, "r");
    assert_non_null(f);
    text[fread(text, 1, sizeof text - 1, f)] = '\0';
    fclose(f);
    double progress = 0, distance = 0;
    unsigned long long ticks = 0, scans = 0, hal_errors = 1, exchanges = 0;
    assert_int_equal(sscanf(strstr(text, "result rt_ticks"), "result rt_ticks %llu", &ticks), 1);
    assert_int_equal(sscanf(strstr(text, "result progress_m"), "result progress_m %lf", &progress), 1);
    assert_int_equal(sscanf(strstr(text, "result distance_m"), "result distance_m %lf", &distance), 1);
    assert_int_equal(sscanf(strstr(text, "result scans"), "result scans %llu", &scans), 1);
    assert_int_equal(sscanf(strstr(text, "result hal_errors"), "result hal_errors %llu", &hal_errors), 1);
    assert_int_equal(sscanf(strstr(text, "result link_exchanges"), "result link_exchanges %llu", &exchanges), 1);
    print_message("board_hil: %llu RT ticks, %llu exchanges, %llu scans, progress %.2f m\n", ticks, exchanges,
                  scans, progress);
    assert_int_equal(ticks, 200); /* 4 s at 50 Hz */
    /* One TICK per RT tick, pose and scan sharing it (a tick run a whole period late shares
       the next one's: fewer then, never more). */
    assert_true(exchanges <= ticks && exchanges >= ticks - ticks / 10u);
    assert_true(scans >= 35 && scans <= 41); /* every 5th tick */
    assert_int_equal(hal_errors, 0);
    assert_true(progress > 0.4);
    /* The world's distance, from its last line: the same robot. */
    memset(text, 0, sizeof text);
    f = fopen(b->log, "r");
    assert_non_null(f);
    text[fread(text, 1, sizeof text - 1, f)] = '\0';
    fclose(f);
    double world_distance = 0;
    const char *d = strstr(text, "distance ");
    while (d != NULL && strstr(d + 1, "distance ") != NULL)
        d = strstr(d + 1, "distance ");
    assert_non_null(d);
    assert_int_equal(sscanf(d, "distance %lf", &world_distance), 1);
    print_message("distance: %.3f m by the RT core's odometry, %.3f m in the world\n", distance, world_distance);
    assert_true(fabs(world_distance - distance) < 0.15 * distance);
}

/* A board whose world stops answering (host_sim hil stopped, SIGSTOP: no port-unreachable to
   tell the board, as a host that froze or lost power) ends on its own: after
   HAL_STDC_HIL_DOWN_AFTER unanswered exchanges the link is down, board_hil says so and exits 1,
   long before its --time (the lockstep board's clock stands still while it waits, so --time
   alone would take an exchange's wait per reading). */
static void test_board_ends_when_its_world_stops(void **st)
{
    (void)st;
    board_t *b = &b1;
    start_server(b, "hil_stops", LINK_UDP);
    char log[PATH_MAX];
    const char *const fast[] = {"--timeout-ms", "100", NULL};
    const pid_t pid = start_board_hil(b, "board_stops", "600", fast, log);
    char text[8192] = "";
    for (const double t0 = fp_now(); strstr(text, "board_hil: board ") == NULL; fp_sleep_ms(20)) {
        FILE *f = fopen(log, "r");
        if (f != NULL) {
            text[fread(text, 1, sizeof text - 1, f)] = '\0';
            fclose(f);
        }
        if (fp_now() - t0 > DEADLINE_S) {
            fp_show_log(log);
            fail_msg("board_hil did not reach its world within %g s", DEADLINE_S);
        }
    }
    fp_sleep_ms(500); /* driving */
    assert_int_equal(kill(b->pid, SIGSTOP), 0);
    const double stopped = fp_now();
    /* 10 exchanges of 5 TICKs, 100 ms each: 5 s, and the deadline's margin */
    const int status = fp_wait(pid, stopped + 5.0 + DEADLINE_S);
    const double took = fp_now() - stopped;
    fp_kill(b->pid);
    b->pid = 0;
    if (status == -1)
        fp_kill(pid);
    FILE *f = fopen(log, "r");
    assert_non_null(f);
    text[fread(text, 1, sizeof text - 1, f)] = '\0';
    fclose(f);
    print_message("board_hil ended %.1f s after its world stopped, status %d\n", took, status);
    if (status != 1)
        fp_show_log(log);
    assert_int_equal(status, 1);
    assert_non_null(strstr(text, "stopped answering (10 exchanges in a row): the link is down"));
    unsigned long long ticks = 0;
    assert_int_equal(sscanf(strstr(text, "result rt_ticks"), "result rt_ticks %llu", &ticks), 1);
    assert_true(ticks > 0 && ticks < 600u * 50u);
    assert_true(took >= 4.5); /* it waited for its exchanges: a paused world is not dropped at once */
}

/* The serial link (a serial line's bytes carried over TCP, as QEMU's -serial tcp: gives
   them): frames cut anywhere and noise between them reach the world, its answers come back
   as a byte stream, a second connection is refused while the board's lasts, and a board that
   hangs up and comes back (a new session) is served again. */
static void test_serial_stream(void **st)
{
    (void)st;
    board_t *b = &b1;
    start_server(b, "hil_serial", LINK_SERIAL);
    uint8_t buf[HAL_HIL_FRAME_MAX];
    hal_hil_frame_t f;

    /* HELLO and the first TICK in one write, cut in odd pieces, noise before and between. */
    static uint8_t bytes[4 * HAL_HIL_FRAME_MAX];
    size_t n = 0;
    const char noise[] = "\xF1\x00boot log\r\n\xF1\x5E\x07";
    memcpy(bytes, noise, sizeof noise - 1);
    n += sizeof noise - 1;
    const hal_hil_hello_t h = {0, 20000, "test-uart"};
    n += (size_t)hal_hil_encode(bytes + n, sizeof bytes - n, HAL_HIL_HELLO, b->session, ++b->seq, b->payload,
                                (size_t)hal_hil_put_hello(b->payload, sizeof b->payload, &h));
    memcpy(bytes + n, noise, sizeof noise - 1);
    n += sizeof noise - 1;
    const hal_hil_tick_t t0 = {0, 0, 0};
    n += (size_t)hal_hil_encode(bytes + n, sizeof bytes - n, HAL_HIL_TICK, b->session, ++b->seq, b->payload,
                                (size_t)hal_hil_put_tick(b->payload, sizeof b->payload, &t0));
    for (size_t at = 0, k = 1; at < n; at += k, k = k % 7 + 3) {
        const size_t m = at + k <= n ? k : n - at;
        assert_int_equal(send(b->fd, bytes + at, m, 0), (ssize_t)m);
        fp_sleep_ms(1);
    }
    hal_hil_hello_t w;
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 5000), 1);
    assert_int_equal(hal_hil_get_hello(&f, &w), 0);
    assert_string_equal(w.board, "host_sim");
    hal_hil_world_t wd;
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 5000), 1);
    assert_int_equal(hal_hil_get_world(&f, &wd), 0);
    hal_pose_t p0, p1;
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 5000), 1);
    assert_int_equal(hal_hil_get_scan(&f, &scan_a), 0);
    assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 5000), 1);
    assert_int_equal(hal_hil_get_pose(&f, &p0), 0);
    double x0, y0;
    tour_start(&x0, &y0);
    assert_true(fabs(p0.x_m - x0) < 0.05 && fabs(p0.y_m - y0) < 0.05 && scan_a.count > 0);

    /* A second board on the same line: refused (its connection closed), the first goes on. */
    const int other = board_socket(b);
    struct pollfd po = {.fd = other, .events = POLLIN};
    assert_int_equal(poll(&po, 1, 5000), 1);
    assert_int_equal(recv(other, buf, sizeof buf, 0), 0);
    close(other);
    wheels(b, 4.0f, 4.0f);
    tick(b, 500000, &p1, &scan_a);
    assert_true(p1.stamp_us > p0.stamp_us);

    /* The board hangs up and comes back with a new session: served from its HELLO on. */
    close(b->fd);
    fp_sleep_ms(100); /* the hang-up reaches the world before the new connection */
    b->fd = board_socket(b);
    b->session++;
    b->seq = 0;
    hal_hil_guard_init(&b->guard);
    hal_hil_stream_init(&b->rx);
    open_session(b);
    tick(b, 1000000, &p1, &scan_a);
    assert_true(p1.stamp_us >= 990000u);

    static char text[8192];
    const char *last = server_last_line(b, text, sizeof text);
    unsigned long long ticks = 0, sessions = 0, refused = 0, noise_bytes = 0, others = 0;
    assert_int_equal(sscanf(last, "hil: served %*f simulated s: %llu ticks, %*u scans sent, %*u wheel commands, %llu sessions", &ticks,
                            &sessions),
                     2);
    assert_int_equal(sscanf(strstr(last, "refused "), "refused %llu (bad frames), %llu noise bytes", &refused,
                            &noise_bytes),
                     2);
    assert_int_equal(sscanf(strstr(last, "before a HELLO, "), "before a HELLO, %llu from another", &others), 1);
    assert_int_equal(ticks, 3);
    assert_int_equal(sessions, 2);
    assert_int_equal(refused, 2); /* the false magics, "\xF1\x5E\x07...": a bad header */
    assert_true(noise_bytes > 0); /* the rest of the noise, skipped */
    assert_int_equal(others, 1);
    assert_true(strstr(text, "the board's connection closed (it hung up)") != NULL);
    close(b->fd);
}

/* The Ethernet link (a board's network interface under QEMU: Ethernet frames in UDP
   datagrams): padded short frames taken, the answers addressed to the board's MAC with the
   link's EtherType, other EtherTypes and multicast sources not ours. */
static void test_ether_frames(void **st)
{
    (void)st;
    board_t *b = &b1;
    start_server(b, "hil_ether", LINK_ETHER);
    send_ether(b, 0x0800u, (const uint8_t *)"an IPv4 packet", 14); /* another EtherType */
    open_session(b);
    hal_pose_t p0, p1;
    tick(b, 0, &p0, &scan_a);
    wheels(b, 4.0f, 4.0f);
    tick(b, 500000, &p1, &scan_a);
    assert_true(p1.stamp_us > p0.stamp_us && scan_a.count > 0);
    static char text[8192];
    const char *last = server_last_line(b, text, sizeof text);
    unsigned long long ticks = 0, noise = 1, not_ours = 0;
    assert_int_equal(sscanf(last, "hil: served %*f simulated s: %llu ticks", &ticks), 1);
    assert_int_equal(sscanf(strstr(last, "(bad frames), "), "(bad frames), %llu noise bytes", &noise), 1);
    assert_int_equal(sscanf(strstr(last, "on the way in, "), "on the way in, %llu not ours", &not_ours), 1);
    assert_int_equal(ticks, 2);
    assert_int_equal(noise, 0); /* the padding of short frames is not noise */
    assert_int_equal(not_ours, 1);
    close(b->fd);
}

/* The bridge (--fleet-lcm): the world as the board's network interface on the fleet's LCM. The
   board's datagram reaches an LCM member (this test); the member's datagrams on the channel
   the board subscribed to come back inside TICK answers, never more per answer than the room
   the TICK names; the board's own, which LCM loops back on the channel it also subscribed to,
   never do (counted as own echoes). */
static void test_fleet_bridge(void **st)
{
    (void)st;
    static char url[128];
    snprintf(url, sizeof url, "udpm://239.255.76.67:%u?ttl=0&recv_buf_size=4194304", 7960u + (unsigned)(getpid() % 30));
    hal_host_net_t *fleet = NULL;
    assert_int_equal(hal_host_net_open(url, 16, 0, &fleet), 0);
    assert_int_equal(hal_host_net_subscribe(fleet, "hiltest_out"), 0);
    board_t *b = &b1;
    server_fleet_lcm = url;
    start_server(b, "hil_bridge", LINK_UDP);
    server_fleet_lcm = NULL;
    uint8_t buf[HAL_HIL_FRAME_MAX];
    hal_hil_frame_t f;
    open_session(b);
    send_frame(b, HAL_HIL_SUBSCRIBE, hal_hil_put_subscribe(b->payload, sizeof b->payload, "hiltest_in"));
    send_frame(b, HAL_HIL_SUBSCRIBE, hal_hil_put_subscribe(b->payload, sizeof b->payload, "hiltest_out"));
    static const uint8_t out[3] = {1, 2, 3};
    send_frame(b, HAL_HIL_DATAGRAM, hal_hil_put_datagram(b->payload, sizeof b->payload, "hiltest_out", out, 3));
    hal_pose_t p;
    tick(b, 0, &p, &scan_a); /* the world took both frames before this answer */

    /* The board's datagram, on the fleet's LCM. */
    hal_net_rx_info_t info;
    uint8_t got[64];
    int r = -EAGAIN;
    for (const double t0 = fp_now(); r == -EAGAIN && fp_now() - t0 < 5.0;) {
        assert_int_equal(hal_host_net_wait(fleet, 0, 100), 0);
        r = hal_host_net_receive(fleet, 0, &info, got, sizeof got);
    }
    assert_int_equal(r, 0);
    assert_string_equal(info.channel, "hiltest_out");
    assert_true(info.len == 3 && memcmp(got, out, 3) == 0);

    /* Five from the fleet: two per answer at most, all of them within a few ticks. */
    for (uint8_t k = 0; k < 5; k++)
        assert_int_equal(hal_host_net_publish(fleet, "hiltest_in", &k, 1), 0);
    int to_board = 0, most = 0;
    for (uint64_t t = 20000; to_board < 5 && t < 3000000; t += 20000) {
        const hal_hil_tick_t tk = {t, scan_a.stamp_us + 1u, 2};
        send_frame(b, HAL_HIL_TICK, hal_hil_put_tick(b->payload, sizeof b->payload, &tk));
        int in_answer = 0;
        for (;;) {
            assert_int_equal(recv_frame(b, buf, sizeof buf, &f, 5000), 1);
            if (f.type == HAL_HIL_POSE)
                break;
            if (f.type == HAL_HIL_SCAN) {
                assert_int_equal(hal_hil_get_scan(&f, &scan_a), 0);
                continue;
            }
            hal_hil_datagram_t d;
            assert_int_equal(hal_hil_get_datagram(&f, &d), 0);
            assert_string_equal(d.channel, "hiltest_in");
            assert_true(d.len == 1 && d.data[0] == (uint8_t)to_board); /* in order */
            in_answer++;
            to_board++;
        }
        most = in_answer > most ? in_answer : most;
        fp_sleep_ms(10);
    }
    assert_int_equal(to_board, 5);
    assert_true(most <= 2);
    static char text[8192];
    const char *last = server_last_line(b, text, sizeof text);
    unsigned long long to_fleet = 0, board = 0, subs = 0;
    assert_int_equal(sscanf(strstr(last, "fleet datagrams: "),
                            "fleet datagrams: %llu to the fleet, %llu to the board, %llu subscriptions", &to_fleet,
                            &board, &subs),
                     3);
    assert_true(to_fleet == 1 && board == 5 && subs == 2);
    unsigned long long echoes = 0;
    assert_int_equal(sscanf(strstr(last, "dropped on arrival, "), "dropped on arrival, %llu own echoes", &echoes), 1);
    assert_true(echoes == 1);
    hal_host_net_close(fleet);
    close(b->fd);
}

static int setup(void **st)
{
    (void)st;
    return fp_setup("fleetsim_hil", 0u, NULL);
}

static int teardown(void **st)
{
    (void)st;
    return fp_teardown();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_same_seed_same_bytes),
        cmocka_unit_test(test_rt_core_drives_through_the_link),
        cmocka_unit_test(test_board_ends_when_its_world_stops),
        cmocka_unit_test(test_serial_stream),
        cmocka_unit_test(test_ether_frames),
        cmocka_unit_test(test_fleet_bridge),
    };
    return cmocka_run_group_tests_name("sim/hil_serve", tests, setup, teardown);
}
