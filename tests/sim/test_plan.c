/* Floor-plan parser: good inputs (point syntaxes, nesting, room types, scale), every class of
 * bad input with its line and column (and the element's id, on a one-line CubiCasa-style
 * plan), file faults, door cutting geometry, openings nested in their wall or
 * sibling to it (same geometry, warnings for openings over no wall), normalisation, and the
 * default plan. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "sim_grid.h"
#include "sim_plan.h"

#define HEAD "<?xml version=\"1.0\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\">\n" /* lines 1-2 */

static const char *const GOOD =
    HEAD
    "<!-- a comment <g class=\"Wall\"> that must be ignored -->\n"          /* 3 */
    "<g id=\"Wall\" class=\"Wall External\">\n"                            /* 4 */
    "  <polygon points=\"0,0 1000,0 1000,20 0,20\"/>\n"                    /* 5 */
    "  <g id=\"Door\" class=\"Door Swing\"><polygon points='200 0 300 0 300 20 200 20'/></g>\n" /* 6 */
    "  <g class='Window Regular' id='Window'>\n"                           /* 7 */
    "    <polygon fill=\"none\" points=\"600,0,700,0,700,20,600,20\"/>\n"   /* 8 */
    "  </g>\n"
    "</g>\n"
    "<g class=\"Wall\"><polygon points=\"0,20 20,20 20,500 0,500\"/></g>\n"  /* 11 */
    "<g class=\"Space Kitchen\">\n"                                        /* 12 */
    "  <polygon points=\"20,20 500,20 500,500 20,500\"/>\n"
    "  <text>Kitchen</text><path d=\"M 0 0 L 1 1\"/>\n"
    "</g>\n"
    "<g class=\"Space\"><polygon points=\"500,20 1000,20 1000,500\"/></g>\n"
    "<g class=\"FixedFurniture Sink\"><polygon points=\"30,30 40,30 40,40 30,40\"/></g>\n"
    "</svg>\n";

static void test_good_plan(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(GOOD, "good.svg", 0.0, &p, err, sizeof err), 0);
    assert_string_equal(err, "");
    assert_true(p.scale == SIM_PLAN_DEFAULT_SCALE);
    assert_int_equal(p.n_walls, 2);
    assert_int_equal(p.walls[0].outline.n, 4);
    assert_int_equal(p.walls[0].line, 5);
    assert_int_equal(p.walls[0].col, 3);
    assert_string_equal(p.walls[0].id, "Wall");
    assert_int_equal(p.walls[1].line, 11);
    assert_int_equal(p.walls[1].col, 17);
    assert_string_equal(p.walls[1].id, "");
    assert_int_equal(p.n_openings, 2);
    assert_int_equal(p.openings[0].kind, SIM_OPENING_DOOR);
    assert_int_equal(p.openings[0].wall, 0);
    assert_int_equal(p.openings[0].line, 6);
    assert_int_equal(p.openings[0].col, 35);
    assert_string_equal(p.openings[0].id, "Door");
    assert_int_equal(p.openings[0].isolated, 0);
    assert_int_equal(sim_plan_warnings(&p, "good.svg", NULL), 0);
    assert_int_equal(p.openings[1].kind, SIM_OPENING_WINDOW);
    assert_int_equal(p.openings[1].line, 8);
    assert_int_equal(p.openings[1].col, 5);
    assert_string_equal(p.openings[1].id, "Window");
    assert_true(fabs(p.openings[0].outline.p[1].x - 3.0) < 1e-12);
    assert_true(fabs(p.openings[1].outline.p[2].y - 0.2) < 1e-12);
    assert_int_equal(p.n_rooms, 2);
    assert_string_equal(p.rooms[0].type, "Kitchen");
    assert_string_equal(p.rooms[1].type, "Undefined");
    assert_int_equal(p.rooms[1].outline.n, 3);
    /* Bounding box over the walls, in metres. */
    assert_true(fabs(p.min.x) < 1e-12 && fabs(p.min.y) < 1e-12);
    assert_true(fabs(p.max.x - 10.0) < 1e-12 && fabs(p.max.y - 5.0) < 1e-12);
    /* Wall 0 cut by its door into two rectangles, window kept solid; wall 1 whole. */
    assert_int_equal(p.n_solids, 3);
    for (int i = 0; i < p.n_solids; i++)
        assert_int_equal(p.solids[i].is_rect, 1);
    sim_plan_free(&p);
    assert_null(p.walls);
    assert_int_equal(p.n_walls, 0);
}

static void test_scale(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(GOOD, "good.svg", 0.02, &p, err, sizeof err), 0);
    assert_true(fabs(p.max.x - 20.0) < 1e-12);
    assert_true(fabs(p.max.y - 10.0) < 1e-12);
    sim_plan_free(&p);
    assert_int_equal(sim_plan_parse(GOOD, "good.svg", INFINITY, &p, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "absurd scale"));
}

/* Closing repeat of the first point and consecutive repeats are dropped; signs and
 * exponents are numbers too; a namespace prefix on elements is accepted. */
static void test_point_forms(void **state)
{
    (void)state;
    const char *t = "<svg:svg><svg:g class=\"Wall\"><svg:polygon points=\" -1e2,0 , 100 0 100,10 100,10 -100,10 -1e2,0 \"/>"
                    "</svg:g></svg:svg>";
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(t, "ns.svg", 1.0, &p, err, sizeof err), 0);
    assert_int_equal(p.n_walls, 1);
    assert_int_equal(p.walls[0].outline.n, 4);
    assert_true(p.walls[0].outline.p[0].x == -100.0);
    assert_int_equal(p.solids[0].is_rect, 1);
    sim_plan_free(&p);
}

