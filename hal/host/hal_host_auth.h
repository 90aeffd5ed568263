/* Fleet membership on the host network: a MAC on every datagram, checked before the bounds
 * check and before anything decodes the bytes.
 *
 * Why a MAC and not encryption: what the fleet must protect is who may speak (membership) and
 * that what arrives is what a member sent (integrity, replays); a floor plan's occupancy is
 * not secret enough to pay for encryption and lose lcm-spy/lcm-logger on the wire. The
 * messages stay readable LCM; the trailer makes them unforgeable.
 *
 * Wire: the message as the firmware wrote it, then a 48-byte trailer
 *     run id (8 bytes, big-endian) | nonce (24 bytes, random per datagram) | tag (16 bytes)
 *     channel key = BLAKE2b-256(key; channel | 0x00)
 *     tag = XChaCha20-Poly1305(channel key, nonce; no plaintext, associated data message | run id)
 * The IETF XChaCha20-Poly1305 AEAD with an empty plaintext: its tag over the associated
 * data, a standard one-pass MAC. A robot checks every datagram of its neighbours (about 5 MB a
 * round in a fleet of 64 at `small` fp32), so its speed is a round's: libsodium computes it,
 * and OpenSSL's Poly1305 the long datagrams' (the same tag, 1.7x faster on a Zen 5). The
 * 192-bit nonce is drawn at random for every datagram, so no (key, nonce) pair repeats,
 * whichever members and runs share a key. The tag is 128 bits (Poly1305): a forgery is
 * accepted with probability about 2^-94 at most for the largest datagram, and each try
 * costs the forger a datagram on the wire.
 * The channel keys the tag, so a message cannot be moved to another channel (another fleet
 * id). The run id names one launch of a fleet (tools/fleet draws a random one per run): a
 * recording of an earlier run with the same key carries a valid tag but another run id, and
 * is refused as a replay (HAL_HOST_AUTH_OTHER_RUN). Within a run, the protocol's own rules
 * drop what is older (gp_pse: incarnations, rounds).
 *
 * The key file: 64 hexadecimal digits (32 bytes) and an optional newline, nothing else,
 * readable by its owner only (mode 0600 or stricter; anything else is refused, as ssh does
 * with private keys). `host_sim key new FILE` writes one.
 *
 * A board without libsodium has no key option: hal_host is the only back end that starts a
 * keyed fleet (docs/architecture.md section 4). Thread-safe: no state but libsodium's init
 * and a per-thread OpenSSL context, freed when its thread ends. */
#ifndef HAL_HOST_AUTH_H
#define HAL_HOST_AUTH_H

#include <stddef.h>
#include <stdint.h>

#define HAL_HOST_AUTH_KEY_BYTES 32u
#define HAL_HOST_AUTH_TAG_BYTES 16u
#define HAL_HOST_AUTH_NONCE_BYTES 24u
#define HAL_HOST_AUTH_RUN_ID_BYTES 8u
#define HAL_HOST_AUTH_TRAILER_BYTES (HAL_HOST_AUTH_RUN_ID_BYTES + HAL_HOST_AUTH_NONCE_BYTES + HAL_HOST_AUTH_TAG_BYTES)

typedef struct hal_host_auth {
    uint8_t key[HAL_HOST_AUTH_KEY_BYTES];
    uint64_t run_id;
} hal_host_auth_t;

typedef enum hal_host_auth_verdict {
    HAL_HOST_AUTH_OK = 0,
    HAL_HOST_AUTH_SHORT,     /* shorter than the trailer: not from a keyed member */
    HAL_HOST_AUTH_BAD_TAG,   /* forged, damaged, another key or another channel */
    HAL_HOST_AUTH_OTHER_RUN  /* a member's tag, but of another run: a replay */
} hal_host_auth_verdict_t;

/* libsodium's one-time set-up (idempotent, thread-safe). 0 or -EIO. */
int hal_host_auth_init(void);

/* Reads a key file (format above). 0, or -1 with the reason in why (names the file). */
int hal_host_auth_key_load(const char *path, uint8_t key[HAL_HOST_AUTH_KEY_BYTES], char *why, size_t why_cap);

/* Writes a new random key to path, created 0600, never over an existing file. 0, or -1
 * with the reason in why. */
int hal_host_auth_key_new(const char *path, char *why, size_t why_cap);

/* Seals the message wire[0 .. len) on `channel`: its trailer goes to wire[len .. len +
 * HAL_HOST_AUTH_TRAILER_BYTES), which the caller's buffer must hold (the message and its run
 * id are signed as one contiguous run of bytes). */
void hal_host_auth_seal(const hal_host_auth_t *a, const char *channel, uint8_t *wire, size_t len);

/* Checks a datagram of wire_len bytes (message and trailer) received on `channel`. On
 * HAL_HOST_AUTH_OK, *msg_len is the message's length (the trailer stripped). Constant-time
 * tag comparison. */
hal_host_auth_verdict_t hal_host_auth_open(const hal_host_auth_t *a, const char *channel, const void *wire,
                                           size_t wire_len, size_t *msg_len);

/* Zeroes the key (when a network closes). */
void hal_host_auth_wipe(hal_host_auth_t *a);

const char *hal_host_auth_verdict_name(hal_host_auth_verdict_t v);

#endif /* HAL_HOST_AUTH_H */
