/* The hardware-in-the-loop link's ports of the stdc back end's targets (hal/hal_hil_client.h):
 * how a board's bytes reach `host_sim hil`. A Linux board: a UDP socket
 * (hal_stdc_posix_hil.c). A Cortex-M board's serial port is not built yet. */
#ifndef HAL_STDC_HIL_H
#define HAL_STDC_HIL_H

#include "hal/hal_hil_client.h"

/* A UDP socket connected to "A.B.C.D:PORT" (the world's --listen, numeric) into *port; *fd_out holds the
 * descriptor and is the port's context (it must outlive the port). 0, -EINVAL (a bad address,
 * said on stderr) or -EIO. */
int hal_stdc_hil_udp_open(const char *host_port, hal_hil_port_t *port, int *fd_out);

#endif /* HAL_STDC_HIL_H */
