/* Exploration goals and their claims: see gp_goal.h for the contract. */
#include "gp/gp_goal.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#define UNREACHED 0xFFFFu
/* Seq is an int32 on the wire, non-negative: 2^31 claims are 6.8 years at 10 Hz. */
#define SEQ_MAX 0x7FFFFFFFu

static int finite_nonneg(double v)
{
    return isfinite(v) && v >= 0.0;
}

int gp_goal_init(gp_goal_t *g, const gp_goal_cfg_t *cfg)
{
    if (g == NULL || cfg == NULL)
        return -EINVAL;
    if (cfg->n_peers < 1u || cfg->n_peers > GP_GOAL_MAX_FLEET || cfg->self >= cfg->n_peers || cfg->w < 1u ||
        cfg->w > GP_GOAL_MAX_W || cfg->h < 1u || cfg->h > GP_GOAL_MAX_H || !isfinite(cfg->res_m) ||
        cfg->res_m <= 0.0 || !isfinite(cfg->origin_x_m) || !isfinite(cfg->origin_y_m) || cfg->occ_max == 0u ||
        !finite_nonneg(cfg->sensor_radius_m) || !finite_nonneg(cfg->lambda) || !finite_nonneg(cfg->keep_m) || !isfinite(cfg->min_info_m2) ||
        cfg->min_info_m2 <= 0.0 || !finite_nonneg(cfg->claim_radius_m) || !finite_nonneg(cfg->claim_discount) ||
        !finite_nonneg(cfg->claim_tie_m) || !finite_nonneg(cfg->claim_speed_mps) || !finite_nonneg(cfg->claim_window_m) ||
        cfg->claim_discount > 1.0 || cfg->claim_period_us == 0u || cfg->claim_lifetime_us <= cfg->claim_period_us ||
        cfg->claim_lifetime_us > cfg->claim_max_lifetime_us || cfg->claim_max_lifetime_us > GP_GOAL_MAX_LIFETIME_US ||
        (cfg->info_by_path != 0 && cfg->info_by_path != 1))
        return -EINVAL;
    /* The map's corners must stay finite too (a huge origin or cell would overflow them). */
    if (!isfinite(cfg->origin_x_m + cfg->res_m * cfg->w) || !isfinite(cfg->origin_y_m + cfg->res_m * cfg->h))
        return -EINVAL;
    memset(g, 0, sizeof *g);
    g->cfg = *cfg;
    return 0;
}

/* The cell holding (x, y), or -EINVAL outside the map. The half-open bounds [origin, origin +
 * w res) make every point belong to exactly one cell. */
static int cell_of(const gp_goal_cfg_t *cfg, double x_m, double y_m, uint32_t *cell)
{
    if (!isfinite(x_m) || !isfinite(y_m))
        return -EINVAL;
    const double fx = (x_m - cfg->origin_x_m) / cfg->res_m, fy = (y_m - cfg->origin_y_m) / cfg->res_m;
    if (!(fx >= 0.0 && fx < (double)cfg->w && fy >= 0.0 && fy < (double)cfg->h))
        return -EINVAL;
    uint32_t cx = (uint32_t)fx, cy = (uint32_t)fy;
    /* Rounding of the division may land exactly on w or h for a point just inside. */
    if (cx >= cfg->w)
        cx = cfg->w - 1u;
    if (cy >= cfg->h)
        cy = cfg->h - 1u;
    *cell = cy * cfg->w + cx;
    return 0;
}

static double centre(double origin, double res, uint32_t i)
{
    return origin + ((double)i + 0.5) * res;
}

/* Breadth-first search from our cell over traversable cells, neighbours in a fixed order
 * (-x, +x, -y, +y), so the steps are a pure function of the grid: 4-connected steps of one
 * cell are the cost, which a coarse grid makes good enough for ranking goals and cheap
 * (one pass, no heap). */
/* Breadth-first steps from start, up to max_steps; returns how many cells it reached (g->queue
 * holds them in the order of their steps). */
