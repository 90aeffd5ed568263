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

/* A third on x86-64 built with PCLMULQDQ: common/crc32_x86.c (the intrinsics stay in that
 * per-ISA file). */
#include "common/crc32_x86.h"

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
