/* Procedural plans of more rooms than one band holds: bands as the wings of a comb off a
 * spine corridor (layout in sim_plangen.h). Integer pixels, 1 px = 1 cm. */
#include "sim_plangen.h"
#include "sim_plangen_int.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>

#define EXT PG_EXT
#define INT PG_INT
#define JAMB PG_JAMB
#define MAX_WINGS ((SIM_PLANGEN_MAX_ROOMS + SIM_PLANGEN_BAND_ROOMS - 1) / SIM_PLANGEN_BAND_ROOMS)

/* An office's rooms: mostly offices, the rest what an office floor also has. */
static const char *const OFFICE_TYPES[] = {"Office", "Office", "Office", "Office", "Office",
                                           "Kitchen", "Bath", "Storage", "Dining", "Closet"};

typedef struct {
    int n_top, n_bot;
    pg_room_t top[SIM_PLANGEN_BAND_ROOMS], bot[SIM_PLANGEN_BAND_ROOMS];
    int x_in1;  /* inner right end of the rows and the corridor (the end wall's left edge) */
    int y0;     /* top edge of the wing's top exterior wall */
    int y_cw1;  /* the corridor's upper wall, top edge */
    int y_c0;   /* corridor inner top */
    int y_c1;   /* corridor inner bottom */
    int y_b0;   /* bottom rooms inner top */
    int y_b1;   /* bottom rooms inner bottom */
    int corr;   /* corridor width */
} wing_t;

/* Draws one wing's sizes (x_lo: the rows' inner left edge) and places it from y0 down. */
static void draw_wing(sim_rng_seq_t *rng, wing_t *w, int rooms, int x_lo, int y0)
{
    w->n_top = (rooms + 1) / 2;
    w->n_bot = rooms - w->n_top;
    int wt[SIM_PLANGEN_BAND_ROOMS], wb[SIM_PLANGEN_BAND_ROOMS];
    int sum_t = (w->n_top - 1) * INT, sum_b = (w->n_bot - 1) * INT;
    for (int i = 0; i < w->n_top; i++)
        sum_t += (wt[i] = pg_range(rng, 240, 450));
    for (int i = 0; i < w->n_bot; i++)
        sum_b += (wb[i] = pg_range(rng, 240, 450));
    int inner_w = sum_t > sum_b ? sum_t : sum_b;
    int d_top = pg_range(rng, 280, 450), d_bot = pg_range(rng, 280, 450);
    w->corr = pg_range(rng, 120, 160);
    pg_place_row(w->top, wt, w->n_top, x_lo, inner_w);
    pg_place_row(w->bot, wb, w->n_bot, x_lo, inner_w);
    for (int i = 0; i < w->n_top; i++)
        w->top[i].door = i < w->n_top - 1 && pg_range(rng, 0, 99) < 35;
    for (int i = 0; i < w->n_bot; i++)
        w->bot[i].door = i < w->n_bot - 1 && pg_range(rng, 0, 99) < 35;
    w->x_in1 = x_lo + inner_w;
    w->y0 = y0;
    w->y_cw1 = y0 + EXT + d_top;
    w->y_c0 = w->y_cw1 + INT;
    w->y_c1 = w->y_c0 + w->corr;
    w->y_b0 = w->y_c1 + INT;
    w->y_b1 = w->y_b0 + d_bot;
}

static int wing_bottom(const wing_t *w)
{
    return w->y_b1 + EXT;
}

