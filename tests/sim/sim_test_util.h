/* Helpers for the host_sim tests: hand-built plans with known geometry. */
#ifndef TESTS_SIM_TEST_UTIL_H
#define TESTS_SIM_TEST_UTIL_H

#include <math.h>
#include <string.h>

#include "sim_plan.h"

static inline void tu_rect(sim_solid_t *s, double x0, double y0, double x1, double y1)
{
    memset(s, 0, sizeof *s);
    s->outline.n = 4;
    s->outline.p[0] = (sim_vec2_t){x0, y0};
    s->outline.p[1] = (sim_vec2_t){x1, y0};
    s->outline.p[2] = (sim_vec2_t){x1, y1};
    s->outline.p[3] = (sim_vec2_t){x0, y1};
    s->is_rect = 1;
}

/* A closed box room: free interior [0, W] x [0, H], walls 0.1 m thick outside it.
 * solids[4] and room[1] are caller storage (the plan points at them).
 * as_mesh: flag the walls as non-rectangular so the world builds trimeshes. */
static inline void tu_box_room(sim_plan_t *p, sim_solid_t solids[4], sim_room_t *room, double W,
                               double H, int as_mesh)
{
    const double t = 0.1;
    memset(p, 0, sizeof *p);
    tu_rect(&solids[0], -t, -t, W + t, 0);     /* south */
    tu_rect(&solids[1], -t, H, W + t, H + t);  /* north */
    tu_rect(&solids[2], -t, 0, 0, H);          /* west */
    tu_rect(&solids[3], W, 0, W + t, H);       /* east */
    for (int i = 0; i < 4 && as_mesh; i++)
        solids[i].is_rect = 0;
    p->scale = 1.0;
    p->solids = solids;
    p->n_solids = 4;
    p->min = (sim_vec2_t){-t, -t};
    p->max = (sim_vec2_t){W + t, H + t};
    if (room) {
        memset(room, 0, sizeof *room);
        room->outline.n = 4;
        room->outline.p[0] = (sim_vec2_t){0, 0};
        room->outline.p[1] = (sim_vec2_t){W, 0};
        room->outline.p[2] = (sim_vec2_t){W, H};
        room->outline.p[3] = (sim_vec2_t){0, H};
        strcpy(room->type, "LivingRoom");
        p->rooms = room;
        p->n_rooms = 1;
    }
}

/* Analytic distance from (x, y) inside [0, W] x [0, H] along angle a to the box boundary. */
static inline double tu_box_distance(double W, double H, double x, double y, double a)
{
    double c = cos(a), s = sin(a), best = INFINITY;
    if (c > 1e-12)
        best = fmin(best, (W - x) / c);
    if (c < -1e-12)
        best = fmin(best, -x / c);
    if (s > 1e-12)
        best = fmin(best, (H - y) / s);
    if (s < -1e-12)
        best = fmin(best, -y / s);
    return best;
}

#endif /* TESTS_SIM_TEST_UTIL_H */
