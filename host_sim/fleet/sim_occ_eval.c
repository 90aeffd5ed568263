/* Occupancy of a model against the ground truth: see sim_occ_eval.h. */
#include "sim_occ_eval.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_grid.h"

void sim_occ_eval_free(sim_occ_eval_t *ev)
{
    if (!ev)
        return;
    free(ev->xy);
    free(ev->truth);
    free(ev->cell);
    free(ev->pred);
    memset(ev, 0, sizeof *ev);
}

int sim_occ_eval_build(const sim_plan_t *plan, double res, sim_occ_eval_t *ev)
{
    if (!plan || !ev || !isfinite(res) || res <= 0.0)
        return -EINVAL;
    memset(ev, 0, sizeof *ev);
    const int sub = 2;
    sim_grid_t fine;
    int rc = sim_grid_from_plan(plan, res / sub, &fine);
    if (rc)
        return rc;
    const int w = (fine.w + sub - 1) / sub, h = (fine.h + sub - 1) / sub;
    const size_t cells = (size_t)w * (size_t)h;
    ev->xy = malloc(cells * 2 * sizeof(float));
    ev->truth = malloc(cells);
    ev->cell = malloc(cells * sizeof(int));
    ev->pred = malloc(cells * sizeof(float));
    if (!ev->xy || !ev->truth || !ev->cell || !ev->pred) {
        sim_grid_free(&fine);
        sim_occ_eval_free(ev);
        return -ENOMEM;
    }
    ev->res = res;
    ev->w = w;
    ev->h = h;
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            int wall = 0, free_ = 0;
            for (int a = 0; a < sub; a++)
                for (int b = 0; b < sub; b++) {
                    const int v = sim_grid_at(&fine, c * sub + a, r * sub + b);
                    wall |= v == SIM_CELL_WALL;
                    free_ |= v == SIM_CELL_FREE;
                }
            if (!wall && !free_)
                continue;
            const double xm = fine.origin.x + (c + 0.5) * res, ym = fine.origin.y + (r + 0.5) * res;
            float xn, yn;
            sim_plan_normalise(plan, xm, ym, &xn, &yn);
            xn = fminf(fmaxf(xn, -1.0f), 1.0f);
            yn = fminf(fmaxf(yn, -1.0f), 1.0f);
            ev->xy[2 * ev->n] = xn;
            ev->xy[2 * ev->n + 1] = yn;
            ev->truth[ev->n] = (uint8_t)wall;
            ev->cell[ev->n] = r * w + c;
            ev->n++;
        }
    sim_grid_free(&fine);
    return ev->n > 0 ? 0 : -ENOENT;
}

static int mean_map(bnn_model_t *m, const float *xy, size_t n, float *p)
{
    const size_t chunk = m->cfg.max_batch;
    for (size_t o = 0; o < n; o += chunk) {
        const size_t c = n - o < chunk ? n - o : chunk;
        int rc = bnn_forward_logits(m, xy + 2 * o, c, 1, 0, p + o);
        if (rc)
            return rc;
        for (size_t i = 0; i < c; i++)
            p[o + i] = 1.0f / (1.0f + expf(-p[o + i]));
    }
    return 0;
}

int sim_occ_eval_run(const sim_occ_eval_t *ev, bnn_model_t *m, double *mse, double *iou)
{
    if (!ev || !m || !mse || !iou || ev->n == 0)
        return -EINVAL;
    int rc = mean_map(m, ev->xy, ev->n, ev->pred);
    if (rc)
        return rc;
    double se = 0.0;
    size_t inter = 0, uni = 0;
    for (size_t i = 0; i < ev->n; i++) {
        const double d = (double)ev->pred[i] - ev->truth[i];
        se += d * d;
        const int p = ev->pred[i] >= 0.5f, t = ev->truth[i];
        inter += (size_t)(p && t);
        uni += (size_t)(p || t);
    }
    *mse = se / (double)ev->n;
    *iou = uni ? (double)inter / (double)uni : 1.0;
    return 0;
}
