/* Two implementations, one result, chosen by the board (CRC32_SLICE8 in fw_config.h):
 * - four bits per table step: 16 entries, small enough for any MCU's flash, ~8x faster than
 *   the bitwise loop (255 MB/s on a Zen 4 core);
 * - slicing by 8: eight bytes per step through 8 x 256 entries (8 KB; ~2 GB/s), for boards that
 *   check megabytes per round (the fleet's states: every received state is CRC-checked).
 * The tables of crc32_slice8.h come from the byte table t0 (the nibble loop below run for one
 * byte) by t[k][i] = (t[k-1][i] >> 8) ^ t0[t[k-1][i] & 0xFF]. */
#include "common/crc32.h"

#if CRC32_SLICE8
#include "common/crc32_slice8.h"
#endif

/* A third on x86-64 built with PCLMULQDQ (the host's -march=native): carry-less multiplies
 * fold 64 bytes per step (the folding of Intel's "Fast CRC Computation for Generic
 * Polynomials Using PCLMULQDQ", the constants of the reflected IEEE polynomial as zlib's and
 * Linux's use them), about 10 GB/s against slicing by 8's 2 GB/s: a fleet member checks
 * every neighbour's whole state each round. The tables finish what is not whole 16-byte
 * blocks; the result is the same CRC. */
#if defined(__x86_64__) && defined(__PCLMUL__) && defined(__SSE4_1__)
#define CRC32_FOLD 1
#include <immintrin.h>

/* The CRC register (already inverted) over len bytes, len >= 64 and a multiple of 16. */
static uint32_t crc32_fold(uint32_t crc, const uint8_t *p, size_t len)
{
    const __m128i k1k2 = _mm_set_epi64x(0x01c6e41596, 0x0154442bd4);
    const __m128i k3k4 = _mm_set_epi64x(0x00ccaa009e, 0x01751997d0);
    const __m128i k5 = _mm_set_epi64x(0, 0x0163cd6124);
    const __m128i poly = _mm_set_epi64x(0x01f7011641, 0x01db710641); /* u', P' */
    __m128i x1 = _mm_loadu_si128((const __m128i *)(const void *)(p + 0));
    __m128i x2 = _mm_loadu_si128((const __m128i *)(const void *)(p + 16));
    __m128i x3 = _mm_loadu_si128((const __m128i *)(const void *)(p + 32));
    __m128i x4 = _mm_loadu_si128((const __m128i *)(const void *)(p + 48));
    x1 = _mm_xor_si128(x1, _mm_cvtsi32_si128((int)crc));
    p += 64;
    len -= 64;
    for (; len >= 64; p += 64, len -= 64) {
        const __m128i x5 = _mm_clmulepi64_si128(x1, k1k2, 0x00), x6 = _mm_clmulepi64_si128(x2, k1k2, 0x00),
                      x7 = _mm_clmulepi64_si128(x3, k1k2, 0x00), x8 = _mm_clmulepi64_si128(x4, k1k2, 0x00);
        x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, k1k2, 0x11), x5),
                           _mm_loadu_si128((const __m128i *)(const void *)(p + 0)));
        x2 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x2, k1k2, 0x11), x6),
                           _mm_loadu_si128((const __m128i *)(const void *)(p + 16)));
        x3 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x3, k1k2, 0x11), x7),
                           _mm_loadu_si128((const __m128i *)(const void *)(p + 32)));
        x4 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x4, k1k2, 0x11), x8),
                           _mm_loadu_si128((const __m128i *)(const void *)(p + 48)));
    }
    /* Four lanes into one, then the remaining 16-byte blocks. */
    const __m128i lanes[3] = {x2, x3, x4};
    for (int i = 0; i < 3; i++)
        x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, k3k4, 0x11), lanes[i]),
                           _mm_clmulepi64_si128(x1, k3k4, 0x00));
    for (; len >= 16; p += 16, len -= 16)
        x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, k3k4, 0x11),
                                         _mm_loadu_si128((const __m128i *)(const void *)p)),
                           _mm_clmulepi64_si128(x1, k3k4, 0x00));
    /* 128 bits to 64, to 32, then Barrett's reduction. */
    const __m128i lo32 = _mm_setr_epi32(~0, 0, ~0, 0);
    x1 = _mm_xor_si128(_mm_srli_si128(x1, 8), _mm_clmulepi64_si128(x1, k3k4, 0x10));
    x1 = _mm_xor_si128(_mm_clmulepi64_si128(_mm_and_si128(x1, lo32), k5, 0x00), _mm_srli_si128(x1, 4));
    __m128i x = _mm_clmulepi64_si128(_mm_and_si128(x1, lo32), poly, 0x10);
    x = _mm_clmulepi64_si128(_mm_and_si128(x, lo32), poly, 0x00);
    return (uint32_t)_mm_extract_epi32(_mm_xor_si128(x1, x), 1);
}
#endif

static const uint32_t crc_nibble[16] = {
    0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u,
    0x4DB26158u, 0x5005713Cu, 0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
    0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu,
};

uint32_t crc32_ieee_update(uint32_t crc, const void *data, size_t len)
{
    const uint8_t *p = data;
    crc = ~crc;
#ifdef CRC32_FOLD
    if (len >= 64) {
        const size_t whole = len & ~(size_t)15;
        crc = crc32_fold(crc, p, whole);
        p += whole;
        len -= whole;
    }
#endif
#if CRC32_SLICE8
    /* Eight bytes at a time (assembled little-endian byte by byte: any alignment, any CPU). */
    for (; len >= 8; p += 8, len -= 8) {
        const uint32_t lo = crc ^ ((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
        const uint32_t hi = (uint32_t)p[4] | (uint32_t)p[5] << 8 | (uint32_t)p[6] << 16 | (uint32_t)p[7] << 24;
        crc = crc32_slice8[7][lo & 0xFFu] ^ crc32_slice8[6][(lo >> 8) & 0xFFu] ^ crc32_slice8[5][(lo >> 16) & 0xFFu] ^
              crc32_slice8[4][lo >> 24] ^ crc32_slice8[3][hi & 0xFFu] ^ crc32_slice8[2][(hi >> 8) & 0xFFu] ^
              crc32_slice8[1][(hi >> 16) & 0xFFu] ^ crc32_slice8[0][hi >> 24];
    }
#endif
    for (size_t i = 0; i < len; i++) {
        crc ^= p[i];
        crc = (crc >> 4) ^ crc_nibble[crc & 15u];
        crc = (crc >> 4) ^ crc_nibble[crc & 15u];
    }
    return ~crc;
}

uint32_t crc32_ieee(const void *data, size_t len)
{
    return crc32_ieee_update(0u, data, len);
}
