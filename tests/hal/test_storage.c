/* hal_storage on the host (a directory): round trip through the HAL wrappers, name
 * validation, missing and oversized blobs, and atomic overwrite: a writer process killed
 * with SIGKILL at arbitrary moments never leaves a torn blob behind. */
#define _GNU_SOURCE 1
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "hal/hal.h"
#include "hal_host.h"

static char dir[256];

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof(dir), "/tmp/fleetsim_test_storage_XXXXXX");
    return mkdtemp(dir) == NULL ? -1 : 0;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[300];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static hal_host_t *make_board(void)
{
    hal_host_config_t cfg = hal_host_config_default();
    cfg.storage_dir = dir;
    hal_host_t *h = NULL;
    assert_int_equal(hal_host_create(&cfg, &h), 0);
    assert_int_equal(hal_board_install(hal_host_board(h)), 0);
    return h;
}

static uint8_t blob[1u << 20];
static uint8_t back[1u << 20];

static void test_round_trip(void **state)
{
    (void)state;
    hal_host_t *h = make_board();
    for (size_t i = 0; i < 100000u; i++)
        blob[i] = (uint8_t)(i * 2654435761u >> 24);
    size_t len = 0;
    assert_int_equal(hal_storage_read("ckpt_0001.bin", back, sizeof(back), &len), -ENOENT);
    alloc_count_reset(); /* checkpointing from the GP core must not allocate in our code */
    assert_int_equal(hal_storage_write("ckpt_0001.bin", blob, 100000u), 0);
    assert_int_equal(hal_storage_read("ckpt_0001.bin", back, sizeof(back), &len), 0);
    assert_int_equal(alloc_count_allocations(), 0);
    assert_int_equal(len, 100000u);
    assert_memory_equal(back, blob, 100000u);
    /* Too small a buffer: the size is reported. */
    assert_int_equal(hal_storage_read("ckpt_0001.bin", back, 99999u, &len), -EMSGSIZE);
    assert_int_equal(len, 100000u);
    /* Overwrite with a shorter blob: no tail of the old one survives. */
    assert_int_equal(hal_storage_write("ckpt_0001.bin", "abc", 3), 0);
    assert_int_equal(hal_storage_read("ckpt_0001.bin", back, sizeof(back), &len), 0);
    assert_int_equal(len, 3);
    assert_memory_equal(back, "abc", 3);
    /* Empty blobs exist. */
    assert_int_equal(hal_storage_write("empty", NULL, 0), 0);
    assert_int_equal(hal_storage_read("empty", back, sizeof(back), &len), 0);
    assert_int_equal(len, 0);
    assert_int_equal(hal_storage_remove("empty"), 0);
    assert_int_equal(hal_storage_remove("empty"), -ENOENT);
    assert_int_equal(hal_storage_read("empty", back, sizeof(back), &len), -ENOENT);
    hal_host_destroy(h);
    assert_int_equal(hal_storage_write("x", "a", 1), -ENODEV);
}

