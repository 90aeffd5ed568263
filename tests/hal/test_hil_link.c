/* The hardware-in-the-loop link (hal/hal_hil_frame.h, hal/hal_hil_msg.h): every frame type
 * survives a datagram and a byte stream cut in any pieces with noise between frames; bad,
 * truncated, trailing, oversized, unknown and corrupted frames are refused with their reason
 * (and a stream finds the next good frame at once); the guard refuses replays and frames of a
 * session no HELLO opened; each payload's decoder refuses what the robot must not act on; the
 * board's end (hal_hil_client) against a scripted world, over datagrams and over a noisy stream,
 * resending a lost TICK and giving up after its tries; and a seeded fuzz loop feeds random and
 * mutated bytes to both readers (make test-asan runs it). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "common/crc32.h"
#include "common/le_bytes.h"
#include "hal/hal_hil_client.h"
#include "hal_stdc.h"

static uint8_t frame[HAL_HIL_FRAME_MAX];
static uint8_t payload[HAL_HIL_PAYLOAD_MAX];

static uint32_t rng_state = 12345u;
static uint32_t rnd(void) /* xorshift32: the same bytes every run */
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 17;
    rng_state ^= rng_state << 5;
    return rng_state;
}

static hal_lidar_scan_t test_scan(uint32_t count)
{
    hal_lidar_scan_t s;
    memset(&s, 0, sizeof s);
    s.stamp_us = 123456789u;
    s.angle_min_rad = -3.1f;
    s.angle_step_rad = 6.2f / (float)count;
    s.range_min_m = 0.1f;
    s.range_max_m = 8.0f;
    s.count = count;
    for (uint32_t i = 0; i < count; i++)
        s.ranges_m[i] = i % 7u == 0 ? INFINITY : 0.1f + 0.01f * (float)i;
    return s;
}

/* A frame of type t with a payload of len bytes (pattern from seed) into frame[]. */
static int make_frame(hal_hil_type_t t, uint32_t seq, size_t len, uint8_t seed)
{
    for (size_t i = 0; i < len; i++)
        payload[i] = (uint8_t)(seed + 31u * i);
    const int n = hal_hil_encode(frame, sizeof frame, t, 0xC0FFEEu, seq, payload, len);
    assert_int_equal(n, (int)(len + HAL_HIL_OVERHEAD_BYTES));
    return n;
}

/* Rewrites the header check after a header field was changed on purpose. */
static void reseal_header(uint8_t *f)
{
    le_put_u16(f + 14, (uint16_t)crc32_ieee(f, 14));
}

static void test_datagram_round_trip(void **st)
{
    (void)st;
    const size_t lens[] = {0, 1, 17, 1400, HAL_HIL_PAYLOAD_MAX};
    for (size_t k = 0; k < sizeof lens / sizeof lens[0]; k++) {
        const int n = make_frame(HAL_HIL_DATAGRAM, (uint32_t)k + 1u, lens[k], (uint8_t)k);
        hal_hil_frame_t f;
        assert_int_equal(hal_hil_parse(frame, (size_t)n, &f), HAL_HIL_OK);
        assert_int_equal(f.type, HAL_HIL_DATAGRAM);
        assert_int_equal(f.session, 0xC0FFEEu);
        assert_int_equal(f.seq, k + 1u);
        assert_int_equal(f.len, lens[k]);
        if (lens[k] > 0)
            assert_memory_equal(f.payload, payload, lens[k]);
    }
    assert_int_equal(hal_hil_encode(frame, sizeof frame, HAL_HIL_SCAN, 1, 1, payload, HAL_HIL_PAYLOAD_MAX + 1u),
                     -EMSGSIZE);
    assert_int_equal(hal_hil_encode(frame, 30, HAL_HIL_SCAN, 1, 1, payload, 11), -EMSGSIZE);
    assert_int_equal(hal_hil_encode(frame, sizeof frame, HAL_HIL_TYPE_END, 1, 1, payload, 4), -EINVAL);
    assert_int_equal(hal_hil_encode(frame, sizeof frame, HAL_HIL_SCAN, 1, 1, NULL, 4), -EINVAL);
}

