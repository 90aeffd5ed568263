/* The RT core's exploration mode (rt/rt_explore.h) without the RT core: a synthetic scan
 * marks the cells it passed free and its hits occupied (once per scan, hits first); the
 * coarse seen view against brute force and its once-a-second rule; a goal behind a wall in a
 * room the robot has not seen yet is reached around the wall, with a unicycle integrator and a
 * ray-cast lidar in this file (no ODE), the robot never closer to a wall than its radius; a
 * robot that does not move is found stuck, backs off, re-plans, and gives the goal up after
 * max_stuck; a plan failure gives the goal up; a door the grid narrowed below the clearance
 * band is left through the tight band; a keep-in fence keeps the robot out of the cells it
 * fences, whatever the scans see; GP_GOAL_MSG_DONE and the budget stop it; the
 * configuration is checked; two runs give the same bytes; nothing is allocated. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "rt/rt_explore.h"

#define PI_F 3.14159265358979f
#define PERIOD_US 20000u
#define DT_S 0.02f

static rt_explore_t ex;
static rt_seen_t seen;

/* ---- the synthetic room: 6 x 4 m at 0.05 m, walls 0.1 m thick around, and an inner wall at
 * x = 2.95 .. 3.05 from the floor up to y = 3.0 (a 0.9 m gap above it). ---------------------- */
#define ROOM_RES 0.05f
#define ROOM_W 120
#define ROOM_H 80
static uint8_t room[ROOM_W * ROOM_H];

static void room_build(void)
{
    memset(room, 0, sizeof room);
    for (int r = 0; r < ROOM_H; r++)
        for (int c = 0; c < ROOM_W; c++) {
            int border = c < 2 || r < 2 || c >= ROOM_W - 2 || r >= ROOM_H - 2;
            int inner = (c == 59 || c == 60) && r < 60;
            room[r * ROOM_W + c] = (uint8_t)(border || inner);
        }
}

static int room_wall(float x, float y)
{
    int c = (int)floorf(x / ROOM_RES), r = (int)floorf(y / ROOM_RES);
    if (c < 0 || r < 0 || c >= ROOM_W || r >= ROOM_H)
        return 1;
    return room[r * ROOM_W + c];
}

/* Distance from (x, y) to the nearest wall square within 0.5 m (0.5 when none). */
static float room_clearance(float x, float y)
{
    float best = 0.5f;
    int c0 = (int)floorf((x - 0.5f) / ROOM_RES), c1 = (int)floorf((x + 0.5f) / ROOM_RES);
    int r0 = (int)floorf((y - 0.5f) / ROOM_RES), r1 = (int)floorf((y + 0.5f) / ROOM_RES);
    for (int r = r0; r <= r1; r++)
        for (int c = c0; c <= c1; c++) {
            if (c >= 0 && r >= 0 && c < ROOM_W && r < ROOM_H && !room[r * ROOM_W + c])
                continue;
            float lx = (float)c * ROOM_RES, ly = (float)r * ROOM_RES;
            float dx = fmaxf(fmaxf(lx - x, 0.0f), x - (lx + ROOM_RES));
            float dy = fmaxf(fmaxf(ly - y, 0.0f), y - (ly + ROOM_RES));
            best = fminf(best, sqrtf(dx * dx + dy * dy));
        }
    return best;
}

#define N_BEAMS 180
#define RANGE_MAX 3.5f
static float ranges[N_BEAMS];

/* A lidar at (x, y, th): beams from -pi every 2 pi / N_BEAMS, marched in 1 cm steps. */
static rt_scan_view_t room_scan(float x, float y, float th)
{
    const float inc = 2.0f * PI_F / (float)N_BEAMS;
    for (int i = 0; i < N_BEAMS; i++) {
        float a = th - PI_F + (float)i * inc, dx = cosf(a), dy = sinf(a);
        ranges[i] = INFINITY;
        for (float t = 0.01f; t < RANGE_MAX; t += 0.01f)
            if (room_wall(x + t * dx, y + t * dy)) {
                ranges[i] = t;
                break;
            }
    }
    rt_scan_view_t v = {ranges, N_BEAMS, -PI_F, inc, RANGE_MAX};
    return v;
}

