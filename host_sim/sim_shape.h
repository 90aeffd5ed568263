/* Polygon helpers shared by the ODE world, the validation set and the renderer.
 * Pure functions on sim_poly_t (metres); thread-safe. */
#ifndef SIM_SHAPE_H
#define SIM_SHAPE_H

#include "sim_plan.h"

/* Signed area (positive when the points run counter-clockwise). */
double sim_shape_area(const sim_poly_t *p);

/* Triangulates a simple polygon by ear clipping. tris receives n-2 triangles as point
 * indices, counter-clockwise. Returns the number of triangles, or a negative code
 * (-EINVAL for fewer than 3 points or a polygon that is not simple enough to clip). */
FS_MUST_CHECK
int sim_shape_triangulate(const sim_poly_t *p, int tris[][3], int max_tris);

/* 1 when (x, y) is inside the polygon (even-odd rule), else 0. */
int sim_shape_contains(const sim_poly_t *p, double x, double y);

/* Distance from (x, y) to the polygon's boundary. */
double sim_shape_edge_distance(const sim_poly_t *p, double x, double y);

#endif /* SIM_SHAPE_H */
