/* Scan -> samples: see rt_samples.h for the labelling rule. */
#include "rt/rt_samples.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>

int rt_samples_from_scan(const rt_samples_cfg_t *cfg, const rt_scan_view_t *scan, float x,
                         float y, float theta, ai_sample_t *out, int32_t cap, int32_t *n_out,
                         rt_samples_stats_t *stats)
{
    if (cfg == NULL || scan == NULL || out == NULL || n_out == NULL || scan->ranges == NULL)
        return -EINVAL;
    if (scan->n_scan < 1 || cfg->n_beams < 1 || cfg->n_beams > scan->n_scan ||
        cfg->n_beams > RT_SAMPLES_MAX_BEAMS || cfg->points_per_beam < 1 ||
        cfg->points_per_beam > RT_SAMPLES_MAX_POINTS)
        return -EINVAL;
    if (!isfinite(x) || !isfinite(y) || !isfinite(theta) || !isfinite(scan->angle_min) ||
        !isfinite(scan->angle_inc) || !isfinite(scan->range_max) || !(scan->range_max > 0.0f))
        return -EINVAL;
    if (!isfinite(cfg->min_x) || !isfinite(cfg->min_y) || !isfinite(cfg->max_x) ||
        !isfinite(cfg->max_y) || !(cfg->max_x > cfg->min_x) || !(cfg->max_y > cfg->min_y))
        return -EINVAL;
    if (cap < RT_SAMPLES_MAX_OUT(cfg->n_beams, cfg->points_per_beam))
        return -ENOSPC;

    rt_samples_stats_t st = {0, 0, 0, 0};
    const int32_t K = cfg->points_per_beam;
    const float sx = 2.0f / (cfg->max_x - cfg->min_x), sy = 2.0f / (cfg->max_y - cfg->min_y);
    int32_t n = 0;
    for (int32_t j = 0; j < cfg->n_beams; j++) {
        /* 64-bit product: n_scan * n_beams may exceed 2^31 for absurd inputs. */
        int32_t i = (int32_t)(((int64_t)j * scan->n_scan) / cfg->n_beams);
        float r = scan->ranges[i];
        if (isnan(r)) {
            st.beams_dropped++;
            continue;
        }
        int hit = r < scan->range_max;
        float d = hit ? fmaxf(r, 0.0f) : scan->range_max;
        float a = theta + scan->angle_min + (float)i * scan->angle_inc;
        float c = cosf(a), s = sinf(a);
        st.beams_used++;
        st.beams_hit += hit;
        for (int32_t k = 0; k < K; k++) {
            float t = d * (float)(k + 1) / (float)K;
            float px = x + t * c, py = y + t * s;
            float xn = (px - cfg->min_x) * sx - 1.0f, yn = (py - cfg->min_y) * sy - 1.0f;
            if (!(xn >= -1.0f && xn <= 1.0f && yn >= -1.0f && yn <= 1.0f)) {
                st.points_outside++;
                continue;
            }
            out[n].x = xn;
            out[n].y = yn;
            out[n].occ = (hit && k == K - 1) ? 1.0f : 0.0f;
            n++;
        }
    }
    *n_out = n;
    if (stats != NULL)
        *stats = st;
    return 0;
}
