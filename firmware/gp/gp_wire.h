/* The fleet's messages (the .lcm files of firmware/msg) in LCM's wire format, read and written
 * by the firmware's own code so that it never runs generated code on bytes from the network: an
 * 8-byte big-endian type fingerprint (the one lcm-gen computes; tests/gp/test_gp_wire.c checks
 * it), then the fields big-endian in declaration order, arrays as their elements. The layouts
 * and fingerprints come from the .lcm files themselves (tools/lcmgen.py writes them into the
 * build folder as msg/msg_layout.h): gp_wire.c walks those field tables, so a field declared
 * in a .lcm file is encoded and decoded with no edit here, given a member of the same name in
 * the gp_pse struct (or a MSG_<TYPE>_MEMBER_<field> mapping below).
 *
 * Decoders validate everything against the datagram's own length and the compile-time maxima
 * before they write their output: the fingerprint, every length field (non-negative, within
 * its maximum, exactly what is left), chunk < n_chunks, non-negative ids and rounds. They return
 * 0 or -EBADMSG, and leave the output untouched on failure; a decoded chunk's data points into
 * the datagram. The protocol's own checks (sender inside the fleet, round window, sizes equal
 * to the fleet's, finite positions) are gp_pse's. No allocation; thread-safe. */
#ifndef GP_GP_WIRE_H
#define GP_GP_WIRE_H

#include <stddef.h>
#include <stdint.h>

#include "gp/gp_goal.h"
#include "gp/gp_pse.h"

/* gp_pse_request_t calls chunk_request_t's n_chunks `n`; every other field is its member's name. */
#define MSG_CHUNK_REQUEST_MEMBER_n_chunks n
#include "msg/msg_layout.h"

#define GP_WIRE_FP_STATE_CHUNK MSG_STATE_CHUNK_FINGERPRINT
#define GP_WIRE_FP_ROUND_COMPLETE MSG_ROUND_COMPLETE_FINGERPRINT
#define GP_WIRE_FP_CHUNK_REQUEST MSG_CHUNK_REQUEST_FINGERPRINT
#define GP_WIRE_FP_GOAL_CLAIM MSG_GOAL_CLAIM_FINGERPRINT

/* Bytes of each message on the wire: a chunk's header (its data follows), a RoundComplete, a
 * request naming n chunks (4 bytes each: gp_wire.c checks the element size). */
#define GP_WIRE_CHUNK_HEADER_BYTES MSG_STATE_CHUNK_FIXED_BYTES
#define GP_WIRE_DONE_BYTES MSG_ROUND_COMPLETE_FIXED_BYTES
#define GP_WIRE_REQUEST_BYTES(n) (MSG_CHUNK_REQUEST_FIXED_BYTES + 4u * (uint32_t)(n))
/* An exploration claim (gp_goal.h): fixed size, 48 bytes (plus the keyed fleet's trailer). */
#define GP_WIRE_CLAIM_BYTES MSG_GOAL_CLAIM_FIXED_BYTES

/* Writes the message into buf: its length, or -EMSGSIZE when cap is too small. */
int gp_wire_encode_chunk(const gp_pse_chunk_t *c, uint8_t *buf, size_t cap);
int gp_wire_encode_done(const gp_pse_done_t *d, uint8_t *buf, size_t cap);
int gp_wire_encode_request(const gp_pse_request_t *r, uint8_t *buf, size_t cap);
int gp_wire_encode_claim(const gp_goal_claim_t *c, uint8_t *buf, size_t cap);

FS_MUST_CHECK int gp_wire_decode_chunk(const uint8_t *buf, size_t len, gp_pse_chunk_t *c);
FS_MUST_CHECK int gp_wire_decode_done(const uint8_t *buf, size_t len, gp_pse_done_t *d);
FS_MUST_CHECK int gp_wire_decode_request(const uint8_t *buf, size_t len, gp_pse_request_t *r);
/* A claim's own checks here: sender and seq non-negative, x_m, y_m, cost_m finite, cost_m >= 0,
 * expiry_us non-negative; the fleet's, the map's and the clock's are gp_goal_on_claim's. */
FS_MUST_CHECK int gp_wire_decode_claim(const uint8_t *buf, size_t len, gp_goal_claim_t *c);

#endif /* GP_GP_WIRE_H */
