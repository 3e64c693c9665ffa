// SPDX-License-Identifier: MIT
// CRC-32 (IEEE 802.3, as zlib.crc32) for model blob validation. Private to lib/.
#ifndef VD_CRC32_H
#define VD_CRC32_H

#include <stddef.h>
#include <stdint.h>

// Continues a CRC-32 over n bytes at p. Start with crc = 0 for a new message;
// the result of one call can be passed to the next for a message in pieces.
// Reflected polynomial 0xEDB88320, initial value and final XOR 0xFFFFFFFF
// (handled inside, so vd__crc32(0, "123456789", 9) == 0xCBF43926).
uint32_t vd__crc32(uint32_t crc, const void *p, size_t n);

#endif
