/* Floor plans: parsing CubiCasa5K-style model.svg files into metric geometry.
 *
 * Structure read (everything else, e.g. furniture and labels, is ignored):
 *   <g id="Wall" class="Wall ...">  first <polygon points="..."> = wall outline
 *   <g class="Door ..."> / <g class="Window ...">  first <polygon> = an opening, wherever the
 *       group sits in the tree (nested in its Wall group, or a sibling of the walls), as
 *       CubiCasa5K's own loader (floortrans/loaders/house.py) takes every such group
 *   <g class="Space <Type> ...">   first <polygon> = room outline, <Type> its room type
 *   <g class="Railing ...">  first <polygon> = a railing (what bounds CubiCasa5K's balconies):
 *       an obstacle like a wall but only SIM_PLAN_RAILING_HEIGHT high; doors do not cut it
 * Points are "x,y x,y ..." or "x y x y ..." in pixels; metres = pixels * scale.
 *
 * Geometry contract (what the ODE world, the rasteriser and the path planner all use):
 *   solids = wall outlines with door openings cut away, then railing outlines (whole, with
 *   their height). Windows stay solid: a TurtleBot's lidar at 0.17 m sees the wall under the
 *   sill. Each solid is a simple polygon in metres; rectangles (the common case) are flagged
 *   so the world can use a box geom. The bounding box covers walls and railings, so a
 *   balcony bounded by railings only is inside it.
 * Axes are the SVG's: x to the right, y DOWN the drawing (metres = pixels * scale, no flip).
 * Accepted: XML comments, <?xml?> and <!DOCTYPE> declarations, attributes in any order with
 * single or double quotes, points separated by commas and/or whitespace, `transform`
 * attributes (matrix/translate/scale/rotate/skewX/skewY, composed down the element tree and
 * applied before the scale). The root's width/height/viewBox are not applied, and a file
 * with several floors (CubiCasa's `Floorplan Floor-2` groups) is read as one merged plan.
 * Rejected with "FILE:LINE:COL: reason" (1-based line and byte column of the fault, and
 * `ELEM id="ID": ` before the reason when the element at fault has an id; CubiCasa5K writes
 * a whole plan on one line): no <svg> root, bad numbers, an odd coordinate count,
 * fewer than 3 distinct points or zero area, more than SIM_POLY_MAX_POINTS points,
 * unclosed tags/groups/quotes/comments, a malformed or singular transform, a Wall/Door/
 * Window/Space/Railing group without a polygon, no walls, absurd sizes (coordinates beyond
 * 10 km, a plan wider than 2 km or narrower than 5 cm, files over 64 MB, scale over
 * 100 m/px).
 * Warned about, the plan still loads: an opening that neither overlaps nor touches (within
 * 1 mm) any wall; it cuts nothing (sim_plan_warnings).
 * Door cutting: a convex wall (rectangle, or the trapezoids CubiCasa5K draws at mitred
 * corners) loses the slab of each cutting door's projection onto its long axis (the direction
 * of its longest edge), across its full thickness; a non-convex wall stays whole (doors not
 * cut). The doors that cut a wall: those nested in its group (whatever their overlap, as
 * always), and every other door that crosses it, i.e. overlaps it with positive area over at
 * least half its thickness; a door that only grazes a wall (the face of a perpendicular wall
 * at a junction) does not cut it. So a door cuts the same walls nested or as a sibling.
 * Not thread-safe per plan; distinct plans are independent. Allocates (host side). */
#ifndef SIM_PLAN_H
#define SIM_PLAN_H

#include <stddef.h>
#include <stdio.h>

#define SIM_POLY_MAX_POINTS 64
#define SIM_ROOM_TYPE_MAX 32
/* Bytes kept of an element's id attribute, with the terminating NUL (longer ids are cut). */
#define SIM_PLAN_ID_MAX 64
/* Height of a railing's solid, metres: a balcony railing is about 1 m high (building codes ask
 * 0.9-1.1 m), so a lidar at 0.17 m sees it and one above 1 m sees over it. */
#define SIM_PLAN_RAILING_HEIGHT 1.0
/* Default metres per pixel for CubiCasa5K plans (their drawings are about 1 px per cm). */
#define SIM_PLAN_DEFAULT_SCALE 0.01

typedef struct sim_vec2 {
    double x, y; /* metres (or pixels before scaling) */
} sim_vec2_t;

typedef struct sim_poly {
    int n;                               /* points, 3 .. SIM_POLY_MAX_POINTS, not repeated */
    sim_vec2_t p[SIM_POLY_MAX_POINTS];
} sim_poly_t;

