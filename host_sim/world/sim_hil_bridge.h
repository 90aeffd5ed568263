/* The bridge of `host_sim hil` (sim_hil_serve.h) on the fleet's LCM: the network interface of a
 * robot whose firmware runs on a board. What the board publishes goes out on the fleet's
 * transport as that robot's; what arrives on the channels the board subscribed to waits in a
 * bounded queue (the host network's, hal_host.h: a receiver thread, datagrams checked on
 * arrival, dropped and counted when the queue is full) until a TICK's answer takes it. The
 * board's own datagrams, which LCM loops back, are recognised and never sent back to it. */
#ifndef SIM_HIL_BRIDGE_H
#define SIM_HIL_BRIDGE_H

#include <stddef.h>
#include <stdint.h>

#include "hal/hal_net.h"
#include "sim_hil_serve.h"

typedef struct sim_hil_lcm_bridge sim_hil_lcm_bridge_t;

/* Opens the bridge on the LCM url (e.g. udpm://239.255.76.67:7667?ttl=0) into *out and its
 * operations into *ops (ctx: *out). 0, or a negative code with a message in err. */
int sim_hil_lcm_bridge_open(const char *url, sim_hil_lcm_bridge_t **out, sim_hil_bridge_t *ops, char *err,
                            size_t errlen);

/* What crossed it: datagrams the fleet sent that were dropped on arrival (queue full,
 * malformed), from the host network's counters, and the board's own datagrams LCM brought back
 * (*echoes: never sent to the board). */
void sim_hil_lcm_bridge_stats(const sim_hil_lcm_bridge_t *b, hal_net_stats_t *st, uint64_t *echoes);

void sim_hil_lcm_bridge_close(sim_hil_lcm_bridge_t *b);

#endif /* SIM_HIL_BRIDGE_H */
