/* The HAL's board contract: wrappers without a board (-ENODEV), optional operations
 * (-ENOTSUP), install-time checks of required operations, argument checks before any
 * operation runs; the host board's motor, pose, lidar and log adapters; fw_image argument
 * checks and its handling of tick errors. */
#define _GNU_SOURCE 1
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "fw_image.h"
#include "hal/hal.h"
#include "hal_host.h"

/* ---- a minimal board of our own, to probe the wrappers ---------------------------------- */
static int calls;
static int fake_now(void *ctx, uint64_t *now) { (void)ctx; *now = 42; calls++; return 0; }
static int fake_sleep(void *ctx, uint64_t t) { (void)ctx; (void)t; calls++; return 0; }
static int fake_start(void *ctx, hal_core_id_t id, hal_core_entry_t e, void *a)
{
    (void)ctx; (void)id; (void)e; (void)a; calls++; return 0;
}
static void fake_vlog(void *ctx, hal_log_level_t l, const char *f, va_list ap)
{
    (void)ctx; (void)l; (void)f; (void)ap; calls++;
}
static void fake_entry(void *arg) { (void)arg; }
static int fake_twist(void *ctx, float v, float w) { (void)ctx; (void)v; (void)w; calls++; return 0; }

static const hal_clock_ops_t fake_clock = {.now_us = fake_now, .sleep_until_us = fake_sleep};
static const hal_core_ops_t fake_core = {.start = fake_start};
static const hal_log_ops_t fake_log = {fake_vlog};
static const hal_motor_ops_t fake_motor = {.set_twist = fake_twist};

static void test_wrappers_without_board_and_optional_ops(void **state)
{
    (void)state;
    assert_int_equal(hal_board_install(NULL), 0);
    uint64_t t;
    hal_pose_t p;
    hal_lidar_scan_t s;
    size_t u, z;
    hal_core_id_t id;
    assert_int_equal(hal_clock_now_us(&t), -ENODEV);
    assert_int_equal(hal_sleep_until_us(1), -ENODEV);
    assert_int_equal(hal_pose_read(&p), -ENODEV);
    assert_int_equal(hal_lidar_read_scan(&s), -ENODEV);
    assert_int_equal(hal_core_stack_high_water(HAL_CORE_RT, &u, &z), -ENODEV);
    assert_int_equal(hal_log(HAL_LOG_INFO, "x"), -ENODEV);

    hal_board_t b = {.name = "fake", .clock = &fake_clock, .core = &fake_core, .log = &fake_log,
                     .motor = &fake_motor};
    assert_int_equal(hal_board_install(&b), 0);
    calls = 0;
    assert_int_equal(hal_clock_now_us(&t), 0);
    assert_int_equal(t, 42);
    /* Optional operations the board lacks. */
    assert_int_equal(hal_core_stack_high_water(HAL_CORE_RT, &u, &z), -ENOTSUP);
    assert_int_equal(hal_core_self(&id), -ENOTSUP);
    assert_int_equal(hal_motor_set_wheels(1.0f, 1.0f), -ENOTSUP);
    assert_int_equal(hal_motor_set_twist(0.1f, 0.0f), 0);
    /* Interfaces the board lacks. */
    assert_int_equal(hal_pose_read(&p), -ENODEV);
    assert_int_equal(hal_net_publish("c", "x", 1), -ENODEV);
    assert_int_equal(hal_storage_write("n", "x", 1), -ENODEV);
    assert_int_equal(calls, 2);
    /* Arguments are checked before any operation runs. */
    calls = 0;
    assert_int_equal(hal_clock_now_us(NULL), -EINVAL);
    assert_int_equal(hal_motor_set_twist(NAN, 0.0f), -EINVAL);
    assert_int_equal(hal_motor_set_twist(0.0f, INFINITY), -EINVAL);
    assert_int_equal(hal_core_start((hal_core_id_t)3, fake_entry, NULL), -EINVAL);
    assert_int_equal(hal_core_start(HAL_CORE_RT, NULL, NULL), -EINVAL);
    assert_int_equal(hal_log((hal_log_level_t)9, "x"), -EINVAL);
    assert_int_equal(calls, 0);
    assert_string_equal(hal_core_name(HAL_CORE_AI), "AI");
    assert_string_equal(hal_core_name((hal_core_id_t)7), "?");
    assert_int_equal(hal_board_install(NULL), 0);
}

