/* Lockstep runtime of the host HAL: three cores with periods 20 ms (RT, 10 Hz scan
 * sub-rate), 100 ms (GP) and 50 ms (AI) run through fw_image against a small kinematic
 * world written here. Checks: every tick at exactly k * period (none skipped or run twice),
 * lateness 0, physics times strictly increasing, byte-identical traces over repeated runs
 * and with one core loaded by busy work, stack high-water marks, and no allocation once the
 * cores run (measured from inside a core loop). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "common/mbox.h"
#include "common/ring.h"
#include "fw_image.h"
#include "hal/hal.h"
#include "hal_host.h"

/* ---- a kinematic stand-in world: a unicycle in a 10 m x 10 m room --------------------- */
#define WORLD_MAX_STEPS 4096u
#define ROOM_HALF 5.0
#define PI_D 3.14159265358979323846

typedef struct world {
    double x, y, th;        /* pose */
    double wl, wr;          /* wheel rates, rad/s */
    uint64_t t_us;          /* time simulated up to */
    uint64_t step_t[WORLD_MAX_STEPS];
    uint32_t n_steps;
    int non_monotonic;
} world_t;

#define WHEEL_R 0.033
#define WHEEL_SEP 0.160

static int world_advance(void *ctx, uint64_t t_us)
{
    world_t *w = ctx;
    if (t_us <= w->t_us)
        w->non_monotonic = 1;
    if (w->n_steps < WORLD_MAX_STEPS)
        w->step_t[w->n_steps++] = t_us;
    /* Integrate in fixed 1 ms sub-steps so the result depends only on the time points. */
    while (w->t_us < t_us) {
        uint64_t dt_us = t_us - w->t_us < 1000u ? t_us - w->t_us : 1000u;
        double dt = (double)dt_us * 1e-6;
        double v = WHEEL_R * (w->wl + w->wr) * 0.5, om = WHEEL_R * (w->wr - w->wl) / WHEEL_SEP;
        w->x += v * cos(w->th) * dt;
        w->y += v * sin(w->th) * dt;
        w->th = atan2(sin(w->th + om * dt), cos(w->th + om * dt));
        w->t_us += dt_us;
    }
    return 0;
}

static int world_pose(void *ctx, uint32_t robot, hal_pose_t *p)
{
    world_t *w = ctx;
    (void)robot;
    p->stamp_us = w->t_us;
    p->x_m = (float)w->x;
    p->y_m = (float)w->y;
    p->heading_rad = (float)w->th;
    return 0;
}

/* Distance along each beam to the walls of the square room. */
static int world_scan(void *ctx, uint32_t robot, hal_lidar_scan_t *s)
{
    world_t *w = ctx;
    (void)robot;
    s->stamp_us = w->t_us;
    s->count = 36;
    s->angle_min_rad = (float)-PI_D;
    s->angle_step_rad = (float)(2.0 * PI_D / 36.0);
    s->range_min_m = 0.05f;
    s->range_max_m = 3.5f;
    for (uint32_t i = 0; i < s->count; i++) {
        double a = w->th + s->angle_min_rad + i * s->angle_step_rad;
        double dx = cos(a), dy = sin(a), d = 1e9;
        if (dx > 1e-9) d = fmin(d, (ROOM_HALF - w->x) / dx);
        if (dx < -1e-9) d = fmin(d, (-ROOM_HALF - w->x) / dx);
        if (dy > 1e-9) d = fmin(d, (ROOM_HALF - w->y) / dy);
        if (dy < -1e-9) d = fmin(d, (-ROOM_HALF - w->y) / dy);
        s->ranges_m[i] = d <= s->range_max_m ? (float)d : INFINITY;
    }
    return 0;
}

static int world_wheels(void *ctx, uint32_t robot, float l, float r)
{
    world_t *w = ctx;
    (void)robot;
    w->wl = l;
    w->wr = r;
    return 0;
}

/* ---- the test image: RT -> ring -> AI -> mailbox -> GP ----------------------------------- */
#define TRACE_MAX 512u

typedef struct trace_rec {
    uint64_t now_us;
    uint64_t index;
    uint64_t value; /* something that depends on what the core saw */
} trace_rec_t;

typedef struct sample {
    uint64_t stamp_us;
    float x, y, r;
} sample_t;

