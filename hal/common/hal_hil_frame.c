/* The hardware-in-the-loop link's frames (hal/hal_hil_frame.h): encode, parse a datagram, read
 * a byte stream, guard against replays. */
#include "hal/hal_hil_frame.h"

#include "common/crc32.h"
#include "common/le_bytes.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

static const char *const verdict_names[HAL_HIL_VERDICTS] = {
    "ok", "truncated", "trailing bytes", "bad magic", "bad version", "bad header check", "oversized",
    "unknown type", "bad CRC",
};

const char *hal_hil_verdict_name(hal_hil_verdict_t v)
{
    return (unsigned)v < HAL_HIL_VERDICTS ? verdict_names[v] : "?";
}

static uint16_t header_check(const uint8_t *h)
{
    return (uint16_t)crc32_ieee(h, HAL_HIL_HEADER_BYTES - 2u);
}

int hal_hil_encode(uint8_t *out, size_t cap, hal_hil_type_t type, uint32_t session, uint32_t seq,
                   const void *payload, size_t len)
{
    if (out == NULL || (payload == NULL && len > 0) || type < HAL_HIL_HELLO || type >= HAL_HIL_TYPE_END)
        return -EINVAL;
    if (len > HAL_HIL_PAYLOAD_MAX || cap < len + HAL_HIL_OVERHEAD_BYTES)
        return -EMSGSIZE;
    out[0] = HAL_HIL_MAGIC0;
    out[1] = HAL_HIL_MAGIC1;
    out[2] = HAL_HIL_VERSION;
    out[3] = (uint8_t)type;
    le_put_u32(out + 4, session);
    le_put_u32(out + 8, seq);
    le_put_u16(out + 12, (uint16_t)len);
    le_put_u16(out + 14, header_check(out));
    if (len > 0)
        memmove(out + HAL_HIL_HEADER_BYTES, payload, len); /* payload may already sit there */
    le_put_u32(out + HAL_HIL_HEADER_BYTES + len, crc32_ieee(out, HAL_HIL_HEADER_BYTES + len));
    return (int)(len + HAL_HIL_OVERHEAD_BYTES);
}

/* The header's verdict (n >= HAL_HIL_HEADER_BYTES) and the payload length it gives. */
static hal_hil_verdict_t check_header(const uint8_t *h, uint16_t *len)
{
    if (h[0] != HAL_HIL_MAGIC0 || h[1] != HAL_HIL_MAGIC1)
        return HAL_HIL_BAD_MAGIC;
    if (le_get_u16(h + 14) != header_check(h))
        return HAL_HIL_BAD_HEADER;
    if (h[2] != HAL_HIL_VERSION)
        return HAL_HIL_BAD_VERSION;
    *len = le_get_u16(h + 12);
    if (*len > HAL_HIL_PAYLOAD_MAX)
        return HAL_HIL_OVERSIZED;
    if (h[3] < HAL_HIL_HELLO || h[3] >= HAL_HIL_TYPE_END)
        return HAL_HIL_BAD_TYPE;
    return HAL_HIL_OK;
}

/* A whole frame's CRC (the header checked, n = its length) and *f. */
static hal_hil_verdict_t finish(const uint8_t *b, uint16_t len, hal_hil_frame_t *f)
{
    const size_t body = HAL_HIL_HEADER_BYTES + len;
    if (le_get_u32(b + body) != crc32_ieee(b, body))
        return HAL_HIL_BAD_CRC;
    f->type = b[3];
    f->session = le_get_u32(b + 4);
    f->seq = le_get_u32(b + 8);
    f->len = len;
    f->payload = b + HAL_HIL_HEADER_BYTES;
    return HAL_HIL_OK;
}

hal_hil_verdict_t hal_hil_parse(const uint8_t *buf, size_t n, hal_hil_frame_t *f)
{
    if (buf == NULL || f == NULL || n < HAL_HIL_OVERHEAD_BYTES)
        return HAL_HIL_TRUNCATED;
    uint16_t len = 0;
    const hal_hil_verdict_t v = check_header(buf, &len);
    if (v != HAL_HIL_OK)
        return v;
    if (n < (size_t)len + HAL_HIL_OVERHEAD_BYTES)
        return HAL_HIL_TRUNCATED;
    if (n > (size_t)len + HAL_HIL_OVERHEAD_BYTES)
        return HAL_HIL_TRAILING;
    return finish(buf, len, f);
}

void hal_hil_stream_init(hal_hil_stream_t *s)
{
    memset(s, 0, offsetof(hal_hil_stream_t, buf));
}

