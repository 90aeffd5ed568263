/* CRC-32 by carry-less multiply folding: see crc32_x86.h. */
#include "common/crc32_x86.h"

#ifdef CRC32_FOLD
#include <immintrin.h>

/* On x86-64 built with PCLMULQDQ (the host's -march=native): carry-less multiplies
 * fold 64 bytes per step (the folding of Intel's "Fast CRC Computation for Generic
 * Polynomials Using PCLMULQDQ", the constants of the reflected IEEE polynomial as zlib's and
 * Linux's use them), about 10 GB/s against slicing by 8's 2 GB/s: a fleet member checks
 * every neighbour's whole state each round. The tables finish what is not whole 16-byte
 * blocks; the result is the same CRC. */

/* The CRC register (already inverted) over len bytes, len >= 64 and a multiple of 16. */
uint32_t crc32_fold(uint32_t crc, const uint8_t *p, size_t len)
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
