/* host_sim coverage: a fleet's coverage from its robots' coverage.bin files (sim_coverage.h),
 * and the coverage files every result folder gets. */
#include "cmd_coverage.h"

#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cli_opts.h"
#include "commands.h"

#define COVERAGE_ROW_S 1.0 /* coverage.csv: a row per simulated second */

int cmd_coverage_write(const char *cmd, const sim_coverage_t *c, int n_robots, const char *csv, const char *bin)
{
    char err[4400];
    if (bin != NULL && sim_coverage_write(c, bin, err, sizeof err) != 0) {
        fprintf(stderr, "host_sim %s: %s\n", cmd, err);
        return -1;
    }
    hal_host_file_t f;
    if (cmd_out_begin(cmd, &f, csv) != 0)
        return -1;
    const int rc = sim_coverage_write_csv(c, n_robots, COVERAGE_ROW_S, hal_host_file_stream(&f));
    if (rc < 0) {
        fprintf(stderr, "host_sim %s: %s: %s\n", cmd, csv, hal_host_file_strerror(rc));
        hal_host_file_abort(&f);
        return -1;
    }
    return cmd_out_commit(cmd, &f);
}

void cmd_coverage_line(FILE *f, const sim_coverage_t *c, int n_robots)
{
    fprintf(f, "coverage: %.4f of free space at %.1f s (%d robot%s, %.2f m grid, %llu of %llu free cells seen)\n",
            sim_coverage_at(c, c->t_end), c->t_end, n_robots, n_robots == 1 ? "" : "s", c->res,
            (unsigned long long)sim_coverage_seen(c, c->t_end), (unsigned long long)c->n_free);
}

typedef struct cov_opts {
    const char *out, *bin;
} cov_opts_t;

static const cli_opt_t cov_table[] = {
    {.names = "--out", .meta = "FILE.csv", CLI_STRING(cov_opts_t, out), .required = 1,
     .help = "the fleet's coverage.csv (sim_time_s,robot_seconds,coverage; robot_seconds = N x sim_time_s)"},
    {.names = "--bin", .meta = "FILE.bin", CLI_STRING(cov_opts_t, bin),
     .help = "also write the union as a coverage.bin"},
    CLI_OPT_END,
};

static void cov_usage(FILE *out)
{
    fprintf(out, "usage: host_sim coverage merge --out DIR/coverage.csv [--bin DIR/coverage.bin] ROBOT.bin...\n"
                 "\n"
                 "Unites the coverage of N robots: each ROBOT.bin is a robot's coverage.bin (host_sim run writes\n"
                 "one in its folder), the first simulated time each free cell of the plan's 0.1 m ground-truth\n"
                 "grid was crossed by a lidar ray. The fleet saw a cell when any robot did (the minimum of the\n"
                 "times). Writes coverage.csv, a row per simulated second, with robot_seconds = N x sim_time_s,\n"
                 "and prints the final coverage. Every file must be of the same grid (one plan).\n"
                 "Exit 2 on bad usage or a file that is no valid coverage.bin, 1 when an output cannot be written.\n\n");
    cli_opts_help(out, cov_table, NULL);
}

int cmd_coverage(int argc, char **argv)
{
    cov_opts_t o = {0};
    char **ops = calloc((size_t)(argc > 0 ? argc : 1), sizeof *ops);
    if (ops == NULL) {
        fprintf(stderr, "host_sim coverage: out of memory\n");
        return 1;
    }
    int n = 0;
    const cli_parser_t parser = {.cmd = "coverage", .opts = cov_table, .usage = cov_usage, .operands = "merge FILE..."};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, ops, &n);
    if (pr != 0) {
        free(ops);
        return pr > 0 ? 0 : 2;
    }
    if (n < 2 || strcmp(ops[0], "merge") != 0) {
        fprintf(stderr, "host_sim coverage: expected 'merge --out FILE.csv ROBOT.bin...' (see --help)\n");
        free(ops);
        return 2;
    }
    sim_coverage_t u, c;
    char err[4400];
    int rc = 0;
    memset(&u, 0, sizeof u);
    for (int i = 1; i < n && rc == 0; i++) {
        if (sim_coverage_read(i == 1 ? &u : &c, ops[i], err, sizeof err) != 0) {
            fprintf(stderr, "host_sim coverage: %s\n", err);
            rc = 2;
        } else if (i > 1) {
            if (sim_coverage_merge(&u, &c) != 0) {
                fprintf(stderr, "host_sim coverage: %s: not of the same grid as %s (another plan or resolution)\n",
                        ops[i], ops[1]);
                rc = 2;
            }
            sim_coverage_free(&c);
        }
    }
    if (rc == 0 && cmd_coverage_write("coverage", &u, n - 1, o.out, o.bin) != 0)
        rc = 1;
    if (rc == 0)
        cmd_coverage_line(stdout, &u, n - 1);
    sim_coverage_free(&u);
    free(ops);
    return rc;
}
