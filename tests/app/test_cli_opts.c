/* host_sim's option tables (host_sim/app/cli_opts.h): every type (flag, int, double, string,
 * choice, hex64, custom, an included sub-table), ranges, choices, aliases, a missing value, an
 * unknown option, flags given a value, repeated options (the last wins), required options,
 * operands ("--", options first) and the generated --help listing with its defaults. The messages
 * are the ones the command tests (tests/app/test_outputs.c, test_maps.c) match. */
#define _XOPEN_SOURCE 700 /* open_memstream, dup */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "app/cli_opts.c" /* the module under test (host_sim/app is not a library) */

/* host_sim's --version (cmd_version.c, not linked here): counted. */
static int g_version_calls;
void cli_version(FILE *out)
{
    (void)out;
    g_version_calls++;
}

typedef struct sub {
    int depth;
    double weight;
} sub_t;

typedef struct topts {
    int flag, off_flag;
    int i32;
    long long i64;
    uint32_t u32;
    uint64_t u64;
    double dbl;
    float flt;
    const char *str, *req;
    int choice, mapped;
    uint64_t hex;
    int hex_given;
    int n_custom;
    const char *custom_last;
    sub_t sub;
} topts_t;

static topts_t defaults(void)
{
    return (topts_t){.off_flag = 1, .i32 = 7, .i64 = -1, .u32 = 3, .u64 = 11, .dbl = 0.5, .flt = 0.25f,
                     .str = "abc", .req = NULL, .choice = 1, .mapped = 20, .sub = {.depth = 2, .weight = 1.5}};
}

static int count_custom(const char *cmd, const char *opt, const char *v, void *field, void *opts)
{
    topts_t *o = opts;
    if (strcmp(v, "bad") == 0) {
        fprintf(stderr, "host_sim %s: %s: '%s' is refused\n", cmd, opt, v);
        return -1;
    }
    memcpy(field, &v, sizeof v);
    o->n_custom++;
    return 0;
}

static const cli_opt_t sub_opts[] = {
    {.names = "--depth", .meta = "D", CLI_INT(sub_t, depth, 0, 9), .help = "a sub-table option"},
    {.names = "-w|--weight", .meta = "W", CLI_DOUBLE(sub_t, weight, 0.0, 10.0), .help = "another"},
    CLI_OPT_END,
};

static const cli_opt_t t_opts[] = {
    {.names = "--flag", CLI_FLAG(topts_t, flag, 1), .help = "a flag"},
    {.names = "--no-off", CLI_FLAG(topts_t, off_flag, 0), .help = "clears off_flag"},
    {.names = "-n|--number|--num", .meta = "N", CLI_INT(topts_t, i32, 1, 100), .help = "an int in [1, 100]"},
    {.names = "--long", .meta = "L", CLI_INT(topts_t, i64, -5, INT64_MAX), .help = "a long long"},
    {.names = "--u32", .meta = "U", CLI_INT(topts_t, u32, 0, 4000000000LL), .help = "a uint32_t"},
    {.names = "--u64", .meta = "U", CLI_INT(topts_t, u64, 0, INT64_MAX), .help = "a uint64_t"},
    {.names = "--dbl", .meta = "X", CLI_DOUBLE(topts_t, dbl, -1.0, 1.0), .help = "a double"},
    {.names = "--flt", .meta = "F", CLI_DOUBLE(topts_t, flt, 0.0, 2.0), .help = "a float"},
    {.names = "--str", .meta = "S", CLI_STRING(topts_t, str), .help = "a string"},
    {.names = "--req", .meta = "R", CLI_STRING(topts_t, req), .required = 1, .help = "required"},
    {.names = "--choice", CLI_CHOICE(topts_t, choice, "a|b|c"), .help = "by index"},
    {.names = "--mapped", .meta = "M", CLI_CHOICE(topts_t, mapped, "x|y"), .values = (const int[]){10, 20},
     .help = "by value"},
    {.names = "--hex", .meta = "H", CLI_HEX64(topts_t, hex), CLI_GIVEN(topts_t, hex_given), .help = "hex"},
    {.names = "--custom", .meta = "C", CLI_CUSTOM(topts_t, custom_last, count_custom), .def = "none",
     .help = "a callback, repeatable; this help text is long enough to be wrapped onto a second line of the "
             "listing, under its own column"},
    {CLI_INCLUDE(topts_t, sub, sub_opts)},
    CLI_OPT_END,
};

