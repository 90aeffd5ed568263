/* The hardware-in-the-loop link's ports on a Cortex-M board (hal_stdc_hil.h), both polled:
 *   uart0 .. uart3  a CMSDK APB UART (the MPS2 boards' UARTs, which QEMU connects to its
 *                   -serial), a byte stream: frames go out back to back and come in through the
 *                   client's stream reader;
 *   eth0            the MPS2 boards' SMSC LAN9118 Ethernet controller (QEMU's -nic), one frame
 *                   per Ethernet frame of EtherType 0x88B5 (host_sim hil --link ether), given to
 *                   the same stream reader (it skips the padding of short Ethernet frames).
 *
 * The UART:
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

/* The link's timeouts count the time base, held or not (hal_stdc_target_hold). */
static uint64_t link_us(void)
{
    return hal_stdc_target_link_ns() / 1000u;
}

static int uart_send(void *ctx, const uint8_t *bytes, size_t n)
{
    cmsdk_uart_t *u = ctx;
    for (size_t i = 0; i < n; i++) {
        const uint64_t t0 = link_us();
        while (u->state & UART_STATE_TX_FULL)
            if (link_us() - t0 > TX_BYTE_TIMEOUT_US)
                return -EIO; /* the line does not drain: nobody reads the other end */
        u->data = bytes[i];
    }
    return 0;
}

static int uart_recv(void *ctx, uint8_t *buf, size_t cap, uint32_t timeout_us)
{
    cmsdk_uart_t *u = ctx;
    size_t n = 0;
    uint64_t last = link_us();
    const uint64_t deadline = last + timeout_us;
    while (n < cap) {
        if (u->state & UART_STATE_RX_FULL) {
            buf[n++] = (uint8_t)u->data;
            last = link_us();
            continue;
        }
        const uint64_t now = link_us();
        if (n > 0 ? now - last >= RX_GAP_US : now >= deadline)
            break;
    }
    u->state = UART_STATE_OVERRUNS; /* cleared: the stream reader finds its way after a lost byte */
    return (int)n;
}

static const char *kind = "serial";

const char *hal_stdc_hil_kind(void)
{
    return kind;
}

/* ---- the LAN9118 ---------------------------------------------------------------------------
 * Programmed as QEMU models it (hw/net/lan9118.c) and as SMSC's data sheet describes it: the
 * MAC's registers through MAC_CSR_CMD/DATA, a frame out as TX command A and B and its words
 * (bytes little-endian), a frame in as its RX status (length with the 4-byte FCS) and its
 * words. Promiscuous: the world's frames are picked by their EtherType. */
#ifdef BOARD_ETH_LAN9118_BASE
#define LAN_REG(off) (*(volatile uint32_t *)(BOARD_ETH_LAN9118_BASE + (off)))
#else
#define LAN_REG(off) (*(volatile uint32_t *)(off)) /* never reached: eth_open refuses first */
#endif
#define LAN_RX_DATA 0x00u
#define LAN_TX_DATA 0x20u
#define LAN_RX_STATUS 0x40u
#define LAN_BYTE_TEST 0x64u
#define LAN_RX_FIFO_INF 0x7Cu
#define LAN_TX_FIFO_INF 0x80u
#define LAN_HW_CFG 0x74u
#define LAN_TX_CFG 0x70u
#define LAN_PMT_CTRL 0x84u
#define LAN_MAC_CSR_CMD 0xA4u
#define LAN_MAC_CSR_DATA 0xA8u
#define LAN_MAC_CR 1u
#define LAN_MAC_ADDRH 2u
#define LAN_MAC_ADDRL 3u
#define LAN_MAC_CR_RXEN (1u << 2)
#define LAN_MAC_CR_TXEN (1u << 3)
#define LAN_MAC_CR_PRMS (1u << 18)
#define LAN_TX_ON (1u << 1)
#define LAN_TX_SAO (1u << 2) /* the TX status FIFO may overflow: nobody reads it */
#define ETHERTYPE_HIL 0x88B5u
#define ETH_HEADER 14u
#define ETH_FRAME_MAX 1514u
#define ETH_MIN_FRAME 60u
/* The receive data FIFO with the reset's 5 KB transmit FIFO (HW_CFG TX_FIF_SZ = 5). A frame that
   arrives when it is full is lost (QEMU drops it as the chip does): 3,251 datagrams sent to the
   board in an 8-round fleet, 2,062 received, when an answer could bring 16. So an answer brings
   no more than fit beside its SCAN and POSE, each frame at its largest (with the FCS). */
#define LAN_RX_DATA_FIFO_BYTES 10560u
#define ETH_FRAME_FIFO_BYTES (((ETH_FRAME_MAX + 4u + 3u) / 4u) * 4u)
#define ETH_ANSWER_DATAGRAMS (LAN_RX_DATA_FIFO_BYTES / ETH_FRAME_FIFO_BYTES - 2u)
_Static_assert(ETH_ANSWER_DATAGRAMS >= 1u, "an answer must bring a datagram");

/* How long eth_recv polls before it sleeps between looks (the time base's us). */
#define ETH_POLL_US 1000u

static struct {
    uint8_t mac[6], peer[6]; /* peer: the world's, once it spoke; broadcast until then */
    uint32_t words[(ETH_FRAME_MAX + 4u + 3u) / 4u];
} eth;

static uint32_t mac_read(uint32_t reg)
{
    LAN_REG(LAN_MAC_CSR_CMD) = 0xC0000000u | reg; /* busy, read */
    return LAN_REG(LAN_MAC_CSR_DATA);
}

static void mac_write(uint32_t reg, uint32_t v)
{
    LAN_REG(LAN_MAC_CSR_DATA) = v;
    LAN_REG(LAN_MAC_CSR_CMD) = 0x80000000u | reg;
}