static rt_explore_cfg_t room_cfg(void)
{
    rt_explore_cfg_t c = rt_explore_default_cfg();
    c.res_m = ROOM_RES;
    c.w = ROOM_W;
    c.h = ROOM_H;
    c.seen_factor = 4;
    c.seen_w = ROOM_W / 4;
    c.seen_h = ROOM_H / 4;
    return c;
}

static gp_goal_msg_t go(uint32_t seq, float x, float y)
{
    gp_goal_msg_t g = {.stamp_us = 0, .seq = seq, .mode = GP_GOAL_MSG_GO, .x_m = x, .y_m = y};
    return g;
}

/* ---- scan integration ---------------------------------------------------------------------- */

static uint8_t occ_at(int c, int r) { return ex.grid.occ[r * ex.grid.w + c]; }
static uint8_t known_at(int c, int r) { return ex.grid.known[r * ex.grid.w + c]; }

static void test_scan_marks_free_and_occupied(void **st)
{
    (void)st;
    rt_explore_cfg_t c = rt_explore_default_cfg();
    c.res_m = 0.1f;
    c.w = c.h = 40;
    c.seen_factor = 10;
    c.seen_w = c.seen_h = 4;
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    /* From the centre of cell (10, 10), heading 0: east hits at 1 m, north has no return
     * (range_max 2 m), west dropped out, south hits at 0.5 m. */
    float r4[4] = {1.0f, INFINITY, NAN, 0.5f};
    rt_scan_view_t v = {r4, 4, 0.0f, PI_F / 2.0f, 2.0f};
    int changed = rt_explore_integrate_scan(&ex, &v, 1.05f, 1.05f, 0.0f, 777);
    assert_true(changed > 0);
    for (int col = 10; col < 20; col++) /* east: free up to the hit */
        assert_true(known_at(col, 10) == 1 && occ_at(col, 10) == 128 - 16);
    assert_true(known_at(20, 10) == 1 && occ_at(20, 10) == 128 + 64);
    assert_int_equal(known_at(21, 10), 0);
    for (int row = 11; row <= 30; row++) /* north: free up to range_max, end cell included */
        assert_true(known_at(10, row) == 1 && occ_at(10, row) == 112);
    assert_int_equal(known_at(10, 31), 0);
    for (int col = 0; col < 10; col++) /* west: NaN says nothing */
        assert_int_equal(known_at(col, 10), 0);
    for (int row = 6; row < 10; row++)
        assert_int_equal(occ_at(10, row), 112);
    assert_int_equal(occ_at(10, 5), 192);
    /* Every cell once: 10 + 1 east (the start cell among them), 20 north, 4 + 1 south. */
    assert_int_equal(changed, 11 + 20 + 5);
    int n_known = 0;
    for (int i = 0; i < 40 * 40; i++)
        n_known += ex.grid.known[i] != 0;
    assert_int_equal(n_known, changed);
    /* The same scan again: hits saturate at 255, misses go on down. */
    assert_int_equal(rt_explore_integrate_scan(&ex, &v, 1.05f, 1.05f, 0.0f, 778), changed);
    assert_int_equal(occ_at(20, 10), 255);
    assert_int_equal(occ_at(15, 10), 96);
    assert_int_equal(known_at(15, 10), 2);
    /* Two beams along the same line in one scan: the cell one hits and the other passes is
     * hit (hits win within a scan), and each cell counts once. */
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    float r2[2] = {1.0f, 2.0f};
    rt_scan_view_t v2 = {r2, 2, 0.0f, 0.0f, 3.0f};
    assert_true(rt_explore_integrate_scan(&ex, &v2, 1.05f, 1.05f, 0.0f, 1) > 0);
    assert_int_equal(occ_at(20, 10), 192);
    assert_int_equal(occ_at(30, 10), 192);
    assert_int_equal(occ_at(25, 10), 112);
    assert_int_equal(known_at(12, 10), 1);
    /* Bad scans. */
    rt_scan_view_t bad = v2;
    bad.range_max = 0.0f;
    assert_int_equal(rt_explore_integrate_scan(&ex, &bad, 1.0f, 1.0f, 0.0f, 1), -EINVAL);
    assert_int_equal(rt_explore_integrate_scan(&ex, &v2, NAN, 1.0f, 0.0f, 1), -EINVAL);
    assert_int_equal(rt_explore_integrate_scan(NULL, &v2, 1.0f, 1.0f, 0.0f, 1), -EINVAL);
    /* A pose outside the grid still marks the cells inside the grid the beam crosses. */
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    float r1[1] = {2.95f}; /* from x = -1 to 1.95: cells 0 .. 18 free, 19 hit */
    rt_scan_view_t v1 = {r1, 1, 0.0f, 0.0f, 3.5f};
    assert_int_equal(rt_explore_integrate_scan(&ex, &v1, -1.0f, 0.55f, 0.0f, 1), 20);
    assert_int_equal(occ_at(19, 5), 192);
    assert_int_equal(occ_at(0, 5), 112);
}

