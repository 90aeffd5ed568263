/* One option table per host_sim command: parsing and help from the table (cli_opts.h). */
#include "cli_opts.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define CLI_MAX_OPTS 256 /* options of one table, sub-tables included */
#define CLI_HELP_WIDTH 100
#define CLI_HELP_MAX_COL 26

/* An option found in a table: the entry, the offset of its struct in the options struct, and
 * its index in table order (sub-tables flattened). */
typedef struct cli_hit {
    const cli_opt_t *opt;
    size_t base;
    int index;
} cli_hit_t;

/* 1 when `name` (n bytes) is one of the '|'-separated `names`. */
static int name_in(const char *names, const char *name, size_t n)
{
    for (const char *p = names; p != NULL && *p != '\0';) {
        const char *bar = strchr(p, '|');
        const size_t len = bar ? (size_t)(bar - p) : strlen(p);
        if (len == n && strncmp(p, name, n) == 0)
            return 1;
        p = bar ? bar + 1 : NULL;
    }
    return 0;
}

/* Finds `name` in the table (depth first); *index counts the options passed. */
static int find(const cli_opt_t *t, size_t base, const char *name, size_t n, int *index, cli_hit_t *hit)
{
    for (; t->type != CLI_T_END; t++) {
        if (t->type == CLI_T_INCLUDE) {
            if (find(t->sub, base + t->off, name, n, index, hit))
                return 1;
            continue;
        }
        if (name_in(t->names, name, n)) {
            hit->opt = t;
            hit->base = base;
            hit->index = *index;
            return 1;
        }
        (*index)++;
    }
    return 0;
}

static void store_int(void *field, size_t size, long long v)
{
    if (size == sizeof(int32_t)) {
        const int32_t x = (int32_t)v;
        memcpy(field, &x, sizeof x);
    } else {
        const int64_t x = (int64_t)v;
        memcpy(field, &x, sizeof x);
    }
}

static long long load_int(const void *field, size_t size)
{
    if (size == sizeof(int32_t)) {
        int32_t x;
        memcpy(&x, field, sizeof x);
        return x;
    }
    int64_t x;
    memcpy(&x, field, sizeof x);
    return (long long)x;
}

static void store_double(void *field, size_t size, double v)
{
    if (size == sizeof(float)) {
        const float x = (float)v;
        memcpy(field, &x, sizeof x);
    } else {
        memcpy(field, &v, sizeof v);
    }
}

static double load_double(const void *field, size_t size)
{
    if (size == sizeof(float)) {
        float x;
        memcpy(&x, field, sizeof x);
        return (double)x;
    }
    double x;
    memcpy(&x, field, sizeof x);
    return x;
}

int cli_choice_name(const char *choices, int index, char *out, size_t cap)
{
    const char *p = choices;
    for (int k = 0; p != NULL && k < index; k++) {
        p = strchr(p, '|');
        p = p ? p + 1 : NULL;
    }
    if (p == NULL || index < 0 || cap == 0)
        return -1;
    const char *bar = strchr(p, '|');
    size_t len = bar ? (size_t)(bar - p) : strlen(p);
    if (len >= cap)
        len = cap - 1;
    memcpy(out, p, len);
    out[len] = '\0';
    return 0;
}

/* "'v' is not a, b or c": the message of a refused choice. */
static void choice_refused(const char *cmd, const char *opt, const char *v, const char *choices)
{
    fprintf(stderr, "host_sim %s: %s: '%s' is not ", cmd, opt, v);
    char name[64];
    int n = 0;
    while (cli_choice_name(choices, n, name, sizeof name) == 0)
        n++;
    for (int k = 0; k < n; k++) {
        (void)cli_choice_name(choices, k, name, sizeof name);
        fprintf(stderr, "%s%s", k == 0 ? "" : k == n - 1 ? " or " : ", ", name);
    }
    fputc('\n', stderr);
}

