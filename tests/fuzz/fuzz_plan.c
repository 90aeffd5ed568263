/* Fuzz target: the SVG floor-plan parser (host_sim/floorplan/sim_plan*.c) through
 * sim_plan_parse, its from-memory entry point (sim_plan_load reads the file into memory,
 * refuses a NUL byte, and calls it). Beyond memory safety it checks the contract of sim_plan.h:
 *   - a refused plan says "NAME:LINE:COL: reason" (or "NAME: reason") and leaves the plan
 *     empty;
 *   - a loaded one has walls, every polygon 3 .. SIM_POLY_MAX_POINTS finite points within the
 *     limits, a bounding box within the absurd-size limits that holds every solid (solids are
 *     pieces of walls, then whole railings with their height), rectangles flagged as such,
 *     room types and ids terminated, every record at a line and column >= 1, and as many
 *     warnings as isolated openings.
 * No state survives an input. */
#include "fuzz/fuzz_config.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sim_plan.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define NAME "fuzz.svg"

static void check_poly(const sim_poly_t *o, double lim)
{
    CHECK(o->n >= 3 && o->n <= SIM_POLY_MAX_POINTS);
    for (int k = 0; k < o->n; k++)
        CHECK(isfinite(o->p[k].x) && isfinite(o->p[k].y) && fabs(o->p[k].x) <= lim && fabs(o->p[k].y) <= lim);
}

/* Where a record comes from: a place in the text and a terminated id. */
static void check_source(int line, int col, const char *id)
{
    CHECK(line >= 1 && col >= 1 && memchr(id, '\0', SIM_PLAN_ID_MAX) != NULL);
}

static void check_plan(const sim_plan_t *p)
{
    const double lim = 10000.0; /* metres, PLAN_MAX_COORD_M */
    CHECK(p->n_walls >= 1 && p->walls != NULL);
    /* A door as long as its wall cuts it away whole: fewer solids than walls is fine. */
    CHECK(p->n_openings >= 0 && p->n_rooms >= 0 && p->n_solids >= 0 && (p->n_solids == 0 || p->solids != NULL));
    CHECK(isfinite(p->min.x) && isfinite(p->min.y) && isfinite(p->max.x) && isfinite(p->max.y));
    const double wx = p->max.x - p->min.x, wy = p->max.y - p->min.y;
    CHECK(wx >= 0.05 && wy >= 0.05 && wx <= 2000.0 && wy <= 2000.0);
    for (int i = 0; i < p->n_walls; i++) {
        check_poly(&p->walls[i].outline, lim);
        check_source(p->walls[i].line, p->walls[i].col, p->walls[i].id);
    }
    CHECK(p->n_railings >= 0 && (p->n_railings == 0 || p->railings != NULL));
    for (int i = 0; i < p->n_railings; i++) {
        check_poly(&p->railings[i].outline, lim);
        check_source(p->railings[i].line, p->railings[i].col, p->railings[i].id);
    }
    int isolated = 0;
    for (int i = 0; i < p->n_openings; i++) {
        const sim_opening_t *o = &p->openings[i];
        check_poly(&o->outline, lim);
        check_source(o->line, o->col, o->id);
        CHECK(o->kind == SIM_OPENING_DOOR || o->kind == SIM_OPENING_WINDOW);
        CHECK(o->wall >= -1 && o->wall < p->n_walls);
        isolated += o->isolated != 0;
    }
    for (int i = 0; i < p->n_rooms; i++) {
        check_poly(&p->rooms[i].outline, lim);
        check_source(p->rooms[i].line, p->rooms[i].col, p->rooms[i].id);
        CHECK(memchr(p->rooms[i].type, '\0', SIM_ROOM_TYPE_MAX) != NULL);
    }
    const double tol = 1e-3;
    for (int i = 0; i < p->n_solids; i++) {
        const sim_solid_t *s = &p->solids[i];
        check_poly(&s->outline, lim);
        CHECK(s->is_rect == sim_poly_is_rect(&s->outline));
        /* The railings are the last n_railings solids, whole. */
        const int railing = i >= p->n_solids - p->n_railings;
        CHECK(s->height == (railing ? SIM_PLAN_RAILING_HEIGHT : 0.0));
        for (int k = 0; k < s->outline.n; k++)
            CHECK(s->outline.p[k].x >= p->min.x - tol && s->outline.p[k].x <= p->max.x + tol &&
                  s->outline.p[k].y >= p->min.y - tol && s->outline.p[k].y <= p->max.y + tol);
    }
    CHECK(sim_plan_warnings(p, NAME, NULL) == isolated);
    float xn, yn;
    sim_plan_normalise(p, 0.5 * (p->min.x + p->max.x), 0.5 * (p->min.y + p->max.y), &xn, &yn);
    CHECK(fabsf(xn) < 1e-3f && fabsf(yn) < 1e-3f);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (memchr(data, '\0', size) != NULL)
        return 0; /* sim_plan_load refuses these before parsing */
    char *text = malloc(size + 1);
    if (text == NULL)
        return 0;
    memcpy(text, data, size);
    text[size] = '\0';
    sim_plan_t plan;
    char err[256];
    const int rc = sim_plan_parse(text, NAME, 0.0, &plan, err, sizeof err);
    if (rc == 0) {
        CHECK(err[0] == '\0');
        check_plan(&plan);
    } else {
        CHECK(rc < 0);
        CHECK(rc == -ENOMEM || strncmp(err, NAME ":", sizeof NAME) == 0);
        CHECK(plan.walls == NULL && plan.n_walls == 0 && plan.openings == NULL && plan.rooms == NULL &&
              plan.railings == NULL && plan.n_railings == 0 && plan.solids == NULL && plan.n_solids == 0);
    }
    sim_plan_free(&plan);
    free(text);
    return 0;
}
