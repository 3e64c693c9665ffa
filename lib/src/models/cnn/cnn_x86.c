// SPDX-License-Identifier: MIT
// Optional x86-64 kernels of the int8 CNN (AVX-512 VNNI, AVX2): pointwise/spatial GEMM, depthwise 3x3, exact requantisation.
//
// Compiled only when CMake's VD_CNN_X86 is ON (x86-64 gcc/clang hosts); the
// kernels carry per-function target attributes and cnn.c picks them per
// call by vd_cnn_x86_level() (runtime CPU check: AVX-512 F/BW/VL/VNNI, else
// AVX2, else the portable C), so the library runs on any x86-64 CPU. The
// AVX2 set (end of the file) is described there. Every output equals the portable kernels' byte
// for byte (tests/unit/test_cnn.c compares the two on random models and the
// shipped ones):
//  * GEMM (CONV3X3 / CONV5X5 / PW1X1): vpdpbusd multiplies unsigned by signed
//    bytes, four products into an int32 lane, with no intermediate
//    saturation (unlike vpmaddubsw), so with u = x + 128 in 0..255,
//    sum w u = sum w (x - zp_in) + (zp_in + 128) sum w exactly; the caller
//    feeds padding taps as u = zp_in + 128 (a zero term, as in the portable
//    rows) and subtracts (zp_in + 128) sum w from the bias, modulo 2^32 like
//    every accumulation. Output channels run along the lanes (16 per
//    register, 4 registers per tile), 4 pixels per pass.
//  * DW3X3: int16 products, vpdpwssd on tap pairs interleaved per channel
//    (unpacklo/hi); 2 products + int32 per lane, exact. packs_epi32 of the
//    lo/hi results restores the channel order.
//  * Requantisation: the one-shift form of internal/requant.h (vd_rq_z,
//    vd_rq_z_nn, vd_rq_lshift_sat) on 16 lanes: the 64-bit product u * mult
//    of even and odd lanes by vpmuludq, + k (- dk), per-lane vpsrlvq. Same
//    integer operations, so the same result.
// Bounds: as the portable kernels; stack ~3.5 KiB (constants of one tile of 64 channels).
#include "models/cnn/cnn_x86.h"
#include "internal/blob_internal.h"

#include <immintrin.h>
#include <string.h>

#define X86_TARGET __attribute__((target("avx512f,avx512bw,avx512vl,avx512vnni")))
#define X86_INLINE static inline __attribute__((always_inline)) X86_TARGET

uint32_t vd_cnn_x86_level(void)
{
    __builtin_cpu_init();
    uint32_t level = VD_CNN_X86_NONE;
    if (__builtin_cpu_supports("avx2") != 0) {
        level = VD_CNN_X86_AVX2;
    }
    if (__builtin_cpu_supports("avx512f") != 0 && __builtin_cpu_supports("avx512bw") != 0 &&
        __builtin_cpu_supports("avx512vl") != 0 && __builtin_cpu_supports("avx512vnni") != 0) {
        level = VD_CNN_X86_AVX512;
    }
#if defined(VD_CNN_X86_MAX_LEVEL)
    // Test builds cap the level to exercise the AVX2 kernels on an AVX-512 CPU.
    level = (level > VD_CNN_X86_MAX_LEVEL) ? VD_CNN_X86_MAX_LEVEL : level;
#endif
    return level;
}

void vd_cnn_x86_rqv_fill(vd_cnn_x86_rqv_t *v, const vd_cnn_layer_t *L, const uint32_t *ch_of, const int32_t *corr,
                         uint32_t n_lanes)
{
    for (uint32_t j = 0u; j < 16u; j++) {
        const uint32_t jj = (j < n_lanes) ? j : 0u;
        const size_t o = ch_of[jj];
        const uint32_t cr = (corr != NULL) ? (uint32_t)corr[jj] : 0u;
        const int32_t bias = vd_rq_u32_to_i32(vd_blob_u32(L->bias + 4u * o) - cr);
        vd_rq_ch_t c;
        vd_rq_prepare(vd_rq_u32_to_i32(vd_blob_u32(L->mult + 4u * o)), L->shift[o], bias, &c);
        v->bias[j] = c.bias;
        v->mult[j] = c.mult;
        v->thr[j] = c.thr;
        v->dk[j] = c.dk;
        v->off[j] = c.off;
        v->lsh[j] = c.lsh;
        if ((j & 1u) == 0u) {
            v->k_e[j / 2u] = c.k;
            v->rsh_e[j / 2u] = c.rsh;
        } else {
            v->k_o[j / 2u] = c.k;
            v->rsh_o[j / 2u] = c.rsh;
        }
    }
}

