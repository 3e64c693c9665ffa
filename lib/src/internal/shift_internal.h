// SPDX-License-Identifier: MIT
// Private: portable floor and rounding right shifts of signed values (C99 leaves >> of negatives implementation-defined).
// The one place lib/ shifts a value that may be negative: every such shift goes through these helpers.
#ifndef VD_SHIFT_INTERNAL_H
#define VD_SHIFT_INTERNAL_H

#include <stdint.h>

// floor(x / 2^n) for any int64 x and 0 <= n <= 63. For x < 0, ~x = -x - 1 is
// non-negative, and floor(x / 2^n) = ~floor((-x - 1) / 2^n): only shifts of
// non-negative values, whose result C99 defines. Equal to the arithmetic
// shift that gcc and clang emit for x >> n (so results are bit-exact with the
// code that used >> on those compilers), and to numpy's `x >> n` on int64.
static inline int64_t vd_shr_floor_i64(int64_t x, uint32_t n)
{
    return (x >= 0) ? (x >> n) : ~((~x) >> n);
}

// floor(x / 2^n) for any int32 x and 0 <= n <= 31: as vd_shr_floor_i64 (the
// gemmlowp RoundingDivideByPOT of models/requant.h rounds on top of it).
static inline int32_t vd_shr_floor_i32(int32_t x, uint32_t n)
{
    return (x >= 0) ? (x >> n) : ~((~x) >> n);
}

// round-half-up(x / 2^n) = floor((x + 2^(n-1)) / 2^n) for 1 <= n <= 62; the
// caller keeps x + 2^(n-1) inside int64. Ties go towards +infinity (-1.5 ->
// -1), as the `(x + half) >> n` idiom it replaces did on gcc and clang.
static inline int64_t vd_shr_round_i64(int64_t x, uint32_t n)
{
    return vd_shr_floor_i64(x + ((int64_t)1 << (n - 1u)), n);
}

#endif
