/* CRC-32 on x86-64 built with PCLMULQDQ and SSE 4.1: the folding kernel crc32_ieee_update uses
 * for whole 16-byte blocks (the tables of crc32.c, its reference, finish the rest and run
 * everywhere else). Internal to common/crc32.c. */
#ifndef COMMON_CRC32_X86_H
#define COMMON_CRC32_X86_H

#include <stddef.h>
#include <stdint.h>

#if defined(__x86_64__) && defined(__PCLMUL__) && defined(__SSE4_1__)
#define CRC32_FOLD 1
/* The CRC register (already inverted) over len bytes, len >= 64 and a multiple of 16. */
uint32_t crc32_fold(uint32_t crc, const uint8_t *p, size_t len);
#endif

#endif /* COMMON_CRC32_X86_H */
