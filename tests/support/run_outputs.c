/* Helpers of the tests that run programs: see run_outputs.h. */
#define _XOPEN_SOURCE 700 /* popen */
#include "run_outputs.h"

#include <limits.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

void test_build_program(const char *name, char *out, size_t cap)
{
    char self[PATH_MAX];
    const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    assert_true(n > 0);
    self[n] = '\0';
    char *cut = strstr(self, "/tests/");
    assert_non_null(cut);
    *cut = '\0';
    const int w = snprintf(out, cap, "%s/bin/%s", self, name);
    assert_true(w > 0 && (size_t)w < cap);
}

int test_remove_tree(const char *dir)
{
    char cmd[PATH_MAX + 16];
    const int w = snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return w > 0 && (size_t)w < sizeof cmd && system(cmd) == 0 ? 0 : -1;
}

int test_run(const char *bin, const char *const *args, long fail_after, const char *dir, char *err, char *out,
             size_t cap)
{
    char files[2][PATH_MAX + 16];
    snprintf(files[0], sizeof files[0], "%s/.stderr", dir);
    snprintf(files[1], sizeof files[1], "%s/.stdout", dir);
    fflush(NULL);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        int fe = open(files[0], O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int fo = open(out ? files[1] : "/dev/null", O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fe < 0 || fo < 0)
            _exit(127);
        dup2(fe, 2);
        dup2(fo, 1);
        if (fail_after >= 0) {
            char v[32];
            snprintf(v, sizeof v, "%ld", fail_after);
            setenv("FLEETSIM_FAIL_WRITE_AFTER", v, 1);
        }
        execv(bin, (char *const *)args);
        _exit(127);
    }
    int st = 0;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    char *bufs[2] = {err, out};
    for (int k = 0; k < 2; k++) {
        if (bufs[k] == NULL)
            continue;
        FILE *f = fopen(files[k], "r");
        assert_non_null(f);
        size_t n = fread(bufs[k], 1, cap - 1, f);
        bufs[k][n] = '\0';
        fclose(f);
        unlink(files[k]);
    }
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

uint8_t *test_slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return NULL;
    size_t cap = 4096, len = 0;
    uint8_t *b = malloc(cap);
    assert_non_null(b);
    for (size_t got; (got = fread(b + len, 1, cap - len - 1, f)) > 0;) {
        len += got;
        if (cap - len - 1 == 0) {
            cap *= 2;
            b = realloc(b, cap);
            assert_non_null(b);
        }
    }
    fclose(f);
    b[len] = 0;
    *n = len;
    return b;
}

void snap_take(snap_t *s, const char *dir)
{
    memset(s, 0, sizeof *s);
    char cmd[PATH_MAX + 32];
    snprintf(cmd, sizeof cmd, "ls -A '%s'", dir);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    char line[300];
    while (fgets(line, sizeof line, p) && s->n < SNAP_MAX_FILES) {
        line[strcspn(line, "\n")] = '\0';
        char full[PATH_MAX + 300];
        snprintf(full, sizeof full, "%s/%s", dir, line);
        if (strlen(line) >= sizeof s->name[0])
            continue;
        struct stat st;
        if (stat(full, &st) != 0 || !S_ISREG(st.st_mode))
            continue;
        snprintf(s->name[s->n], sizeof s->name[0], "%s", line);
        s->data[s->n] = test_slurp(full, &s->len[s->n]);
        s->n++;
    }
    pclose(p);
}

int snap_has(const snap_t *s, const char *name)
{
    for (int i = 0; i < s->n; i++)
        if (strcmp(s->name[i], name) == 0 && s->data[i] != NULL)
            return 1;
    return 0;
}

void snap_check(const snap_t *s, const char *dir)
{
    for (int i = 0; i < s->n; i++) {
        char full[PATH_MAX + 300];
        snprintf(full, sizeof full, "%s/%s", dir, s->name[i]);
        size_t n = 0;
        uint8_t *now = test_slurp(full, &n);
        if (now == NULL || n != s->len[i] || memcmp(now, s->data[i], n) != 0)
            fail_msg("%s changed or vanished", full);
        free(now);
    }
    char cmd[PATH_MAX + 64];
    snprintf(cmd, sizeof cmd, "ls -A '%s' | grep -c 'fstmp$'", dir);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    int left = -1;
    assert_int_equal(fscanf(p, "%d", &left), 1);
    pclose(p);
    if (left != 0)
        fail_msg("%d temporary file(s) left in %s", left, dir);
}

void snap_free(snap_t *s)
{
    for (int i = 0; i < s->n; i++)
        free(s->data[i]);
}