static uint32_t search(gp_goal_t *g, const gp_goal_grid_t *grid, uint32_t start, uint32_t max_steps)
{
    const uint32_t w = g->cfg.w, n = w * g->cfg.h;
    for (uint32_t i = 0; i < n; i++)
        g->steps[i] = UNREACHED;
    g->steps[start] = 0;
    g->queue[0] = (uint16_t)start;
    uint32_t head = 0, tail = 1;
    while (head < tail) {
        const uint32_t c = g->queue[head++], cx = c % w, cy = c / w;
        if (g->steps[c] >= max_steps)
            break; /* the queue is in the order of the steps: the rest are as far */
        const uint32_t nb[4] = {cx > 0u ? c - 1u : UINT32_MAX, cx + 1u < w ? c + 1u : UINT32_MAX,
                                cy > 0u ? c - w : UINT32_MAX, cy + 1u < g->cfg.h ? c + w : UINT32_MAX};
        for (int k = 0; k < 4; k++) {
            const uint32_t m = nb[k];
            if (m == UINT32_MAX || g->steps[m] != UNREACHED || grid->occ[m] >= g->cfg.occ_max)
                continue;
            g->steps[m] = (uint16_t)(g->steps[c] + 1u);
            g->queue[tail++] = (uint16_t)m;
        }
    }
    return tail;
}

/* sat[(y + 1) (w + 1) + x + 1] = the sum of unknown over cells [0, x] x [0, y], `taken` cells
 * counted as 0 when skip_taken: any window's sum in four reads, so the info of every cell costs
 * O(cells), whatever the sensor radius. */
static void summed_area(const gp_goal_t *g, const gp_goal_grid_t *grid, int skip_taken, uint32_t *sat)
{
    const uint32_t w = g->cfg.w, h = g->cfg.h, s = w + 1u;
    memset(sat, 0, sizeof sat[0] * s * (h + 1u));
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            const uint32_t u = skip_taken && g->taken[y * w + x] ? 0u : grid->unknown[y * w + x];
            sat[(y + 1u) * s + x + 1u] = u + sat[y * s + x + 1u] + sat[(y + 1u) * s + x] - sat[y * s + x];
        }
}

/* The square of half side r cells around (cx, cy), cut to the grid: columns [x0, x1), rows [y0, y1). */
typedef struct window {
    uint32_t x0, y0, x1, y1;
} window_t;

static window_t window_at(const gp_goal_cfg_t *cfg, uint32_t cx, uint32_t cy, uint32_t r)
{
    return (window_t){cx > r ? cx - r : 0u, cy > r ? cy - r : 0u, cx + r < cfg->w ? cx + r + 1u : cfg->w,
                      cy + r < cfg->h ? cy + r + 1u : cfg->h};
}

static uint32_t window_sum(const gp_goal_t *g, const uint32_t *sat, uint32_t cx, uint32_t cy, uint32_t r)
{
    const uint32_t s = g->cfg.w + 1u;
    const window_t b = window_at(&g->cfg, cx, cy, r);
    return sat[b.y1 * s + b.x1] - sat[b.y0 * s + b.x1] - sat[b.y1 * s + b.x0] + sat[b.y0 * s + b.x0];
}

/* A 2-D Fenwick tree over the grid in the same (w + 1) x (h + 1) layout as a summed-area
 * table: cells are added one by one (info_by_path: in the order of their path steps) and a
 * window's sum is read with the same four prefix sums. */
static void bit_add(const gp_goal_t *g, uint32_t *bit, uint32_t cell, uint32_t v)
{
    const uint32_t w = g->cfg.w, h = g->cfg.h, s = w + 1u;
    if (v == 0u)
        return;
    for (uint32_t i = cell / w + 1u; i <= h; i += i & (0u - i))
        for (uint32_t j = cell % w + 1u; j <= w; j += j & (0u - j))
            bit[i * s + j] += v;
}

static uint32_t bit_prefix(const gp_goal_t *g, const uint32_t *bit, uint32_t x1, uint32_t y1)
{
    const uint32_t s = g->cfg.w + 1u;
    uint32_t sum = 0;
    for (uint32_t i = y1; i > 0u; i -= i & (0u - i))
        for (uint32_t j = x1; j > 0u; j -= j & (0u - j))
            sum += bit[i * s + j];
    return sum;
}

