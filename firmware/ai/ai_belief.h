/* The AI core's coarse belief grid: what its current model says about the map (occupancy) and
 * how much of it is left to learn (epistemic uncertainty), cell by cell, in ONE pass over the
 * cell centres (bnn_post_predict: the mean weights' logits and the posterior's unknown share
 * together). It is what exploration consumes: the GP core's goal selection (gp/gp_goal.h) and,
 * coarse, the RT core's planner (rt/rt_grid.h).
 *
 * Layout (the same as gp_goal_grid_t, rt_grid_t and host_sim/maps/sim_grid.h): row-major, cell
 * (col, row) at index row * w + col; column c spans x in [origin_x + c res, origin_x + (c+1) res),
 * row r spans y in [origin_y + r res, ...) (rows grow with y). Units: metres. Per cell:
 *   occ    round(255 sigmoid(logit)), logit of the model's mean weights at the cell centre:
 *          0 free .. 255 occupied (gp_goal.h's and rt_grid.h's occ);
 *   unknown  round(255 log(1 + S u) / log(1 + S)), u = bnn_post.h's known(x) in (0, 1] at the
 *          centre, the share of the read-out's prior variance left, S = AI_BELIEF_INFO_SNR:
 *          the information a look could still give (0.5 log(1 + S u) nats for a prior variance
 *          S times the observation noise's) over its largest. 255 never seen .. 0 nothing left
 *          to learn. A log scale, because u falls everywhere as data come (the SIREN features
 *          are global) while its contrast between seen and unseen cells stays: a linear byte
 *          rounded the whole building to a few LSB within a minute of driving. With a count
 *          grid (ai_seen.h), u is the larger of the posterior's share and the count's: the
 *          features being global, the posterior alone comes to say it knows rooms no ray
 *          entered. (gp_goal.h's unknown, byte for byte; rt_grid.h's known is the other way
 *          round, see ai_belief_to_rt_grid.)
 *   post_unknown  the same byte of the posterior's share alone (without a count grid, unknown
 *          itself): what the uncertainty policy steers by first, unknown (with the count grid's
 *          unreached_only) being its fallback when this one has nothing left (gp/gp_explore.h).
 * The model sees positions normalised over the plan's bounding box (ai/ai_sample.h):
 * x_n = 2 (x - min_x) / (max_x - min_x) - 1, likewise y; cells outside the box are evaluated
 * all the same (the model extrapolates there, the posterior says it knows nothing).
 *
 * Layering: the AI core may include the other cores' plain-data headers (ai_core.h already
 * includes gp/ and rt/ link headers; tools/check-layering.sh only fences firmware/ off the host),
 * so the copies into gp_goal_grid_t and rt_grid_t live here; the round loop does not call them
 * yet.
 *
 * Cost of ai_belief_update, per cell: one forward pass with the mean weights (2S + S H +
 * (L - 1) H^2 + H multiply-adds, S sines) and the posterior's features and variance (2S + S
 * multiply-adds, S sines, and D (D + 1) / 2 with D = S + 1), in batches of AI_BELIEF_BATCH
 * points (bnn_post_predict splits them further into the model's max_batch). The `small` preset
 * (S 128, H 64, L 3): 16,704 + 8,769 = 25,473 multiply-adds and 256 sines per cell, about
 * 104 M multiply-adds for a 64 x 64 grid (docs/architecture.md). Plus, once after the
 * posterior changed, its factorisation (bnn_post_factor).
 *
 * Memory: everything inside ai_belief_t (AI_BELIEF_BYTES, about 16 KiB), no allocation.
 * Thread-safety: one thread at a time per belief, and the model and posterior it reads must
 * not be used by another thread during an update (their scratch is clobbered). Deterministic:
 * the same model, posterior and geometry give the same bytes. */
#ifndef AI_AI_BELIEF_H
#define AI_AI_BELIEF_H

#include <stddef.h>
#include <stdint.h>

#include "ai/bnn.h"
#include "ai/bnn_post.h"
#include "gp/gp_goal.h"
#include "rt/rt_grid.h"

#define AI_BELIEF_MAX_W 64u
#define AI_BELIEF_MAX_H 64u
#define AI_BELIEF_MAX_CELLS (AI_BELIEF_MAX_W * AI_BELIEF_MAX_H)
#define AI_BELIEF_BATCH 256u /* cell centres per bnn_post_predict call */
#define AI_BELIEF_INFO_SNR 1000.0 /* S of the unknown byte's scale (above) */

_Static_assert(AI_BELIEF_MAX_W <= GP_GOAL_MAX_W && AI_BELIEF_MAX_H <= GP_GOAL_MAX_H,
               "a belief grid must fit gp_goal_grid_t");
_Static_assert(AI_BELIEF_MAX_W <= RT_GRID_MAX_SIDE && AI_BELIEF_MAX_H <= RT_GRID_MAX_SIDE,
               "a belief grid's sides must fit rt_grid_t");
struct ai_seen; /* ai/ai_seen.h: the counts of what the lidar covered, on this grid */

_Static_assert(AI_BELIEF_BATCH >= 1u && AI_BELIEF_BATCH <= AI_BELIEF_MAX_CELLS, "batch of 1 .. all cells");