static void test_datagram_refusals(void **st)
{
    (void)st;
    hal_hil_frame_t f;
    const int n = make_frame(HAL_HIL_WHEELS, 9, 40, 3);
    for (int cut = 0; cut < n; cut++)
        assert_int_equal(hal_hil_parse(frame, (size_t)cut, &f), HAL_HIL_TRUNCATED);
    assert_int_equal(hal_hil_parse(frame, (size_t)n + 1u, &f), HAL_HIL_TRAILING);
    for (int i = 0; i < n; i++) { /* every single bit flip is caught, by the right check */
        for (int b = 0; b < 8; b++) {
            frame[i] ^= (uint8_t)(1u << b);
            const hal_hil_verdict_t v = hal_hil_parse(frame, (size_t)n, &f);
            if (i < 2)
                assert_int_equal(v, HAL_HIL_BAD_MAGIC);
            else if (i < (int)HAL_HIL_HEADER_BYTES)
                assert_int_equal(v, HAL_HIL_BAD_HEADER);
            else
                assert_int_equal(v, HAL_HIL_BAD_CRC);
            frame[i] ^= (uint8_t)(1u << b);
        }
    }
    frame[2] = HAL_HIL_VERSION + 1u;
    reseal_header(frame);
    assert_int_equal(hal_hil_parse(frame, (size_t)n, &f), HAL_HIL_BAD_VERSION);
    frame[2] = HAL_HIL_VERSION;
    frame[3] = 0;
    reseal_header(frame);
    assert_int_equal(hal_hil_parse(frame, (size_t)n, &f), HAL_HIL_BAD_TYPE);
    frame[3] = HAL_HIL_TYPE_END;
    reseal_header(frame);
    assert_int_equal(hal_hil_parse(frame, (size_t)n, &f), HAL_HIL_BAD_TYPE);
    frame[3] = HAL_HIL_WHEELS;
    le_put_u16(frame + 12, (uint16_t)(HAL_HIL_PAYLOAD_MAX + 1u));
    reseal_header(frame);
    assert_int_equal(hal_hil_parse(frame, sizeof frame, &f), HAL_HIL_OVERSIZED);
    assert_string_equal(hal_hil_verdict_name(HAL_HIL_BAD_CRC), "bad CRC");

    /* The link's addresses: HOST:PORT split at the last ':' */
    char host[16];
    uint32_t port = 1;
    assert_int_equal(hal_hil_split_address("127.0.0.1:7800", host, sizeof host, &port), 0);
    assert_string_equal(host, "127.0.0.1");
    assert_int_equal(port, 7800);
    assert_int_equal(hal_hil_split_address("localhost:0", host, sizeof host, &port), 0);
    assert_int_equal(port, 0);
    const char *bad[] = {"7800", ":7800", "host:", "host:65536", "host:78x", "host:-1", "averyveryverylonghostname:1",
                         NULL};
    for (int i = 0; bad[i] != NULL; i++)
        assert_int_equal(hal_hil_split_address(bad[i], host, sizeof host, &port), -EINVAL);
    assert_int_equal(hal_hil_split_address(NULL, host, sizeof host, &port), -EINVAL);
}

/* Feeds bytes to the stream in random pieces; collects the seqs of the frames out. */
static int feed_all(hal_hil_stream_t *s, const uint8_t *b, size_t n, uint32_t *seqs, int max)
{
    int got_n = 0;
    size_t at = 0;
    while (at < n) {
        size_t piece = 1u + rnd() % 300u;
        if (piece > n - at)
            piece = n - at;
        size_t off = 0;
        for (int guard = 0; off < piece; guard++) {
            assert_true(guard < 100000);
            hal_hil_frame_t f;
            int got = 0;
            off += hal_hil_stream_feed(s, b + at + off, piece - off, &f, &got);
            if (got) {
                assert_true(got_n < max);
                seqs[got_n++] = f.seq;
            }
        }
        at += piece;
    }
    for (;;) { /* a frame may still be held behind the last one handed out */
        hal_hil_frame_t f;
        int got = 0;
        (void)hal_hil_stream_feed(s, NULL, 0, &f, &got);
        if (!got)
            break;
        seqs[got_n++] = f.seq;
    }
    return got_n;
}

static uint8_t wire[1u << 20];

static void test_stream_finds_every_frame_through_noise(void **st)
{
    (void)st;
    static hal_hil_stream_t s;
    hal_hil_stream_init(&s);
    size_t n = 0;
    uint64_t noise = 0;
    for (uint32_t k = 1; k <= 200; k++) {
        const size_t len = k % 10u == 0 ? 3000u : rnd() % 200u;
        const int fl = make_frame((hal_hil_type_t)(1u + k % 8u), k, len, (uint8_t)k);
        memcpy(wire + n, frame, (size_t)fl);
        n += (size_t)fl;
        if (k % 3u == 0) { /* noise, with the magic's bytes in it */
            const size_t g = rnd() % 40u;
            for (size_t i = 0; i < g; i++)
                wire[n + i] = i % 5u == 0 ? HAL_HIL_MAGIC0 : i % 5u == 1 ? HAL_HIL_MAGIC1 : (uint8_t)rnd();
            n += g;
            noise += g;
        }
        assert_true(n + 4000u < sizeof wire);
    }
    uint32_t seqs[256];
    assert_int_equal(feed_all(&s, wire, n, seqs, 256), 200);
    for (uint32_t k = 0; k < 200; k++)
        assert_int_equal(seqs[k], k + 1u);
    assert_int_equal(s.frames, 200);
    assert_true(s.skipped > 0 && s.skipped <= noise);
}

