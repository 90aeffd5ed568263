/* Procedural floor plans (layout in sim_plangen.h). All geometry is in integer pixels
 * (1 px = 1 cm at the default scale), so the output is exact and reproducible text. */
#include "sim_plangen.h"
#include "sim_plangen_int.h"
#include "hal_host_file.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define EXT PG_EXT
#define INT PG_INT
#define JAMB PG_JAMB

static const char *const ROOM_TYPES[] = {"Bedroom", "Kitchen", "LivingRoom", "Bath", "Bedroom",
                                         "Storage", "Dining", "Office", "Bedroom", "Closet"};

/* The one-band layout (rooms <= SIM_PLANGEN_BAND_ROOMS): one corridor, a row of rooms above
 * and one below. Its draws and text are what they were before the wings existed, so the
 * plans made since stay byte for byte the same. */
static int one_band(FILE *f, sim_rng_seq_t *rng, unsigned long seed, int rooms)
{
    int n_top = (rooms + 1) / 2, n_bot = rooms - n_top;
    int wt[SIM_PLANGEN_BAND_ROOMS], wb[SIM_PLANGEN_BAND_ROOMS];
    int sum_t = (n_top - 1) * INT, sum_b = (n_bot - 1) * INT;
    for (int i = 0; i < n_top; i++)
        sum_t += (wt[i] = pg_range(rng, 240, 450));
    for (int i = 0; i < n_bot; i++)
        sum_b += (wb[i] = pg_range(rng, 240, 450));
    int inner_w = sum_t > sum_b ? sum_t : sum_b;
    int d_top = pg_range(rng, 280, 450), d_bot = pg_range(rng, 280, 450);
    int corr = pg_range(rng, 120, 160);
    int width = inner_w + 2 * EXT;
    int y_cw1 = EXT + d_top;        /* corridor's upper wall, top edge */
    int y_c0 = y_cw1 + INT;         /* corridor inner top */
    int y_c1 = y_c0 + corr;         /* corridor inner bottom = lower wall top edge */
    int y_b0 = y_c1 + INT;          /* bottom rooms inner top */
    int y_b1 = y_b0 + d_bot;        /* bottom rooms inner bottom */
    int height = y_b1 + EXT;

    pg_room_t top[SIM_PLANGEN_BAND_ROOMS], bot[SIM_PLANGEN_BAND_ROOMS];
    pg_place_row(top, wt, n_top, EXT, inner_w);
    pg_place_row(bot, wb, n_bot, EXT, inner_w);
    for (int i = 0; i < n_top; i++)
        top[i].door = i < n_top - 1 && pg_range(rng, 0, 99) < 35;
    for (int i = 0; i < n_bot; i++)
        bot[i].door = i < n_bot - 1 && pg_range(rng, 0, 99) < 35;

    fprintf(f, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
               "<!-- fleetsim procedural floor plan: seed %lu, %d rooms + corridor, %.2f x %.2f m at 0.01 m/px -->\n"
               "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"%d\" height=\"%d\">\n"
               "<g id=\"Model\" class=\"Model\">\n",
            seed, rooms, width / 100.0, height / 100.0, width, height);

    /* Spaces. */
    fprintf(f, "  <g id=\"Space\" class=\"Space Hall\">");
    pg_rect(f, EXT, y_c0, width - EXT, y_c1);
    fprintf(f, "</g>\n");
    for (int row = 0; row < 2; row++) {
        const pg_room_t *rr = row ? bot : top;
        int n = row ? n_bot : n_top, y0 = row ? y_b0 : EXT, y1 = row ? y_b1 : y_cw1;
        for (int i = 0; i < n; i++) {
            const char *type = ROOM_TYPES[pg_range(rng, 0, (int)(sizeof ROOM_TYPES / sizeof *ROOM_TYPES) - 1)];
            fprintf(f, "  <g id=\"Space\" class=\"Space %s\">", type);
            pg_rect(f, rr[i].x0, y0, rr[i].x1, y1);
            fprintf(f, "</g>\n");
        }
    }

    /* Exterior walls with a window per room on the outer side, entrance at a corridor end. */
    for (int row = 0; row < 2; row++) {
        const pg_room_t *rr = row ? bot : top;
        pg_outer_wall(f, rng, rr, row ? n_bot : n_top, 0, width, row ? height - EXT : 0);
    }
    int entrance_right = pg_range(rng, 0, 1);
    for (int side = 0; side < 2; side++) {
        int x0 = side ? width - EXT : 0;
        fprintf(f, "  <g id=\"Wall\" class=\"Wall External\">");
        pg_rect(f, x0, EXT, x0 + EXT, height - EXT);
        fprintf(f, "\n");
        if (side == entrance_right) {
            int dw = pg_range(rng, 90, corr - 20 < 100 ? corr - 20 : 100);
            int dy = y_c0 + (corr - dw) / 2;
            pg_opening(f, "Door Swing Beside", x0, dy, x0 + EXT, dy + dw);
        }
        fprintf(f, "  </g>\n");
    }

    /* The corridor's two long walls, with one door per room. */
    for (int row = 0; row < 2; row++) {
        const pg_room_t *rr = row ? bot : top;
        int n = row ? n_bot : n_top, y0 = row ? y_c1 : y_cw1;
        fprintf(f, "  <g id=\"Wall\" class=\"Wall\">");
        pg_rect(f, EXT, y0, width - EXT, y0 + INT);
        fprintf(f, "\n");
        for (int i = 0; i < n; i++) {
            int dw = pg_range(rng, 80, 100);
            int dx = pg_range(rng, rr[i].x0 + JAMB, rr[i].x1 - JAMB - dw);
            pg_opening(f, "Door Swing Beside", dx, y0, dx + dw, y0 + INT);
        }
        fprintf(f, "  </g>\n");
    }

    /* Partitions between neighbours, some with a door. */
    pg_partitions(f, rng, top, n_top, EXT, y_cw1);
    pg_partitions(f, rng, bot, n_bot, y_b0, y_b1);
    fprintf(f, "</g>\n</svg>\n");
    return 0;
}

int sim_plangen_svg(unsigned long seed, int rooms, char **out)
{
    if (out == NULL)
        return -EINVAL;
    *out = NULL;
    if (rooms < SIM_PLANGEN_MIN_ROOMS || rooms > SIM_PLANGEN_MAX_ROOMS)
        return -EINVAL;
    sim_rng_seq_t rng = {(uint64_t)seed * 0xD1B54A32D192ED03ull + 0x2545F4914F6CDD1Dull};
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    if (f == NULL)
        return -ENOMEM;
    int rc = rooms <= SIM_PLANGEN_BAND_ROOMS ? one_band(f, &rng, seed, rooms) : sim_plangen_wings(f, &rng, seed, rooms);
    if (fclose(f) != 0 || buf == NULL || rc != 0) {
        free(buf);
        return rc != 0 ? rc : -ENOMEM;
    }
    *out = buf;
    return 0;
}

int sim_plangen_write(const char *path, unsigned long seed, int rooms, char *err, size_t errlen)
{
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (path == NULL)
        return -EINVAL;
    char *text = NULL;
    int rc = sim_plangen_svg(seed, rooms, &text);
    if (rc != 0) {
        if (err != NULL && errlen > 0)
            snprintf(err, errlen, "cannot generate a plan with %d rooms: %s", rooms, strerror(-rc));
        return rc;
    }
    rc = hal_host_file_write_all(path, text, strlen(text));
    if (rc < 0 && err != NULL && errlen > 0)
        snprintf(err, errlen, "%s: %s", path, hal_host_file_strerror(rc));
    free(text);
    return rc;
}
