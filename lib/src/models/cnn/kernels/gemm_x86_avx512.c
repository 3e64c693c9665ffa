// SPDX-License-Identifier: MIT
// The AVX-512 VNNI GEMM of the CONV3X3 / CONV5X5 / PW1X1 kernel (conv_x86.c is its driver): the weight packing
// of one tile of <= 64 output channels and the multiply of one block of <= VD_CNN_NPIX pixels.
//
// Algorithm: vpdpbusd multiplies unsigned by signed bytes, four products into an int32 lane, with no
// intermediate saturation (unlike vpmaddubsw), so with u = x + 128 in 0..255,
// sum w u = sum w (x - zp_in) + (zp_in + 128) sum w exactly; padding taps are fed as u = zp_in + 128 (a zero
// term, as in the portable rows) and (zp_in + 128) sum w is subtracted from the bias, modulo 2^32 like every
// accumulation. The int8 weights are packed [k4 / 4][n][4] (n k4 <= the int16 copy's 2 chunk kp bytes; 32-bit
// gathers, the weight sums by vpdpbusd against ones), the rows are unsigned bytes x + 128, k4 apart. Output
// channels run along the lanes (16 per register, 4 registers per tile), 4 pixels per pass.
// Reference: conv.c (tests/unit/test_cnn.c compares every tensor with it on random and shipped models).
// Bounds: O(k n_o) per pack, O(npix k4 n_o / 64) vector operations per GEMM; stack: the tile's registers.
#include "models/cnn/kernels/x86.h"

#include <string.h>

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
            rq16_store(d_, m0, a##p##0, &cv[0], q);                                     \
            if (nv > 1u) {                                                              \
                rq16_store(d_ + 16, m1, a##p##1, &cv[1], q);                            \
            }                                                                           \
            if (nv > 2u) {                                                              \
                rq16_store(d_ + 32, m2, a##p##2, &cv[2], q);                            \
            }                                                                           \
            if (nv > 3u) {                                                              \
                rq16_store(d_ + 48, m3, a##p##3, &cv[3], q);                            \
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

// gemm_nv by the number of channel registers.
X86_INLINE void gemm_by_nv(const uint8_t *rows, size_t rstride, uint32_t f, size_t k4, const int8_t *wp, size_t n_o,
                           const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out,
                           uint32_t npix)
{
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

X86_TARGET void vd__cnn_gemm_vnni(const uint8_t *rows, size_t rstride, bool flip, size_t k4, const int8_t *wp,
                                     size_t n_o, const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride,
                                     int8_t *out, uint32_t npix)
{
    const uint32_t f = flip ? 0x80808080u : 0u;
    // A local copy (the int8 stores may alias *q, so its fields were read again per output), and the shipped
    // networks' case with the flags as constants, as the AVX2 GEMM does.
    const vd_cnn_x86_rq_t qv = *q;
    vd_cnn_x86_rq_t qc;
    if (vd__cnn_x86_rq_shipped(&qv, &qc)) {
        gemm_by_nv(rows, rstride, f, k4, wp, n_o, cv, &qc, pstride, out, npix);
    } else {
        gemm_by_nv(rows, rstride, f, k4, wp, n_o, cv, &qv, pstride, out, npix);
    }
}

X86_TARGET void vd__cnn_pack_vnni(const int8_t *w, size_t k, size_t n_o, int8_t *wp, uint32_t *wsum)
{
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
        vd__cnn_x86_pack_tail(src, k, n_o, nl, dst, s, wsum + o0);
    }
}
