/* The kernel filter as an eBPF program whose wanted senders live in a map
 * (hal_host_net_kfilter_ebpf.h). */
#define _DEFAULT_SOURCE /* syscall() */
#include "hal_host_net_kfilter_ebpf.h"

#include <errno.h>
#include <string.h>

#if defined(__linux__)
#include <linux/bpf.h>
#include <linux/filter.h>
#include <pthread.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <unistd.h>

#ifndef SO_ATTACH_BPF
#define SO_ATTACH_BPF 50
#endif

/* What the program reads, as the classic program does (hal_host_net_kfilter.c): relative to
   the IP header, a 20-byte IP header, the UDP header, then LCM's magic, sequence number and
   channel. LD_ABS keeps classic BPF's meaning in eBPF, negative SKF_NET_OFF offsets included;
   a load past the datagram's end drops it, as in the classic program. */
#define AT(off) ((int32_t)(SKF_NET_OFF + 28 + (int32_t)(off)))
#define LCM_MAGIC_SHORT 0x4c433032u /* "LC02" */
#define KEY_AT (-4)                 /* the map key's place on the program's stack */

/* The header checks (6), per rule its channel (a load and a compare per word, per byte of the
   rest) and the sender's test (16), per channel received its compare and a jump; the two
   returns. */
#define CHANNEL_MAX_INS (2u * (HAL_NET_CHANNEL_MAX / 4u + 3u))
#define EPROG_MAX (6u + KFILTER_MAX_RULES * (CHANNEL_MAX_INS + 16u) + KFILTER_MAX_RECEIVED * (CHANNEL_MAX_INS + 1u) + 5u)
_Static_assert(EPROG_MAX <= 4096u, "within the kernel's smallest program limit");
_Static_assert(HAL_HOST_NET_SENDER_BYTES * 8u >= BOARD_MAX_FLEET, "a bit per sender in a map value");

enum { R0 = 0, R1, R2, R6 = 6, R7, R10 = 10 };
enum { TO_PASS, TO_DROP, TO_NEXT };

typedef struct eprog {
    struct bpf_insn ins[EPROG_MAX];
    uint32_t n;
    uint32_t jump[EPROG_MAX]; /* forward jumps still to point */
    uint8_t jump_to[EPROG_MAX];
    uint32_t n_jumps;
} eprog_t;

static void put(eprog_t *p, uint8_t code, uint8_t dst, uint8_t src, int16_t off, int32_t imm)
{
    p->ins[p->n++] = (struct bpf_insn){.code = code, .dst_reg = dst, .src_reg = src, .off = off, .imm = imm};
}

/* A jump whose target is a label below (PASS, DROP, or the next rule's start). */
static void put_jump(eprog_t *p, uint8_t code, uint8_t dst, int32_t imm, uint8_t to)
{
    p->jump[p->n_jumps] = p->n;
    p->jump_to[p->n_jumps++] = to;
    put(p, code, dst, 0, 0, imm);
}

/* Every pending jump to label `to` lands here. */
static void land(eprog_t *p, uint8_t to)
{
    uint32_t k = 0;
    for (uint32_t i = 0; i < p->n_jumps; i++) {
        if (p->jump_to[i] == to)
            p->ins[p->jump[i]].off = (int16_t)(p->n - p->jump[i] - 1u);
        else {
            p->jump[k] = p->jump[i];
            p->jump_to[k++] = p->jump_to[i];
        }
    }
    p->n_jumps = k;
}

static void put_load(eprog_t *p, uint8_t size, int32_t off)
{
    put(p, BPF_LD | BPF_ABS | size, 0, 0, 0, AT(off));
}

/* The channel's name and its NUL compared, a word at a time then a byte; a mismatch jumps to
   the next rule or channel. */
