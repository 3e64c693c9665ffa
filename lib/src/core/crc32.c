// SPDX-License-Identifier: MIT
// CRC-32 (IEEE, reflected 0xEDB88320) used to validate .vdm model blobs.
//
// Algorithm: table-driven CRC, one nibble per step with a 16-entry table
// (64 bytes of flash instead of 1 KiB for the byte-wise table; two lookups per
// byte). Reference: ISO/IEC 3309 / IEEE 802.3 CRC-32, identical to zlib's
// crc32() and Python's zlib.crc32. Bounds: time O(n), stack a few words.
#include "core/crc32.h"

// crc_table[i] = CRC of the 4-bit value i (reflected), i.e. i processed for 4 bits.
static const uint32_t crc_nibble_table[16] = {
    0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu,
    0x76DC4190u, 0x6B6B51F4u, 0x4DB26158u, 0x5005713Cu,
    0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
    0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu,
};

uint32_t vd__crc32(uint32_t crc, const void *p, size_t n)
{
    const uint8_t *b = (const uint8_t *)p;
    uint32_t c = ~crc;
    for (size_t i = 0u; i < n; i++) {
        c ^= (uint32_t)b[i];
        c = (c >> 4) ^ crc_nibble_table[c & 0x0Fu];
        c = (c >> 4) ^ crc_nibble_table[c & 0x0Fu];
    }
    return ~c;
}
