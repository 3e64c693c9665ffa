// SPDX-License-Identifier: MIT
// Exact comparison of ratios a^2/da used by Otsu-style criteria (shared with refine's max-distance).
#ifndef VD_OTSU_INTERNAL_H
#define VD_OTSU_INTERNAL_H

#include <stdint.h>
#include <stdbool.h>

// Full 64 x 64 -> 128-bit unsigned product as (hi, lo) words, from four
// 32 x 32 -> 64-bit partial products (portable C99, no __int128).
static inline void vd_mul_u64_wide(uint64_t a, uint64_t b, uint64_t *hi, uint64_t *lo)
{
    const uint64_t a0 = a & 0xFFFFFFFFu, a1 = a >> 32;
    const uint64_t b0 = b & 0xFFFFFFFFu, b1 = b >> 32;
    const uint64_t p00 = a0 * b0, p01 = a0 * b1, p10 = a1 * b0, p11 = a1 * b1;
    // Middle column: at most 3 * (2^32 - 1) summands of 32 bits -> fits 64 bits.
    const uint64_t mid = (p00 >> 32) + (p01 & 0xFFFFFFFFu) + (p10 & 0xFFFFFFFFu);
    *lo = (mid << 32) | (p00 & 0xFFFFFFFFu);
    *hi = p11 + (p01 >> 32) + (p10 >> 32) + (mid >> 32);
}

// 192-bit unsigned value, w[2] most significant.
typedef struct vd_u192 {
    uint64_t w[3];
} vd_u192_t;

// a^2 * d exactly (a^2 < 2^128, times d < 2^64 gives < 2^192: never overflows).
static inline vd_u192_t vd_sq_mul_u64(uint64_t a, uint64_t d)
{
    uint64_t sh, sl, h1, l1, h2, l2;
    vd_u192_t r;
    vd_mul_u64_wide(a, a, &sh, &sl);
    vd_mul_u64_wide(sl, d, &h1, &l1);
    vd_mul_u64_wide(sh, d, &h2, &l2);
    r.w[0] = l1;
    r.w[1] = h1 + l2;
    r.w[2] = h2 + (r.w[1] < l2 ? 1u : 0u); // carry out of the middle word
    return r;
}

// true if x > y.
static inline bool vd_u192_gt(const vd_u192_t *x, const vd_u192_t *y)
{
    if (x->w[2] != y->w[2]) {
        return x->w[2] > y->w[2];
    }
    if (x->w[1] != y->w[1]) {
        return x->w[1] > y->w[1];
    }
    return x->w[0] > y->w[0];
}

// Exact a^2 / da > b^2 / db for any uint64 a, b and da, db >= 1, by
// cross-multiplication a^2 * db > b^2 * da in 192 bits. This is the
// comparison behind Otsu's between-class variance (a = |N*s0 - n0*S|,
// da = n0 * (N - n0)); refine's max-distance criterion can reuse it.
static inline bool vd_ratio_sq_gt(uint64_t a, uint64_t da, uint64_t b, uint64_t db)
{
    const vd_u192_t x = vd_sq_mul_u64(a, db);
    const vd_u192_t y = vd_sq_mul_u64(b, da);
    return vd_u192_gt(&x, &y);
}

#endif