static void put_channel(eprog_t *p, const char *channel)
{
    const size_t len = strlen(channel) + 1u;
    size_t at = 0;
    for (; at + 4u <= len; at += 4u) {
        const uint8_t *c = (const uint8_t *)channel + at;
        put_load(p, BPF_W, 8 + (int32_t)at);
        const uint32_t word = (uint32_t)c[0] << 24 | (uint32_t)c[1] << 16 | (uint32_t)c[2] << 8 | c[3];
        put_jump(p, BPF_JMP32 | BPF_JNE | BPF_K, R0, (int32_t)word, TO_NEXT);
    }
    for (; at < len; at++) {
        put_load(p, BPF_B, 8 + (int32_t)at);
        put_jump(p, BPF_JMP | BPF_JNE | BPF_K, R0, (uint8_t)channel[at], TO_NEXT);
    }
}

/* Rule `slot`: its channel, then its sender's bit in the map's value `slot`. */
static void put_rule(eprog_t *p, const char *channel, uint32_t slot, int map_fd)
{
    put_channel(p, channel);
    put_load(p, BPF_W, 8 + (int32_t)strlen(channel) + 1 + 8); /* the sender, after the fingerprint */
    put_jump(p, BPF_JMP | BPF_JGE | BPF_K, R0, (int32_t)BOARD_MAX_FLEET, TO_DROP);
    put(p, BPF_ALU64 | BPF_MOV | BPF_X, R7, R0, 0, 0);
    put(p, BPF_ST | BPF_MEM | BPF_W, R10, 0, KEY_AT, (int32_t)slot);
    put(p, BPF_LD | BPF_DW | BPF_IMM, R1, BPF_PSEUDO_MAP_FD, 0, map_fd); /* two instructions */
    put(p, 0, 0, 0, 0, 0);
    put(p, BPF_ALU64 | BPF_MOV | BPF_X, R2, R10, 0, 0);
    put(p, BPF_ALU64 | BPF_ADD | BPF_K, R2, 0, 0, KEY_AT);
    put(p, BPF_JMP | BPF_CALL, 0, 0, 0, BPF_FUNC_map_lookup_elem);
    put_jump(p, BPF_JMP | BPF_JEQ | BPF_K, R0, 0, TO_DROP);
    put(p, BPF_ALU64 | BPF_MOV | BPF_X, R1, R7, 0, 0);
    put(p, BPF_ALU64 | BPF_RSH | BPF_K, R1, 0, 0, 3);
    put(p, BPF_ALU64 | BPF_ADD | BPF_X, R0, R1, 0, 0);
    put(p, BPF_LDX | BPF_MEM | BPF_B, R0, R0, 0, 0);
    put(p, BPF_ALU64 | BPF_AND | BPF_K, R7, 0, 0, 7);
    put(p, BPF_ALU64 | BPF_RSH | BPF_X, R0, R7, 0, 0);
    put(p, BPF_ALU64 | BPF_AND | BPF_K, R0, 0, 0, 1);
    put_jump(p, BPF_JMP | BPF_JEQ | BPF_K, R0, 0, TO_DROP);
    put_jump(p, BPF_JMP | BPF_JA, 0, 0, TO_PASS);
    land(p, TO_NEXT);
}

static void build(eprog_t *p, const kfilter_rule_t *rules, uint32_t n, const char (*received)[HAL_NET_CHANNEL_MAX],
                  uint32_t n_received, int map_fd)
{
    p->n = p->n_jumps = 0;
    put(p, BPF_ALU64 | BPF_MOV | BPF_X, R6, R1, 0, 0); /* LD_ABS reads the packet of R6 */
    put_load(p, BPF_B, -28);                            /* the IP header's first byte */
    put(p, BPF_ALU64 | BPF_AND | BPF_K, R0, 0, 0, 0x0f);
    put_jump(p, BPF_JMP | BPF_JNE | BPF_K, R0, 5, TO_PASS); /* IP options: pass */
    put_load(p, BPF_W, 0);
    put_jump(p, BPF_JMP32 | BPF_JNE | BPF_K, R0, (int32_t)LCM_MAGIC_SHORT, TO_PASS); /* a fragment, not LCM */
    for (uint32_t i = 0; i < n; i++)
        put_rule(p, rules[i].channel, i, map_fd);
    for (uint32_t i = 0; i < n_received; i++) {
        put_channel(p, received[i]);
        put_jump(p, BPF_JMP | BPF_JA, 0, 0, TO_PASS);
        land(p, TO_NEXT);
    }
    put_jump(p, BPF_JMP | BPF_JA, 0, 0, n_received > 0 ? TO_DROP : TO_PASS); /* a channel not received */
    land(p, TO_PASS);
    put(p, BPF_ALU | BPF_MOV | BPF_K, R0, 0, 0, -1); /* 0xffffffff: the whole datagram */
    put(p, BPF_JMP | BPF_EXIT, 0, 0, 0, 0);
    land(p, TO_DROP);
    put(p, BPF_ALU64 | BPF_MOV | BPF_K, R0, 0, 0, 0);
    put(p, BPF_JMP | BPF_EXIT, 0, 0, 0, 0);
}