static int g_usage_calls;

static void t_usage(FILE *out)
{
    g_usage_calls++;
    fprintf(out, "usage: t\n");
}

static char g_err[4096];

/* Parses the NULL-terminated arguments (after argv[0] = "t") into *o (from the defaults);
 * stderr goes to g_err. */
static int parse_v(const cli_parser_t *p, topts_t *o, char **ops, int *n_ops, const char *const *args)
{
    char *argv[64];
    int argc = 0;
    argv[argc++] = (char *)"t";
    for (; *args != NULL; args++)
        argv[argc++] = (char *)*args;
    *o = defaults();
    fflush(stderr);
    FILE *tmp = tmpfile();
    assert_non_null(tmp);
    const int saved = dup(2);
    dup2(fileno(tmp), 2);
    const int rc = cli_opts_parse(p, argc, argv, o, ops, n_ops);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    rewind(tmp);
    const size_t n = fread(g_err, 1, sizeof g_err - 1, tmp);
    g_err[n] = '\0';
    fclose(tmp);
    return rc;
}

static const cli_parser_t g_p = {.cmd = "t", .opts = t_opts, .usage = t_usage};
#define PARSE(o, ...) parse_v(&g_p, (o), NULL, NULL, (const char *const[]){__VA_ARGS__, NULL})
#define ERR_HAS(s) assert_non_null(strstr(g_err, (s)))

static void test_each_type(void **st)
{
    (void)st;
    topts_t o;
    assert_int_equal(PARSE(&o, "--req", "r"), 0);
    assert_string_equal(g_err, "");
    assert_true(o.flag == 0 && o.off_flag == 1 && o.i32 == 7 && o.i64 == -1 && o.u32 == 3 && o.u64 == 11);
    assert_true(o.dbl == 0.5 && o.flt == 0.25f && strcmp(o.str, "abc") == 0 && o.choice == 1 && o.mapped == 20);
    assert_true(o.hex == 0 && o.hex_given == 0 && o.n_custom == 0 && o.custom_last == NULL);
    assert_true(o.sub.depth == 2 && o.sub.weight == 1.5); /* nothing but --req moved */
    assert_int_equal(PARSE(&o, "--req", "r", "--flag", "--no-off", "--number", "42", "--long", "-5", "--u32",
                           "4000000000", "--u64", "9223372036854775807", "--dbl", "-0.75", "--flt", "1.5", "--str",
                           "xyz", "--choice", "c", "--mapped", "x", "--hex", "00fF", "--custom", "k", "--depth", "9",
                           "-w", "2.5"),
                     0);
    assert_int_equal(o.flag, 1);
    assert_int_equal(o.off_flag, 0);
    assert_int_equal(o.i32, 42);
    assert_int_equal(o.i64, -5);
    assert_true(o.u32 == 4000000000u);
    assert_true(o.u64 == 9223372036854775807ull);
    assert_true(o.dbl == -0.75);
    assert_true(o.flt == 1.5f);
    assert_string_equal(o.str, "xyz");
    assert_string_equal(o.req, "r");
    assert_int_equal(o.choice, 2);
    assert_int_equal(o.mapped, 10);
    assert_true(o.hex == 0xff);
    assert_int_equal(o.hex_given, 1);
    assert_string_equal(o.custom_last, "k");
    assert_int_equal(o.n_custom, 1);
    assert_int_equal(o.sub.depth, 9);
    assert_true(o.sub.weight == 2.5);
    /* --name=value, also for an empty value and a value with '='. */
    assert_int_equal(PARSE(&o, "--req=a=b", "--number=5", "--str="), 0);
    assert_string_equal(o.req, "a=b");
    assert_int_equal(o.i32, 5);
    assert_string_equal(o.str, "");
    /* A value that starts with '-' is a value. */
    assert_int_equal(PARSE(&o, "--req", "-r", "--dbl", "-1"), 0);
    assert_string_equal(o.req, "-r");
    assert_true(o.dbl == -1.0);
    /* A custom parser's refusal. */
    assert_int_equal(PARSE(&o, "--req", "r", "--custom", "bad"), -1);
    assert_string_equal(g_err, "host_sim t: --custom: 'bad' is refused\n");
}

