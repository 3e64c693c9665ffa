// SPDX-License-Identifier: MIT
// The x86-64 back end's shared part: which kernel set this CPU runs, requantisation constants as vectors.
//
// Algorithm: vd__cnn_x86_level asks the CPU (__builtin_cpu_supports, CPUID) per call (the executor: once per
// run): AVX-512 F/BW/VL/VNNI, else AVX2 with AVX-VNNI, else AVX2, else none (the portable kernels); no
// cached global, so two detectors never interfere and a binary built here runs on any x86-64 CPU. The
// constants of 16 lanes are vd_rq_prepare's per-channel fields spread for the even/odd 64-bit halves of
// vpmuludq. Also the VNNI packs' shared tail (vd__cnn_x86_pack_tail).
// Bounds: O(16) per vector of constants; O(cout) per layer for vd__cnn_x86_rq_of.
#include "models/cnn/kernels/x86.h"
#include "models/blob_internal.h"

#include <cpuid.h>

// AVX-VNNI: CPUID leaf 7 sub-leaf 1, EAX bit 4 (clang 14's __builtin_cpu_supports has no name for it). Its
// 256-bit registers are the AVX2 ones, whose OS support __builtin_cpu_supports("avx2") has checked.
static bool avx_vnni(void)
{
    unsigned int a = 0u, b = 0u, c = 0u, d = 0u;
    return __get_cpuid_count(7u, 1u, &a, &b, &c, &d) != 0 && (a & (1u << 4)) != 0u;
}

uint32_t vd__cnn_x86_level(void)
{
    __builtin_cpu_init();
    uint32_t level = VD_CNN_X86_NONE;
    if (__builtin_cpu_supports("avx512f") != 0 && __builtin_cpu_supports("avx512bw") != 0 &&
        __builtin_cpu_supports("avx512vl") != 0 && __builtin_cpu_supports("avx512vnni") != 0) {
        level = VD_CNN_X86_AVX512;
    } else if (__builtin_cpu_supports("avx2") != 0) {
        level = avx_vnni() ? VD_CNN_X86_AVXVNNI : VD_CNN_X86_AVX2;   // a CPUID (the caller asks once per run)
    }
#if defined(VD_CNN_X86_MAX_LEVEL)
    // Test builds cap the level to exercise the AVX2 or AVX-VNNI kernels on an AVX-512 CPU.
    level = (level > VD_CNN_X86_MAX_LEVEL) ? VD_CNN_X86_MAX_LEVEL : level;
    // An AVX-512 CPU capped at AVX-VNNI need not have it (Ice Lake, Zen 4): then AVX2.
    level = (level == VD_CNN_X86_AVXVNNI && !avx_vnni()) ? VD_CNN_X86_AVX2 : level;
#endif
    return level;
}