/* Expect failure with "name:LINE:COL: ..." containing `what`. */
static void expect_error(const char *text, int line, int col, const char *what)
{
    sim_plan_t p;
    char err[256], prefix[64];
    memset(&p, 0x5a, sizeof p);
    int rc = sim_plan_parse(text, "bad.svg", 0.0, &p, err, sizeof err);
    if (rc >= 0)
        fail_msg("accepted, expected error at %d:%d (%s)", line, col, what);
    snprintf(prefix, sizeof prefix, "bad.svg:%d:%d: ", line, col);
    if (strncmp(err, prefix, strlen(prefix)) != 0 || strstr(err, what) == NULL)
        fail_msg("message '%s', expected prefix '%s' and '%s'", err, prefix, what);
    /* The plan is left empty. */
    assert_null(p.walls);
    assert_null(p.rooms);
    assert_null(p.openings);
    assert_null(p.solids);
    assert_int_equal(p.n_walls + p.n_rooms + p.n_openings + p.n_solids, 0);
}

#define WALL_OK "<g class=\"Wall\"><polygon points=\"0,0 100,0 100,10 0,10\"/></g>\n"

static void test_bad_inputs(void **state)
{
    (void)state;
    expect_error("", 1, 1, "no <svg> root");
    expect_error("<?xml version=\"1.0\"?>\n<!-- only -->\n\n", 4, 1, "no <svg> root");
    expect_error("<?xml version=\"1.0\"?>\n<html>\n</html>\n", 2, 1, "not an SVG file");
    expect_error(HEAD "<g class=\"Wall\"><polygon points=\"0,0 1x0,0 100,10 0,10\"/></g>\n</svg>\n", 3, 38,
                 "bad number '1x0'");
    expect_error(HEAD "<g class=\"Wall\"><polygon points=\"0,0 100,0\n100,10 0,nan\"/></g>\n</svg>\n", 4, 10,
                 "bad number 'nan'");
    expect_error(HEAD "<g class=\"Wall\">\n<polygon points=\"0,0 100,0 100,10 0\"/></g>\n</svg>\n", 4, 18,
                 "odd number of coordinates");
    expect_error(HEAD "<g class=\"Wall\"><polygon points=\"0,0 100,0\"/></g>\n</svg>\n", 3, 34, "degenerate");
    expect_error(HEAD "<g class=\"Wall\"><polygon points=\"0,0 100,0 100,0 0,0\"/></g>\n</svg>\n", 3, 34,
                 "degenerate");
    expect_error(HEAD "<g class=\"Wall\"><polygon points=\"0,0 100,0 200,0 50,0\"/></g>\n</svg>\n", 3, 34,
                 "zero area");
    expect_error(HEAD "\n<g class=\"Wall\"><polygon points=\"0,0 100,0 100,10 0,10\"/>\n</svg>\n", 4, 1,
                 "<g> is never closed");
    expect_error(HEAD WALL_OK "<g>\n<g class=\"Space Bath\">\n", 5, 1, "<g> is never closed");
    expect_error(HEAD "<g class=\"Wall\"><polygon points=\"0,0 100,0 100,10 0,10\n\n/></g>\n</svg>\n", 3, 33,
                 "unclosed quote");
    expect_error(HEAD WALL_OK "<polygon points='1 2 3 4 5 6'", 4, 1, "unclosed tag <polygon>");
    expect_error(HEAD "<!-- never\nends\n", 3, 1, "unclosed comment");
    expect_error(HEAD "<g class=\"Space Bath\"><polygon points=\"0,0 100,0 100,10 0,10\"/></g>\n</svg>\n", 2, 1,
                 "no walls");
    expect_error(HEAD "<g class=\"Wall\">\n</g>\n</svg>\n", 3, 1, "Wall group has no polygon");
    expect_error(HEAD "<g class=\"Wall\"><polygon points=\"0,0 1e9,0 1e9,10 0,10\"/></g>\n</svg>\n", 3, 34,
                 "absurd");
    expect_error(HEAD "<g class=\"Wall\"><polygon points=\"0,0 300000,0 300000,10 0,10\"/></g>\n</svg>\n", 3, 17,
                 "absurd plan size");
    expect_error(HEAD "<g class=\"Wall\"><polygon points=\"0,0 1,0 1,1 0,1\"/></g>\n</svg>\n", 3, 17,
                 "absurd plan size");
    expect_error(HEAD WALL_OK "<g class=Wall></g></svg>\n", 4, 10, "not quoted");
    expect_error(HEAD WALL_OK "</svg>\n<g/>\n", 5, 1, "after the end");
    expect_error(HEAD WALL_OK "</g>\n", 4, 1, "matches no open element");
    expect_error(HEAD WALL_OK "<g>\n<g>\n</x>\n", 6, 1, "matches no open element");
    /* Too many points: 65 distinct points. */
    char big[4096];
    int k = snprintf(big, sizeof big, HEAD "<g class=\"Wall\">\n<polygon points=\"");
    for (int i = 0; i <= SIM_POLY_MAX_POINTS; i++) {
        double a = 2.0 * 3.14159265358979323846 * i / (SIM_POLY_MAX_POINTS + 1);
        k += snprintf(big + k, sizeof big - (size_t)k, "%.3f,%.3f ", 500 + 400 * cos(a), 500 + 400 * sin(a));
    }
    snprintf(big + k, sizeof big - (size_t)k, "\"/></g></svg>\n");
    expect_error(big, 4, 18, "too many points");
}

/* Column of `what` (its first occurrence) in its line of `text`, 1-based. */
static int col_of(const char *text, const char *what)
{
    const char *p = strstr(text, what);
    assert_non_null(p);
    const char *line = p;
    while (line > text && line[-1] != '\n')
        line--;
    return (int)(p - line) + 1;
}

static void expect_message(const char *text, const char *want)
{
    sim_plan_t p;
    char err[512];
    assert_true(sim_plan_parse(text, "plan.svg", 0.0, &p, err, sizeof err) < 0);
    if (strcmp(err, want) != 0)
        fail_msg("message '%s', expected '%s'", err, want);
}

/* CubiCasa5K writes a whole plan on one line: errors name the column, and the element's id
 * when it has one (the polygon's own, not its group's); warnings likewise. */
#define ONE_LINE_HEAD "<?xml version=\"1.0\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\">" \
                      "<g id=\"Wall_1\" class=\"Wall External\"><polygon points=\"0,0 1000,0 1000,20 0,20\"/></g>"