static void test_ranges(void **st)
{
    (void)st;
    topts_t o;
    static const char *const bad_int[][2] = {{"--number", "0"},   {"--number", "101"}, {"--number", "1.5"},
                                             {"--number", ""},    {"--number", "7x"},  {"--long", "-6"},
                                             {"--u64", "99999999999999999999"}};
    for (size_t k = 0; k < sizeof bad_int / sizeof bad_int[0]; k++) {
        assert_int_equal(PARSE(&o, "--req", "r", bad_int[k][0], bad_int[k][1]), -1);
        ERR_HAS(bad_int[k][0]);
        ERR_HAS("is not an integer in [");
    }
    assert_int_equal(PARSE(&o, "--req", "r", "--number", "101"), -1);
    assert_string_equal(g_err, "host_sim t: --number: '101' is not an integer in [1, 100]\n");
    assert_int_equal(PARSE(&o, "--req", "r", "--number", "1"), 0);
    assert_int_equal(o.i32, 1);
    assert_int_equal(PARSE(&o, "--req", "r", "--number", "100"), 0);
    assert_int_equal(o.i32, 100);
    static const char *const bad_dbl[] = {"1.01", "-2", "nan", "inf", "x", "", "0.5y", "1e999"};
    for (size_t k = 0; k < sizeof bad_dbl / sizeof bad_dbl[0]; k++) {
        assert_int_equal(PARSE(&o, "--req", "r", "--dbl", bad_dbl[k]), -1);
        ERR_HAS("is not a number in [-1, 1]");
    }
    assert_int_equal(PARSE(&o, "--req", "r", "--dbl", "1"), 0);
    assert_true(o.dbl == 1.0);
    static const char *const bad_hex[] = {"", "0x12", "12345678901234567", "-1", "g"};
    for (size_t k = 0; k < sizeof bad_hex / sizeof bad_hex[0]; k++) {
        assert_int_equal(PARSE(&o, "--req", "r", "--hex", bad_hex[k]), -1);
        ERR_HAS("is not 1 to 16 hexadecimal digits");
    }
    assert_int_equal(PARSE(&o, "--req", "r", "--hex", "ffffffffffffffff"), 0);
    assert_true(o.hex == UINT64_MAX);
}

static void test_choices(void **st)
{
    (void)st;
    topts_t o;
    assert_int_equal(PARSE(&o, "--req", "r", "--choice", "d"), -1);
    assert_string_equal(g_err, "host_sim t: --choice: 'd' is not a, b or c\n");
    assert_int_equal(PARSE(&o, "--req", "r", "--mapped", "X"), -1);
    assert_string_equal(g_err, "host_sim t: --mapped: 'X' is not x or y\n");
    assert_int_equal(PARSE(&o, "--req", "r", "--choice", "a", "--mapped", "y"), 0);
    assert_int_equal(o.choice, 0);
    assert_int_equal(o.mapped, 20);
    char name[8];
    assert_int_equal(cli_choice_name("kl|separate|uniform", 1, name, sizeof name), 0);
    assert_string_equal(name, "separat"); /* cut to the room given */
    assert_int_equal(cli_choice_name("kl|separate|uniform", 3, name, sizeof name), -1);
    assert_int_equal(cli_choice_name("kl|separate|uniform", -1, name, sizeof name), -1);
}

static void test_aliases(void **st)
{
    (void)st;
    topts_t o;
    assert_int_equal(PARSE(&o, "--req", "r", "-n", "3"), 0);
    assert_int_equal(o.i32, 3);
    assert_int_equal(PARSE(&o, "--req", "r", "--num", "4"), 0);
    assert_int_equal(o.i32, 4);
    assert_int_equal(PARSE(&o, "--req", "r", "--weight", "3"), 0);
    assert_true(o.sub.weight == 3.0);
    /* The message names the spelling given. */
    assert_int_equal(PARSE(&o, "--req", "r", "--num", "0"), -1);
    assert_string_equal(g_err, "host_sim t: --num: '0' is not an integer in [1, 100]\n");
    /* A prefix of a name is not the name. */
    assert_int_equal(PARSE(&o, "--req", "r", "--numb", "4"), -1);
    ERR_HAS("unknown option '--numb'");
}

