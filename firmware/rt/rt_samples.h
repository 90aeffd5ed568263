/* Lidar scan -> labelled training samples (RT core, pure C11, no allocation).
 *
 * Follows the DiNNO reference mapping setup (docs/architecture.md section 2): from a scan, n_beams
 * beams are taken evenly spaced (beam j uses scan index floor(j * n_scan / n_beams)); along
 * each beam, K = points_per_beam points are placed evenly from the robot to the end point,
 * at distances d * (k + 1) / K for k = 0 .. K-1, so the last point is the end point itself
 * and no point sits on the robot. For a beam that hit something at range d, the last point
 * (the hit) is labelled 1 (occupied) and the K-1 others 0 (free). For a beam with no return
 * within range_max, d = range_max and all K points are labelled 0 (free).
 * Dropped-out beams (NaN) are skipped: the sensor said nothing about them.
 *
 * Range encoding of the scan (host_sim's lidar produces exactly this):
 *   finite r in [0, range_max): a hit at r metres;
 *   +INFINITY (or any r >= range_max): no return within range_max;
 *   NaN: dropout / invalid (e.g. closer than the sensor's minimum range).
 * Beam i of the scan points at angle theta + angle_min + i * angle_inc (radians, CCW).
 *
 * Coordinates are normalised to [-1, 1] over the plan's bounding box (ai_sample.h):
 *   x_n = 2 * (x - min_x) / (max_x - min_x) - 1, likewise y.
 * Points falling outside the bounding box (possible for free points of no-hit beams near
 * the outer walls' openings) are dropped and counted, so every emitted sample is in range.
 *
 * Pure function of its inputs: thread-safe, deterministic. */
#ifndef RT_SAMPLES_H
#define RT_SAMPLES_H

#include <stdint.h>

#include "ai/ai_sample.h"

#define RT_SAMPLES_DEFAULT_BEAMS 20
#define RT_SAMPLES_DEFAULT_POINTS 25
#define RT_SAMPLES_MAX_BEAMS 4096
#define RT_SAMPLES_MAX_POINTS 1024

typedef struct rt_samples_cfg {
    int32_t n_beams;         /* beams used, 1 .. min(n_scan, RT_SAMPLES_MAX_BEAMS) */
    int32_t points_per_beam; /* K, 1 .. RT_SAMPLES_MAX_POINTS */
    float min_x, min_y;      /* plan bounding box, metres (max > min) */
    float max_x, max_y;
} rt_samples_cfg_t;

typedef struct rt_scan_view {
    const float *ranges; /* n_scan ranges, encoding above */
    int32_t n_scan;
    float angle_min;     /* rad, beam 0 relative to the robot heading */
    float angle_inc;     /* rad between consecutive beams */
    float range_max;     /* m, > 0 */
} rt_scan_view_t;

typedef struct rt_samples_stats {
    int32_t beams_used;    /* beams that produced points */
    int32_t beams_hit;     /* of which ended on a hit */
    int32_t beams_dropped; /* NaN beams skipped */
    int32_t points_outside; /* points dropped for leaving the bounding box */
} rt_samples_stats_t;

/* Upper bound of samples one call writes: n_beams * points_per_beam. */
#define RT_SAMPLES_MAX_OUT(n_beams, points) ((int32_t)(n_beams) * (int32_t)(points))

/* Converts one scan taken at pose (x, y, theta) into at most cap samples written to out.
 * *n_out receives the count; stats may be NULL. Returns 0, -EINVAL on bad arguments
 * (NULL, non-finite pose, n_beams > n_scan, empty box, ...) or -ENOSPC when cap is below
 * RT_SAMPLES_MAX_OUT(n_beams, points_per_beam) (nothing is written then). */
FS_MUST_CHECK
int rt_samples_from_scan(const rt_samples_cfg_t *cfg, const rt_scan_view_t *scan, float x,
                         float y, float theta, ai_sample_t *out, int32_t cap, int32_t *n_out,
                         rt_samples_stats_t *stats);

#endif /* RT_SAMPLES_H */