static void test_error_places_on_one_line(void **state)
{
    (void)state;
    char want[512];
    const char *t =
        ONE_LINE_HEAD "<g class=\"Wall\"><polygon id=\"Wall_12\" points=\"0,20 20,20 20,50O 0,500\"/></g></svg>";
    snprintf(want, sizeof want, "plan.svg:2:%d: polygon id=\"Wall_12\": bad number '50O' in points", col_of(t, "50O"));
    expect_message(t, want);
    t = ONE_LINE_HEAD "<g class=\"Wall\"><polygon id=\"Wall_13\" points=\"0,20 20,20 20,500\n\n 0\"/></g></svg>";
    snprintf(want, sizeof want, "plan.svg:2:%d: polygon id=\"Wall_13\": odd number of coordinates (7) in points",
             col_of(t, "0,20 20,20 20,500"));
    expect_message(t, want);
    /* No id: no element named. */
    t = ONE_LINE_HEAD "<g class=\"Wall\"><polygon points=\"0,20 20,20 20,x 0,500\"/></g></svg>";
    snprintf(want, sizeof want, "plan.svg:2:%d: bad number 'x' in points", col_of(t, "x 0,500"));
    expect_message(t, want);
    t = ONE_LINE_HEAD "<g id=\"Door_3\" class=\"Door\"></g></svg>";
    snprintf(want, sizeof want, "plan.svg:2:%d: g id=\"Door_3\": Door group has no polygon",
             col_of(t, "<g id=\"Door_3\""));
    expect_message(t, want);
    t = ONE_LINE_HEAD "<svg:g id='F1' transform='scale(0)'></svg:g></svg>";
    snprintf(want, sizeof want, "plan.svg:2:%d: svg:g id=\"F1\": degenerate transform (zero determinant)",
             col_of(t, "scale(0)"));
    expect_message(t, want);
    t = ONE_LINE_HEAD "<g id=\"G7\"></svg>";
    snprintf(want, sizeof want, "plan.svg:2:%d: g id=\"G7\": <g> is never closed (found </svg> at 2:%d)",
             col_of(t, "<g id=\"G7\""), col_of(t, "</svg>"));
    expect_message(t, want);
    /* An id is quoted up to SIM_PLAN_ID_MAX - 1 bytes, in messages and records alike. */
    char big[1024], id[101];
    memset(id, 'a', 100);
    id[100] = '\0';
    snprintf(big, sizeof big, ONE_LINE_HEAD "<g class=\"Wall\"><polygon id=\"%s\" points=\"0,20 20,20\"/></g></svg>",
             id);
    snprintf(want, sizeof want,
             "plan.svg:2:%d: polygon id=\"%.*s\": degenerate polygon: 2 distinct points, at least 3 needed",
             col_of(big, "0,20 20,20"), SIM_PLAN_ID_MAX - 1, id);
    expect_message(big, want);

    /* Records: the group's id, else the polygon's; the polygon's place. Warnings name both. */
    snprintf(big, sizeof big,
             ONE_LINE_HEAD "<g class=\"Wall\"><polygon id=\"%s\" points=\"0,20 20,20 20,500 0,500\"/></g>"
                           "<g id=\"D9\" class=\"Door\"><polygon points=\"200,100 290,100 290,120 200,120\"/></g>"
                           "<g class=\"Window\"><polygon points=\"600,150 700,150 700,160 600,160\"/></g></svg>",
             id);
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(big, "plan.svg", 0.0, &p, err, sizeof err), 0);
    assert_string_equal(p.walls[0].id, "Wall_1");
    assert_int_equal(p.walls[0].line, 2);
    assert_int_equal(p.walls[0].col, col_of(big, "<polygon points=\"0,0 1000,0"));
    assert_int_equal((int)strlen(p.walls[1].id), SIM_PLAN_ID_MAX - 1);
    assert_true(strncmp(p.walls[1].id, id, SIM_PLAN_ID_MAX - 1) == 0);
    char *buf = NULL;
    size_t len = 0;
    FILE *out = open_memstream(&buf, &len);
    assert_non_null(out);
    assert_int_equal(sim_plan_warnings(&p, "plan.svg", out), 2);
    fclose(out);
    snprintf(want, sizeof want,
             "plan.svg:2:%d: warning: Door id=\"D9\" overlaps no wall, it cuts nothing\n"
             "plan.svg:2:%d: warning: Window overlaps no wall, it cuts nothing\n",
             col_of(big, "<polygon points=\"200,100"), col_of(big, "<polygon points=\"600,150"));
    assert_string_equal(buf, want);
    free(buf);
    sim_plan_free(&p);
}

/* Faults of the file itself are "FILE: reason"; a NUL byte is a place in it. */
static void test_load_errors(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256], dir[] = "/tmp/fleetsim-plan-XXXXXX", path[64];
    assert_true(sim_plan_load("/nonexistent.svg", 0.0, &p, err, sizeof err) == -ENOENT);
    assert_string_equal(err, "/nonexistent.svg: cannot open: No such file or directory");
    assert_null(p.walls);
    assert_non_null(mkdtemp(dir));
    assert_true(sim_plan_load(dir, 0.0, &p, err, sizeof err) == -EISDIR);
    snprintf(path, sizeof path, "%s: cannot open: Is a directory", dir);
    assert_string_equal(err, path);
    snprintf(path, sizeof path, "%s/nul.svg", dir);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite("<svg>\n<g>\0</g>", 1, 15, f), 15);
    fclose(f);
    assert_int_equal(sim_plan_load(path, 0.0, &p, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, ":2:4: NUL byte in the file"));
    assert_true(strncmp(err, path, strlen(path)) == 0);
    assert_null(p.walls);
    assert_int_equal(unlink(path), 0);
    assert_int_equal(rmdir(dir), 0);
    assert_true(sim_plan_parse(GOOD, "x.svg", 1e6, &p, err, sizeof err) < 0);
    assert_string_equal(err, "x.svg: absurd scale 1e+06 metres per pixel");
}

