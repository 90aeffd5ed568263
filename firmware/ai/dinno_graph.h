/* Communication graphs of a DiNNO fleet: whose states each node takes in a round.
 *
 * Nodes are 0 .. n-1 (n <= DINNO_GRAPH_MAX_NODES, the board's largest fleet); node i takes the
 * states of its neighbours nb[i][0 .. deg[i]-1], ascending ids, at most DINNO_GRAPH_MAX_DEGREE
 * (DiNNO's slots), no self loops. Slot s of node i holds the state of nb[i][s].
 *   full: every pair (n - 1 <= DINNO_GRAPH_MAX_DEGREE);  ring: i ~ i+1 mod n (n = 2: one edge);
 *   disk: node i takes node j when the Euclidean distance of their positions is <= radius
 *         (metres) and j is among the DINNO_GRAPH_MAX_DEGREE nearest such nodes of i, by
 *         (squared distance, id). Symmetric while no node has more nodes in reach than slots;
 *         beyond, i may take j and j not i (the graph of gp_pse, which keeps the nearest).
 * The fleet driver rebuilds the disk graph every round from the robots' positions.
 * Pure functions of their inputs; no allocation; thread-safe on distinct graphs. */
#ifndef AI_DINNO_GRAPH_H
#define AI_DINNO_GRAPH_H

#include <stdint.h>

#include "ai/dinno.h"

#define DINNO_GRAPH_MAX_NODES BOARD_MAX_FLEET
#define DINNO_GRAPH_MAX_DEGREE DINNO_MAX_PEERS
_Static_assert(DINNO_GRAPH_MAX_NODES <= 0xFFFFu, "node ids are 16-bit");

typedef enum dinno_graph_kind {
    DINNO_GRAPH_FULL = 0,
    DINNO_GRAPH_RING = 1,
    DINNO_GRAPH_DISK = 2,
} dinno_graph_kind_t;

typedef struct dinno_graph {
    uint32_t n;
    uint16_t deg[DINNO_GRAPH_MAX_NODES];
    uint16_t nb[DINNO_GRAPH_MAX_NODES][DINNO_GRAPH_MAX_DEGREE];
} dinno_graph_t;

typedef struct dinno_graph_report {
    uint32_t edges;      /* pairs of nodes of which one, or both, takes the other's state */
    uint32_t components; /* connected components of those pairs (an isolated node counts as one) */
    uint32_t isolated;   /* nodes without a neighbour */
    uint32_t largest;    /* nodes in the largest component */
} dinno_graph_report_t;

/* Each returns 0 or -EINVAL (n == 0 or n > DINNO_GRAPH_MAX_NODES; disk: NULL xy, radius not
 * finite or < 0, a non-finite position), full also -E2BIG (n - 1 > DINNO_GRAPH_MAX_DEGREE).
 * xy: n interleaved positions (x0, y0, x1, y1, ...). */
FS_MUST_CHECK int dinno_graph_full(dinno_graph_t *g, uint32_t n);
FS_MUST_CHECK int dinno_graph_ring(dinno_graph_t *g, uint32_t n);
FS_MUST_CHECK int dinno_graph_disk(dinno_graph_t *g, uint32_t n, const double *xy,
                                                         double radius);

/* 1 when node i takes node j's state. */
int dinno_graph_has_edge(const dinno_graph_t *g, uint32_t i, uint32_t j);

uint32_t dinno_graph_degree(const dinno_graph_t *g, uint32_t i);
void dinno_graph_report(const dinno_graph_t *g, dinno_graph_report_t *r);

const char *dinno_graph_name(dinno_graph_kind_t k);
/* "full" | "ring" | "disk"; returns 0 or -EINVAL. */
FS_MUST_CHECK int dinno_graph_parse(const char *name, dinno_graph_kind_t *out);

#endif /* AI_DINNO_GRAPH_H */
