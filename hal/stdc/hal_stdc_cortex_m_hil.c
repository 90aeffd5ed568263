/* The hardware-in-the-loop link's serial port on a Cortex-M board (hal_stdc_hil.h): one CMSDK
 * APB UART (the MPS2 boards' UARTs, which QEMU models and connects to its -serial), polled, as
 * a byte stream: frames go out back to back and come in through the client's stream reader.
 *
 * Polled, not interrupt-driven: the link is only used inside the RT core's sense step, which
 * waits for the world's answer anyway, and a polled wait under `-icount shift=0,sleep=off` is
 * the board's instructions, so the board's time goes on while it waits, as it would on a real
 * line. With the receive interrupt and `wfi`, QEMU would jump the board's time to the next
 * timer tick at every byte (sleep=off), or let it run at the host's pace (sleep=on); measured,
 * the bytes came no faster that way.
 * QEMU's model receives one byte at a time (RXFULL until DATA is read) and takes the next from
 * its character device at the next turn of its main loop, about 6 KB/s on the machine of
 * docs/boards.md: nothing is lost while the core does other work, but a tick's answer (a 40-byte
 * pose, and a 1,486-byte scan every 5th tick) takes about 2 ms of the board's time. A real UART
 * at 1 Mbaud would need its FIFO or a DMA ring instead. */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "hal_stdc_hil.h"
#include "hal_stdc_target.h"

#ifndef BOARD_CORE_CLOCK_HZ
#error "a Cortex-M board must define BOARD_CORE_CLOCK_HZ (the UART's clock on the MPS2 boards)"
#endif

/* CMSDK APB UART registers (Arm DDI 0479). */
typedef struct cmsdk_uart {
    volatile uint32_t data;     /* 0x00: the byte in or out */
    volatile uint32_t state;    /* 0x04: bit 0 TX full, bit 1 RX full, bits 2-3 overruns (write 1 clears) */
    volatile uint32_t ctrl;     /* 0x08: bit 0 TX enable, bit 1 RX enable */
    volatile uint32_t intstatus;
    volatile uint32_t bauddiv;  /* 0x10: the APB clock over the baud rate, 16 at least */
} cmsdk_uart_t;

#define UART_STATE_TX_FULL 1u
#define UART_STATE_RX_FULL 2u
#define UART_STATE_OVERRUNS 0xCu
#define UART_CTRL_TX_RX 3u
#define UART_BAUD 1000000u /* what a real board's USB serial bridge carries; QEMU does not pace it */
_Static_assert(BOARD_CORE_CLOCK_HZ / UART_BAUD >= 16u, "the CMSDK UART's divider must be 16 at least");

/* The MPS2 boards' UARTs 0-3 (AN385/AN386/AN500 memory maps). */
static const uintptr_t uart_base[] = {0x40004000u, 0x40005000u, 0x40006000u, 0x40007000u};

/* A burst of bytes ends when none came for this long: the world writes a frame at once, so a
   gap means it is all here (or the rest comes in the next read: the stream reader does not mind). */
#define RX_GAP_US 200u
#define TX_BYTE_TIMEOUT_US 10000u

static cmsdk_uart_t *uart;

static int uart_send(void *ctx, const uint8_t *bytes, size_t n)
{
    cmsdk_uart_t *u = ctx;
    for (size_t i = 0; i < n; i++) {
        const uint64_t t0 = hal_stdc_target_now_us();
        while (u->state & UART_STATE_TX_FULL)
            if (hal_stdc_target_now_us() - t0 > TX_BYTE_TIMEOUT_US)
                return -EIO; /* the line does not drain: nobody reads the other end */
        u->data = bytes[i];
    }
    return 0;
}

static int uart_recv(void *ctx, uint8_t *buf, size_t cap, uint32_t timeout_us)
{
    cmsdk_uart_t *u = ctx;
    size_t n = 0;
    uint64_t last = hal_stdc_target_now_us();
    const uint64_t deadline = last + timeout_us;
    while (n < cap) {
        if (u->state & UART_STATE_RX_FULL) {
            buf[n++] = (uint8_t)u->data;
            last = hal_stdc_target_now_us();
            continue;
        }
        const uint64_t now = hal_stdc_target_now_us();
        if (n > 0 ? now - last >= RX_GAP_US : now >= deadline)
            break;
    }
    u->state = UART_STATE_OVERRUNS; /* cleared: the stream reader finds its way after a lost byte */
    return (int)n;
}

const char *hal_stdc_hil_kind(void)
{
    return "serial";
}

int hal_stdc_hil_open(const char *where, hal_hil_port_t *port)
{
    const size_t count = sizeof uart_base / sizeof uart_base[0];
    if (where == NULL || strncmp(where, "uart", 4) != 0 || where[4] < '0' || where[4] >= (char)('0' + count) ||
        where[5] != '\0') {
        fprintf(stderr, "hil: '%s' is not a UART of this board (uart0 .. uart%u)\n", where != NULL ? where : "",
                (unsigned)(count - 1u));
        return -EINVAL;
    }
    uart = (cmsdk_uart_t *)uart_base[where[4] - '0'];
    uart->ctrl = 0;
    uart->bauddiv = BOARD_CORE_CLOCK_HZ / UART_BAUD;
    uart->state = UART_STATE_OVERRUNS;
    uart->ctrl = UART_CTRL_TX_RX;
    while (uart->state & UART_STATE_RX_FULL) /* whatever waited before the board started */
        (void)uart->data;
    *port = (hal_hil_port_t){.ctx = uart, .stream = 1, .send = uart_send, .recv = uart_recv};
    return 0;
}
