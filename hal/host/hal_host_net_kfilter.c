/* The kernel filter of an LCM udpm socket (hal_host_net_kfilter.h). */
#define _DEFAULT_SOURCE /* SO_ATTACH_FILTER */
#include "hal_host_net_kfilter.h"
#include "hal_host_net_kfilter_ebpf.h"

#include <errno.h>
#include <stdio.h>
#include <unistd.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#if defined(__linux__)
#include <linux/filter.h>
#endif

#if defined(__linux__)
/* Where the filter reads: relative to the IP header (SKF_NET_OFF), so that it does not depend
   on where the socket layer has the packet start; a 20-byte IP header (checked), the 8-byte
   UDP header, then LCM's: magic (4), sequence number (4), the channel. */
#define AT(off) ((uint32_t)(SKF_NET_OFF + 28 + (off)))
#define LCM_MAGIC_SHORT 0x4c433032u /* "LC02" */
#define PASS 0xffffffffu
/* The header checks (7), per rule its channel (a load and a compare per word, per byte of the
   rest: the jump past a rule must stay within 255), its sender's load, ids and two returns;
   the final return. */
#define RULE_MAX (2u * (HAL_NET_CHANNEL_MAX / 4u + 3u) + 1u + KFILTER_MAX_IDS + 2u)
_Static_assert(RULE_MAX <= 255u, "a classic BPF jump reaches 255 instructions ahead");
#define RECEIVED_MAX (2u * (HAL_NET_CHANNEL_MAX / 4u + 3u) + 1u)
#define PROG_MAX (7u + KFILTER_MAX_RULES * RULE_MAX + KFILTER_MAX_RECEIVED * RECEIVED_MAX + 1u)
_Static_assert(PROG_MAX <= 4096u, "a classic BPF program holds 4,096 instructions (BPF_MAXINSNS)");

typedef struct prog {
    struct sock_filter ins[PROG_MAX];
    uint32_t n;
} prog_t;

static void put(prog_t *p, uint16_t code, uint8_t jt, uint8_t jf, uint32_t k)
{
    p->ins[p->n++] = (struct sock_filter){code, jt, jf, k};
}

/* The channel's name and its NUL compared, a word at a time then a byte: the compares' places
   into mism (the caller points their mismatch jumps); returns with the match's path next. */
static void put_channel(prog_t *p, const char *channel, uint32_t *mism, uint32_t *n_mism)
{
    const size_t len = strlen(channel) + 1u; /* the NUL is on the wire */
    size_t at = 0;
    for (; at + 4u <= len; at += 4u) {
        const uint8_t *c = (const uint8_t *)channel + at;
        put(p, BPF_LD | BPF_W | BPF_ABS, 0, 0, AT(8u + at));
        mism[(*n_mism)++] = p->n;
        put(p, BPF_JMP | BPF_JEQ | BPF_K, 0, 0, (uint32_t)c[0] << 24 | (uint32_t)c[1] << 16 | (uint32_t)c[2] << 8 | c[3]);
    }
    for (; at < len; at++) {
        put(p, BPF_LD | BPF_B | BPF_ABS, 0, 0, AT(8u + at));
        mism[(*n_mism)++] = p->n;
        put(p, BPF_JMP | BPF_JEQ | BPF_K, 0, 0, (uint32_t)(uint8_t)channel[at]);
    }
}

/* The mismatch jumps of mism to here. */
static void point_here(prog_t *p, const uint32_t *mism, uint32_t n_mism)
{
    for (uint32_t i = 0; i < n_mism; i++)
        p->ins[mism[i]].jf = (uint8_t)(p->n - mism[i] - 1u);
}

/* One rule: the channel compared (a mismatch jumps to the next rule), the sender compared with
   every wanted id (a match jumps to the rule's pass), else drop. */
static void put_rule(prog_t *p, const kfilter_rule_t *r, const uint32_t *ids, uint32_t n_ids)
{
    uint32_t mism[HAL_NET_CHANNEL_MAX], n_mism = 0;
    put_channel(p, r->channel, mism, &n_mism);
    put(p, BPF_LD | BPF_W | BPF_ABS, 0, 0, AT(8u + strlen(r->channel) + 1u + 8u)); /* the sender, after the fingerprint */
    for (uint32_t i = 0; i < n_ids; i++)
        put(p, BPF_JMP | BPF_JEQ | BPF_K, (uint8_t)(n_ids - i), 0, ids[i]); /* to this rule's pass */
    put(p, BPF_RET | BPF_K, 0, 0, 0);    /* an unwanted sender: dropped */
    put(p, BPF_RET | BPF_K, 0, 0, PASS); /* a wanted one */
    point_here(p, mism, n_mism);
}

/* A channel received: its message passes (a mismatch jumps to the next). */
static void put_received(prog_t *p, const char *channel)
{
    uint32_t mism[HAL_NET_CHANNEL_MAX], n_mism = 0;
    put_channel(p, channel, mism, &n_mism);
    put(p, BPF_RET | BPF_K, 0, 0, PASS);
    point_here(p, mism, n_mism);
}

