/* The kernel filter of hal_host_net_kfilter.h as an eBPF socket filter (SO_ATTACH_BPF) that
 * reads each filtered channel's wanted senders from an array map: the program is built and put
 * on the socket when the channels change, and a new wanted set is one map update. The classic
 * program holds the ids as constants, so every change of the set was a new program, checked and
 * compiled by the kernel's JIT again: 9 times per robot and round, 5 % of both cores with 64
 * robots on 2 (docs/scaling.md).
 *
 * Same decisions as the classic program, datagram by datagram, except that a rule has no
 * KFILTER_MAX_IDS limit. Needs Linux with bpf() allowed to the process (root or CAP_BPF where
 * kernel.unprivileged_bpf_disabled is set, as on Debian); every function says -errno otherwise,
 * and the caller keeps the classic program. Internal to hal_host_net_kfilter.c. */
#ifndef HAL_HOST_NET_KFILTER_EBPF_H
#define HAL_HOST_NET_KFILTER_EBPF_H

#include <stdint.h>

#include "hal_host_net_kfilter.h"

/* A new map for the wanted sets (one value of HAL_HOST_NET_SENDER_BYTES per rule, all
   senders off): its descriptor, or -errno (-EPERM: bpf() not allowed here; -ENOTSUP: not
   Linux). The caller closes it. */
int kfilter_ebpf_map(void);

/* Writes every rule's set into the map, then builds the program for rules[0..n) and
 * received[0..n_received) (as hal_host_net_kfilter_attach) and puts it on socket sock, in place
 * of any filter there. 0 or -errno (the socket keeps its filter on an error). */
int kfilter_ebpf_attach(int map_fd, int sock, const kfilter_rule_t *rules, uint32_t n,
                        const char (*received)[HAL_NET_CHANNEL_MAX], uint32_t n_received);

/* Rule `slot`'s wanted senders (HAL_HOST_NET_SENDER_BYTES, bit s: sender s) in the map: the
 * attached program reads them from the next datagram on. 0 or -errno. */
int kfilter_ebpf_set(int map_fd, uint32_t slot, const uint8_t *wanted);

#endif /* HAL_HOST_NET_KFILTER_EBPF_H */