/* Exactly SIM_POLY_MAX_POINTS points is fine. */
static void test_max_points(void **state)
{
    (void)state;
    char big[4096];
    int k = snprintf(big, sizeof big, HEAD "<g class=\"Wall\">\n<polygon points=\"");
    for (int i = 0; i < SIM_POLY_MAX_POINTS; i++) {
        double a = 2.0 * 3.14159265358979323846 * i / SIM_POLY_MAX_POINTS;
        k += snprintf(big + k, sizeof big - (size_t)k, "%.3f,%.3f ", 500 + 400 * cos(a), 500 + 400 * sin(a));
    }
    snprintf(big + k, sizeof big - (size_t)k, "\"/></g></svg>\n");
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(big, "round.svg", 0.0, &p, err, sizeof err), 0);
    assert_int_equal(p.walls[0].outline.n, SIM_POLY_MAX_POINTS);
    assert_int_equal(p.n_solids, 1);
    assert_int_equal(p.solids[0].is_rect, 0);
    sim_plan_free(&p);
}

static int solid_count_at(const sim_plan_t *p, double x, double y)
{
    int n = 0;
    for (int i = 0; i < p->n_solids; i++)
        n += sim_poly_contains(&p->solids[i].outline, x, y);
    return n;
}

/* A CubiCasa-style mitred (trapezoid) wall is cut like a rectangle; an L-shaped (non-convex)
 * wall keeps its door closed (documented limitation). */
static void test_trapezoid_and_nonconvex_walls(void **state)
{
    (void)state;
    const char *t = HEAD
        "<g class=\"Wall External\"><polygon points=\"118.00,21.56 1293.38,21.56 1277.38,37.56 133.97,37.56\"/>\n"
        "<g class=\"Door Swing Beside\"><polygon points=\"400,21.56 490,21.56 490,37.56 400,37.56\"/></g></g>\n"
        "<g class=\"Wall\"><polygon points=\"0,100 300,100 300,110 10,110 10,400 0,400\"/>\n"
        "<g class=\"Door\"><polygon points=\"100,100 190,100 190,110 100,110\"/></g></g>\n"
        "</svg>\n";
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(t, "trap.svg", 0.0, &p, err, sizeof err), 0);
    assert_int_equal(p.n_solids, 3);
    assert_int_equal(p.solids[0].outline.n, 4);
    assert_int_equal(p.solids[1].outline.n, 4);
    assert_int_equal(p.solids[0].is_rect, 0);
    assert_int_equal(p.solids[2].is_rect, 0);
    assert_int_equal(p.solids[2].outline.n, 6);
    /* Trapezoid: solid left and right of the door, open in it, areas add up. */
    assert_int_equal(solid_count_at(&p, 2.0, 0.3), 1);
    assert_int_equal(solid_count_at(&p, 4.45, 0.3), 0);
    assert_int_equal(solid_count_at(&p, 10.0, 0.3), 1);
    double whole = fabs(sim_poly_signed_area(&p.walls[0].outline));
    double pieces = fabs(sim_poly_signed_area(&p.solids[0].outline)) + fabs(sim_poly_signed_area(&p.solids[1].outline));
    assert_true(fabs(whole - pieces - 0.9 * 0.16) < 1e-9);
    /* L-shaped wall: the door stays closed. */
    assert_int_equal(solid_count_at(&p, 1.45, 1.05), 1);
    sim_plan_free(&p);
}

static int solid_has(const sim_plan_t *p, double x, double y)
{
    for (int i = 0; i < p->n_solids; i++)
        if (sim_poly_contains(&p->solids[i].outline, x, y))
            return 1;
    return 0;
}

/* A vertical wall (long axis y) with two doors, one overlapping the wall end and two
 * overlapping each other: the pieces are exactly the uncovered intervals. */
static void test_door_cutting(void **state)
{
    (void)state;
    const char *t = HEAD
        "<g class=\"Wall\"><polygon points=\"100,0 110,0 110,1000 100,1000\"/>\n"
        "<g class=\"Door\"><polygon points=\"95,200 115,200 115,300 95,300\"/></g>\n"
        "<g class=\"Door\"><polygon points=\"100,250 110,250 110,400 100,400\"/></g>\n"
        "<g class=\"Door\"><polygon points=\"100,900 110,900 110,1100 100,1100\"/></g>\n"
        "<g class=\"Window\"><polygon points=\"100,500 110,500 110,600 100,600\"/></g>\n"
        "</g></svg>\n";
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(t, "cut.svg", 0.0, &p, err, sizeof err), 0);
    assert_int_equal(p.n_openings, 4);
    assert_int_equal(p.n_solids, 2); /* y 0..2 and y 4..9 (metres) */
    double lo[2], hi[2];
    for (int i = 0; i < 2; i++) {
        const sim_poly_t *o = &p.solids[i].outline;
        assert_int_equal(p.solids[i].is_rect, 1);
        lo[i] = INFINITY;
        hi[i] = -INFINITY;
        double xlo = INFINITY, xhi = -INFINITY;
        for (int k = 0; k < 4; k++) {
            lo[i] = fmin(lo[i], o->p[k].y);
            hi[i] = fmax(hi[i], o->p[k].y);
            xlo = fmin(xlo, o->p[k].x);
            xhi = fmax(xhi, o->p[k].x);
        }
        assert_true(fabs(xlo - 1.0) < 1e-9 && fabs(xhi - 1.1) < 1e-9); /* full thickness */
    }
    assert_true(fabs(lo[0] - 0.0) < 1e-9 && fabs(hi[0] - 2.0) < 1e-9);
    assert_true(fabs(lo[1] - 4.0) < 1e-9 && fabs(hi[1] - 9.0) < 1e-9);
    assert_true(solid_has(&p, 1.05, 1.0));
    assert_false(solid_has(&p, 1.05, 3.0));
    assert_true(solid_has(&p, 1.05, 5.5)); /* window stays solid */
    assert_false(solid_has(&p, 1.05, 9.5));
    sim_plan_free(&p);
}

