/* What a board program needs from the world it runs in (`host_sim hil` at the other end of the
 * hardware-in-the-loop link): its tour, and the link connected. The C library and the stdc back
 * end alone, so board_hil and board_robot read and connect the same way on every board. */
#ifndef BOARD_WORLD_H
#define BOARD_WORLD_H

#include <stdint.h>

#include "hal/hal_hil_client.h"
#include "rt/rt_core.h"

/* Reads the tour `path` ("x_m,y_m" lines after an optional header, as `host_sim paths gen`
 * writes) into wps: 2 .. RT_CORE_MAX_WAYPOINTS finite points. The count, or -1 with the reason
 * on stderr, prefixed by `prog`. */
int board_read_tour(const char *prog, const char *path, rt_waypoint_t wps[RT_CORE_MAX_WAYPOINTS]);

/* Opens the link `where` (hal_stdc_hil.h) and says HELLO as robot `robot` with a new session
 * (the world takes a restarted board's HELLO), answers awaited timeout_ms, `tries` times.
 * 0, or -1 with the reason on stderr (2: a bad `where`). */
int board_connect_world(const char *prog, const char *where, uint32_t robot, uint32_t timeout_ms, uint32_t tries,
                        hal_hil_client_t *client, hal_hil_port_t *port);

/* How a board program starts: its tour read (into wps, *n_wps points) and its world connected
 * (board_connect_world). 0, or the status the program exits with, the reason said on stderr: 2
 * for a bad tour or link name, 1 when no world answered. */
int board_start_world(const char *prog, const char *tour, const char *where, uint32_t robot, uint32_t timeout_ms,
                      uint32_t tries, rt_waypoint_t wps[RT_CORE_MAX_WAYPOINTS], int *n_wps,
                      hal_hil_client_t *client, hal_hil_port_t *port);

#endif /* BOARD_WORLD_H */
