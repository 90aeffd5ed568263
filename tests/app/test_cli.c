/* A newcomer's first hour with host_sim, on the real program (each case was a report):
 *   - `host_sim --version` (and `host_sim CMD --version`) names the commit and the build's preset,
 *     precision and instruction set;
 *   - scan and valset's help name their output as the project names samples files (.samples);
 *   - `run --offline --online` is refused (exit 2, one line), not "the last wins";
 *   - an image written as PNG must be named .png (render --out x.jpg: exit 2, nothing written);
 *   - `key check README.md` says "not a fleet key" (the contents), not "chmod 600" (the mode);
 *     a real key readable by others still says chmod 600;
 *   - a tour that does not open is "FILE: cannot open: reason", with no line number.
 * Run from the repository's root (as `make test` does). */
#define _XOPEN_SOURCE 700 /* realpath, mkdtemp */
#include <limits.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <cmocka.h>

#include "ai/bnn.h"
#include "run_outputs.h"

#define SHORT_PATH 1024
static char g_bin[SHORT_PATH];
static char g_dir[SHORT_PATH];
static char g_plan[PATH_MAX];
static char g_tour[PATH_MAX];
static char g_err[1 << 16], g_out[1 << 16];

static int hs(const char *const *args)
{
    return test_run(g_bin, args, -1, g_dir, g_err, g_out, sizeof g_err);
}
#define HS(...) hs((const char *const[]){"host_sim", __VA_ARGS__, NULL})

static void has(const char *text, const char *what, const char *want)
{
    if (strstr(text, want) == NULL)
        fail_msg("%s lacks '%s':\n%s", what, want, text);
}

static void lacks(const char *text, const char *what, const char *bad)
{
    if (strstr(text, bad) != NULL)
        fail_msg("%s has '%s':\n%s", what, bad, text);
}

/* One line of stderr, no more: the message a usage error prints. */
static void one_line(void)
{
    const char *nl = strchr(g_err, '\n');
    if (nl == NULL || nl[1] != '\0')
        fail_msg("stderr is not one line:\n%s", g_err);
}

static void in_dir(char *out, const char *name)
{
    snprintf(out, PATH_MAX, "%.1000s/%.60s", g_dir, name);
}

static int setup(void **st)
{
    (void)st;
    test_build_program("host_sim", g_bin, sizeof g_bin);
    snprintf(g_dir, sizeof g_dir, "/tmp/fleetsim-cli-XXXXXX");
    assert_non_null(mkdtemp(g_dir));
    assert_non_null(realpath("host_sim/plans/apartment.svg", g_plan));
    assert_non_null(realpath("host_sim/plans/apartment/robot_0.csv", g_tour));
    return 0;
}

static int teardown(void **st)
{
    (void)st;
    return test_remove_tree(g_dir);
}

static void test_version(void **st)
{
    (void)st;
    char preset[64];
    snprintf(preset, sizeof preset, "preset %s, precision %s", BNN_PRESET_NAME, BNN_PRECISION_NAME);
    const char *forms[][3] = {{"--version", NULL, NULL}, {"version", NULL, NULL}, {"run", "--version", NULL},
                              {"paths", "--version", NULL}, {"scan", "--plan", "--version"}};
    for (size_t k = 0; k < sizeof forms / sizeof forms[0]; k++) {
        const char *args[5] = {"host_sim", forms[k][0], forms[k][1], forms[k][2], NULL};
        /* "scan --plan --version": --version is the value of --plan, so that one is not it */
        const int value = forms[k][2] != NULL;
        const int rc = hs(args);
        if (value) {
            assert_int_not_equal(rc, 0);
            continue;
        }
        if (rc != 0)
            fail_msg("host_sim %s %s: exit %d\n%s", forms[k][0], forms[k][1] ? forms[k][1] : "", rc, g_err);
        assert_true(strncmp(g_out, "host_sim ", 9) == 0);
        assert_true(g_out[9] != '\n' && g_out[9] != '\0'); /* a commit, or "unknown" */
        has(g_out, "--version", preset);
        has(g_out, "--version", "ARCH=");
        has(g_out, "--version", "fp32 products ");
        has(g_out, "--version", "bf16 products ");
    }
    /* The usage names it. */
    assert_int_equal(HS("--help"), 0);
    has(g_out, "--help", "--version");
}

static void test_samples_are_named_samples(void **st)
{
    (void)st;
    assert_int_equal(HS("scan", "--help"), 0);
    has(g_out, "scan --help", "--out FILE.samples");
    lacks(g_out, "scan --help", ".bin");
    assert_int_equal(HS("valset", "--help"), 0);
    has(g_out, "valset --help", "--out VAL.samples");
    lacks(g_out, "valset --help", ".bin");
}

static void test_two_modes_refused(void **st)
{
    (void)st;
    char out[PATH_MAX];
    in_dir(out, "modes");
    const char *orders[2][2] = {{"--offline", "--online"}, {"--online", "--offline"}};
    for (int k = 0; k < 2; k++) {
        assert_int_equal(HS("run", "--plan", g_plan, "--path", g_tour, "--out", out, orders[k][0], orders[k][1]), 2);
        has(g_err, "stderr", "--online and --offline");
        one_line();
    }
    assert_int_not_equal(access(out, F_OK), 0); /* refused before anything was made */
    /* One of them, even twice, is fine (the parse goes on to the next check: --resume). */
    assert_int_equal(HS("run", "--plan", g_plan, "--path", g_tour, "--out", out, "--online", "--online", "--resume"), 2);
    has(g_err, "stderr", "--resume needs --offline");
}

