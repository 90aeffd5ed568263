/* Path planner on the belief grid (RT core, pure C11, no allocation, deterministic).
 *
 * 1. Obstacles: a cell is an obstacle when occ >= occ_threshold, or when it is unknown and
 *    unknown_is_obstacle is set (unknown cells are free otherwise: optimistic, for
 *    exploration). Space outside the grid is neither obstacle nor traversable: paths stay in
 *    the grid, and the grid's border is not a wall unless its cells are.
 * 2. Clearance: the EXACT Euclidean distance transform (Felzenszwalb & Huttenlocher 2012, two
 *    separable 1-D passes, O(w * h)) from every cell centre to the nearest obstacle cell
 *    centre, kept squared in cell units (integers, exact in a float; no approximation error).
 *    A grid without obstacles has infinite clearance everywhere.
 * 3. Allowed cells: d >= R / res + sqrt(2), R = robot_radius_m + margin_m, d the clearance
 *    in cells. The sqrt(2) cell is half a cell diagonal for the point inside the allowed cell
 *    plus half a diagonal for the obstacle cell's extent, so EVERY POINT of an allowed cell is
 *    at least R from every obstacle cell's square. Paths only cross allowed cells, hence
 *    every point of a returned path is at least R from every obstacle cell (the price: a
 *    corridor must be about 2 R + 3 cells wide to be passable).
 *    RT_PLAN_TIGHT: d >= R / res + 1 instead, half a cell side for each of the two cells: the
 *    guarantee of R holds against obstacle cells in the same row or column (walls along the
 *    grid, the sides of a door), and R - (sqrt(2) - 1) res diagonally. A door 2 R + 2 cells
 *    wide in the grid is passable: on a 0.16 m grid the robot with its margin (0.155 m) passes
 *    4 free cells, where the full band asks for 5 (a 0.64 m door, which a 0.21 m robot drove
 *    in through before its jambs were seen, and then could not plan out of).
 * 4. A* over the allowed cells, 8-connected; a diagonal step needs both cells it cuts past
 *    allowed (no corner cutting). Step cost = L * (1 + k_clear_m / c), L the step's length
 *    (res or res * sqrt(2)), c the clearance in metres of the cell stepped into: paths keep
 *    away from walls when it costs little. Heuristic: octile distance in metres (admissible
 *    and consistent since the factor is >= 1), so the path is the cheapest one.
 *    Ties in the open list: lower f, then higher g (nearer the goal), then lower cell index.
 *    Neighbours in a fixed order (E, NE, N, NW, W, SW, S, SE). Same inputs, same path.
 * 5. Simplification: from the first cell, the farthest next cell of the path reachable by a
 *    shortcut, greedily. A shortcut between two cell centres must be in line of sight (every
 *    cell the segment touches is allowed, including both cells beside a corner it passes
 *    exactly through) and cost no more than the A* sub-path it replaces (1e-5 relative slack),
 *    its cost being its length times the mean of (1 + k_clear_m / c) over the cells it
 *    enters (all touched but the first): with k_clear_m = 0 any line of sight, otherwise no cutting back along a wall.
 *    Waypoints are cell centres, first the start cell, last the goal cell, at most
 *    RT_PLAN_MAX_WAYPOINTS.
 *
 * Start in the forbidden band: the search starts from the nearest allowed cell (Euclidean
 * from cell to cell, ties to the lower index) and the result says RT_PLAN_START_MOVED; the
 * first waypoint is then that cell, and the straight line to it from the robot is NOT
 * guaranteed any clearance. Goal forbidden or unreachable: -ENOENT, unless cfg->flags has
 * RT_PLAN_NEAREST_GOAL: the search then runs until the open list is empty and the path goes
 * to the reached allowed cell nearest the goal (ties to the lower index), RT_PLAN_GOAL_MOVED.
 *
 * Cost: O(w h log(w h)) time; the workspace is RT_PLAN_WORKSPACE_BYTES_PER_CELL (21) bytes per
 * cell, 1,376,256 bytes for 65,536 cells, plus 16 KiB of per-line scratch (1,392,648 bytes).
 * Thread-safety: pure function of its inputs; concurrent calls need separate workspaces and
 * results. */
#ifndef RT_PLAN_H
#define RT_PLAN_H

#include <stddef.h>
#include <stdint.h>

#include "rt/rt_follow.h"
#include "rt/rt_grid.h"

#define RT_PLAN_MAX_WAYPOINTS 128

/* cfg->flags */
#define RT_PLAN_NEAREST_GOAL 1u /* go to the nearest reachable allowed cell instead of -ENOENT */
#define RT_PLAN_TIGHT 4u        /* the band of 3. with one cell instead of sqrt(2) */
/* result->flags */
#define RT_PLAN_START_MOVED 1u /* the start cell was forbidden: started from the nearest allowed */
#define RT_PLAN_GOAL_MOVED 2u  /* the goal was not reached: ends at the nearest reached cell */

