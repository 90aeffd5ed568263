/* Bounds check of fleet datagrams before any decoder: see hal_host_msg.h. */
#include "hal_host_msg.h"

#include "hal/hal_net.h"
#include "lcm/fleetsim_chunk_request_t.h"
#include "lcm/fleetsim_round_complete_t.h"
#include "lcm/fleetsim_state_chunk_t.h"

enum field_kind { F_I8, F_I32, F_F64, F_BYTES, F_I32_ARRAY, F_END };

typedef struct field {
    enum field_kind kind;
    int len_field; /* F_BYTES / F_I32_ARRAY: index of the int32 field holding the count */
    int64_t max;   /* F_BYTES / F_I32_ARRAY: largest count accepted */
} field_t;

/* A datagram is at most one MTU, so no array may claim more elements than fit in it. */
#define MAX_BYTES ((int64_t)HAL_NET_MTU_BYTES)
#define MAX_I32S ((int64_t)HAL_NET_MTU_BYTES / 4)

/* The fields of the .lcm files in firmware/msg, in declaration order. */
static const field_t STATE_CHUNK[] = {
    {F_I32, 0, 0}, /* sender */
    {F_I32, 0, 0}, /* round */
    {F_I32, 0, 0}, /* chunk */
    {F_I32, 0, 0}, /* n_chunks */
    {F_I32, 0, 0}, /* state_bytes */
    {F_I8, 0, 0},  /* encoding */
    {F_I32, 0, 0}, /* crc32 */
    {F_F64, 0, 0}, /* x_m */
    {F_F64, 0, 0}, /* y_m */
    {F_I32, 0, 0}, /* incarnation */
    {F_I32, 0, 0}, /* n_bytes */
    {F_BYTES, 10, MAX_BYTES}, /* data[n_bytes] */
    {F_END, 0, 0},
};
static const field_t ROUND_COMPLETE[] = {
    {F_I32, 0, 0}, /* sender */
    {F_I32, 0, 0}, /* round */
    {F_I32, 0, 0}, /* incarnation */
    {F_END, 0, 0},
};
static const field_t CHUNK_REQUEST[] = {
    {F_I32, 0, 0}, /* requester */
    {F_I32, 0, 0}, /* target */
    {F_I32, 0, 0}, /* round */
    {F_I32, 0, 0}, /* incarnation */
    {F_I32, 0, 0}, /* n_chunks */
    {F_I32_ARRAY, 4, MAX_I32S}, /* chunks[n_chunks] */
    {F_END, 0, 0},
};

static int64_t get_i32(const uint8_t *p)
{
    return (int32_t)((uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3]);
}

static int64_t fingerprint(hal_host_msg_type_t type)
{
    switch (type) {
    case HAL_HOST_MSG_STATE_CHUNK: return __fleetsim_state_chunk_t_get_hash();
    case HAL_HOST_MSG_ROUND_COMPLETE: return __fleetsim_round_complete_t_get_hash();
    case HAL_HOST_MSG_CHUNK_REQUEST: return __fleetsim_chunk_request_t_get_hash();
    default: return 0;
    }
}

hal_host_msg_reject_t hal_host_msg_check(hal_host_msg_type_t type, const void *data, size_t len)
{
    static const field_t *const layout[HAL_HOST_MSG_TYPE_COUNT] = {
        [HAL_HOST_MSG_STATE_CHUNK] = STATE_CHUNK,
        [HAL_HOST_MSG_ROUND_COMPLETE] = ROUND_COMPLETE,
        [HAL_HOST_MSG_CHUNK_REQUEST] = CHUNK_REQUEST,
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
    if ((int64_t)fp != fingerprint(type))
        return HAL_HOST_MSG_FINGERPRINT;
    size_t at = 8;
    int64_t ints[16] = {0}; /* values of the scalar fields, by field index */
    const field_t *f = layout[type];
    for (int i = 0; f[i].kind != F_END; i++) {
        size_t need;
        switch (f[i].kind) {
        case F_I8:
            need = 1;
            break;
        case F_I32:
            need = 4;
            break;
        case F_F64:
            need = 8;
            break;
        default: {
            const int64_t n = ints[f[i].len_field];
            if (n < 0 || n > f[i].max)
                return HAL_HOST_MSG_BAD_LENGTH;
            need = (size_t)n * (f[i].kind == F_BYTES ? 1u : 4u);
            break;
        }
        }
        if (len - at < need)
            return HAL_HOST_MSG_SHORT;
        if (f[i].kind == F_I32 && i < 16)
            ints[i] = get_i32(p + at);
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
