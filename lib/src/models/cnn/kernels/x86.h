// SPDX-License-Identifier: MIT
// The x86-64 back end's shared part (AVX-512 VNNI, AVX-VNNI, AVX2): requantisation on vector lanes, target attributes.
//
// Included only by the x86 back end's files (kernels/*x86*.c, compiled when CMake's VD_CNN_X86 is ON):
// the one place besides them that includes <immintrin.h> (the include rule's named exception). Functions
// carry per-function target attributes, so the rest of the library keeps the compiler's baseline.
// Requantisation: the one-shift form of models/requant.h (vd_rq_z, vd_rq_z_nn, vd_rq_lshift_sat) on
// 16 (AVX-512) or 8 (AVX2) lanes: the 64-bit product u * mult of even and odd lanes by vpmuludq,
// + k (- dk), per-lane vpsrlvq. Same integer operations as the portable kernels, so the same bytes.
#ifndef VD_CNN_X86_H
#define VD_CNN_X86_H

#include <immintrin.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "models/cnn/cnn_internal.h"

#define X86_TARGET __attribute__((target("avx512f,avx512bw,avx512vl,avx512vnni")))
#define X86_INLINE static inline __attribute__((always_inline)) X86_TARGET
#define AVX2_TARGET __attribute__((target("avx2")))
#define AVX2_INLINE static inline __attribute__((always_inline)) AVX2_TARGET
#define AVXVNNI_TARGET __attribute__((target("avx2,avxvnni")))
#define AVXVNNI_INLINE static inline __attribute__((always_inline)) AVXVNNI_TARGET
// A file-local kernel called from one driver. gcc would clone a plain static
// one for that call site (constant propagation, argument changes): +5 %
// instructions in the AVX2 GEMM (callgrind, vd_cnn at 320x256); noipa keeps
// the code an external function gets.
#if defined(__GNUC__) && !defined(__clang__)
#define X86_KERNEL static __attribute__((noipa))
#else
#define X86_KERNEL static
#endif

// Output channels per vector (one 512-bit register of int32) and per GEMM
// tile (four vectors).
#define VD_CNN_X86_LANES 16u
#define VD_CNN_X86_TILE 64u

// Requantisation constants of 16 int32 lanes (any lane -> channel map):
// the vd_rq_ch_t fields spread for the even/odd 64-bit halves of
// _mm512_mul_epu32. bias includes the kernel's zero-point correction.
typedef struct vd_cnn_x86_rqv {
    int32_t bias[16];
    uint32_t bias_u[16];   // bias + 2^31 modulo 2^32: the AVX2 form without the sign term adds it to the sum
    uint32_t mult[16];   // Q31 multiplier
    uint32_t mult_sw[16];  // mult of lanes 2j + 1, 2j (the odd lanes' multiplier in the even places)
    int32_t thr[16];
    uint32_t dk[16];     // 0 or 2^31
    uint32_t off[16];
    uint32_t lsh[16];
    uint64_t k_e[8], k_o[8];       // k of lanes 2j, 2j + 1
    uint64_t rsh_e[8], rsh_o[8];   // s of lanes 2j, 2j + 1 (31..62)
} vd_cnn_x86_rqv_t;

// Layer-wide part of the requantisation (output clamp relative to the zero point).
typedef struct vd_cnn_x86_rq {
    int32_t zp, lo, hi;
    bool general;   // some channel has lsh > 0
    bool sign;      // the sign term is needed (not ReLU-clamped, or general)
    bool sat8;      // act_min -128, act_max 127: the clamp is int8 saturation of z + zp (sat8_16)
} vd_cnn_x86_rq_t;