/* A rotated (45 degree) rectangular wall is cut along its own axis. */
static void test_door_cutting_rotated(void **state)
{
    (void)state;
    const char *t = HEAD
        "<g class=\"Wall\"><polygon points=\"0,0 700,700 690,710 -10,10\"/>\n"
        "<g class=\"Door\"><polygon points=\"300,300 400,400 390,410 290,310\"/></g>\n"
        "</g></svg>\n";
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(t, "rot.svg", 0.0, &p, err, sizeof err), 0);
    assert_int_equal(p.n_solids, 2);
    assert_true(sim_poly_is_rect(&p.solids[0].outline));
    assert_true(sim_poly_is_rect(&p.solids[1].outline));
    assert_true(solid_has(&p, 1.0, 1.0 + 0.02));
    assert_false(solid_has(&p, 3.5, 3.5 + 0.02));
    assert_true(solid_has(&p, 6.0, 6.0 + 0.02));
    sim_plan_free(&p);
}

/* Transforms compose down the tree: group translate, then the polygon's own scale/rotate. */
static void test_transforms(void **state)
{
    (void)state;
    const char *t = HEAD
        "<g class=\"Floorplan\" transform=\"translate(100, 50)\">\n"
        "<g class=\"Wall\"><polygon transform=\"scale(2)\" points=\"0,0 100,0 100,10 0,10\"/></g>\n"
        "<g class=\"Wall\" transform=\"rotate(90 0 0)\"><polygon points=\"0,0 100,0 100,10 0,10\"/></g>\n"
        "<g class=\"Space Bath\" transform=\"matrix(1,0,0,1,10,10) skewX(0)\"><polygon points=\"0,0 50,0 50,50\"/></g>\n"
        "</g></svg>\n";
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(t, "tf.svg", 0.0, &p, err, sizeof err), 0);
    const sim_poly_t *w0 = &p.walls[0].outline, *w1 = &p.walls[1].outline;
    /* (100,0) -> scale 2 -> (200,0) -> translate -> (300,50) px -> (3, 0.5) m */
    assert_true(fabs(w0->p[1].x - 3.0) < 1e-12 && fabs(w0->p[1].y - 0.5) < 1e-12);
    assert_true(fabs(w0->p[2].y - 0.7) < 1e-12);
    /* rotate 90: (100,0) -> (0,100) -> (100,150) px */
    assert_true(fabs(w1->p[1].x - 1.0) < 1e-9 && fabs(w1->p[1].y - 1.5) < 1e-9);
    assert_true(sim_poly_is_rect(w1));
    assert_true(fabs(p.rooms[0].outline.p[1].x - 1.6) < 1e-12 && fabs(p.rooms[0].outline.p[1].y - 0.6) < 1e-12);
    sim_plan_free(&p);

    expect_error(HEAD "<g class=\"Wall\"\n transform=\"translate(1,x)\"><polygon points=\"0,0 100,0 100,10 0,10\"/></g></svg>",
                 4, 25, "bad number 'x' in transform");
    expect_error(HEAD "<g transform=\"warp(3)\">" WALL_OK "</g></svg>", 3, 15, "bad transform 'warp'");
    expect_error(HEAD "<g transform=\"scale(1 2 3)\">" WALL_OK "</g></svg>", 3, 15, "wrong argument count");
    expect_error(HEAD "<g transform=\"translate(1,2\">" WALL_OK "</g></svg>", 3, 15, "unclosed '('");
    expect_error(HEAD "<g transform=\"scale(0)\">" WALL_OK "</g></svg>", 3, 15, "degenerate transform");
}

/* ---- openings wherever they sit in the tree ---------------------------------------------- */

/* A 10 x 3 m flat of two rooms: 20 px walls, a window in the north wall, the entrance door in
 * the south wall, a door in the partition. The same plan in two layouts: openings nested in
 * their wall groups, and openings as siblings of the walls (one inside an unrelated group). */
#define FLAT_ROOMS                                                                       \
    "<g class=\"Space Kitchen\"><polygon points=\"20,20 490,20 490,280 20,280\"/></g>\n" \
    "<g class=\"Space Bath\"><polygon points=\"510,20 980,20 980,280 510,280\"/></g>\n"
#define FLAT_WINDOW "<g class=\"Window\"><polygon points=\"100,0 300,0 300,20 100,20\"/></g>\n"
#define FLAT_ENTRANCE "<g class=\"Door\"><polygon points=\"700,280 790,280 790,300 700,300\"/></g>\n"
#define FLAT_INNER_DOOR "<g class=\"Door\"><polygon points=\"490,100 510,100 510,190 490,190\"/></g>\n"

static const char *const FLAT_NESTED =
    HEAD
    "<g class=\"Wall\"><polygon points=\"0,0 1000,0 1000,20 0,20\"/>\n" FLAT_WINDOW "</g>\n"
    "<g class=\"Wall\"><polygon points=\"0,280 1000,280 1000,300 0,300\"/>\n" FLAT_ENTRANCE "</g>\n"
    "<g class=\"Wall\"><polygon points=\"0,20 20,20 20,280 0,280\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"980,20 1000,20 1000,280 980,280\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"490,20 510,20 510,280 490,280\"/>\n" FLAT_INNER_DOOR "</g>\n"
    FLAT_ROOMS "</svg>\n";

static const char *const FLAT_SIBLING =
    HEAD
    "<g class=\"Wall\"><polygon points=\"0,0 1000,0 1000,20 0,20\"/></g>\n" FLAT_WINDOW
    "<g class=\"Wall\"><polygon points=\"0,280 1000,280 1000,300 0,300\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"0,20 20,20 20,280 0,280\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"980,20 1000,20 1000,280 980,280\"/></g>\n"
    "<g class=\"Wall\"><polygon points=\"490,20 510,20 510,280 490,280\"/></g>\n"
    FLAT_INNER_DOOR
    "<g class=\"Openings\">\n" FLAT_ENTRANCE "</g>\n"
    FLAT_ROOMS "</svg>\n";

/* The two plans have the same walls, the same solids (bit for bit, same order) and the same
 * ground-truth raster. */
