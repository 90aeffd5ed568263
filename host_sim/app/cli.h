/* Helpers shared by the host_sim sub-commands: strict option-value parsing with messages,
 * preparing output directories, the shared DiNNO option table (options: cli_opts.h), the wall
 * clock of progress lines. */
#ifndef HOST_SIM_APP_CLI_H
#define HOST_SIM_APP_CLI_H

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ai/dinno.h"
#include "cli_opts.h"
#include "hal_host_file.h"

/* Monotonic wall time in seconds (progress lines, timings; never the simulation's clock). */
static inline double cmd_wall_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static inline int cmd_parse_double(const char *s, const char *opt, double lo, double hi, double *out)
{
    char *end = NULL;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end != '\0' || errno != 0 || !isfinite(v) || v < lo || v > hi) {
        fprintf(stderr, "host_sim: %s: '%s' is not a number in [%g, %g]\n", opt, s, lo, hi);
        return -1;
    }
    *out = v;
    return 0;
}

static inline int cmd_parse_ll(const char *s, const char *opt, long long lo, long long hi, long long *out)
{
    char *end = NULL;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (end == s || *end != '\0' || errno != 0 || v < lo || v > hi) {
        fprintf(stderr, "host_sim: %s: '%s' is not an integer in [%lld, %lld]\n", opt, s, lo, hi);
        return -1;
    }
    *out = v;
    return 0;
}

/* 1 to 16 hexadecimal digits (no sign, no 0x) into a 64-bit value. */
static inline int cmd_parse_hex64(const char *s, const char *opt, uint64_t *out)
{
    size_t n = strlen(s);
    int ok = n >= 1 && n <= 16;
    for (size_t i = 0; ok && i < n; i++)
        ok = (s[i] >= '0' && s[i] <= '9') || (s[i] >= 'a' && s[i] <= 'f') || (s[i] >= 'A' && s[i] <= 'F');
    if (!ok) {
        fprintf(stderr, "host_sim: %s: '%s' is not 1 to 16 hexadecimal digits\n", opt, s);
        return -1;
    }
    *out = (uint64_t)strtoull(s, NULL, 16);
    return 0;
}

/* An output directory of `host_sim CMD`: created with its parents, refused when it (or a
 * parent) exists and is not a directory, and cleared of the temporary files an earlier run of
 * ours left when it was killed. Prints "host_sim CMD: DIR: reason" and returns -1 on error. */
static inline int cmd_prepare_out_dir(const char *cmd, const char *dir)
{
    int rc = hal_host_file_mkdirs(dir);
    if (rc == 0 && (rc = hal_host_file_clean_stale(dir)) > 0)
        rc = 0;
    if (rc < 0) {
        fprintf(stderr, "host_sim %s: %s: %s\n", cmd, dir, hal_host_file_strerror(rc));
        return -1;
    }
    return 0;
}

/* An output file of `host_sim cmd` through the one writer: begin, and commit (which drops the
 * file on failure). Each prints "host_sim CMD: PATH: reason" and returns -1 on error. */
static inline int cmd_out_begin(const char *cmd, hal_host_file_t *out, const char *path)
{
    int rc = hal_host_file_begin(out, path);
    if (rc < 0)
        fprintf(stderr, "host_sim %s: %s: %s\n", cmd, path, hal_host_file_strerror(rc));
    return rc < 0 ? -1 : 0;
}

static inline int cmd_out_commit(const char *cmd, hal_host_file_t *out)
{
    int rc = hal_host_file_commit(out);
    if (rc < 0) {
        fprintf(stderr, "host_sim %s: %s: %s\n", cmd, out->path, hal_host_file_strerror(rc));
        hal_host_file_abort(out);
    }
    return rc < 0 ? -1 : 0;
}

/* An output file whose format its name says: refused (with "host_sim CMD: OPT PATH: ...", for
 * exit status 2) unless PATH ends in one of the '|'-separated endings `exts` (".png", or
 * ".png|.pgm"), which name what the command writes: a picture named x.jpg would hold PNG bytes. */
static inline int cmd_check_out_ext(const char *cmd, const char *opt, const char *path, const char *exts, const char *what)
{
    const size_t n = strlen(path);
    for (const char *e = exts; *e != '\0';) {
        const size_t k = strcspn(e, "|");
        if (n > k && strncmp(path + n - k, e, k) == 0)
            return 0;
        e += k + (e[k] == '|');
    }
    fprintf(stderr, "host_sim %s: %s %s: the file written is %s: give a name ending in ", cmd, opt, path, what);
    for (const char *e = exts; *e != '\0';) {
        const size_t k = strcspn(e, "|");
        fprintf(stderr, "%s%.*s", e == exts ? "" : " or ", (int)k, e);
        e += k + (e[k] == '|');
    }
    fputc('\n', stderr);
    return -1;
}

/* The DiNNO optimiser options `host_sim fleet` and `host_sim run` share (cli_dinno.c): a
 * sub-table over a dinno_cfg_t, included in both commands' tables with CLI_INCLUDE. */
extern const cli_opt_t cmd_dinno_opts[];

#endif /* HOST_SIM_APP_CLI_H */
