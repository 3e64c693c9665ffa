// SPDX-License-Identifier: MIT
// Private checks shared by the .vdm loaders (dbn.c, cnn.c): reserved bytes, the name field and
// array placement inside a blob. Not installed.
#ifndef VD_BLOB_INTERNAL_H
#define VD_BLOB_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

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