static uint32_t bit_window_sum(const gp_goal_t *g, const uint32_t *bit, uint32_t cx, uint32_t cy, uint32_t r)
{
    const window_t b = window_at(&g->cfg, cx, cy, r);
    return bit_prefix(g, bit, b.x1, b.y1) - bit_prefix(g, bit, b.x0, b.y1) - bit_prefix(g, bit, b.x1, b.y0) +
           bit_prefix(g, bit, b.x0, b.y0);
}

/* A window's sum of the table gp_goal_select filled: a Fenwick tree with info_by_path, else a
 * summed-area table. */
static uint32_t info_sum(const gp_goal_t *g, const uint32_t *table, uint32_t cx, uint32_t cy, uint32_t r)
{
    return g->cfg.info_by_path ? bit_window_sum(g, table, cx, cy, r) : window_sum(g, table, cx, cy, r);
}

/* A window's half side in cells: round(m / res), capped where it covers the grid anyway (which
 * also keeps the sums' indices small). */
static uint32_t half_side(const gp_goal_cfg_t *cfg, double m)
{
    const double rr = floor(m / cfg->res_m + 0.5);
    return rr > (double)GP_GOAL_MAX_W + GP_GOAL_MAX_H ? GP_GOAL_MAX_W + GP_GOAL_MAX_H : (uint32_t)rr;
}

/* Drops the claims whose expiry passed (expiry <= now: a claim lives until its expiry). */
static void expire(gp_goal_t *g, uint64_t now_us)
{
    for (uint32_t i = 0; i < GP_GOAL_MAX_CLAIMS; i++)
        if (g->claims[i].used && g->claims[i].c.expiry_us <= now_us) {
            g->claims[i].used = 0;
            g->stats.claims_expired++;
        }
}

/* The claimant keeps its goal against us, whose cost to it is ours_m (the header's rule): its
 * cost aged to now, compared with ours, so both robots reach the same verdict from costs of the
 * same moment, and the lower id settles a tie the same way on both sides. */
static int claim_holds(const gp_goal_cfg_t *cfg, const gp_goal_claim_t *c, double ours_m, uint64_t now_us)
{
    const uint64_t sent_us = c->expiry_us > cfg->claim_lifetime_us ? c->expiry_us - cfg->claim_lifetime_us : 0u;
    const double age_s = now_us > sent_us ? (double)(now_us - sent_us) * 1e-6 : 0.0;
    const double theirs = fmax(0.0, c->cost_m - cfg->claim_speed_mps * age_s), tie = cfg->claim_tie_m;
    return !(theirs > ours_m + tie || (fabs(theirs - ours_m) <= tie && c->sender > cfg->self));
}

/* The cells within the claim window of a kept claim's cell gc are taken (what its claimant will
 * see). */
static void take_window(gp_goal_t *g, uint32_t gc)
{
    const gp_goal_cfg_t *cfg = &g->cfg;
    const window_t b = window_at(cfg, gc % cfg->w, gc / cfg->w, half_side(cfg, cfg->claim_window_m));
    for (uint32_t y = b.y0; y < b.y1; y++)
        memset(&g->taken[y * cfg->w + b.x0], 1, b.x1 - b.x0);
}

/* The discount of every cell from the claims their claimants keep against us, and the cells
 * their windows take. */
