/* The one bounds check every received fleet datagram passes before anything decodes it.
 *
 * The C decoders lcm-gen 1.3.1 generates trust the length fields of a message: a state chunk
 * with n_bytes = -1 crashes them and n_chunks = INT_MAX reads past the buffer. So hal/host
 * walks the LCM encoding of the message types of firmware/msg/ itself (8-byte big-endian type
 * fingerprint, then the fields big-endian in declaration order, arrays as their elements)
 * from the field tables tools/lcmgen.py derives from the .lcm files (msg/msg_layout.h, the
 * ones gp_wire uses), and accepts a datagram only when its fingerprint is the
 * expected type's, every length field is within 0 .. the compile-time maximum, and the fields
 * end exactly at the end of the datagram. A channel declared typed
 * (hal_host_net_expect_type) drops and counts anything else (hal_net_stats_t
 * rx_dropped_malformed), so a generated decoder only ever sees well-formed bytes.
 * Stateless and thread-safe. */
#ifndef HAL_HOST_MSG_H
#define HAL_HOST_MSG_H

#include <stddef.h>
#include <stdint.h>

typedef enum hal_host_msg_type {
    HAL_HOST_MSG_ANY = 0,          /* raw bytes: no check (e.g. telemetry, own codec) */
    HAL_HOST_MSG_STATE_CHUNK,      /* fleetsim.state_chunk_t */
    HAL_HOST_MSG_ROUND_COMPLETE,   /* fleetsim.round_complete_t */
    HAL_HOST_MSG_CHUNK_REQUEST,    /* fleetsim.chunk_request_t */
    HAL_HOST_MSG_GOAL_CLAIM,       /* fleetsim.goal_claim_t (gp_goal.h's exploration claims) */
    HAL_HOST_MSG_TYPE_COUNT
} hal_host_msg_type_t;

/* Why a datagram was refused (for counters and logs). */
typedef enum hal_host_msg_reject {
    HAL_HOST_MSG_OK = 0,
    HAL_HOST_MSG_SHORT,        /* shorter than its fields say */
    HAL_HOST_MSG_FINGERPRINT,  /* not the expected type */
    HAL_HOST_MSG_BAD_LENGTH,   /* a length field negative or over its maximum */
    HAL_HOST_MSG_TRAILING      /* bytes after the last field */
} hal_host_msg_reject_t;

/* Checks `len` bytes as a message of `type`: HAL_HOST_MSG_OK or the reason. */
hal_host_msg_reject_t hal_host_msg_check(hal_host_msg_type_t type, const void *data, size_t len);

const char *hal_host_msg_reject_name(hal_host_msg_reject_t r);

#endif /* HAL_HOST_MSG_H */