static void test_png_outputs_named_png(void **st)
{
    (void)st;
    char jpg[PATH_MAX], paths_out[PATH_MAX];
    in_dir(jpg, "x.jpg");
    assert_int_equal(HS("render", "--plan", g_plan, "--out", jpg), 2);
    has(g_err, "stderr", "x.jpg");
    has(g_err, "stderr", "ending in .png");
    one_line();
    assert_int_not_equal(access(jpg, F_OK), 0);
    in_dir(paths_out, "tours");
    assert_int_equal(HS("paths", "gen", "--plan", g_plan, "--robots", "2", "--seed", "1", "--out", paths_out, "--png",
                        jpg),
                     2);
    has(g_err, "stderr", "ending in .png");
    assert_int_not_equal(access(paths_out, F_OK), 0);
    assert_int_equal(HS("plan", "grid", g_plan, "--res", "0.5", "--out", jpg), 2);
    has(g_err, "stderr", "ending in .png or .pgm");
    assert_int_not_equal(access(jpg, F_OK), 0);
}

/* The ZeroMQ proxy and the run options that use it: bad usage is refused with the reason. */
static void test_zmq_proxy_refusals(void **st)
{
    (void)st;
    assert_int_equal(HS("zmq-proxy"), 2);
    has(g_err, "stderr", "--port");
    assert_int_equal(HS("zmq-proxy", "--port", "0"), 2);
    assert_int_equal(HS("zmq-proxy", "--port", "65535"), 2); /* no P + 1 */
    assert_int_equal(HS("zmq-proxy", "--port", "7000", "--bind", "a b"), 2);
    has(g_err, "stderr", "not a host");
    assert_int_equal(HS("zmq-proxy", "--help"), 0);
    has(g_out, "zmq-proxy --help", "--zmq-proxy HOST:P");
    char out[PATH_MAX];
    in_dir(out, "proxied");
    assert_int_equal(HS("run", "--plan", g_plan, "--path", g_tour, "--out", out, "--fleet", "2", "--id", "0",
                        "--transport", "zmq", "--zmq-proxy", "127.0.0.1:7000", "--peers", "127.0.0.1:1,127.0.0.1:2"),
                     2);
    has(g_err, "stderr", "either --peers");
    assert_int_equal(HS("run", "--plan", g_plan, "--path", g_tour, "--out", out, "--fleet", "2", "--id", "0",
                        "--zmq-proxy", "127.0.0.1:7000"),
                     2);
    has(g_err, "stderr", "are for --transport zmq");
    assert_int_not_equal(access(out, F_OK), 0); /* refused before anything was made */
}

static void write_file(const char *path, const char *text, mode_t mode)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
    assert_int_equal(chmod(path, mode), 0);
}

static void test_key_check_reads_the_contents_first(void **st)
{
    (void)st;
    assert_int_equal(HS("key", "check", "README.md"), 1);
    has(g_err, "stderr", "README.md: not a fleet key");
    lacks(g_err, "stderr", "chmod");
    char p[PATH_MAX];
    in_dir(p, "notes.txt");
    write_file(p, "not a key\n", 0644);
    assert_int_equal(HS("key", "check", p), 1);
    has(g_err, "stderr", "not a fleet key");
    lacks(g_err, "stderr", "chmod");
    /* A key readable by others: now the mode is the fault. */
    in_dir(p, "fleet.key");
    assert_int_equal(HS("key", "new", p), 0);
    assert_int_equal(HS("key", "check", p), 0);
    assert_int_equal(chmod(p, 0644), 0);
    assert_int_equal(HS("key", "check", p), 1);
    has(g_err, "stderr", "chmod 600");
}

static void test_missing_tour_has_no_line(void **st)
{
    (void)st;
    char s[PATH_MAX];
    in_dir(s, "x.samples");
    assert_int_equal(HS("scan", "--plan", g_plan, "--path", "nosuch.csv", "--out", s), 1);
    has(g_err, "stderr", "nosuch.csv: cannot open: No such file or directory\n");
    lacks(g_err, "stderr", "nosuch.csv:0");
    assert_int_equal(HS("paths", "check", "--plan", g_plan, "nosuch.csv"), 1);
    has(g_err, "stderr", "nosuch.csv: cannot open: No such file or directory\n");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_version),
        cmocka_unit_test(test_samples_are_named_samples),
        cmocka_unit_test(test_two_modes_refused),
        cmocka_unit_test(test_png_outputs_named_png),
        cmocka_unit_test(test_key_check_reads_the_contents_first),
        cmocka_unit_test(test_zmq_proxy_refusals),
        cmocka_unit_test(test_missing_tour_has_no_line),
    };
    return cmocka_run_group_tests_name("app/cli", tests, setup, teardown);
}