/* Sets the option's field from `v`; 0, or -1 with the reason printed. */
static int apply(const char *cmd, const cli_hit_t *h, const char *opt, const char *v, void *opts)
{
    const cli_opt_t *o = h->opt;
    void *field = (char *)opts + h->base + o->off;
    switch (o->type) {
    case CLI_T_FLAG:
        store_int(field, o->size, o->ilo);
        return 0;
    case CLI_T_STRING:
        memcpy(field, &v, sizeof v);
        return 0;
    case CLI_T_INT: {
        char *end = NULL;
        errno = 0;
        const long long x = strtoll(v, &end, 10);
        if (end == v || *end != '\0' || errno != 0 || x < o->ilo || x > o->ihi) {
            fprintf(stderr, "host_sim %s: %s: '%s' is not an integer in [%lld, %lld]\n", cmd, opt, v, o->ilo, o->ihi);
            return -1;
        }
        store_int(field, o->size, x);
        return 0;
    }
    case CLI_T_DOUBLE: {
        char *end = NULL;
        errno = 0;
        const double x = strtod(v, &end);
        if (end == v || *end != '\0' || errno != 0 || !isfinite(x) || x < o->dlo || x > o->dhi) {
            fprintf(stderr, "host_sim %s: %s: '%s' is not a number in [%g, %g]\n", cmd, opt, v, o->dlo, o->dhi);
            return -1;
        }
        store_double(field, o->size, x);
        return 0;
    }
    case CLI_T_CHOICE: {
        char name[64];
        for (int k = 0; cli_choice_name(o->choices, k, name, sizeof name) == 0; k++)
            if (strcmp(name, v) == 0) {
                store_int(field, o->size, o->values ? o->values[k] : k);
                return 0;
            }
        choice_refused(cmd, opt, v, o->choices);
        return -1;
    }
    case CLI_T_HEX64: {
        const size_t n = strlen(v);
        int ok = n >= 1 && n <= 16;
        for (size_t i = 0; ok && i < n; i++)
            ok = (v[i] >= '0' && v[i] <= '9') || (v[i] >= 'a' && v[i] <= 'f') || (v[i] >= 'A' && v[i] <= 'F');
        if (!ok) {
            fprintf(stderr, "host_sim %s: %s: '%s' is not 1 to 16 hexadecimal digits\n", cmd, opt, v);
            return -1;
        }
        const uint64_t x = (uint64_t)strtoull(v, NULL, 16);
        memcpy(field, &x, sizeof x);
        return 0;
    }
    case CLI_T_CUSTOM:
        return o->fn(cmd, opt, v, field, opts);
    default:
        return -1;
    }
}

/* The first option of the table (in order) that is required and not seen; NULL: none. */
static const cli_opt_t *first_missing(const cli_opt_t *t, const unsigned char *seen, int *index)
{
    for (; t->type != CLI_T_END; t++) {
        if (t->type == CLI_T_INCLUDE) {
            const cli_opt_t *m = first_missing(t->sub, seen, index);
            if (m != NULL)
                return m;
            continue;
        }
        if (t->required && (*index >= CLI_MAX_OPTS || !seen[*index]))
            return t;
        (*index)++;
    }
    return NULL;
}

int cli_opts_parse(const cli_parser_t *p, int argc, char **argv, void *opts, char **operands, int *n_operands)
{
    unsigned char seen[CLI_MAX_OPTS] = {0};
    int n_ops = 0, only_operands = 0;
    if (n_operands != NULL)
        *n_operands = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const int is_opt = !only_operands && a[0] == '-' && a[1] != '\0';
        if (is_opt && (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0)) {
            p->usage(stdout);
            return 1;
        }
        if (is_opt && strcmp(a, "--version") == 0) {
            cli_version(stdout);
            return 1;
        }
        if (!is_opt) {
            if (p->operands == NULL || operands == NULL) {
                fprintf(stderr, "host_sim %s: unexpected argument '%s' (see --help)\n", p->cmd, a);
                return -1;
            }
            operands[n_ops++] = argv[i];
            continue;
        }
        if (strcmp(a, "--") == 0) {
            only_operands = 1;
            continue;
        }
        if (p->options_first && n_ops > 0) {
            fprintf(stderr, "host_sim %s: options must come before the %s ('%s')\n", p->cmd, p->operands, a);
            return -1;
        }
        const char *eq = strncmp(a, "--", 2) == 0 ? strchr(a, '=') : NULL;
        const size_t n = eq ? (size_t)(eq - a) : strlen(a);
        char opt[128];
        snprintf(opt, sizeof opt, "%.*s", (int)n, a);
        cli_hit_t h;
        int index = 0;
        if (!find(p->opts, 0, a, n, &index, &h)) {
            fprintf(stderr, "host_sim %s: unknown option '%s' (see --help)\n", p->cmd, opt);
            return -1;
        }
        const char *v = NULL;
        if (h.opt->type == CLI_T_FLAG) {
            if (eq != NULL) {
                fprintf(stderr, "host_sim %s: option %s takes no value\n", p->cmd, opt);
                return -1;
            }
        } else if (eq != NULL) {
            v = eq + 1;
        } else if (i + 1 < argc) {
            v = argv[++i];
        } else {
            fprintf(stderr, "host_sim %s: option %s needs a value\n", p->cmd, opt);
            return -1;
        }
        if (apply(p->cmd, &h, opt, v, opts) != 0)
            return -1;
        if (h.index < CLI_MAX_OPTS)
            seen[h.index] = 1;
        if (h.opt->given != 0) {
            const int one = 1;
            memcpy((char *)opts + h.opt->given - 1, &one, sizeof one);
        }
    }
    int index = 0;
    const cli_opt_t *missing = first_missing(p->opts, seen, &index);
    if (missing != NULL) {
        const char *bar = strchr(missing->names, '|');
        fprintf(stderr, "host_sim %s: %.*s is required (see --help)\n", p->cmd,
                (int)(bar ? (size_t)(bar - missing->names) : strlen(missing->names)), missing->names);
        return -1;
    }
    if (n_operands != NULL)
        *n_operands = n_ops;
    return 0;
}

