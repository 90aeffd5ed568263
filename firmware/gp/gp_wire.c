/* The fleet's messages in LCM's wire format: see gp_wire.h. One walker per direction over a
 * field table per message; the tables are built here from the generated layouts
 * (msg/msg_layout.h, from the .lcm files of firmware/msg) and the gp_pse structs' members,
 * and checked against both at compile time. What each message requires of its values beyond its layout
 * (ranges, chunk < n_chunks) is its own check below. */
#include "gp/gp_wire.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

/* How a field sits in the C struct: a value of the field's own width (a scalar, or the
 * elements of an array member), or a pointer to the bytes (a byte array that stays in the
 * datagram on decode: the chunk's data). */
enum { W_VALUE, W_POINTER };

typedef struct wire_field {
    uint16_t at;        /* offsetof the member */
    uint8_t size;       /* bytes of one element, on the wire and in the member */
    uint8_t how;        /* W_VALUE or W_POINTER */
    int8_t len_field;   /* a variable array: index of the field that holds its count; else -1 */
    uint32_t count;     /* 1 a scalar, N a fixed array, 0 a variable array */
    uint32_t cap;       /* W_VALUE arrays: elements the member holds */
} wire_field_t;

typedef struct wire_msg {
    uint64_t fingerprint;
    uint32_t fixed_bytes; /* the fingerprint and every field before the first variable array */
    uint32_t n_fields;
    const wire_field_t *fields;
} wire_msg_t;

/* One table entry of struct T per X-macro entry of msg/msg_layout.h. A member that is a pointer
 * to bytes is W_POINTER; anything else, arrays included, is W_VALUE (stored in the struct). */
#define HOW(T, member) \
    _Generic(&((T *)0)->member, const uint8_t **: W_POINTER, uint8_t **: W_POINTER, default: W_VALUE)
#define FIELD(T, name, member, type, size, count, len_field, offset) \
    {(uint16_t)offsetof(T, member), (uint8_t)(size), (uint8_t)HOW(T, member), (int8_t)(len_field), (count), \
     (uint32_t)(sizeof(((T *)0)->member) / (size))},
/* The member holds what the field carries: a scalar or a fixed array exactly (the widths of the
 * wire and the struct agree), a variable array whole elements; a pointer only bytes. */