typedef struct app {
    ring_t *ring;          /* RT -> AI samples */
    mbox_t *mbox;          /* AI -> GP checksum */
    uint64_t busy_ai;      /* busy-work iterations per AI tick (load) */
    trace_rec_t trace[HAL_CORE_COUNT][TRACE_MAX];
    uint32_t n[HAL_CORE_COUNT];
    uint64_t ai_sum;
    volatile uint64_t sink;
    /* allocation probe, written by the GP core */
    uint64_t alloc_at_10, alloc_at_end;
    int probe;
    int net_errors;
} app_t;

RING_DEFINE(ring_run0, sizeof(sample_t), 64);
RING_DEFINE(ring_run1, sizeof(sample_t), 64);
RING_DEFINE(ring_run2, sizeof(sample_t), 64);
RING_DEFINE(ring_run3, sizeof(sample_t), 64);
MBOX_DEFINE(mbox_run0, sizeof(uint64_t));
MBOX_DEFINE(mbox_run1, sizeof(uint64_t));
MBOX_DEFINE(mbox_run2, sizeof(uint64_t));
MBOX_DEFINE(mbox_run3, sizeof(uint64_t));

static void trace(app_t *a, hal_core_id_t c, const fw_tick_t *t, uint64_t v)
{
    if (a->n[c] < TRACE_MAX)
        a->trace[c][a->n[c]++] = (trace_rec_t){t->now_us, t->index, v};
}

static uint64_t bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof(u));
    return u;
}

static int rt_tick(void *arg, const fw_tick_t *t)
{
    app_t *a = arg;
    hal_pose_t p;
    int r = hal_pose_read(&p);
    if (r != 0)
        return r;
    /* Drive a slow curve that depends on the pose, so timing errors change the path. */
    float turn = p.x_m > 0.0f ? 2.0f : 1.0f;
    r = hal_motor_set_twist(0.2f, 0.3f * turn);
    if (r != 0)
        return r;
    uint64_t v = bits(p.x_m) ^ (bits(p.y_m) << 32);
    if (t->sub) {
        hal_lidar_scan_t s;
        r = hal_lidar_read_scan(&s);
        if (r != 0)
            return r;
        sample_t smp = {t->now_us, p.x_m, p.y_m, s.ranges_m[9]};
        if (ring_put(a->ring, &smp) == -ENOSPC) /* full: dropped and counted, never waits */
            v ^= 1u;
        v ^= bits(s.ranges_m[9]) << 16;
    }
    trace(a, HAL_CORE_RT, t, v);
    return 0;
}

static int ai_tick(void *arg, const fw_tick_t *t)
{
    app_t *a = arg;
    sample_t s;
    while (ring_get(a->ring, &s) == 0)
        a->ai_sum = a->ai_sum * 31u + s.stamp_us + bits(s.x) + bits(s.r);
    for (uint64_t i = 0; i < a->busy_ai; i++) /* load: wall time only */
        a->sink = a->sink * 6364136223846793005ull + i;
    if (mbox_put(a->mbox, &a->ai_sum) != 0)
        return -EIO;
    trace(a, HAL_CORE_AI, t, a->ai_sum);
    return 0;
}

static int gp_tick(void *arg, const fw_tick_t *t)
{
    app_t *a = arg;
    uint64_t sum = 0, seq = 0;
    if (mbox_get(a->mbox, &sum, &seq) < 0)
        return -EIO;
    hal_pose_t p;
    if (hal_pose_read(&p) != 0)
        return -EIO;
    if (a->probe) {
        /* Exercise the network path inside the measured window too (memq://). */
        uint8_t msg[256];
        memset(msg, (int)(t->index & 0xFFu), sizeof(msg));
        hal_net_rx_info_t info;
        if (hal_net_publish("test/probe", msg, sizeof(msg)) != 0)
            a->net_errors++;
        (void)!hal_net_wait(2000000u); /* the receiver thread queues it a moment later */
        int rr = hal_net_receive(&info, msg, sizeof(msg));
        if (rr != 0 || info.len != sizeof(msg)) {
            fprintf(stderr, "probe tick %llu: receive %d len %u\n", (unsigned long long)t->index, rr, info.len);
            a->net_errors++;
        }
        if (t->index == 10)
            a->alloc_at_10 = alloc_count_allocations();
        a->alloc_at_end = alloc_count_allocations();
    }
    trace(a, HAL_CORE_GP, t, sum ^ (seq << 40) ^ bits(p.heading_rad));
    return 0;
}