// vd_rq_prepare on 8 lanes at a time (AVX2, which every AVX-512 CPU has): a
// call per 16 output channels per layer call, and streamed runs call every
// layer once per row, so the scalar form cost ~5 % of the demo's instructions.
// Same integer operations, modulo 2^64 / 2^32 as there.
AVX2_TARGET void vd__cnn_x86_rqv_fill(vd_cnn_x86_rqv_t *v, const vd_cnn_layer_t *L, const uint32_t *ch_of,
                                      const int32_t *corr, uint32_t n_lanes)
{
    int32_t idx[16], shift[16], cr[16];
    for (uint32_t j = 0u; j < 16u; j++) {
        const uint32_t jj = (j < n_lanes) ? j : 0u;
        idx[j] = (int32_t)(4u * ch_of[jj]);   // byte offset: cout <= 1024
        shift[j] = L->shift[ch_of[jj]];
        cr[j] = (corr != NULL) ? corr[jj] : 0;
    }
    const __m256i lo32 = _mm256_set1_epi64x(0xFFFFFFFFLL);
    for (uint32_t h = 0u; h < 2u; h++) {
        const __m256i ix = _mm256_loadu_si256((const __m256i *)(const void *)(idx + 8u * h));
        // The blob's little-endian int32 arrays (x86 is little-endian).
        const __m256i mult = _mm256_i32gather_epi32((const int *)(const void *)L->mult, ix, 1);
        const __m256i bias = _mm256_sub_epi32(_mm256_i32gather_epi32((const int *)(const void *)L->bias, ix, 1),
                                              _mm256_loadu_si256((const __m256i *)(const void *)(cr + 8u * h)));
        const __m256i sh = _mm256_loadu_si256((const __m256i *)(const void *)(shift + 8u * h));
        const __m256i zero = _mm256_setzero_si256();
        const __m256i e = _mm256_max_epi32(_mm256_sub_epi32(zero, sh), zero);   // max(-shift, 0)
        const __m256i s = _mm256_add_epi32(e, _mm256_set1_epi32(31));
        const __m256i epos = _mm256_cmpgt_epi32(e, zero);
        _mm256_storeu_si256((__m256i *)(void *)(v->bias + 8u * h), bias);
        _mm256_storeu_si256((__m256i *)(void *)(v->bias_u + 8u * h),
                            _mm256_xor_si256(bias, _mm256_set1_epi32(INT32_MIN)));
        _mm256_storeu_si256((__m256i *)(void *)(v->mult + 8u * h), mult);
        _mm256_storeu_si256((__m256i *)(void *)(v->mult_sw + 8u * h), _mm256_shuffle_epi32(mult, 0xB1));
        // thr = -1 if mult > 2^30 else -2 (mult >= 2^30).
        _mm256_storeu_si256((__m256i *)(void *)(v->thr + 8u * h),
                            _mm256_sub_epi32(_mm256_set1_epi32(-2),
                                             _mm256_cmpgt_epi32(mult, _mm256_set1_epi32(0x40000000))));
        _mm256_storeu_si256((__m256i *)(void *)(v->dk + 8u * h), _mm256_and_si256(epos, _mm256_set1_epi32(INT32_MIN)));
        // off = 2^(63 - s) mod 2^32 = 2^(32 - e): vpsllvd gives 0 for the count 32.
        _mm256_storeu_si256((__m256i *)(void *)(v->off + 8u * h),
                            _mm256_sllv_epi32(_mm256_set1_epi32(1), _mm256_sub_epi32(_mm256_set1_epi32(32), e)));
        _mm256_storeu_si256((__m256i *)(void *)(v->lsh + 8u * h), _mm256_max_epi32(sh, zero));
        // k = 2^63 - 2^31 mult + 2^30 + (e > 0 ? 2^(e - 1 + 31) : 0) per 64-bit lane: the
        // even lanes from the low dwords, the odd ones from the high dwords; the
        // count 64 (e = 0) makes vpsllvq give 0.
        const __m256i cnt = _mm256_blendv_epi8(_mm256_set1_epi32(64), _mm256_add_epi32(e, _mm256_set1_epi32(30)), epos);
        const __m256i base = _mm256_set1_epi64x(INT64_MIN + ((int64_t)1 << 30));   // 2^63 + 2^30
        const __m256i one = _mm256_set1_epi64x(1);
        for (uint32_t odd = 0u; odd < 2u; odd++) {
            const __m256i m = odd ? _mm256_srli_epi64(mult, 32) : _mm256_and_si256(mult, lo32);
            const __m256i c = odd ? _mm256_srli_epi64(cnt, 32) : _mm256_and_si256(cnt, lo32);
            const __m256i k = _mm256_add_epi64(_mm256_sub_epi64(base, _mm256_slli_epi64(m, 31)),
                                               _mm256_sllv_epi64(one, c));
            const __m256i r = odd ? _mm256_srli_epi64(s, 32) : _mm256_and_si256(s, lo32);
            _mm256_storeu_si256((__m256i *)(void *)((odd ? v->k_o : v->k_e) + 4u * h), k);
            _mm256_storeu_si256((__m256i *)(void *)((odd ? v->rsh_o : v->rsh_e) + 4u * h), r);
        }
    }
}

vd_cnn_x86_rq_t vd__cnn_x86_rq_of(const vd_cnn_layer_t *L)
{
    vd_cnn_x86_rq_t q;
    q.zp = L->out_zp;
    q.lo = L->act_min - L->out_zp;
    q.hi = L->act_max - L->out_zp;
    // The largest shift (a max loop gcc vectorises; the || chain it did not:
    // ~2 % of the demo's instructions, one call per layer call).
    int32_t smax = INT8_MIN;
    for (uint32_t o = 0u; o < L->cout; o++) {
        smax = (L->shift[o] > smax) ? L->shift[o] : smax;
    }
    q.general = smax > 0;
    q.sign = q.general || q.lo < 0;
    q.sat8 = L->act_min == -128 && L->act_max == 127;
    return q;
}

vd_cnn_x86_rq_t vd__cnn_x86_layer_rq(const vd_cnn_layer_t *L, const uint8_t **prep)
{
    if (*prep == NULL) {
        return vd__cnn_x86_rq_of(L);
    }
    vd_cnn_x86_rq_t q;
    memcpy(&q, *prep, sizeof q);
    *prep += VD_CNN_X86_PREP_RQ;
    return q;
}

// The flags fit their place at the head of a prepared area.
typedef char vd_cnn_x86_rq_fits[(sizeof(vd_cnn_x86_rq_t) <= VD_CNN_X86_PREP_RQ) ? 1 : -1];

size_t vd__cnn_x86_prep_layer(const vd_cnn_layer_t *L, int32_t zp_in, uint32_t level, uint8_t *dst)
{
    if (dst != NULL) {
        const vd_cnn_x86_rq_t q = vd__cnn_x86_rq_of(L);
        memset(dst, 0, VD_CNN_X86_PREP_RQ);
        memcpy(dst, &q, sizeof q);
    }
    uint8_t *body = (dst != NULL) ? dst + VD_CNN_X86_PREP_RQ : NULL;
    const size_t n = (L->op == VD_CNN_OP_DW3X3) ? vd__cnn_x86_prep_dw(L, zp_in, level, body)
                                                : vd__cnn_x86_prep_conv(L, zp_in, level, body);
    return VD_CNN_X86_PREP_RQ + n;
}

// pack_vnni / pack_avxvnni: the last, partial group of 4 weights of channels o0 .. o0 + nl - 1 (src: channel
// o0's weights, dst: its place in the packing; zero weights past k, whose activations are 0 too), and the
// channels' weight sums (s: those of the full groups).
void vd__cnn_x86_pack_tail(const int8_t *src, size_t k, size_t n_o, size_t nl, int8_t *dst, uint32_t *s, uint32_t *wsum)
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
