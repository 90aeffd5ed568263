/* Cost of a keyed fleet's datagram MAC (hal/host/hal_host_auth.h, XChaCha20-Poly1305:
 * libsodium, OpenSSL's Poly1305 for long datagrams) on this CPU: sealing and checking full-size
 * state chunks and 20-byte RoundCompletes, and what that makes per DiNNO round for one robot of
 * a 7-robot fleet of the build's preset (its own state sealed once, six neighbours' states
 * checked; fp32 and int8). And the other check every received state goes through, its CRC-32
 * (firmware/common/crc32.h), over one fp32 state in the cache.
 *
 *   bench_auth [--mb N] [--help]      (N: MB of chunks per measurement, 1..4096, default 256)
 * Prints `BENCH <name> <value> <unit>` lines. The fleet's round time keyed against unkeyed, in
 * the same run, is tools/bench/bench_fleet.py's. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ai/dinno_codec.h"
#include "common/crc32.h"
#include "gp/gp_fleet.h"
#include "gp/gp_pse.h"
#include "hal/hal.h"
#include "hal_host_auth.h"

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static uint8_t wire[HAL_NET_MTU_BYTES + HAL_HOST_AUTH_TRAILER_BYTES];

/* Seconds per datagram of `len` message bytes: seal (open = 0) or check (open = 1). */
static double per_datagram(const hal_host_auth_t *a, size_t len, uint64_t count, int open)
{
    hal_host_auth_seal(a, "fleetsim/0/state", wire, len);
    uint64_t ok = 0;
    const double t0 = now_s();
    for (uint64_t i = 0; i < count; i++) {
        if (open) {
            size_t n = 0;
            ok += hal_host_auth_open(a, "fleetsim/0/state", wire, len + HAL_HOST_AUTH_TRAILER_BYTES, &n) ==
                  HAL_HOST_AUTH_OK;
        } else {
            wire[i % len] ^= 1u; /* a new message each time, as a robot's chunks are */
            hal_host_auth_seal(a, "fleetsim/0/state", wire, len);
            ok++;
        }
    }
    const double dt = now_s() - t0;
    if (ok != count) {
        fprintf(stderr, "bench_auth: a sealed datagram did not check (%llu of %llu)\n", (unsigned long long)ok,
                (unsigned long long)count);
        exit(1);
    }
    return dt / (double)count;
}

/* GB/s of CRC-32 over `bytes` of a state, `reps` times (the same bytes: in the cache, as a
   state just reassembled is). */
static double crc_gb_per_s(uint32_t bytes, uint64_t reps)
{
    static uint8_t state[GP_PSE_MAX_STATE_BYTES];
    for (size_t i = 0; i < bytes; i++)
        state[i] = (uint8_t)(i * 29u + 7u);
    uint32_t sum = 0;
    const double t0 = now_s();
    for (uint64_t i = 0; i < reps; i++) {
        state[i % bytes] ^= 1u; /* not the same input twice */
        sum ^= crc32_ieee(state, bytes);
    }
    const double dt = now_s() - t0;
    if (sum == 0x5a5a5a5au) /* keeps the loop; a value the XOR of CRCs hardly takes */
        fprintf(stderr, "bench_auth: (crc sum %08x)\n", (unsigned)sum);
    return (double)bytes * (double)reps / dt / 1e9;
}

/* Seconds to seal (open = 0) or check one whole state of `bytes` in chunks of the fleet's size. */
static double per_state(double chunk_s, double tail_s, uint32_t bytes)
{
    const uint32_t full = bytes / GP_PSE_MAX_CHUNK_BYTES;
    return (double)full * chunk_s + (bytes % GP_PSE_MAX_CHUNK_BYTES ? tail_s : 0.0);
}

int main(int argc, char **argv)
{
    unsigned long long mb = 256;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            printf("usage: %s [--mb N]\n"
                   "  Seals and checks N MB of full-size state chunks (1..4096, default 256) and as many\n"
                   "  RoundComplete-sized datagrams with the keyed fleet's MAC, and prints the cost per MB,\n"
                   "  per datagram and per DiNNO round of one robot among 7; then CRC-32 over one fp32\n"
                   "  state (as much again), the other check of every received state.\n",
                   argv[0]);
            return 0;
        }
        if (strcmp(argv[i], "--mb") == 0 && i + 1 < argc) {
            char *end = NULL;
            errno = 0;
            mb = strtoull(argv[++i], &end, 10);
            if (errno != 0 || end == argv[i] || *end != '\0' || mb < 1 || mb > 4096) {
                fprintf(stderr, "bench_auth: --mb wants an integer in 1..4096\n");
                return 2;
            }
            continue;
        }
        fprintf(stderr, "bench_auth: unknown argument '%s' (see --help)\n", argv[i]);
        return 2;
    }
    if (hal_host_auth_init() != 0) {
        fprintf(stderr, "bench_auth: libsodium cannot start\n");
        return 1;
    }
    hal_host_auth_t a;
    for (size_t i = 0; i < sizeof a.key; i++)
        a.key[i] = (uint8_t)(i * 37u + 1u);
    a.run_id = 0x0123456789abcdefull;
    for (size_t i = 0; i < sizeof wire; i++)
        wire[i] = (uint8_t)(i * 13u);
    const size_t chunk = GP_PSE_MAX_CHUNK_BYTES;
    const uint64_t n = mb * 1024u * 1024u / chunk;
    const double seal = per_datagram(&a, chunk, n, 0), open = per_datagram(&a, chunk, n, 1);
    const double small_seal = per_datagram(&a, 20, n * 16u, 0), small_open = per_datagram(&a, 20, n * 16u, 1);
    printf("BENCH auth_seal_mb_per_s %.0f MB/s\n", (double)chunk / seal / 1048576.0);
    printf("BENCH auth_check_mb_per_s %.0f MB/s\n", (double)chunk / open / 1048576.0);
    printf("BENCH auth_seal_us_per_chunk %.1f us (%zu B)\n", seal * 1e6, chunk);
    printf("BENCH auth_check_us_per_chunk %.1f us (%zu B)\n", open * 1e6, chunk);
    printf("BENCH auth_seal_us_per_small %.2f us (20 B, a RoundComplete)\n", small_seal * 1e6);
    printf("BENCH auth_check_us_per_small %.2f us (20 B)\n", small_open * 1e6);
    const dinno_codec_t enc[2] = {DINNO_CODEC_FP32, DINNO_CODEC_INT8};
    for (int e = 0; e < 2; e++) {
        const uint32_t sb = gp_fleet_state_bytes(enc[e]);
        const size_t tail = sb % chunk ? sb % chunk : chunk;
        const double tail_seal = per_datagram(&a, tail, n / 4u + 1u, 0), tail_open = per_datagram(&a, tail, n / 4u + 1u, 1);
        /* One robot of 7 in a round: its state sealed, six states checked, 7 x 2 RoundCompletes. */
        const double round = per_state(seal, tail_seal, sb) + 6.0 * per_state(open, tail_open, sb) +
                             7.0 * small_seal + 12.0 * small_open;
        printf("BENCH auth_us_per_round_%s_%s_7robots %.0f us (state %u B)\n", BNN_PRESET_NAME, dinno_codec_name(enc[e]), round * 1e6,
               (unsigned)sb);
    }
    const uint32_t sb = gp_fleet_state_bytes(DINNO_CODEC_FP32);
    printf("BENCH crc32_gb_per_s %.1f GB/s (a %u B fp32 state in the cache)\n",
           crc_gb_per_s(sb, n * chunk / sb + 1u), (unsigned)sb);
    hal_host_auth_wipe(&a);
    return 0;
}