typedef struct run_result {
    hal_host_core_stats_t cs[HAL_CORE_COUNT];
    fw_core_stats_t fs[HAL_CORE_COUNT];
    uint64_t world_steps;
} run_result_t;

static world_t g_world;
static app_t g_app;
static fw_image_t g_img;

static const uint32_t periods[HAL_CORE_COUNT] = {20000u, 100000u, 50000u};

static void run_image(hal_host_sched_t sched, uint64_t busy_ai, int run_no, uint64_t t_end_us,
                      int probe, run_result_t *res)
{
    static ring_t *const rings[] = {&ring_run0, &ring_run1, &ring_run2, &ring_run3};
    static mbox_t *const mboxes[] = {&mbox_run0, &mbox_run1, &mbox_run2, &mbox_run3};
    memset(&g_world, 0, sizeof(g_world));
    memset(&g_app, 0, sizeof(g_app));
    g_app.ring = rings[run_no];
    g_app.mbox = mboxes[run_no];
    g_app.busy_ai = busy_ai;
    g_app.probe = probe;

    hal_host_world_t w = {.ctx = &g_world, .advance_to_us = world_advance,
                          .read_scan = world_scan, .read_pose = world_pose,
                          .set_wheels = world_wheels};
    hal_host_config_t cfg = hal_host_config_default();
    cfg.world = &w;
    cfg.sched = sched;
    cfg.wheel_radius_m = (float)WHEEL_R;
    cfg.wheel_separation_m = (float)WHEEL_SEP;
    if (probe) {
        cfg.net_url = "memq://";
        cfg.net_queue_depth = 8;
    }
    hal_host_t *h = NULL;
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    assert_int_equal(hal_board_install(hal_host_board(h)), 0);
    if (probe)
        assert_int_equal(hal_net_subscribe("test/probe"), 0);

    fw_image_defaults(&g_img);
    fw_core_tick_fn ticks[HAL_CORE_COUNT] = {rt_tick, gp_tick, ai_tick};
    for (int c = 0; c < HAL_CORE_COUNT; c++) {
        g_img.core[c].period_us = periods[c];
        g_img.core[c].tick = ticks[c];
        g_img.core[c].arg = &g_app;
    }
    assert_int_equal(fw_image_start(&g_img), 0);
    /* Run in two legs to show the scheduler resumes where it stopped. */
    assert_int_equal(hal_host_run_until(h, t_end_us / 2u), 0);
    assert_int_equal(hal_host_now_us(h), t_end_us / 2u);
    assert_int_equal(hal_host_run_until(h, t_end_us), 0);
    assert_int_equal(hal_host_now_us(h), t_end_us);
    hal_host_stop(h);
    for (int c = 0; c < HAL_CORE_COUNT; c++) {
        assert_int_equal(hal_host_core_stats(h, (hal_core_id_t)c, &res->cs[c]), 0);
        res->fs[c] = g_img.stats[c];
    }
    res->world_steps = hal_host_world_steps(h);
    hal_host_destroy(h);
    assert_null(hal_board_current);
}

#define T_END_US 3000000u /* 3 simulated seconds */

static void check_ticks(const app_t *a, const run_result_t *res)
{
    for (int c = 0; c < HAL_CORE_COUNT; c++) {
        uint64_t expect = T_END_US / periods[c] + 1u; /* t = 0, P, 2P, ..., T */
        assert_int_equal(a->n[c], expect);
        for (uint32_t k = 0; k < a->n[c]; k++) {
            assert_int_equal(a->trace[c][k].index, k);
            assert_int_equal(a->trace[c][k].now_us, (uint64_t)k * periods[c]);
        }
        assert_int_equal(res->fs[c].ticks, expect);
        assert_int_equal(res->fs[c].errors, 0);
        assert_int_equal(res->cs[c].ticks, expect);
        assert_int_equal(res->cs[c].late_ticks, 0);
        assert_int_equal(res->cs[c].lateness_max_us, 0);
        assert_true(res->cs[c].finished);
        assert_true(res->cs[c].wall_ticks >= expect - 1u);
        assert_true(res->cs[c].wall_min_ns <= res->cs[c].wall_max_ns);
    }
}

