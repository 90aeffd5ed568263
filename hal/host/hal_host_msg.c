/* Bounds check of fleet datagrams before any decoder: see hal_host_msg.h. */
#include "hal_host_msg.h"

#include "hal/hal_net.h"
#include "msg/msg_layout.h"

typedef struct field {
    uint8_t size;      /* bytes of one element */
    int8_t len_field;  /* a variable array: index of the int field holding its count; else -1 */
    uint32_t count;    /* 1 a scalar, N a fixed array, 0 a variable array */
} field_t;

typedef struct layout {
    uint64_t fingerprint;
    uint32_t n_fields;
    const field_t *fields;
} layout_t;

/* A datagram is at most one MTU, so no array may claim more elements than fit in it. */
#define MAX_ELEMENTS(size) ((int64_t)HAL_NET_MTU_BYTES / (size))
/* Length fields index the small array of counts below. */
#define MAX_FIELDS 16

/* The fields of the .lcm files in firmware/msg, in declaration order (tools/lcmgen.py). */
#define FIELD(name, member, type, size, count, len_field, offset) {(size), (len_field), (count)},
static const field_t STATE_CHUNK[] = {MSG_STATE_CHUNK_FIELDS(FIELD)};
static const field_t ROUND_COMPLETE[] = {MSG_ROUND_COMPLETE_FIELDS(FIELD)};
static const field_t CHUNK_REQUEST[] = {MSG_CHUNK_REQUEST_FIELDS(FIELD)};
static const field_t GOAL_CLAIM[] = {MSG_GOAL_CLAIM_FIELDS(FIELD)};
_Static_assert(MSG_STATE_CHUNK_N_FIELDS <= MAX_FIELDS && MSG_ROUND_COMPLETE_N_FIELDS <= MAX_FIELDS &&
                   MSG_CHUNK_REQUEST_N_FIELDS <= MAX_FIELDS && MSG_GOAL_CLAIM_N_FIELDS <= MAX_FIELDS,
               "a message has at most MAX_FIELDS fields");

/* A field's big-endian value as its signed integer (a count; only scalars are read). */
static int64_t get_int(const uint8_t *p, unsigned size)
{
    uint64_t v = 0;
    for (unsigned i = 0; i < size; i++)
        v = v << 8 | p[i];
    if (size < 8 && (v >> (8 * size - 1)) & 1)
        return (int64_t)v - ((int64_t)1 << (8 * size));
    return size == 8 && v >> 63 ? -1 : (int64_t)v;
}

hal_host_msg_reject_t hal_host_msg_check(hal_host_msg_type_t type, const void *data, size_t len)
{
    static const layout_t layout[HAL_HOST_MSG_TYPE_COUNT] = {
        [HAL_HOST_MSG_STATE_CHUNK] = {MSG_STATE_CHUNK_FINGERPRINT, MSG_STATE_CHUNK_N_FIELDS, STATE_CHUNK},
        [HAL_HOST_MSG_ROUND_COMPLETE] = {MSG_ROUND_COMPLETE_FINGERPRINT, MSG_ROUND_COMPLETE_N_FIELDS, ROUND_COMPLETE},
        [HAL_HOST_MSG_CHUNK_REQUEST] = {MSG_CHUNK_REQUEST_FINGERPRINT, MSG_CHUNK_REQUEST_N_FIELDS, CHUNK_REQUEST},
        [HAL_HOST_MSG_GOAL_CLAIM] = {MSG_GOAL_CLAIM_FINGERPRINT, MSG_GOAL_CLAIM_N_FIELDS, GOAL_CLAIM},
    };
    if (type == HAL_HOST_MSG_ANY)
        return HAL_HOST_MSG_OK;
    if ((unsigned)type >= HAL_HOST_MSG_TYPE_COUNT || data == NULL)
        return HAL_HOST_MSG_FINGERPRINT;
    const uint8_t *p = data;
    if (len < 8)
        return HAL_HOST_MSG_SHORT;
    uint64_t fp = 0;
    for (int i = 0; i < 8; i++)
        fp = fp << 8 | p[i];
    const layout_t *m = &layout[type];
    if (fp != m->fingerprint)
        return HAL_HOST_MSG_FINGERPRINT;
    size_t at = 8;
    int64_t ints[MAX_FIELDS] = {0}; /* values of the scalar fields, by field index */
    for (uint32_t i = 0; i < m->n_fields; i++) {
        const field_t *f = &m->fields[i];
        int64_t n = f->count;
        if (n == 0) {
            n = ints[f->len_field];
            if (n < 0 || n > MAX_ELEMENTS(f->size))
                return HAL_HOST_MSG_BAD_LENGTH;
        }
        const size_t need = (size_t)n * f->size;
        if (len - at < need)
            return HAL_HOST_MSG_SHORT;
        if (f->count == 1)
            ints[i] = get_int(p + at, f->size);
        at += need;
    }
    return at == len ? HAL_HOST_MSG_OK : HAL_HOST_MSG_TRAILING;
}

const char *hal_host_msg_reject_name(hal_host_msg_reject_t r)
{
    switch (r) {
    case HAL_HOST_MSG_OK: return "ok";
    case HAL_HOST_MSG_SHORT: return "shorter than its fields";
    case HAL_HOST_MSG_FINGERPRINT: return "not the expected message type";
    case HAL_HOST_MSG_BAD_LENGTH: return "a length field out of range";
    case HAL_HOST_MSG_TRAILING: return "bytes after the last field";
    default: return "?";
    }
}
