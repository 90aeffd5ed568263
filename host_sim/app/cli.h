/* Helpers shared by the host_sim sub-commands: strict option-value parsing with messages,
 * and preparing output directories. */
#ifndef HOST_SIM_APP_CLI_H
#define HOST_SIM_APP_CLI_H

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hal_host_file.h"

/* 0 when argv[i] has a value after it; prints an error otherwise. */
static inline int cmd_need_value(int argc, char **argv, int i, const char *cmd)
{
    if (i + 1 < argc)
        return 0;
    fprintf(stderr, "host_sim %s: option %s needs a value\n", cmd, argv[i]);
    return -1;
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

#endif /* HOST_SIM_APP_CLI_H */
