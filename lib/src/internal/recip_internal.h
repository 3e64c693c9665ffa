// SPDX-License-Identifier: MIT
// Exact division by a run-time constant through a reciprocal multiply, for quotients below 256 (rounded means).
#ifndef VD_RECIP_INTERNAL_H
#define VD_RECIP_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

// floor(x / n) for every x < 256 * n, as (x * m) >> k with m = ceil(2^k / n)
// and k = 8 + 2L, 2^L >= n. Why exact: x*m / 2^k = x/n + x*e / (n * 2^k)
// with e = m*n - 2^k in [0, n); x < 256n makes the error term < 256n / 2^k
// <= 1/n, and x/n has a fractional part <= (n-1)/n, so the floor is
// unchanged. Product bound: x*m < 256n * (2^k/n + 1) <= 2^(16+2L) + 2^(8+L),
// < 2^63 for L <= 23; for n <= 2^16 both x (< 2^24) and m (< 2^25) fit 32
// bits (one 32x32->64 multiply on Cortex-M). Divisors above 2^23 are not
// handled (init returns false: the caller divides).
typedef struct vd_recip256 {
    uint32_t m;   // < 2^32 for n <= 2^23 (below), so x*m is a 32x32->64 product for x < 2^32
    uint32_t k;
} vd_recip256_t;

// Largest divisor vd_recip256_init accepts.
#define VD_RECIP256_MAX_DIV (1u << 23)

static inline bool vd_recip256_init(uint32_t n, vd_recip256_t *r)
{
    r->m = 1u;   // identity until set (keeps the struct defined on failure)
    r->k = 0u;
    if (n == 0u || n > VD_RECIP256_MAX_DIV) {
        return false;
    }
    uint32_t l = 0u;
    while (l < 23u && (1u << l) < n) {   // smallest L with 2^L >= n
        l++;
    }
    r->k = 8u + 2u * l;
    // m < 2^(k)/2^(L-1) + 1 = 2^(L+9) + 1 <= 2^31 + 1 for L <= 22; for L = 23,
    // n > 2^22 gives 2^54 / n < 2^32 - 1023: m fits 32 bits.
    r->m = (uint32_t)(((1ull << r->k) + (uint64_t)n - 1u) / (uint64_t)n);
    return true;
}

// floor(x / n) for x < 256 * n (the divisor given to vd_recip256_init).
static inline uint32_t vd_recip256_div(const vd_recip256_t *r, uint64_t x)
{
    return (uint32_t)((x * r->m) >> r->k);
}

// The same for x < 2^32: one 32x32->64 multiply (UMULL; pmuludq in SIMD loops).
static inline uint32_t vd_recip256_div32(uint32_t m, uint32_t k, uint32_t x)
{
    return (uint32_t)(((uint64_t)x * m) >> k);
}

#endif
