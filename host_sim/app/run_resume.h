/* `host_sim run --resume` and the incarnation counter: what a robot restarted with the same
 * --out continues from, and how it tells its fleet that it is a new start.
 *
 * Resuming (offline runs only: an online robot's pose and pool are not in a checkpoint):
 *   - the last complete round checkpoint of --out, round_NNNN.bnn with the highest round below
 *     --rounds that bnn_ckpt_load accepts (the storage writes whole files, but a checkpoint of
 *     another preset, or one damaged on disk, is skipped with a warning naming it); the run
 *     continues at the round after it, or from round 0 when there is none;
 *   - metrics.csv and traffic.csv are written through temporaries committed only at the end, so
 *     a killed run left its rows in its temporary `.metrics.csv.PID.fstmp`: the complete rows
 *     of the rounds before the one resumed are carried over from it into the new files (from
 *     the temporary with the most such rows when several killed runs left one);
 *   - then the temporaries killed runs left in --out are removed, and how many is said.
 * The incarnation (<out>/incarnation: one decimal number and a newline) counts the starts of a
 * robot with this --out: a fresh run writes 1, a resumed one the number found + 1 (0 when
 * there is no file; a malformed file is refused). It goes into the fleet's messages
 * (gp_fleet_cfg_t.incarnation), so that the peers tell a restarted robot from a late one. */
#ifndef HOST_SIM_APP_RUN_RESUME_H
#define HOST_SIM_APP_RUN_RESUME_H

#include <limits.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

enum { RUN_CARRY_METRICS = 0, RUN_CARRY_TRAFFIC = 1, RUN_CARRY_FILES = 2 };

/* Rows of one per-round file carried over from a killed run. */
typedef struct run_carry {
    const char *name;     /* "metrics.csv", "traffic.csv"; NULL: this run does not write it */
    char from[PATH_MAX];  /* the file they came from, its name in the output folder (summary.txt
                             names no folder); "" when none */
    char *rows;           /* complete rows, each ending in '\n' (malloc'd), NULL when none */
    size_t len;
    uint32_t n_rows;
    uint32_t first, last; /* rounds of the first and the last row */
} run_carry_t;

typedef struct run_resume {
    uint32_t start_round;     /* the round the run continues at: c + 1, or 0 */
    uint32_t ckpt_round;      /* c, when ckpt != NULL */
    char ckpt_name[64];       /* "round_NNNN.bnn", "" when none */
    uint8_t *ckpt;            /* its bytes (malloc'd), NULL when none */
    size_t ckpt_bytes;
    uint32_t skipped;         /* checkpoints skipped (torn, invalid) */
    int tmp_removed;          /* temporaries of killed runs removed from --out */
    run_carry_t carry[RUN_CARRY_FILES];
} run_resume_t;

/* Finds what `out` holds for a run of `rounds` rounds (see above). headers: the exact header
 * lines (ending in '\n') of metrics.csv and traffic.csv as this run writes them, NULL for a file
 * it does not write; rows are carried only from a temporary with the same header and the same
 * number of fields per row. Warnings and what was removed are printed. 0, or -1 with the
 * reason printed ("host_sim run: PATH: reason"). */
int run_resume_find(const char *out, uint32_t rounds, const char *const headers[RUN_CARRY_FILES], run_resume_t *r);

/* One line on `f` per carried file: where the rows of rounds before start_round came from, or
 * which of them are missing. Nothing for a fresh run (start_round 0). */
void run_resume_describe(const run_resume_t *r, FILE *f);

void run_resume_free(run_resume_t *r);

/* Writes <out>/incarnation through hal_host_file: 1, or with `resume` the number found + 1.
 * *inc receives it. 0, or -1 with the reason printed (malformed file, write error). */
int run_incarnation_next(const char *out, int resume, uint32_t *inc);

#endif /* HOST_SIM_APP_RUN_RESUME_H */
