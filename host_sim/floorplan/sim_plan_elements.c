/* What the groups of a CubiCasa5K model.svg mean (sim_plan.h): a <g> whose class starts with
 * Wall, Door, Window, Space or Railing opens a record, and the first <polygon> inside it (nested at
 * any depth, outside any inner such group) is its outline. Everything else is ignored. The
 * tokenizer (sim_plan_svg.c) calls these as it walks the tree. */
#include "sim_plan_int.h"

#include <stdio.h>
#include <string.h>

/* The first two whitespace-separated tokens of a class attribute, each truncated to its
 * buffer (empty when absent). */
static void class_tokens(const sim_plan_attr_t *cls, char *first, size_t flen, char *second, size_t slen)
{
    first[0] = second[0] = '\0';
    if (!cls->present)
        return;
    size_t i = 0;
    char *dst[2] = {first, second};
    size_t cap[2] = {flen, slen};
    for (int t = 0; t < 2; t++) {
        while (i < cls->len && sim_plan_is_space(cls->v[i]))
            i++;
        size_t j = i;
        while (j < cls->len && !sim_plan_is_space(cls->v[j]))
            j++;
        size_t l = 0;
        /* A loop, not memcpy: GCC 12 warned (-Wstringop-overflow) on the memcpy, bound SIZE_MAX. */
        for (; l + 1 < cap[t] && i + l < j; l++)
            dst[t][l] = cls->v[i + l];
        dst[t][l] = '\0';
        i = j;
    }
}

static int innermost_semantic(const sim_plan_reader_t *r)
{
    for (int d = r->depth - 1; d >= 0; d--)
        if (r->stack[d].kind != FR_OTHER)
            return d;
    return -1;
}

static int innermost_wall(const sim_plan_reader_t *r)
{
    for (int d = r->depth - 1; d >= 0; d--)
        if (r->stack[d].kind == FR_WALL)
            return d;
    return -1;
}

/* A <g> opened: decide what it is from its class and allocate its record. */
int sim_plan_open_group(sim_plan_reader_t *r, sim_plan_frame_t *f, const sim_plan_attr_t *cls)
{
    char first[32], second[SIM_ROOM_TYPE_MAX];
    class_tokens(cls, first, sizeof first, second, sizeof second);
    sim_plan_t *p = r->plan;
    int rc;
    if (strcmp(first, "Wall") == 0) {
        if (p->n_walls >= PLAN_MAX_ITEMS)
            return sim_plan_fail(&r->e, f->at, &f->el, "too many walls (more than %d)", PLAN_MAX_ITEMS);
        if ((rc = sim_plan_grow((void **)&p->walls, &r->cap_walls, p->n_walls + 1, sizeof *p->walls)) != 0)
            return rc;
        memset(&p->walls[p->n_walls], 0, sizeof p->walls[0]);
        sim_plan_copy_id(p->walls[p->n_walls].id, &f->el);
        f->kind = FR_WALL;
        f->index = p->n_walls++;
    } else if (strcmp(first, "Door") == 0 || strcmp(first, "Window") == 0) {
        /* Anywhere in the tree, as CubiCasa5K's loader reads them: nested in the wall it
         * opens, or a sibling drawn across or over walls (sim_plan_cuts.c finds which). */
        int w = innermost_wall(r);
        if (p->n_openings >= PLAN_MAX_ITEMS)
            return sim_plan_fail(&r->e, f->at, &f->el, "too many openings (more than %d)", PLAN_MAX_ITEMS);
        if ((rc = sim_plan_grow((void **)&p->openings, &r->cap_open, p->n_openings + 1, sizeof *p->openings)) != 0)
            return rc;
        sim_opening_t *o = &p->openings[p->n_openings];
        memset(o, 0, sizeof *o);
        o->kind = first[0] == 'D' ? SIM_OPENING_DOOR : SIM_OPENING_WINDOW;
        o->wall = w >= 0 ? r->stack[w].index : -1;
        sim_plan_copy_id(o->id, &f->el);
        f->kind = first[0] == 'D' ? FR_DOOR : FR_WINDOW;
        f->index = p->n_openings++;
    } else if (strcmp(first, "Railing") == 0) {
        /* A wall of its own kind (lower, never cut): a record like a wall's, in its own list so
         * that nothing that means walls (a door's own wall, "no walls") takes it for one. */
        if (p->n_railings >= PLAN_MAX_ITEMS)
            return sim_plan_fail(&r->e, f->at, &f->el, "too many railings (more than %d)", PLAN_MAX_ITEMS);
        if ((rc = sim_plan_grow((void **)&p->railings, &r->cap_railings, p->n_railings + 1, sizeof *p->railings)) != 0)
            return rc;
        memset(&p->railings[p->n_railings], 0, sizeof p->railings[0]);
        sim_plan_copy_id(p->railings[p->n_railings].id, &f->el);
        f->kind = FR_RAILING;
        f->index = p->n_railings++;
    } else if (strcmp(first, "Space") == 0) {
        if (p->n_rooms >= PLAN_MAX_ITEMS)
            return sim_plan_fail(&r->e, f->at, &f->el, "too many rooms (more than %d)", PLAN_MAX_ITEMS);
        if ((rc = sim_plan_grow((void **)&p->rooms, &r->cap_rooms, p->n_rooms + 1, sizeof *p->rooms)) != 0)
            return rc;
        sim_room_t *rm = &p->rooms[p->n_rooms];
        memset(rm, 0, sizeof *rm);
        snprintf(rm->type, sizeof rm->type, "%s", second[0] ? second : "Undefined");
        sim_plan_copy_id(rm->id, &f->el);
        f->kind = FR_SPACE;
        f->index = p->n_rooms++;
    }
    return 0;
}

