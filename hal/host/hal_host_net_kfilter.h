/* A kernel filter for an LCM udpm socket: the sender check of hal_host_net.c done by Linux
 * before the datagram is queued, so that an unwanted sender's datagram costs no copy into the
 * process and no wake-up of its receiver.
 *
 * Over LCM's one multicast group the kernel hands every member's datagram to every socket; a
 * robot that keeps its 32 nearest of 64 was handed 50 MB a round and kept 4 MB of it. A
 * classic BPF program (SO_ATTACH_FILTER) on the socket reads what hal_host_net.c reads on
 * arrival: an LCM short message (magic "LC02", sequence number, channel name and its NUL, the
 * payload), on a filtered channel, whose payload names its sender in bytes 8-11 (big-endian,
 * after the 8-byte fingerprint: hal_host_msg.h), and drops it when that sender is not
 * wanted. Given the channels the robot receives, it drops an LCM short message on any other
 * channel too (LCM would, after the copy). Everything else passes: fragments of long messages
 * (their first fragment alone names the channel), IP headers with options, and a channel whose
 * wanted set is too large for the program (KFILTER_MAX_IDS).
 *
 * Two differences from the check on arrival, both on datagrams it would drop too: a datagram
 * of a filtered channel too short to name its sender is dropped unseen (not counted invalid),
 * and so is the robot's own echo when it does not want itself (not counted as one).
 *
 * Linux only; elsewhere, and whenever a filter cannot be attached, hal_host_net.c's check on
 * arrival remains the filter (it runs whatever the kernel did).
 *
 * A socket's filter and what it holds is a hal_host_net_kfilter_t. Where the process may use
 * bpf() (root or CAP_BPF on Debian), the program is an eBPF one reading the wanted senders from
 * a map (hal_host_net_kfilter_ebpf.h): a new wanted set is then a map update, not a new program
 * compiled by the kernel. Elsewhere each change puts a new classic program
 * (hal_host_net_kfilter_attach). */
#ifndef HAL_HOST_NET_KFILTER_H
#define HAL_HOST_NET_KFILTER_H

#include <stdint.h>

#include "hal_host.h"
#include "hal_host_net_transport.h"

/* Filtered channels one program holds, and the wanted senders one channel may list (a jump of
   classic BPF reaches 255 instructions ahead). */
#define KFILTER_MAX_RULES 4u
#define KFILTER_MAX_IDS 200u
#define KFILTER_MAX_RECEIVED HAL_HOST_NET_MAX_SUBS

typedef struct kfilter_rule {
    char channel[HAL_NET_CHANNEL_MAX];
    uint8_t wanted[HAL_HOST_NET_SENDER_BYTES]; /* bit s: sender s kept */
} kfilter_rule_t;

/* Puts on socket fd the program for rules[0..n) and, when n_received > 0, the channels the
   socket's owner receives, received[0..n_received) (those of the rules among them): an LCM
   short message on any other channel is dropped, as LCM would drop it after the kernel's copy
   (over one group, what is for one robot alone, another robot's inbox, then costs the others
   nothing). n 0 and n_received 0: a program that passes everything. 0, -EINVAL (bad
   arguments), or -errno of setsockopt. A rule whose channel lists more than KFILTER_MAX_IDS
   senders is left out (its datagrams pass, when its channel is received). */
int hal_host_net_kfilter_attach(int fd, const kfilter_rule_t *rules, uint32_t n,
                                const char (*received)[HAL_NET_CHANNEL_MAX], uint32_t n_received);

typedef struct hal_host_net_kfilter {
    int fd;        /* the socket, or -1: nothing to filter */
    int ebpf;      /* 1: the eBPF program and its map; 0: not tried yet; -1: classic programs */
    int map_fd;    /* the eBPF program's wanted sets (hal_host_net_kfilter_ebpf.h), or -1 */
    int installed; /* the eBPF program for the current channels is on the socket */
    uint32_t n, n_received;
    kfilter_rule_t rule[KFILTER_MAX_RULES];
    char received[KFILTER_MAX_RECEIVED][HAL_NET_CHANNEL_MAX];
    uint32_t programs; /* programs put on the socket */
    uint32_t sets;     /* wanted sets changed in the eBPF map, with no new program */
} hal_host_net_kfilter_t;

/* Nothing on socket fd yet (-1: a transport without one). ebpf 0: classic programs only. */
void hal_host_net_kfilter_init(hal_host_net_kfilter_t *k, int fd, int ebpf);

/* The socket's owner receives `channel` from now on: short messages on channels it does not
   receive are dropped. 0, -ENOSPC (KFILTER_MAX_RECEIVED channels already: the filter stays as
   it was), or the error of putting the program (hal_host_net_kfilter_attach). */
int hal_host_net_kfilter_receive(hal_host_net_kfilter_t *k, const char *channel);

/* Channel's wanted senders (HAL_HOST_NET_SENDER_BYTES; NULL: all) from now on. A channel beyond
   KFILTER_MAX_RULES is left unfiltered (0). 0 or the error of putting the program or the set. */
int hal_host_net_kfilter_senders(hal_host_net_kfilter_t *k, const char *channel, const uint8_t *wanted);

/* The eBPF map (the socket keeps its program until it is closed). */
void hal_host_net_kfilter_close(hal_host_net_kfilter_t *k);

#endif /* HAL_HOST_NET_KFILTER_H */
