/* Communication graphs of a DiNNO fleet: who exchanges states with whom in a round.
 *
 * Nodes are 0 .. n-1 (n <= DINNO_GRAPH_MAX_NODES); the graph is undirected, without self
 * loops, stored as one neighbour bitmask per node (bit j of adj[i] set <=> edge i-j).
 * Node j's state goes into slot j of node i (fixed slots, ai/dinno.h).
 *   full: every pair;  ring: i ~ i+1 mod n (n = 2: one edge);
 *   disk: i ~ j when the Euclidean distance of their positions is <= radius (metres).
 * The fleet driver rebuilds the disk graph every round from the robots' positions.
 * Pure functions of their inputs; no allocation; thread-safe on distinct graphs. */
#ifndef AI_DINNO_GRAPH_H
#define AI_DINNO_GRAPH_H

#include <stdint.h>

#include "ai/dinno.h"

#define DINNO_GRAPH_MAX_NODES DINNO_MAX_PEERS
_Static_assert(DINNO_GRAPH_MAX_NODES <= 32u, "neighbour masks are 32-bit");

typedef enum dinno_graph_kind {
    DINNO_GRAPH_FULL = 0,
    DINNO_GRAPH_RING = 1,
    DINNO_GRAPH_DISK = 2,
} dinno_graph_kind_t;

typedef struct dinno_graph {
    uint32_t n;
    uint32_t adj[DINNO_GRAPH_MAX_NODES];
} dinno_graph_t;

typedef struct dinno_graph_report {
    uint32_t edges;
    uint32_t components; /* connected components (an isolated node counts as one) */
    uint32_t isolated;   /* nodes without a neighbour */
    uint32_t largest;    /* nodes in the largest component */
} dinno_graph_report_t;

/* Each returns 0 or -EINVAL (n == 0 or n > DINNO_GRAPH_MAX_NODES; disk: NULL xy, radius not
 * finite or < 0, a non-finite position). xy: n interleaved positions (x0, y0, x1, y1, ...). */
FS_MUST_CHECK int dinno_graph_full(dinno_graph_t *g, uint32_t n);
FS_MUST_CHECK int dinno_graph_ring(dinno_graph_t *g, uint32_t n);
FS_MUST_CHECK int dinno_graph_disk(dinno_graph_t *g, uint32_t n, const double *xy,
                                                         double radius);

static inline int dinno_graph_has_edge(const dinno_graph_t *g, uint32_t i, uint32_t j)
{
    return i < g->n && j < g->n && ((g->adj[i] >> j) & 1u);
}

uint32_t dinno_graph_degree(const dinno_graph_t *g, uint32_t i);
void dinno_graph_report(const dinno_graph_t *g, dinno_graph_report_t *r);

const char *dinno_graph_name(dinno_graph_kind_t k);
/* "full" | "ring" | "disk"; returns 0 or -EINVAL. */
FS_MUST_CHECK int dinno_graph_parse(const char *name, dinno_graph_kind_t *out);

#endif /* AI_DINNO_GRAPH_H */
