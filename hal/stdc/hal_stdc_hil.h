/* The hardware-in-the-loop link's ports of the stdc back end's targets (hal/hal_hil_client.h):
 * how a board's bytes reach `host_sim hil`. One function per target, the same name:
 *   a Linux board (hal_stdc_posix_hil.c):   "A.B.C.D:PORT", a connected UDP socket, one frame per
 *                                           datagram (`host_sim hil --link udp`);
 *   a Cortex-M board (hal_stdc_cortex_m_hil.c): "eth0", the LAN9118 Ethernet controller, a frame
 *                                           per Ethernet frame (QEMU's -nic; `host_sim hil --link
 *                                           ether`), or "uart0" .. "uart3", the CMSDK APB UART of
 *                                           that number as a byte stream, frames back to back
 *                                           (QEMU's -serial; `host_sim hil --link serial`). */
#ifndef HAL_STDC_HIL_H
#define HAL_STDC_HIL_H

#include "hal/hal_hil_client.h"

/* Opens the link named `where` into *port (its context is the target's own static state: one
 * link per board). 0, -EINVAL (a name the target does not have, said on stderr) or -EIO. */
int hal_stdc_hil_open(const char *where, hal_hil_port_t *port);

/* What the target's open link is, for messages ("udp", "serial", "ethernet"). */
const char *hal_stdc_hil_kind(void);

#endif /* HAL_STDC_HIL_H */