static void apply_claims(gp_goal_t *g, uint64_t now_us)
{
    const gp_goal_cfg_t *cfg = &g->cfg;
    const uint32_t n = cfg->w * cfg->h;
    for (uint32_t i = 0; i < n; i++)
        g->discount[i] = 1.0;
    memset(g->taken, 0, n);
    const double r = cfg->claim_radius_m, r2 = r * r;
    for (uint32_t k = 0; k < GP_GOAL_MAX_CLAIMS; k++) {
        const gp_goal_held_t *hc = &g->claims[k];
        uint32_t gc;
        if (!hc->used || cell_of(cfg, hc->c.x_m, hc->c.y_m, &gc) != 0)
            continue;
        if (g->steps[gc] != UNREACHED) {
            if (!claim_holds(cfg, &hc->c, g->steps[gc] * cfg->res_m, now_us))
                continue; /* we are nearer, or as near and the lower id */
        }
        if (cfg->claim_window_m > 0.0)
            take_window(g, gc);
        /* Cells whose centre lies within the claim radius of the claimed point. */
        const double fx0 = floor((hc->c.x_m - r - cfg->origin_x_m) / cfg->res_m);
        const double fy0 = floor((hc->c.y_m - r - cfg->origin_y_m) / cfg->res_m);
        const uint32_t x0 = fx0 > 0.0 ? (uint32_t)fx0 : 0u, y0 = fy0 > 0.0 ? (uint32_t)fy0 : 0u;
        for (uint32_t y = y0; y < cfg->h; y++) {
            const double dy = centre(cfg->origin_y_m, cfg->res_m, y) - hc->c.y_m;
            if (dy > r)
                break;
            for (uint32_t x = x0; x < cfg->w; x++) {
                const double dx = centre(cfg->origin_x_m, cfg->res_m, x) - hc->c.x_m;
                if (dx > r)
                    break;
                if (dx * dx + dy * dy <= r2)
                    g->discount[y * cfg->w + x] *= cfg->claim_discount;
            }
        }
    }
}

/* Our claim of our current goal, with the next seq and a fresh expiry. */
static void send_claim(gp_goal_t *g, uint64_t now_us)
{
    if (g->sent_any && g->seq < SEQ_MAX)
        g->seq++;
    g->sent_any = 1;
    g->sent_us = now_us;
    gp_goal_claim_t c;
    if (g->cfg.send == NULL || gp_goal_our_claim(g, g->seq, now_us, &c) != 0)
        return;
    if (g->cfg.send(g->cfg.send_ctx, &c) == 0)
        g->stats.claims_sent++;
    else
        g->stats.send_failures++;
}

int gp_goal_our_claim(const gp_goal_t *g, uint32_t seq, uint64_t now_us, gp_goal_claim_t *out)
{
    if (g == NULL || out == NULL)
        return -EINVAL;
    if (!g->has_goal)
        return -ENOENT;
    const double age_s = now_us > g->picked_us ? (double)(now_us - g->picked_us) * 1e-6 : 0.0;
    *out = (gp_goal_claim_t){g->cfg.self, seq, g->goal.x_m, g->goal.y_m,
                             fmax(0.0, g->goal.cost_m - g->cfg.claim_speed_mps * age_s),
                             now_us + g->cfg.claim_lifetime_us};
    return 0;
}

int gp_goal_contested(const gp_goal_t *g, uint64_t now_us)
{
    gp_goal_claim_t ours;
    if (g == NULL || gp_goal_our_claim(g, 0, now_us, &ours) != 0)
        return 0;
    const double r2 = g->cfg.claim_radius_m * g->cfg.claim_radius_m;
    for (uint32_t k = 0; k < GP_GOAL_MAX_CLAIMS; k++) {
        const gp_goal_held_t *hc = &g->claims[k];
        const double dx = hc->c.x_m - ours.x_m, dy = hc->c.y_m - ours.y_m;
        if (hc->used && hc->c.expiry_us > now_us && dx * dx + dy * dy <= r2 &&
            claim_holds(&g->cfg, &hc->c, ours.cost_m, now_us))
            return 1;
    }
    return 0;
}

