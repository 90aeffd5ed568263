/* Command-line values of the board programs (board_train, board_hil, board_robot): the C library alone, so
 * the same parsing runs on every board. */
#ifndef BOARD_ARGS_H
#define BOARD_ARGS_H

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* s as a decimal in [lo, hi] into *out: 0, or -EINVAL (missing, not a number, out of range). */
static inline int board_parse_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *out)
{
    char *end;
    unsigned long v = s != NULL ? strtoul(s, &end, 10) : 0;
    if (s == NULL || *s == '\0' || *end != '\0' || v < lo || v > hi)
        return -EINVAL;
    *out = (uint32_t)v;
    return 0;
}

/* s as a finite decimal in [lo, hi] into *out: 0, or -EINVAL. */
static inline int board_parse_double(const char *s, double lo, double hi, double *out)
{
    char *end;
    const double d = s != NULL ? strtod(s, &end) : NAN;
    if (s == NULL || *s == '\0' || *end != '\0' || !isfinite(d) || d < lo || d > hi)
        return -EINVAL;
    *out = d;
    return 0;
}

/* Says on stderr why `prog` refused an option: unknown (known == 0; or its value missing), or a
 * bad value for a known one. Returns -EINVAL, for the parser to return. */
static inline int board_bad_option(const char *prog, const char *opt, const char *value, int known)
{
    if (!known)
        fprintf(stderr, "%s: unknown option '%s' or its value missing (see --help)\n", prog, opt);
    else
        fprintf(stderr, "%s: bad value for %s: '%s' (see --help)\n", prog, opt, value ? value : "");
    return -EINVAL;
}

#endif /* BOARD_ARGS_H */
