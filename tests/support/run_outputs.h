/* Helpers for the tests that run programs and check what they left behind: run a program as
 * a child, read a whole file, and snapshot every regular file of a folder to check later that a failed
 * run changed none of them and left no temporary file (the writer's "*.fstmp").
 * Failures are cmocka assertions. Not thread-safe. */
#ifndef TESTS_SUPPORT_RUN_OUTPUTS_H
#define TESTS_SUPPORT_RUN_OUTPUTS_H

#include <stddef.h>
#include <stdint.h>

/* The bytes of a file, read to its end (so /proc files work too), malloc'd and NUL-terminated;
 * *n its size. NULL when it cannot be opened. */
uint8_t *test_slurp(const char *path, size_t *n);

/* Runs `bin` with args (NULL-terminated; args[0] is ignored) as a child process, optionally
 * with the disk-full seam FLEETSIM_FAIL_WRITE_AFTER=fail_after (fail_after >= 0). Its stderr
 * goes into err and its stdout into out (NULL: discarded), each cut to cap - 1 bytes and
 * NUL-terminated; the scratch files live in `dir`. Returns the exit status, 128 + the signal
 * when it was killed. */
int test_run(const char *bin, const char *const *args, long fail_after, const char *dir, char *err, char *out,
             size_t cap);

/* The path of a program of this test's own build: a test at build/<config>/tests/<module>/X
 * finds build/<config>/bin/<name>. Fails the test when the layout is not that. */
void test_build_program(const char *name, char *out, size_t cap);

/* Removes a scratch folder and all below it (rm -rf). 0, or -1 when that failed. */
int test_remove_tree(const char *dir);

#define SNAP_MAX_FILES 64

/* Every regular file directly in a folder: names and bytes. */
typedef struct snap {
    int n;
    char name[SNAP_MAX_FILES][300];
    uint8_t *data[SNAP_MAX_FILES];
    size_t len[SNAP_MAX_FILES];
} snap_t;

void snap_take(snap_t *s, const char *dir);
/* 1 when the snapshot holds a file of that name. */
int snap_has(const snap_t *s, const char *name);
/* Every file of the snapshot is still there, byte for byte, and no temporary file is left. */
void snap_check(const snap_t *s, const char *dir);
void snap_free(snap_t *s);

#endif /* TESTS_SUPPORT_RUN_OUTPUTS_H */
