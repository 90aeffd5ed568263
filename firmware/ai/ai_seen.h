/* What the lidar has covered, cell by cell on the belief grid (ai_belief.h): how many of the
 * samples (ray points, ai_sample.h) fell in each cell, and how many of them were hits. It is the
 * local half of the epistemic uncertainty exploration steers by.
 *
 * Why counts beside the posterior: the posterior (bnn_post.h) is over the SIREN layer's
 * features, and those are global. So every sample shrinks the variance everywhere, seen or
 * not. In a 64 m office, the prior variance left in rooms nobody had entered fell below
 * 6/255 of the log scale after some 30 minutes, and the robots stopped at 70 % coverage with
 * "nothing left to learn". A cell's count does not leak into the other cells.
 *
 * The share of prior variance left that the counts give (ai_seen_share):
 *   a cell rays reached (n > 0): the share of its spots no sample fell on, for n samples
 *     spread at random over the m = (res / AI_SEEN_SPOT_M)^2 spots of the cell, exp(-n / m)
 *     (a 0.8 m cell of the office holds 64 spots of 0.1 m: two rays through it leave most of
 *     it unseen; 1 / (1 + S n), a local mean at the posterior's S, called it known after one
 *     point, and the robots left rooms they had glimpsed through a door);
 *   a cell no ray reached that joins an open cell (points there, under one in ten a hit)
 *     through cells no ray reached (4-neighbours): 1, the unseen part of the building beyond
 *     a frontier, all of it, so that a large unseen wing weighs what it hides;
 *   any other cell no ray reached: 0, the counts say nothing. It lies behind cells with hits
 *     (outside the building, a closed room), where no look reaches. Counting those as unknown
 *     sent the robots along the outer walls, whose windows (gp_goal.h) looked half unknown for
 *     ever; counting the frontier cells alone let an unseen wing weigh one row of cells, and
 *     in a 64 m office the robots left a whole floor unseen.
 * (A wall nobody has seen yet is cells no ray reached: until it is seen, the part beyond it
 * counts too.) ai_seen_flood works the reach out after the counts changed.
 * ai_belief_update takes the larger of this share and the posterior's at each cell.
 *
 * In a fleet the counts are reached as the posterior is (ai_core.h): at the first shared round
 * they become N times the robot's own, new samples count N each, and every shared round mixes
 * in the neighbours' grids with weights 1/N. Counts add like precisions, so the mean of the
 * robots' grids is the fleet's count at every instant, and on a complete graph one shared
 * round makes each robot's grid that count. The grids ride in the posterior round's state,
 * after the posterior (ai_seen_to_state), when the state has room for both.
 *
 * Memory: everything inside ai_seen_t (about 44 KiB), no allocation. One thread at a time.
 * Deterministic: the same calls give the same bits. */
#ifndef AI_AI_SEEN_H
#define AI_AI_SEEN_H

#include <stddef.h>
#include <stdint.h>

#include "ai/ai_belief.h"
#include "ai/ai_sample.h"

/* Floats of the state form of a w x h grid: w, h, the w h counts, the w h hit counts. */
#define AI_SEEN_STATE_FLOATS(cells) (2u + 2u * (size_t)(cells))
/* The spot a sample observes, m: a cell holds m = (res / spot)^2 of them (at least 1). */
#define AI_SEEN_SPOT_M 0.1
/* An open cell: points there, fewer than one in AI_SEEN_OPEN_HITS of them hits. */
#define AI_SEEN_OPEN_HITS 10.0

typedef struct ai_seen {
    ai_belief_cfg_t cfg;              /* the belief grid's geometry */
    float n[AI_BELIEF_MAX_CELLS];     /* first w * h used: samples per cell (fleet's estimate) */
    float hits[AI_BELIEF_MAX_CELLS];  /* of which labelled occupied (a beam's end on something) */
    uint8_t beyond[AI_BELIEF_MAX_CELLS]; /* 1: no ray reached it, joined to an open cell (above) */
    uint16_t queue[AI_BELIEF_MAX_CELLS]; /* scratch of ai_seen_flood */
    int dirty;                        /* the counts changed since the last ai_seen_flood */
    int unreached_only;               /* 0 (ai_seen_init's): the share above; 1: a cell rays
                                         reached says nothing (0), only the unreached cells
                                         beyond count (the uncertainty policy's fallback layer,
                                         ai_link.h) */
} ai_seen_t;

#define AI_SEEN_BYTES sizeof(ai_seen_t)
_Static_assert(sizeof(ai_seen_t) <= BOARD_RAM_AI_BYTES / 16u, "the count grid must stay a small part of the AI RAM");

/* Takes the belief grid's geometry; every count 0. 0 or -EINVAL (NULL, a geometry that
 * ai_belief_init refuses); s untouched on error. */
FS_MUST_CHECK int ai_seen_init(ai_seen_t *s, const ai_belief_cfg_t *cfg);

/* Counts n samples (positions normalised as ai_sample.h says; occ >= 0.5 a hit) with weight w
 * each (finite, >= 0). A sample outside the grid, or not finite, is not counted. 0 or -EINVAL. */
FS_MUST_CHECK int ai_seen_add(ai_seen_t *s, const ai_sample_t *smp, size_t n, double w);

/* Every count times a (finite, >= 0). 0 or -EINVAL. */
FS_MUST_CHECK int ai_seen_scale(ai_seen_t *s, double a);

/* Works out which cells no ray reached join an open cell (`beyond`), when the counts changed
 * since the last call: one breadth-first pass over the grid. 0 or -EINVAL. */
FS_MUST_CHECK int ai_seen_flood(ai_seen_t *s);

/* The share above for cell index i < w h (as of the last ai_seen_flood; with unreached_only, 0
 * where rays reached); 0 for a NULL s or a cell outside. */
double ai_seen_share(const ai_seen_t *s, uint32_t i);

/* Writes the state form (AI_SEEN_STATE_FLOATS(w h) floats) into out. 0, -EINVAL, -ENOSPC. */
FS_MUST_CHECK int ai_seen_to_state(const ai_seen_t *s, float *out, size_t cap);

/* Mixes the n <= DINNO_MAX_PEERS neighbour grids (states[k] + off, cap - off floats each, in
 * the state form) into s with weight w each (0 < n w <= 1): s = (1 - c w) s + w sum of the c
 * accepted ones. A grid of another size, or with a count not finite, negative or below its
 * hits, is left out.
 * *used (may be NULL): how many were mixed in. 0 or -EINVAL. */
FS_MUST_CHECK int ai_seen_mix(ai_seen_t *s, const float *const *states, size_t n, size_t off, size_t cap, double w,
                              uint32_t *used);

#endif /* AI_AI_SEEN_H */