// Prepared areas (vd_cnn_prepare): a layer's starts with its vd_cnn_x86_rq_t in this many bytes, then
// conv_x86.c's tiles (vd__cnn_x86_prep_conv) or dw3x3_x86.c's pass constants (vd__cnn_x86_prep_dw).
#define VD_CNN_X86_PREP_RQ 64u
size_t vd__cnn_x86_prep_conv(const vd_cnn_layer_t *L, int32_t zp_in, uint32_t level, uint8_t *dst);
size_t vd__cnn_x86_prep_dw(const vd_cnn_layer_t *L, int32_t zp_in, uint32_t level, uint8_t *dst);
// A kernel call's layer-wide requantisation flags: from the head of the layer's prepared area (*prep then
// points past them, at the tiles or pass constants), or made (vd__cnn_x86_rq_of) when *prep is NULL.
vd_cnn_x86_rq_t vd__cnn_x86_layer_rq(const vd_cnn_layer_t *L, const uint8_t **prep);

// Fills v for lanes 0..15: lane j takes output channel ch_of[j] of layer L
// (its bias, mult, shift; vd_rq_prepare), n_lanes lanes valid and the
// others copying lane 0, with corr[j] subtracted from the bias modulo 2^32
// (corr may be NULL).
void vd__cnn_x86_rqv_fill(vd_cnn_x86_rqv_t *v, const vd_cnn_layer_t *L, const uint32_t *ch_of, const int32_t *corr,
                         uint32_t n_lanes);

// Layer-wide requantisation flags of layer L (as vd__cnn_rq_setup's).
vd_cnn_x86_rq_t vd__cnn_x86_rq_of(const vd_cnn_layer_t *L);

// The shipped networks' case (output range all of int8, ReLU-clamped, one right shift): true then. *qc: q's
// values with those flags as constants, for the kernels' copies specialised on it (no branch per output).
static inline bool vd__cnn_x86_rq_shipped(const vd_cnn_x86_rq_t *q, vd_cnn_x86_rq_t *qc)
{
    const vd_cnn_x86_rq_t c = {q->zp, q->lo, q->hi, false, false, true};
    *qc = c;
    return q->sat8 && !q->sign && !q->general;
}

// z of requantize(acc + bias) on 16 lanes, before the clamp, as rq8_z on 8: vd_rq_apply's (general),
// vd_rq_z's (sign) or vd_rq_z_nn's in the portable kernels.
X86_INLINE __m512i rq16_z(__m512i acc, const vd_cnn_x86_rqv_t *c, const vd_cnn_x86_rq_t *q)
{
    __m512i x = acc, xu;
    if (!q->general && !q->sign) {
        // x itself is not needed: x + 2^31 = sum + (bias + 2^31), modulo 2^32.
        xu = _mm512_add_epi32(acc, _mm512_loadu_si512(c->bias_u));
    } else {
        x = _mm512_add_epi32(acc, _mm512_loadu_si512(c->bias));
        if (q->general) {
            // vd_rq_lshift_sat: x * 2^lsh, saturated where the shift changes the value.
            const __m512i sh = _mm512_loadu_si512(c->lsh);
            const __m512i t = _mm512_sllv_epi32(x, sh);
            const __mmask16 ovf = _mm512_cmpneq_epi32_mask(_mm512_srav_epi32(t, sh), x);
            const __m512i sat = _mm512_xor_si512(_mm512_srai_epi32(x, 31), _mm512_set1_epi32(INT32_MAX));
            x = _mm512_mask_blend_epi32(ovf, t, sat);
        }
        xu = _mm512_xor_si512(x, _mm512_set1_epi32(INT32_MIN));   // x + 2^31 as uint32
    }
    __m512i ve = _mm512_add_epi64(_mm512_mul_epu32(xu, _mm512_loadu_si512(c->mult)), _mm512_loadu_si512(c->k_e));
    __m512i vo = _mm512_add_epi64(_mm512_mul_epu32(_mm512_srli_epi64(xu, 32), _mm512_loadu_si512(c->mult_sw)),
                                  _mm512_loadu_si512(c->k_o));
    if (q->sign) {
        // - dk where x <= thr (modulo 2^64 like the portable uint64 sum).
        const __mmask16 neg = _mm512_cmple_epi32_mask(x, _mm512_loadu_si512(c->thr));
        const __m512i d = _mm512_maskz_mov_epi32(neg, _mm512_loadu_si512(c->dk));
        ve = _mm512_sub_epi64(ve, _mm512_and_si512(d, _mm512_set1_epi64(0xFFFFFFFFLL)));
        vo = _mm512_sub_epi64(vo, _mm512_srli_epi64(d, 32));
    }
    ve = _mm512_srlv_epi64(ve, _mm512_loadu_si512(c->rsh_e));
    vo = _mm512_srlv_epi64(vo, _mm512_loadu_si512(c->rsh_o));
    const __m512i z = _mm512_mask_blend_epi32((__mmask16)0xAAAAu, ve, _mm512_slli_epi64(vo, 32));
    return _mm512_sub_epi32(z, _mm512_loadu_si512(c->off));
}