static void test_bad_names_rejected(void **state)
{
    (void)state;
    hal_host_t *h = make_board();
    const char *bad[] = {"", ".", "..", "../x", "a/b", "/etc/passwd", ".hidden", "a..b",
                         "x..", "has space", "tab\t", "semi;colon", "uml\xc3\xa4ut", "a\\b"};
    size_t len = 0;
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
        assert_int_equal(hal_storage_write(bad[i], "a", 1), -EINVAL);
        assert_int_equal(hal_storage_read(bad[i], back, sizeof(back), &len), -EINVAL);
        assert_int_equal(hal_storage_remove(bad[i]), -EINVAL);
    }
    assert_int_equal(hal_storage_write(NULL, "a", 1), -EINVAL);
    assert_int_equal(hal_storage_write("ok", NULL, 1), -EINVAL);
    assert_int_equal(hal_storage_read("ok", back, sizeof(back), NULL), -EINVAL);
    char name[HAL_STORAGE_NAME_MAX + 1];
    memset(name, 'n', sizeof(name));
    name[HAL_STORAGE_NAME_MAX - 1] = '\0'; /* 63 characters: the longest valid */
    assert_int_equal(hal_storage_write(name, "a", 1), 0);
    name[HAL_STORAGE_NAME_MAX - 1] = 'n';
    name[HAL_STORAGE_NAME_MAX] = '\0';
    assert_int_equal(hal_storage_write(name, "a", 1), -EINVAL);
    /* Dots inside a name are fine. */
    assert_int_equal(hal_storage_write("map.v1.bin", "a", 1), 0);
    /* Nothing was written outside the directory, nothing with a bad name inside it. */
    DIR *d = opendir(dir);
    assert_non_null(d);
    struct dirent *e;
    int files = 0;
    while ((e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
            continue;
        assert_true(hal_storage_name_valid(e->d_name));
        files++;
    }
    closedir(d);
    assert_int_equal(files, 2);
    hal_host_destroy(h);
    /* A directory that cannot be used is reported at start-up. */
    hal_host_config_t cfg = hal_host_config_default();
    cfg.storage_dir = "/proc/version/sub";
    assert_int_equal(hal_host_create(&cfg, &h), -EIO);
}

/* Two versions that differ in size and in every byte. */
#define A_LEN (700u * 1024u)
#define B_LEN (1000u * 1024u)

static int check_whole(const uint8_t *p, size_t len)
{
    uint8_t v = len == A_LEN ? 'A' : len == B_LEN ? 'B' : 0;
    if (v == 0)
        return 0;
    for (size_t i = 0; i < len; i++)
        if (p[i] != v)
            return 0;
    return 1;
}

static void test_overwrite_is_atomic(void **state)
{
    (void)state;
    hal_host_storage_t *s = NULL;
    assert_int_equal(hal_host_storage_open(dir, &s), 0);
    memset(blob, 'A', A_LEN);
    assert_int_equal(hal_host_storage_write(s, "ckpt", blob, A_LEN), 0);
    int seen_a = 0, seen_b = 0;
    for (int round = 0; round < 12; round++) {
        fflush(NULL);
        pid_t pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
            /* Writer: alternate the two versions until killed. */
            static uint8_t a[A_LEN], b[B_LEN];
            memset(a, 'A', sizeof(a));
            memset(b, 'B', sizeof(b));
            for (unsigned i = 0;; i++)
                if (hal_host_storage_write(s, "ckpt", (i & 1u) ? b : a,
                                           (i & 1u) ? B_LEN : A_LEN) != 0)
                    _exit(3);
        }
        /* Kill it at a different moment each round (0.5 .. 6 ms into its loop). */
        struct timespec ts = {0, 500000L + 500000L * round};
        nanosleep(&ts, NULL);
        kill(pid, SIGKILL);
        int status = 0;
        waitpid(pid, &status, 0);
        assert_true(WIFSIGNALED(status));
        size_t len = 0;
        assert_int_equal(hal_host_storage_read(s, "ckpt", back, sizeof(back), &len), 0);
        assert_true(check_whole(back, len));
        seen_a += len == A_LEN;
        seen_b += len == B_LEN;
    }
    printf("# 12 writers killed mid-loop: blob was whole every time (A %d times, B %d times)\n",
           seen_a, seen_b);
    /* A temporary file left by a killed writer does not disturb the next write. */
    memset(blob, 'B', B_LEN);
    assert_int_equal(hal_host_storage_write(s, "ckpt", blob, B_LEN), 0);
    size_t len = 0;
    assert_int_equal(hal_host_storage_read(s, "ckpt", back, sizeof(back), &len), 0);
    assert_int_equal(len, B_LEN);
    assert_true(check_whole(back, len));
    hal_host_storage_close(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_round_trip, setup, teardown),
        cmocka_unit_test_setup_teardown(test_bad_names_rejected, setup, teardown),
        cmocka_unit_test_setup_teardown(test_overwrite_is_atomic, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