static void test_seen_view(void **st)
{
    (void)st;
    rt_explore_cfg_t c = rt_explore_default_cfg();
    c.res_m = 0.1f;
    c.w = 38; /* the coarse grid overhangs the fine one: those fine cells count as observed walls */
    c.h = 40;
    c.seen_factor = 10;
    c.seen_w = c.seen_h = 4;
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    assert_int_equal(rt_explore_seen(&ex, 0, &seen), 0); /* nothing observed: not due */
    float r[36];
    for (int i = 0; i < 36; i++)
        r[i] = i % 3 == 0 ? INFINITY : 0.4f + 0.05f * (float)(i % 7);
    rt_scan_view_t v = {r, 36, -PI_F, 2.0f * PI_F / 36.0f, 2.5f};
    assert_true(rt_explore_integrate_scan(&ex, &v, 1.55f, 2.05f, 0.3f, 5000) > 0);
    assert_int_equal(rt_explore_seen(&ex, 100000, &seen), 1);
    assert_int_equal(seen.w, 4);
    assert_int_equal(seen.h, 4);
    assert_int_equal(seen.updates, 1);
    assert_int_equal(seen.stamp_us, 5000);
    int any_occ = 0;
    for (int cy = 0; cy < 4; cy++)
        for (int cx = 0; cx < 4; cx++) {
            unsigned obs = 0, occ = 0;
            for (int fy = cy * 10; fy < cy * 10 + 10; fy++)
                for (int fx = cx * 10; fx < cx * 10 + 10; fx++) {
                    if (fx >= c.w || fy >= c.h) { /* outside the map */
                        obs++;
                        occ++;
                        continue;
                    }
                    if (!known_at(fx, fy))
                        continue;
                    obs++;
                    occ += occ_at(fx, fy) >= c.plan.occ_threshold;
                }
            unsigned want_occ = obs ? (unsigned)lround(255.0 * occ / obs) : 0u;
            unsigned want_unk = (unsigned)lround(255.0 * (100 - obs) / 100.0);
            assert_int_equal(seen.occ[cy * 4 + cx], want_occ);
            assert_int_equal(seen.unknown[cy * 4 + cx], want_unk);
            any_occ |= occ > 0;
        }
    assert_true(any_occ);
    /* The last column's coarse cells, 2 of 10 fine columns beyond the grid, are a fifth
       known wall however little the scan saw of them. */
    for (int cy = 0; cy < 4; cy++)
        assert_true(seen.unknown[cy * 4 + 3] <= 204 && seen.occ[cy * 4 + 3] >= 51);
    /* Changed again within the second: not due; after it: due; unchanged: never due. */
    assert_true(rt_explore_integrate_scan(&ex, &v, 1.05f, 1.05f, 0.0f, 6000) > 0);
    assert_int_equal(rt_explore_seen(&ex, 1099999, &seen), 0);
    assert_int_equal(rt_explore_seen(&ex, 1100000, &seen), 1);
    assert_int_equal(seen.updates, 2);
    assert_int_equal(seen.stamp_us, 6000);
    assert_int_equal(rt_explore_seen(&ex, 9000000, &seen), 0);
}