/* Geometry. All finite; res_m > 0; max_x > min_x, max_y > min_y; 1 <= w <= AI_BELIEF_MAX_W,
 * 1 <= h <= AI_BELIEF_MAX_H; every cell centre's normalised coordinate finite as a float. */
typedef struct ai_belief_cfg {
    uint32_t w, h;                 /* columns (x), rows (y) */
    float res_m;                   /* a cell's side, m */
    float origin_x_m, origin_y_m;  /* the outer corner of cell (0, 0), m */
    float min_x, min_y, max_x, max_y; /* the plan's bounding box the model's inputs are normalised over, m */
} ai_belief_cfg_t;

typedef struct ai_belief {
    ai_belief_cfg_t cfg;
    uint32_t updates;              /* successful ai_belief_update calls since init */
    uint32_t valid;                /* 1: occ and unknown are the last update's; 0 before it or after a failed one */
    double unknown_mean;           /* mean unknown share of the last update (exact floats, not the bytes) */
    double post_unknown_mean;      /* the same of the posterior's share alone */
    uint8_t occ[AI_BELIEF_MAX_CELLS];   /* first w * h used */
    uint8_t unknown[AI_BELIEF_MAX_CELLS];
    uint8_t post_unknown[AI_BELIEF_MAX_CELLS];
    float xy[2u * AI_BELIEF_BATCH];     /* scratch: a batch's normalised centres */
    float logit[AI_BELIEF_BATCH];
    float share[AI_BELIEF_BATCH];
} ai_belief_t;

#define AI_BELIEF_BYTES sizeof(ai_belief_t)
_Static_assert(sizeof(((ai_belief_t *)0)->occ) == AI_BELIEF_MAX_CELLS, "one occupancy byte per cell");
_Static_assert(sizeof(ai_belief_t) <= 20u * 1024u, "the belief grid stays a small fixed block");
_Static_assert(sizeof(ai_belief_t) <= BOARD_RAM_AI_BYTES / 16u, "the belief grid must stay a small part of the AI RAM");

/* 1 when cfg is a geometry ai_belief_init accepts (the bounds above), else 0 (NULL too). */
int ai_belief_cfg_ok(const ai_belief_cfg_t *cfg);

/* Checks cfg and sets the geometry; every cell occ 128 (no opinion), unknown 255 (never seen),
 * valid 0, updates 0. 0, or -EINVAL (NULL, a bound above broken); b untouched on error. */
FS_MUST_CHECK int ai_belief_init(ai_belief_t *b, const ai_belief_cfg_t *cfg);

/* Evaluates every cell centre through bnn_post_predict(post, m) in batches of AI_BELIEF_BATCH
 * and writes occ, unknown and post_unknown (above); unknown_mean and post_unknown_mean become
 * the means of their shares.
 * post: over m's configuration (post->dim = S + 1); it is factored when it changed (post is
 * written then), m's activation scratch is clobbered, neither's data is. 0, -EINVAL (NULL, a
 * belief not initialised, a posterior of another dimension), -EDOM (the posterior not positive
 * definite, or a non-finite logit: a corrupt model). On error valid = 0 and the cells are
 * partly written; updates counts successes only. seen (NULL: the posterior alone): each cell's
 * unknown share is the larger of the posterior's and ai_seen_share's (a cell no ray reached is
 * unknown whatever the global features say; seen's reach is brought up to date first,
 * ai_seen_flood); a count grid of another size is -EINVAL. */
FS_MUST_CHECK int ai_belief_update(ai_belief_t *b, bnn_model_t *m, bnn_post_t *post, struct ai_seen *seen);

/* The model's input at the centre of cell (col, row): xy[0], xy[1] normalised as above, the
 * point ai_belief_update evaluates. 0 or -EINVAL (NULL, cell outside). */
FS_MUST_CHECK int ai_belief_cell_xy(const ai_belief_t *b, uint32_t col, uint32_t row, float xy[2]);

/* How much is left to learn: the mean over the w x h cells of the unknown share of the last
 * update, in [0, 1] (1 before the first update, and after a failed one); a coverage proxy
 * (1 - it: the share of the map's prior uncertainty the data removed). -1 for a NULL b. */
double ai_belief_known_share(const ai_belief_t *b);

/* Copies occ and unknown into the GP core's grid (identical layout and meaning: w * h bytes of
 * each; the rest of g is left alone). gcfg: the goal selection's configuration, whose geometry
 * must be this grid's (w, h equal; res_m, origin equal as floats). 0 or -EINVAL (NULL, a
 * different geometry, no valid update). */
FS_MUST_CHECK int ai_belief_to_goal_grid(const ai_belief_t *b, const gp_goal_cfg_t *gcfg, gp_goal_grid_t *g);

/* Initialises g to this grid's geometry (rt_grid_init) and copies occ; rt's known counts what
 * was observed: 0 (never observed) where unknown > seen_max, else 255 - unknown, at least 1. E.g.
 * seen_max 230: a cell whose prior variance dropped to about half or less counts as seen. (The RT
 * core plans on a finer grid; this coarse one is for a consumer to resample.) 0, -EINVAL (NULL,
 * no valid update) or rt_grid_init's error. */
FS_MUST_CHECK int ai_belief_to_rt_grid(const ai_belief_t *b, uint8_t seen_max, rt_grid_t *g);

#endif /* AI_AI_BELIEF_H */
