/* Exploration goals chosen by each robot itself, coordinated by claims (Burgard et al. 2005,
 * "Coordinated multi-robot exploration"), as a module with no I/O of its own: the GP core hands
 * it the AI core's coarse belief grid, its pose, the claims its peers sent and the simulated
 * time; it returns the next goal and emits our own claim through a callback (a codec,
 * gp_wire_encode_claim, and a transport sit outside it, as for gp_pse).
 *
 * The grid (gp_goal_cfg_t's geometry, row-major, cell (0, 0) at the origin's corner): per cell
 *   occ    0 free .. 255 occupied; a cell is traversable and a candidate goal when occ < occ_max;
 *   unknown  the share of the model's prior (epistemic) variance left, ai/bnn_post.h's known(x)
 *          in (0, 1] quantised to 0 .. 255 (255: never seen, 0: nothing left to learn).
 *
 * gp_goal_select(grid, x, y, now), in this order:
 *   cost    a breadth-first search over traversable cells (4-neighbours) from the robot's cell:
 *           cost_m(c) = res_m x steps (the robot's own cell counts as traversable);
 *   claims  for every live claim (peer p, goal g, its cost when sent c): p's cost now is taken
 *           as cp = max(0, c - claim_speed_mps x the claim's age), its age now - (expiry -
 *           claim_lifetime_us) (the fleet shares one lifetime); p keeps g against us when
 *           cp < our cost_m(g) - claim_tie_m, or the two within claim_tie_m and p < self, or g
 *           is unreachable for us (robots driving side by side to one goal, each comparing
 *           its fresh cost with the other's older one, would both keep it); then every
 *           candidate within claim_radius_m of g has its info (below) multiplied by claim_discount
 *           (once per such claim; 0 removes those candidates); with claim_window_m > 0, the
 *           unknown of the cells within claim_window_m (a square, as the info window) of such a
 *           g is also taken out of every candidate's info: what the claimant will see is not
 *           ours to learn, so a goal just beyond the claim radius no longer counts the
 *           claimed room (Burgard's utility reduction of what the assigned robot sees);
 *   info    info_m2(c) = res_m^2 x sum(unknown / 255) over the square of half side
 *           r = round(sensor_radius_m / res_m) cells around c (a summed-area table: one pass):
 *           the area of prior uncertainty a visit could remove, m^2; with info_by_path only
 *           over the cells of that square the search reaches within r steps past c's own
 *           (steps(u) <= steps(c) + r): a room behind a wall the robot has seen, reached the
 *           long way round, is not what a look from beside the wall takes in (the cells are
 *           added in the order of their steps to a 2-D Fenwick tree, O(cells log^2) a choice);
 *   utility u(c) = info_m2(c) - lambda x cost_m(c)   (lambda in m^2 per metre of path); the
 *           goal held (not contested: no claim discounts it) counts keep_m nearer, cost_m -
 *           keep_m: hysteresis, since the coarse search's cost to it can grow while the RT core
 *           drives a finer path round a wall, and another goal would win at every choice;
 *   goal    the reachable candidate of the highest utility among those with info_m2 >=
 *           min_info_m2 before the claims (ties: the lowest cell index); none: -ENOENT,
 *           exploration is finished for us (nothing left to learn within reach), or -EBUSY
 *           when there were such candidates but the claims removed them all (a discount of 0,
 *           or less than min_info_m2 left outside the claims' windows: what is left is nearer
 *           peers': try again later).
 * Our claim (sender = self, the goal's centre, its cost aged as above, seq + 1, expiry = now +
 * claim_lifetime_us) goes out when the goal changes, and again every claim_period_us from
 * gp_goal_select or gp_goal_poll while the goal stands. A failed send is counted; the next
 * period sends again (a lost claim is what the period is for).
 *
 * gp_goal_on_claim(claim, now) validates every field before it changes anything: sender inside
 * the fleet and not us, finite goal inside the map, finite cost in 0 .. the longest path of
 * the grid (-EBADMSG); expiry after now (-ESTALE: late), at most claim_max_lifetime_us ahead
 * (-EBADMSG: forged or a clock far off). One claim per robot: a seq lower than the one held
 * is -ESTALE (reordered), an equal one -EALREADY (duplicate), both ignored. A held claim
 * drops out at its expiry. The claims carry absolute simulated times: the fleet's clocks
 * agree (the host's lockstep) within far less than a lifetime. A restarted robot counts its
 * seq from 0 again; its peers ignore it until the claim they hold of it expired (a lifetime
 * at most). The table holds GP_GOAL_MAX_CLAIMS claims; full, a new robot's claim takes the
 * place of the one that expires first when that one expires before it, else -ENOSPC.
 *
 * Deterministic: the same calls with the same arguments give the same goals and claims (no
 * clock, no randomness, ties by index/id). Memory: everything inside gp_goal_t (about 90 KB
 * with the 64 x 64 grid), no allocation. One thread (the GP core). */