static void check_physics(const world_t *w)
{
    assert_false(w->non_monotonic);
    assert_true(w->n_steps > 0);
    for (uint32_t i = 1; i < w->n_steps; i++)
        assert_true(w->step_t[i] > w->step_t[i - 1]);
    /* Steps happen exactly at the union of the tick times of the three cores (20, 50 and
     * 100 ms multiples), ending at T: nothing in between, nothing missing. */
    uint32_t k = 0;
    for (uint64_t t = 1; t <= T_END_US; t++) {
        int due = 0;
        for (int c = 0; c < HAL_CORE_COUNT; c++)
            due |= (t % periods[c]) == 0;
        if (!due)
            continue;
        assert_true(k < w->n_steps);
        assert_int_equal(w->step_t[k], t);
        k++;
    }
    assert_int_equal(k, w->n_steps);
    assert_int_equal(w->t_us, T_END_US);
}

static void print_profile(const char *what, const run_result_t *res)
{
    for (int c = 0; c < HAL_CORE_COUNT; c++) {
        const hal_host_core_stats_t *s = &res->cs[c];
        printf("# %s %s: ticks %llu, lateness max %llu us, wall per tick min/mean/max "
               "%llu/%llu/%llu ns, stack %zu/%zu bytes\n",
               what, hal_core_name((hal_core_id_t)c), (unsigned long long)s->ticks,
               (unsigned long long)s->lateness_max_us, (unsigned long long)s->wall_min_ns,
               (unsigned long long)(s->wall_ticks ? s->wall_total_ns / s->wall_ticks : 0),
               (unsigned long long)s->wall_max_ns, s->stack_used_bytes, s->stack_size_bytes);
    }
}

static app_t g_first;

static void test_lockstep_ticks_physics_and_determinism(void **state)
{
    (void)state;
    run_result_t res;
    /* Run 0: reference. */
    run_image(HAL_HOST_SCHED_SERIAL, 0, 0, T_END_US, 0, &res);
    check_ticks(&g_app, &res);
    check_physics(&g_world);
    assert_int_equal(res.world_steps, g_world.n_steps);
    /* The robot moved and the AI core consumed samples: the trace carries real data. */
    assert_true(fabs(g_world.x) + fabs(g_world.y) > 0.1);
    assert_true(g_app.ai_sum != 0);
    print_profile("serial", &res);
    memcpy(&g_first, &g_app, sizeof(g_app));
    double x0 = g_world.x, y0 = g_world.y;

    /* Run 1: same inputs -> byte-identical traces and the same final pose. */
    run_image(HAL_HOST_SCHED_SERIAL, 0, 1, T_END_US, 0, &res);
    check_ticks(&g_app, &res);
    assert_memory_equal(g_first.trace, g_app.trace, sizeof(g_app.trace));
    assert_true(g_world.x == x0 && g_world.y == y0);

    /* Run 2: the AI core burns wall time every tick (a loaded machine): same trace. */
    run_image(HAL_HOST_SCHED_SERIAL, 200000u, 2, T_END_US, 0, &res);
    check_ticks(&g_app, &res);
    check_physics(&g_world);
    assert_memory_equal(g_first.trace, g_app.trace, sizeof(g_app.trace));
    assert_true(g_world.x == x0 && g_world.y == y0);
    print_profile("serial+load", &res);
}

/* Parallel release: still lockstep (exact tick times, lateness 0, monotonic physics). */
static void test_lockstep_parallel_mode(void **state)
{
    (void)state;
    run_result_t res;
    run_image(HAL_HOST_SCHED_PARALLEL, 1000u, 3, T_END_US, 0, &res);
    check_ticks(&g_app, &res);
    check_physics(&g_world);
}

/* ---- stack high-water mark --------------------------------------------------------------- */
#define STACK_USE_BYTES (64u * 1024u)

__attribute__((noinline)) static uint64_t use_stack(uint32_t seed)
{
    volatile uint8_t buf[STACK_USE_BYTES];
    for (size_t i = 0; i < sizeof(buf); i++)
        buf[i] = (uint8_t)(seed + i);
    uint64_t s = 0;
    for (size_t i = 0; i < sizeof(buf); i += 4096)
        s += buf[i];
    return s;
}