/* ---- driving in the room -------------------------------------------------------------------- */

typedef struct run_out {
    float x, y, th;
    float min_clear;
    float max_x, max_y;
    int64_t reached_tick; /* 64 bits: no padding before hash (the runs are compared byte for byte) */
    uint64_t hash;
} run_out_t;

static uint64_t fnv(uint64_t h, const void *p, size_t n)
{
    const uint8_t *b = p;
    for (size_t i = 0; i < n; i++)
        h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

/* From (1, 1) facing east to a goal behind the inner wall, the room unseen at first; keep_in:
 * the fence (NULL: none). */
static run_out_t run_room(int max_ticks, const uint8_t *keep_in)
{
    room_build();
    rt_explore_cfg_t c = room_cfg();
    c.keep_in = keep_in;
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    const rt_follow_cfg_t fc = rt_follow_default_cfg();
    gp_goal_msg_t goal = go(1, 5.0f, 1.0f);
    run_out_t o = {1.0f, 1.0f, 0.0f, 1.0f, 0.0f, 0.0f, -1, 14695981039346656037ull};
    rt_scan_view_t v = {0};
    int have_scan = 0;
    for (int k = 0; k < max_ticks; k++) {
        uint64_t now = (uint64_t)k * PERIOD_US;
        assert_int_equal(rt_explore_clock(&ex, now), 0);
        if (k % 5 == 0) {
            v = room_scan(o.x, o.y, o.th);
            have_scan = 1;
            assert_true(rt_explore_integrate_scan(&ex, &v, o.x, o.y, o.th, now) >= 0);
        }
        rt_follow_cmd_t cmd;
        assert_int_equal(rt_explore_step(&ex, &goal, o.x, o.y, o.th, have_scan ? &v : NULL, now,
                                         &fc, &cmd), 0);
        o.hash = fnv(o.hash, &cmd, sizeof cmd);
        if (ex.goal_reached == 1) {
            o.reached_tick = k;
            break;
        }
        /* Unicycle from the wheel rates the motors would get. */
        float vel = fc.wheel_radius * 0.5f * (cmd.wheel_left + cmd.wheel_right);
        float om = fc.wheel_radius * (cmd.wheel_right - cmd.wheel_left) / fc.wheel_separation;
        o.x += vel * cosf(o.th) * DT_S;
        o.y += vel * sinf(o.th) * DT_S;
        o.th = rt_wrap_angle(o.th + om * DT_S);
        o.min_clear = fminf(o.min_clear, room_clearance(o.x, o.y));
        o.max_x = fmaxf(o.max_x, o.x);
        o.max_y = fmaxf(o.max_y, o.y);
    }
    o.hash = fnv(o.hash, ex.grid.occ, (size_t)(ROOM_W * ROOM_H));
    o.hash = fnv(o.hash, ex.grid.known, (size_t)(ROOM_W * ROOM_H));
    return o;
}

static void test_goal_behind_wall_reached_around_it(void **st)
{
    (void)st;
    alloc_count_reset();
    run_out_t o = run_room(150 * 50, NULL); /* 150 s */
    assert_int_equal(alloc_count_allocations(), 0);
    assert_true(o.reached_tick > 0);
    assert_true(hypotf(o.x - 5.0f, o.y - 1.0f) <= 0.3f + 1e-3f);
    assert_true(o.max_y > 3.0f);               /* it went through the gap above the wall */
    /* Never nearer a wall than the burger's radius (0.105 m) plus most of the margin. */
    assert_true(o.min_clear > 0.15f);
    /* The first path took the wall's unseen far half for free space; seeing it re-planned. */
    assert_true(ex.plans >= 2);
    assert_int_equal(ex.plan_failures, 0);
    assert_int_equal(ex.goal_failed, 0);
    rt_status_t s;
    memset(&s, 0, sizeof s);
    rt_explore_status(&ex, &s);
    assert_int_equal(s.goal_seq, 1);
    assert_int_equal(s.goal_reached, 1);
    assert_int_equal(s.plans, ex.plans);
    /* Reached: the wheels stay at 0 until a new goal. */
    rt_follow_cmd_t cmd;
    gp_goal_msg_t goal = go(1, 5.0f, 1.0f);
    const rt_follow_cfg_t fc = rt_follow_default_cfg();
    assert_int_equal(rt_explore_step(&ex, &goal, o.x, o.y, o.th, NULL, 999000000ull, &fc, &cmd), 0);
    assert_true(cmd.v == 0.0f && cmd.wheel_left == 0.0f && cmd.wheel_right == 0.0f);
}

/* The keep-in fence: everything east of the inner wall (columns 61 on, x >= 3.05 m) is outside
 * the area to explore. The goal there is not driven to: the robot stops at the reachable cell
 * nearest it, west of the wall, and says reached; no scan through the gap wears the fence away;
 * the seen view has the fenced cells as observed wall from the start. */
static void test_fence_keeps_the_robot_in(void **st)
{
    (void)st;
    static uint8_t inside[ROOM_W * ROOM_H];
    for (int r = 0; r < ROOM_H; r++)
        for (int c = 0; c < ROOM_W; c++)
            inside[r * ROOM_W + c] = c <= 60;
    rt_explore_cfg_t c = room_cfg();
    c.keep_in = inside;
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    assert_int_equal(ex.fenced, (ROOM_W - 61) * ROOM_H);
    assert_int_equal(rt_explore_seen(&ex, 0, &seen), 1); /* due at once: the fence is news */
    for (uint32_t cy = 0; cy < seen.h; cy++)
        for (uint32_t cx = 0; cx < seen.w; cx++) {
            const uint32_t k = cy * seen.w + cx;
            if (cx * 4 >= 61) { /* wholly fenced: observed, and wall */
                assert_int_equal(seen.occ[k], 255);
                assert_int_equal(seen.unknown[k], 0);
            } else if (cx * 4 + 3 < 61) { /* wholly inside: never observed yet */
                assert_int_equal(seen.unknown[k], 255);
            }
        }
    alloc_count_reset();
    run_out_t o = run_room(150 * 50, inside);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_true(o.reached_tick > 0);                /* the nearest reachable cell */
    assert_true(o.max_x < 3.05f - 0.105f);          /* never into the fenced half, body included */
    assert_true(hypotf(o.x - 5.0f, o.y - 1.0f) > 2.0f);
    assert_int_equal(ex.goal_failed, 0);
    for (int r = 0; r < ROOM_H; r++)
        for (int cc = 61; cc < ROOM_W; cc++) {
            assert_int_equal(occ_at(cc, r), 255);
            assert_int_equal(known_at(cc, r), 255);
        }
    /* a cfg's keep_in is read at init only */
    assert_null(ex.cfg.keep_in);
}

static void test_deterministic(void **st)
{
    (void)st;
    run_out_t a = run_room(60 * 50, NULL);
    run_out_t b = run_room(60 * 50, NULL);
    assert_true(a.hash == b.hash);
    assert_memory_equal(&a, &b, sizeof a);
}

static void test_replans_when_path_blocked(void **st)
{
    (void)st;
    room_build();
    rt_explore_cfg_t c = room_cfg();
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    const rt_follow_cfg_t fc = rt_follow_default_cfg();
    gp_goal_msg_t goal = go(1, 5.0f, 1.0f);
    rt_follow_cmd_t cmd;
    /* Nothing seen: the straight line through the (unknown) wall. */
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, 0, &fc, &cmd), 0);
    assert_int_equal(ex.plans, 1);
    assert_int_equal(ex.plan_res.n_wps, 2);
    /* A scan that sees nothing in the way: no re-plan. */
    float r[8];
    for (int i = 0; i < 8; i++)
        r[i] = INFINITY;
    rt_scan_view_t free_scan = {r, 8, -PI_F, PI_F / 4.0f, 0.5f};
    assert_true(rt_explore_integrate_scan(&ex, &free_scan, 1.0f, 1.0f, 0.0f, 20000) > 0);
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, &free_scan, 20000, &fc, &cmd), 0);
    assert_int_equal(ex.plans, 1);
    /* The wall seen: re-planned over it, through the gap. */
    rt_scan_view_t v = room_scan(1.0f, 1.0f, 0.0f);
    assert_true(rt_explore_integrate_scan(&ex, &v, 1.0f, 1.0f, 0.0f, 40000) > 0);
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, &v, 40000, &fc, &cmd), 0);
    assert_int_equal(ex.plans, 2);
    assert_int_equal(ex.state, RT_EXPLORE_DRIVE);
    float top = 0.0f;
    for (int i = 0; i < ex.plan_res.n_wps; i++)
        top = fmaxf(top, ex.plan_res.wps[i].y);
    assert_true(top > 3.0f);
    /* Checked once per scan: without a new scan, no new check. */
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, &v, 60000, &fc, &cmd), 0);
    assert_int_equal(ex.plans, 2);
}

