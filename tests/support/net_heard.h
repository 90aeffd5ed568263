/* What a test's receiving network heard: the tests of the host network over real udpm
 * sockets (tests/hal/test_net_groups.c, test_net_kfilter.c) send RoundCompletes whose sender
 * field says who sent them. */
#ifndef TESTS_NET_HEARD_H
#define TESTS_NET_HEARD_H

#include <stdint.h>

#include "hal_host.h"

/* Waits up to timeout_ms for rx's queue, then drains it: the sender of every RoundComplete
 * as a bit set (bit s: sender s, s < 31; a RoundComplete that does not decode fails the
 * test), bit 31 for any datagram on `plain` (NULL: none is expected there). */
uint32_t net_heard_within(hal_host_net_t *rx, int timeout_ms, const char *plain);

#endif