// z = clamp(requantize(acc + bias), lo, hi) + zp on 16 lanes, as
// vd_cnn_rq_out(vd_rq_apply(..)) (general), vd_cnn_rq_out(vd_rq_z(..)) (sign) or
// vd_cnn_rq_out(vd_rq_z_nn(..)) in the portable kernels.
X86_INLINE __m512i rq16(__m512i acc, const vd_cnn_x86_rqv_t *c, const vd_cnn_x86_rq_t *q)
{
    __m512i z = rq16_z(acc, c, q);
    z = _mm512_max_epi32(z, _mm512_set1_epi32(q->lo));
    z = _mm512_min_epi32(z, _mm512_set1_epi32(q->hi));
    return _mm512_add_epi32(z, _mm512_set1_epi32(q->zp));
}

// Stores rq16's bytes of 16 lanes to d (lanes of m). Where q->sat8 the clamp is saturation (sat8_16's
// argument on 16 lanes): int32 -> int16 saturated, + zp saturated, -> int8 saturated.
X86_INLINE void rq16_store(int8_t *d, __mmask16 m, __m512i acc, const vd_cnn_x86_rqv_t *c,
                           const vd_cnn_x86_rq_t *q)
{
    if (q->sat8) {
        const __m256i z = _mm256_adds_epi16(_mm512_cvtsepi32_epi16(rq16_z(acc, c, q)),
                                            _mm256_set1_epi16((int16_t)q->zp));
        _mm256_mask_cvtsepi16_storeu_epi8(d, m, z);
    } else {
        _mm512_mask_cvtepi32_storeu_epi8(d, m, rq16(acc, c, q));
    }
}