/* ---- recovery ------------------------------------------------------------------------------- */

static void test_stuck_backs_off_replans_and_gives_up(void **st)
{
    (void)st;
    rt_explore_cfg_t c = room_cfg();
    c.stuck_window_s = 1.0f;
    c.backoff_s = 0.5f;
    c.max_stuck = 3;
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    const rt_follow_cfg_t fc = rt_follow_default_cfg();
    gp_goal_msg_t goal = go(7, 2.0f, 1.0f);
    rt_follow_cmd_t cmd;
    int backing = 0, backoffs = 0, forward = 0;
    uint64_t k = 0;
    /* The pose never moves: a wheel slipping on the spot. */
    for (; k < 10 * 50 && ex.goal_failed == 0; k++) {
        assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, k * PERIOD_US, &fc, &cmd), 0);
        if (cmd.v < 0.0f) {
            assert_true(fabsf(cmd.v - c.backoff_v_mps) < 1e-6f);
            assert_true(cmd.omega == c.backoff_omega_rps);
            backoffs += !backing;
            backing = 1;
        } else {
            backing = 0;
            forward += cmd.v > 0.0f;
        }
    }
    assert_int_equal(ex.goal_failed, 7);
    assert_int_equal(ex.stuck_events, 3);
    assert_int_equal(backoffs, 2);       /* the third stuck event gives up instead */
    assert_int_equal(ex.plans, 3);       /* the goal, then one re-plan after each back-off */
    assert_true(forward > 0);
    /* Given up at t = 3 windows + 2 back-offs: 1 + 1 + 0.5 + 1 + 0.5 = 4 s. */
    assert_int_equal(k, 4 * 50 + 1);
    /* Stopped until a new goal; the same seq again changes nothing. */
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, k * PERIOD_US, &fc, &cmd), 0);
    assert_true(cmd.v == 0.0f && cmd.omega == 0.0f);
    assert_int_equal(ex.plans, 3);
    /* A new goal starts afresh: its own stuck count. */
    goal = go(8, 2.0f, 2.0f);
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, ++k * PERIOD_US, &fc, &cmd), 0);
    assert_int_equal(ex.plans, 4);
    assert_int_equal(ex.goal_seq, 8);
    assert_int_equal(ex.goal_stuck, 0);
    assert_int_equal(ex.state, RT_EXPLORE_DRIVE);
}

