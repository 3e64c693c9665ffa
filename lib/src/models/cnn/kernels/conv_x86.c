// SPDX-License-Identifier: MIT
// CNN kernel CONV3X3 / CONV5X5 / PW1X1 on x86-64 (AVX-512 VNNI, AVX2): the GEMM of conv.c on vector
// registers, with conv.c's scratch and bytes.
//
// Algorithm:
//  * AVX-512 VNNI: vpdpbusd multiplies unsigned by signed bytes, four products into an int32 lane, with
//    no intermediate saturation (unlike vpmaddubsw), so with u = x + 128 in 0..255,
//    sum w u = sum w (x - zp_in) + (zp_in + 128) sum w exactly; padding taps are fed as u = zp_in + 128
//    (a zero term, as in the portable rows) and (zp_in + 128) sum w is subtracted from the bias, modulo
//    2^32 like every accumulation. Per tile of <= 64 output channels the int8 weights are packed
//    [k4 / 4][n][4] (n k4 <= the int16 copy's 2 chunk kp bytes), per block of 16 pixels the rows as
//    unsigned bytes x + 128, k4 apart (16 k4 <= the int16 rows' bytes; the one-channel first layer per
//    row span, gather_c1k3_u8). Output channels run along the
//    lanes (16 per register, 4 registers per tile), 4 pixels per pass. Pointwise layers whose input
//    channels are a multiple of 4 read their input row in place.
//  * AVX2 (no AVX-512): exact int16 products by vpmaddwd (pairs of int16 products summed into int32:
//    |sum| <= 2 * 255 * 128, no saturation) on conv.c's int16 rows (x - zp_in, padding 0), so no
//    zero-point correction; weights as int16 pairs [k2 / 2][n][2] (2 n k2 <= the int16 copy's bytes).
//    8 output channels per register, tiles of 4 pixels x 16 channels (16 ymm registers). Rows: pointwise
//    16 channels per vector op (gather_pw), the one-channel first layer per row span (gather_c1k3), others
//    conv.c's gather. Layers whose output range is all of int8 skip the clamp (sat8_16 in x86.h).
// Streamed runs repack a layer's weights per call as conv.c re-copies its own (32-bit gathers; AVX-512
// weight sums by vpdpbusd against ones).
// Reference: conv.c (tests/unit/test_cnn.c compares every tensor with it on random and shipped models).
// Bounds: as conv.c; stack ~4 KiB (the constants of one tile of 64 channels).
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

X86_KERNEL X86_TARGET void gemm_vnni(const uint8_t *rows, size_t rstride, bool flip, size_t k4, const int8_t *wp,
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

// pack_vnni / pack_avxvnni: the last, partial group of 4 weights of channels o0 .. o0 + nl - 1 (src: channel
// o0's weights, dst: its place in the packing; zero weights past k, whose activations are 0 too), and the
// channels' weight sums (s: those of the full groups).
static void pack_tail(const int8_t *src, size_t k, size_t n_o, size_t nl, int8_t *dst, uint32_t *s, uint32_t *wsum)
{
    const size_t full = k / 4u, k4 = (k + 3u) / 4u * 4u;
    for (size_t j = 0u; j < nl; j++) {
        int8_t *d = dst + full * n_o * 4u + j * 4u;
        for (size_t i = 4u * full; i < k4; i++) {
            const int32_t wv = (i < k) ? src[j * k + i] : 0;
            d[i - 4u * full] = (int8_t)wv;
            s[j] += (uint32_t)wv;
        }
        wsum[j] = s[j];
    }
}

X86_KERNEL X86_TARGET void pack_vnni(const int8_t *w, size_t k, size_t n_o, int8_t *wp, uint32_t *wsum)
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
        pack_tail(src, k, n_o, nl, dst, s, wsum + o0);
    }
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

X86_KERNEL AVX2_TARGET void pack_avx2(const int8_t *w, size_t k, size_t n_o, int16_t *wp)
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