static void test_stream_refuses_and_goes_on(void **st)
{
    (void)st;
    static hal_hil_stream_t s;
    hal_hil_stream_init(&s);
    size_t n = 0;
    int fl = make_frame(HAL_HIL_POSE, 1, 20, 1);
    memcpy(wire + n, frame, (size_t)fl);
    n += (size_t)fl;
    fl = make_frame(HAL_HIL_POSE, 2, 20, 2); /* a bad CRC */
    frame[HAL_HIL_HEADER_BYTES + 5] ^= 0x40u;
    memcpy(wire + n, frame, (size_t)fl);
    n += (size_t)fl;
    fl = make_frame(HAL_HIL_POSE, 3, 20, 3); /* a length corrupted to 60,000: refused at its header */
    le_put_u16(frame + 12, 60000u);
    memcpy(wire + n, frame, (size_t)fl);
    n += (size_t)fl;
    fl = make_frame(HAL_HIL_POSE, 4, 20, 4); /* oversized, with a header that checks */
    le_put_u16(frame + 12, (uint16_t)(HAL_HIL_PAYLOAD_MAX + 1u));
    reseal_header(frame);
    memcpy(wire + n, frame, (size_t)fl);
    n += (size_t)fl;
    fl = make_frame(HAL_HIL_POSE, 5, 20, 5);
    memcpy(wire + n, frame, (size_t)fl);
    n += (size_t)fl;
    /* Frame 5 comes out as soon as its own bytes are in: nothing waits for 60,000 bytes. */
    uint32_t seqs[8];
    assert_int_equal(feed_all(&s, wire, n, seqs, 8), 2);
    assert_int_equal(seqs[0], 1);
    assert_int_equal(seqs[1], 5);
    assert_int_equal(s.refused[HAL_HIL_BAD_CRC], 1);
    assert_int_equal(s.refused[HAL_HIL_BAD_HEADER], 1);
    assert_int_equal(s.refused[HAL_HIL_OVERSIZED], 1);
    /* A frame cut off by silence: dropped and counted when the link goes quiet. */
    fl = make_frame(HAL_HIL_POSE, 6, 20, 6);
    assert_int_equal(feed_all(&s, frame, (size_t)fl - 3u, seqs, 8), 0);
    hal_hil_stream_idle(&s);
    assert_int_equal(s.refused[HAL_HIL_TRUNCATED], 1);
    fl = make_frame(HAL_HIL_POSE, 7, 20, 7);
    assert_int_equal(feed_all(&s, frame, (size_t)fl, seqs, 8), 1);
    assert_int_equal(seqs[0], 7);
}

static void test_guard_refuses_replays_and_unopened_sessions(void **st)
{
    (void)st;
    hal_hil_guard_t g;
    hal_hil_guard_init(&g);
    hal_hil_frame_t f = {HAL_HIL_SCAN, 77, 1, 0, payload};
    assert_int_equal(hal_hil_guard_accept(&g, &f), -ENOTCONN); /* no HELLO yet */
    f.type = HAL_HIL_HELLO;
    assert_int_equal(hal_hil_guard_accept(&g, &f), 0);
    f.type = HAL_HIL_SCAN;
    f.seq = 2;
    assert_int_equal(hal_hil_guard_accept(&g, &f), 0);
    assert_int_equal(hal_hil_guard_accept(&g, &f), -EALREADY); /* the same frame again */
    f.seq = 5;
    assert_int_equal(hal_hil_guard_accept(&g, &f), 0);
    f.seq = 4; /* late */
    assert_int_equal(hal_hil_guard_accept(&g, &f), -EALREADY);
    assert_int_equal(g.lost, 2);
    f.type = HAL_HIL_HELLO; /* a HELLO replayed in its own session opens nothing again */
    f.seq = 1;
    assert_int_equal(hal_hil_guard_accept(&g, &f), -EALREADY);
    f.type = HAL_HIL_SCAN; /* another session's frame: refused until its HELLO */
    f.session = 78;
    f.seq = 9;
    assert_int_equal(hal_hil_guard_accept(&g, &f), -ENOTCONN);
    f.type = HAL_HIL_HELLO; /* the peer restarted */
    f.seq = 1;
    assert_int_equal(hal_hil_guard_accept(&g, &f), 0);
    f.type = HAL_HIL_SCAN;
    f.seq = 2;
    assert_int_equal(hal_hil_guard_accept(&g, &f), 0);
    f.session = 77; /* the old session's frames are refused now */
    f.seq = 6;
    assert_int_equal(hal_hil_guard_accept(&g, &f), -ENOTCONN);
    assert_int_equal(g.sessions, 2);
    assert_int_equal(g.replayed, 3);
    assert_int_equal(g.unopened, 3);
}