typedef enum { SIM_OPENING_DOOR = 0, SIM_OPENING_WINDOW = 1 } sim_opening_kind_t;

/* Where a wall, opening or room comes from, for messages: line and column of its polygon's
 * '<' (1-based, the column in bytes), and the id attribute of its group, else of its polygon
 * ("" when neither has one). */
typedef struct sim_wall {
    sim_poly_t outline;
    int line, col;
    char id[SIM_PLAN_ID_MAX];
} sim_wall_t;

typedef struct sim_opening {
    sim_poly_t outline;
    sim_opening_kind_t kind;
    int wall;     /* index of the Wall group it is nested in, -1 when it is in none */
    int line, col;
    char id[SIM_PLAN_ID_MAX];
    int isolated; /* 1 when it neither overlaps nor touches any wall: cuts nothing (a warning) */
} sim_opening_t;

typedef struct sim_room {
    sim_poly_t outline;
    char type[SIM_ROOM_TYPE_MAX]; /* e.g. "Kitchen", "LivingRoom", "Bath" */
    int line, col;
    char id[SIM_PLAN_ID_MAX];
} sim_room_t;

typedef struct sim_solid {
    sim_poly_t outline;
    int is_rect;   /* 1 when outline is a rectangle (4 points, right angles) */
    double height; /* metres above the floor; 0: as high as the world's walls (every wall
                    * piece), SIM_PLAN_RAILING_HEIGHT for a railing */
} sim_solid_t;

typedef struct sim_plan {
    double scale;      /* metres per pixel used when loading */
    sim_vec2_t min;    /* bounding box of all walls and railings, metres */
    sim_vec2_t max;
    sim_wall_t *walls;       int n_walls;
    sim_wall_t *railings;    int n_railings; /* outlines as read, like walls' */
    sim_opening_t *openings; int n_openings;
    sim_room_t *rooms;       int n_rooms;
    sim_solid_t *solids;     int n_solids;
} sim_plan_t;

/* Parses `path`. On failure returns a negative code, leaves *plan empty and writes
 * "FILE:LINE:COL: reason" into err (errlen bytes), or "FILE: reason" when the fault is not
 * at a place in the text (e.g. "FILE: cannot open: No such file or directory", the errno
 * returned). scale <= 0 means SIM_PLAN_DEFAULT_SCALE.
 * On success the plan's warnings, if any, are printed to stderr (sim_plan_warnings), so
 * every command that loads a plan shows them. */
FS_MUST_CHECK
int sim_plan_load(const char *path, double scale, sim_plan_t *plan, char *err, size_t errlen);

/* Same, from a string in memory; `name` is used in messages. Prints nothing: the caller
 * decides what to do with the warnings. */
FS_MUST_CHECK
int sim_plan_parse(const char *text, const char *name, double scale, sim_plan_t *plan,
                   char *err, size_t errlen);

/* Writes the plan's warnings to `out` (NULL: count only), one "NAME:LINE:COL: warning: reason"
 * line each (the reason names the element and its id, when it has one), `name` being the
 * file the plan came from. Returns how many there are. */
int sim_plan_warnings(const sim_plan_t *plan, const char *name, FILE *out);

void sim_plan_free(sim_plan_t *plan);

/* Normalised coordinates of docs/architecture.md section 2 over the plan's bounding box. */
void sim_plan_normalise(const sim_plan_t *plan, double x_m, double y_m, float *xn, float *yn);
void sim_plan_denormalise(const sim_plan_t *plan, float xn, float yn, double *x_m, double *y_m);

/* Polygon helpers (additions to the contract, used by the rasteriser and the planner). */
/* Signed area (shoelace): positive for counter-clockwise in an x-right, y-up frame. */
double sim_poly_signed_area(const sim_poly_t *poly);
/* 1 when (x, y) is inside (even-odd rule). A point on the boundary is decided by a half-open
 * rule that every polygon applies to an edge alike, whichever way it walks it: on an edge
 * two polygons share (the same two end points), a point is inside exactly one of them (the
 * one on the edge's +x side; for a horizontal edge, the one on its +y side). */
int sim_poly_contains(const sim_poly_t *poly, double x, double y);
/* 1 when (x, y) is inside or within tol (>= 0) of the boundary: a closed polygon, for free
 * space that must not lose its edges to rounding (sim_grid's rooms and doors). */
int sim_poly_covers(const sim_poly_t *poly, double x, double y, double tol);
/* 1 when poly has 4 points and 4 right angles (any orientation). */
int sim_poly_is_rect(const sim_poly_t *poly);

#endif /* SIM_PLAN_H */