static void test_install_checks_required_ops(void **state)
{
    (void)state;
    hal_board_t b = {.name = "fake", .clock = &fake_clock, .core = &fake_core, .log = &fake_log};
    hal_board_t bad = b;
    bad.name = NULL;
    assert_int_equal(hal_board_install(&bad), -EINVAL);
    bad = b;
    bad.clock = NULL;
    assert_int_equal(hal_board_install(&bad), -EINVAL);
    hal_clock_ops_t half_clock = {.now_us = fake_now};
    bad = b;
    bad.clock = &half_clock;
    assert_int_equal(hal_board_install(&bad), -EINVAL);
    hal_motor_ops_t no_motor = {0};
    bad = b;
    bad.motor = &no_motor;
    assert_int_equal(hal_board_install(&bad), -EINVAL);
    hal_net_ops_t half_net = {0};
    bad = b;
    bad.net = &half_net;
    assert_int_equal(hal_board_install(&bad), -EINVAL);
    assert_null(hal_board_current);
    assert_int_equal(hal_board_install(&b), 0);
    assert_ptr_equal(hal_board_current, &b);
    assert_int_equal(hal_board_install(NULL), 0);
}

/* ---- the host board's world adapters ---------------------------------------------------- */
typedef struct probe_world {
    float left, right;
    uint32_t robot;
    int fail_scan;
} probe_world_t;

static int pw_advance(void *ctx, uint64_t t) { (void)ctx; (void)t; return 0; }
static int pw_pose(void *ctx, uint32_t robot, hal_pose_t *p)
{
    probe_world_t *w = ctx;
    w->robot = robot;
    *p = (hal_pose_t){.stamp_us = 7, .x_m = 1.5f, .y_m = -2.0f, .heading_rad = 0.25f};
    return 0;
}
static int pw_scan(void *ctx, uint32_t robot, hal_lidar_scan_t *s)
{
    probe_world_t *w = ctx;
    (void)robot;
    memset(s, 0, sizeof(*s));
    s->count = w->fail_scan ? 0u : 3u; /* 0 beams breaks the scan contract */
    s->ranges_m[0] = 1.0f;
    return 0;
}
static int pw_wheels(void *ctx, uint32_t robot, float l, float r)
{
    probe_world_t *w = ctx;
    (void)robot;
    w->left = l;
    w->right = r;
    return 0;
}