/* A payload of `len` bytes from put, framed, parsed back. */
static hal_hil_frame_t framed(hal_hil_type_t t, int len)
{
    assert_true(len >= 0);
    const int n = hal_hil_encode(frame, sizeof frame, t, 1, 1, payload, (size_t)len);
    assert_true(n > 0);
    hal_hil_frame_t f;
    assert_int_equal(hal_hil_parse(frame, (size_t)n, &f), HAL_HIL_OK);
    return f;
}

static void test_payloads_round_trip_and_refuse(void **st)
{
    (void)st;
    /* HELLO */
    hal_hil_hello_t h = {3, 1000, "mps2-an500"}, h2;
    hal_hil_frame_t f = framed(HAL_HIL_HELLO, hal_hil_put_hello(payload, sizeof payload, &h));
    assert_int_equal(hal_hil_get_hello(&f, &h2), 0);
    assert_int_equal(h2.robot, 3);
    assert_int_equal(h2.rt_period_us, 1000);
    assert_string_equal(h2.board, "mps2-an500");
    payload[8 + 3] = '\n'; /* not printable */
    f = framed(HAL_HIL_HELLO, HAL_HIL_HELLO_BYTES);
    assert_int_equal(hal_hil_get_hello(&f, &h2), -EBADMSG);
    f.type = HAL_HIL_POSE;
    assert_int_equal(hal_hil_get_hello(&f, &h2), -EBADMSG);
    hal_hil_hello_t empty = {3, 1000, ""};
    assert_int_equal(hal_hil_put_hello(payload, sizeof payload, &empty), -EINVAL);

    /* SCAN: the full beam count and one; NaN, a count past the board's, a wrong length */
    static hal_lidar_scan_t s, s2;
    s = test_scan(HAL_LIDAR_MAX_BEAMS);
    const int sl = hal_hil_put_scan(payload, sizeof payload, &s);
    assert_int_equal(sl, (int)HAL_HIL_SCAN_PAYLOAD_MAX);
    f = framed(HAL_HIL_SCAN, sl);
    assert_int_equal(hal_hil_get_scan(&f, &s2), 0);
    assert_int_equal(s2.count, s.count);
    assert_memory_equal(s2.ranges_m, s.ranges_m, sizeof s.ranges_m);
    assert_true(s2.stamp_us == s.stamp_us && s2.angle_step_rad == s.angle_step_rad);
    s = test_scan(1);
    f = framed(HAL_HIL_SCAN, hal_hil_put_scan(payload, sizeof payload, &s));
    assert_int_equal(hal_hil_get_scan(&f, &s2), 0);
    assert_int_equal(s2.count, 1);
    le_put_f32(payload + 26, NAN);
    f = framed(HAL_HIL_SCAN, 30);
    assert_int_equal(hal_hil_get_scan(&f, &s2), -EBADMSG);
    le_put_f32(payload + 26, -INFINITY);
    f = framed(HAL_HIL_SCAN, 30);
    assert_int_equal(hal_hil_get_scan(&f, &s2), -EBADMSG);
    le_put_f32(payload + 26, 1.0f);
    f = framed(HAL_HIL_SCAN, 29); /* one byte short */
    assert_int_equal(hal_hil_get_scan(&f, &s2), -EBADMSG);
    le_put_u16(payload + 24, 0);
    f = framed(HAL_HIL_SCAN, 26);
    assert_int_equal(hal_hil_get_scan(&f, &s2), -EBADMSG);
    s = test_scan(HAL_LIDAR_MAX_BEAMS);
    (void)hal_hil_put_scan(payload, sizeof payload, &s);
    le_put_u16(payload + 24, (uint16_t)(HAL_LIDAR_MAX_BEAMS + 1u));
    f = framed(HAL_HIL_SCAN, (int)(26u + 4u * (HAL_LIDAR_MAX_BEAMS + 1u) <= HAL_HIL_PAYLOAD_MAX
                                       ? 26u + 4u * (HAL_LIDAR_MAX_BEAMS + 1u) : HAL_HIL_SCAN_PAYLOAD_MAX));
    assert_int_equal(hal_hil_get_scan(&f, &s2), -EBADMSG);
    s.range_max_m = s.range_min_m;
    assert_int_equal(hal_hil_put_scan(payload, sizeof payload, &s), -EINVAL);
    s = test_scan(10);
    assert_int_equal(hal_hil_put_scan(payload, 40, &s), -EMSGSIZE);

    /* POSE */
    hal_pose_t p = {42, 1.5f, -2.25f, 3.14159265f}, p2;
    f = framed(HAL_HIL_POSE, hal_hil_put_pose(payload, sizeof payload, &p));
    assert_int_equal(hal_hil_get_pose(&f, &p2), 0);
    assert_true(p2.x_m == p.x_m && p2.y_m == p.y_m && p2.heading_rad == p.heading_rad && p2.stamp_us == 42);
    le_put_f32(payload + 16, 4.0f);
    f = framed(HAL_HIL_POSE, HAL_HIL_POSE_BYTES);
    assert_int_equal(hal_hil_get_pose(&f, &p2), -EBADMSG);
    p.x_m = INFINITY;
    assert_int_equal(hal_hil_put_pose(payload, sizeof payload, &p), -EINVAL);

    /* WHEELS */
    hal_hil_wheels_t w = {7, 2.5f, -1.0f}, w2;
    f = framed(HAL_HIL_WHEELS, hal_hil_put_wheels(payload, sizeof payload, &w));
    assert_int_equal(hal_hil_get_wheels(&f, &w2), 0);
    assert_true(w2.left_rad_s == 2.5f && w2.right_rad_s == -1.0f && w2.stamp_us == 7);
    le_put_f32(payload + 8, NAN);
    f = framed(HAL_HIL_WHEELS, HAL_HIL_WHEELS_BYTES);
    assert_int_equal(hal_hil_get_wheels(&f, &w2), -EBADMSG);

    /* DATAGRAM */
    static const uint8_t dg[5] = {1, 2, 3, 4, 5};
    hal_hil_datagram_t d;
    f = framed(HAL_HIL_DATAGRAM, hal_hil_put_datagram(payload, sizeof payload, "fleetsim/3/state", dg, 5));
    assert_int_equal(hal_hil_get_datagram(&f, &d), 0);
    assert_string_equal(d.channel, "fleetsim/3/state");
    assert_int_equal(d.len, 5);
    assert_memory_equal(d.data, dg, 5);
    payload[4] = '\0'; /* a NUL inside the channel */
    f = framed(HAL_HIL_DATAGRAM, 1 + 16 + 5);
    assert_int_equal(hal_hil_get_datagram(&f, &d), -EBADMSG);
    payload[4] = ' '; /* not a channel character */
    f = framed(HAL_HIL_DATAGRAM, 1 + 16 + 5);
    assert_int_equal(hal_hil_get_datagram(&f, &d), -EBADMSG);
    payload[0] = 40; /* the channel runs past the payload */
    f = framed(HAL_HIL_DATAGRAM, 1 + 16 + 5);
    assert_int_equal(hal_hil_get_datagram(&f, &d), -EBADMSG);
    payload[0] = 0;
    f = framed(HAL_HIL_DATAGRAM, 8);
    assert_int_equal(hal_hil_get_datagram(&f, &d), -EBADMSG);
    assert_int_equal(hal_hil_put_datagram(payload, sizeof payload, "bad channel", dg, 5), -EINVAL);
    assert_int_equal(hal_hil_put_datagram(payload, sizeof payload, "ok", dg, HAL_NET_MTU_BYTES + 1u), -EMSGSIZE);

    /* SUBSCRIBE: a channel alone */
    char ch[HAL_NET_CHANNEL_MAX];
    f = framed(HAL_HIL_SUBSCRIBE, hal_hil_put_subscribe(payload, sizeof payload, "fleetsim/3/state"));
    assert_int_equal(hal_hil_get_subscribe(&f, ch), 0);
    assert_string_equal(ch, "fleetsim/3/state");
    f = framed(HAL_HIL_SUBSCRIBE, hal_hil_put_datagram(payload, sizeof payload, "fleetsim/3/state", dg, 5));
    assert_int_equal(hal_hil_get_subscribe(&f, ch), -EBADMSG); /* bytes after the channel */
    f.type = HAL_HIL_DATAGRAM;
    assert_int_equal(hal_hil_get_subscribe(&f, ch), -EBADMSG);
    assert_int_equal(hal_hil_put_subscribe(payload, sizeof payload, "bad channel"), -EINVAL);

    /* WORLD */
    const hal_hil_world_t wd = {-1.0f, -2.0f, 12.0f, 9.0f, 10000, 100000};
    hal_hil_world_t wd2;
    f = framed(HAL_HIL_WORLD, hal_hil_put_world(payload, sizeof payload, &wd));
    assert_int_equal(hal_hil_get_world(&f, &wd2), 0);
    assert_memory_equal(&wd, &wd2, sizeof wd);
    le_put_f32(payload, 20.0f); /* min above max */
    f = framed(HAL_HIL_WORLD, HAL_HIL_WORLD_BYTES);
    assert_int_equal(hal_hil_get_world(&f, &wd2), -EBADMSG);
    const hal_hil_world_t no_step = {0, 0, 1, 1, 0, 1};
    assert_int_equal(hal_hil_put_world(payload, sizeof payload, &no_step), -EINVAL);

    /* TICK */
    const hal_hil_tick_t tk = {123456789012ull, 99ull, 7u};
    hal_hil_tick_t tk2;
    f = framed(HAL_HIL_TICK, hal_hil_put_tick(payload, sizeof payload, &tk));
    assert_int_equal(hal_hil_get_tick(&f, &tk2), 0);
    assert_true(tk2.stamp_us == 123456789012ull && tk2.scan_held == 99ull && tk2.datagram_room == 7u);
    f = framed(HAL_HIL_TICK, 16);
    assert_int_equal(hal_hil_get_tick(&f, &tk2), -EBADMSG);
    f.type = HAL_HIL_WHEELS;
    assert_int_equal(hal_hil_get_tick(&f, &tk2), -EBADMSG);
}