// rq16 on lanes 8 h .. 8 h + 7 of c, before the clamp: z of the one-shift
// form (vd_rq_z, vd_rq_z_nn), an int32.
AVX2_INLINE __m256i rq8_z(__m256i acc, const vd_cnn_x86_rqv_t *c, uint32_t h, const vd_cnn_x86_rq_t *q)
{
    __m256i x = acc, xu;
    if (!q->general && !q->sign) {
        // x itself is not needed: x + 2^31 = sum + (bias + 2^31), modulo 2^32.
        xu = _mm256_add_epi32(acc, _mm256_loadu_si256((const __m256i *)(const void *)(c->bias_u + 8u * h)));
    } else {
        x = _mm256_add_epi32(acc, _mm256_loadu_si256((const __m256i *)(const void *)(c->bias + 8u * h)));
        if (q->general) {
            const __m256i sh = _mm256_loadu_si256((const __m256i *)(const void *)(c->lsh + 8u * h));
            const __m256i t = _mm256_sllv_epi32(x, sh);
            const __m256i same = _mm256_cmpeq_epi32(_mm256_srav_epi32(t, sh), x);
            const __m256i sat = _mm256_xor_si256(_mm256_srai_epi32(x, 31), _mm256_set1_epi32(INT32_MAX));
            x = _mm256_blendv_epi8(sat, t, same);
        }
        xu = _mm256_xor_si256(x, _mm256_set1_epi32(INT32_MIN));
    }
    __m256i ve = _mm256_add_epi64(
        _mm256_mul_epu32(xu, _mm256_loadu_si256((const __m256i *)(const void *)(c->mult + 8u * h))),
        _mm256_loadu_si256((const __m256i *)(const void *)(c->k_e + 4u * h)));
    __m256i vo = _mm256_add_epi64(
        _mm256_mul_epu32(_mm256_srli_epi64(xu, 32),
                         _mm256_loadu_si256((const __m256i *)(const void *)(c->mult_sw + 8u * h))),
        _mm256_loadu_si256((const __m256i *)(const void *)(c->k_o + 4u * h)));
    if (q->sign) {
        // d = dk where not (x > thr).
        const __m256i gt = _mm256_cmpgt_epi32(x, _mm256_loadu_si256((const __m256i *)(const void *)(c->thr + 8u * h)));
        const __m256i d = _mm256_andnot_si256(gt, _mm256_loadu_si256((const __m256i *)(const void *)(c->dk + 8u * h)));
        ve = _mm256_sub_epi64(ve, _mm256_and_si256(d, _mm256_set1_epi64x(0xFFFFFFFFLL)));
        vo = _mm256_sub_epi64(vo, _mm256_srli_epi64(d, 32));
    }
    ve = _mm256_srlv_epi64(ve, _mm256_loadu_si256((const __m256i *)(const void *)(c->rsh_e + 4u * h)));
    vo = _mm256_srlv_epi64(vo, _mm256_loadu_si256((const __m256i *)(const void *)(c->rsh_o + 4u * h)));
    const __m256i z = _mm256_blend_epi32(ve, _mm256_slli_epi64(vo, 32), 0xAA);
    return _mm256_sub_epi32(z, _mm256_loadu_si256((const __m256i *)(const void *)(c->off + 8u * h)));
}

// rq16 on lanes 8 h .. 8 h + 7 of c: clamp(z, lo, hi) + zp.
AVX2_INLINE __m256i rq8(__m256i acc, const vd_cnn_x86_rqv_t *c, uint32_t h, const vd_cnn_x86_rq_t *q)
{
    __m256i z = rq8_z(acc, c, h, q);
    z = _mm256_max_epi32(z, _mm256_set1_epi32(q->lo));
    z = _mm256_min_epi32(z, _mm256_set1_epi32(q->hi));
    return _mm256_add_epi32(z, _mm256_set1_epi32(q->zp));
}

// Where q->sat8: the int16 lanes of p (packs of two rq8_z results) + zp,
// saturated. packs_epi32 then adds_epi16 then packs_epi16 equals
// clamp(z + zp, -128, 127) = clamp(z, lo, hi) + zp for every int32 z: a z
// saturated to +-32767/-32768 stays beyond +-127 after adding |zp| <= 128.
AVX2_INLINE __m256i sat8_16(__m256i p, const vd_cnn_x86_rq_t *q)
{
    const __m256i s = _mm256_adds_epi16(p, _mm256_set1_epi16((int16_t)q->zp));
    return _mm256_packs_epi16(s, s);
}

// ------------------------------------------------------------ the GEMM kernels (gemm_x86_*.c)
// conv_x86.c's driver calls, per tile of n_o <= VD_CNN_X86_TILE output channels of a layer with k = vd_cnn_k_of
// weights per channel, a pack (w: the model's [n_o][k] int8 weights of the tile; wp: the scratch's weight area)
// and then, per block of npix <= VD_CNN_NPIX pixels, a GEMM of its rows (rstride elements apart) into out
// (pstride bytes per pixel), through the tile's requantisation constants cv (one per 16 channels) and q.
// AVX-512 VNNI and AVX-VNNI: int8 weights packed [k4 / 4][n_o][4] with their sums wsum (for the bias's
// (zp_in + 128) sum w), unsigned rows (flip: the rows are the int8 input itself, made unsigned in the kernel).
X86_TARGET void vd__cnn_pack_vnni(const int8_t *w, size_t k, size_t n_o, int8_t *wp, uint32_t *wsum);
X86_TARGET void vd__cnn_gemm_vnni(const uint8_t *rows, size_t rstride, bool flip, size_t k4, const int8_t *wp,
                                  size_t n_o, const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride,
                                  int8_t *out, uint32_t npix);