static void test_plan_failure_gives_up(void **st)
{
    (void)st;
    rt_explore_cfg_t c = room_cfg();
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    const rt_follow_cfg_t fc = rt_follow_default_cfg();
    rt_follow_cmd_t cmd;
    /* The robot is outside its grid: no plan. */
    gp_goal_msg_t goal = go(3, 2.0f, 1.0f);
    assert_int_equal(rt_explore_step(&ex, &goal, -2.0f, 1.0f, 0.0f, NULL, 0, &fc, &cmd), 0);
    assert_int_equal(ex.plan_failures, 1);
    assert_int_equal(ex.goal_failed, 3);
    assert_true(cmd.v == 0.0f && cmd.wheel_left == 0.0f);
    /* A goal with a non-finite point: given up without planning. */
    goal = go(4, NAN, 1.0f);
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, 20000, &fc, &cmd), 0);
    assert_int_equal(ex.goal_failed, 4);
    assert_int_equal(ex.plans, 1);
    /* A goal far outside the grid is clamped into it and planned to. */
    goal = go(5, 50.0f, 1.0f);
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, 40000, &fc, &cmd), 0);
    assert_int_equal(ex.state, RT_EXPLORE_DRIVE);
    assert_true(ex.goal_x < 6.0f);
}

/* A robot in a room whose door its 0.16 m grid narrowed to 4 cells (a wall two cells thick, as
 * in office64): the full band closes the door, so the tight one plans the way out, and the
 * robot drives it; with the door at 2 cells neither passes and the plan stops short. */
