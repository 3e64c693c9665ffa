// SPDX-License-Identifier: MIT
// Shared helpers of vd's fuzz harnesses: a byte reader for structured inputs and a finding check.
#ifndef VD_FUZZ_COMMON_H
#define VD_FUZZ_COMMON_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

// The entry point every harness defines (libFuzzer's name, also called by replay_main.c).
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

// A finding: print where and why, then abort so libFuzzer (and CTest) report it.
#define FZ_CHECK(cond)                                                                 \
    do {                                                                               \
        if (!(cond)) {                                                                 \
            fprintf(stderr, "%s:%d: fuzz invariant failed: %s\n", __FILE__, __LINE__, #cond); \
            abort();                                                                   \
        }                                                                              \
    } while (0)

// Consumes the input front to back; reads past the end give zeros, so every
// input, even an empty one, decodes to some parameters.
typedef struct fz_reader {
    const uint8_t *p;
    size_t n;
} fz_reader_t;

static inline void fz_init(fz_reader_t *r, const uint8_t *data, size_t size)
{
    r->p = data;
    r->n = size;
}

static inline uint8_t fz_u8(fz_reader_t *r)
{
    if (r->n == 0u) {
        return 0u;
    }
    uint8_t v = r->p[0];
    r->p++;
    r->n--;
    return v;
}

static inline uint16_t fz_u16(fz_reader_t *r)
{
    uint16_t lo = fz_u8(r);
    return (uint16_t)(lo | (uint16_t)(fz_u8(r) << 8));
}

static inline uint32_t fz_u32(fz_reader_t *r)
{
    uint32_t lo = fz_u16(r);
    return lo | ((uint32_t)fz_u16(r) << 16);
}

// Exactly `n` bytes of heap (at least 1), so AddressSanitizer sees any access past them.
// malloc's alignment (16 on glibc) satisfies VD_WORKSPACE_ALIGN.
static inline void *fz_alloc(size_t n)
{
    void *p = malloc(n == 0u ? 1u : n);
    if (p == NULL) {
        abort();
    }
    return p;
}

// Fills a w x h plane (stride bytes) from the reader: mode 0 = one input byte per pixel,
// otherwise one input bit per pixel (0 or `on`), which gives the sparse masks that
// make interesting shapes. Padding between rows is set to 0xA5.
static inline void fz_fill_plane(fz_reader_t *r, uint8_t *buf, uint32_t w, uint32_t h, size_t stride, int bits,
                                 uint8_t on)
{
    uint8_t cur = 0u;
    uint32_t left = 0u;
    for (uint32_t y = 0u; y < h; y++) {
        uint8_t *row = buf + (size_t)y * stride;
        if (y + 1u < h) {
            memset(row + w, 0xA5, stride - w);
        }
        for (uint32_t x = 0u; x < w; x++) {
            if (!bits) {
                row[x] = fz_u8(r);
                continue;
            }
            if (left == 0u) {
                cur = fz_u8(r);
                left = 8u;
            }
            row[x] = (cur & 1u) ? on : 0u;
            cur = (uint8_t)(cur >> 1);
            left--;
        }
    }
}

// Bytes of a plane with `h` rows of `row` bytes at `stride`: the last row ends at
// stride*(h-1)+row (no padding after it), so an over-read of the last row is caught.
static inline size_t fz_plane_bytes(size_t stride, uint32_t h, size_t row)
{
    return stride * (size_t)(h - 1u) + row;
}

// .vdm helpers: little-endian u32 and the CRC-32 (IEEE, reflected) the container stores,
// written out here so a harness can repair CRCs without the library's internals.
static inline uint32_t fz_rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static inline uint32_t fz_crc32(const uint8_t *p, size_t n)
{
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0u; i < n; i++) {
        c ^= p[i];
        for (int k = 0; k < 8; k++) {
            c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
        }
    }
    return ~c;
}

#endif