int gp_goal_select(gp_goal_t *g, const gp_goal_grid_t *grid, double x_m, double y_m, uint64_t now_us,
                                 gp_goal_pick_t *out)
{
    uint32_t start;
    if (g == NULL || grid == NULL || out == NULL || cell_of(&g->cfg, x_m, y_m, &start) != 0)
        return -EINVAL;
    const gp_goal_cfg_t *cfg = &g->cfg;
    expire(g, now_us);
    const uint32_t reached = search(g, grid, start, UNREACHED);
    apply_claims(g, now_us); /* the claims' verdicts need the costs, the sums the taken cells */
    const uint32_t r = half_side(cfg, cfg->sensor_radius_m);
    const uint32_t *sat_left = g->sat;
    if (cfg->info_by_path) { /* filled as the candidates come, in the order of their steps */
        const size_t bytes = sizeof g->sat[0] * (cfg->w + 1u) * (cfg->h + 1u);
        memset(g->sat, 0, bytes);
        memset(g->sat_left, 0, bytes);
        sat_left = g->sat_left;
    } else {
        summed_area(g, grid, 0, g->sat);
        /* what the claims leave: without a window, all of it (the same table) */
        if (cfg->claim_window_m > 0.0) {
            summed_area(g, grid, 1, g->sat_left);
            sat_left = g->sat_left;
        }
    }
    const double cell_m2 = cfg->res_m * cfg->res_m;
    int found = 0, claimed = 0;
    gp_goal_pick_t best = {0};
    uint32_t added = 0;
    /* The reachable cells, in the search's order (the tie rule below keeps the lowest index). */
    for (uint32_t k = 0; k < reached; k++) {
        const uint32_t c = g->queue[k];
        if (cfg->info_by_path) /* the unknown a look from c takes in: reached within r steps past c */
            for (; added < reached && g->steps[g->queue[added]] <= (uint32_t)g->steps[c] + r; added++) {
                const uint32_t m = g->queue[added];
                bit_add(g, g->sat, m, grid->unknown[m]);
                bit_add(g, g->sat_left, m, g->taken[m] ? 0u : grid->unknown[m]);
            }
        if (grid->occ[c] >= cfg->occ_max)
            continue; /* the robot's own cell, which the search starts from whatever it holds */
        const uint32_t cx = c % cfg->w, cy = c / cfg->w;
        const double info = info_sum(g, g->sat, cx, cy, r) / 255.0 * cell_m2;
        if (info < cfg->min_info_m2)
            continue;
        const double left = info_sum(g, sat_left, cx, cy, r) / 255.0 * cell_m2;
        if (g->discount[c] <= 0.0 || left < cfg->min_info_m2) { /* worth a look, but a nearer peer's */
            claimed = 1;
            continue;
        }
        const double cost = g->steps[c] * cfg->res_m, info_d = left * g->discount[c];
        /* the goal held, not contested: its path is counted keep_m shorter */
        const double kept = g->has_goal && c == g->goal.cell && g->discount[c] >= 1.0 ? cfg->keep_m : 0.0;
        const double u = info_d - cfg->lambda * (cost - kept);
        /* The lowest index wins a tie (the cells come by steps, not index). */
        if (!found || u > best.utility || (u == best.utility && c < best.cell)) {
            found = 1;
            best = (gp_goal_pick_t){c,      centre(cfg->origin_x_m, cfg->res_m, cx),
                                    centre(cfg->origin_y_m, cfg->res_m, cy),
                                    info_d, cost, u};
        }
    }
    if (!found) {
        g->has_goal = 0;
        return claimed ? -EBUSY : -ENOENT;
    }
    const int changed = !g->has_goal || g->goal.cell != best.cell;
    g->goal = best;
    g->picked_us = now_us;
    g->has_goal = 1;
    if (changed) {
        g->stats.goal_changes++;
        send_claim(g, now_us);
    } else if (now_us - g->sent_us >= cfg->claim_period_us) {
        send_claim(g, now_us);
    }
    *out = best;
    return 0;
}

int gp_goal_look(gp_goal_t *g, const gp_goal_grid_t *grid, uint32_t cell, uint8_t *mark)
{
    if (g == NULL || grid == NULL || mark == NULL || cell >= g->cfg.w * g->cfg.h)
        return -EINVAL;
    const gp_goal_cfg_t *cfg = &g->cfg;
    const uint32_t r = half_side(cfg, cfg->sensor_radius_m);
    const window_t b = window_at(cfg, cell % cfg->w, cell / cfg->w, r);
    if (!cfg->info_by_path) {
        for (uint32_t y = b.y0; y < b.y1; y++)
            memset(&mark[y * cfg->w + b.x0], 1, b.x1 - b.x0);
        return 0;
    }
    /* A corner of the window is 2 r steps away along the grid's axes. */
    const uint32_t reached = search(g, grid, cell, 2u * r);
    for (uint32_t k = 0; k < reached; k++) {
        const uint32_t m = g->queue[k], x = m % cfg->w, y = m / cfg->w;
        if (x >= b.x0 && x < b.x1 && y >= b.y0 && y < b.y1)
            mark[m] = 1u;
    }
    return 0;
}

