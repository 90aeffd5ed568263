/* Link models of the in-process DiNNO fleet (sim_fleet.h): which neighbour states of a round
 * arrive, so that the consensus can be studied fast under bad links (docs/faults.md, "Link
 * models of the in-process fleet").
 *
 * A link is the undirected pair {i, j}. In round k it delivers both ways or neither:
 *   - a scheduled cut holds it: in a cut's rounds [from, until) agents of different groups
 *     do not hear each other;
 *   - else it delivers with probability `success`, one draw per (run seed, k, min(i,j),
 *     max(i,j)) of the counter-based sim_rng, so the drops do not depend on threads or on the
 *     order anything is computed in, and the same seed drops the same links.
 * Why both ways or neither: in the multi-process fleet a state that got through one way nearly
 * always gets through the other (the protocol asks again for what is missing, so a link is
 * lost for a round only when it is down for the whole round, both ways), and a node must not be
 * left guessing whether its own state arrived: with one-way drops i would mix in j's state
 * while j trained without i's, which no real fleet does for long.
 * The default (success 1, no cut) draws nothing: a run is bit-identical to one without a link
 * model.
 *
 * Spec of the cuts (host_sim fleet --inproc --link-faults; the syntax of host_sim run's
 * --net-faults partition where it fits, in rounds instead of seconds): cuts separated by ';',
 * each comma-separated key=value:
 *   partition=A/B[/C...]  groups of agent ids, ids '.'-separated (partition=0.1.2/3.4.5); the
 *                         agents named in no group form one more group (partition=0.1 is
 *                         {0, 1} | the rest)
 *   away=I                agent I alone: the cut {I} | the rest ("a robot away")
 *   from=R1               first round of the cut (default 0)
 *   until=R2              the cut ends before round R2 (default: never), R2 > R1
 * Rounds count from 0: round k exchanges the states of metrics.csv's row k.
 *
 * Pure functions; no allocation. */
#ifndef SIM_LINKS_H
#define SIM_LINKS_H

#include <stddef.h>
#include <stdint.h>

#include "ai/dinno_graph.h"

#define SIM_LINKS_MAX_CUTS 4
#define SIM_LINKS_MAX_AGENTS ((int)DINNO_GRAPH_MAX_NODES)
#define SIM_LINKS_FOREVER UINT32_MAX /* until= not given: the cut never ends */
#define SIM_LINKS_STREAM 0x4C494E4Bu /* "LINK": the sim_rng stream of the link draws */

typedef struct sim_links_cut {
    uint32_t from, until;                  /* rounds [from, until) */
    uint32_t groups;                       /* groups named, >= 1 */
    uint16_t group[SIM_LINKS_MAX_AGENTS];  /* agent's group: 1 .. groups, 0 = named in none */
} sim_links_cut_t;

typedef struct sim_links {
    double success;                        /* probability a link delivers in a round, [0, 1] */
    int n_cuts;
    sim_links_cut_t cut[SIM_LINKS_MAX_CUTS];
} sim_links_t;

/* Every link delivers: success 1, no cut. */
void sim_links_default(sim_links_t *l);
/* 1 when a link can fail (success < 1 or a cut), else 0. */
int sim_links_active(const sim_links_t *l);
/* Appends the cuts of `spec` (syntax above) to l; on an error l is unchanged and err says why.
 * Agent ids are checked against SIM_LINKS_MAX_AGENTS here, against the fleet by
 * sim_links_check. 0 or -EINVAL (-E2BIG: more than SIM_LINKS_MAX_CUTS cuts in all). */
FS_MUST_CHECK int sim_links_parse(const char *spec, sim_links_t *l, char *err, size_t errlen);
/* The model for a fleet of n agents: success a number in [0, 1], at most SIM_LINKS_MAX_CUTS
 * cuts, each with from < until, every named agent < n, and at least two groups among the n
 * (a cut that splits nothing is a mistake). 0 or -EINVAL with err. */
FS_MUST_CHECK int sim_links_check(const sim_links_t *l, int n_agents, char *err, size_t errlen);
/* 1 when the link {i, j} delivers in round k of the run with this seed, else 0. Symmetric in
 * i and j. No draw when success is 1 (or 0). */
int sim_links_deliver(const sim_links_t *l, uint64_t seed, uint32_t k, uint32_t i, uint32_t j);
/* One line for summary.txt ("success 0.9; partition=0.1/2 rounds [10, 20)"; "every link
 * delivers"), truncated to cap. */
void sim_links_describe(const sim_links_t *l, char *out, size_t cap);

#endif /* SIM_LINKS_H */