/* ---- the board's end (hal_hil_client) against a scripted world -------------------------------- */
typedef struct fake_world {
    int stream;           /* hand the answers out as bytes in 7-byte pieces */
    int drop_answers;     /* answers to drop (a lossy link) */
    int noise;            /* garbage bytes before every answer (stream) */
    uint32_t seq;
    uint64_t ticks_seen, wheels_seen, scans_sent, datagrams_seen, subscribes_seen;
    int fleet_waiting;    /* datagrams the fleet sent the board, not yet in an answer */
    float last_left;
    uint8_t q[16384];     /* what the board will receive */
    size_t q_n, q_at;
    size_t dgram_len[64]; /* datagram mode: the frames' lengths, in order */
    int dg_n, dg_at;
} fake_world_t;

static fake_world_t fw;

static void world_says(hal_hil_type_t type, const uint8_t *p, int len)
{
    uint8_t f[HAL_HIL_FRAME_MAX];
    const int n = hal_hil_encode(f, sizeof f, type, 0x5EED, ++fw.seq, p, (size_t)len);
    assert_true(n > 0 && fw.q_n + (size_t)n + 16u < sizeof fw.q);
    if (fw.stream && fw.noise)
        for (int i = 0; i < 5; i++)
            fw.q[fw.q_n++] = i == 2 ? HAL_HIL_MAGIC0 : (uint8_t)(0x30 + i);
    memcpy(fw.q + fw.q_n, f, (size_t)n);
    fw.q_n += (size_t)n;
    if (!fw.stream)
        fw.dgram_len[fw.dg_n++] = (size_t)n;
}