static volatile uint64_t stack_sink;
static int stack_rt_tick(void *arg, const fw_tick_t *t)
{
    (void)arg;
    stack_sink += use_stack((uint32_t)t->index);
    return t->index >= 2 ? FW_CORE_DONE : 0;
}

static int idle_tick(void *arg, const fw_tick_t *t)
{
    (void)arg;
    return t->index >= 2 ? FW_CORE_DONE : 0;
}

static void test_stack_high_water(void **state)
{
    (void)state;
    hal_host_config_t cfg = hal_host_config_default();
    hal_host_t *h = NULL;
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    assert_int_equal(hal_board_install(hal_host_board(h)), 0);
    size_t used = 0, size = 0;
    assert_int_equal(hal_core_stack_high_water(HAL_CORE_RT, &used, &size), -ESRCH);
    fw_image_defaults(&g_img);
    g_img.core[HAL_CORE_RT].tick = stack_rt_tick;
    g_img.core[HAL_CORE_GP].tick = idle_tick;
    assert_int_equal(fw_image_start(&g_img), 0);
    /* A second start of a running core is refused. */
    assert_int_equal(hal_core_start(HAL_CORE_RT, (hal_core_entry_t)(void (*)(void *))0x1, NULL),
                     -EBUSY);
    assert_int_equal(hal_host_run_until(h, 1000000u), 0);
    /* Both loops returned FW_CORE_DONE: the cores finished on their own. */
    assert_int_equal(g_img.stats[HAL_CORE_RT].ticks, 3);
    assert_true(g_img.stats[HAL_CORE_RT].done);
    assert_int_equal(hal_core_stack_high_water(HAL_CORE_RT, &used, &size), 0);
    printf("# stack RT: used %zu of %zu bytes (a frame of %u bytes was used)\n", used, size,
           STACK_USE_BYTES);
    assert_int_equal(size, BOARD_STACK_RT_BYTES);
    assert_true(used >= STACK_USE_BYTES);
    assert_true(used < BOARD_STACK_RT_BYTES);
    size_t used_gp = 0;
    assert_int_equal(hal_core_stack_high_water(HAL_CORE_GP, &used_gp, &size), 0);
    printf("# stack GP (idle loop): used %zu of %zu bytes\n", used_gp, size);
    assert_true(used_gp > 0 && used_gp < STACK_USE_BYTES);
    assert_int_equal(hal_core_stack_high_water(HAL_CORE_AI, &used, &size), -ESRCH);
    hal_host_destroy(h);
}

/* ---- no allocation once the cores run ---------------------------------------------------- */
static void test_no_allocation_in_steady_state(void **state)
{
    (void)state;
    run_result_t res;
    run_image(HAL_HOST_SCHED_SERIAL, 0, 3, T_END_US, 1, &res);
    check_ticks(&g_app, &res);
    assert_int_equal(g_app.net_errors, 0);
    printf("# allocations between GP tick 10 and tick %u: %llu\n",
           (unsigned)(T_END_US / periods[HAL_CORE_GP]),
           (unsigned long long)(g_app.alloc_at_end - g_app.alloc_at_10));
    assert_int_equal(g_app.alloc_at_end, g_app.alloc_at_10);
}

/* ---- contract corners -------------------------------------------------------------------- */
static void noop_entry(void *arg)
{
    (void)arg;
}

