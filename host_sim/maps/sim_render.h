/* Offscreen 3D picture of a host_sim scene, rendered with OSMesa (no display needed) and
 * legacy OpenGL 1.x immediate mode, saved as PNG.
 *
 * Scene: the floor (room outlines tinted), walls = plan solids extruded to wall_height (a
 * railing to its own height, when lower) with one directional light, robots as chassis
 * boxes with wheels and a heading mark, paths as coloured polylines just above the floor,
 * and at most one lidar sweep drawn as rays from the sensor to their hits (red) or to max
 * range (faint) for beams without a hit.
 * Camera: perspective (fov_deg), looking at the plan centre from azimuth_deg (0 = from +x,
 * -90 = from the south, i.e. from -y) and elevation_deg above the floor, at the distance that
 * fits the plan's bounding box in the view. The world is not mirrored: from the default
 * azimuth -90 the plan's +y points up the image and +x to the right, as in every other figure
 * (sim_figure.h), so the scene and the maps show the building the same way round. Robots and
 * paths are drawn in their sim_palette.h colours.
 * Not thread-safe (one OSMesa context per call, made current on the calling thread).
 *
 * libOSMesa is not linked: the first render loads it (dlopen "libOSMesa.so.8", else
 * "libOSMesa.so"; Debian's package libosmesa6), so a program that never renders never maps it
 * nor the libLLVM it pulls in. Without it a render fails with -ENOENT and says so. */
#ifndef SIM_RENDER_H
#define SIM_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_world.h"

#define SIM_RENDER_MAX_SIDE 4096

typedef struct sim_render_sweep {
    sim_pose_t pose;       /* sensor pose */
    const double *ranges;  /* n distances, +INFINITY (or >= range_max) = no hit */
    int n;                 /* beams over a full turn, beam i at pose.theta + i * 2 pi / n */
    double range_max;
    double height;         /* sensor height, m */
} sim_render_sweep_t;

typedef struct sim_render_scene {
    const sim_plan_t *plan;
    const sim_path_t *paths;
    int n_paths;
    const sim_pose_t *robots;
    int n_robots;
    const sim_render_sweep_t *sweep; /* NULL: none */
    double wall_height;              /* m, default 2.5 when <= 0 */
} sim_render_scene_t;

typedef struct sim_render_cfg {
    int width, height;      /* pixels, 16 .. SIM_RENDER_MAX_SIDE */
    double fov_deg;         /* vertical field of view, (5, 120) */
    double azimuth_deg;
    double elevation_deg;   /* (5, 90] */
} sim_render_cfg_t;

sim_render_cfg_t sim_render_default_cfg(void); /* 1024 x 768, fov 40, azimuth -90, elevation 72 */

/* Loads libOSMesa and its GL entry points, once per process: the first of `names` (a NULL-ended
 * list; NULL for the defaults above) that dlopen finds. Returns 0 (also when already loaded,
 * whatever `names`), or -ENOENT with "render: cannot load <names[0]> (install libosmesa6):
 * <dlerror>" in err (or which function it lacks); a failure is not remembered. The renders
 * call it themselves; a caller may call it first to fail early, a test to see the message. */
FS_MUST_CHECK
int sim_render_load(const char *const *names, char *err, size_t errlen);

/* Renders into rgb (width * height * 3 bytes, row-major, top row first).
 * Returns 0, -EINVAL, -ENOENT (no libOSMesa: sim_render_load) or -EIO (OSMesa failure) with a
 * message in err. */
FS_MUST_CHECK
int sim_render_rgb(const sim_render_scene_t *scene, const sim_render_cfg_t *cfg, uint8_t *rgb,
                   char *err, size_t errlen);

/* Renders and writes a PNG. */
FS_MUST_CHECK
int sim_render_png(const sim_render_scene_t *scene, const sim_render_cfg_t *cfg, const char *path,
                   char *err, size_t errlen);

#endif /* SIM_RENDER_H */