// gemm_avx2's body; q's flags and wfull (n_o a multiple of 16: plain weight
// loads, which leave gcc the registers the masks took: with them it spilled
// accumulators in the inner loop) are constants where the caller specialises them.
// rows holds VD_CNN_NPIX rows (the scratch's), so the 4 rows of the last
// group are read even past npix (finite values; their results are not stored).
AVX2_INLINE void gemm_avx2_body(const int16_t *rows, size_t rstride, size_t k, const int16_t *wp, size_t n_o,
                                const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out,
                                uint32_t npix, size_t o_end, const bool wfull)
{
    const size_t ng = (k + 1u) / 2u;
    const size_t row = n_o * 2u;
    for (size_t o0 = 0u; o0 < o_end; o0 += 16u) {
        const size_t n0 = (n_o - o0 < 8u) ? n_o - o0 : 8u;
        const size_t n1 = (n_o - o0 > 8u) ? ((n_o - o0 - 8u < 8u) ? n_o - o0 - 8u : 8u) : 0u;
        const __m256i m0 = lane_mask8(n0), m1 = lane_mask8(n1);
        const vd_cnn_x86_rqv_t *c = &cv[o0 / 16u];
        for (uint32_t p0 = 0u; p0 < npix; p0 += 4u) {
            const int16_t *r0 = rows + (size_t)p0 * rstride;
            const int16_t *r1 = r0 + rstride;
            const int16_t *r2 = r1 + rstride;
            const int16_t *r3 = r2 + rstride;
            const __m256i z = _mm256_setzero_si256();
            __m256i a00 = z, a01 = z, a10 = z, a11 = z, a20 = z, a21 = z, a30 = z, a31 = z;
            const int16_t *wr = wp + 2u * o0;
            for (size_t gi = 0u; gi < ng; gi++) {
                const __m256i w0 = wfull ? _mm256_loadu_si256((const __m256i *)(const void *)wr)
                                         : _mm256_maskload_epi32((const int *)(const void *)wr, m0);
                const __m256i w1 = wfull ? _mm256_loadu_si256((const __m256i *)(const void *)(wr + 16))
                                         : _mm256_maskload_epi32((const int *)(const void *)(wr + 16), m1);
                int32_t b;
                memcpy(&b, r0 + 2u * gi, sizeof b);
                __m256i bb = _mm256_set1_epi32(b);
                a00 = _mm256_add_epi32(_mm256_madd_epi16(bb, w0), a00);
                a01 = _mm256_add_epi32(_mm256_madd_epi16(bb, w1), a01);
                memcpy(&b, r1 + 2u * gi, sizeof b);
                bb = _mm256_set1_epi32(b);
                a10 = _mm256_add_epi32(_mm256_madd_epi16(bb, w0), a10);
                a11 = _mm256_add_epi32(_mm256_madd_epi16(bb, w1), a11);
                memcpy(&b, r2 + 2u * gi, sizeof b);
                bb = _mm256_set1_epi32(b);
                a20 = _mm256_add_epi32(_mm256_madd_epi16(bb, w0), a20);
                a21 = _mm256_add_epi32(_mm256_madd_epi16(bb, w1), a21);
                memcpy(&b, r3 + 2u * gi, sizeof b);
                bb = _mm256_set1_epi32(b);
                a30 = _mm256_add_epi32(_mm256_madd_epi16(bb, w0), a30);
                a31 = _mm256_add_epi32(_mm256_madd_epi16(bb, w1), a31);
                wr += row;
            }
            const __m256i acc[4][2] = {{a00, a01}, {a10, a11}, {a20, a21}, {a30, a31}};
            for (uint32_t p = 0u; p < 4u; p++) {
                if (p0 + p < npix) {
                    gemm_out(out + ((size_t)p0 + p) * pstride + o0, acc[p][0], acc[p][1], c, q, n0, n1);
                }
            }
        }
    }
}

