/* summary.txt of `host_sim run`: the lines of a fleet member (traffic, losses, faults survived,
 * the network queue, the screen and the duals, the key, the injected faults), apart from
 * cmd_run.c so that each file keeps one job. */
#ifndef HOST_SIM_APP_RUN_SUMMARY_H
#define HOST_SIM_APP_RUN_SUMMARY_H

#include <stdint.h>
#include <stdio.h>

#include "cmd_run_opts.h"
#include "sim_image.h"

/* The posterior rounds after the DiNNO rounds, as the run counted them (not in traffic.csv). */
typedef struct run_post {
    uint32_t rounds, done;
    uint64_t sent, received;
} run_post_t;

/* Writes the fleet's lines to f; start_round: the first round this start ran. */
void run_summary_fleet(FILE *f, const run_opts_t *o, const sim_image_result_t *res, uint32_t start_round,
                       const run_post_t *post);

#endif /* HOST_SIM_APP_RUN_SUMMARY_H */