#define CHECK(T, name, member, type, size, count, len_field, offset)                                      \
    _Static_assert(HOW(T, member) == W_POINTER ? (size) == 1 && (count) == 0                             \
                   : (count) != 0             ? sizeof(((T *)0)->member) == (size) * (count)             \
                                              : sizeof(((T *)0)->member) % (size) == 0,                  \
                   #T "." #member " does not fit the .lcm field " #name);                                  \
    _Static_assert(offsetof(T, member) <= 0xFFFFu, #T "." #member ": its offset fits wire_field_t.at");

#define CHUNK_FIELD(...) FIELD(gp_pse_chunk_t, __VA_ARGS__)
#define DONE_FIELD(...) FIELD(gp_pse_done_t, __VA_ARGS__)
#define REQUEST_FIELD(...) FIELD(gp_pse_request_t, __VA_ARGS__)
#define CHUNK_CHECK(...) CHECK(gp_pse_chunk_t, __VA_ARGS__)
#define DONE_CHECK(...) CHECK(gp_pse_done_t, __VA_ARGS__)
#define REQUEST_CHECK(...) CHECK(gp_pse_request_t, __VA_ARGS__)
#define CLAIM_FIELD(...) FIELD(gp_goal_claim_t, __VA_ARGS__)
#define CLAIM_CHECK(...) CHECK(gp_goal_claim_t, __VA_ARGS__)

MSG_STATE_CHUNK_FIELDS(CHUNK_CHECK)
MSG_ROUND_COMPLETE_FIELDS(DONE_CHECK)
MSG_CHUNK_REQUEST_FIELDS(REQUEST_CHECK)
MSG_GOAL_CLAIM_FIELDS(CLAIM_CHECK)

static const wire_field_t CHUNK_FIELDS[] = {MSG_STATE_CHUNK_FIELDS(CHUNK_FIELD)};
static const wire_field_t DONE_FIELDS[] = {MSG_ROUND_COMPLETE_FIELDS(DONE_FIELD)};
static const wire_field_t REQUEST_FIELDS[] = {MSG_CHUNK_REQUEST_FIELDS(REQUEST_FIELD)};
static const wire_field_t CLAIM_FIELDS[] = {MSG_GOAL_CLAIM_FIELDS(CLAIM_FIELD)};

static const wire_msg_t CHUNK = {MSG_STATE_CHUNK_FINGERPRINT, MSG_STATE_CHUNK_FIXED_BYTES, MSG_STATE_CHUNK_N_FIELDS,
                                 CHUNK_FIELDS};
static const wire_msg_t DONE = {MSG_ROUND_COMPLETE_FINGERPRINT, MSG_ROUND_COMPLETE_FIXED_BYTES,
                                MSG_ROUND_COMPLETE_N_FIELDS, DONE_FIELDS};
static const wire_msg_t REQUEST = {MSG_CHUNK_REQUEST_FINGERPRINT, MSG_CHUNK_REQUEST_FIXED_BYTES,
                                   MSG_CHUNK_REQUEST_N_FIELDS, REQUEST_FIELDS};
static const wire_msg_t CLAIM = {MSG_GOAL_CLAIM_FINGERPRINT, MSG_GOAL_CLAIM_FIXED_BYTES, MSG_GOAL_CLAIM_N_FIELDS,
                                 CLAIM_FIELDS};

_Static_assert(sizeof CHUNK_FIELDS / sizeof CHUNK_FIELDS[0] == MSG_STATE_CHUNK_N_FIELDS, "one entry per field");
_Static_assert(sizeof DONE_FIELDS / sizeof DONE_FIELDS[0] == MSG_ROUND_COMPLETE_N_FIELDS, "one entry per field");
_Static_assert(sizeof REQUEST_FIELDS / sizeof REQUEST_FIELDS[0] == MSG_CHUNK_REQUEST_N_FIELDS, "one entry per field");
_Static_assert(sizeof CLAIM_FIELDS / sizeof CLAIM_FIELDS[0] == MSG_GOAL_CLAIM_N_FIELDS, "one entry per field");
_Static_assert(MSG_GOAL_CLAIM_N_FIELDS <= 16, "a message has at most MAX_FIELDS fields");
/* Length fields index a small array below; a walk may count on at most this many fields. */
#define MAX_FIELDS 16
_Static_assert(MSG_STATE_CHUNK_N_FIELDS <= MAX_FIELDS && MSG_ROUND_COMPLETE_N_FIELDS <= MAX_FIELDS &&
                   MSG_CHUNK_REQUEST_N_FIELDS <= MAX_FIELDS,
               "a message has at most MAX_FIELDS fields");
_Static_assert(GP_WIRE_CHUNK_HEADER_BYTES <= GP_PSE_CHUNK_HEADER_ROOM, "the chunk header fits the room gp_pse keeps");
/* GP_WIRE_REQUEST_BYTES counts 4 bytes per requested chunk, and what the chunk's data field
 * carries is bytes: the two array fields gp_pse's structs know. */
_Static_assert(sizeof(((gp_pse_request_t *)0)->chunks[0]) == 4u, "chunk_request_t's chunks are int32");
_Static_assert(GP_WIRE_REQUEST_BYTES(GP_PSE_MAX_REQUEST) <= 0x7FFFFFFFu && GP_PSE_MAX_CHUNK_BYTES <= 0x7FFFFFFFu,
               "lengths fit the int returned");

/* A field's value (one element) between its big-endian wire bytes and the struct's own
 * representation of the same width: the bits travel unchanged (an IEEE double as its 64 bits). */
static uint64_t get_be(const uint8_t *p, unsigned size)
{
    uint64_t v = 0;
    for (unsigned i = 0; i < size; i++)
        v = v << 8 | p[i];
    return v;
}

static void put_be(uint8_t *p, unsigned size, uint64_t v)
{
    for (unsigned i = size; i-- > 0; v >>= 8)
        p[i] = (uint8_t)v;
}

static uint64_t load(const uint8_t *src, unsigned size)
{
    switch (size) {
    case 1: return *src;
    case 2: {
        uint16_t v;
        memcpy(&v, src, sizeof v);
        return v;
    }
    case 4: {
        uint32_t v;
        memcpy(&v, src, sizeof v);
        return v;
    }
    default: {
        uint64_t v;
        memcpy(&v, src, sizeof v);
        return v;
    }
    }
}

static void store(uint8_t *dst, unsigned size, uint64_t v)
{
    switch (size) {
    case 1: *dst = (uint8_t)v; break;
    case 2: {
        const uint16_t w = (uint16_t)v;
        memcpy(dst, &w, sizeof w);
        break;
    }
    case 4: {
        const uint32_t w = (uint32_t)v;
        memcpy(dst, &w, sizeof w);
        break;
    }
    default: memcpy(dst, &v, sizeof v); break;
    }
}

/* A count as the wire's signed integer of its width: negative counts are refused. */
static int64_t as_signed(uint64_t v, unsigned size)
{
    if ((v >> (8 * size - 1)) & 1)
        return size < 8 ? (int64_t)v - ((int64_t)1 << (8 * size)) : -1;
    return (int64_t)v;
}

/* Elements of field i of the struct: 1, the fixed count, or its length field's value. */
static uint64_t elements(const wire_msg_t *m, const uint8_t *s, uint32_t i)
{
    const wire_field_t *f = &m->fields[i];
    if (f->count != 0)
        return f->count;
    const wire_field_t *n = &m->fields[f->len_field];
    return load(s + n->at, n->size);
}

static int encode(const wire_msg_t *m, const void *msg, uint8_t *buf, size_t cap)
{
    const uint8_t *s = msg;
    size_t len = m->fixed_bytes;
    for (uint32_t i = 0; i < m->n_fields; i++) {
        const wire_field_t *f = &m->fields[i];
        if (f->count != 0)
            continue;
        const uint64_t n = elements(m, s, i);
        if ((f->how == W_VALUE && n > f->cap) || n > 0x7FFFFFFFu || n * f->size > 0x7FFFFFFFu - len)
            return -EMSGSIZE;
        len += (size_t)(n * f->size);
    }
    if (cap < len)
        return -EMSGSIZE;
    uint8_t *p = buf;
    put_be(p, 8, m->fingerprint);
    p += 8;
    for (uint32_t i = 0; i < m->n_fields; i++) {
        const wire_field_t *f = &m->fields[i];
        const size_t n = (size_t)elements(m, s, i);
        if (f->how == W_POINTER) {
            const uint8_t *src;
            memcpy(&src, s + f->at, sizeof src);
            if (n)
                memcpy(p, src, n);
            p += n;
            continue;
        }
        for (size_t e = 0; e < n; e++, p += f->size)
            put_be(p, f->size, load(s + f->at + e * f->size, f->size));
    }
    return (int)len;
}

/* Decodes into *msg (the caller's scratch copy): 0, or -EBADMSG with *msg partly written. Every
 * length is checked before it is used: non-negative, within the member, within the datagram,
 * and the fields end exactly at its end. */
static int decode(const wire_msg_t *m, const uint8_t *buf, size_t len, void *msg)
{
    if (buf == NULL || len < m->fixed_bytes || get_be(buf, 8) != m->fingerprint)
        return -EBADMSG;
    uint8_t *s = msg;
    int64_t counts[MAX_FIELDS] = {0};
    size_t at = 8;
    for (uint32_t i = 0; i < m->n_fields; i++) {
        const wire_field_t *f = &m->fields[i];
        uint64_t n = f->count;
        if (n == 0) {
            const int64_t c = counts[f->len_field];
            if (c < 0 || (f->how == W_VALUE && (uint64_t)c > f->cap))
                return -EBADMSG;
            n = (uint64_t)c;
        }
        if (n > (len - at) / f->size)
            return -EBADMSG;
        if (f->how == W_POINTER) {
            const uint8_t *src = buf + at;
            memcpy(s + f->at, &src, sizeof src);
            at += (size_t)n;
            continue;
        }
        for (uint64_t e = 0; e < n; e++, at += f->size) {
            const uint64_t v = get_be(buf + at, f->size);
            store(s + f->at + (size_t)e * f->size, f->size, v);
            if (f->count == 1)
                counts[i] = as_signed(v, f->size);
        }
    }
    return at == len ? 0 : -EBADMSG;
}

/* int32 fields that must not be negative (ids, rounds, counts). */
#define NONNEG(v) ((v) <= 0x7FFFFFFFu)

int gp_wire_encode_chunk(const gp_pse_chunk_t *c, uint8_t *buf, size_t cap)
{
    return encode(&CHUNK, c, buf, cap);
}

int gp_wire_decode_chunk(const uint8_t *buf, size_t len, gp_pse_chunk_t *out)
{
    gp_pse_chunk_t c;
    memset(&c, 0, sizeof c);
    if (out == NULL || decode(&CHUNK, buf, len, &c) != 0)
        return -EBADMSG;
    if (!NONNEG(c.sender) || !NONNEG(c.round) || !NONNEG(c.n_chunks) || c.n_chunks < 1 ||
        c.chunk >= c.n_chunks || c.state_bytes < 1 || c.state_bytes > GP_PSE_MAX_STATE_BYTES ||
        c.n_bytes > GP_PSE_MAX_CHUNK_BYTES || c.n_bytes > c.state_bytes)
        return -EBADMSG;
    c.to = GP_PSE_TO_ALL; /* not on the wire: the channel it came on says */
    *out = c;
    return 0;
}

int gp_wire_encode_done(const gp_pse_done_t *d, uint8_t *buf, size_t cap)
{
    return encode(&DONE, d, buf, cap);
}

int gp_wire_decode_done(const uint8_t *buf, size_t len, gp_pse_done_t *out)
{
    gp_pse_done_t d;
    memset(&d, 0, sizeof d);
    if (out == NULL || decode(&DONE, buf, len, &d) != 0)
        return -EBADMSG;
    if (!NONNEG(d.sender) || !NONNEG(d.round) || d.has_next_position > 1u ||
        (d.has_next_position && (!isfinite(d.next_x_m) || !isfinite(d.next_y_m))))
        return -EBADMSG;
    *out = d;
    return 0;
}

int gp_wire_encode_request(const gp_pse_request_t *r, uint8_t *buf, size_t cap)
{
    return encode(&REQUEST, r, buf, cap);
}

int gp_wire_decode_request(const uint8_t *buf, size_t len, gp_pse_request_t *out)
{
    gp_pse_request_t r;
    memset(&r, 0, sizeof r);
    if (out == NULL || decode(&REQUEST, buf, len, &r) != 0)
        return -EBADMSG;
    if (!NONNEG(r.requester) || !NONNEG(r.target) || !NONNEG(r.round) || r.has_position > 1u ||
        (r.has_position && (!isfinite(r.x_m) || !isfinite(r.y_m))))
        return -EBADMSG;
    for (uint32_t i = 0; i < r.n; i++)
        if (!NONNEG(r.chunks[i]))
            return -EBADMSG;
    r.to = GP_PSE_TO_ALL; /* not on the wire: the channel it came on says */
    *out = r;
    return 0;
}

int gp_wire_encode_claim(const gp_goal_claim_t *c, uint8_t *buf, size_t cap)
{
    return encode(&CLAIM, c, buf, cap);
}

int gp_wire_decode_claim(const uint8_t *buf, size_t len, gp_goal_claim_t *out)
{
    gp_goal_claim_t c;
    memset(&c, 0, sizeof c);
    if (out == NULL || decode(&CLAIM, buf, len, &c) != 0)
        return -EBADMSG;
    /* expiry_us is an int64 on the wire: the top bit set is a negative time. */
    if (!NONNEG(c.sender) || !NONNEG(c.seq) || !isfinite(c.x_m) || !isfinite(c.y_m) || !isfinite(c.cost_m) ||
        c.cost_m < 0.0 || (c.expiry_us >> 63) != 0u)
        return -EBADMSG;
    *out = c;
    return 0;
}