// The last group of output channels o0 .. n_o - 1 when it holds at most 8 (n_o % 16 in
// 1..8: the heads, a 24- or 136-channel layer): 4 pixels x 8 channels, where
// gemm_avx2_body would compute 16 lanes per pixel and store 8.
X86_KERNEL AVX2_TARGET void gemm_avx2_8(const int16_t *rows, size_t rstride, size_t k, const int16_t *wp, size_t n_o,
                                        size_t o0, const vd_cnn_x86_rqv_t *c, const vd_cnn_x86_rq_t *q, size_t pstride,
                                        int8_t *out, uint32_t npix)
{
    const size_t ng = (k + 1u) / 2u;
    const size_t row = n_o * 2u;
    const size_t n0 = n_o - o0;
    const __m256i m0 = lane_mask8(n0);
    for (uint32_t p0 = 0u; p0 < npix; p0 += 4u) {
        const int16_t *r0 = rows + (size_t)p0 * rstride;   // 16 rows in the scratch, as gemm_avx2_body
        const int16_t *r1 = r0 + rstride;
        const int16_t *r2 = r1 + rstride;
        const int16_t *r3 = r2 + rstride;
        const __m256i z = _mm256_setzero_si256();
        __m256i a0 = z, a1 = z, a2 = z, a3 = z;
        const int16_t *wr = wp + 2u * o0;
        for (size_t gi = 0u; gi < ng; gi++) {
            const __m256i w0 = _mm256_maskload_epi32((const int *)(const void *)wr, m0);
            int32_t b;
            memcpy(&b, r0 + 2u * gi, sizeof b);
            a0 = _mm256_add_epi32(_mm256_madd_epi16(_mm256_set1_epi32(b), w0), a0);
            memcpy(&b, r1 + 2u * gi, sizeof b);
            a1 = _mm256_add_epi32(_mm256_madd_epi16(_mm256_set1_epi32(b), w0), a1);
            memcpy(&b, r2 + 2u * gi, sizeof b);
            a2 = _mm256_add_epi32(_mm256_madd_epi16(_mm256_set1_epi32(b), w0), a2);
            memcpy(&b, r3 + 2u * gi, sizeof b);
            a3 = _mm256_add_epi32(_mm256_madd_epi16(_mm256_set1_epi32(b), w0), a3);
            wr += row;
        }
        const __m256i acc[4] = {a0, a1, a2, a3};
        for (uint32_t p = 0u; p < 4u; p++) {
            if (p0 + p < npix) {
                store8(out + ((size_t)p0 + p) * pstride + o0, rq8(acc[p], c, 0u, q), n0);
            }
        }
    }
}

X86_KERNEL AVX2_TARGET void gemm_avx2(const int16_t *rows, size_t rstride, size_t k, const int16_t *wp, size_t n_o,
                                      const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out,
                                      uint32_t npix)
{
    const size_t tail = n_o % 16u;
    const size_t o_end = (tail != 0u && tail <= 8u) ? n_o - tail : n_o;   // groups of gemm_avx2_body
    if (q->sat8 && !q->sign && !q->general && o_end % 16u == 0u) {
        // The shipped networks' case: the flags as constants (no branch per output), whole groups.
        const vd_cnn_x86_rq_t qc = {q->zp, q->lo, q->hi, false, false, true};
        gemm_avx2_body(rows, rstride, k, wp, n_o, cv, &qc, pstride, out, npix, o_end, true);
    } else {
        gemm_avx2_body(rows, rstride, k, wp, n_o, cv, q, pstride, out, npix, o_end, false);
    }
    if (o_end < n_o) {
        gemm_avx2_8(rows, rstride, k, wp, n_o, o_end, &cv[o_end / 16u], q, pstride, out, npix);
    }
}

// ---------------------------------------------------------------- AVX-VNNI (256-bit vpdpbusd, no AVX-512)
// The AVX-512 VNNI scheme on 8 lanes: weights packed [k4 / 4][n][4] as pack_vnni does, the rows as unsigned
// bytes x + 128, (zp_in + 128) sum w taken from the bias; vpdpbusd sums four u8 x s8 products into an int32
// lane without intermediate saturation, so the sums equal the portable ones modulo 2^32 (as vpmaddwd's).
// Four products per lane and instruction where vpmaddwd gives two and needs an add: about a third of the
// AVX2 GEMM's instructions per multiply-add in the inner loop.

X86_KERNEL AVXVNNI_TARGET void pack_avxvnni(const int8_t *w, size_t k, size_t n_o, int8_t *wp, uint32_t *wsum)
{
    const size_t full = k / 4u;   // groups of 4 weights inside the channel
    const __m256i ones = _mm256_set1_epi8(1);
    const __m256i idx = _mm256_mullo_epi32(_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), _mm256_set1_epi32((int32_t)k));
    for (size_t o0 = 0u; o0 < n_o; o0 += 8u) {
        const size_t nl = (n_o - o0 < 8u) ? n_o - o0 : 8u;
        const __m256i m = lane_mask8(nl);
        const int8_t *src = w + o0 * k;
        int8_t *dst = wp + o0 * 4u;
        __m256i sum = _mm256_setzero_si256();
        for (size_t gi = 0u; gi < full; gi++) {
            // Lane j: weights 4 gi .. 4 gi + 3 of channel o0 + j (a 32-bit transpose).
            const __m256i v = _mm256_mask_i32gather_epi32(_mm256_setzero_si256(),
                                                          (const int *)(const void *)(src + 4u * gi), idx, m, 1);
            _mm256_maskstore_epi32((int *)(void *)(dst + gi * n_o * 4u), m, v);
            sum = _mm256_dpbusd_avx_epi32(sum, ones, v);
        }
        uint32_t s[8];
        _mm256_storeu_si256((__m256i *)(void *)s, sum);
        pack_tail(src, k, n_o, nl, dst, s, wsum + o0);
    }
}

