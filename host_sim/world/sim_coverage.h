/* Coverage: the share of a plan's free space that some lidar ray has seen, against simulated
 * time. The measure exploration policies are compared by.
 *
 * Grid: the plan's ground-truth grid (sim_grid.h: same cell rule, layout, origin, w, h; rows
 * grow with y, row-major cells[row * w + col]). Per cell one float, the simulated time in
 * seconds it was FIRST seen:
 *   >= 0 (finite)          a free cell first seen at that time;
 *   +INFINITY              a free cell never seen (yet);
 *   SIM_COVERAGE_NOT_FREE  (-1) a wall or outside cell: never counts.
 * Coverage at t = (free cells with first-seen <= t) / (free cells), in [0, 1], monotone in t.
 *
 * Seen: every cell a ray passes through, from the sensor to its return (the cell holding the
 * return included) or to range_max when the beam has no return, found by a grid traversal
 * (Amanatides & Woo, "A fast voxel traversal algorithm", 1987: exact, every cell the segment
 * crosses, no sampling step). A beam with NaN (dropout, or a surface closer than range_min as
 * sim_lidar writes it) or a finite value below range_min sees nothing: its length is unknown.
 *
 * The union of robots (merge) is the element-wise minimum of first-seen times.
 *
 * File coverage.bin (all little-endian, 64-byte header, then the cells):
 *   0  char[8]  magic "FSCOVBIN"
 *   8  u32      version (1)
 *   12 u32 w, 16 u32 h   cells per side, 1 .. SIM_GRID_MAX_SIDE
 *   20 u32      CRC-32 (IEEE) of the cell bytes
 *   24 f64 res (m, > 0), 32 f64 origin_x, 40 f64 origin_y (m), 48 f64 t_end (s, >= 0)
 *   56 u64      free cells
 *   64 f32[w*h] first-seen times as above
 * Reading checks the size (exactly 64 + 4 w h bytes), magic, version, dimensions, the CRC,
 * every value (no NaN, no negative but -1, none after t_end) and the free-cell count.
 *
 * Everything is simulated time and pure arithmetic on the inputs: the same scans give the same
 * bytes. Not thread-safe per coverage grid; distinct grids are independent. Allocates. */
#ifndef SIM_COVERAGE_H
#define SIM_COVERAGE_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "hal/hal_lidar.h"
#include "sim_grid.h"
#include "sim_plan.h"

#define SIM_COVERAGE_RES_M 0.1          /* the grid `host_sim run` measures on */
#define SIM_COVERAGE_NOT_FREE (-1.0f)
#define SIM_COVERAGE_VERSION 1u
#define SIM_COVERAGE_HEADER_BYTES 64u
#define SIM_COVERAGE_MAX_RANGE_M 1000.0 /* longest ray accepted (a lidar's range_max) */
#define SIM_COVERAGE_CSV_HEADER "sim_time_s,robot_seconds,coverage\n"
#define SIM_COVERAGE_CSV_MAX_ROWS 1e7   /* t_end / step_s beyond this is refused (-E2BIG) */

typedef struct sim_coverage {
    int w, h;           /* cells per side */
    double res;         /* metres per cell */
    sim_vec2_t origin;  /* outer corner of cell (0, 0), metres */
    double t_end;       /* simulated seconds the record covers (latest scan, or set by the caller) */
    uint64_t n_free;    /* free cells */
    float *first_seen;  /* w * h, as above */
} sim_coverage_t;

/* A grid with every free cell of `g` unseen. 0, -EINVAL or -ENOMEM (c left empty). */
FS_MUST_CHECK int sim_coverage_from_grid(sim_coverage_t *c, const sim_grid_t *g);

/* Rasterises plan at res_m (sim_grid_from_plan) and does the above. 0 or a negative code. */
FS_MUST_CHECK int sim_coverage_from_plan(sim_coverage_t *c, const sim_plan_t *plan, double res_m);

void sim_coverage_free(sim_coverage_t *c);

/* One scan taken at simulated time t_s (>= 0) from the sensor at world (x, y) heading theta
 * (rad, CCW from +x): beam i points at theta + angle_min_rad + i * angle_step_rad and reads
 * ranges_m[i] (hal_lidar.h). Marks what its rays crossed; t_end becomes max(t_end, t_s).
 * 0, or -EINVAL (non-finite pose or time, a sensor more than 1e9 cells off the grid, count 0
 * or > HAL_LIDAR_MAX_BEAMS, range_max not in (0, SIM_COVERAGE_MAX_RANGE_M]); nothing is marked
 * then. Allocates nothing (it runs in the lockstep's world callback). */
FS_MUST_CHECK int sim_coverage_add_scan(sim_coverage_t *c, double t_s, double x, double y, double theta,
                                        const hal_lidar_scan_t *scan);

/* Share of free cells seen at or before t_s, in [0, 1]; 0 when the grid has no free cell.
 * O(cells) per call: for many times, write the CSV (one sort, one sweep). */
double sim_coverage_at(const sim_coverage_t *c, double t_s);

/* Free cells seen at or before t_s (c non-NULL). */
uint64_t sim_coverage_seen(const sim_coverage_t *c, double t_s);

/* dst := union of dst and src (minimum first-seen time per cell; t_end the larger). -EINVAL
 * when they are not of the same grid (dimensions, res, origin, free cells). */
FS_MUST_CHECK int sim_coverage_merge(sim_coverage_t *dst, const sim_coverage_t *src);

/* The file's bytes into a malloc'd buffer (*buf, *len; the caller frees). 0 or -ENOMEM. */
FS_MUST_CHECK int sim_coverage_encode(const sim_coverage_t *c, uint8_t **buf, size_t *len);

/* Parses a file's bytes into c (validated as above). 0, or -EINVAL with the reason in *why
 * (a static string), -ENOMEM. c is left empty on failure. */
FS_MUST_CHECK int sim_coverage_decode(sim_coverage_t *c, const uint8_t *buf, size_t len, const char **why);

/* Writes coverage.bin whole or not at all (hal_host_file). 0 or a negative errno, the reason
 * in err ("PATH: reason"). */
FS_MUST_CHECK int sim_coverage_write(const sim_coverage_t *c, const char *path, char *err, size_t errlen);

/* Reads and validates a file. 0 or a negative code, "PATH: reason" in err; c left empty then. */
FS_MUST_CHECK int sim_coverage_read(sim_coverage_t *c, const char *path, char *err, size_t errlen);

/* coverage.csv into f: SIM_COVERAGE_CSV_HEADER, then a row every step_s (> 0) simulated seconds
 * from 0 while <= t_end and a last row at t_end: sim_time_s, robot_seconds = n_robots x
 * sim_time_s, coverage. 0, -EINVAL, -E2BIG (more than SIM_COVERAGE_CSV_MAX_ROWS rows), -ENOMEM
 * or -EIO (a stream error). c and f non-NULL. */
FS_MUST_CHECK int sim_coverage_write_csv(const sim_coverage_t *c, int n_robots, double step_s, FILE *f);

#endif /* SIM_COVERAGE_H */
