/* Command-line values of the board programs (board_train, board_hil): the C library alone, so
 * the same parsing runs on every board. */
#ifndef BOARD_ARGS_H
#define BOARD_ARGS_H

#include <errno.h>
#include <stdint.h>
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

#endif /* BOARD_ARGS_H */