static int fake_send(void *ctx, const uint8_t *bytes, size_t n)
{
    (void)ctx;
    hal_hil_frame_t f;
    assert_int_equal(hal_hil_parse(bytes, n, &f), HAL_HIL_OK);
    uint8_t p[HAL_HIL_PAYLOAD_MAX];
    if (f.type == HAL_HIL_HELLO) {
        const hal_hil_hello_t h = {0, 1, "fake"};
        world_says(HAL_HIL_HELLO, p, hal_hil_put_hello(p, sizeof p, &h));
        const hal_hil_world_t w = {0, 0, 10, 8, 10000, 100000};
        world_says(HAL_HIL_WORLD, p, hal_hil_put_world(p, sizeof p, &w));
    } else if (f.type == HAL_HIL_TICK) {
        hal_hil_tick_t tk;
        assert_int_equal(hal_hil_get_tick(&f, &tk), 0);
        const uint64_t t = tk.stamp_us;
        fw.ticks_seen++;
        if (fw.drop_answers > 0) {
            fw.drop_answers--;
            return 0;
        }
        hal_lidar_scan_t scan = test_scan(90); /* a new scan every 100 ms */
        scan.stamp_us = t - t % 100000u;
        if (scan.stamp_us + 1u != tk.scan_held) {
            world_says(HAL_HIL_SCAN, p, hal_hil_put_scan(p, sizeof p, &scan));
            fw.scans_sent++;
        }
        for (uint32_t k = 0; k < tk.datagram_room && fw.fleet_waiting > 0; k++, fw.fleet_waiting--) {
            const uint8_t byte = (uint8_t)fw.fleet_waiting;
            world_says(HAL_HIL_DATAGRAM, p, hal_hil_put_datagram(p, sizeof p, "fleetsim/0/state", &byte, 1));
        }
        const hal_pose_t pose = {t, 1.0f + (float)t * 1e-6f, 2.0f, 0.5f};
        world_says(HAL_HIL_POSE, p, hal_hil_put_pose(p, sizeof p, &pose));
    } else if (f.type == HAL_HIL_WHEELS) {
        hal_hil_wheels_t w;
        assert_int_equal(hal_hil_get_wheels(&f, &w), 0);
        fw.wheels_seen++;
        fw.last_left = w.left_rad_s;
    } else if (f.type == HAL_HIL_DATAGRAM) {
        hal_hil_datagram_t d;
        assert_int_equal(hal_hil_get_datagram(&f, &d), 0);
        fw.datagrams_seen++;
    } else if (f.type == HAL_HIL_SUBSCRIBE) {
        char ch[HAL_NET_CHANNEL_MAX];
        assert_int_equal(hal_hil_get_subscribe(&f, ch), 0);
        fw.subscribes_seen++;
    }
    return 0;
}