static void test_host_world_adapters_and_log(void **state)
{
    (void)state;
    probe_world_t pw = {0};
    hal_host_world_t w = {.ctx = &pw, .advance_to_us = pw_advance, .read_scan = pw_scan,
                          .read_pose = pw_pose, .set_wheels = pw_wheels};
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    hal_host_config_t cfg = hal_host_config_default();
    cfg.world = &w;
    cfg.robot_id = 5;
    cfg.wheel_radius_m = 0.05f;
    cfg.wheel_separation_m = 0.2f;
    cfg.log_fd = fds[1];
    cfg.log_level = HAL_LOG_INFO;
    hal_host_t *h = NULL;
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    assert_int_equal(hal_board_install(hal_host_board(h)), 0);
    assert_string_equal(hal_board_current->name, "host");

    hal_pose_t p;
    assert_int_equal(hal_pose_read(&p), 0);
    assert_int_equal(pw.robot, 5);
    assert_true(p.x_m == 1.5f && p.y_m == -2.0f && p.heading_rad == 0.25f);
    /* v = 0.1 m/s, omega = 1 rad/s: left = (0.1 - 0.1) / 0.05 = 0, right = 0.2 / 0.05 = 4. */
    assert_int_equal(hal_motor_set_twist(0.1f, 1.0f), 0);
    assert_float_equal(pw.left, 0.0f, 1e-6f);
    assert_float_equal(pw.right, 4.0f, 1e-6f);
    assert_int_equal(hal_motor_set_wheels(-1.0f, 2.0f), 0);
    assert_true(pw.left == -1.0f && pw.right == 2.0f);
    hal_lidar_scan_t s;
    assert_int_equal(hal_lidar_read_scan(&s), 0);
    assert_int_equal(s.count, 3);
    pw.fail_scan = 1;
    assert_int_equal(hal_lidar_read_scan(&s), -EIO);

    /* Log: level filter, simulated time stamp, caller name, one line per message. */
    assert_int_equal(hal_host_run_until(h, 1234567u), 0);
    assert_int_equal(hal_log(HAL_LOG_DEBUG, "hidden %d", 1), 0);
    assert_int_equal(hal_log(HAL_LOG_WARN, "visible %d", 2), 0);
    char long_msg[600];
    memset(long_msg, 'z', sizeof(long_msg) - 1);
    long_msg[sizeof(long_msg) - 1] = '\0';
    assert_int_equal(hal_log(HAL_LOG_INFO, "%s", long_msg), 0);
    hal_host_destroy(h);
    close(fds[1]);
    char buf[2048];
    ssize_t n = read(fds[0], buf, sizeof(buf) - 1);
    close(fds[0]);
    assert_true(n > 0);
    buf[n] = '\0';
    assert_null(strstr(buf, "hidden"));
    assert_non_null(strstr(buf, "[     1.234567] host WARN  visible 2\n"));
    /* The long message was cut to the line limit, still one line. */
    char *second = strchr(buf, '\n') + 1;
    char *end = strchr(second, '\n');
    assert_non_null(end);
    assert_true((size_t)(end - second) < HAL_LOG_LINE_MAX + 64u);
    assert_null(strchr(end + 1, '\n'));
    /* Configuration errors. */
    cfg = hal_host_config_default();
    hal_host_world_t no_advance = {0};
    cfg.world = &no_advance;
    assert_int_equal(hal_host_create(&cfg, &h), -EINVAL);
    cfg = hal_host_config_default();
    cfg.wheel_radius_m = -1.0f;
    assert_int_equal(hal_host_create(&cfg, &h), -EINVAL);
    cfg = hal_host_config_default();
    cfg.net_url = "nosuchprovider://";
    assert_int_equal(hal_host_create(&cfg, &h), -EIO);
}

/* ---- fw_image ------------------------------------------------------------------------------ */
static fw_image_t img;
static int failing_tick(void *arg, const fw_tick_t *t)
{
    (void)arg;
    if (t->index >= 20)
        return FW_CORE_DONE;
    return (t->index % 2) ? -EIO : 0;
}
static int failing_init(void *arg) { (void)arg; return -ENOMEM; }
static int ok_tick(void *arg, const fw_tick_t *t) { (void)arg; (void)t; return 0; }

