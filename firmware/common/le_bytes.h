/* Little-endian fields in byte buffers, whatever the host's byte order: the one set of helpers
 * every file format and wire message of the project uses (checkpoints' posterior, telemetry,
 * sample files, coverage files). Floats travel as their IEEE-754 bit patterns. Pure, no state;
 * p must hold the field's bytes. */
#ifndef COMMON_LE_BYTES_H
#define COMMON_LE_BYTES_H

#include <stdint.h>
#include <string.h>

static inline void le_put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

static inline void le_put_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static inline void le_put_u64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static inline void le_put_f32(uint8_t *p, float f)
{
    uint32_t v;
    memcpy(&v, &f, sizeof v);
    le_put_u32(p, v);
}

static inline void le_put_f64(uint8_t *p, double d)
{
    uint64_t v;
    memcpy(&v, &d, sizeof v);
    le_put_u64(p, v);
}

static inline uint16_t le_get_u16(const uint8_t *p)
{
    return (uint16_t)(p[0] | (p[1] << 8));
}

static inline uint32_t le_get_u32(const uint8_t *p)
{
    uint32_t v = 0;
    for (int i = 0; i < 4; i++)
        v |= (uint32_t)p[i] << (8 * i);
    return v;
}

static inline uint64_t le_get_u64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; i++)
        v |= (uint64_t)p[i] << (8 * i);
    return v;
}

static inline float le_get_f32(const uint8_t *p)
{
    const uint32_t v = le_get_u32(p);
    float f;
    memcpy(&f, &v, sizeof f);
    return f;
}

static inline double le_get_f64(const uint8_t *p)
{
    const uint64_t v = le_get_u64(p);
    double d;
    memcpy(&d, &v, sizeof d);
    return d;
}

#endif /* COMMON_LE_BYTES_H */
