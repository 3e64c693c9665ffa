// SPDX-License-Identifier: MIT
// The AVX-VNNI GEMM of the CONV3X3 / CONV5X5 / PW1X1 kernel (conv_x86.c is its driver), for CPUs with AVX-VNNI
// (VEX vpdpbusd on 256-bit registers) and no AVX-512, e.g. Intel's since Alder Lake.
//
// Algorithm: the AVX-512 VNNI scheme on 8 lanes: weights packed [k4 / 4][n][4] as vd__cnn_pack_vnni does, the
// rows as unsigned bytes x + 128, (zp_in + 128) sum w taken from the bias. vpdpbusd sums four u8 x s8
// products into an int32 lane without intermediate saturation, so the sums equal the portable ones modulo
// 2^32 (as vpmaddwd's). Four products per lane and instruction where vpmaddwd gives two and needs an add:
// about a third of the AVX2 GEMM's instructions per multiply-add in the inner loop. Tiles of 4 pixels x 16
// channels (two registers of 8); the requantisation and stores of the AVX2 set (gemm_out in x86.h).
// Reference: conv.c (tests/unit/test_cnn.c compares every tensor with it on random and shipped models).
// Bounds: O(k n_o) per pack, O(npix k4 n_o / 32) vector operations per GEMM; stack: the tile's registers.
#include "models/cnn/kernels/x86.h"

#include <string.h>

AVXVNNI_TARGET void vd__cnn_pack_avxvnni(const int8_t *w, size_t k, size_t n_o, int8_t *wp, uint32_t *wsum)
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
        vd__cnn_x86_pack_tail(src, k, n_o, nl, dst, s, wsum + o0);
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
AVXVNNI_TARGET void vd__cnn_gemm_avxvnni(const uint8_t *rows, size_t rstride, bool flip, size_t k4,
                                            const int8_t *wp, size_t n_o, const vd_cnn_x86_rqv_t *cv,
                                            const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out, uint32_t npix)
{
    const uint32_t f = flip ? 0x80808080u : 0u;
    vd_cnn_x86_rq_t qc;
    const bool shipped = vd__cnn_x86_rq_shipped(q, &qc);
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