// One pixel's 4 bytes of group gi, flipped to unsigned where the rows are the input itself, on all lanes.
AVXVNNI_INLINE __m256i vnni8_bcast(const uint8_t *r, size_t gi, uint32_t flip)
{
    uint32_t b;
    memcpy(&b, r + 4u * gi, sizeof b);
    return _mm256_set1_epi32((int32_t)(b ^ flip));
}

// Channels o0 .. o0 + 15 (nv = 2, a constant after inlining) or o0 .. o0 + 7 (nv = 1) of npix pixels in
// tiles of 4 pixels; wfull: every channel of the registers is one (plain weight loads, no masks).
AVXVNNI_INLINE void gemm_avxvnni_body(const uint8_t *rows, size_t rstride, uint32_t flip, size_t k4,
                                      const int8_t *wp, size_t n_o, size_t o0, const vd_cnn_x86_rqv_t *c,
                                      const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out, uint32_t npix,
                                      const size_t nv, const bool wfull)
{
    const size_t n0 = (n_o - o0 < 8u) ? n_o - o0 : 8u;
    const size_t n1 = (nv > 1u && n_o - o0 > 8u) ? ((n_o - o0 - 8u < 8u) ? n_o - o0 - 8u : 8u) : 0u;
    const __m256i m0 = lane_mask8(n0), m1 = lane_mask8(n1);
    const size_t ng = k4 / 4u, wstep = n_o * 4u;
    for (uint32_t p0 = 0u; p0 < npix; p0 += 4u) {
        const uint8_t *r[4];   // past npix the last pixel's row again (read, not stored: in-place rows end there)
        for (uint32_t p = 0u; p < 4u; p++) {
            r[p] = rows + (size_t)((p0 + p < npix) ? p0 + p : npix - 1u) * rstride;
        }
        const __m256i z = _mm256_setzero_si256();
        __m256i a00 = z, a01 = z, a10 = z, a11 = z, a20 = z, a21 = z, a30 = z, a31 = z;
        const int8_t *w = wp + o0 * 4u;
        for (size_t gi = 0u; gi < ng; gi++) {
            const __m256i w0 = wfull ? _mm256_loadu_si256((const __m256i *)(const void *)w)
                                     : _mm256_maskload_epi32((const int *)(const void *)w, m0);
            const __m256i w1 = (nv < 2u) ? z
                               : wfull ? _mm256_loadu_si256((const __m256i *)(const void *)(w + 32))
                                       : _mm256_maskload_epi32((const int *)(const void *)(w + 32), m1);
            __m256i bb = vnni8_bcast(r[0], gi, flip);
            a00 = _mm256_dpbusd_avx_epi32(a00, bb, w0);
            a01 = (nv > 1u) ? _mm256_dpbusd_avx_epi32(a01, bb, w1) : a01;
            bb = vnni8_bcast(r[1], gi, flip);
            a10 = _mm256_dpbusd_avx_epi32(a10, bb, w0);
            a11 = (nv > 1u) ? _mm256_dpbusd_avx_epi32(a11, bb, w1) : a11;
            bb = vnni8_bcast(r[2], gi, flip);
            a20 = _mm256_dpbusd_avx_epi32(a20, bb, w0);
            a21 = (nv > 1u) ? _mm256_dpbusd_avx_epi32(a21, bb, w1) : a21;
            bb = vnni8_bcast(r[3], gi, flip);
            a30 = _mm256_dpbusd_avx_epi32(a30, bb, w0);
            a31 = (nv > 1u) ? _mm256_dpbusd_avx_epi32(a31, bb, w1) : a31;
            w += wstep;
        }
        const __m256i acc[4][2] = {{a00, a01}, {a10, a11}, {a20, a21}, {a30, a31}};
        for (uint32_t p = 0u; p < 4u; p++) {
            if (p0 + p < npix) {
                gemm_out(out + ((size_t)p0 + p) * pstride + o0, acc[p][0], acc[p][1], c, q, n0, n1);
            }
        }
    }
}

