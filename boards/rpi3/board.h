/* Board "rpi3": a Cortex-A53 Linux computer, Raspberry Pi 3 B class (4 x A53 at 1.2 GHz, 1 GB
 * of RAM), the kind of computer a TurtleBot 3 carries. The image is one static aarch64
 * executable; QEMU's user mode (qemu-aarch64) runs it on a build machine.
 *
 * The budgets leave most of the 1 GB to Linux and the camera/ROS stack a robot also runs: the
 * firmware takes at most 260 MB (4 MB of it the RT core's: its exploration grid and planner
 * workspace, about 1.6 MB), which holds the `paper` network (527,361 parameters) with the
 * paper's fleet of 7. */
#ifndef BOARD_RPI3_BOARD_H
#define BOARD_RPI3_BOARD_H

#define BOARD_NAME "rpi3"

#define BOARD_PART_CLOCK_HZ 1200000000u

#define BOARD_RAM_RT_BYTES (4u * 1024u * 1024u)
#define BOARD_RAM_GP_BYTES (64u * 1024u * 1024u)
#define BOARD_RAM_AI_BYTES (192u * 1024u * 1024u)

#define BOARD_STACK_RT_BYTES (64u * 1024u)
#define BOARD_STACK_GP_BYTES (256u * 1024u)
#define BOARD_STACK_AI_BYTES (1024u * 1024u)

/* UDP over Wi-Fi or Ethernet, LCM's largest datagram. */
#define BOARD_NET_MTU_BYTES (60u * 1024u)

#define BOARD_MAX_PEERS 8u
/* Largest fleet (robot ids 0 .. BOARD_MAX_FLEET - 1): about 140 bytes of GP RAM per robot;
 * each round keeps the states of the BOARD_MAX_PEERS nearest within the radius. */
#define BOARD_MAX_FLEET 1024u

#endif /* BOARD_RPI3_BOARD_H */
