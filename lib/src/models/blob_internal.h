// SPDX-License-Identifier: MIT
// Private checks shared by the .vdm loaders (models/dbn.c, models/cnn/loader.c, models/boost.c):
// little-endian reads, the common container (magic, version, header size, total size, CRC), reserved
// bytes, the name field and array placement inside a blob. Not installed.
#ifndef VD_BLOB_INTERNAL_H
#define VD_BLOB_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/crc32.h"
#include "vd/status.h"

// The container every .vdm kind starts with (docs/model-format.md): "VDMF", format version,
// header size, total size, CRC-32 of bytes [VD_BLOB_H_BODY, total).
#define VD_BLOB_MAGIC 0x464D4456u   // "VDMF" read little-endian
#define VD_BLOB_H_MAGIC 0u
#define VD_BLOB_H_VERSION 4u
#define VD_BLOB_H_HEADER_SIZE 6u
#define VD_BLOB_H_TOTAL 8u
#define VD_BLOB_H_CRC 12u
#define VD_BLOB_H_BODY 16u

static inline uint16_t vd_blob_u16(const uint8_t *p)
{
    return (uint16_t)((uint16_t)p[0] | (uint16_t)((uint16_t)p[1] << 8));
}

static inline uint32_t vd_blob_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

// Checks the container before any other size is trusted: bytes >= header_size, the magic, a
// version in [v_min, v_max], the header size, a total size that is a multiple of 4 inside bytes,
// and the CRC. Fills *version and *total. VD_ERR_MODEL for any mismatch.
static inline vd_status_t vd_blob_container(const uint8_t *b, size_t bytes, uint16_t v_min, uint16_t v_max,
                                            uint16_t header_size, uint16_t *version, uint32_t *total)
{
    if (bytes < header_size || vd_blob_u32(b + VD_BLOB_H_MAGIC) != VD_BLOB_MAGIC) {
        return VD_ERR_MODEL;
    }
    const uint16_t v = vd_blob_u16(b + VD_BLOB_H_VERSION);
    if (v < v_min || v > v_max || vd_blob_u16(b + VD_BLOB_H_HEADER_SIZE) != header_size) {
        return VD_ERR_MODEL;
    }
    const uint32_t t = vd_blob_u32(b + VD_BLOB_H_TOTAL);
    if (t < header_size || (size_t)t > bytes || (t % 4u) != 0u ||
        vd__crc32(0u, b + VD_BLOB_H_BODY, (size_t)t - VD_BLOB_H_BODY) != vd_blob_u32(b + VD_BLOB_H_CRC)) {
        return VD_ERR_MODEL;
    }
    *version = v;
    *total = t;
    return VD_OK;
}

// True when the n bytes at p are all zero (reserved fields must be, so that a
// newer writer's data is never silently ignored).
static inline bool vd_blob_all_zero(const uint8_t *p, size_t n)
{
    for (size_t i = 0u; i < n; i++) {
        if (p[i] != 0u) {
            return false;
        }
    }
    return true;
}

// Name field of len bytes: printable ASCII, then only NULs.
static inline bool vd_blob_name_ok(const uint8_t *p, uint32_t len)
{
    bool ended = false;
    for (uint32_t i = 0u; i < len; i++) {
        if (p[i] == 0u) {
            ended = true;
        } else if (ended || p[i] < 0x20u || p[i] > 0x7Eu) {
            return false;
        }
    }
    return true;
}

// One array: 4-byte aligned, inside [lo, total), in 64-bit arithmetic (no wrap-around).
static inline bool vd_blob_segment_ok(uint32_t off, uint64_t len, uint32_t lo, uint32_t total)
{
    return (off % 4u) == 0u && off >= lo && len <= (uint64_t)total && (uint64_t)off + len <= (uint64_t)total;
}

#endif