// gemm_vnni's contract on AVX-VNNI: n_o <= VD_CNN_X86_TILE channels of packed weights wp (pack_avxvnni),
// the rows rstride bytes apart (flip: the rows are int8 input pixels, made unsigned here).
X86_KERNEL AVXVNNI_TARGET void gemm_avxvnni(const uint8_t *rows, size_t rstride, bool flip, size_t k4,
                                            const int8_t *wp, size_t n_o, const vd_cnn_x86_rqv_t *cv,
                                            const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out, uint32_t npix)
{
    const uint32_t f = flip ? 0x80808080u : 0u;
    // The shipped networks' case: the requantisation flags as constants (no branch per output).
    const bool shipped = q->sat8 && !q->sign && !q->general;
    const vd_cnn_x86_rq_t qc = {q->zp, q->lo, q->hi, false, false, true};
    for (size_t o0 = 0u; o0 < n_o; o0 += 16u) {
        const vd_cnn_x86_rqv_t *c = &cv[o0 / 16u];
        if (n_o - o0 >= 16u && shipped) {
            gemm_avxvnni_body(rows, rstride, f, k4, wp, n_o, o0, c, &qc, pstride, out, npix, 2u, true);
        } else if (n_o - o0 > 8u) {
            gemm_avxvnni_body(rows, rstride, f, k4, wp, n_o, o0, c, q, pstride, out, npix, 2u, false);
        } else {
            gemm_avxvnni_body(rows, rstride, f, k4, wp, n_o, o0, c, q, pstride, out, npix, 1u, false);
        }
    }
}

// The per-lane requantisation constants of output channels o0 .. o0 + n_o - 1
// (one tile), corr[j] subtracted from channel o0 + j's bias (corr may be NULL).
static void tile_consts(const vd_cnn_layer_t *L, size_t o0, size_t n_o, const int32_t *corr, vd_cnn_x86_rqv_t *cv)
{
    for (size_t v = 0u; v * VD_CNN_X86_LANES < n_o; v++) {
        uint32_t ch_of[VD_CNN_X86_LANES];
        const size_t n_l = (n_o - v * 16u < 16u) ? n_o - v * 16u : 16u;
        for (size_t j = 0u; j < n_l; j++) {
            ch_of[j] = (uint32_t)(o0 + v * 16u + j);
        }
        vd__cnn_x86_rqv_fill(&cv[v], L, ch_of, (corr != NULL) ? corr + v * 16u : NULL, (uint32_t)n_l);
    }
}

// The unsigned rows (x + 128, padding taps zp_in + 128) of npix output pixels
// from x0, k4 bytes apart, in the weight order [ky][kx][c] (the k..k4 tails
// stay as the caller zeroed them). rowp: the ks input rows (NULL: padding row).
static void gather_u8(const geom_t *g, const int8_t *const rowp[5], int32_t ks, int32_t step, uint32_t x0,
                      uint32_t npix, size_t k4, uint8_t *rows)
{
    const size_t ci = g->ci;
    const uint8_t upad = (uint8_t)(g->zp_in + 128);
    const int32_t pad = ks / 2;
    for (uint32_t i = 0u; i < npix; i++) {
        uint8_t *r = rows + (size_t)i * k4;
        const int32_t ox = (int32_t)(x0 + i);
        if (ks == 1) {   // pointwise: one tap, never padding
            const int8_t *x = rowp[0] + (size_t)ox * ci;
            for (size_t c = 0u; c < ci; c++) {
                r[c] = (uint8_t)((uint8_t)x[c] ^ 0x80u);
            }
            continue;
        }
        const int32_t ix0 = ox * step - pad;
        const bool inside = ix0 >= 0 && ix0 + ks <= (int32_t)g->wi;
        for (int32_t ky = 0; ky < ks; ky++) {
            uint8_t *d = r + (size_t)(ky * ks) * ci;
            if (inside && rowp[ky] != NULL) {
                // ks taps of ci channels, contiguous in the input row.
                const int8_t *x = rowp[ky] + (size_t)ix0 * ci;
                for (size_t c = 0u; c < (size_t)ks * ci; c++) {
                    d[c] = (uint8_t)((uint8_t)x[c] ^ 0x80u);
                }
                continue;
            }
            for (int32_t kx = 0; kx < ks; kx++) {
                const int32_t ix = ix0 + kx;
                uint8_t *dk = d + (size_t)kx * ci;
                if (rowp[ky] == NULL || ix < 0 || ix >= (int32_t)g->wi) {
                    memset(dk, upad, ci);
                } else {
                    const int8_t *x = rowp[ky] + (size_t)ix * ci;
                    for (size_t c = 0u; c < ci; c++) {
                        dk[c] = (uint8_t)((uint8_t)x[c] ^ 0x80u);
                    }
                }
            }
        }
    }
}

