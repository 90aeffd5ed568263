/* The fleet's messages (the .lcm files of firmware/msg) in LCM's wire format, written and read
 * by hand so that the firmware never runs generated code on bytes from the network: an 8-byte
 * big-endian
 * type fingerprint (the one lcm-gen computes; tests/gp/test_gp_wire.c checks it), then the
 * fields big-endian in declaration order, arrays as their elements.
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

#include "gp/gp_pse.h"

#define GP_WIRE_FP_STATE_CHUNK 0xdf65602b2d04bf15ull
#define GP_WIRE_FP_ROUND_COMPLETE 0x9ec25daeb3a35535ull
#define GP_WIRE_FP_CHUNK_REQUEST 0x2765123cb5b82f65ull

/* Bytes of each message on the wire. */
#define GP_WIRE_CHUNK_HEADER_BYTES (8u + 8u * 4u + 1u + 2u * 8u)
#define GP_WIRE_DONE_BYTES (8u + 3u * 4u)
#define GP_WIRE_REQUEST_BYTES(n) (8u + 5u * 4u + 4u * (uint32_t)(n))

/* Writes the message into buf: its length, or -EMSGSIZE when cap is too small. */
int gp_wire_encode_chunk(const gp_pse_chunk_t *c, uint8_t *buf, size_t cap);
int gp_wire_encode_done(const gp_pse_done_t *d, uint8_t *buf, size_t cap);
int gp_wire_encode_request(const gp_pse_request_t *r, uint8_t *buf, size_t cap);

FS_MUST_CHECK int gp_wire_decode_chunk(const uint8_t *buf, size_t len, gp_pse_chunk_t *c);
FS_MUST_CHECK int gp_wire_decode_done(const uint8_t *buf, size_t len, gp_pse_done_t *d);
FS_MUST_CHECK int gp_wire_decode_request(const uint8_t *buf, size_t len, gp_pse_request_t *r);

#endif /* GP_GP_WIRE_H */