#ifndef GP_GP_GOAL_H
#define GP_GP_GOAL_H

#include <stddef.h>
#include <stdint.h>

#define GP_GOAL_MAX_W 64u
#define GP_GOAL_MAX_H 64u
#define GP_GOAL_MAX_CELLS (GP_GOAL_MAX_W * GP_GOAL_MAX_H)
#define GP_GOAL_MAX_CLAIMS 32u
#define GP_GOAL_MAX_FLEET BOARD_MAX_FLEET
/* Bounds on the configured times (a claim lives at most a minute of simulated time). */
#define GP_GOAL_MAX_LIFETIME_US (60ull * 1000000ull)
_Static_assert(GP_GOAL_MAX_CELLS <= 0xFFFFu, "cell indices and BFS steps fit uint16_t");

/* The coarse belief grid of the AI core (see above): cells [y * w + x], w x h of the cfg. */
typedef struct gp_goal_grid {
    uint8_t occ[GP_GOAL_MAX_CELLS];
    uint8_t unknown[GP_GOAL_MAX_CELLS];
} gp_goal_grid_t;

/* A claim (fleetsim.goal_claim_t, firmware/msg/goal_claim.lcm): robot `sender` heads for
 * (x_m, y_m) at path cost cost_m metres; it lapses at expiry_us (simulated time). */
typedef struct gp_goal_claim {
    uint32_t sender, seq;
    double x_m, y_m;
    double cost_m;
    uint64_t expiry_us;
} gp_goal_claim_t;

/* A peer's claims on their way to gp_goal_on_claim: a fleet hands robot p's claims of rounds
 * up to k over at its round k, so that every run takes the same ones at the same simulated
 * instant whatever the order claims and round ends come in. p may be a round ahead (it began
 * round k + 1 once it had our position of k, while we still wait for another's state), so its
 * claim of k + 1 must not replace the one of k not handed over yet: two slots, by seq parity
 * (a peer's unhanded claims are of k and k + 1 while the fleet keeps its lockstep). */
typedef struct gp_goal_inbox {
    gp_goal_claim_t slot[2];
    uint8_t held;                    /* bit i: slot[i] holds a claim */
} gp_goal_inbox_t;

/* Keeps c (sender and the rest are checked when it is handed over): a newer or equal seq
 * replaces the claim held in its slot, an older one is dropped. */
void gp_goal_inbox_put(gp_goal_inbox_t *in, const gp_goal_claim_t *c);

/* The newest held claim of seq <= round into *out (1), and every held one of seq <= round
 * dropped; 0 when none. Claims of later rounds stay. */
int gp_goal_inbox_take(gp_goal_inbox_t *in, uint32_t round, gp_goal_claim_t *out);

/* Sends our claim. 0, or a negative code (counted, sent again next period). */
typedef int (*gp_goal_send_fn)(void *ctx, const gp_goal_claim_t *c);

typedef struct gp_goal_cfg {
    uint32_t self, n_peers;          /* self < n_peers <= GP_GOAL_MAX_FLEET */
    uint32_t w, h;                   /* 1 .. GP_GOAL_MAX_W, 1 .. GP_GOAL_MAX_H */
    double res_m;                    /* > 0, finite: a cell's side */
    double origin_x_m, origin_y_m;   /* finite: the corner of cell (0, 0) */
    uint8_t occ_max;                 /* > 0: a cell with occ < occ_max is free enough */
    double sensor_radius_m;          /* >= 0: half side of the square a goal's info sums */
    double lambda;                   /* >= 0: m^2 of info one metre of path is worth */
    double min_info_m2;              /* > 0: less is nothing left to learn there */
    double keep_m;                   /* >= 0: the goal held counts this much nearer (above) */
    double claim_radius_m;           /* >= 0: a kept claim discounts candidates this near it */
    double claim_discount;           /* 0 .. 1: their info is multiplied by it */
    double claim_window_m;           /* >= 0: half side of the square of unknown a kept claim takes
                                        out of every candidate's info (0: none) */
    double claim_tie_m;              /* >= 0: costs this close are a tie (above); 0: equal only */
    int info_by_path;                /* 1: info counts only what a look takes in (above) */
    double claim_speed_mps;          /* >= 0: a claimant's cost falls this fast with the claim's age */
    uint64_t claim_period_us;        /* > 0: our claim is sent again this often */
    uint64_t claim_lifetime_us;      /* > claim_period_us, <= claim_max_lifetime_us: ours */
    uint64_t claim_max_lifetime_us;  /* <= GP_GOAL_MAX_LIFETIME_US: the furthest expiry accepted */
    gp_goal_send_fn send;            /* may be NULL: no claim is sent */
    void *send_ctx;
} gp_goal_cfg_t;

/* The goal gp_goal_select chose. */
typedef struct gp_goal_pick {
    uint32_t cell;                   /* y * w + x */
    double x_m, y_m;                 /* its centre */
    double info_m2, cost_m, utility; /* info after the claims' discount */
} gp_goal_pick_t;

