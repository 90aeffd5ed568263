/* Helpers shared by the host_sim sub-commands: strict option-value parsing with messages,
 * and preparing output directories. */
#ifndef HOST_SIM_APP_CLI_H
#define HOST_SIM_APP_CLI_H

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ai/dinno.h"
#include "hal_host_file.h"

typedef void (*cmd_usage_fn)(FILE *out);

/* 1 when `opt` stands in the command's --help text as a whole word: the usage text is the
 * one list of a command's options. */
static inline int cmd_option_listed(cmd_usage_fn usage, const char *opt)
{
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    if (f == NULL)
        return 0;
    usage(f);
    fclose(f);
    int found = 0;
    const size_t n = strlen(opt);
    for (const char *p = text; n > 0 && (p = strstr(p, opt)) != NULL; p += n) {
        const char before = p == text ? ' ' : p[-1], after = p[n];
        if ((before == ' ' || before == '[' || before == '|' || before == '\n') &&
            (after == ' ' || after == ']' || after == '\n' || after == '|' || after == '=' || after == '\0')) {
            found = 1;
            break;
        }
    }
    free(text);
    return found;
}

/* 0 when argv[i] has a value after it. Otherwise prints why, naming the option: "unknown
 * option" when the command's --help does not list it, "needs a value" when it does. */
static inline int cmd_need_value(int argc, char **argv, int i, const char *cmd, cmd_usage_fn usage)
{
    if (i + 1 < argc)
        return 0;
    if (usage != NULL && !cmd_option_listed(usage, argv[i]))
        fprintf(stderr, "host_sim %s: unknown option '%s' (see --help)\n", cmd, argv[i]);
    else
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

/* The DiNNO optimiser options `host_sim fleet` and `host_sim run` share (one spelling, one
 * range each). Returns 1 when `opt` is one of them (*bad = 1 when its value was refused, with
 * the message printed), 0 when it is not. */
static inline int cmd_parse_dinno_opt(const char *opt, const char *v, dinno_cfg_t *d, int *bad)
{
    long long ll = 0;
    double dv = 0.0;
    if (strcmp(opt, "--batch") == 0) {
        *bad = cmd_parse_ll(v, opt, 1, BNN_MAX_BATCH, &ll);
        d->batch = (uint32_t)ll;
    } else if (strcmp(opt, "--primal-steps") == 0 || strcmp(opt, "--steps-per-round") == 0) {
        *bad = cmd_parse_ll(v, opt, 1, 100000, &ll);
        d->primal_steps = (uint32_t)ll;
    } else if (strcmp(opt, "--kl-weight") == 0) {
        *bad = cmd_parse_double(v, opt, 0.0, 1e6, &dv);
        d->kl_weight = (float)dv;
    } else if (strcmp(opt, "--w-mu") == 0) {
        *bad = cmd_parse_double(v, opt, 0.0, 1e6, &dv);
        d->w_mu = (float)dv;
    } else if (strcmp(opt, "--w-rho") == 0) {
        *bad = cmd_parse_double(v, opt, 0.0, 1e6, &dv);
        d->w_rho = (float)dv;
    } else if (strcmp(opt, "--rho0") == 0) {
        *bad = cmd_parse_double(v, opt, 1e-9, 1e6, &dv);
        d->rho0 = (float)dv;
    } else if (strcmp(opt, "--rho-scaling") == 0) {
        *bad = cmd_parse_double(v, opt, 1e-3, 10.0, &dv);
        d->rho_scaling = (float)dv;
    } else if (strcmp(opt, "--lr-start") == 0) {
        *bad = cmd_parse_double(v, opt, 1e-12, 10.0, &dv);
        d->lr_start = (float)dv;
    } else if (strcmp(opt, "--lr-end") == 0) {
        *bad = cmd_parse_double(v, opt, 1e-12, 10.0, &dv);
        d->lr_end = (float)dv;
    } else if (strcmp(opt, "--kl-form") == 0) {
        *bad = dinno_kl_form_parse(v, &d->kl_form) != 0;
        if (*bad)
            fprintf(stderr, "host_sim: %s: '%s' is not own, reverse or full\n", opt, v);
    } else if (strcmp(opt, "--kl-reduce") == 0) {
        *bad = dinno_kl_reduce_parse(v, &d->kl_reduce) != 0;
        if (*bad)
            fprintf(stderr, "host_sim: %s: '%s' is not sum or mean\n", opt, v);
    } else if (strcmp(opt, "--rho-pred-grad") == 0) {
        *bad = cmd_parse_ll(v, opt, 0, 1, &ll);
        d->rho_pred_grad = (int)ll;
    } else if (strcmp(opt, "--screen-radius") == 0) {
        *bad = cmd_parse_double(v, opt, 0.0, 1e6, &dv);
        d->screen_radius = (float)dv;
    } else {
        return 0;
    }
    return 1;
}

#endif /* HOST_SIM_APP_CLI_H */