static void assert_same_geometry(const sim_plan_t *a, const sim_plan_t *b, double res)
{
    assert_int_equal(a->n_walls, b->n_walls);
    assert_int_equal(a->n_solids, b->n_solids);
    for (int i = 0; i < a->n_walls; i++)
        assert_memory_equal(&a->walls[i].outline, &b->walls[i].outline, sizeof a->walls[i].outline);
    for (int i = 0; i < a->n_solids; i++) {
        assert_int_equal(a->solids[i].is_rect, b->solids[i].is_rect);
        assert_int_equal(a->solids[i].outline.n, b->solids[i].outline.n);
        assert_memory_equal(a->solids[i].outline.p, b->solids[i].outline.p,
                            (size_t)a->solids[i].outline.n * sizeof a->solids[i].outline.p[0]);
    }
    sim_grid_t ga, gb;
    assert_int_equal(sim_grid_from_plan(a, res, &ga), 0);
    assert_int_equal(sim_grid_from_plan(b, res, &gb), 0);
    assert_int_equal(ga.w, gb.w);
    assert_int_equal(ga.h, gb.h);
    assert_memory_equal(ga.cells, gb.cells, (size_t)ga.w * (size_t)ga.h);
    sim_grid_free(&ga);
    sim_grid_free(&gb);
}

static int grid_cell_at(const sim_plan_t *p, double res, double x, double y)
{
    sim_grid_t g;
    assert_int_equal(sim_grid_from_plan(p, res, &g), 0);
    int c, r;
    assert_int_equal(sim_grid_world_to_cell(&g, x, y, &c, &r), 0);
    int v = g.cells[(size_t)r * (size_t)g.w + (size_t)c];
    sim_grid_free(&g);
    return v;
}

static void test_sibling_openings_same_as_nested(void **state)
{
    (void)state;
    sim_plan_t n, s;
    char err[256];
    assert_int_equal(sim_plan_parse(FLAT_NESTED, "nested.svg", 0.0, &n, err, sizeof err), 0);
    assert_int_equal(sim_plan_parse(FLAT_SIBLING, "sibling.svg", 0.0, &s, err, sizeof err), 0);
    assert_int_equal(s.n_openings, 3);
    for (int i = 0; i < s.n_openings; i++) {
        assert_int_equal(s.openings[i].wall, -1);
        assert_int_equal(s.openings[i].isolated, 0);
    }
    assert_int_equal(sim_plan_warnings(&s, "sibling.svg", NULL), 0);
    /* 5 walls, 2 of them cut once: 7 solids. */
    assert_int_equal(s.n_solids, 7);
    assert_same_geometry(&n, &s, 0.02);
    /* The sibling doors open their walls (solid gone, raster free); the window does not. */
    assert_false(solid_has(&s, 7.45, 2.9));
    assert_int_equal(grid_cell_at(&s, 0.02, 7.45, 2.9), SIM_CELL_FREE);
    assert_false(solid_has(&s, 5.0, 1.45));
    assert_int_equal(grid_cell_at(&s, 0.02, 5.0, 1.45), SIM_CELL_FREE);
    assert_true(solid_has(&s, 2.0, 0.1));
    assert_int_equal(grid_cell_at(&s, 0.02, 2.0, 0.1), SIM_CELL_WALL);
    /* Beside the doors the walls stay. */
    assert_true(solid_has(&s, 6.9, 2.9) && solid_has(&s, 8.0, 2.9));
    assert_true(solid_has(&s, 5.0, 0.9) && solid_has(&s, 5.0, 2.0));
    sim_plan_free(&n);
    sim_plan_free(&s);
}

/* The default plan rewritten with every door and window moved out of its wall group, next to
 * the furniture: the same solids and raster as the plan itself, and no warning. */
static void test_default_plan_sibling_layout(void **state)
{
    (void)state;
    FILE *f = fopen("host_sim/plans/apartment.svg", "rb");
    assert_non_null(f);
    static char text[1 << 16], moved[1 << 16], out[1 << 17];
    size_t len = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    assert_true(len > 0 && len < sizeof text - 1);
    text[len] = '\0';
    size_t nm = 0, no = 0;
    int n_moved = 0;
    for (char *line = text; *line != '\0';) {
        char *end = strchr(line, '\n');
        size_t l = end ? (size_t)(end - line) + 1 : strlen(line);
        char one[512];
        assert_true(l < sizeof one);
        memcpy(one, line, l);
        one[l] = '\0';
        if (strstr(one, "class=\"Door ") != NULL || strstr(one, "class=\"Window ") != NULL) {
            memcpy(moved + nm, line, l);
            nm += l;
            n_moved++;
        } else {
            if (strstr(one, "<!-- furniture") != NULL) {
                memcpy(out + no, moved, nm);
                no += nm;
            }
            memcpy(out + no, line, l);
            no += l;
        }
        line += l;
    }
    out[no] = '\0';
    assert_int_equal(n_moved, 17);
    sim_plan_t a, b;
    char err[256];
    assert_int_equal(sim_plan_load("host_sim/plans/apartment.svg", 0.0, &a, err, sizeof err), 0);
    assert_int_equal(sim_plan_parse(out, "apartment_sibling.svg", 0.0, &b, err, sizeof err), 0);
    assert_int_equal(b.n_openings, 17);
    for (int i = 0; i < b.n_openings; i++)
        assert_int_equal(b.openings[i].wall, -1);
    assert_int_equal(sim_plan_warnings(&b, "apartment_sibling.svg", NULL), 0);
    assert_int_equal(b.n_solids, 20);
    assert_same_geometry(&a, &b, 0.05);
    assert_same_geometry(&a, &b, 0.02);
    sim_plan_free(&a);
    sim_plan_free(&b);
}

/* A door drawn across a gap between two wall pieces, touching their ends: nothing to cut, no
 * warning, and the gap is free in the raster even though no room covers it. */
