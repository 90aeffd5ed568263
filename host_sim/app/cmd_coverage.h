/* The coverage files of a result folder (sim_coverage.h), shared by `host_sim run`,
 * `host_sim fleet` and `host_sim coverage merge`. */
#ifndef HOST_SIM_APP_CMD_COVERAGE_H
#define HOST_SIM_APP_CMD_COVERAGE_H

#include <stdio.h>

#include "sim_coverage.h"

/* Writes `csv` (coverage.csv: a row every simulated second, robot_seconds = n_robots x
 * sim_time_s) and, when bin is non-NULL, `bin` (coverage.bin), each whole or not at all.
 * 0, or -1 after "host_sim CMD: PATH: reason" on stderr. */
int cmd_coverage_write(const char *cmd, const sim_coverage_t *c, int n_robots, const char *csv, const char *bin);

/* The summary line, "coverage: 0.8312 of free space at 512.0 s (...)\n", into f. */
void cmd_coverage_line(FILE *f, const sim_coverage_t *c, int n_robots);

#endif /* HOST_SIM_APP_CMD_COVERAGE_H */
