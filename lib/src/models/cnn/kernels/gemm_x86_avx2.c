// SPDX-License-Identifier: MIT
// The AVX2 GEMM of the CONV3X3 / CONV5X5 / PW1X1 kernel (conv_x86.c is its driver), for CPUs without AVX-512
// or AVX-VNNI: the weight packing of one tile of <= 64 output channels and the multiply of one block of
// <= VD_CNN_NPIX pixels.
//
// Algorithm: exact int16 products by vpmaddwd (pairs of int16 products summed into int32:
// |sum| <= 2 * 255 * 128, no saturation) on conv.c's int16 rows (x - zp_in, padding 0), so no zero-point
// correction; weights as int16 pairs [k2 / 2][n][2] (2 n k2 <= the int16 copy's bytes; 32-bit gathers).
// 8 output channels per register, tiles of 4 pixels x 16 channels (16 ymm registers); a last group of <= 8
// channels on 8 lanes. Layers whose output range is all of int8 skip the clamp (sat8_16 in x86.h).
// Reference: conv.c (tests/unit/test_cnn.c compares every tensor with it on random and shipped models).
// Bounds: O(k n_o) per pack, O(npix k2 n_o / 16) vector operations per GEMM; stack: the tile's registers.
#include "models/cnn/kernels/x86.h"

#include <string.h>

AVX2_TARGET void vd__cnn_pack_avx2(const int8_t *w, size_t k, size_t n_o, int16_t *wp)
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

// One pixel's int16 pair at r, broadcast, times the weight pairs of 16 channels (w0: 0-7, w1: 8-15), added to
// its accumulators.
AVX2_INLINE void madd_pair(const int16_t *r, __m256i w0, __m256i w1, __m256i *a0, __m256i *a1)
{
    int32_t b;
    memcpy(&b, r, sizeof b);
    const __m256i bb = _mm256_set1_epi32(b);
    *a0 = _mm256_add_epi32(_mm256_madd_epi16(bb, w0), *a0);
    *a1 = _mm256_add_epi32(_mm256_madd_epi16(bb, w1), *a1);
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
                madd_pair(r0 + 2u * gi, w0, w1, &a00, &a01);
                madd_pair(r1 + 2u * gi, w0, w1, &a10, &a11);
                madd_pair(r2 + 2u * gi, w0, w1, &a20, &a21);
                madd_pair(r3 + 2u * gi, w0, w1, &a30, &a31);
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

AVX2_TARGET void vd__cnn_gemm_avx2(const int16_t *rows, size_t rstride, size_t k, const int16_t *wp, size_t n_o,
                                      const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out,
                                      uint32_t npix)
{
    const size_t tail = n_o % 16u;
    const size_t o_end = (tail != 0u && tail <= 8u) ? n_o - tail : n_o;   // groups of gemm_avx2_body
    vd_cnn_x86_rq_t qc;
    if (vd__cnn_x86_rq_shipped(q, &qc) && o_end % 16u == 0u) {   // and whole groups
        gemm_avx2_body(rows, rstride, k, wp, n_o, cv, &qc, pstride, out, npix, o_end, true);
    } else {
        gemm_avx2_body(rows, rstride, k, wp, n_o, cv, q, pstride, out, npix, o_end, false);
    }
    if (o_end < n_o) {
        gemm_avx2_8(rows, rstride, k, wp, n_o, o_end, &cv[o_end / 16u], q, pstride, out, npix);
    }
}
