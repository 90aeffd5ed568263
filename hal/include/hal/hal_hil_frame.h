/* The hardware-in-the-loop link's frames: how a robot whose firmware runs on a board (or under
 * QEMU) and the host_sim that serves it its world exchange messages, over a UDP socket (one
 * frame per datagram) or a serial byte stream (frames back to back, found again after noise).
 * Pure C, no I/O, no allocation: the board's HAL and host_sim's HIL server share it.
 *
 * A frame, every field little-endian:
 *
 *   offset  bytes  field
 *        0      2  magic 0xF1 0x5E (where a frame may start in a byte stream)
 *        2      1  version (HAL_HIL_VERSION)
 *        3      1  type (hal_hil_type_t; the payload's layout is hal_hil_msg.h's)
 *        4      4  session: chosen by the sender when it starts; a HELLO opens it
 *        8      4  seq: the sender's frame counter in the session, +1 per frame
 *       12      2  payload length, <= HAL_HIL_PAYLOAD_MAX
 *       14      2  header check: the low 16 bits of CRC-32 over bytes 0..13
 *       16      n  payload
 *     16+n      4  CRC-32 (IEEE, firmware/common/crc32.h) over bytes 0 .. 16+n-1
 *
 * Why a header check beside the CRC: in a byte stream a corrupted length would otherwise make
 * the reader wait for up to 64 KB that never come; with it a bad header is refused at its 16th
 * byte and the reader looks for the next magic at once.
 *
 * What is refused (and counted, never acted on): a frame too short for its header or its
 * length (truncated), longer than its length says (trailing bytes, datagrams only), of a
 * length above HAL_HIL_PAYLOAD_MAX (oversized), of another version or an unknown type, with a
 * bad header check or CRC, and, by the guard (hal_hil_guard_t), a frame whose seq is not above
 * the last one accepted in its session (replayed or reordered) or of a session no HELLO opened.
 */
#ifndef HAL_HIL_FRAME_H
#define HAL_HIL_FRAME_H

#include "hal/hal_board.h"
#include "hal/hal_lidar.h"
#include "hal/hal_net.h"

#include <stddef.h>
#include <stdint.h>

#define HAL_HIL_MAGIC0 0xF1u
#define HAL_HIL_MAGIC1 0x5Eu
#define HAL_HIL_VERSION 2u /* 2: a TICK names the scan the board holds */
#define HAL_HIL_HEADER_BYTES 16u
#define HAL_HIL_OVERHEAD_BYTES (HAL_HIL_HEADER_BYTES + 4u)

/* The largest payloads (hal_hil_msg.h's layouts): a bridged datagram (channel length, the
 * channel, the datagram) and a full scan. */
#define HAL_HIL_DATAGRAM_PAYLOAD_MAX (1u + HAL_NET_CHANNEL_MAX + HAL_NET_MTU_BYTES)
#define HAL_HIL_SCAN_PAYLOAD_MAX (26u + 4u * (size_t)HAL_LIDAR_MAX_BEAMS)
#define HAL_HIL_PAYLOAD_MAX \
    (HAL_HIL_DATAGRAM_PAYLOAD_MAX > HAL_HIL_SCAN_PAYLOAD_MAX ? HAL_HIL_DATAGRAM_PAYLOAD_MAX : HAL_HIL_SCAN_PAYLOAD_MAX)
#define HAL_HIL_FRAME_MAX (HAL_HIL_PAYLOAD_MAX + HAL_HIL_OVERHEAD_BYTES)
/* The largest fleet datagram whose DATAGRAM frame fits `room` bytes of a carrier, whatever its
 * channel's name (1500: one Ethernet frame's payload). A fleet whose robot is on such a link
 * sizes its state chunks to it. */
#define HAL_HIL_DATAGRAM_FITS(room) ((room) - HAL_HIL_OVERHEAD_BYTES - 1u - (HAL_NET_CHANNEL_MAX - 1u))
_Static_assert(HAL_HIL_PAYLOAD_MAX <= 0xFFFFu, "the length field is 16 bits: the board's MTU is too large");

typedef enum hal_hil_type {
    HAL_HIL_HELLO = 1,    /* board -> host, host -> board: a session starts (hal_hil_hello_t) */
    HAL_HIL_SCAN = 2,     /* host -> board: a lidar scan (hal_lidar_scan_t) */
    HAL_HIL_POSE = 3,     /* host -> board: the pose fix (hal_pose_t) */
    HAL_HIL_WHEELS = 4,   /* board -> host: a wheel command (hal_hil_wheels_t) */
    HAL_HIL_DATAGRAM = 5, /* both ways: a fleet datagram, bridged to the other robots */
    HAL_HIL_TICK = 6,     /* board -> host: bring the world to this time, send its sensors */
    HAL_HIL_WORLD = 7,    /* host -> board, after its HELLO: the world's box and rates */
    HAL_HIL_SUBSCRIBE = 8, /* board -> host: bridge this fleet channel's datagrams to the board */
    HAL_HIL_TYPE_END
} hal_hil_type_t;