static int eth_send(void *ctx, const uint8_t *bytes, size_t n)
{
    (void)ctx;
    if (ETH_HEADER + n > ETH_FRAME_MAX)
        return -EMSGSIZE;
    uint8_t *f = (uint8_t *)eth.words;
    memcpy(f, eth.peer, 6);
    memcpy(f + 6, eth.mac, 6);
    f[12] = (uint8_t)(ETHERTYPE_HIL >> 8);
    f[13] = (uint8_t)ETHERTYPE_HIL;
    memcpy(f + ETH_HEADER, bytes, n);
    size_t len = ETH_HEADER + n;
    for (; len < ETH_MIN_FRAME; len++)
        f[len] = 0;
    const uint32_t words = (uint32_t)(len + 3u) / 4u;
    if ((LAN_REG(LAN_TX_FIFO_INF) & 0xFFFFu) < 4u * (words + 2u))
        return -EIO; /* never with one frame at a time: the FIFO holds 4.5 KB */
    LAN_REG(LAN_TX_DATA) = (1u << 13) | (1u << 12) | (uint32_t)len; /* A: first and last segment, size */
    LAN_REG(LAN_TX_DATA) = (uint32_t)len;                             /* B: tag 0, length */
    for (uint32_t i = 0; i < words; i++)
        LAN_REG(LAN_TX_DATA) = eth.words[i];
    return 0;
}

static int eth_recv(void *ctx, uint8_t *buf, size_t cap, uint32_t timeout_us)
{
    (void)ctx;
    const uint64_t start = link_us(), deadline = start + timeout_us;
    for (;;) {
        /* Checked before every frame too: a flood of other frames ends the wait as a timeout. */
        const uint64_t now = link_us();
        if (now >= deadline)
            return 0;
        if (((LAN_REG(LAN_RX_FIFO_INF) >> 16) & 0xFFu) == 0) {
            /* Polled while an answer is due (the world's come within 0.4 ms of the time base),
               then asleep to the next SysTick: polling is the board's instructions under
               -icount, so a world that never answers made each 200 ms wait a second or more of
               the host's time; asleep, QEMU (sleep=on) lets it pass in real time. */
            if (now - start >= ETH_POLL_US)
                __asm__ volatile("wfi");
            continue;
        }
        const uint32_t len = (LAN_REG(LAN_RX_STATUS) >> 16) & 0x3FFFu; /* with the FCS */
        const uint32_t words = (len + 3u) / 4u;
        for (uint32_t i = 0; i < words; i++) {
            const uint32_t w = LAN_REG(LAN_RX_DATA);
            if (i < sizeof eth.words / 4u)
                eth.words[i] = w;
        }
        const uint8_t *f = (const uint8_t *)eth.words;
        if (len < ETH_HEADER + 4u || len > ETH_FRAME_MAX + 4u || (((uint32_t)f[12] << 8) | f[13]) != ETHERTYPE_HIL ||
            (f[6] & 1u))
            continue; /* not the world's */
        memcpy(eth.peer, f + 6, 6);
        size_t n = len - 4u - ETH_HEADER;
        if (n > cap)
            n = cap;
        memcpy(buf, f + ETH_HEADER, n);
        return (int)n;
    }
}

static int eth_open(hal_hil_port_t *port)
{
#ifndef BOARD_ETH_LAN9118_BASE
    fprintf(stderr, "hil: this board has no eth0 (its board.h names no BOARD_ETH_LAN9118_BASE)\n");
    return -EINVAL;
#endif
    if (LAN_REG(LAN_BYTE_TEST) != 0x87654321u) {
        fprintf(stderr, "hil: no LAN9118 answers at its address (this board has no eth0)\n");
        return -EIO;
    }
    LAN_REG(LAN_HW_CFG) = 1u; /* soft reset */
    const uint64_t t0 = link_us();
    while ((LAN_REG(LAN_HW_CFG) & 1u) || !(LAN_REG(LAN_PMT_CTRL) & 1u))
        if (link_us() - t0 > 100000u)
            return -EIO;
    const uint32_t lo = mac_read(LAN_MAC_ADDRL), hi = mac_read(LAN_MAC_ADDRH);
    for (int i = 0; i < 4; i++)
        eth.mac[i] = (uint8_t)(lo >> (8 * i));
    eth.mac[4] = (uint8_t)hi;
    eth.mac[5] = (uint8_t)(hi >> 8);
    memset(eth.peer, 0xFF, sizeof eth.peer);
    LAN_REG(LAN_TX_CFG) = LAN_TX_ON | LAN_TX_SAO;
    mac_write(LAN_MAC_CR, LAN_MAC_CR_RXEN | LAN_MAC_CR_TXEN | LAN_MAC_CR_PRMS);
    *port = (hal_hil_port_t){.ctx = NULL, .stream = 1, .send = eth_send, .recv = eth_recv,
                             .answer_datagrams_max = ETH_ANSWER_DATAGRAMS};
    return 0;
}

int hal_stdc_hil_open(const char *where, hal_hil_port_t *port)
{
    if (where != NULL && strcmp(where, "eth0") == 0) {
        kind = "ethernet";
        return eth_open(port);
    }
    const size_t count = sizeof uart_base / sizeof uart_base[0];
    if (where == NULL || strncmp(where, "uart", 4) != 0 || where[4] < '0' || where[4] >= (char)('0' + count) ||
        where[5] != '\0') {
        fprintf(stderr, "hil: '%s' is not a link of this board (uart0 .. uart%u, eth0)\n",
                where != NULL ? where : "", (unsigned)(count - 1u));
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
