// SPDX-License-Identifier: MIT
// TFLite/CMSIS-NN int8 requantisation shared by the DBN and the CNN: reference steps, one-shift form.
//
// Reference semantics (docs/fixed-point.md "dbn", "Requantisation to the sigmoid's input"):
//   x    = shift > 0 ? saturate_int32(acc * 2^shift) : acc
//   high = SaturatingRoundingDoublingHighMul(x, mult)     (gemmlowp)
//   z    = RoundingDivideByPOT(high, max(-shift, 0))       (gemmlowp)
// i.e. TFLite MultiplyByQuantizedMultiplier on its default double-rounding
// path (not TFLITE_SINGLE_ROUNDING), CMSIS-NN arm_nn_requantize without
// CMSIS_NN_USE_SINGLE_ROUNDING. Private to lib/; tests include it directly.
#ifndef VD_REQUANT_H
#define VD_REQUANT_H

#include <stdint.h>

#include "vd/config.h"
#include "internal/shift_internal.h"

#define VD_RQ_SHIFT_MIN (-31)
#define VD_RQ_SHIFT_MAX 7
#define VD_RQ_MULT_MIN 0x40000000L

// gemmlowp SaturatingRoundingDoublingHighMul: round(a*b / 2^31) with ties
// away from zero via the nudge, truncating division as in C.
static inline int32_t vd_rq_srdhm(int32_t a, int32_t b)
{
    if (a == INT32_MIN && b == INT32_MIN) {
        return INT32_MAX;
    }
    const int64_t ab = (int64_t)a * (int64_t)b;
    const int64_t nudge = (ab >= 0) ? ((int64_t)1 << 30) : (1 - ((int64_t)1 << 30));
    return (int32_t)((ab + nudge) / ((int64_t)1 << 31));
}

// gemmlowp RoundingDivideByPOT: x / 2^e rounded half away from zero, e 0..31.
static inline int32_t vd_rq_rounding_divide_by_pot(int32_t x, int32_t e)
{
    const uint32_t mask = ((uint32_t)1 << (uint32_t)e) - 1u;
    const uint32_t remainder = (uint32_t)x & mask;
    uint32_t threshold = mask >> 1;
    if (x < 0) {
        threshold += 1u;
    }
    int32_t r = vd_shr_floor_i32(x, (uint32_t)e);
    if (remainder > threshold) {
        r += 1;
    }
    return r;
}

// The reference: round(acc * mult_q31 * 2^(shift-31)) exactly as above.
// shift in -31..7 and mult_q31 >= 0 (VD_ASSERT). Where shift > 0 and
// acc << shift leaves int32 (undefined in TFLite) the shifted value saturates.
static inline int32_t vd_rq_requantize(int32_t acc, int32_t mult_q31, int32_t shift)
{
    VD_ASSERT(shift >= VD_RQ_SHIFT_MIN && shift <= VD_RQ_SHIFT_MAX);
    VD_ASSERT(mult_q31 >= 0);
    int32_t x = acc;
    if (shift > 0) {
        int64_t v = (int64_t)acc * ((int64_t)1 << shift);
        if (v > INT32_MAX) {
            v = INT32_MAX;
        } else if (v < INT32_MIN) {
            v = INT32_MIN;
        }
        x = (int32_t)v;
    }
    const int32_t right = (shift < 0) ? -shift : 0;
    return vd_rq_rounding_divide_by_pot(vd_rq_srdhm(x, mult_q31), right);
}

// ----------------------------------------------------------- one-shift form
// For mult in [2^30, 2^31-1] the two roundings fold into one floor shift of
// the 64-bit product (the CNN kernels use this per output value):
//  * mult > 0, so srdhm's nudge picks 2^30 exactly when ab + 2^30 >= 0, and
//    trunc((ab + 1 - 2^30) / 2^31) = floor((ab + 2^30) / 2^31) for ab < 0;
//    hence high = floor((ab + 2^30) / 2^31) for every ab = x * mult.
//  * RoundingDivideByPOT(high, e), e >= 1, is floor((high + 2^(e-1) - n) / 2^e)
//    with n = (high < 0): the remainder test rem > 2^(e-1) - 1 + n.
//  * floor((floor(A / M) + c) / N) = floor((A + c M) / (M N)) for integers.
// So z = floor((ab + R) / 2^s), s = 31 + e, R = 2^30 + (2^(e-1) - n) 2^31
// (R = 2^30 when e = 0), n = (ab + 2^30 < 0) = (x <= thr) with thr = -1 if
// mult > 2^30 else -2 (x = -1 gives ab = -mult). |ab| < 2^62, |R| <= 2^61 +
// 2^30, and z lies in int32 (it is what RoundingDivideByPOT returns).
// Unsigned evaluation (cheap: no 64-bit compare, no arithmetic shift, no
// branch): with u = x + 2^31 in [0, 2^32), ab + R + 2^63 = u * mult + k where
// k = R - 2^31 mult + 2^63 (k - dk when n = 1); that sum lies in [0, 2^64), so the uint64
// arithmetic is exact, and z = ((u * mult + k) >> s) - 2^(63-s), taken
// modulo 2^32 (z fits int32). tests/unit/test_cnn.c checks this form against
// vd_rq_requantize on edge and random values.
typedef struct vd_rq_ch {
    uint64_t k;       // k for x > thr (R with n = 0)
    uint32_t mult;    // Q31 multiplier, 2^30 .. 2^31-1
    uint32_t dk;      // k(x > thr) - k(x <= thr): 2^31 if e > 0, else 0
    int32_t thr;      // -1 or -2
    uint32_t off;     // 2^(63-s) mod 2^32
    int32_t bias;     // added to the sum of products first (modulo 2^32)
    uint8_t rsh;      // s = 31 + max(-shift, 0)
    uint8_t lsh;      // max(shift, 0): acc * 2^lsh saturated to int32 first
} vd_rq_ch_t;

