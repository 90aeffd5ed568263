/* The fleet's messages in LCM's wire format: see gp_wire.h. */
#include "gp/gp_wire.h"

#include <errno.h>
#include <string.h>

static uint8_t *put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
    return p + 4;
}

static uint8_t *put64(uint8_t *p, uint64_t v)
{
    return put32(put32(p, (uint32_t)(v >> 32)), (uint32_t)v);
}

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

static uint64_t get64(const uint8_t *p)
{
    return (uint64_t)get32(p) << 32 | get32(p + 4);
}

static uint8_t *put_f64(uint8_t *p, double d)
{
    uint64_t v;
    memcpy(&v, &d, sizeof v);
    return put64(p, v);
}

static double get_f64(const uint8_t *p)
{
    const uint64_t v = get64(p);
    double d;
    memcpy(&d, &v, sizeof d);
    return d;
}

_Static_assert(GP_WIRE_CHUNK_HEADER_BYTES <= GP_PSE_CHUNK_HEADER_ROOM, "the chunk header fits the room gp_pse keeps");

/* int32 fields that must not be negative (ids, rounds, counts). */
#define NONNEG(v) ((v) <= 0x7FFFFFFFu)

int gp_wire_encode_chunk(const gp_pse_chunk_t *c, uint8_t *buf, size_t cap)
{
    const size_t len = GP_WIRE_CHUNK_HEADER_BYTES + (size_t)c->n_bytes;
    if (cap < len)
        return -EMSGSIZE;
    uint8_t *p = put64(buf, GP_WIRE_FP_STATE_CHUNK);
    p = put32(p, c->sender);
    p = put32(p, c->round);
    p = put32(p, c->chunk);
    p = put32(p, c->n_chunks);
    p = put32(p, c->state_bytes);
    *p++ = c->encoding;
    p = put32(p, c->crc32);
    p = put_f64(p, c->x_m);
    p = put_f64(p, c->y_m);
    p = put32(p, c->incarnation);
    p = put32(p, c->n_bytes);
    memcpy(p, c->data, c->n_bytes);
    return (int)len;
}

int gp_wire_decode_chunk(const uint8_t *buf, size_t len, gp_pse_chunk_t *out)
{
    if (buf == NULL || out == NULL || len < GP_WIRE_CHUNK_HEADER_BYTES || get64(buf) != GP_WIRE_FP_STATE_CHUNK)
        return -EBADMSG;
    const uint8_t *p = buf + 8;
    gp_pse_chunk_t c;
    c.sender = get32(p);
    c.round = get32(p + 4);
    c.chunk = get32(p + 8);
    c.n_chunks = get32(p + 12);
    c.state_bytes = get32(p + 16);
    c.encoding = p[20];
    c.crc32 = get32(p + 21);
    c.x_m = get_f64(p + 25);
    c.y_m = get_f64(p + 33);
    c.incarnation = get32(p + 41);
    c.n_bytes = get32(p + 45);
    c.data = buf + GP_WIRE_CHUNK_HEADER_BYTES;
    if (!NONNEG(c.sender) || !NONNEG(c.round) || !NONNEG(c.n_chunks) || c.n_chunks < 1 ||
        c.chunk >= c.n_chunks || c.state_bytes < 1 || c.state_bytes > GP_PSE_MAX_STATE_BYTES ||
        c.n_bytes > GP_PSE_MAX_CHUNK_BYTES || c.n_bytes > c.state_bytes ||
        (size_t)c.n_bytes != len - GP_WIRE_CHUNK_HEADER_BYTES)
        return -EBADMSG;
    *out = c;
    return 0;
}

int gp_wire_encode_done(const gp_pse_done_t *d, uint8_t *buf, size_t cap)
{
    if (cap < GP_WIRE_DONE_BYTES)
        return -EMSGSIZE;
    put32(put32(put32(put64(buf, GP_WIRE_FP_ROUND_COMPLETE), d->sender), d->round), d->incarnation);
    return (int)GP_WIRE_DONE_BYTES;
}

int gp_wire_decode_done(const uint8_t *buf, size_t len, gp_pse_done_t *out)
{
    if (buf == NULL || out == NULL || len != GP_WIRE_DONE_BYTES || get64(buf) != GP_WIRE_FP_ROUND_COMPLETE)
        return -EBADMSG;
    const gp_pse_done_t d = {get32(buf + 8), get32(buf + 12), get32(buf + 16)};
    if (!NONNEG(d.sender) || !NONNEG(d.round))
        return -EBADMSG;
    *out = d;
    return 0;
}

int gp_wire_encode_request(const gp_pse_request_t *r, uint8_t *buf, size_t cap)
{
    if (r->n > GP_PSE_MAX_REQUEST || cap < GP_WIRE_REQUEST_BYTES(r->n))
        return -EMSGSIZE;
    uint8_t *p = put64(buf, GP_WIRE_FP_CHUNK_REQUEST);
    p = put32(p, r->requester);
    p = put32(p, r->target);
    p = put32(p, r->round);
    p = put32(p, r->incarnation);
    p = put32(p, r->n);
    for (uint32_t i = 0; i < r->n; i++)
        p = put32(p, r->chunks[i]);
    return (int)GP_WIRE_REQUEST_BYTES(r->n);
}

int gp_wire_decode_request(const uint8_t *buf, size_t len, gp_pse_request_t *out)
{
    if (buf == NULL || out == NULL || len < GP_WIRE_REQUEST_BYTES(0) || get64(buf) != GP_WIRE_FP_CHUNK_REQUEST)
        return -EBADMSG;
    const uint32_t n = get32(buf + 24);
    if (n > GP_PSE_MAX_REQUEST || len != GP_WIRE_REQUEST_BYTES(n))
        return -EBADMSG;
    gp_pse_request_t r;
    r.requester = get32(buf + 8);
    r.target = get32(buf + 12);
    r.round = get32(buf + 16);
    r.incarnation = get32(buf + 20);
    r.n = n;
    if (!NONNEG(r.requester) || !NONNEG(r.target) || !NONNEG(r.round))
        return -EBADMSG;
    for (uint32_t i = 0; i < n; i++) {
        r.chunks[i] = get32(buf + 28 + 4 * i);
        if (!NONNEG(r.chunks[i]))
            return -EBADMSG;
    }
    *out = r;
    return 0;
}