static int sys_bpf(int cmd, union bpf_attr *a)
{
    const long r = syscall(__NR_bpf, cmd, a, sizeof *a);
    return r < 0 ? -errno : (int)r;
}

int kfilter_ebpf_map(void)
{
    union bpf_attr a;
    memset(&a, 0, sizeof a);
    a.map_type = BPF_MAP_TYPE_ARRAY;
    a.key_size = sizeof(uint32_t);
    a.value_size = (uint32_t)HAL_HOST_NET_SENDER_BYTES;
    a.max_entries = KFILTER_MAX_RULES;
    return sys_bpf(BPF_MAP_CREATE, &a);
}

int kfilter_ebpf_attach(int map_fd, int sock, const kfilter_rule_t *rules, uint32_t n,
                        const char (*received)[HAL_NET_CHANNEL_MAX], uint32_t n_received)
{
    if (map_fd < 0 || n > KFILTER_MAX_RULES || n_received > KFILTER_MAX_RECEIVED)
        return -EINVAL;
    /* The sets first: the new program reads them from its first datagram on. */
    for (uint32_t i = 0; i < n; i++) {
        const int r = kfilter_ebpf_set(map_fd, i, rules[i].wanted);
        if (r != 0)
            return r;
    }
    /* One program under construction in the process (a static: not on the caller's stack). */
    static pthread_mutex_t mu = PTHREAD_MUTEX_INITIALIZER;
    static eprog_t p;
    pthread_mutex_lock(&mu);
    build(&p, rules, n, received, n_received, map_fd);
    union bpf_attr a;
    memset(&a, 0, sizeof a);
    a.prog_type = BPF_PROG_TYPE_SOCKET_FILTER;
    a.insns = (uint64_t)(uintptr_t)p.ins;
    a.insn_cnt = p.n;
    a.license = (uint64_t)(uintptr_t) ""; /* no GPL-only helper is called */
    const int prog = sys_bpf(BPF_PROG_LOAD, &a);
    pthread_mutex_unlock(&mu);
    if (prog < 0)
        return prog;
    int rc = setsockopt(sock, SOL_SOCKET, SO_ATTACH_BPF, &prog, sizeof prog) == 0 ? 0 : -errno;
    /* The socket holds the program now (or kept its old one): ours is not needed either way. */
    close(prog);
    return rc;
}

int kfilter_ebpf_set(int map_fd, uint32_t slot, const uint8_t *wanted)
{
    if (map_fd < 0 || slot >= KFILTER_MAX_RULES)
        return -EINVAL;
    union bpf_attr a;
    memset(&a, 0, sizeof a);
    a.map_fd = (uint32_t)map_fd;
    a.key = (uint64_t)(uintptr_t)&slot;
    a.value = (uint64_t)(uintptr_t)wanted;
    a.flags = BPF_ANY;
    return sys_bpf(BPF_MAP_UPDATE_ELEM, &a);
}
#else
int kfilter_ebpf_map(void)
{
    return -ENOTSUP;
}

int kfilter_ebpf_attach(int map_fd, int sock, const kfilter_rule_t *rules, uint32_t n,
                        const char (*received)[HAL_NET_CHANNEL_MAX], uint32_t n_received)
{
    (void)e, (void)sock, (void)rules, (void)n, (void)received, (void)n_received;
    return -ENOTSUP;
}

int kfilter_ebpf_set(int map_fd, uint32_t slot, const uint8_t *wanted)
{
    (void)e, (void)slot, (void)wanted;
    return -ENOTSUP;
}
#endif