static void test_sleep_outside_core_and_config(void **state)
{
    (void)state;
    hal_host_config_t cfg = hal_host_config_default();
    hal_host_t *h = NULL;
    cfg.log_level = (hal_log_level_t)7;
    assert_int_equal(hal_host_create(&cfg, &h), -EINVAL);
    cfg = hal_host_config_default();
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    assert_int_equal(hal_board_install(hal_host_board(h)), 0);
    assert_int_equal(hal_sleep_until_us(10), -EPERM);
    hal_core_id_t id;
    assert_int_equal(hal_core_self(&id), -EPERM);
    uint64_t now = 1;
    assert_int_equal(hal_clock_now_us(&now), 0);
    assert_int_equal(now, 0);
    /* No world: no lidar, pose or motors. */
    hal_pose_t p;
    assert_int_equal(hal_pose_read(&p), -ENODEV);
    assert_int_equal(hal_motor_set_wheels(1.0f, 1.0f), -ENODEV);
    assert_int_equal(hal_log(HAL_LOG_INFO, "log line from the test at t=%llu", (unsigned long long)now), 0);
    /* Time runs without cores; it never goes back. */
    assert_int_equal(hal_host_run_until(h, 5000u), 0);
    assert_int_equal(hal_host_now_us(h), 5000u);
    assert_int_equal(hal_host_run_until(h, 4000u), -EINVAL);
    hal_host_stop(h);
    assert_int_equal(hal_host_run_until(h, 6000u), -ECANCELED);
    /* A stopped board starts nothing, and does not keep the static stacks from others. */
    assert_int_equal(hal_core_start(HAL_CORE_RT, noop_entry, NULL), -ECANCELED);
    hal_host_t *h2 = NULL;
    assert_int_equal(hal_host_create(&cfg, &h2), 0);
    assert_int_equal(hal_board_install(hal_host_board(h2)), 0);
    assert_int_equal(hal_core_start(HAL_CORE_RT, noop_entry, NULL), 0);
    hal_host_destroy(h);
    assert_int_equal(hal_host_run_until(h2, 1000u), 0);
    hal_host_destroy(h2);
}

/* A failing physics step stops the run with its error, before any core sees that time. */
static uint64_t failing_world_last;
static int failing_advance(void *ctx, uint64_t t_us)
{
    (void)ctx;
    if (t_us >= 500000u)
        return -EIO;
    failing_world_last = t_us;
    return 0;
}

static uint64_t last_rt_tick;
static int record_tick(void *arg, const fw_tick_t *t)
{
    (void)arg;
    last_rt_tick = t->now_us;
    return 0;
}

static void test_world_error_stops_run(void **state)
{
    (void)state;
    hal_host_world_t w = {.advance_to_us = failing_advance};
    hal_host_config_t cfg = hal_host_config_default();
    cfg.world = &w;
    hal_host_t *h = NULL;
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    assert_int_equal(hal_board_install(hal_host_board(h)), 0);
    fw_image_defaults(&g_img);
    g_img.core[HAL_CORE_RT].tick = record_tick;
    assert_int_equal(fw_image_start(&g_img), 0);
    assert_int_equal(hal_host_run_until(h, 1000000u), -EIO);
    assert_int_equal(failing_world_last, 480000u);
    assert_int_equal(last_rt_tick, 480000u);
    assert_int_equal(hal_host_now_us(h), 480000u);
    hal_host_stop(h);
    assert_true(g_img.stats[HAL_CORE_RT].done);
    assert_int_equal(g_img.stats[HAL_CORE_RT].ticks, 25);
    hal_host_destroy(h);
}

/* The wall-clock watchdog names a core that computes too long; simulation unaffected. */
static int slow_tick(void *arg, const fw_tick_t *t)
{
    (void)arg;
    if (t->index == 1) {
        struct timespec ts = {0, 300000000L}; /* 300 ms of wall time inside one tick */
        nanosleep(&ts, NULL);
    }
    return t->index >= 3 ? FW_CORE_DONE : 0;
}

static void test_watchdog_reports_slow_core(void **state)
{
    (void)state;
    hal_host_config_t cfg = hal_host_config_default();
    cfg.watchdog_ms = 50;
    hal_host_t *h = NULL;
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    assert_int_equal(hal_board_install(hal_host_board(h)), 0);
    fw_image_defaults(&g_img);
    g_img.core[HAL_CORE_GP].tick = slow_tick;
    assert_int_equal(fw_image_start(&g_img), 0);
    assert_int_equal(hal_host_run_until(h, 1000000u), 0);
    assert_true(hal_host_watchdog_reports(h) >= 1);
    assert_int_equal(g_img.stats[HAL_CORE_GP].ticks, 4);
    hal_host_core_stats_t cs;
    assert_int_equal(hal_host_core_stats(h, HAL_CORE_GP, &cs), 0);
    assert_int_equal(cs.lateness_max_us, 0);
    hal_host_destroy(h);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lockstep_ticks_physics_and_determinism),
        cmocka_unit_test(test_lockstep_parallel_mode),
        cmocka_unit_test(test_stack_high_water),
        cmocka_unit_test(test_no_allocation_in_steady_state),
        cmocka_unit_test(test_sleep_outside_core_and_config),
        cmocka_unit_test(test_world_error_stops_run),
        cmocka_unit_test(test_watchdog_reports_slow_core),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
