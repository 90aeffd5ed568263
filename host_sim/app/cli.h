/* Helpers shared by the host_sim sub-commands: strict option-value parsing with messages,
 * and creating an output directory. */
#ifndef HOST_SIM_APP_CLI_H
#define HOST_SIM_APP_CLI_H

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>

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

/* mkdir -p: 0, or -errno (-ENAMETOOLONG for a path over 4095 characters). */
static inline int cmd_mkdir_p(const char *dir)
{
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s", dir) >= (int)sizeof tmp)
        return -ENAMETOOLONG;
    for (char *p = tmp + 1; *p; p++) {
        if (*p != '/')
            continue;
        *p = '\0';
        if (mkdir(tmp, 0777) != 0 && errno != EEXIST)
            return -errno;
        *p = '/';
    }
    if (mkdir(tmp, 0777) != 0 && errno != EEXIST)
        return -errno;
    return 0;
}

#endif /* HOST_SIM_APP_CLI_H */