static int fake_recv(void *ctx, uint8_t *buf, size_t cap, uint32_t timeout_us)
{
    (void)ctx, (void)timeout_us;
    if (fw.stream) {
        size_t n = fw.q_n - fw.q_at < 7u ? fw.q_n - fw.q_at : 7u;
        if (n > cap)
            n = cap;
        memcpy(buf, fw.q + fw.q_at, n);
        fw.q_at += n;
        return (int)n;
    }
    if (fw.dg_at == fw.dg_n)
        return 0; /* the timeout */
    const size_t n = fw.dgram_len[fw.dg_at++];
    assert_true(n <= cap);
    memcpy(buf, fw.q + fw.q_at, n);
    fw.q_at += n;
    return (int)n;
}

static int got_datagrams;

static void count_datagram(void *ctx, const hal_hil_datagram_t *d)
{
    assert_string_equal(d->channel, "fleetsim/0/state");
    assert_int_equal(d->len, 1);
    (*(int *)ctx)++;
}

static void client_round(int stream)
{
    static hal_hil_client_t c;
    memset(&fw, 0, sizeof fw);
    fw.stream = stream;
    fw.noise = stream;
    const hal_hil_port_t port = {NULL, stream, fake_send, fake_recv, 0};
    assert_int_equal(hal_hil_client_init(&c, &port, 0, 20000, 77, "test", 1000, 3), 0);
    assert_int_equal(hal_hil_client_connect(&c), 0);
    assert_true(c.world.max_x == 10.0f && c.world.step_us == 10000u);
    assert_int_equal(hal_hil_client_tick(&c, 20000), 0);
    assert_true(c.pose.stamp_us == 20000u && c.scan.count == 90u && c.scan.stamp_us == 0u);
    assert_int_equal(fw.scans_sent, 1);
    fw.drop_answers = 2; /* two TICKs lost: the third gets through */
    assert_int_equal(hal_hil_client_tick(&c, 40000), 0);
    assert_true(c.pose.stamp_us == 40000u);
    assert_int_equal(c.stats.resent_ticks, 2);
    assert_int_equal(fw.scans_sent, 1); /* the board holds the world's latest: not sent again */
    fw.drop_answers = 3; /* all three lost: the link is down */
    assert_int_equal(hal_hil_client_tick(&c, 60000), -ETIMEDOUT);
    assert_true(c.pose.stamp_us == 40000u); /* what was held stays */
    assert_int_equal(hal_hil_client_wheels(&c, 60000, 1.5f, 1.0f), 0);
    assert_true(fw.wheels_seen == 1 && fw.last_left == 1.5f);
    assert_int_equal(hal_hil_client_wheels(&c, 60000, NAN, 1.0f), -EINVAL);
    assert_int_equal(hal_hil_client_tick(&c, 120000), 0); /* a newer scan: it comes before the pose */
    assert_true(c.pose.stamp_us == 120000u && c.scan.stamp_us == 100000u);
    assert_int_equal(fw.scans_sent, 2);

    /* The fleet's datagrams: as many as the board has room for in each answer, to its sink. */
    fw.fleet_waiting = 5;
    c.on_datagram = count_datagram;
    c.datagram_ctx = &got_datagrams;
    got_datagrams = 0;
    c.datagram_room = 3;
    assert_int_equal(hal_hil_client_tick(&c, 140000), 0);
    assert_true(got_datagrams == 3 && c.stats.datagrams_in == 3 && fw.fleet_waiting == 2);
    assert_int_equal(hal_hil_client_tick(&c, 160000), 0);
    assert_true(got_datagrams == 5 && fw.fleet_waiting == 0);
    /* A port whose receiver holds fewer (an Ethernet FIFO) caps every TICK's room. */
    fw.fleet_waiting = 4;
    c.port.answer_datagrams_max = 1;
    assert_int_equal(hal_hil_client_tick(&c, 180000), 0);
    assert_true(got_datagrams == 6 && fw.fleet_waiting == 3);
    c.port.answer_datagrams_max = 0;
    assert_int_equal(hal_hil_client_tick(&c, 200000), 0);
    assert_true(got_datagrams == 9 && fw.fleet_waiting == 0);
    static const uint8_t out[3] = {9, 8, 7};
    assert_int_equal(hal_hil_client_datagram(&c, "fleetsim/1/state", out, sizeof out), 0);
    assert_int_equal(fw.datagrams_seen, 1);
    assert_int_equal(hal_hil_client_datagram(&c, "not a channel", out, sizeof out), -EINVAL);
    assert_int_equal(hal_hil_client_init(&c, &port, 0, 20000, 77, "", 1000, 3), -EINVAL);
}

static void test_client_against_a_scripted_world(void **st)
{
    (void)st;
    client_round(0); /* datagrams */
    client_round(1); /* a stream in 7-byte pieces, noise before every frame */
}

