/* Private to the files of the floor-plan parser, not part of its API (sim_plan.h):
 *   sim_plan.c          the API: parse, load, warnings, free, normalise; the bounding box;
 *   sim_plan_svg.c      the XML tokenizer (elements, attributes, comments, declarations) and
 *                       the attribute values it reads (points, transforms);
 *   sim_plan_elements.c what CubiCasa5K's groups mean (Wall, Door, Window, Space, Railing);
 *   sim_plan_cuts.c     openings against walls: which doors cut which walls, the solids;
 *   sim_plan_geom.c     polygon geometry (the exported helpers and the clipping ones).
 * The tokenizer and the element semantics share the reader below: the tokenizer owns the
 * element stack and the transforms, the semantics own the records they open on it. */
#ifndef SIM_PLAN_INT_H
#define SIM_PLAN_INT_H

#include <stddef.h>

#include "sim_plan.h"

/* Limits on what we accept from a file ("absurd sizes"). */
#define PLAN_MAX_FILE_BYTES (64L * 1024 * 1024)
#define PLAN_MAX_DEPTH 256
#define PLAN_MAX_COORD_M 10000.0 /* |coordinate| in metres */
#define PLAN_MAX_EXTENT_M 2000.0 /* bounding box side in metres */
#define PLAN_MIN_EXTENT_M 0.05
#define PLAN_MAX_SCALE 100.0
#define PLAN_MAX_ITEMS 1000000 /* walls, rooms, openings each */
/* Area below this (m^2) is degenerate; a 1 cm x 1 cm square is 1e-4. */
#define PLAN_MIN_AREA_M2 1e-8

/* ---- errors and arrays (sim_plan.c) ------------------------------------------------------ */

typedef struct {
    const char *name;
    char *err;
    size_t errlen;
} sim_plan_errctx_t;

/* A place in the text: 1-based line and 1-based byte column. CubiCasa5K writes a whole plan
 * on one line, so the column is what finds an element there. */
typedef struct {
    int line, col;
} sim_plan_loc_t;

/* The element a message is about, as written in the text (not terminated): its name, and its
 * id attribute (id NULL when it has none). */
typedef struct {
    const char *name;
    size_t name_len;
    const char *id;
    size_t id_len;
} sim_plan_elem_t;

/* Writes "NAME:LINE:COL: reason" into e->err, with `ELEM id="ID": ` before the reason when
 * el (may be NULL) has an id, and returns -EINVAL. */
__attribute__((format(printf, 4, 5)))
int sim_plan_fail(const sim_plan_errctx_t *e, sim_plan_loc_t at, const sim_plan_elem_t *el, const char *fmt, ...);

/* Copies el's id (truncated) into a record's id field; empty when it has none. */
void sim_plan_copy_id(char id[SIM_PLAN_ID_MAX], const sim_plan_elem_t *el);

/* Grows *arr (of elem-sized items, *cap of them) to hold `need`: 0 or -ENOMEM. */
int sim_plan_grow(void **arr, int *cap, int need, size_t elem);

/* XML white space. */
static inline int sim_plan_is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

/* ---- the reader (sim_plan_svg.c) ---------------------------------------------------------- */

typedef enum { FR_OTHER = 0, FR_WALL, FR_DOOR, FR_WINDOW, FR_SPACE, FR_RAILING } sim_plan_frame_kind_t;

/* One open element. */
typedef struct {
    sim_plan_elem_t el;  /* its name (matched by the end tag) and id */
    sim_plan_loc_t at;   /* where its '<' is */
    sim_plan_frame_kind_t kind; /* set by the semantics for the groups they recognise */
    int index;                  /* index into walls/openings/rooms for semantic frames */
    int has_poly;
    double m[6]; /* transform from this element's coordinates to the document's */
} sim_plan_frame_t;

/* One attribute value in the text (not terminated). */
typedef struct {
    const char *v;
    size_t len;
    sim_plan_loc_t at; /* of its first character */
    int present;
} sim_plan_attr_t;

typedef struct {
    const char *s;
    size_t n, pos;
    int line;
    size_t line_start; /* offset of the current line's first character */
    sim_plan_errctx_t e;
    double scale;
    sim_plan_t *plan;
    int cap_walls, cap_open, cap_rooms, cap_railings;
    sim_plan_frame_t stack[PLAN_MAX_DEPTH];
    int depth;
    int root_seen, root_closed;
    sim_plan_loc_t root_at;
} sim_plan_reader_t;

/* Reads the whole text, calling the semantics below for each group and polygon. */
int sim_plan_read_document(sim_plan_reader_t *r);

/* Parses points attribute a of element el into metres through transform m (SVG order a b c d
 * e f) and the scale: repeats dropped, at least 3 distinct points with a non-zero area. */
int sim_plan_parse_points(const sim_plan_errctx_t *e, const sim_plan_attr_t *a, const sim_plan_elem_t *el,
                          double scale, const double *m, sim_poly_t *out);

/* ---- CubiCasa5K semantics (sim_plan_elements.c) ------------------------------------------- */

/* A <g> was opened as frame f (already on the stack): records it when its class is one we
 * read. */
int sim_plan_open_group(sim_plan_reader_t *r, sim_plan_frame_t *f, const sim_plan_attr_t *cls);

/* A <polygon> (element el at `at`, transform m) was seen: the outline of the innermost
 * semantic group, if that has none yet. */
int sim_plan_take_polygon(sim_plan_reader_t *r, const sim_plan_elem_t *el, sim_plan_loc_t at,
                          const sim_plan_attr_t *points, const double *m);

/* Frame f is being closed: a semantic group must have found its polygon. */
int sim_plan_close_group(sim_plan_reader_t *r, const sim_plan_frame_t *f);

/* ---- openings and cuts (sim_plan_cuts.c) -------------------------------------------------- */

/* Given the walls, openings, railings and bounding box: flags isolated openings and builds
 * the solids (walls minus the doors that cut them, then the railings). 0 or -ENOMEM. */
int sim_plan_build_solids(sim_plan_t *p);

/* ---- geometry (sim_plan_geom.c) ----------------------------------------------------------- */

typedef struct {
    double x0, y0, x1, y1;
} sim_plan_box_t;

sim_plan_box_t sim_plan_poly_box(const sim_poly_t *o);

/* Convex (all turns the same way; collinear points allowed). */
int sim_plan_poly_is_convex(const sim_poly_t *o);

/* Sutherland-Hodgman against one half-plane: keeps points with s * (t(p) - lim) <= 0, where
 * t(p) = (p - c0) . u. Returns the output count (at most cap; points beyond are dropped). */
int sim_plan_clip_half(const sim_vec2_t *in, int n, sim_vec2_t c0, double ux, double uy, double lim, double sgn,
                       sim_vec2_t *out, int cap);

/* The part of convex `in` with lo <= t <= hi: 1 when it is a proper polygon, 0 when empty
 * or degenerate, -1 when it has more than SIM_POLY_MAX_POINTS points. */
int sim_plan_clip_slab(const sim_poly_t *in, sim_vec2_t c0, double ux, double uy, double lo, double hi,
                       sim_poly_t *out);

/* 1 when polygons a and b overlap or come within tol of each other. */
int sim_plan_polys_near(const sim_poly_t *a, const sim_poly_t *b, double tol);

#endif /* SIM_PLAN_INT_H */