/* Drops buf[0] and whatever follows up to the next byte that may start a frame. */
static void resync(hal_hil_stream_t *s)
{
    const uint8_t *m = s->n > 1u ? memchr(s->buf + 1, HAL_HIL_MAGIC0, s->n - 1u) : NULL;
    const size_t drop = m != NULL ? (size_t)(m - s->buf) : s->n;
    memmove(s->buf, s->buf + drop, s->n - drop);
    s->n -= drop;
}

/* What the held bytes make: 1 (a frame, *f), 0 (more bytes needed). Refused starts are
 * counted and skipped. */
static int settle(hal_hil_stream_t *s, hal_hil_frame_t *f)
{
    for (;;) {
        if (s->n >= 1u && s->buf[0] != HAL_HIL_MAGIC0) {
            const size_t before = s->n;
            resync(s);
            s->skipped += before - s->n;
            continue;
        }
        if (s->n >= 2u && s->buf[1] != HAL_HIL_MAGIC1) {
            s->skipped++;
            resync(s);
            continue;
        }
        if (s->n < HAL_HIL_HEADER_BYTES)
            return 0;
        uint16_t len = 0;
        hal_hil_verdict_t v = check_header(s->buf, &len);
        if (v == HAL_HIL_OK) {
            if (s->n < (size_t)len + HAL_HIL_OVERHEAD_BYTES)
                return 0;
            v = finish(s->buf, len, f);
            if (v == HAL_HIL_OK)
                return 1;
        }
        s->refused[v]++;
        resync(s);
    }
}

/* The frame handed out last time is done with: its bytes go. Bytes after it are possible only
   when a refused frame's tail held a whole one; they are looked at again. */
static int drop_held(hal_hil_stream_t *s, hal_hil_frame_t *f)
{
    if (!s->frame_held)
        return 0;
    const size_t used = (size_t)le_get_u16(s->buf + 12) + HAL_HIL_OVERHEAD_BYTES;
    memmove(s->buf, s->buf + used, s->n - used);
    s->n -= used;
    s->frame_held = 0;
    return f != NULL && settle(s, f);
}

static void hand_out(hal_hil_stream_t *s, int *got)
{
    s->frame_held = *got = 1;
    s->frames++;
}

size_t hal_hil_stream_feed(hal_hil_stream_t *s, const uint8_t *data, size_t len, hal_hil_frame_t *f, int *got)
{
    *got = 0;
    if (drop_held(s, f)) {
        hand_out(s, got);
        return 0;
    }
    size_t taken = 0;
    while (taken < len) {
        /* The magic a byte at a time, then the header, then the rest of the frame its length
           announces, one copy each: never past the frame, so a whole frame is at buf[0]. */
        size_t want = 1;
        if (s->n >= HAL_HIL_HEADER_BYTES)
            want = (size_t)le_get_u16(s->buf + 12) + HAL_HIL_OVERHEAD_BYTES - s->n;
        else if (s->n >= 2u)
            want = HAL_HIL_HEADER_BYTES - s->n;
        if (want > len - taken)
            want = len - taken;
        memcpy(s->buf + s->n, data + taken, want);
        s->n += want;
        taken += want;
        if (settle(s, f)) {
            hand_out(s, got);
            break;
        }
    }
    return taken;
}

void hal_hil_stream_idle(hal_hil_stream_t *s)
{
    (void)drop_held(s, NULL);
    if (s->n > 0)
        s->refused[HAL_HIL_TRUNCATED]++;
    s->n = 0;
}

void hal_hil_guard_init(hal_hil_guard_t *g)
{
    memset(g, 0, sizeof *g);
}

int hal_hil_guard_accept(hal_hil_guard_t *g, const hal_hil_frame_t *f)
{
    if (f->type == HAL_HIL_HELLO && (!g->open || f->session != g->session)) {
        g->open = 1;
        g->session = f->session;
        g->last_seq = f->seq;
        g->sessions++;
        g->accepted++;
        return 0;
    }
    if (!g->open || f->session != g->session) {
        g->unopened++;
        return -ENOTCONN;
    }
    if (f->seq <= g->last_seq) {
        g->replayed++;
        return -EALREADY;
    }
    g->lost += f->seq - g->last_seq - 1u;
    g->last_seq = f->seq;
    g->accepted++;
    return 0;
}

int hal_hil_split_address(const char *s, char *host, size_t cap, uint32_t *port)
{
    const char *colon = s != NULL ? strrchr(s, ':') : NULL;
    if (colon == NULL || colon == s || (size_t)(colon - s) >= cap || colon[1] < '0' || colon[1] > '9')
        return -EINVAL;
    char *end = NULL;
    const unsigned long p = strtoul(colon + 1, &end, 10);
    if (*end != '\0' || p > 65535u)
        return -EINVAL;
    memcpy(host, s, (size_t)(colon - s));
    host[colon - s] = '\0';
    *port = (uint32_t)p;
    return 0;
}
