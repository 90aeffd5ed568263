/* Robot paths: waypoint CSV files and a coverage tour generator for N robots.
 *
 * CSV format: a header line `x_m,y_m`, then one waypoint per line `X,Y` in metres (plan
 * frame, see sim_plan.h). Empty lines and lines starting with '#' are skipped. On read every
 * line is validated (two finite numbers, the point FREE in the plan by sim_plan_classify_point)
 * and the file must hold at least 2 waypoints; errors are "FILE:LINE: reason", or "FILE: reason"
 * for the file itself (cannot open, too large, not text).
 *
 * Generator: the plan is rasterised (sim_grid) at cfg->res_m; a cell is traversable when it
 * is FREE, its centre is at least clearance_m + res_m from every solid (exact polygon
 * distance) and from every OUTSIDE cell centre, and it belongs to the largest 4-connected
 * traversable region; a room is reachable when one of its cells is. In each room the sweep
 * goals are the traversable cells nearest the points of a lattice of spacing sweep_m, in
 * boustrophedon order (row by row, alternating direction).
 *
 * N <= reachable rooms: each robot starts in its own room (N distinct start rooms; with more
 * rooms than robots the start rooms are a seeded choice), every other room is assigned to
 * the robot with the smallest tour so far (nearest room first), so together the robots visit
 * every reachable room; a robot sweeps each of its rooms whole. With cfg->own_rooms the other
 * rooms go to nobody: each robot sweeps its start room only (the same seeded start rooms), and
 * the rooms no robot starts in are left unvisited (a fleet that leaves part of the building
 * unseen). Every waypoint of such a tour lies in its start room as long as the A* legs between
 * the room's own goals need not leave it (tests/sim/test_paths.c checks the default plan and
 * generated ones).
 *
 * N > reachable rooms: every reachable room starts at least one robot and the rooms take the
 * others, largest work first: robot r < R (R reachable rooms) starts in the r-th of them in
 * room order; each further robot, in id order, joins the room with the most sweep goals per
 * robot so far (ties: the lower room index), so the robots of a room are its first, then the
 * later ids in the order they joined. The k robots of a room with g goals (a goal closer than
 * half the lattice spacing to an earlier one dropped) share its sweep: robot j of them drives
 * goals j*g/k .. (j+1)*g/k - 1, consecutive runs of the sweep order, and starts on the first of
 * its run, so the starts are distinct traversable cells at least half the spacing apart,
 * spread along the sweep, and together the robots still visit every goal of every room. A
 * room with fewer goals than robots gets a finer lattice for them (half the spacing, again,
 * down to res_m); a room still too small fails with its index, type and the counts.
 * A robot whose run is one goal drives on to the neighbouring run's first goal. The seed
 * plays no part then. Each robot sweeps only its own room (so cfg->own_rooms changes nothing).
 *
 * Consecutive goals are joined by A* (8-connected, no corner cutting) and each leg is
 * shortened by line-of-sight shortcuts that stay on traversable cells (sampled every res/2),
 * so every point of every segment keeps at least clearance_m from every solid. Deterministic
 * for (plan, cfg). Not thread-safe per path; allocates: about 30 bytes per grid cell (the
 * grid, its traversable cells, the searches' state) and the tours. */
#ifndef SIM_PATHS_H
#define SIM_PATHS_H

#include <stddef.h>
#include <stdint.h>

#include "sim_grid.h"
#include "sim_plan.h"

/* Up to 1024 robots: tools/fleet's fleet limit, which the firmware's is being raised to. */
#define SIM_PATHS_MAX_ROBOTS 1024
#define SIM_PATH_MAX_POINTS 100000

typedef struct sim_path {
    int n;          /* waypoints */
    sim_vec2_t *p;  /* n waypoints, metres */
    int start_room; /* index into plan->rooms of the start room; -1 when read from a file */
    int *line;      /* CSV line of each waypoint when read from a file, else NULL */
} sim_path_t;

typedef struct sim_paths_cfg {
    int n_robots;       /* 1 .. SIM_PATHS_MAX_ROBOTS */
    uint64_t seed;
    double clearance_m; /* robot centre to any wall, default 0.2 (TurtleBot3 burger radius 0.105 + margin) */
    double res_m;       /* planning grid resolution, default 0.05 */
    double sweep_m;     /* spacing of sweep goals inside rooms, default 1.0 */
    int own_rooms;      /* 0 (default): the tours together sweep every reachable room; 1: each robot
                         * sweeps only its start room, the rooms nobody starts in stay unvisited */
} sim_paths_cfg_t;

void sim_paths_cfg_default(sim_paths_cfg_t *cfg);

/* Fills paths[0 .. cfg->n_robots-1]. On failure every path is left empty, err says why
 * (e.g. no reachable room, a room too small for its robots) and a negative code is returned. */
FS_MUST_CHECK
int sim_paths_generate(const sim_plan_t *plan, const sim_paths_cfg_t *cfg, sim_path_t *paths, char *err,
                       size_t errlen);

/* An empty path (no allocation): what sim_path_free leaves behind. */
void sim_path_init(sim_path_t *path);
void sim_path_free(sim_path_t *path);

/* Arc length of the polyline in metres (0 for fewer than 2 waypoints). */
double sim_path_length(const sim_path_t *path);

/* Distance in metres from (x, y) to the polyline (to the single waypoint when n == 1;
 * INFINITY when the path is empty). */
double sim_path_distance(const sim_path_t *path, double x_m, double y_m);

FS_MUST_CHECK
int sim_path_write_csv(const sim_path_t *path, const char *file, char *err, size_t errlen);

/* Reads and validates a CSV against `plan` (see above). On failure *path is left empty. */
FS_MUST_CHECK
int sim_path_read_csv(const char *file, const sim_plan_t *plan, sim_path_t *path, char *err, size_t errlen);

/* Same, from text in memory (`name` for messages). */
FS_MUST_CHECK
int sim_path_parse_csv(const char *text, const char *name, const sim_plan_t *plan, sim_path_t *path, char *err,
                       size_t errlen);

/* Smallest distance from any point of the polyline to any solid of the plan (0 when a point
 * is inside a solid). Exact segment-polygon geometry. */
double sim_path_min_clearance(const sim_plan_t *plan, const sim_path_t *path);

/* The first segment (i -> i+1) of the polyline that comes closer than clearance_m to a solid
 * (crossing one counts as 0 m), its index in *seg and its clearance in *dist_m: 1; 0 when every
 * point of every segment keeps clearance_m. Exact geometry, cost O(segments x solid edges). */
int sim_path_first_tight_segment(const sim_plan_t *plan, const sim_path_t *path, double clearance_m, int *seg,
                                 double *dist_m);

/* Fraction (0..1) of the grid's FREE cells whose centre is within range_m of a point of
 * some path (points sampled every 0.2 m along the segments) with a line of sight that
 * crosses no WALL cell. A sample point in a grid cell that an earlier sample point already
 * occupied adds nothing (tours that pass a place again cost nothing more), and the sweep
 * stops once every FREE cell is covered. Negative on allocation failure. */
double sim_paths_coverage(const sim_grid_t *grid, const sim_path_t *paths, int n, double range_m);

/* Index of the room containing (x, y), or -1. */
int sim_plan_room_at(const sim_plan_t *plan, double x_m, double y_m);

#endif /* SIM_PATHS_H */