/* One frame as parsed: the payload points into the caller's buffer (or the stream's). */
typedef struct hal_hil_frame {
    uint8_t type;
    uint32_t session, seq;
    uint16_t len;
    const uint8_t *payload;
} hal_hil_frame_t;

typedef enum hal_hil_verdict {
    HAL_HIL_OK = 0,
    HAL_HIL_TRUNCATED,   /* fewer bytes than the header or its length needs */
    HAL_HIL_TRAILING,    /* more bytes than its length says (a datagram) */
    HAL_HIL_BAD_MAGIC,
    HAL_HIL_BAD_VERSION,
    HAL_HIL_BAD_HEADER,  /* the header check failed */
    HAL_HIL_OVERSIZED,   /* a length above HAL_HIL_PAYLOAD_MAX */
    HAL_HIL_BAD_TYPE,
    HAL_HIL_BAD_CRC,
    HAL_HIL_VERDICTS
} hal_hil_verdict_t;

/* The verdict's name, for logs ("bad CRC"). */
const char *hal_hil_verdict_name(hal_hil_verdict_t v);

/* One frame into out[0..cap): its length, or -EINVAL (bad type, payload NULL with len > 0),
 * -EMSGSIZE (len > HAL_HIL_PAYLOAD_MAX or cap too small). */
int hal_hil_encode(uint8_t *out, size_t cap, hal_hil_type_t type, uint32_t session, uint32_t seq,
                   const void *payload, size_t len);

/* A datagram holding exactly one frame: HAL_HIL_OK and *f filled (payload into buf), or why not. */
hal_hil_verdict_t hal_hil_parse(const uint8_t *buf, size_t len, hal_hil_frame_t *f);

/* A byte stream's reader: bytes in any pieces, frames out. Fixed storage, no allocation. */
typedef struct hal_hil_stream {
    size_t n;                          /* bytes held in buf */
    int frame_held;                    /* buf holds a frame handed out: dropped at the next feed */
    uint64_t frames;                   /* frames handed out */
    uint64_t skipped;                  /* bytes dropped while looking for a frame's start */
    uint64_t refused[HAL_HIL_VERDICTS]; /* frames refused, by verdict (no HAL_HIL_OK) */
    uint8_t buf[HAL_HIL_FRAME_MAX];
} hal_hil_stream_t;

void hal_hil_stream_init(hal_hil_stream_t *s);

/* Takes bytes from data[0..len) until one frame is whole: returns how many it took and sets
 * *got (1: *f is a frame, its payload valid until the next call on s; 0: all len bytes taken,
 * no frame yet). Feed the rest of data in the next call. A frame refused on the way is counted
 * and the reader goes on at the next magic after its first byte. */
size_t hal_hil_stream_feed(hal_hil_stream_t *s, const uint8_t *data, size_t len, hal_hil_frame_t *f, int *got);

/* The link went quiet (the caller's timeout): a frame begun and not finished is dropped and
 * counted truncated. */
void hal_hil_stream_idle(hal_hil_stream_t *s);

/* Which frames to act on: one session at a time, each frame's seq above the last accepted.
 * A HELLO of another session opens it (the peer restarted); a gap in seq is a loss, counted. */
typedef struct hal_hil_guard {
    int open;
    uint32_t session, last_seq;
    uint64_t accepted, replayed, unopened, lost, sessions;
} hal_hil_guard_t;

void hal_hil_guard_init(hal_hil_guard_t *g);

/* 0 (act on it), -EALREADY (seq not above the last: replayed or late), -ENOTCONN (no HELLO
 * opened its session). */
int hal_hil_guard_accept(hal_hil_guard_t *g, const hal_hil_frame_t *f);

/* "HOST:PORT", the address either end of a UDP link is given: the host (the text before the
 * last ':', 1 .. cap - 1 characters, not checked further: each end resolves it its own way) into
 * host[cap] and the port, 0 .. 65535, into *port. 0, or -EINVAL. */
int hal_hil_split_address(const char *s, char *host, size_t cap, uint32_t *port);

#endif /* HAL_HIL_FRAME_H */