static void test_sibling_door_in_wall_gap(void **state)
{
    (void)state;
    const char *t = HEAD
        "<g class=\"Wall\"><polygon points=\"0,0 1000,0 1000,20 0,20\"/></g>\n"
        "<g class=\"Wall\"><polygon points=\"0,280 700,280 700,300 0,300\"/></g>\n"
        "<g class=\"Wall\"><polygon points=\"790,280 1000,280 1000,300 790,300\"/></g>\n"
        FLAT_ENTRANCE
        "<g class=\"Wall\"><polygon points=\"0,20 20,20 20,280 0,280\"/></g>\n"
        "<g class=\"Wall\"><polygon points=\"980,20 1000,20 1000,280 980,280\"/></g>\n"
        FLAT_ROOMS "</svg>\n";
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(t, "gap.svg", 0.0, &p, err, sizeof err), 0);
    assert_int_equal(p.n_openings, 1);
    assert_int_equal(p.openings[0].isolated, 0);
    assert_int_equal(sim_plan_warnings(&p, "gap.svg", NULL), 0);
    assert_int_equal(p.n_solids, 5); /* no wall cut */
    assert_int_equal(grid_cell_at(&p, 0.02, 7.45, 2.9), SIM_CELL_FREE);
    assert_int_equal(grid_cell_at(&p, 0.02, 6.9, 2.9), SIM_CELL_WALL);
    sim_plan_free(&p);
}

/* Openings over no wall load, with one warning each naming their polygon's line, and change
 * no solid: a sibling door and a sibling window in the middle of a room, and a window nested
 * in a wall group but drawn 5 mm off it. One drawn 0.5 mm off a wall (within the 1 mm
 * tolerance) is not warned about. */
static void test_opening_over_no_wall_warns(void **state)
{
    (void)state;
    const char *t = HEAD
        "<g class=\"Wall\"><polygon points=\"0,0 1000,0 1000,20 0,20\"/></g>\n"                   /* 3 */
        "<g class=\"Wall\"><polygon points=\"0,280 1000,280 1000,300 0,300\"/></g>\n"             /* 4 */
        "<g class=\"Wall\"><polygon points=\"0,20 20,20 20,280 0,280\"/></g>\n"                   /* 5 */
        "<g class=\"Wall\"><polygon points=\"980,20 1000,20 1000,280 980,280\"/>\n"               /* 6 */
        "  <g class=\"Window\"><polygon points=\"940,100 979.5,100 979.5,200 940,200\"/></g>\n"   /* 7 */
        "</g>\n"
        "<g class=\"Door\">\n"                                                                    /* 9 */
        "  <polygon points=\"200,100 290,100 290,120 200,120\"/>\n"                               /* 10 */
        "</g>\n"
        "<g class=\"Floor\"><g class=\"Window Regular\">\n"                                       /* 12 */
        "  <polygon points=\"600,20.05 700,20.05 700,40 600,40\"/></g>\n"                         /* 13 */
        "  <g class=\"Window\"><polygon points=\"600,150 700,150 700,160 600,160\"/></g></g>\n"   /* 14 */
        FLAT_ROOMS "</svg>\n";
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(t, "lone.svg", 0.0, &p, err, sizeof err), 0);
    assert_string_equal(err, "");
    assert_int_equal(p.n_openings, 4);
    assert_int_equal(p.openings[0].wall, 3);
    assert_int_equal(p.openings[0].isolated, 1);
    assert_int_equal(p.openings[1].isolated, 1);
    assert_int_equal(p.openings[2].isolated, 0);
    assert_int_equal(p.openings[3].isolated, 1);
    assert_int_equal(p.n_solids, 4); /* nothing cut */
    char *buf = NULL;
    size_t len = 0;
    FILE *out = open_memstream(&buf, &len);
    assert_non_null(out);
    assert_int_equal(sim_plan_warnings(&p, "lone.svg", out), 3);
    fclose(out);
    assert_string_equal(buf, "lone.svg:7:21: warning: Window overlaps no wall, it cuts nothing\n"
                             "lone.svg:10:3: warning: Door overlaps no wall, it cuts nothing\n"
                             "lone.svg:14:21: warning: Window overlaps no wall, it cuts nothing\n");
    free(buf);
    sim_plan_free(&p);
}

/* Which walls a door cuts besides its own: one it crosses (a wall drawn double, as two
 * polygons side by side), whether the door is nested in one of them or a sibling; not one
 * whose face it only grazes (a quarter of the wall's thickness at a junction). */
static void test_door_crosses_and_grazes(void **state)
{
    (void)state;
    const char *nested = HEAD
        "<g class=\"Wall\"><polygon points=\"0,0 1000,0 1000,20 0,20\"/></g>\n"
        "<g class=\"Wall\"><polygon points=\"0,280 1000,280 1000,290 0,290\"/>\n"
        FLAT_ENTRANCE "</g>\n"
        "<g class=\"Wall\"><polygon points=\"0,290 1000,290 1000,300 0,300\"/></g>\n"
        "<g class=\"Wall\"><polygon points=\"490,20 510,20 510,280 490,280\"/>\n"
        "<g class=\"Door\"><polygon points=\"490,15 510,15 510,105 490,105\"/></g></g>\n"
        FLAT_ROOMS "</svg>\n";
    const char *sibling = HEAD
        "<g class=\"Wall\"><polygon points=\"0,0 1000,0 1000,20 0,20\"/></g>\n"
        "<g class=\"Wall\"><polygon points=\"0,280 1000,280 1000,290 0,290\"/></g>\n"
        "<g class=\"Wall\"><polygon points=\"0,290 1000,290 1000,300 0,300\"/></g>\n"
        "<g class=\"Wall\"><polygon points=\"490,20 510,20 510,280 490,280\"/></g>\n"
        FLAT_ENTRANCE "<g class=\"Door\"><polygon points=\"490,15 510,15 510,105 490,105\"/></g>\n"
        FLAT_ROOMS "</svg>\n";
    sim_plan_t n, s;
    char err[256];
    assert_int_equal(sim_plan_parse(nested, "n.svg", 0.0, &n, err, sizeof err), 0);
    assert_int_equal(sim_plan_parse(sibling, "s.svg", 0.0, &s, err, sizeof err), 0);
    assert_same_geometry(&n, &s, 0.02);
    /* Both halves of the double wall are open under the entrance, the raster too. */
    assert_false(solid_has(&s, 7.45, 2.85));
    assert_false(solid_has(&s, 7.45, 2.95));
    assert_int_equal(grid_cell_at(&s, 0.02, 7.45, 2.85), SIM_CELL_FREE);
    assert_int_equal(grid_cell_at(&s, 0.02, 7.45, 2.95), SIM_CELL_FREE);
    /* The partition door grazes the north wall: the partition is cut, the north wall not. */
    assert_true(solid_has(&s, 5.0, 0.1));
    assert_true(solid_has(&s, 5.0, 0.18));
    assert_false(solid_has(&s, 5.0, 0.5));
    assert_true(solid_has(&s, 5.0, 1.2));
    /* north 1 + double wall 2 x 2 + partition 1 */
    assert_int_equal(s.n_solids, 6);
    sim_plan_free(&n);
    sim_plan_free(&s);
}