static void test_fw_image_checks_and_errors(void **state)
{
    (void)state;
    assert_int_equal(fw_image_start(NULL), -EINVAL);
    fw_image_defaults(&img);
    assert_int_equal(img.core[HAL_CORE_RT].period_us, 20000u);
    assert_int_equal(img.core[HAL_CORE_RT].sub_divider, 5u);
    assert_int_equal(img.core[HAL_CORE_GP].period_us, 100000u);
    assert_int_equal(img.core[HAL_CORE_AI].period_us, 100000u);
    assert_int_equal(fw_image_start(&img), -EINVAL); /* no loop at all */
    img.core[HAL_CORE_RT].tick = ok_tick;
    img.core[HAL_CORE_RT].period_us = 0;
    assert_int_equal(fw_image_start(&img), -EINVAL);

    int fds[2];
    assert_int_equal(pipe(fds), 0);
    hal_host_config_t cfg = hal_host_config_default();
    cfg.log_fd = fds[1];
    hal_host_t *h = NULL;
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    assert_int_equal(hal_board_install(hal_host_board(h)), 0);
    fw_image_defaults(&img);
    img.core[HAL_CORE_RT].tick = failing_tick;
    img.core[HAL_CORE_AI].tick = ok_tick;
    img.core[HAL_CORE_AI].init = failing_init;
    assert_int_equal(fw_image_start(&img), 0);
    assert_int_equal(hal_host_run_until(h, 2000000u), 0);
    hal_host_stop(h);
    /* RT: 21 ticks, every odd one failed and was counted; the loop went on to DONE. */
    assert_int_equal(img.stats[HAL_CORE_RT].ticks, 21);
    assert_int_equal(img.stats[HAL_CORE_RT].errors, 10);
    assert_int_equal(img.stats[HAL_CORE_RT].last_error, -EIO);
    assert_true(img.stats[HAL_CORE_RT].done);
    /* AI: init failed, so no tick ran. */
    assert_int_equal(img.stats[HAL_CORE_AI].init_error, -ENOMEM);
    assert_int_equal(img.stats[HAL_CORE_AI].ticks, 0);
    hal_host_destroy(h);
    close(fds[1]);
    char buf[4096];
    ssize_t n = read(fds[0], buf, sizeof(buf) - 1);
    close(fds[0]);
    assert_true(n > 0);
    buf[n] = '\0';
    /* Errors are logged with the core's name; only the first FW_CORE_LOG_ERRORS of them. */
    assert_non_null(strstr(buf, "AI   ERROR AI: init failed (-12)"));
    assert_non_null(strstr(buf, "[     0.020000] RT   WARN  RT: tick 1 failed (-5)"));
    int lines = 0;
    for (char *p = buf; (p = strstr(p, "RT: tick")) != NULL; p++)
        lines++;
    assert_int_equal(lines, FW_CORE_LOG_ERRORS);
    (void)alloc_count_allocations();
}

/* Cores started at an instant that is not a whole period are released at whole periods of the
 * board's clock: a scheduler waking on its tick then releases them at the tick itself, and a
 * world stepped in whole periods sees every tick at its own step (the HIL boards). */
static uint64_t first_release_us, releases_off_period;
static int record_tick(void *arg, const fw_tick_t *t)
{
    (void)arg;
    if (t->index == 0)
        first_release_us = t->now_us;
    if (t->now_us % 20000u != 0)
        releases_off_period++;
    return 0;
}

static void test_fw_image_releases_at_whole_periods(void **state)
{
    (void)state;
    hal_host_config_t cfg = hal_host_config_default();
    hal_host_t *h = NULL;
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    assert_int_equal(hal_board_install(hal_host_board(h)), 0);
    assert_int_equal(hal_host_run_until(h, 12345u), 0);
    fw_image_defaults(&img);
    img.core[HAL_CORE_RT].tick = record_tick;
    first_release_us = releases_off_period = 0;
    assert_int_equal(fw_image_start(&img), 0);
    assert_int_equal(hal_host_run_until(h, 200000u), 0);
    hal_host_stop(h);
    assert_int_equal(img.stats[HAL_CORE_RT].start_us, 20000u);
    assert_int_equal(first_release_us, 20000u);
    assert_int_equal(img.stats[HAL_CORE_RT].ticks, 10); /* 20, 40, .. 200 ms */
    assert_int_equal(releases_off_period, 0);
    hal_host_destroy(h);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_wrappers_without_board_and_optional_ops),
        cmocka_unit_test(test_install_checks_required_ops),
        cmocka_unit_test(test_host_world_adapters_and_log),
        cmocka_unit_test(test_fw_image_checks_and_errors),
        cmocka_unit_test(test_fw_image_releases_at_whole_periods),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