static void test_missing_value_and_unknown(void **st)
{
    (void)st;
    topts_t o;
    assert_int_equal(PARSE(&o, "--req", "r", "--number"), -1);
    assert_string_equal(g_err, "host_sim t: option --number needs a value\n");
    assert_int_equal(PARSE(&o, "--req"), -1);
    assert_string_equal(g_err, "host_sim t: option --req needs a value\n");
    /* Unknown, also when given last (not "needs a value") and with =value. */
    assert_int_equal(PARSE(&o, "--req", "r", "--bogus", "x"), -1);
    assert_string_equal(g_err, "host_sim t: unknown option '--bogus' (see --help)\n");
    assert_int_equal(PARSE(&o, "--req", "r", "--bogus"), -1);
    assert_string_equal(g_err, "host_sim t: unknown option '--bogus' (see --help)\n");
    assert_int_equal(PARSE(&o, "--req", "r", "--bogus=3"), -1);
    assert_string_equal(g_err, "host_sim t: unknown option '--bogus' (see --help)\n");
    assert_int_equal(PARSE(&o, "--req", "r", "-x"), -1);
    ERR_HAS("unknown option '-x'");
    /* No operands taken: a word is unexpected. */
    assert_int_equal(PARSE(&o, "--req", "r", "word"), -1);
    assert_string_equal(g_err, "host_sim t: unexpected argument 'word' (see --help)\n");
    /* Required. */
    assert_int_equal(PARSE(&o, "--flag"), -1);
    assert_string_equal(g_err, "host_sim t: --req is required (see --help)\n");
}

static void test_flags(void **st)
{
    (void)st;
    topts_t o;
    assert_int_equal(PARSE(&o, "--req", "r", "--flag", "--flag"), 0);
    assert_int_equal(o.flag, 1);
    assert_int_equal(PARSE(&o, "--req", "r", "--flag=1"), -1);
    assert_string_equal(g_err, "host_sim t: option --flag takes no value\n");
    /* A flag takes no value: the next argument is parsed on its own. */
    assert_int_equal(PARSE(&o, "--req", "r", "--flag", "1"), -1);
    ERR_HAS("unexpected argument '1'");
    assert_int_equal(PARSE(&o, "--req", "r"), 0);
    assert_int_equal(o.flag, 0);
    assert_int_equal(o.off_flag, 1);
}

static void test_repeated_last_wins(void **st)
{
    (void)st;
    topts_t o;
    assert_int_equal(PARSE(&o, "--req", "a", "--number", "5", "-n", "6", "--choice", "c", "--choice", "a", "--req",
                           "b", "--custom", "1", "--custom", "2", "--hex", "1", "--hex", "2"),
                     0);
    assert_int_equal(o.i32, 6);
    assert_int_equal(o.choice, 0);
    assert_string_equal(o.req, "b");
    assert_string_equal(o.custom_last, "2");
    assert_int_equal(o.n_custom, 2); /* a callback may accumulate */
    assert_true(o.hex == 2);
    /* A bad value after a good one still fails. */
    assert_int_equal(PARSE(&o, "--req", "a", "--number", "5", "--number", "500"), -1);
}

static void test_help_and_operands(void **st)
{
    (void)st;
    topts_t o;
    g_usage_calls = 0;
    /* --help and -h print the usage (to stdout) and stop, whatever else is there. */
    assert_int_equal(PARSE(&o, "--bogus-later-is-not-seen", "x"), -1);
    assert_int_equal(PARSE(&o, "-h", "--bogus"), 1);
    assert_int_equal(PARSE(&o, "--number", "5", "--help"), 1);
    assert_int_equal(g_usage_calls, 2);
    /* --version: the same, with the version instead of the usage. */
    assert_int_equal(PARSE(&o, "--number", "5", "--version", "--bogus"), 1);
    assert_int_equal(g_version_calls, 1);
    assert_int_equal(g_usage_calls, 2);
    /* Operands anywhere, "-" is one, "--" ends the options. */
    const cli_parser_t ops_p = {.cmd = "t ops", .opts = t_opts, .usage = t_usage, .operands = "FILE"};
    char *ops[16];
    int n = -1;
    assert_int_equal(parse_v(&ops_p, &o, ops, &n, (const char *const[]){"a", "--req", "r", "-", "b", "--", "--flag",
                                                                         NULL}),
                     0);
    assert_int_equal(n, 4);
    assert_string_equal(ops[0], "a");
    assert_string_equal(ops[1], "-");
    assert_string_equal(ops[2], "b");
    assert_string_equal(ops[3], "--flag");
    assert_int_equal(o.flag, 0);
    /* Options first: an option after an operand is refused. */
    const cli_parser_t first_p = {.cmd = "t first", .opts = t_opts, .usage = t_usage, .operands = "CSV files",
                                  .options_first = 1};
    assert_int_equal(parse_v(&first_p, &o, ops, &n, (const char *const[]){"--req", "r", "a.csv", "b.csv", NULL}), 0);
    assert_int_equal(n, 2);
    assert_int_equal(parse_v(&first_p, &o, ops, &n, (const char *const[]){"--req", "r", "a.csv", "--flag", NULL}), -1);
    assert_string_equal(g_err, "host_sim t first: options must come before the CSV files ('--flag')\n");
}