static void test_normalise_round_trip(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_parse(GOOD, "good.svg", 0.0, &p, err, sizeof err), 0);
    float xn, yn;
    sim_plan_normalise(&p, 0.0, 0.0, &xn, &yn);
    assert_true(xn == -1.0f && yn == -1.0f);
    sim_plan_normalise(&p, 10.0, 5.0, &xn, &yn);
    assert_true(xn == 1.0f && yn == 1.0f);
    sim_plan_normalise(&p, 5.0, 2.5, &xn, &yn);
    assert_true(fabs(xn) < 1e-7 && fabs(yn) < 1e-7);
    alloc_count_reset();
    for (int i = 0; i <= 100; i++) {
        double x = 10.0 * i / 100.0, y = 5.0 * (100 - i) / 100.0, bx, by;
        sim_plan_normalise(&p, x, y, &xn, &yn);
        assert_true(xn >= -1.0f && xn <= 1.0f && yn >= -1.0f && yn <= 1.0f);
        sim_plan_denormalise(&p, xn, yn, &bx, &by);
        assert_true(fabs(bx - x) < 1e-5 && fabs(by - y) < 1e-5);
    }
    assert_int_equal(alloc_count_allocations(), 0); /* per-sample calls allocate nothing */
    sim_plan_free(&p);
}

/* Mutated and truncated inputs never crash: each either parses or fails with a
 * "name:LINE: " message and an empty plan (run under ASan by make test-asan). */
static void test_mutations(void **state)
{
    (void)state;
    static const char pool[] = "<>/=\"' ,-.0123456789eE\n!?gG";
    size_t len = strlen(GOOD);
    char *buf = malloc(len + 1);
    assert_non_null(buf);
    uint64_t x = 0x243F6A8885A308D3ull;
    int parsed = 0, failed = 0;
    for (int it = 0; it < 4000; it++) {
        memcpy(buf, GOOD, len + 1);
        int edits = 1 + it % 4;
        for (int k = 0; k < edits; k++) {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            size_t pos = (size_t)(x % len);
            if (k == 0 && it % 5 == 0)
                buf[pos] = '\0'; /* truncation */
            else
                buf[pos] = pool[(x >> 32) % (sizeof pool - 1)];
        }
        sim_plan_t p;
        char err[256];
        int rc = sim_plan_parse(buf, "mut.svg", 0.0, &p, err, sizeof err);
        if (rc == 0) {
            parsed++;
            assert_true(p.n_walls > 0 && p.n_solids > 0);
            sim_plan_free(&p);
        } else {
            failed++;
            assert_true(rc < 0);
            assert_true(strncmp(err, "mut.svg:", 8) == 0);
            assert_null(p.walls);
            assert_null(p.solids);
        }
    }
    free(buf);
    assert_true(parsed > 0 && failed > 0);
}

static void test_load_default_plan(void **state)
{
    (void)state;
    sim_plan_t p;
    char err[256];
    assert_int_equal(sim_plan_load("host_sim/plans/apartment.svg", 0.0, &p, err, sizeof err), 0);
    assert_true(fabs(p.max.x - p.min.x - 12.0) < 1e-9);
    assert_true(fabs(p.max.y - p.min.y - 9.0) < 1e-9);
    assert_true(p.n_rooms >= 6);
    int doors = 0;
    for (int i = 0; i < p.n_openings; i++) {
        if (p.openings[i].kind != SIM_OPENING_DOOR)
            continue;
        doors++;
        /* Every door is at least 0.8 m wide (the longer side of its rectangle). */
        const sim_poly_t *o = &p.openings[i].outline;
        double a = hypot(o->p[1].x - o->p[0].x, o->p[1].y - o->p[0].y);
        double b = hypot(o->p[2].x - o->p[1].x, o->p[2].y - o->p[1].y);
        assert_true(fmax(a, b) >= 0.8 - 1e-9);
    }
    assert_true(doors >= p.n_rooms);
    sim_plan_free(&p);

    assert_true(sim_plan_load("no/such/file.svg", 0.0, &p, err, sizeof err) < 0);
    assert_string_equal(err, "no/such/file.svg: cannot open: No such file or directory");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_good_plan),
        cmocka_unit_test(test_scale),
        cmocka_unit_test(test_point_forms),
        cmocka_unit_test(test_bad_inputs),
        cmocka_unit_test(test_error_places_on_one_line),
        cmocka_unit_test(test_load_errors),
        cmocka_unit_test(test_max_points),
        cmocka_unit_test(test_trapezoid_and_nonconvex_walls),
        cmocka_unit_test(test_door_cutting),
        cmocka_unit_test(test_door_cutting_rotated),
        cmocka_unit_test(test_transforms),
        cmocka_unit_test(test_sibling_openings_same_as_nested),
        cmocka_unit_test(test_default_plan_sibling_layout),
        cmocka_unit_test(test_sibling_door_in_wall_gap),
        cmocka_unit_test(test_opening_over_no_wall_warns),
        cmocka_unit_test(test_door_crosses_and_grazes),
        cmocka_unit_test(test_normalise_round_trip),
        cmocka_unit_test(test_mutations),
        cmocka_unit_test(test_load_default_plan),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
