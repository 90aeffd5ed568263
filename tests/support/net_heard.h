/* What a test's receiving network heard: the tests of the host network over real sockets and
 * shared memory (tests/hal/test_net_groups.c, test_net_kfilter.c, test_net_zmq.c,
 * test_net_shm.c) send RoundCompletes whose sender field says who sent them. */
#ifndef TESTS_NET_HEARD_H
#define TESTS_NET_HEARD_H

#include <stdint.h>

#include "hal_host.h"

/* Waits up to timeout_ms for rx's queue, then drains it: the sender of every RoundComplete
 * as a bit set (bit s: sender s, s < 31; a RoundComplete that does not decode fails the
 * test), bit 31 for any datagram on `plain` (NULL: none is expected there). */
uint32_t net_heard_within(hal_host_net_t *rx, int timeout_ms, const char *plain);

/* Publishes on n's `channel` a RoundComplete naming `sender` (round 3; fails the test when it
 * cannot). */
void net_publish_done(hal_host_net_t *n, const char *channel, uint32_t sender);

#endif