// z = clamp(requantize(acc + bias), lo, hi) + zp on 16 lanes, as
// rq_out(vd_rq_apply(..)) (general), rq_out(vd_rq_z(..)) (sign) or
// rq_out(vd_rq_z_nn(..)) in cnn.c.
X86_INLINE __m512i rq16(__m512i acc, const vd_cnn_x86_rqv_t *c, const vd_cnn_x86_rq_t *q)
{
    __m512i x = _mm512_add_epi32(acc, _mm512_loadu_si512(c->bias));
    if (q->general) {
        // vd_rq_lshift_sat: x * 2^lsh, saturated where the shift changes the value.
        const __m512i sh = _mm512_loadu_si512(c->lsh);
        const __m512i t = _mm512_sllv_epi32(x, sh);
        const __mmask16 ovf = _mm512_cmpneq_epi32_mask(_mm512_srav_epi32(t, sh), x);
        const __m512i sat = _mm512_xor_si512(_mm512_srai_epi32(x, 31), _mm512_set1_epi32(INT32_MAX));
        x = _mm512_mask_blend_epi32(ovf, t, sat);
    }
    const __m512i xu = _mm512_xor_si512(x, _mm512_set1_epi32(INT32_MIN));   // x + 2^31 as uint32
    const __m512i mult = _mm512_loadu_si512(c->mult);
    __m512i ve = _mm512_add_epi64(_mm512_mul_epu32(xu, mult), _mm512_loadu_si512(c->k_e));
    __m512i vo = _mm512_add_epi64(_mm512_mul_epu32(_mm512_srli_epi64(xu, 32), _mm512_srli_epi64(mult, 32)),
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
    __m512i z = _mm512_mask_blend_epi32((__mmask16)0xAAAAu, ve, _mm512_slli_epi64(vo, 32));
    z = _mm512_sub_epi32(z, _mm512_loadu_si512(c->off));
    z = _mm512_max_epi32(z, _mm512_set1_epi32(q->lo));
    z = _mm512_min_epi32(z, _mm512_set1_epi32(q->hi));
    return _mm512_add_epi32(z, _mm512_set1_epi32(q->zp));
}

// Depthwise (both kernel sets): the 3 input rows of output row oy (NULL: padding row) ...
static inline void dw_rows(const vd_cnn_x86_dw_t *d, uint32_t oy, const int8_t *rows[3])
{
    for (uint32_t ky = 0u; ky < 3u; ky++) {
        const int32_t iy = (int32_t)oy * (int32_t)d->stride - 1 + (int32_t)ky;
        rows[ky] = (iy >= 0 && iy < (int32_t)d->hi) ? d->in + (size_t)((uint32_t)iy % d->in_slots) * d->in_row
                                                     : NULL;
    }
}

// ... and the 9 tap pointers of output pixel ox; padding taps read the zero row.
static inline void dw_taps(const vd_cnn_x86_dw_t *d, const int8_t *const rows[3], uint32_t ox, const int8_t *t[9])
{
    const size_t c_n = d->c_n;
    const int32_t ix0 = (int32_t)ox * (int32_t)d->stride - 1;
    const bool left = ix0 >= 0, right = ix0 + 2 < (int32_t)d->wi;
    for (size_t ky = 0u; ky < 3u; ky++) {
        const int8_t *r = rows[ky];
        if (r == NULL) {
            t[ky * 3u] = d->zrow;
            t[ky * 3u + 1u] = d->zrow;
            t[ky * 3u + 2u] = d->zrow;
            continue;
        }
        const int8_t *c1 = r + (size_t)ox * (size_t)d->stride * c_n;
        t[ky * 3u] = left ? c1 - c_n : d->zrow;
        t[ky * 3u + 1u] = c1;
        t[ky * 3u + 2u] = right ? c1 + c_n : d->zrow;
    }
}

static uint32_t lane_mask16(size_t rem)
{
    return (rem >= 16u) ? 0xFFFFu : (((uint32_t)1 << rem) - 1u);
}

// One pixel's row of the tile: broadcast 4 bytes of its row, 1..4 vpdpbusd.
#define GEMM_PIX(p)                                                                     \
    do {                                                                                \
        uint32_t b_;                                                                    \
        memcpy(&b_, r##p + 4u * gi, sizeof b_);                                         \
        const __m512i bb_ = _mm512_set1_epi32((int32_t)(b_ ^ flip));                    \
        a##p##0 = _mm512_dpbusd_epi32(a##p##0, bb_, w0);                                \
        if (nv > 1u) {                                                                  \
            a##p##1 = _mm512_dpbusd_epi32(a##p##1, bb_, w1);                            \
        }                                                                               \
        if (nv > 2u) {                                                                  \
            a##p##2 = _mm512_dpbusd_epi32(a##p##2, bb_, w2);                            \
        }                                                                               \
        if (nv > 3u) {                                                                  \
            a##p##3 = _mm512_dpbusd_epi32(a##p##3, bb_, w3);                            \
        }                                                                               \
    } while (0)

// Requantises and stores one pixel of the tile (if it is one of the npix).
#define GEMM_OUT(p)                                                                     \
    do {                                                                                \
        if (p0 + (p) < npix) {                                                          \
            int8_t *d_ = out + ((size_t)p0 + (p)) * pstride;                            \
            _mm512_mask_cvtepi32_storeu_epi8(d_, m0, rq16(a##p##0, &cv[0], q));         \
            if (nv > 1u) {                                                              \
                _mm512_mask_cvtepi32_storeu_epi8(d_ + 16, m1, rq16(a##p##1, &cv[1], q)); \
            }                                                                           \
            if (nv > 2u) {                                                              \
                _mm512_mask_cvtepi32_storeu_epi8(d_ + 32, m2, rq16(a##p##2, &cv[2], q)); \
            }                                                                           \
            if (nv > 3u) {                                                              \
                _mm512_mask_cvtepi32_storeu_epi8(d_ + 48, m3, rq16(a##p##3, &cv[3], q)); \
            }                                                                           \
        }                                                                               \
    } while (0)

// The GEMM with nv (1..4, a constant after inlining) registers of channels:
// tiles of 4 pixels x nv * 16 channels, the 4 nv accumulators as separate
// variables (gcc 12 keeps an array of 16 vectors in memory).
X86_INLINE void gemm_nv(const uint8_t *rows, size_t rstride, uint32_t flip, size_t k4, const int8_t *wp, size_t n_o,
                        const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out,
                        uint32_t npix, const size_t nv)
{
    const __mmask16 m0 = (__mmask16)lane_mask16(n_o);
    const __mmask16 m1 = (__mmask16)((nv > 1u) ? lane_mask16(n_o - 16u) : 0u);
    const __mmask16 m2 = (__mmask16)((nv > 2u) ? lane_mask16(n_o - 32u) : 0u);
    const __mmask16 m3 = (__mmask16)((nv > 3u) ? lane_mask16(n_o - 48u) : 0u);
    const size_t wstep = n_o * 4u;   // bytes per group of 4 k
    const size_t ng = k4 / 4u;
    for (uint32_t p0 = 0u; p0 < npix; p0 += 4u) {
        // Rows of the 4 pixels; past npix the last one again (read, not stored).
        const uint8_t *r0 = rows + (size_t)p0 * rstride;
        const uint8_t *r1 = rows + (size_t)((p0 + 1u < npix) ? p0 + 1u : npix - 1u) * rstride;
        const uint8_t *r2 = rows + (size_t)((p0 + 2u < npix) ? p0 + 2u : npix - 1u) * rstride;
        const uint8_t *r3 = rows + (size_t)((p0 + 3u < npix) ? p0 + 3u : npix - 1u) * rstride;
        const __m512i z = _mm512_setzero_si512();
        __m512i a00 = z, a01 = z, a02 = z, a03 = z, a10 = z, a11 = z, a12 = z, a13 = z;
        __m512i a20 = z, a21 = z, a22 = z, a23 = z, a30 = z, a31 = z, a32 = z, a33 = z;
        const int8_t *w = wp;
        for (size_t gi = 0u; gi < ng; gi++) {
            const __m512i w0 = _mm512_maskz_loadu_epi32(m0, w);
            const __m512i w1 = (nv > 1u) ? _mm512_maskz_loadu_epi32(m1, w + 64) : z;
            const __m512i w2 = (nv > 2u) ? _mm512_maskz_loadu_epi32(m2, w + 128) : z;
            const __m512i w3 = (nv > 3u) ? _mm512_maskz_loadu_epi32(m3, w + 192) : z;
            GEMM_PIX(0);
            GEMM_PIX(1);
            GEMM_PIX(2);
            GEMM_PIX(3);
            w += wstep;
        }
        GEMM_OUT(0);
        GEMM_OUT(1);
        GEMM_OUT(2);
        GEMM_OUT(3);
    }
}

X86_TARGET void vd_cnn_x86_gemm(const uint8_t *rows, size_t rstride, bool flip, size_t k4, const int8_t *wp,
                                size_t n_o, const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride,
                                int8_t *out, uint32_t npix)
{
    const uint32_t f = flip ? 0x80808080u : 0u;
    switch ((n_o + 15u) / 16u) {
    case 1:
        gemm_nv(rows, rstride, f, k4, wp, n_o, cv, q, pstride, out, npix, 1u);
        break;
    case 2:
        gemm_nv(rows, rstride, f, k4, wp, n_o, cv, q, pstride, out, npix, 2u);
        break;
    case 3:
        gemm_nv(rows, rstride, f, k4, wp, n_o, cv, q, pstride, out, npix, 3u);
        break;
    default:
        gemm_nv(rows, rstride, f, k4, wp, n_o, cv, q, pstride, out, npix, 4u);
        break;
    }
}

X86_TARGET void vd_cnn_x86_pack(const int8_t *w, size_t k, size_t n_o, int8_t *wp, uint32_t *wsum)
{
    const size_t k4 = (k + 3u) / 4u * 4u;
    const size_t full = k / 4u;   // groups of 4 weights inside the channel
    const __m512i ones = _mm512_set1_epi8(1);
    const __m512i idx = _mm512_mullo_epi32(_mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
                                           _mm512_set1_epi32((int32_t)k));
    for (size_t o0 = 0u; o0 < n_o; o0 += 16u) {
        const size_t nl = (n_o - o0 < 16u) ? n_o - o0 : 16u;
        const __mmask16 m = (__mmask16)lane_mask16(nl);
        const int8_t *src = w + o0 * k;
        int8_t *dst = wp + o0 * 4u;
        __m512i sum = _mm512_setzero_si512();
        for (size_t gi = 0u; gi < full; gi++) {
            // Lane j: weights 4 gi .. 4 gi + 3 of channel o0 + j (a 32-bit transpose).
            // (gcc 12 at -O0 expands the intrinsic to a builtin whose mask
            // parameter is a signed short: a false -Wsign-conversion.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wsign-conversion"
            const __m512i v = _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), m, idx, src + 4u * gi, 1);
#pragma GCC diagnostic pop
            _mm512_mask_storeu_epi32(dst + gi * n_o * 4u, m, v);
            sum = _mm512_dpbusd_epi32(sum, ones, v);
        }
        uint32_t s[16];
        _mm512_storeu_si512(s, sum);
        for (size_t j = 0u; j < nl; j++) {
            // The last, partial group: zero weights past k (their activations are 0 too).
            int8_t *d = dst + full * n_o * 4u + j * 4u;
            for (size_t i = 4u * full; i < k4; i++) {
                const int32_t wv = (i < k) ? src[j * k + i] : 0;
                d[i - 4u * full] = (int8_t)wv;
                s[j] += (uint32_t)wv;
            }
            wsum[o0 + j] = s[j];
        }
    }
}

X86_INLINE __m512i dw_tap(const int8_t *t, __mmask32 m)
{
    return _mm512_cvtepi8_epi16(_mm256_maskz_loadu_epi8(m, t));
}

X86_TARGET void vd_cnn_x86_dw_rows(const vd_cnn_x86_dw_t *d, const vd_cnn_layer_t *L, const vd_cnn_x86_rq_t *q,
                                   uint32_t y0, uint32_t y1)
{
    const size_t c_n = d->c_n;
    for (size_t c0 = 0u; c0 < c_n; c0 += 32u) {
        const size_t nc = (c_n - c0 < 32u) ? c_n - c0 : 32u;
        const __mmask32 m = (nc == 32u) ? (__mmask32)0xFFFFFFFFu : (__mmask32)(((uint32_t)1 << nc) - 1u);
        // Weights [9][c_n] straight from the model; tap pairs (0,1) (2,3)
        // (4,5) (6,7) (8,-) interleaved per channel as the activations will be.
        __m512i wt[9];
        __m512i wsum = _mm512_setzero_si512();
        for (size_t i = 0u; i < 9u; i++) {
            wt[i] = dw_tap(L->w + i * c_n + c0, m);
            wsum = _mm512_add_epi16(wsum, wt[i]);   // |sum| <= 9 * 128: int16
        }
        __m512i wl[5], wh[5];
        for (size_t i = 0u; i < 5u; i++) {
            const __m512i wb = (i < 4u) ? wt[2u * i + 1u] : _mm512_setzero_si512();
            wl[i] = _mm512_unpacklo_epi16(wt[2u * i], wb);
            wh[i] = _mm512_unpackhi_epi16(wt[2u * i], wb);
        }
        // bias - zp_in sum w (the taps are x, padding taps zp_in), modulo 2^32.
        int16_t ws[32];
        _mm512_storeu_si512(ws, wsum);
        // Lane 4 L + i of the lo / hi sums holds channel c0 + 8 L + i / + 4.
        uint32_t map_lo[16], map_hi[16];
        int32_t corr_lo[16], corr_hi[16];
        for (uint32_t j = 0u; j < 16u; j++) {
            const size_t cl = 8u * (j / 4u) + (j % 4u);
            map_lo[j] = (uint32_t)((c0 + cl < c_n) ? c0 + cl : c0);
            map_hi[j] = (uint32_t)((c0 + cl + 4u < c_n) ? c0 + cl + 4u : c0);
            corr_lo[j] = vd_rq_u32_to_i32((uint32_t)d->zp_in * (uint32_t)(int32_t)ws[cl]);
            corr_hi[j] = vd_rq_u32_to_i32((uint32_t)d->zp_in * (uint32_t)(int32_t)ws[cl + 4u]);
        }
        vd_cnn_x86_rqv_t cl, chv;
        vd_cnn_x86_rqv_fill(&cl, L, map_lo, corr_lo, 16u);
        vd_cnn_x86_rqv_fill(&chv, L, map_hi, corr_hi, 16u);
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rows[3];
            dw_rows(d, oy, rows);
            int8_t *orow = d->out + (size_t)(oy % d->out_slots) * d->out_row;
            for (uint32_t ox = 0u; ox < d->wo; ox++) {
                const int8_t *t[9];
                dw_taps(d, rows, ox, t);
                __m512i al = _mm512_setzero_si512(), ah = _mm512_setzero_si512();
                for (size_t i = 0u; i < 4u; i++) {
                    const __m512i xa = dw_tap(t[2u * i] + c0, m), xb = dw_tap(t[2u * i + 1u] + c0, m);
                    al = _mm512_dpwssd_epi32(al, _mm512_unpacklo_epi16(xa, xb), wl[i]);
                    ah = _mm512_dpwssd_epi32(ah, _mm512_unpackhi_epi16(xa, xb), wh[i]);
                }
                const __m512i x8 = dw_tap(t[8] + c0, m), zero = _mm512_setzero_si512();
                al = _mm512_dpwssd_epi32(al, _mm512_unpacklo_epi16(x8, zero), wl[4]);
                ah = _mm512_dpwssd_epi32(ah, _mm512_unpackhi_epi16(x8, zero), wh[4]);
                const __m512i z = _mm512_packs_epi32(rq16(al, &cl, q), rq16(ah, &chv, q));
                _mm512_mask_cvtepi16_storeu_epi8(orow + (size_t)ox * c_n + c0, m, z);
            }
        }
    }
}

// ------------------------------------------------------------ AVX2 (no AVX-512)
//
// The same scheme on 256-bit registers without VNNI: exact int16 products
// by vpmaddwd (pairs of int16 products summed into int32: |sum| <= 2 * 255 *
// 128, no saturation) on the portable kernel's int16 rows (x - zp_in,
// padding 0), so no zero-point correction. 8 output channels per register,
// tiles of 4 pixels x 16 channels (16 ymm registers).

#define AVX2_TARGET __attribute__((target("avx2")))
#define AVX2_INLINE static inline __attribute__((always_inline)) AVX2_TARGET

// rq16 on lanes 8 h .. 8 h + 7 of c.
AVX2_INLINE __m256i rq8(__m256i acc, const vd_cnn_x86_rqv_t *c, uint32_t h, const vd_cnn_x86_rq_t *q)
{
    __m256i x = _mm256_add_epi32(acc, _mm256_loadu_si256((const __m256i *)(const void *)(c->bias + 8u * h)));
    if (q->general) {
        const __m256i sh = _mm256_loadu_si256((const __m256i *)(const void *)(c->lsh + 8u * h));
        const __m256i t = _mm256_sllv_epi32(x, sh);
        const __m256i same = _mm256_cmpeq_epi32(_mm256_srav_epi32(t, sh), x);
        const __m256i sat = _mm256_xor_si256(_mm256_srai_epi32(x, 31), _mm256_set1_epi32(INT32_MAX));
        x = _mm256_blendv_epi8(sat, t, same);
    }
    const __m256i xu = _mm256_xor_si256(x, _mm256_set1_epi32(INT32_MIN));
    const __m256i mult = _mm256_loadu_si256((const __m256i *)(const void *)(c->mult + 8u * h));
    __m256i ve = _mm256_add_epi64(_mm256_mul_epu32(xu, mult),
                                  _mm256_loadu_si256((const __m256i *)(const void *)(c->k_e + 4u * h)));
    __m256i vo = _mm256_add_epi64(_mm256_mul_epu32(_mm256_srli_epi64(xu, 32), _mm256_srli_epi64(mult, 32)),
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
    __m256i z = _mm256_blend_epi32(ve, _mm256_slli_epi64(vo, 32), 0xAA);
    z = _mm256_sub_epi32(z, _mm256_loadu_si256((const __m256i *)(const void *)(c->off + 8u * h)));
    z = _mm256_max_epi32(z, _mm256_set1_epi32(q->lo));
    z = _mm256_min_epi32(z, _mm256_set1_epi32(q->hi));
    return _mm256_add_epi32(z, _mm256_set1_epi32(q->zp));
}

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

AVX2_TARGET void vd_cnn_x86_pack16(const int8_t *w, size_t k, size_t n_o, int16_t *wp)
{
    const size_t k2 = (k + 1u) / 2u * 2u;
    const size_t full = k / 4u;
    const __m256i idx = _mm256_mullo_epi32(_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), _mm256_set1_epi32((int32_t)k));
    const __m256i even_odd = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
    const size_t row = n_o * 2u;   // int16 per pair row [n_o][2]
    for (size_t o0 = 0u; o0 < n_o; o0 += 8u) {
        const size_t nl = (n_o - o0 < 8u) ? n_o - o0 : 8u;
        const __m256i m = lane_mask8(nl);
        const int8_t *src = w + o0 * k;
        for (size_t gi = 0u; gi < full; gi++) {
            // Lane j: weights 4 gi .. 4 gi + 3 of channel o0 + j, then as
            // int16 pairs (4 gi, 4 gi + 1) and (4 gi + 2, 4 gi + 3) for rows 2 gi, 2 gi + 1.
            const __m256i v = _mm256_mask_i32gather_epi32(_mm256_setzero_si256(),
                                                          (const int *)(const void *)(src + 4u * gi), idx, m, 1);
            const __m256i a = _mm256_permutevar8x32_epi32(_mm256_cvtepi8_epi16(_mm256_castsi256_si128(v)), even_odd);
            const __m256i b =
                _mm256_permutevar8x32_epi32(_mm256_cvtepi8_epi16(_mm256_extracti128_si256(v, 1)), even_odd);
            _mm256_maskstore_epi32((int *)(void *)(wp + 2u * gi * row + 2u * o0), m,
                                   _mm256_permute2x128_si256(a, b, 0x20));
            _mm256_maskstore_epi32((int *)(void *)(wp + (2u * gi + 1u) * row + 2u * o0), m,
                                   _mm256_permute2x128_si256(a, b, 0x31));
        }
        for (size_t j = 0u; j < nl; j++) {
            for (size_t i = 4u * full; i < k2; i++) {
                wp[(i / 2u) * row + 2u * (o0 + j) + i % 2u] = (int16_t)((i < k) ? src[j * k + i] : 0);
            }
        }
    }
}

AVX2_TARGET void vd_cnn_x86_gemm16(const int16_t *rows, size_t rstride, size_t k, const int16_t *wp, size_t n_o,
                                   const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out,
                                   uint32_t npix)
{
    const size_t ng = (k + 1u) / 2u;
    const size_t row = n_o * 2u;
    for (size_t o0 = 0u; o0 < n_o; o0 += 16u) {
        const size_t n0 = (n_o - o0 < 8u) ? n_o - o0 : 8u;
        const size_t n1 = (n_o - o0 > 8u) ? ((n_o - o0 - 8u < 8u) ? n_o - o0 - 8u : 8u) : 0u;
        const __m256i m0 = lane_mask8(n0), m1 = lane_mask8(n1);
        const vd_cnn_x86_rqv_t *c = &cv[o0 / 16u];
        for (uint32_t p0 = 0u; p0 < npix; p0 += 4u) {
            const int16_t *r0 = rows + (size_t)p0 * rstride;
            const int16_t *r1 = rows + (size_t)((p0 + 1u < npix) ? p0 + 1u : npix - 1u) * rstride;
            const int16_t *r2 = rows + (size_t)((p0 + 2u < npix) ? p0 + 2u : npix - 1u) * rstride;
            const int16_t *r3 = rows + (size_t)((p0 + 3u < npix) ? p0 + 3u : npix - 1u) * rstride;
            const __m256i z = _mm256_setzero_si256();
            __m256i a00 = z, a01 = z, a10 = z, a11 = z, a20 = z, a21 = z, a30 = z, a31 = z;
            const int16_t *wr = wp + 2u * o0;
            for (size_t gi = 0u; gi < ng; gi++) {
                const __m256i w0 = _mm256_maskload_epi32((const int *)(const void *)wr, m0);
                const __m256i w1 = _mm256_maskload_epi32((const int *)(const void *)(wr + 16), m1);
                int32_t b;
                memcpy(&b, r0 + 2u * gi, sizeof b);
                __m256i bb = _mm256_set1_epi32(b);
                a00 = _mm256_add_epi32(a00, _mm256_madd_epi16(bb, w0));
                a01 = _mm256_add_epi32(a01, _mm256_madd_epi16(bb, w1));
                memcpy(&b, r1 + 2u * gi, sizeof b);
                bb = _mm256_set1_epi32(b);
                a10 = _mm256_add_epi32(a10, _mm256_madd_epi16(bb, w0));
                a11 = _mm256_add_epi32(a11, _mm256_madd_epi16(bb, w1));
                memcpy(&b, r2 + 2u * gi, sizeof b);
                bb = _mm256_set1_epi32(b);
                a20 = _mm256_add_epi32(a20, _mm256_madd_epi16(bb, w0));
                a21 = _mm256_add_epi32(a21, _mm256_madd_epi16(bb, w1));
                memcpy(&b, r3 + 2u * gi, sizeof b);
                bb = _mm256_set1_epi32(b);
                a30 = _mm256_add_epi32(a30, _mm256_madd_epi16(bb, w0));
                a31 = _mm256_add_epi32(a31, _mm256_madd_epi16(bb, w1));
                wr += row;
            }
            const __m256i acc[4][2] = {{a00, a01}, {a10, a11}, {a20, a21}, {a30, a31}};
            for (uint32_t p = 0u; p < 4u; p++) {
                if (p0 + p < npix) {
                    int8_t *d = out + ((size_t)p0 + p) * pstride + o0;
                    store8(d, rq8(acc[p][0], c, 0u, q), n0);
                    if (n1 > 0u) {
                        store8(d + 8, rq8(acc[p][1], c, 1u, q), n1);
                    }
                }
            }
        }
    }
}

// 16 int8 at p (n of them, 1..16; the rest 0) as int16, reading only
// p[0..n) (a copy through the stack: weights, once per group).
AVX2_INLINE __m256i tap16(const int8_t *p, size_t n)
{
    if (n >= 16u) {
        return _mm256_cvtepi8_epi16(_mm_loadu_si128((const __m128i *)(const void *)p));
    }
    int8_t tmp[16] = {0};
    memcpy(tmp, p, n);
    return _mm256_cvtepi8_epi16(_mm_loadu_si128((const __m128i *)(const void *)tmp));
}

// How tap_act reads the n channels of a pass: 0 all 16 bytes; 1 the 16
// bytes ending at p + n, moved down by shuf (the pixel has >= 16 channels,
// so they are its own); 2 (8 <= n < 16) 8 bytes at p and the 8 ending at
// p + n, shifted by sh bits; 3 (n < 8) through the stack. Never reads
// outside the pixel's channels, without a store-forwarding stall.
typedef struct tail {
    uint32_t mode;
    size_t n;
    __m128i shuf, sh;
} tail_t;

AVX2_INLINE tail_t tail_of(size_t n, size_t c_n)
{
    tail_t t;
    t.n = n;
    t.mode = (n >= 16u) ? 0u : (c_n >= 16u) ? 1u : (n >= 8u) ? 2u : 3u;
    int8_t idx[16];
    for (size_t i = 0u; i < 16u; i++) {
        idx[i] = (int8_t)((i < n) ? (int32_t)(i + 16u - n) : -128);   // -128: pshufb writes 0
    }
    t.shuf = _mm_loadu_si128((const __m128i *)(const void *)idx);
    t.sh = _mm_cvtsi32_si128((int)(8u * (16u - n)));
    return t;
}

AVX2_INLINE __m256i tap_act(const int8_t *p, const tail_t *t)
{
    __m128i v;
    if (t->mode == 0u) {
        v = _mm_loadu_si128((const __m128i *)(const void *)p);
    } else if (t->mode == 1u) {
        v = _mm_shuffle_epi8(_mm_loadu_si128((const __m128i *)(const void *)(p + t->n - 16u)), t->shuf);
    } else if (t->mode == 2u) {
        const __m128i lo = _mm_loadl_epi64((const __m128i *)(const void *)p);
        const __m128i hi = _mm_srl_epi64(_mm_loadl_epi64((const __m128i *)(const void *)(p + t->n - 8u)), t->sh);
        v = _mm_unpacklo_epi64(lo, hi);
    } else {
        return tap16(p, t->n);
    }
    return _mm256_cvtepi8_epi16(v);
}

AVX2_TARGET void vd_cnn_x86_dw_rows_avx2(const vd_cnn_x86_dw_t *d, const vd_cnn_layer_t *L,
                                         const vd_cnn_x86_rq_t *q, uint32_t y0, uint32_t y1)
{
    const size_t c_n = d->c_n;
    for (size_t c0 = 0u; c0 < c_n; c0 += 16u) {
        const size_t nc = (c_n - c0 < 16u) ? c_n - c0 : 16u;
        __m256i wt[9];
        __m256i wsum = _mm256_setzero_si256();
        for (size_t i = 0u; i < 9u; i++) {
            wt[i] = tap16(L->w + i * c_n + c0, nc);
            wsum = _mm256_add_epi16(wsum, wt[i]);   // |sum| <= 9 * 128: int16
        }
        __m256i wl[5], wh[5];
        for (size_t i = 0u; i < 5u; i++) {
            const __m256i wb = (i < 4u) ? wt[2u * i + 1u] : _mm256_setzero_si256();
            wl[i] = _mm256_unpacklo_epi16(wt[2u * i], wb);
            wh[i] = _mm256_unpackhi_epi16(wt[2u * i], wb);
        }
        int16_t ws[16];
        _mm256_storeu_si256((__m256i *)(void *)ws, wsum);
        // Lane j of the lo sums holds channel c0 + 8 (j / 4) + j % 4, of the
        // hi sums 4 more: one constant set, lanes 0..7 lo and 8..15 hi.
        uint32_t map[16];
        int32_t corr[16];
        for (uint32_t j = 0u; j < 8u; j++) {
            const size_t cl = 8u * (j / 4u) + (j % 4u);
            map[j] = (uint32_t)((c0 + cl < c_n) ? c0 + cl : c0);
            map[8u + j] = (uint32_t)((c0 + cl + 4u < c_n) ? c0 + cl + 4u : c0);
            corr[j] = vd_rq_u32_to_i32((uint32_t)d->zp_in * (uint32_t)(int32_t)ws[cl]);
            corr[8u + j] = vd_rq_u32_to_i32((uint32_t)d->zp_in * (uint32_t)(int32_t)ws[cl + 4u]);
        }
        vd_cnn_x86_rqv_t cv;
        vd_cnn_x86_rqv_fill(&cv, L, map, corr, 16u);
        const tail_t tl = tail_of(nc, c_n);
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rows[3];
            dw_rows(d, oy, rows);
            int8_t *orow = d->out + (size_t)(oy % d->out_slots) * d->out_row;
            for (uint32_t ox = 0u; ox < d->wo; ox++) {
                const int8_t *t[9];
                dw_taps(d, rows, ox, t);
                __m256i al = _mm256_setzero_si256(), ah = _mm256_setzero_si256();
                for (size_t i = 0u; i < 4u; i++) {
                    const __m256i xa = tap_act(t[2u * i] + c0, &tl), xb = tap_act(t[2u * i + 1u] + c0, &tl);
                    al = _mm256_add_epi32(al, _mm256_madd_epi16(_mm256_unpacklo_epi16(xa, xb), wl[i]));
                    ah = _mm256_add_epi32(ah, _mm256_madd_epi16(_mm256_unpackhi_epi16(xa, xb), wh[i]));
                }
                const __m256i x8 = tap_act(t[8] + c0, &tl), zero = _mm256_setzero_si256();
                al = _mm256_add_epi32(al, _mm256_madd_epi16(_mm256_unpacklo_epi16(x8, zero), wl[4]));
                ah = _mm256_add_epi32(ah, _mm256_madd_epi16(_mm256_unpackhi_epi16(x8, zero), wh[4]));
                // packs restores the channel order per 128-bit lane; permute joins the lanes' bytes.
                const __m256i z16 = _mm256_packs_epi32(rq8(al, &cv, 0u, q), rq8(ah, &cv, 1u, q));
                const __m256i z8 = _mm256_permute4x64_epi64(_mm256_packs_epi16(z16, z16), 0x08);
                const __m128i b = _mm256_castsi256_si128(z8);
                int8_t *o = orow + (size_t)ox * c_n + c0;
                if (nc == 16u) {
                    _mm_storeu_si128((__m128i *)(void *)o, b);
                } else {
                    int8_t tmp[16];
                    _mm_storeu_si128((__m128i *)(void *)tmp, b);
                    memcpy(o, tmp, nc);
                }
            }
        }
    }
}