// gather_u8 for a CONV3X3 on one input channel (the first layer), as
// gather_c1k3 below does for the int16 rows: each input row's span of the
// block is flipped to unsigned bytes once (zp_in + 128 outside the row), then
// pixel i's 3 taps move from buf + step i with one 4-byte move. The 4th byte
// lands on tap 3 (ky + 1, rewritten next) or, for ky = 2, on position 9 of the
// k4 = 12, whose packed weight is 0 (pack_vnni pads k..k4 with 0). The per-tap
// loop of gather_u8 took 12 % of the demo's time on an AVX-512 machine (perf).
static AVX2_TARGET void gather_c1k3_u8(const geom_t *g, const int8_t *const rowp[5], int32_t step, uint32_t x0,
                                      uint32_t npix, size_t k4, uint8_t *rows)
{
    uint8_t buf[48];   // step (npix - 1) + 4 <= 34 values
    const int32_t ix0 = (int32_t)x0 * step - 1;
    const int32_t n = step * ((int32_t)npix - 1) + 4;
    const int32_t jlo = (ix0 < 0) ? -ix0 : 0;
    const int32_t jhi = ((int32_t)g->wi - ix0 < n) ? (int32_t)g->wi - ix0 : n;
    const uint8_t upad = (uint8_t)(g->zp_in + 128);
    const __m128i top = _mm_set1_epi8((char)0x80);
    for (int32_t ky = 0; ky < 3; ky++) {
        const int8_t *x = rowp[ky];
        int32_t j = 0;
        if (x != NULL) {
            for (; j < jlo; j++) {
                buf[j] = upad;
            }
            for (; j + 16 <= jhi; j += 16) {
                const __m128i v = _mm_loadu_si128((const __m128i *)(const void *)(x + ix0 + j));
                _mm_storeu_si128((__m128i *)(void *)(buf + j), _mm_xor_si128(v, top));
            }
            for (; j < jhi; j++) {
                buf[j] = (uint8_t)((uint8_t)x[ix0 + j] ^ 0x80u);
            }
        }
        for (; j < n; j++) {
            buf[j] = upad;
        }
        for (uint32_t i = 0u; i < npix; i++) {
            memcpy(rows + (size_t)i * k4 + (size_t)ky * 3u, buf + (size_t)step * i, 4u);
        }
    }
}

// vd__cnn_conv_gather for a CONV3X3 on one input channel (the first layer):
// the same int16 rows (x - zp_in, padding taps 0). The generic gather moves
// one tap at a time (callgrind: 18 % of the demo's instructions, almost all
// here); this converts each input row's span of the block once into buf
// (0 outside the row) and copies pixel i's 3 taps from buf + step i with one
// 8-byte move. The move's 4th value lands on tap 3 (ky + 1) or, for ky = 2,
// on position 9, whose packed weight is 0 (pack_avx2 pads k2 = 10 with 0):
// rewritten, or multiplied by 0.
static AVX2_TARGET void gather_c1k3(const geom_t *g, const int8_t *const rowp[5], int32_t step, uint32_t x0,
                                    uint32_t npix, size_t kp, int16_t *rows)
{
    int16_t buf[48];   // step (npix - 1) + 4 <= 34 values, whole 16-value chunks
    const int32_t ix0 = (int32_t)x0 * step - 1;
    const int32_t n = step * ((int32_t)npix - 1) + 4;
    const int32_t jlo = (ix0 < 0) ? -ix0 : 0;
    const int32_t jhi = ((int32_t)g->wi - ix0 < n) ? (int32_t)g->wi - ix0 : n;
    const __m256i zp = _mm256_set1_epi16((int16_t)g->zp_in);
    for (int32_t ky = 0; ky < 3; ky++) {
        const int8_t *x = rowp[ky];
        int32_t j = 0;
        if (x != NULL) {
            for (; j < jlo; j++) {
                buf[j] = 0;
            }
            for (; j + 16 <= jhi; j += 16) {
                const __m128i v = _mm_loadu_si128((const __m128i *)(const void *)(x + ix0 + j));
                _mm256_storeu_si256((__m256i *)(void *)(buf + j), _mm256_sub_epi16(_mm256_cvtepi8_epi16(v), zp));
            }
            for (; j < jhi; j++) {
                buf[j] = (int16_t)(x[ix0 + j] - g->zp_in);
            }
        }
        for (; j < n; j++) {
            buf[j] = 0;
        }
        for (uint32_t i = 0u; i < npix; i++) {
            memcpy(rows + (size_t)i * kp + (size_t)ky * 3u, buf + (size_t)step * i, 4u * sizeof(int16_t));
        }
    }
}

