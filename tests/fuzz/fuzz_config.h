/* What the fuzz targets (tests/fuzz/fuzz_*.c) and their seed generator (tests/fuzz/gen_seeds.c)
 * agree on: the fleet the datagram target plays in, the framing of its inputs, and the model
 * the checkpoint target loads into. See tests/fuzz/README.md. */
#ifndef FUZZ_FUZZ_CONFIG_H
#define FUZZ_FUZZ_CONFIG_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* libFuzzer's entry points (LLVMFuzzerInitialize is optional: defined where a target needs it). */
int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* A broken promise: named on stderr, then abort() (libFuzzer keeps the input). */
#define CHECK(cond)                                                                            \
    do {                                                                                       \
        if (!(cond)) {                                                                         \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);          \
            abort();                                                                           \
        }                                                                                      \
    } while (0)

/* ---- fuzz_wire: one gp_pse engine, peer SELF of a fleet of PEERS ---------------------------
 * A state of STATE_BYTES in chunks of CHUNK_BYTES (3 chunks, the last shorter), so that the
 * fuzzer reaches a whole reassembled state; rounds 0 .. ROUNDS - 1, then the engine leaves. */
#define FUZZ_WIRE_PEERS 3u
#define FUZZ_WIRE_SELF 0u
#define FUZZ_WIRE_STATE_BYTES 2500u
#define FUZZ_WIRE_CHUNK_BYTES 1024u
#define FUZZ_WIRE_ROUNDS 6u
#define FUZZ_WIRE_RADIUS_M 6.0
#define FUZZ_WIRE_RESEND_US 50000u
#define FUZZ_WIRE_TIMEOUT_US 1000000u
#define FUZZ_WIRE_T0_US 1000000u
/* Every robot's state of a round: a pure function of (robot, round), so the seeds carry the
 * states the engine would reassemble and their CRC matches. */
static inline uint8_t fuzz_wire_state_byte(uint32_t robot, uint32_t round, uint32_t i)
{
    return (uint8_t)(i * 7u + robot * 31u + round * 101u);
}

/* An input is a sequence of records, each
 *   op      1 byte: bits 0-1 what (below), bits 2-7 d: the clock first advances d * d ms
 *   len     2 bytes big-endian, then len bytes: a datagram (what 0, 1, 2 only)
 * what = 0, 1, 2: a datagram received on the state, done or request channel (checked by
 * hal_host_msg_check for that channel's type, decoded by gp_wire, handed to the engine as
 * gp_fleet does); what = 3: a tick of the GP core (poll, then complete the round when the states
 * are ready, begin the next one when it finished, leave after the last). A truncated record
 * ends the input. */
#define FUZZ_WIRE_STATE 0u
#define FUZZ_WIRE_DONE 1u
#define FUZZ_WIRE_REQUEST 2u
#define FUZZ_WIRE_TICK 3u
#define FUZZ_WIRE_OP(what, d) ((uint8_t)((what) | (d) << 2))

/* ---- fuzz_ckpt: the smallest model bnn_init accepts with more than one unit per layer ----- */
#define FUZZ_CKPT_SIREN 2u
#define FUZZ_CKPT_HIDDEN 2u
#define FUZZ_CKPT_LAYERS 1u
#define FUZZ_CKPT_SEED 7u

#endif /* FUZZ_FUZZ_CONFIG_H */