/* A <polygon> seen: it is the outline of the innermost semantic group, if that has none yet.
 * The record's place becomes the polygon's (where its points are), its id the polygon's when
 * the group has none. */
int sim_plan_take_polygon(sim_plan_reader_t *r, const sim_plan_elem_t *el, sim_plan_loc_t at,
                          const sim_plan_attr_t *points, const double *m)
{
    int d = innermost_semantic(r);
    if (d < 0 || r->stack[d].has_poly)
        return 0;
    sim_plan_frame_t *f = &r->stack[d];
    if (!points->present)
        return sim_plan_fail(&r->e, at, el, "polygon without a points attribute");
    sim_poly_t *dst;
    int *line, *col;
    char *id;
    switch (f->kind) {
    case FR_WALL:
    case FR_RAILING: {
        sim_wall_t *w = f->kind == FR_WALL ? &r->plan->walls[f->index] : &r->plan->railings[f->index];
        dst = &w->outline;
        line = &w->line;
        col = &w->col;
        id = w->id;
        break;
    }
    case FR_SPACE: {
        sim_room_t *rm = &r->plan->rooms[f->index];
        dst = &rm->outline;
        line = &rm->line;
        col = &rm->col;
        id = rm->id;
        break;
    }
    default: {
        sim_opening_t *o = &r->plan->openings[f->index];
        dst = &o->outline;
        line = &o->line;
        col = &o->col;
        id = o->id;
        break;
    }
    }
    int rc = sim_plan_parse_points(&r->e, points, el, r->scale, m, dst);
    if (rc != 0)
        return rc;
    *line = at.line;
    *col = at.col;
    if (id[0] == '\0')
        sim_plan_copy_id(id, el);
    f->has_poly = 1;
    return 0;
}

static const char *kind_name(sim_plan_frame_kind_t k)
{
    switch (k) {
    case FR_WALL: return "Wall";
    case FR_DOOR: return "Door";
    case FR_WINDOW: return "Window";
    case FR_SPACE: return "Space";
    case FR_RAILING: return "Railing";
    default: return "group";
    }
}

int sim_plan_close_group(sim_plan_reader_t *r, const sim_plan_frame_t *f)
{
    if (f->kind != FR_OTHER && !f->has_poly)
        return sim_plan_fail(&r->e, f->at, &f->el, "%s group has no polygon", kind_name(f->kind));
    return 0;
}
