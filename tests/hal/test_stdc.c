/* The stdc HAL back end (hal/stdc, the cross boards' board) on its Linux target: storage round
 * trip, replacement, missing and oversized blobs and long names; the RAM loopback network
 * (only subscribed channels come back, in order, a full queue drops and counts, a small
 * buffer gives -EMSGSIZE); the clock; cores refused with -ENOTSUP. */
#define _GNU_SOURCE 1
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "hal/hal.h"
#include "hal_stdc.h"

static char dir[256];

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/fleetsim_test_stdc_XXXXXX");
    if (mkdtemp(dir) == NULL)
        return -1;
    return hal_stdc_install(dir);
}

static int teardown(void **state)
{
    (void)state;
    hal_stdc_uninstall();
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void test_storage(void **state)
{
    (void)state;
    char buf[16];
    size_t len = 0;
    assert_int_equal(hal_storage_read("none.bin", buf, sizeof buf, &len), -ENOENT);
    assert_int_equal(hal_storage_write("a.bin", "first", 5), 0);
    assert_int_equal(hal_storage_write("a.bin", "second!", 7), 0); /* replaces */
    assert_int_equal(hal_storage_read("a.bin", buf, sizeof buf, &len), 0);
    assert_int_equal(len, 7);
    assert_memory_equal(buf, "second!", 7);
    assert_int_equal(hal_storage_read("a.bin", buf, 3, &len), -EMSGSIZE);
    assert_int_equal(len, 7); /* tells the size */
    char tmp[300];
    snprintf(tmp, sizeof tmp, "%s/a.bin.tmp", dir);
    assert_int_equal(access(tmp, F_OK), -1); /* no temporary left behind */
    assert_int_equal(hal_storage_write("empty", NULL, 0), 0);
    assert_int_equal(hal_storage_read("empty", buf, sizeof buf, &len), 0);
    assert_int_equal(len, 0);
    assert_int_equal(hal_storage_remove("a.bin"), 0);
    assert_int_equal(hal_storage_remove("a.bin"), -ENOENT);
    assert_int_equal(hal_storage_write("../escape", "x", 1), -EINVAL);
    char longname[200];
    memset(longname, 'n', sizeof longname - 1);
    longname[sizeof longname - 1] = '\0';
    assert_int_equal(hal_storage_write(longname, "x", 1), -EINVAL);
}

static void test_storage_dir_too_long(void **state)
{
    (void)state;
    char longdir[HAL_STDC_DIR_MAX + 8];
    memset(longdir, 'd', sizeof longdir - 1);
    longdir[sizeof longdir - 1] = '\0';
    assert_int_equal(hal_stdc_install(longdir), -EINVAL);
    assert_int_equal(hal_stdc_install(dir), 0);
}

static void test_loopback_net(void **state)
{
    (void)state;
    uint8_t buf[64];
    hal_net_rx_info_t info;
    assert_int_equal(hal_net_receive(&info, buf, sizeof buf), -EAGAIN);
    assert_int_equal(hal_net_publish("nobody/listens", "x", 1), 0); /* gone */
    assert_int_equal(hal_net_subscribe("fleet/state"), 0);
    assert_int_equal(hal_net_subscribe("fleet/state"), 0); /* twice: a no-op */
    assert_int_equal(hal_net_set_senders("fleet/state", NULL, 0), -ENOTSUP); /* no sender filter here */
    for (uint8_t i = 0; i < HAL_STDC_NET_QUEUE + 2u; i++)
        assert_int_equal(hal_net_publish("fleet/state", &i, 1), 0);
    hal_net_stats_t st;
    assert_int_equal(hal_net_get_stats(&st), 0);
    assert_int_equal(st.queue_fill, HAL_STDC_NET_QUEUE);
    assert_int_equal(st.rx_dropped_full, 2);
    for (uint8_t i = 0; i < HAL_STDC_NET_QUEUE; i++) {
        assert_int_equal(hal_net_receive(&info, buf, sizeof buf), 0);
        assert_string_equal(info.channel, "fleet/state");
        assert_int_equal(info.len, 1);
        assert_int_equal(buf[0], i); /* in order */
    }
    assert_int_equal(hal_net_receive(&info, buf, sizeof buf), -EAGAIN);
    assert_int_equal(hal_net_publish("fleet/state", "long message", 12), 0);
    assert_int_equal(hal_net_receive(&info, buf, 4), -EMSGSIZE);
    assert_int_equal(info.len, 12);
    assert_int_equal(hal_net_get_stats(&st), 0);
    assert_int_equal(st.rx_dropped_small, 1);
    uint8_t big[HAL_NET_MTU_BYTES + 1];
    memset(big, 0, sizeof big);
    assert_int_equal(hal_net_publish("fleet/state", big, sizeof big), -EMSGSIZE);
    char name[20];
    for (unsigned i = 0; i < HAL_STDC_NET_CHANNELS - 1u; i++) {
        snprintf(name, sizeof name, "ch/%u", i);
        assert_int_equal(hal_net_subscribe(name), 0);
    }
    assert_int_equal(hal_net_subscribe("one/too/many"), -ENOSPC);
}

static void noop_entry(void *arg)
{
    (void)arg;
}

static void test_clock_and_cores(void **state)
{
    (void)state;
    uint64_t t0 = 0, t1 = 0;
    assert_int_equal(hal_clock_now_us(&t0), 0);
    assert_int_equal(hal_sleep_until_us(t0 + 2000u), 0);
    assert_int_equal(hal_clock_now_us(&t1), 0);
    assert_true(t1 >= t0 + 2000u);
    assert_int_equal(hal_core_start(HAL_CORE_AI, noop_entry, NULL), -ENOTSUP);
    assert_int_equal(hal_log(HAL_LOG_INFO, "stdc log line %d", 1), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_storage, setup, teardown),
        cmocka_unit_test_setup_teardown(test_storage_dir_too_long, setup, teardown),
        cmocka_unit_test_setup_teardown(test_loopback_net, setup, teardown),
        cmocka_unit_test_setup_teardown(test_clock_and_cores, setup, teardown),
    };
    return cmocka_run_group_tests_name("hal_stdc", tests, NULL, NULL);
}