void gp_goal_poll(gp_goal_t *g, uint64_t now_us)
{
    if (g == NULL)
        return;
    expire(g, now_us);
    if (g->has_goal && g->sent_any && now_us - g->sent_us >= g->cfg.claim_period_us)
        send_claim(g, now_us);
}

int gp_goal_on_claim(gp_goal_t *g, const gp_goal_claim_t *c, uint64_t now_us)
{
    if (g == NULL || c == NULL)
        return -EINVAL;
    const gp_goal_cfg_t *cfg = &g->cfg;
    uint32_t cell;
    /* The longest path a claimant can have on the grid: every cell once. */
    const double max_cost = (double)cfg->w * cfg->h * cfg->res_m;
    if (c->sender >= cfg->n_peers || c->sender == cfg->self || c->seq > SEQ_MAX ||
        cell_of(cfg, c->x_m, c->y_m, &cell) != 0 || !finite_nonneg(c->cost_m) || c->cost_m > max_cost ||
        (c->expiry_us > now_us && c->expiry_us - now_us > cfg->claim_max_lifetime_us)) {
        g->stats.claims_invalid++;
        return -EBADMSG;
    }
    if (c->expiry_us <= now_us) {
        g->stats.claims_late++;
        return -ESTALE;
    }
    /* Expired claims go first: an older seq of the same robot then gets in only with an
     * expiry still ahead, which its newer claim (sent later, expiring later) would beat. */
    expire(g, now_us);
    uint32_t slot = GP_GOAL_MAX_CLAIMS, soonest = GP_GOAL_MAX_CLAIMS;
    for (uint32_t i = 0; i < GP_GOAL_MAX_CLAIMS; i++) {
        const gp_goal_held_t *hc = &g->claims[i];
        if (hc->used && hc->c.sender == c->sender) {
            if (c->seq < hc->c.seq) {
                g->stats.claims_reordered++;
                return -ESTALE;
            }
            if (c->seq == hc->c.seq) {
                g->stats.claims_duplicate++;
                return -EALREADY;
            }
            slot = i;
            break;
        }
        if (!hc->used && slot == GP_GOAL_MAX_CLAIMS)
            slot = i; /* the first free one, unless the sender is held further on */
        if (hc->used && (soonest == GP_GOAL_MAX_CLAIMS || hc->c.expiry_us < g->claims[soonest].c.expiry_us))
            soonest = i;
    }
    if (slot == GP_GOAL_MAX_CLAIMS) {
        if (soonest == GP_GOAL_MAX_CLAIMS || g->claims[soonest].c.expiry_us >= c->expiry_us) {
            g->stats.claims_full++;
            return -ENOSPC;
        }
        slot = soonest;
    }
    g->claims[slot].c = *c;
    g->claims[slot].used = 1;
    g->stats.claims_taken++;
    return 0;
}

int gp_goal_claim_of(const gp_goal_t *g, uint32_t id, uint64_t now_us, gp_goal_claim_t *out)
{
    if (g == NULL || out == NULL)
        return -EINVAL;
    for (uint32_t i = 0; i < GP_GOAL_MAX_CLAIMS; i++)
        if (g->claims[i].used && g->claims[i].c.sender == id && g->claims[i].c.expiry_us > now_us) {
            *out = g->claims[i].c;
            return 0;
        }
    return -ENOENT;
}

void gp_goal_inbox_put(gp_goal_inbox_t *in, const gp_goal_claim_t *c)
{
    const uint32_t i = c->seq & 1u;
    if (!(in->held >> i & 1u) || c->seq >= in->slot[i].seq) {
        in->slot[i] = *c;
        in->held |= (uint8_t)(1u << i);
    }
}

int gp_goal_inbox_take(gp_goal_inbox_t *in, uint32_t round, gp_goal_claim_t *out)
{
    int found = 0;
    for (uint32_t i = 0; i < 2u; i++) {
        if (!(in->held >> i & 1u) || in->slot[i].seq > round)
            continue;
        if (!found || in->slot[i].seq > out->seq)
            *out = in->slot[i];
        found = 1;
        in->held &= (uint8_t)~(1u << i);
    }
    return found;
}