int hal_host_net_kfilter_attach(int fd, const kfilter_rule_t *rules, uint32_t n,
                                const char (*received)[HAL_NET_CHANNEL_MAX], uint32_t n_received)
{
    if (fd < 0 || (n > 0 && rules == NULL) || n > KFILTER_MAX_RULES || (n_received > 0 && received == NULL) ||
        n_received > KFILTER_MAX_RECEIVED)
        return -EINVAL;
    for (uint32_t i = 0; i < n; i++)
        if (!hal_net_channel_valid(rules[i].channel))
            return -EINVAL;
    for (uint32_t i = 0; i < n_received; i++)
        if (!hal_net_channel_valid(received[i]))
            return -EINVAL;
    /* One program under construction in the process (13 KB, a static: not on the caller's stack
       nor in every thread's TLS); the kernel copies it at attach. */
    static pthread_mutex_t mu = PTHREAD_MUTEX_INITIALIZER;
    static prog_t p;
    pthread_mutex_lock(&mu);
    p.n = 0;
    put(&p, BPF_LD | BPF_B | BPF_ABS, 0, 0, (uint32_t)SKF_NET_OFF); /* version and header length */
    put(&p, BPF_ALU | BPF_AND | BPF_K, 0, 0, 0x0fu);
    put(&p, BPF_JMP | BPF_JEQ | BPF_K, 1, 0, 5u); /* 20 bytes: on; options: pass */
    put(&p, BPF_RET | BPF_K, 0, 0, PASS);
    put(&p, BPF_LD | BPF_W | BPF_ABS, 0, 0, AT(0));
    put(&p, BPF_JMP | BPF_JEQ | BPF_K, 1, 0, LCM_MAGIC_SHORT); /* a fragment or not LCM: pass */
    put(&p, BPF_RET | BPF_K, 0, 0, PASS);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t ids[KFILTER_MAX_IDS], n_ids = 0;
        int too_many = 0;
        for (uint32_t s = 0; s < BOARD_MAX_FLEET && !too_many; s++)
            if (rules[i].wanted[s / 8u] & (1u << (s % 8u))) {
                if (n_ids == KFILTER_MAX_IDS)
                    too_many = 1;
                else
                    ids[n_ids++] = s;
            }
        if (!too_many)
            put_rule(&p, &rules[i], ids, n_ids);
    }
    for (uint32_t i = 0; i < n_received; i++)
        put_received(&p, received[i]);
    put(&p, BPF_RET | BPF_K, 0, 0, n_received > 0 ? 0u : PASS); /* a channel not received: dropped */
    const struct sock_fprog f = {.len = (unsigned short)p.n, .filter = p.ins};
    const int rc = setsockopt(fd, SOL_SOCKET, SO_ATTACH_FILTER, &f, sizeof f) == 0 ? 0 : -errno;
    pthread_mutex_unlock(&mu);
    return rc;
}
#else
int hal_host_net_kfilter_attach(int fd, const kfilter_rule_t *rules, uint32_t n,
                                const char (*received)[HAL_NET_CHANNEL_MAX], uint32_t n_received)
{
    (void)fd;
    (void)rules;
    (void)n;
    (void)received;
    (void)n_received;
    return -ENOTSUP;
}
#endif

void hal_host_net_kfilter_init(hal_host_net_kfilter_t *k, int fd, int ebpf)
{
    memset(k, 0, sizeof *k);
    k->fd = fd;
    k->ebpf = ebpf ? 0 : -1;
    k->map_fd = -1;
}

/* The program for the rules and channels now: eBPF when it can be (tried once; a refusal, or a
   program the kernel will not take, leaves classic programs for good), else classic. */
static int put_program(hal_host_net_kfilter_t *k)
{
    if (k->fd < 0)
        return 0;
    if (k->ebpf == 0) {
        k->map_fd = kfilter_ebpf_map();
        k->ebpf = k->map_fd >= 0 ? 1 : -1;
    }
    k->installed = 0;
    if (k->ebpf == 1) {
        if (kfilter_ebpf_attach(k->map_fd, k->fd, k->rule, k->n, k->received, k->n_received) == 0) {
            k->installed = 1;
            k->programs++;
            return 0;
        }
        close(k->map_fd);
        k->map_fd = -1;
        k->ebpf = -1;
    }
    const int rc = hal_host_net_kfilter_attach(k->fd, k->rule, k->n, k->received, k->n_received);
    k->programs += rc == 0;
    return rc;
}

int hal_host_net_kfilter_receive(hal_host_net_kfilter_t *k, const char *channel)
{
    if (k == NULL || !hal_net_channel_valid(channel))
        return -EINVAL;
    if (k->n_received == KFILTER_MAX_RECEIVED)
        return -ENOSPC;
    snprintf(k->received[k->n_received++], sizeof k->received[0], "%s", channel);
    return put_program(k);
}

int hal_host_net_kfilter_senders(hal_host_net_kfilter_t *k, const char *channel, const uint8_t *wanted)
{
    if (k == NULL || !hal_net_channel_valid(channel))
        return -EINVAL;
    uint32_t i = 0;
    while (i < k->n && strcmp(k->rule[i].channel, channel) != 0)
        i++;
    if (wanted != NULL && i < k->n) { /* a new set of a channel the program knows */
        memcpy(k->rule[i].wanted, wanted, sizeof k->rule[i].wanted);
        if (k->installed) {
            const int rc = kfilter_ebpf_set(k->map_fd, i, wanted);
            k->sets += rc == 0;
            return rc;
        }
        return put_program(k);
    }
    if (wanted == NULL && i == k->n)
        return 0; /* unfiltered already */
    if (wanted == NULL) /* every sender: the channel's rule goes */
        k->rule[i] = k->rule[--k->n];
    else if (k->n == KFILTER_MAX_RULES)
        return 0; /* left unfiltered */
    else {
        snprintf(k->rule[i].channel, sizeof k->rule[i].channel, "%s", channel);
        memcpy(k->rule[i].wanted, wanted, sizeof k->rule[i].wanted);
        k->n++;
    }
    return put_program(k);
}

void hal_host_net_kfilter_close(hal_host_net_kfilter_t *k)
{
    if (k == NULL)
        return;
    if (k->map_fd >= 0)
        close(k->map_fd);
    k->map_fd = -1;
}