// vd__cnn_conv_gather for a pointwise layer: the npix pixels' ci channels
// (contiguous from x) as int16 x - zp_in, kp apart, 16 and then 8 at a time
// (the generic loop: ~1.8 instructions per value, callgrind).
static AVX2_TARGET void gather_pw(const int8_t *x, size_t ci, int32_t zp_in, uint32_t npix, size_t kp, int16_t *rows)
{
    const __m256i zp = _mm256_set1_epi16((int16_t)zp_in);
    for (uint32_t i = 0u; i < npix; i++) {
        const int8_t *xi = x + (size_t)i * ci;
        int16_t *r = rows + (size_t)i * kp;
        size_t c = 0u;
        for (; c + 16u <= ci; c += 16u) {
            const __m128i v = _mm_loadu_si128((const __m128i *)(const void *)(xi + c));
            _mm256_storeu_si256((__m256i *)(void *)(r + c), _mm256_sub_epi16(_mm256_cvtepi8_epi16(v), zp));
        }
        if (c + 8u <= ci) {
            const __m128i v = _mm_cvtepi8_epi16(_mm_loadl_epi64((const __m128i *)(const void *)(xi + c)));
            _mm_storeu_si128((__m128i *)(void *)(r + c), _mm_sub_epi16(v, _mm256_castsi256_si128(zp)));
            c += 8u;
        }
        for (; c < ci; c++) {
            r[c] = (int16_t)(xi[c] - zp_in);
        }
    }
}

// vd__cnn_conv_rows on the AVX2 GEMM: the portable int16 rows (x - zp_in, padding
// 0) and, per tile of <= 64 output channels, int16 weight pairs
// [k2 / 2][n][2] (2 n k2 <= the int16 copy's 2 chunk kp bytes).
static void conv_rows_avx2(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                           uint32_t y0, uint32_t y1, uint8_t *scr, const scratch_layout_t *s)
{
    const size_t k = vd_cnn_k_of(L);
    const size_t kp = vd_cnn_round_up((uint32_t)k, VD_CNN_KCHUNK);
    int16_t *wp = (int16_t *)(void *)(scr + s->w16);
    int16_t *rows = (int16_t *)(void *)(scr + s->rows);
    if (k % 2u != 0u) {
        // gemm_avx2 reads k2 = k rounded up to even values per row: position k (weight 0) must be
        // defined. The gathers write positions 0..k - 1 of every row they fill; rows past npix feed
        // only results that are not stored. (Zeroing every call: ~1.4 % of the demo's instructions.)
        memset(rows, 0, (size_t)VD_CNN_NPIX * kp * sizeof(int16_t));
    }
    const vd_cnn_x86_rq_t xq = vd__cnn_x86_rq_of(L);
    const int32_t step = L->stride;
    const bool pw = L->op == VD_CNN_OP_PW1X1;
    const int32_t ks = pw ? 1 : ((L->op == VD_CNN_OP_CONV5X5) ? 5 : 3);
    const bool c1k3 = ks == 3 && g->ci == 1u;   // gather_c1k3's case (stride 1 or 2: the loader's bound)
    for (size_t o0 = 0u; o0 < g->co; o0 += VD_CNN_X86_TILE) {
        const size_t n_o = (g->co - o0 < VD_CNN_X86_TILE) ? g->co - o0 : VD_CNN_X86_TILE;
        pack_avx2(L->w + o0 * k, k, n_o, wp);
        vd_cnn_x86_rqv_t cv[VD_CNN_X86_TILE / VD_CNN_X86_LANES];
        tile_consts(L, o0, n_o, NULL, cv);
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rowp[5];
            vd__cnn_conv_row_ptrs(g, in, oy, step, ks, rowp);
            int8_t *orow = vd_cnn_ring_row(out, oy) + o0;
            for (uint32_t x0 = 0u; x0 < g->wo; x0 += VD_CNN_NPIX) {
                const uint32_t npix = (g->wo - x0 < VD_CNN_NPIX) ? g->wo - x0 : VD_CNN_NPIX;
                if (pw) {
                    gather_pw(rowp[0] + (size_t)x0 * g->ci, g->ci, g->zp_in, npix, kp, rows);
                } else if (c1k3) {
                    gather_c1k3(g, rowp, step, x0, npix, kp, rows);
                } else {
                    vd__cnn_conv_gather(g, rowp, ks, step, x0, npix, kp, rows);
                }
                gemm_avx2(rows, kp, k, wp, n_o, cv, &xq, g->co, orow + (size_t)x0 * g->co, npix);
            }
        }
    }
}

