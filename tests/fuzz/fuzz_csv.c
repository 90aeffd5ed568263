/* Fuzz target: the tour CSV parser (host_sim/paths/sim_paths_csv.c) through sim_path_parse_csv, its
 * from-memory entry point (sim_path_read_csv reads the file, refuses a NUL byte or more than
 * 16 MB, and calls it), against the default plan (host_sim/plans/apartment.svg, or
 * $FLEETSIM_FUZZ_PLAN), loaded once. Beyond memory safety it checks the contract of
 * sim_paths.h: a refused tour says "NAME:LINE: reason" and leaves the path empty; an accepted
 * one has 2 .. SIM_PATH_MAX_POINTS waypoints, each finite, free in the plan and with its line,
 * no two in a row equal, and no segment through a wall. The plan is only read. */
#include "fuzz/fuzz_config.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sim_grid.h"
#include "sim_paths.h"
#include "sim_plan.h"

#define NAME "fuzz.csv"

static sim_plan_t g_plan; /* read-only after LLVMFuzzerInitialize */

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    const char *file = getenv("FLEETSIM_FUZZ_PLAN");
    if (file == NULL)
        file = "host_sim/plans/apartment.svg";
    char err[256];
    if (sim_plan_load(file, 0.0, &g_plan, err, sizeof err) != 0) {
        fprintf(stderr, "fuzz_csv: %s (run from the repository's root, or set FLEETSIM_FUZZ_PLAN)\n", err);
        exit(1);
    }
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (memchr(data, '\0', size) != NULL)
        return 0; /* sim_path_read_csv refuses these before parsing */
    char *text = malloc(size + 1);
    if (text == NULL)
        return 0;
    memcpy(text, data, size);
    text[size] = '\0';
    sim_path_t path;
    char err[256];
    const int rc = sim_path_parse_csv(text, NAME, &g_plan, &path, err, sizeof err);
    if (rc == 0) {
        CHECK(path.n >= 2 && path.n <= SIM_PATH_MAX_POINTS && path.p != NULL && path.line != NULL);
        for (int i = 0; i < path.n; i++) {
            CHECK(isfinite(path.p[i].x) && isfinite(path.p[i].y));
            CHECK(sim_plan_classify_point(&g_plan, path.p[i].x, path.p[i].y) == SIM_CELL_FREE);
            CHECK(path.line[i] >= 2 && (i == 0 || path.line[i] > path.line[i - 1]));
            CHECK(i == 0 || path.p[i].x != path.p[i - 1].x || path.p[i].y != path.p[i - 1].y);
        }
        int seg = -1;
        CHECK(!sim_path_first_tight_segment(&g_plan, &path, 1e-9, &seg, NULL));
        CHECK(isfinite(sim_path_length(&path)));
    } else {
        CHECK(rc < 0);
        CHECK(rc == -ENOMEM || strncmp(err, NAME ":", sizeof NAME) == 0);
        CHECK(path.n == 0 && path.p == NULL && path.line == NULL);
    }
    sim_path_free(&path);
    free(text);
    return 0;
}
