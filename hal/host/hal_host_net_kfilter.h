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
 * arrival remains the filter (it runs whatever the kernel did). */
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

#endif /* HAL_HOST_NET_KFILTER_H */
