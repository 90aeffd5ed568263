/* CRC-32 (IEEE 802.3: reflected polynomial 0xEDB88320, init and final xor 0xFFFFFFFF),
 * as used by zlib, PNG and Ethernet. crc32_ieee("123456789") == 0xCBF43926.
 * Table-driven (a 64-byte nibble table, or slicing by 8 with 8 KB of tables where the board
 * sets CRC32_SLICE8; carry-less multiply folding on x86-64 built with PCLMULQDQ), no state,
 * no allocation, thread-safe. */
#ifndef COMMON_CRC32_H
#define COMMON_CRC32_H

#include <stddef.h>
#include <stdint.h>

/* CRC of len bytes. */
uint32_t crc32_ieee(const void *data, size_t len);

/* Incremental form: crc = 0 to start, then feed pieces: crc32_ieee_update(crc, p, n).
 * crc32_ieee_update(0, d, n) == crc32_ieee(d, n). */
uint32_t crc32_ieee_update(uint32_t crc, const void *data, size_t len);

#endif /* COMMON_CRC32_H */
