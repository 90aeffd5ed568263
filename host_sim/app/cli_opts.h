/* One option table per host_sim command: each option is described once (names and aliases,
 * type, range or choices, default, help line) and the table gives the parsing, the range
 * checks, the "unknown option" / "needs a value" / "is required" messages and the option list
 * of --help (getopt_long's table and argparse's idea, in C11, without global state).
 *
 * A table is a static const array of cli_opt_t ending with CLI_OPT_END; each entry names a
 * field of the command's options struct by offset (CLI_INT(T, field, lo, hi) and friends), so
 * one table serves every parse and the help shows the defaults of a struct filled with them:
 *
 *     static const cli_opt_t valset_opts[] = {
 *         {.names = "--poses", .meta = "N", CLI_INT(valset_opts_t, c.n_poses, 1, 1000000),
 *          .help = "number of poses"},
 *         {.names = "-q|--quiet", CLI_FLAG(valset_opts_t, quiet, 1), .help = "no progress lines"},
 *         CLI_OPT_END,
 *     };
 *
 * Types: FLAG (no value; stores its value in an int), INT (long long range, into an int,
 * uint32_t, long long or uint64_t field), DOUBLE (range, into a double or float), STRING (the
 * argv pointer), CHOICE (one of "a|b|c"; stores the choice's index or values[index] in an int or
 * enum field), HEX64 (1 to 16 hexadecimal digits into a uint64_t), CUSTOM (a callback) and
 * INCLUDE (a shared sub-table whose offsets are relative to a sub-struct, e.g. the DiNNO options).
 * Values follow the option (--seed 3) or an '=' (--seed=3); repeated options: the last wins
 * (CUSTOM may accumulate); "--" ends the options. Checks across options stay in the commands. */
#ifndef HOST_SIM_APP_CLI_OPTS_H
#define HOST_SIM_APP_CLI_OPTS_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

typedef enum cli_type {
    CLI_T_END = 0,
    CLI_T_FLAG,
    CLI_T_INT,
    CLI_T_DOUBLE,
    CLI_T_STRING,
    CLI_T_CHOICE,
    CLI_T_HEX64,
    CLI_T_CUSTOM,
    CLI_T_INCLUDE,
} cli_type_t;

/* A CUSTOM option's parser: `field` points at its field, `opts` at the whole options struct.
 * Returns 0, or -1 after printing "host_sim CMD: OPT: why" to stderr. */
typedef int (*cli_custom_fn)(const char *cmd, const char *opt, const char *value, void *field, void *opts);

typedef struct cli_opt {
    cli_type_t type;
    const char *names;   /* "--robot|--id", "-q|--quiet": the first is the option's name */
    const char *meta;    /* the value in the help ("N", "FILE"); CHOICE without one: "a|b|c" */
    const char *help;    /* the help line (wrapped to the terminal-friendly width) */
    size_t off, size;    /* the field: offsetof and sizeof (INCLUDE: the sub-struct's offset) */
    long long ilo, ihi;  /* INT range; FLAG: ilo is the value stored */
    double dlo, dhi;     /* DOUBLE range */
    const char *choices; /* CHOICE: "kl|separate|uniform" */
    const int *values;   /* CHOICE: the value stored per choice; NULL: its index */
    cli_custom_fn fn;    /* CUSTOM */
    const struct cli_opt *sub; /* INCLUDE */
    const char *def;     /* default in the help: NULL = the field's value in the defaults, "" = none */
    size_t given;        /* 0, or 1 + offsetof an int field set to 1 when the option is given */
    int required;        /* parse fails with "OPT is required" when it is not given */
} cli_opt_t;

#define CLI_FIELD_(T, m) .off = offsetof(T, m), .size = sizeof(((T *)0)->m)
#define CLI_FLAG(T, m, value) .type = CLI_T_FLAG, CLI_FIELD_(T, m), .ilo = (value)
#define CLI_INT(T, m, lo, hi) .type = CLI_T_INT, CLI_FIELD_(T, m), .ilo = (lo), .ihi = (hi)
#define CLI_DOUBLE(T, m, lo, hi) .type = CLI_T_DOUBLE, CLI_FIELD_(T, m), .dlo = (lo), .dhi = (hi)
#define CLI_STRING(T, m) .type = CLI_T_STRING, CLI_FIELD_(T, m)
#define CLI_CHOICE(T, m, list) .type = CLI_T_CHOICE, CLI_FIELD_(T, m), .choices = (list)
#define CLI_HEX64(T, m) .type = CLI_T_HEX64, CLI_FIELD_(T, m)
#define CLI_CUSTOM(T, m, f) .type = CLI_T_CUSTOM, CLI_FIELD_(T, m), .fn = (f)
#define CLI_INCLUDE(T, m, table) .type = CLI_T_INCLUDE, .off = offsetof(T, m), .sub = (table)
#define CLI_GIVEN(T, m) .given = 1 + offsetof(T, m)
#define CLI_OPT_END {.type = CLI_T_END}

typedef struct cli_parser {
    const char *cmd;           /* messages start "host_sim CMD: " */
    const cli_opt_t *opts;     /* the table */
    void (*usage)(FILE *out);  /* --help and -h print it to stdout */
    const char *operands;      /* NULL: no operands ("unexpected argument"); else what they are */
    int options_first;         /* 1: no option after the first operand */
} cli_parser_t;

/* Parses argv[1..argc-1] into `opts` (already holding the defaults). Operands (arguments not
 * starting with '-', or "-", or anything after "--") go to operands[] (room for argc) when the
 * parser takes them, *n_operands counting them. Returns 0, 1 after --help or --version
 * (printed), or -1 after printing the reason of a usage error to stderr. */
int cli_opts_parse(const cli_parser_t *p, int argc, char **argv, void *opts, char **operands, int *n_operands);

/* --version of every command (and `host_sim --version`): the commit and the build's
 * configuration, on `out` (host_sim/app/cmd_version.c). */
void cli_version(FILE *out);

/* The option list of --help: one entry per option (aliases together), its help wrapped and
 * followed by "(default X)" read from `defaults` (a struct filled with the defaults; NULL: no
 * defaults but the tables' .def texts) or "(required)". */
void cli_opts_help(FILE *out, const cli_opt_t *table, const void *defaults);

/* The index-th choice of "a|b|c" into out (cap bytes); 0, or -1 when there is none. */
int cli_choice_name(const char *choices, int index, char *out, size_t cap);

#endif /* HOST_SIM_APP_CLI_OPTS_H */