AVXVNNI_TARGET void vd__cnn_pack_avxvnni(const int8_t *w, size_t k, size_t n_o, int8_t *wp, uint32_t *wsum);
AVXVNNI_TARGET void vd__cnn_gemm_avxvnni(const uint8_t *rows, size_t rstride, bool flip, size_t k4,
                                         const int8_t *wp, size_t n_o, const vd_cnn_x86_rqv_t *cv,
                                         const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out, uint32_t npix);
// AVX2: int16 weight pairs [k2 / 2][n_o][2], int16 rows x - zp_in (kp apart).
AVX2_TARGET void vd__cnn_pack_avx2(const int8_t *w, size_t k, size_t n_o, int16_t *wp);
AVX2_TARGET void vd__cnn_gemm_avx2(const int16_t *rows, size_t rstride, size_t k, const int16_t *wp, size_t n_o,
                                   const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out,
                                   uint32_t npix);
// The VNNI packs' last, partial group of 4 weights (x86.c).
void vd__cnn_x86_pack_tail(const int8_t *src, size_t k, size_t n_o, size_t nl, int8_t *dst, uint32_t *s,
                           uint32_t *wsum);

// ------------------------------------------------------------ AVX2 output helpers (the AVX2 and AVX-VNNI GEMMs)

// The low byte of each int32 lane (values in -128..127), n of them (1..8), to d.
AVX2_INLINE void store8(int8_t *d, __m256i z, size_t n)
{
    const __m256i p16 = _mm256_packs_epi32(z, z);
    const __m256i p8 = _mm256_packs_epi16(p16, p16);
    const __m128i b = _mm_unpacklo_epi32(_mm256_castsi256_si128(p8), _mm256_extracti128_si256(p8, 1));
    if (n >= 8u) {
        _mm_storel_epi64((__m128i *)(void *)d, b);
    } else {
        int8_t tmp[16];
        _mm_storeu_si128((__m128i *)(void *)tmp, b);
        memcpy(d, tmp, n);
    }
}

// All-ones in lanes 0 .. rem - 1 (a vpmaskmovd mask).
AVX2_INLINE __m256i lane_mask8(size_t rem)
{
    const __m256i idx = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const int32_t r = (rem >= 8u) ? 8 : (int32_t)rem;
    return _mm256_cmpgt_epi32(_mm256_set1_epi32(r), idx);
}

// Requantises pixel p's accumulators (a0: channels 0-7 of the group, a1: 8-15) and
// stores its n0 + n1 channels at d.
AVX2_INLINE void gemm_out(int8_t *d, __m256i a0, __m256i a1, const vd_cnn_x86_rqv_t *c, const vd_cnn_x86_rq_t *q,
                          size_t n0, size_t n1)
{
    if (n1 == 8u && q->sat8) {
        // 16 channels in one store: after the two packs the dwords 0, 4, 1, 5
        // hold channels 0-3, 4-7, 8-11, 12-15.
        const __m256i b = sat8_16(_mm256_packs_epi32(rq8_z(a0, c, 0u, q), rq8_z(a1, c, 1u, q)), q);
        _mm_storeu_si128((__m128i *)(void *)d, _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
                                                   b, _mm256_setr_epi32(0, 4, 1, 5, 0, 4, 1, 5))));
        return;
    }
    store8(d, rq8(a0, c, 0u, q), n0);
    if (n1 > 0u) {
        store8(d + 8, rq8(a1, c, 1u, q), n1);
    }
}

#endif
