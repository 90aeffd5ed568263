/* Board "mps2-an500": a Cortex-M7 microcontroller board, emulated by QEMU's MPS2 AN500.
 *
 * The part it stands for: an STM32H743-class M7 at 480 MHz with 2 MB of flash, 1 MB of
 * on-chip SRAM and 16 MB of SDRAM on its memory controller (the `small` network, which the
 * fleet runs, with its 1024-point batch). The
 * emulator's RAMs are larger; the linker script (boards/common/cortex_m.ld) cuts them to these
 * sizes, so an image that would not fit the part does not link. The static state of the
 * firmware (the DiNNO node, the pool, the links) lives in the SDRAM; the SRAM holds the main
 * stack, the C library and the HAL.
 * Values the linker script reads carry no `u` suffix (the script is run through cpp). */
#ifndef BOARD_MPS2_AN500_BOARD_H
#define BOARD_MPS2_AN500_BOARD_H

#define BOARD_NAME "mps2-an500"

/* Memories: what the part has, at the addresses the emulated board maps them. */
#define BOARD_FLASH_BASE 0x00000000
#define BOARD_FLASH_BYTES (2048 * 1024)
#define BOARD_SRAM_BASE 0x20000000
#define BOARD_SRAM_BYTES (1024 * 1024)
#define BOARD_XRAM_BASE 0x60000000
#define BOARD_XRAM_BYTES (16384 * 1024)
#define BOARD_HEAP_BYTES (16 * 1024) /* the C library's (stdio buffers); firmware uses none */

/* Clocks: the SysTick clock of the emulated board (instruction counting), and the part's. */
#define BOARD_CORE_CLOCK_HZ 25000000u
#define BOARD_PART_CLOCK_HZ 480000000u

/* Peripherals the emulated board maps: the SMSC LAN9118 Ethernet controller (QEMU's -nic). */
#define BOARD_ETH_LAN9118_BASE 0xA0000000u

/* Static RAM per core (the firmware's _Static_assert budgets). */
#define BOARD_RAM_RT_BYTES (128 * 1024)
#define BOARD_RAM_GP_BYTES (4096 * 1024)
#define BOARD_RAM_AI_BYTES (10240 * 1024)

/* The RT core's exploration grid (rt/rt_grid.h): 512 cells (e.g. 22 x 22, a 2.2 m square at
 * 0.1 m), at most 64 a side: the grid, the planner's workspace (21 bytes a cell plus its
 * per-line scratch) and the scan marks take about 14 KB, so the RT core's state and links
 * (about 119 KB) stay within its 128 KB. */
#define RT_GRID_MAX_CELLS 512
#define RT_GRID_MAX_SIDE 64

/* Stacks per core; the image runs the AI core's work on the main stack, of the AI's size. */
#define BOARD_STACK_RT_BYTES (4 * 1024)
#define BOARD_STACK_GP_BYTES (8 * 1024)
#define BOARD_STACK_AI_BYTES (64 * 1024) /* 32 KB of it: the GEMM's packed panels */

/* Ethernet: one UDP datagram of a 1500-byte frame. */
#define BOARD_NET_MTU_BYTES 1472u

/* Neighbour states per round: every other robot of the paper's fleet of 7, and a spare. */
#define BOARD_MAX_PEERS 8u
/* Largest fleet (robot ids 0 .. BOARD_MAX_FLEET - 1): about 140 bytes of GP RAM per robot;
 * each round keeps the states of the BOARD_MAX_PEERS nearest within the radius. */
#define BOARD_MAX_FLEET 1024u

/* RT -> AI sample ring: 8 scans of 500 samples (the AI core drains it every 100 ms). */
#define FW_LINK_RING_CAPACITY 4096u

/* CRC-32 by nibbles: 64 bytes of table instead of 8 KB of flash. */
#define CRC32_SLICE8 0

#endif /* BOARD_MPS2_AN500_BOARD_H */