static void test_help_listing(void **st)
{
    (void)st;
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    assert_non_null(f);
    const topts_t d = defaults();
    cli_opts_help(f, t_opts, &d);
    fclose(f);
    /* One row per option in table order, aliases together, one column, the defaults read from
       the defaults given, "(required)", choices listed, the sub-table in its place. */
    static const char *const rows[] = {
        "  --flag                 a flag\n",
        "  --no-off               clears off_flag\n",
        "  -n, --number, --num N  an int in [1, 100] (default 7)\n",
        "  --long L               a long long (default -1)\n",
        "  --u32 U                a uint32_t (default 3)\n",
        "  --u64 U                a uint64_t (default 11)\n",
        "  --dbl X                a double (default 0.5)\n",
        "  --flt F                a float (default 0.25)\n",
        "  --str S                a string (default abc)\n",
        "  --req R                required (required)\n",
        "  --choice a|b|c         by index (default b)\n",
        "  --mapped M             by value (default y)\n",
        "  --hex H                hex\n",
        /* one row over two lines (a single literal: clang's -Wstring-concatenation) */
        "  --custom C             a callback, repeatable; this help text is long enough to be wrapped onto a\n                         second line of the listing, under its own column (default none)\n",
        "  --depth D              a sub-table option (default 2)\n",
        "  -w, --weight W         another (default 1.5)\n",
    };
    const char *p = text;
    for (size_t k = 0; k < sizeof rows / sizeof rows[0]; k++) {
        if (strncmp(p, rows[k], strlen(rows[k])) != 0)
            fail_msg("row %zu: expected\n%sgot\n%s", k, rows[k], p);
        p += strlen(rows[k]);
    }
    assert_string_equal(p, "");
    /* No line longer than the help width. */
    for (const char *l = text; *l != '\0';) {
        const size_t n = strcspn(l, "\n");
        assert_true(n <= CLI_HELP_WIDTH);
        l += n + (l[n] == '\n');
    }
    free(text);
    /* Without defaults: only the tables' own texts; a long left column puts the help below. */
    static const cli_opt_t long_opts[] = {
        {.names = "--a-very-long-option-name-indeed", .meta = "VALUE", CLI_INT(sub_t, depth, 0, 9), .help = "h"},
        {.names = "--b", .meta = "B", CLI_INT(sub_t, depth, 0, 9), .def = "computed", .help = "b"},
        {.names = "--c", .meta = "C", CLI_INT(sub_t, depth, 0, 9), .help = "c"},
        CLI_OPT_END,
    };
    f = open_memstream(&text, &len);
    cli_opts_help(f, long_opts, NULL);
    fclose(f);
    assert_string_equal(text, "  --a-very-long-option-name-indeed VALUE\n"
                              "         h\n"
                              "  --b B  b (default computed)\n"
                              "  --c C  c\n");
    free(text);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_each_type),
        cmocka_unit_test(test_ranges),
        cmocka_unit_test(test_choices),
        cmocka_unit_test(test_aliases),
        cmocka_unit_test(test_missing_value_and_unknown),
        cmocka_unit_test(test_flags),
        cmocka_unit_test(test_repeated_last_wins),
        cmocka_unit_test(test_help_and_operands),
        cmocka_unit_test(test_help_listing),
    };
    return cmocka_run_group_tests_name("app/cli_opts", tests, NULL, NULL);
}
