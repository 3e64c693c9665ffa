// SPDX-License-Identifier: MIT
// The x86-64 back end's shared part: which kernel set this CPU runs, requantisation constants as vectors.
//
// Algorithm: vd__cnn_x86_level asks the CPU (__builtin_cpu_supports) per call: AVX-512 F/BW/VL/VNNI, else
// AVX2, else none (the portable kernels); no cached global, so two detectors never interfere and a
// binary built here runs on any x86-64 CPU. The constants of 16 lanes are vd_rq_prepare's per-channel
// fields spread for the even/odd 64-bit halves of vpmuludq.
// Bounds: O(16) per vector of constants; O(cout) per layer for vd__cnn_x86_rq_of.
#include "models/cnn/kernels/x86.h"
#include "models/blob_internal.h"

uint32_t vd__cnn_x86_level(void)
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

void vd__cnn_x86_rqv_fill(vd_cnn_x86_rqv_t *v, const vd_cnn_layer_t *L, const uint32_t *ch_of, const int32_t *corr,
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
        v->bias_u[j] = (uint32_t)c.bias ^ 0x80000000u;
        v->mult[j] = c.mult;
        v->mult_sw[j ^ 1u] = c.mult;
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

vd_cnn_x86_rq_t vd__cnn_x86_rq_of(const vd_cnn_layer_t *L)
{
    vd_cnn_x86_rq_t q;
    q.zp = L->out_zp;
    q.lo = L->act_min - L->out_zp;
    q.hi = L->act_max - L->out_zp;
    q.general = false;
    for (uint32_t o = 0u; o < L->cout; o++) {
        q.general = q.general || L->shift[o] > 0;
    }
    q.sign = q.general || q.lo < 0;
    q.sat8 = L->act_min == -128 && L->act_max == 127;
    return q;
}
