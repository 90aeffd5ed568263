/* Procedural floor plans in the same CubiCasa5K-like SVG structure as the hand-made plans
 * (read back by sim_plan_parse at the default scale of 0.01 m per pixel).
 *
 * Layout, up to SIM_PLANGEN_BAND_ROOMS rooms: one band, a rectangular building with a
 * straight corridor (Space Hall, 1.2-1.6 m wide) across its whole width; the rooms sit in a
 * row above and a row below it, each room 2.4-4.5 m wide and 2.8-4.5 m deep, with a door
 * (0.8-1.0 m) to the corridor and, sometimes, a door to its neighbour in the same row; every
 * room has a window in the outer wall; the corridor has the entrance door at one end.
 *
 * More rooms: ceil(rooms / SIM_PLANGEN_BAND_ROOMS) such bands stacked top to bottom as the
 * wings of a comb-shaped office (the rooms shared out as evenly as they go, the first wings
 * taking one more), each wing's corridor opening at its left end into a spine (a Space Hall
 * 1.4-1.8 m wide along the building's left side, from its top wall to its bottom wall), so
 * every room is reachable from the entrance through its wing's corridor and the spine.
 * Between two wings an open courtyard (3-5 m, outside the building) keeps a window in the
 * outer wall of every room; the entrance door is at the right end of one wing's corridor.
 * Wings have their own lengths (their rooms' widths), so the building is not rectangular.
 *
 * Exterior walls 20 cm, interior walls 12 cm. Deterministic: the same (seed, rooms) gives the
 * same bytes; the one-band layout is byte for byte what it was before wings existed.
 * Thread-safe (no globals). */
#ifndef SIM_PLANGEN_H
#define SIM_PLANGEN_H

#include <stddef.h>

#define SIM_PLANGEN_MIN_ROOMS 2
#define SIM_PLANGEN_MAX_ROOMS 64
/* Rooms of one band (a corridor with a row above and a row below): more make wings. */
#define SIM_PLANGEN_BAND_ROOMS 16

/* Writes the SVG text into a malloc'ed string *out (caller frees). rooms counts the rooms
 * besides the corridors and the spine, SIM_PLANGEN_MIN_ROOMS..SIM_PLANGEN_MAX_ROOMS. */
FS_MUST_CHECK
int sim_plangen_svg(unsigned long seed, int rooms, char **out);

/* Same, written to `path`; on failure writes a reason into err. */
FS_MUST_CHECK
int sim_plangen_write(const char *path, unsigned long seed, int rooms, char *err, size_t errlen);

#endif /* SIM_PLANGEN_H */