static void test_tight_band_leaves_a_narrowed_door(void **st)
{
    (void)st;
    rt_explore_cfg_t c = rt_explore_default_cfg();
    c.res_m = 0.16f;
    c.w = 20;
    c.h = 20;
    c.seen_factor = 4;
    c.seen_w = 5;
    c.seen_h = 5;
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    for (int r = 0; r < 20; r++)
        for (int col = 0; col < 20; col++) {
            const int wall = (r == 0 || r == 19 || col == 0 || col == 19 || r == 9 || r == 10) &&
                             !(r == 10 && col >= 8 && col <= 11) && !(r == 9 && col >= 7 && col <= 13);
            assert_int_equal(rt_grid_set(&ex.grid, col, r, wall ? 255 : 0, 255), 0);
        }
    const rt_follow_cfg_t fc = rt_follow_default_cfg();
    rt_follow_cmd_t cmd;
    gp_goal_msg_t goal = go(1, 1.68f, 0.72f); /* cell (10, 4), below the wall; the robot at (10, 15) */
    alloc_count_reset();
    assert_int_equal(rt_explore_step(&ex, &goal, 1.68f, 2.48f, -PI_F / 2, NULL, 0, &fc, &cmd), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_int_equal(ex.state, RT_EXPLORE_DRIVE);
    assert_int_equal(ex.tight, 1);
    assert_int_equal(ex.tight_plans, 1);
    assert_int_equal(ex.plan_res.flags, 0);
    assert_true(cmd.v > 0.0f);
    rt_status_t s;
    memset(&s, 0, sizeof s);
    rt_explore_status(&ex, &s);
    assert_int_equal(s.tight_plans, 1);
    /* Two cells: the full band's plan, to the nearest cell it reaches (above the wall). */
    assert_int_equal(rt_grid_set(&ex.grid, 10, 10, 255, 255), 0);
    assert_int_equal(rt_grid_set(&ex.grid, 11, 10, 255, 255), 0);
    goal = go(2, 1.68f, 0.72f);
    assert_int_equal(rt_explore_step(&ex, &goal, 1.68f, 2.48f, -PI_F / 2, NULL, 20000, &fc, &cmd), 0);
    assert_int_equal(ex.tight, 0);
    assert_int_equal(ex.tight_plans, 1);
    assert_int_equal(ex.plan_res.flags, RT_PLAN_GOAL_MOVED);
    assert_true(ex.plan_res.goal_row > 10);
}

static void test_done_and_budget_stop(void **st)
{
    (void)st;
    rt_explore_cfg_t c = room_cfg();
    c.budget_us = 2000000;
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    const rt_follow_cfg_t fc = rt_follow_default_cfg();
    rt_follow_cmd_t cmd;
    gp_goal_msg_t goal = go(1, 3.0f, 1.0f);
    assert_int_equal(rt_explore_clock(&ex, 500000), 0); /* the budget starts here */
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, 500000, &fc, &cmd), 0);
    assert_true(cmd.v > 0.0f && cmd.finished == 0);
    goal.mode = GP_GOAL_MSG_DONE;
    goal.seq = 2;
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, 520000, &fc, &cmd), 0);
    assert_int_equal(cmd.finished, 1);
    assert_true(cmd.v == 0.0f && cmd.omega == 0.0f && cmd.wheel_left == 0.0f);
    assert_int_equal(rt_explore_clock(&ex, 540000), 1);
    goal = go(3, 2.0f, 2.0f); /* nothing after DONE */
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, 560000, &fc, &cmd), 0);
    assert_int_equal(cmd.finished, 1);
    assert_int_equal(ex.goal_seq, 1);
    /* The budget: 2 s after the first clock call. */
    assert_int_equal(rt_explore_init(&ex, &c), 0);
    assert_int_equal(rt_explore_clock(&ex, 500000), 0);
    goal = go(1, 3.0f, 1.0f);
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, 500000, &fc, &cmd), 0);
    assert_int_equal(rt_explore_clock(&ex, 2499999), 0);
    assert_int_equal(rt_explore_clock(&ex, 2500000), 1);
    assert_int_equal(rt_explore_step(&ex, &goal, 1.0f, 1.0f, 0.0f, NULL, 2500000, &fc, &cmd), 0);
    assert_int_equal(cmd.finished, 1);
    assert_true(cmd.v == 0.0f);
}