// Two's-complement reinterpretation without implementation-defined casts
// (gcc and clang compile it to nothing).
static inline int32_t vd_rq_u32_to_i32(uint32_t u)
{
    if (u <= (uint32_t)INT32_MAX) {
        return (int32_t)u;
    }
    return -(int32_t)(~u) - 1;
}

static inline void vd_rq_prepare(int32_t mult_q31, int32_t shift, int32_t bias, vd_rq_ch_t *c)
{
    VD_ASSERT(shift >= VD_RQ_SHIFT_MIN && shift <= VD_RQ_SHIFT_MAX);
    VD_ASSERT(mult_q31 >= VD_RQ_MULT_MIN);
    const uint32_t e = (shift < 0) ? (uint32_t)-shift : 0u;
    const uint32_t s = 31u + e;
    const uint64_t base = ((uint64_t)1 << 63) - ((uint64_t)1 << 31) * (uint64_t)mult_q31 + ((uint64_t)1 << 30);
    c->k = base + ((e > 0u) ? ((uint64_t)1 << (e - 1u)) << 31 : 0u);
    c->mult = (uint32_t)mult_q31;
    c->dk = (e > 0u) ? (uint32_t)1 << 31 : 0u;
    c->thr = (mult_q31 > (int32_t)VD_RQ_MULT_MIN) ? -1 : -2;
    c->off = (uint32_t)(((uint64_t)1 << 63) >> s);
    c->bias = bias;
    c->rsh = (uint8_t)s;
    c->lsh = (uint8_t)((shift > 0) ? shift : 0);
}

// acc * 2^lsh saturated to int32 (only for shift > 0, rare in trained nets).
static inline int32_t vd_rq_lshift_sat(int32_t acc, uint32_t lsh)
{
    int64_t v = (int64_t)acc * ((int64_t)1 << lsh);
    if (v > INT32_MAX) {
        v = INT32_MAX;
    } else if (v < INT32_MIN) {
        v = INT32_MIN;
    }
    return (int32_t)v;
}

// z from x (= bias + sum, shifted if lsh): the one-shift form. The mask
// form of the k selection (and no 64-bit compare) lets gcc vectorise a loop
// of these with SSE2 (pmuludq, psrlq) when the channel is loop-invariant.
static inline int32_t vd_rq_z(int32_t x, uint64_t k, uint32_t mult, uint32_t dk, int32_t thr, uint32_t rsh,
                              uint32_t off)
{
    const uint32_t neg = (uint32_t)0 - (uint32_t)(x <= thr);
    const uint64_t v = (uint64_t)((uint32_t)x ^ 0x80000000u) * mult + k - (uint64_t)(neg & dk);
    return vd_rq_u32_to_i32((uint32_t)(v >> rsh) - off);
}

// vd_rq_z with the sign term dropped (n = 0 always), from xb = bias + sum
// as uint32 (shift <= 0 only). Equal to vd_rq_z where x > thr. Where x <= thr
// (high < 0) both are <= 0: the reference RoundingDivideByPOT(high, e) of a
// negative high is <= 0, and the n = 0 value floor((high + 2^(e-1)) / 2^e)
// is <= 0 because high + 2^(e-1) <= 2^(e-1) - 1 < 2^e (e = 0: dk = 0, the two
// coincide). Hence max(vd_rq_z, lo) == max(vd_rq_z_nn, lo) for every lo >= 0:
// kernels use it for layers with act_min >= zp (ReLU). Plain uint32/uint64
// lanes with no compare, so gcc vectorises a loop of it (pmuludq, psrlq).
// tests/unit/test_cnn.c checks it against vd_rq_requantize.
static inline int32_t vd_rq_z_nn(uint32_t xb, uint64_t k, uint32_t mult, uint32_t rsh, uint32_t off)
{
    const uint64_t v = (uint64_t)(xb ^ 0x80000000u) * mult + k;
    return vd_rq_u32_to_i32((uint32_t)(v >> rsh) - off);
}

// requantize(sum + bias) of one channel by the one-shift form.
static inline int32_t vd_rq_apply(int32_t sum, const vd_rq_ch_t *c)
{
    int32_t x = vd_rq_u32_to_i32((uint32_t)c->bias + (uint32_t)sum);
    if (c->lsh != 0u) {
        x = vd_rq_lshift_sat(x, c->lsh);
    }
    return vd_rq_z(x, c->k, c->mult, c->dk, c->thr, c->rsh, c->off);
}

#endif