// vd__cnn_conv_rows on the AVX-512 VNNI GEMM (gemm_vnni), same scratch:
// per tile of <= 64 output channels the int8 weights packed [k4 / 4][n][4]
// (n k4 <= the int16 copy's 2 chunk kp bytes), per block of 16 pixels the
// rows as unsigned bytes x + 128, k4 apart (16 k4 <= the int16 rows' bytes);
// padding taps are zp_in + 128 and the bias loses (zp_in + 128) sum w, so
// the int32 sums equal the portable ones modulo 2^32 (above).
void vd__cnn_conv_rows_x86(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0,
                          uint32_t y1, bool stream, uint8_t *scr, uint32_t level)
{
    scratch_layout_t sl;
    (void)vd__cnn_conv_scratch(L, stream, &sl);
    const scratch_layout_t *s = &sl;
    if (level == VD_CNN_X86_AVX2) {
        conv_rows_avx2(L, g, in, out, y0, y1, scr, s);
        return;
    }
    const bool v512 = level == VD_CNN_X86_AVX512;   // else AVX-VNNI: the same rows, weights and constants
    const size_t k = vd_cnn_k_of(L);
    const size_t k4 = vd_cnn_round_up((uint32_t)k, 4u);
    int8_t *wp = (int8_t *)(void *)(scr + s->w16);
    uint8_t *rows = scr + s->rows;
    memset(rows, 0, (size_t)VD_CNN_NPIX * k4);   // the k..k4 tails stay 0 (their weights are 0 too)
    const vd_cnn_x86_rq_t xq = vd__cnn_x86_rq_of(L);
    const size_t ci = g->ci;
    const int32_t step = L->stride;
    const bool pw = L->op == VD_CNN_OP_PW1X1;
    const int32_t ks = pw ? 1 : ((L->op == VD_CNN_OP_CONV5X5) ? 5 : 3);
    const bool in_place = pw && ci % 4u == 0u;
    const bool c1k3 = ks == 3 && ci == 1u;   // gather_c1k3_u8's case (stride 1 or 2: the loader's bound)
    for (size_t o0 = 0u; o0 < g->co; o0 += VD_CNN_X86_TILE) {
        const size_t n_o = (g->co - o0 < VD_CNN_X86_TILE) ? g->co - o0 : VD_CNN_X86_TILE;
        int32_t corr[VD_CNN_X86_TILE];
        uint32_t wsum[VD_CNN_X86_TILE];
        if (v512) {
            pack_vnni(L->w + o0 * k, k, n_o, wp, wsum);
        } else {
            pack_avxvnni(L->w + o0 * k, k, n_o, wp, wsum);
        }
        for (size_t o = 0u; o < n_o; o++) {
            corr[o] = vd_rq_u32_to_i32(wsum[o] * (uint32_t)(g->zp_in + 128));   // modulo 2^32, as the sums
        }
        vd_cnn_x86_rqv_t cv[VD_CNN_X86_TILE / VD_CNN_X86_LANES];
        tile_consts(L, o0, n_o, corr, cv);
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rowp[5];
            vd__cnn_conv_row_ptrs(g, in, oy, step, ks, rowp);
            int8_t *orow = vd_cnn_ring_row(out, oy) + o0;
            for (uint32_t x0 = 0u; x0 < g->wo; x0 += VD_CNN_NPIX) {
                const uint32_t npix = (g->wo - x0 < VD_CNN_NPIX) ? g->wo - x0 : VD_CNN_NPIX;
                if (in_place) {
                    // The input pixels are the rows (x, flipped to x + 128 in the kernel).
                    const uint8_t *xr = (const uint8_t *)(const void *)(rowp[0] + (size_t)x0 * ci);
                    int8_t *o = orow + (size_t)x0 * g->co;
                    if (v512) {
                        gemm_vnni(xr, ci, true, k4, wp, n_o, cv, &xq, g->co, o, npix);
                    } else {
                        gemm_avxvnni(xr, ci, true, k4, wp, n_o, cv, &xq, g->co, o, npix);
                    }
                    continue;
                }
                if (c1k3) {
                    gather_c1k3_u8(g, rowp, step, x0, npix, k4, rows);
                } else {
                    gather_u8(g, rowp, ks, step, x0, npix, k4, rows);
                }
                if (v512) {
                    gemm_vnni(rows, k4, false, k4, wp, n_o, cv, &xq, g->co, orow + (size_t)x0 * g->co, npix);
                } else {
                    gemm_avxvnni(rows, k4, false, k4, wp, n_o, cv, &xq, g->co, orow + (size_t)x0 * g->co, npix);
                }
            }
        }
    }
}