typedef struct rt_plan_cfg {
    float robot_radius_m;        /* > 0: the robot's footprint radius */
    float margin_m;              /* >= 0: extra clearance required beyond the radius */
    float k_clear_m;             /* >= 0: soft cost weight (0 = shortest allowed path) */
    uint8_t occ_threshold;       /* 1 .. 255: obstacle when occ >= occ_threshold */
    uint8_t unknown_is_obstacle; /* 0: unknown cells are open (optimistic), 1: obstacles */
    uint32_t flags;              /* RT_PLAN_NEAREST_GOAL, RT_PLAN_TIGHT, or 0 */
} rt_plan_cfg_t;

/* Caller-owned scratch for one call (about 1.3 MiB at the default RT_GRID_MAX_CELLS: give it
 * static storage, not the stack). Its content after a call: clear2[row * w + col] is the
 * squared clearance in cells (RT_PLAN_CLEAR_INF without obstacles); the rest is scratch. */
typedef struct rt_plan_workspace {
    float clear2[RT_GRID_MAX_CELLS]; /* squared clearance, cells^2 */
    float g[RT_GRID_MAX_CELLS];      /* A*: cost from the start, m */
    float f[RT_GRID_MAX_CELLS];      /* A*: g + heuristic, m */
    int32_t pos[RT_GRID_MAX_CELLS];  /* A*: heap slot, -1 unseen, -2 closed */
    int32_t heap[RT_GRID_MAX_CELLS]; /* A*: binary min-heap of cell indices, then the cell path */
    uint8_t parent[RT_GRID_MAX_CELLS]; /* A*: direction (0..7) we arrived from */
    float line_f[RT_GRID_MAX_SIDE];  /* distance transform, one row or column */
    int32_t line_v[RT_GRID_MAX_SIDE];
    double line_z[RT_GRID_MAX_SIDE + 1];
} rt_plan_workspace_t;

#define RT_PLAN_WORKSPACE_BYTES_PER_CELL 21
#define RT_PLAN_CLEAR_INF 1.0e30f
_Static_assert(sizeof(rt_plan_workspace_t) >=
                   (size_t)RT_GRID_MAX_CELLS * RT_PLAN_WORKSPACE_BYTES_PER_CELL,
               "the workspace holds its per-cell arrays");

typedef struct rt_plan_result {
    rt_waypoint_t wps[RT_PLAN_MAX_WAYPOINTS]; /* cell centres, metres, ready for rt_follow */
    int32_t n_wps;                            /* 1 .. RT_PLAN_MAX_WAYPOINTS */
    int32_t start_col, start_row;             /* cells actually used (after a move) */
    int32_t goal_col, goal_row;
    uint32_t flags;                           /* RT_PLAN_START_MOVED | RT_PLAN_GOAL_MOVED */
    int32_t path_cells;                       /* cells on the A* path, both ends included */
    int32_t expanded;                         /* cells A* closed */
    float cost;                               /* A* cost of the cell path, m */
    float length_m;                           /* length of the simplified polyline */
} rt_plan_result_t;

/* A cfg with robot_radius 0.105 m (TurtleBot3 burger), margin 0.05 m, k_clear 0.1 m,
 * threshold 128 (P >= 0.5), unknown free, no flags. */
rt_plan_cfg_t rt_plan_default_cfg(void);

/* Only the clearance transform (steps 1-2) into ws->clear2. Returns 0, or -EINVAL (NULL,
 * bad cfg: see rt_plan_path) or the grid's rt_grid_check error. */
FS_MUST_CHECK
int rt_plan_clearance(const rt_grid_t *grid, const rt_plan_cfg_t *cfg, rt_plan_workspace_t *ws);

/* Plans from world point (sx, sy) to (gx, gy). Returns 0 and fills *out, or
 *   -EINVAL  NULL pointer, non-finite point, start or goal outside the grid, bad cfg
 *            (radius <= 0, margin < 0, k < 0, any of them non-finite, threshold 0,
 *            unknown flag not 0/1, unknown flags), bad grid geometry;
 *   -ENOSPC  grid larger than RT_GRID_MAX_CELLS, or the simplified path needs more than
 *            RT_PLAN_MAX_WAYPOINTS waypoints;
 *   -ENOENT  no allowed cell at all, or the goal is forbidden or unreachable (without
 *            RT_PLAN_NEAREST_GOAL).
 * On failure *out holds n_wps = 0. */
FS_MUST_CHECK
int rt_plan_path(const rt_grid_t *grid, const rt_plan_cfg_t *cfg, float sx, float sy, float gx,
                 float gy, rt_plan_workspace_t *ws, rt_plan_result_t *out);

#endif /* RT_PLAN_H */