/* The stdc back end's network over the link (hal_stdc_install_hil with a net): what the GP core
 * publishes and subscribes waits in the out ring until the RT core's next reading talks to the
 * world; the fleet's datagrams of that TICK's answer wait in the in ring for hal_net_receive;
 * a full out ring refuses a publish. */
static void test_stdc_net_over_the_link(void **st)
{
    (void)st;
    static hal_hil_client_t c;
    static hal_stdc_hil_net_t net;
    memset(&fw, 0, sizeof fw);
    const hal_hil_port_t port = {NULL, 0, fake_send, fake_recv, 0};
    assert_int_equal(hal_hil_client_init(&c, &port, 0, 20000, 78, "test", 1000, 3), 0);
    assert_int_equal(hal_hil_client_connect(&c), 0);
    assert_int_equal(hal_stdc_install_hil("", &c, 1, &net), 0);
    assert_int_equal(hal_net_subscribe("fleetsim/0/state"), 0);
    static const uint8_t msg[3] = {4, 5, 6};
    assert_int_equal(hal_net_publish("fleetsim/1/state", msg, sizeof msg), 0);
    assert_true(fw.subscribes_seen == 0 && fw.datagrams_seen == 0); /* not before the RT core talks */
    fw.fleet_waiting = 3;
    hal_pose_t p;
    assert_int_equal(hal_pose_read(&p), 0);
    assert_true(fw.subscribes_seen == 1 && fw.datagrams_seen == 1 && fw.fleet_waiting == 0);
    hal_net_rx_info_t info;
    uint8_t buf[16];
    for (int k = 0; k < 3; k++) {
        assert_int_equal(hal_net_receive(&info, buf, sizeof buf), 0);
        assert_string_equal(info.channel, "fleetsim/0/state");
        assert_int_equal(info.len, 1);
    }
    assert_int_equal(hal_net_receive(&info, buf, sizeof buf), -EAGAIN);
    for (uint32_t k = 0; k < HAL_STDC_HIL_QUEUE; k++)
        assert_int_equal(hal_net_publish("fleetsim/1/state", msg, sizeof msg), 0);
    assert_int_equal(hal_net_publish("fleetsim/1/state", msg, sizeof msg), -EIO);
    hal_net_stats_t ns;
    assert_int_equal(hal_net_get_stats(&ns), 0);
    assert_true(ns.tx_rejected == 1 && ns.rx_messages == 3 && ns.queue_depth == HAL_STDC_HIL_QUEUE);
    hal_stdc_uninstall();
}

/* Random and mutated bytes into both readers: no crash, no overread (ASan), and every frame
 * either reader hands out is one whose CRC checks. */
static void test_fuzz_readers(void **st)
{
    (void)st;
    static hal_hil_stream_t s;
    hal_hil_stream_init(&s);
    int ok = 0, refused = 0;
    for (int it = 0; it < 20000; it++) {
        int n = make_frame((hal_hil_type_t)(1u + rnd() % 8u), (uint32_t)it, rnd() % 64u, (uint8_t)it);
        const int flips = (int)(rnd() % 3u);
        for (int k = 0; k < flips; k++)
            frame[rnd() % (uint32_t)n] ^= (uint8_t)(1u << (rnd() % 8u));
        if (rnd() % 4u == 0)
            n = (int)(rnd() % (uint32_t)(n + 8));
        hal_hil_frame_t f;
        if (hal_hil_parse(frame, (size_t)n, &f) == HAL_HIL_OK) {
            ok++;
            assert_true(f.len + HAL_HIL_OVERHEAD_BYTES == (size_t)n);
        } else {
            refused++;
        }
        for (size_t at = 0; at < (size_t)n;) {
            int got = 0;
            at += hal_hil_stream_feed(&s, frame + at, (size_t)n - at, &f, &got);
            if (got)
                assert_true(le_get_u32(f.payload + f.len) == crc32_ieee(f.payload - HAL_HIL_HEADER_BYTES,
                                                                         HAL_HIL_HEADER_BYTES + f.len));
        }
    }
    print_message("fuzz: %d frames parsed, %d refused; the stream handed out %llu\n", ok, refused,
                  (unsigned long long)s.frames);
    assert_true(ok > 1000 && refused > 1000 && s.frames > 1000);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_datagram_round_trip),
        cmocka_unit_test(test_datagram_refusals),
        cmocka_unit_test(test_stream_finds_every_frame_through_noise),
        cmocka_unit_test(test_stream_refuses_and_goes_on),
        cmocka_unit_test(test_guard_refuses_replays_and_unopened_sessions),
        cmocka_unit_test(test_payloads_round_trip_and_refuse),
        cmocka_unit_test(test_client_against_a_scripted_world),
        cmocka_unit_test(test_stdc_net_over_the_link),
        cmocka_unit_test(test_fuzz_readers),
    };
    return cmocka_run_group_tests_name("hal/hil_link", tests, NULL, NULL);
}