int sim_plangen_wings(FILE *f, sim_rng_seq_t *rng, unsigned long seed, int rooms)
{
    const int nw = (rooms + SIM_PLANGEN_BAND_ROOMS - 1) / SIM_PLANGEN_BAND_ROOMS;
    if (nw < 2 || nw > MAX_WINGS)
        return -EINVAL;
    const int spine = pg_range(rng, 140, 180); /* inner width */
    const int x_sp = EXT + spine;              /* the spine's right edge: the wings start here */
    const int court = pg_range(rng, 300, 500); /* between two wings */
    const int entrance = pg_range(rng, 0, nw - 1);
    wing_t w[MAX_WINGS] = {{0}};
    int width = 0, y = 0;
    for (int b = 0; b < nw; b++) {
        /* The wing's rows start behind the wall it shares with the spine; its corridor does
         * not (it opens into the spine along its whole width). */
        draw_wing(rng, &w[b], rooms / nw + (b < rooms % nw), x_sp + INT, y);
        int right = w[b].x_in1 + EXT;
        width = right > width ? right : width;
        y = wing_bottom(&w[b]) + court;
    }
    const int height = wing_bottom(&w[nw - 1]);

    fprintf(f, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
               "<!-- fleetsim procedural floor plan: seed %lu, %d rooms in %d wings off a spine, %.2f x %.2f m at "
               "0.01 m/px -->\n"
               "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"%d\" height=\"%d\">\n"
               "<g id=\"Model\" class=\"Model\">\n",
            seed, rooms, nw, width / 100.0, height / 100.0, width, height);

    /* Spaces: the spine, then per wing its corridor and its rooms, top row first. */
    fprintf(f, "  <g id=\"Space\" class=\"Space Hall\">");
    pg_rect(f, EXT, EXT, x_sp, height - EXT);
    fprintf(f, "</g>\n");
    for (int b = 0; b < nw; b++) {
        const wing_t *wb = &w[b];
        fprintf(f, "  <g id=\"Space\" class=\"Space Hall\">");
        pg_rect(f, x_sp, wb->y_c0, wb->x_in1, wb->y_c1);
        fprintf(f, "</g>\n");
        for (int row = 0; row < 2; row++) {
            const pg_room_t *rr = row ? wb->bot : wb->top;
            int n = row ? wb->n_bot : wb->n_top, y0 = row ? wb->y_b0 : wb->y0 + EXT, y1 = row ? wb->y_b1 : wb->y_cw1;
            for (int i = 0; i < n; i++) {
                const char *type =
                    OFFICE_TYPES[pg_range(rng, 0, (int)(sizeof OFFICE_TYPES / sizeof *OFFICE_TYPES) - 1)];
                fprintf(f, "  <g id=\"Space\" class=\"Space %s\">", type);
                pg_rect(f, rr[i].x0, y0, rr[i].x1, y1);
                fprintf(f, "</g>\n");
            }
        }
    }

    /* The spine's outer wall, and its walls facing the courtyards. */
    fprintf(f, "  <g id=\"Wall\" class=\"Wall External\">");
    pg_rect(f, 0, EXT, EXT, height - EXT);
    fprintf(f, "\n  </g>\n");
    for (int b = 0; b + 1 < nw; b++) {
        fprintf(f, "  <g id=\"Wall\" class=\"Wall External\">");
        pg_rect(f, x_sp, wing_bottom(&w[b]), x_sp + EXT, w[b + 1].y0);
        fprintf(f, "\n  </g>\n");
    }

    for (int b = 0; b < nw; b++) {
        const wing_t *wb = &w[b];
        /* Exterior walls above and below the wing (over the spine too for the first and the
         * last wing: the building's top and bottom), a window per room. */
        for (int row = 0; row < 2; row++) {
            const pg_room_t *rr = row ? wb->bot : wb->top;
            const int x0 = (row == 0 && b == 0) || (row == 1 && b == nw - 1) ? 0 : x_sp;
            pg_outer_wall(f, rng, rr, row ? wb->n_bot : wb->n_top, x0, wb->x_in1 + EXT, row ? wb->y_b1 : wb->y0);
        }
        /* The end wall, with the entrance in one wing. */
        fprintf(f, "  <g id=\"Wall\" class=\"Wall External\">");
        pg_rect(f, wb->x_in1, wb->y0 + EXT, wb->x_in1 + EXT, wb->y_b1);
        fprintf(f, "\n");
        if (b == entrance) {
            int dw = pg_range(rng, 90, wb->corr - 20 < 100 ? wb->corr - 20 : 100);
            int dy = wb->y_c0 + (wb->corr - dw) / 2;
            pg_opening(f, "Door Swing Beside", wb->x_in1, dy, wb->x_in1 + EXT, dy + dw);
        }
        fprintf(f, "  </g>\n");
        /* The rows' wall against the spine, above and below the corridor's mouth. */
        fprintf(f, "  <g id=\"Wall\" class=\"Wall\">");
        pg_rect(f, x_sp, wb->y0 + EXT, x_sp + INT, wb->y_cw1);
        fprintf(f, "</g>\n  <g id=\"Wall\" class=\"Wall\">");
        pg_rect(f, x_sp, wb->y_b0, x_sp + INT, wb->y_b1);
        fprintf(f, "</g>\n");
        /* The corridor's two long walls, from the spine to the end wall, a door per room. */
        for (int row = 0; row < 2; row++) {
            const pg_room_t *rr = row ? wb->bot : wb->top;
            int n = row ? wb->n_bot : wb->n_top, y0 = row ? wb->y_c1 : wb->y_cw1;
            fprintf(f, "  <g id=\"Wall\" class=\"Wall\">");
            pg_rect(f, x_sp, y0, wb->x_in1, y0 + INT);
            fprintf(f, "\n");
            for (int i = 0; i < n; i++) {
                int dw = pg_range(rng, 80, 100);
                int dx = pg_range(rng, rr[i].x0 + JAMB, rr[i].x1 - JAMB - dw);
                pg_opening(f, "Door Swing Beside", dx, y0, dx + dw, y0 + INT);
            }
            fprintf(f, "  </g>\n");
        }
        /* Partitions between neighbours, some with a door. */
        pg_partitions(f, rng, wb->top, wb->n_top, wb->y0 + EXT, wb->y_cw1);
        pg_partitions(f, rng, wb->bot, wb->n_bot, wb->y_b0, wb->y_b1);
    }
    fprintf(f, "</g>\n</svg>\n");
    return 0;
}