typedef struct gp_goal_stats {
    uint64_t claims_sent, send_failures;
    uint64_t claims_taken, claims_invalid, claims_late, claims_reordered, claims_duplicate, claims_full;
    uint64_t claims_expired, goal_changes;
} gp_goal_stats_t;

typedef struct gp_goal_held {
    gp_goal_claim_t c;
    uint8_t used;
} gp_goal_held_t;

typedef struct gp_goal {
    gp_goal_cfg_t cfg;
    gp_goal_held_t claims[GP_GOAL_MAX_CLAIMS];
    uint16_t steps[GP_GOAL_MAX_CELLS];                /* BFS steps from our cell; 0xFFFF unreached */
    uint16_t queue[GP_GOAL_MAX_CELLS];
    uint32_t sat[(GP_GOAL_MAX_W + 1u) * (GP_GOAL_MAX_H + 1u)]; /* summed-area table of unknown */
    uint32_t sat_left[(GP_GOAL_MAX_W + 1u) * (GP_GOAL_MAX_H + 1u)]; /* the same outside the claims' windows */
    uint8_t taken[GP_GOAL_MAX_CELLS];                /* 1: inside a kept claim's window */
    double discount[GP_GOAL_MAX_CELLS];              /* per candidate, from the claims */
    int has_goal;
    gp_goal_pick_t goal;                             /* ours (with has_goal) */
    uint64_t picked_us;                              /* its cost was computed then */
    uint32_t seq;                                    /* of our last claim */
    uint64_t sent_us;                                /* our last claim went out then */
    int sent_any;
    gp_goal_stats_t stats;
} gp_goal_t;
_Static_assert((GP_GOAL_MAX_W + 1u) * (GP_GOAL_MAX_H + 1u) * 255u <= 0xFFFFFFFFu, "the table's sums fit uint32_t");

/* Validates cfg and resets g. 0 or -EINVAL. */
FS_MUST_CHECK int gp_goal_init(gp_goal_t *g, const gp_goal_cfg_t *cfg);

/* Chooses our goal from grid and our pose (x_m, y_m: inside the map, finite) at now_us (see
 * above), and sends our claim when the goal changed or a period passed. 0 with *out; -ENOENT
 * when nothing is left to learn within reach, -EBUSY when what is left is claimed (in both our
 * goal is cleared, no claim sent: ours lapses at its expiry); -EINVAL bad arguments. */
FS_MUST_CHECK int gp_goal_select(gp_goal_t *g, const gp_goal_grid_t *grid, double x_m, double y_m, uint64_t now_us,
                                 gp_goal_pick_t *out);

/* A received claim: 0 taken, or why not (above: -EBADMSG, -ESTALE, -EALREADY, -ENOSPC,
 * -EINVAL for a NULL argument); every refusal is counted and changes nothing else. */
FS_MUST_CHECK int gp_goal_on_claim(gp_goal_t *g, const gp_goal_claim_t *c, uint64_t now_us);

/* Sets mark[i] = 1 on the cells a look from `cell` takes in, as a goal's info counts them: its
 * window (half side round(sensor_radius_m / res_m) cells), with info_by_path only the window's
 * cells the search from `cell` over grid's traversable cells reaches (within 2 r steps, the
 * window's corners): a room behind a wall beside the goal is not among them. Other marks are
 * left as they are. Uses the search's scratch (the next gp_goal_select fills it again).
 * 0, or -EINVAL (a NULL argument, cell outside the grid). */
FS_MUST_CHECK int gp_goal_look(gp_goal_t *g, const gp_goal_grid_t *grid, uint32_t cell, uint8_t *mark);

/* Drops expired claims and sends our claim again when a period passed. */
void gp_goal_poll(gp_goal_t *g, uint64_t now_us);

/* Our claim of our goal as of now_us, with this seq: its cost aged by claim_speed_mps since it
 * was computed (as a receiver ages it further), expiry now + claim_lifetime_us. The claims
 * gp_goal sends are made by it, and so are those a caller sends itself (gp_core, one per round).
 * 0 with *out, -ENOENT without a goal, -EINVAL. */
FS_MUST_CHECK int gp_goal_our_claim(const gp_goal_t *g, uint32_t seq, uint64_t now_us, gp_goal_claim_t *out);

/* 1 when a live claim holds against our goal at now_us (a peer's goal within claim_radius_m of
 * ours whose claimant keeps it by the rule above, our cost to it taken as our goal's, aged),
 * else 0 (also without a goal). The caller chooses again rather than drive on to a peer's. */
int gp_goal_contested(const gp_goal_t *g, uint64_t now_us);

/* The live claim held of robot id (0 with *out), or -ENOENT. */
FS_MUST_CHECK int gp_goal_claim_of(const gp_goal_t *g, uint32_t id, uint64_t now_us, gp_goal_claim_t *out);

#endif /* GP_GP_GOAL_H */