static void test_cfg_checked(void **st)
{
    (void)st;
    rt_explore_cfg_t good = room_cfg();
    assert_int_equal(rt_explore_check_cfg(&good), 0);
    rt_explore_cfg_t c = good;
    c.res_m = 0.0f;
    assert_int_equal(rt_explore_init(&ex, &c), -EINVAL);
    c = good;
    c.w = RT_GRID_MAX_SIDE + 1;
    assert_int_equal(rt_explore_init(&ex, &c), -ENOSPC);
    c = good;
    c.seen_w = RT_EXPLORE_SEEN_MAX_SIDE + 1;
    assert_int_equal(rt_explore_init(&ex, &c), -EINVAL);
    c = good;
    c.seen_factor = 0;
    assert_int_equal(rt_explore_init(&ex, &c), -EINVAL);
    c = good;
    c.plan.flags = 0;
    assert_int_equal(rt_explore_init(&ex, &c), -EINVAL);
    c = good;
    c.plan.unknown_is_obstacle = 1;
    assert_int_equal(rt_explore_init(&ex, &c), -EINVAL);
    c = good;
    c.backoff_v_mps = 0.05f;
    assert_int_equal(rt_explore_init(&ex, &c), -EINVAL);
    c = good;
    c.max_stuck = 0;
    assert_int_equal(rt_explore_init(&ex, &c), -EINVAL);
    c = good;
    c.occ_miss = 0;
    assert_int_equal(rt_explore_init(&ex, &c), -EINVAL);
    c = good;
    c.avoid.slow_dist_m = c.avoid.stop_dist_m;
    assert_int_equal(rt_explore_init(&ex, &c), -EINVAL);
    assert_int_equal(rt_explore_init(NULL, &good), -EINVAL);
    assert_int_equal(rt_explore_init(&ex, NULL), -EINVAL);
    rt_follow_cmd_t cmd;
    rt_follow_cfg_t fc = rt_follow_default_cfg();
    assert_int_equal(rt_explore_init(&ex, &good), 0);
    assert_int_equal(rt_explore_step(&ex, NULL, INFINITY, 1.0f, 0.0f, NULL, 0, &fc, &cmd), -EINVAL);
    assert_int_equal(rt_explore_step(&ex, NULL, 1.0f, 1.0f, 0.0f, NULL, 0, NULL, &cmd), -EINVAL);
    assert_int_equal(rt_explore_seen(&ex, 0, NULL), -EINVAL);
    /* No goal yet: idle, wheels at 0. */
    assert_int_equal(rt_explore_step(&ex, NULL, 1.0f, 1.0f, 0.0f, NULL, 0, &fc, &cmd), 0);
    assert_true(cmd.v == 0.0f && cmd.finished == 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scan_marks_free_and_occupied),
        cmocka_unit_test(test_seen_view),
        cmocka_unit_test(test_goal_behind_wall_reached_around_it),
        cmocka_unit_test(test_fence_keeps_the_robot_in),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_replans_when_path_blocked),
        cmocka_unit_test(test_stuck_backs_off_replans_and_gives_up),
        cmocka_unit_test(test_plan_failure_gives_up),
        cmocka_unit_test(test_tight_band_leaves_a_narrowed_door),
        cmocka_unit_test(test_done_and_budget_stop),
        cmocka_unit_test(test_cfg_checked),
    };
    return cmocka_run_group_tests_name("rt/explore", tests, NULL, NULL);
}
