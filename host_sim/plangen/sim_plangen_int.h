/* Private to the files of the plan generator, not part of its API (sim_plangen.h):
 *   sim_plangen.c        the API and the one-band layout (up to SIM_PLANGEN_BAND_ROOMS rooms);
 *   sim_plangen_wings.c  several bands as wings off a spine (more rooms).
 * Both write the same kinds of elements with the helpers below, in integer pixels. */
#ifndef SIM_PLANGEN_INT_H
#define SIM_PLANGEN_INT_H

#include <stdint.h>
#include <stdio.h>

#include "sim_rng.h"

#define PG_EXT 20  /* exterior wall thickness, px */
#define PG_INT 12  /* interior wall thickness, px */
#define PG_JAMB 30 /* minimum wall left beside a door or window, px */

/* Uniform integer in [lo, hi] (hi >= lo). */
static inline int pg_range(sim_rng_seq_t *r, int lo, int hi)
{
    return lo + (int)(sim_rng_next(r) % (uint64_t)(hi - lo + 1));
}

static inline void pg_rect(FILE *f, int x0, int y0, int x1, int y1)
{
    fprintf(f, "<polygon points=\"%d,%d %d,%d %d,%d %d,%d\"/>", x0, y0, x1, y0, x1, y1, x0, y1);
}

/* A Door or Window group (cls "Door ..." or "Window ...") over the rectangle. */
static inline void pg_opening(FILE *f, const char *cls, int x0, int y0, int x1, int y1)
{
    fprintf(f, "    <g id=\"%s\" class=\"%s\">", cls[0] == 'D' ? "Door" : "Window", cls);
    pg_rect(f, x0, y0, x1, y1);
    fprintf(f, "</g>\n");
}

typedef struct {
    int x0, x1; /* inner extent along x, px */
    int door;   /* 1 when the partition on its right has a door */
} pg_room_t;

/* Lays out one row of n rooms over [x_lo, x_lo + inner_w] with interior walls between them;
 * widths were drawn already; the last room takes the slack. */
static inline void pg_place_row(pg_room_t *row, const int *widths, int n, int x_lo, int inner_w)
{
    int x = x_lo, used = 0;
    for (int i = 0; i < n; i++)
        used += widths[i];
    used += (n - 1) * PG_INT;
    for (int i = 0; i < n; i++) {
        int w = widths[i] + (i == n - 1 ? inner_w - used : 0);
        row[i].x0 = x;
        row[i].x1 = x + w;
        x += w + PG_INT;
    }
}

/* An outer wall over [x0, x1] at y0 (PG_EXT thick) with one window in front of each room of
 * the row (drawn from rng in row order). */
static inline void pg_outer_wall(FILE *f, sim_rng_seq_t *rng, const pg_room_t *row, int n, int x0, int x1, int y0)
{
    fprintf(f, "  <g id=\"Wall\" class=\"Wall External\">");
    pg_rect(f, x0, y0, x1, y0 + PG_EXT);
    fprintf(f, "\n");
    for (int i = 0; i < n; i++) {
        const int rw = row[i].x1 - row[i].x0;
        const int ww = pg_range(rng, 80, rw - 2 * PG_JAMB < 200 ? rw - 2 * PG_JAMB : 200);
        const int wx = pg_range(rng, row[i].x0 + PG_JAMB, row[i].x1 - PG_JAMB - ww);
        pg_opening(f, "Window Regular", wx, y0, wx + ww, y0 + PG_EXT);
    }
    fprintf(f, "  </g>\n");
}

/* The walls between neighbouring rooms of a row spanning y0..y1, each with a door when the
 * room on its left says so (drawn from rng in row order). */
static inline void pg_partitions(FILE *f, sim_rng_seq_t *rng, const pg_room_t *row, int n, int y0, int y1)
{
    for (int i = 0; i + 1 < n; i++) {
        const int x0 = row[i].x1;
        fprintf(f, "  <g id=\"Wall\" class=\"Wall\">");
        pg_rect(f, x0, y0, x0 + PG_INT, y1);
        fprintf(f, "\n");
        if (row[i].door) {
            const int dw = pg_range(rng, 80, 100);
            const int dy = pg_range(rng, y0 + PG_JAMB, y1 - PG_JAMB - dw);
            pg_opening(f, "Door Swing Beside", x0, dy, x0 + PG_INT, dy + dw);
        }
        fprintf(f, "  </g>\n");
    }
}

/* The layout of more than SIM_PLANGEN_BAND_ROOMS rooms (sim_plangen_wings.c): the SVG text
 * into the open stream f, drawn from rng. 0, or -EINVAL. */
int sim_plangen_wings(FILE *f, sim_rng_seq_t *rng, unsigned long seed, int rooms);

#endif /* SIM_PLANGEN_INT_H */
