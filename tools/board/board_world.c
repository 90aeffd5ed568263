/* What a board program needs from its world: see board_world.h. */
#include "board_world.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "fw_image.h"
#include "hal_stdc_hil.h"
#include "hal_stdc_target.h"

int board_read_tour(const char *prog, const char *path, rt_waypoint_t wps[RT_CORE_MAX_WAYPOINTS])
{
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        fprintf(stderr, "%s: cannot open the tour %s: %s\n", prog, path, strerror(errno));
        return -1;
    }
    char line[256];
    int n = 0, lineno = 0;
    while (fgets(line, sizeof line, f) != NULL) {
        lineno++;
        float x, y;
        char rest;
        if (lineno == 1 && (line[0] < '0' || line[0] > '9') && line[0] != '-' && line[0] != '.')
            continue; /* the header */
        if (line[0] == '\n' || line[0] == '\0')
            continue;
        if (sscanf(line, "%f,%f %c", &x, &y, &rest) != 2 || !isfinite(x) || !isfinite(y)) {
            fprintf(stderr, "%s: %s line %d: not x_m,y_m\n", prog, path, lineno);
            fclose(f);
            return -1;
        }
        if (n == (int)RT_CORE_MAX_WAYPOINTS) {
            fprintf(stderr, "%s: %s: more than %u waypoints\n", prog, path, (unsigned)RT_CORE_MAX_WAYPOINTS);
            fclose(f);
            return -1;
        }
        wps[n++] = (rt_waypoint_t){x, y};
    }
    fclose(f);
    if (n < 2) {
        fprintf(stderr, "%s: %s: a tour needs 2 waypoints at least, it has %d\n", prog, path, n);
        return -1;
    }
    return n;
}

int board_connect_world(const char *prog, const char *where, uint32_t robot, uint32_t timeout_ms, uint32_t tries,
                        hal_hil_client_t *client, hal_hil_port_t *port)
{
    if (hal_stdc_hil_open(where, port) != 0)
        return 2;
    /* Another session each start: the world then takes a restarted board's HELLO. */
    const uint32_t session = ((uint32_t)time(NULL) * 2654435761u) ^ (uint32_t)hal_stdc_target_now_ns() ^ robot;
    int r = hal_hil_client_init(client, port, robot, FW_RT_PERIOD_US, session, BOARD_NAME, timeout_ms * 1000u, tries);
    if (r == 0)
        r = hal_hil_client_connect(client);
    if (r != 0) {
        fprintf(stderr, "%s: no world answered on %s %s (%s)\n", prog, hal_stdc_hil_kind(), where,
                r == -ETIMEDOUT ? "timed out: is `host_sim hil` running there?" : "link error");
        return -1;
    }
    return 0;
}

int board_start_world(const char *prog, const char *tour, const char *where, uint32_t robot, uint32_t timeout_ms,
                      uint32_t tries, rt_waypoint_t wps[RT_CORE_MAX_WAYPOINTS], int *n_wps,
                      hal_hil_client_t *client, hal_hil_port_t *port)
{
    *n_wps = board_read_tour(prog, tour, wps);
    if (*n_wps < 0)
        return 2;
    const int c = board_connect_world(prog, where, robot, timeout_ms, tries, client, port);
    return c == 0 ? 0 : c == 2 ? 2 : 1;
}