/* "  --robot, --id I": the left column of an option. */
static void left_of(const cli_opt_t *o, char *out, size_t cap)
{
    size_t k = (size_t)snprintf(out, cap, "  ");
    for (const char *p = o->names; *p != '\0' && k + 3 < cap; p++) {
        if (*p == '|') {
            out[k++] = ',';
            out[k++] = ' ';
        } else {
            out[k++] = *p;
        }
    }
    out[k] = '\0';
    const char *meta = o->meta ? o->meta : o->type == CLI_T_CHOICE ? o->choices : NULL;
    if (meta != NULL && o->type != CLI_T_FLAG)
        snprintf(out + k, cap - k, " %s", meta);
}

static size_t widest(const cli_opt_t *t)
{
    size_t w = 0;
    char left[256];
    for (; t->type != CLI_T_END; t++) {
        if (t->type == CLI_T_INCLUDE) {
            const size_t s = widest(t->sub);
            w = s > w ? s : w;
            continue;
        }
        left_of(t, left, sizeof left);
        const size_t n = strlen(left);
        if (n <= CLI_HELP_MAX_COL && n > w)
            w = n;
    }
    return w;
}

/* " (default X)", " (required)" or "" for one option. */
static void default_of(const cli_opt_t *o, const void *field, char *out, size_t cap)
{
    char v[128] = "";
    if (o->required) {
        snprintf(out, cap, " (required)");
        return;
    }
    if (o->def != NULL)
        snprintf(v, sizeof v, "%s", o->def);
    else if (field != NULL && o->type == CLI_T_INT)
        snprintf(v, sizeof v, "%lld", load_int(field, o->size));
    else if (field != NULL && o->type == CLI_T_DOUBLE)
        snprintf(v, sizeof v, "%g", load_double(field, o->size));
    else if (field != NULL && o->type == CLI_T_STRING) {
        const char *s;
        memcpy(&s, field, sizeof s);
        snprintf(v, sizeof v, "%s", s ? s : "");
    } else if (field != NULL && o->type == CLI_T_CHOICE) {
        const long long x = load_int(field, o->size);
        char name[64];
        for (int k = 0; cli_choice_name(o->choices, k, name, sizeof name) == 0; k++)
            if ((o->values ? o->values[k] : k) == x) {
                snprintf(v, sizeof v, "%s", name);
                break;
            }
    }
    if (v[0] != '\0')
        snprintf(out, cap, " (default %s)", v);
    else
        out[0] = '\0';
}

/* Writes `text` from column `col` (the cursor being at column `at`), wrapped at the help width
 * on spaces, '\n' starting a new line. */
static void wrapped(FILE *out, const char *text, size_t col, size_t at)
{
    const char *p = text;
    while (*p != '\0') {
        if (*p == '\n') {
            fprintf(out, "\n%*s", (int)col, "");
            at = col;
            p++;
            continue;
        }
        if (*p == ' ') {
            p++;
            continue;
        }
        const size_t n = strcspn(p, " \n");
        if (at > col && at + 1 + n > CLI_HELP_WIDTH) {
            fprintf(out, "\n%*s", (int)col, "");
            at = col;
        } else if (at > col) {
            fputc(' ', out);
            at++;
        }
        fwrite(p, 1, n, out);
        at += n;
        p += n;
    }
    fputc('\n', out);
}

static void help_rows(FILE *out, const cli_opt_t *t, const char *defaults, size_t col)
{
    for (; t->type != CLI_T_END; t++) {
        if (t->type == CLI_T_INCLUDE) {
            help_rows(out, t->sub, defaults ? defaults + t->off : NULL, col);
            continue;
        }
        char left[256], def[160], text[2048];
        left_of(t, left, sizeof left);
        default_of(t, defaults ? defaults + t->off : NULL, def, sizeof def);
        snprintf(text, sizeof text, "%s%s", t->help ? t->help : "", def);
        size_t at = strlen(left);
        fputs(left, out);
        if (at + 1 >= col) {
            fprintf(out, "\n%*s", (int)col, "");
            at = col;
        } else {
            fprintf(out, "%*s", (int)(col - at), "");
            at = col;
        }
        wrapped(out, text, col, at);
    }
}

void cli_opts_help(FILE *out, const cli_opt_t *table, const void *defaults)
{
    help_rows(out, table, (const char *)defaults, widest(table) + 2);
}
