// SPDX-License-Identifier: MIT
// The CMSIS-NN back end's shared part: a layer's requantisation arrays in CMSIS-NN's form, the DSP
// kernels' constants, and the size of a layer's prepared area (plan.c).
//
// Algorithm: the model's per-channel multiplier, shift and bias (little-endian in the blob, read as in
// kernels/scratch.c) copied into three int32 arrays, the form CMSIS-NN's kernels take
// (cmsis_nn_per_channel_quant_params, bias_data); the shift range is checked on the way (cmsis.h).
// Bounds: O(cout) per kernel call.
#include "models/cnn/kernels/cmsis.h"

#include <string.h>

// The arrays replace the portable constants in the same scratch piece (cmsis.h).
typedef char vd_cnn_cmsis_q_fits[(sizeof(vd_rq_ch_t) >= 12u) ? 1 : -1];

bool vd__cnn_cmsis_q_fill(const vd_cnn_layer_t *L, uint8_t *area, vd_cnn_cmsis_q_t *q)
{
    q->mult = (int32_t *)(void *)area;
    q->shift = q->mult + L->cout;
    q->bias = q->shift + L->cout;
    for (uint32_t o = 0u; o < L->cout; o++) {
        const int32_t sh = L->shift[o];
        if (sh > 0 || sh < VD_CNN_CMSIS_SHIFT_MIN) {
            return false;
        }
        q->mult[o] = vd_cnn_rd_i32(L->mult + 4u * (size_t)o);
        q->shift[o] = sh;
        q->bias[o] = vd_cnn_rd_i32(L->bias + 4u * (size_t)o);
    }
    return true;
}

#if defined(VD_CNN_DSP)
// The DSP kernels' constants replace the portable ones in the same scratch piece (cmsis.h).
typedef char vd_cnn_dsp_q_fits[(sizeof(vd_rq_ch_t) >= sizeof(vd_cnn_dsp_ch_t) + 4u) ? 1 : -1];

// Sum of output channel o's weights (DW3X3: [3][3][cout]; the others [cout][K]).
static int32_t wsum_of(const vd_cnn_layer_t *L, uint32_t o)
{
    int32_t s = 0;   // |sum| <= K 128 < 2^31
    if (L->op == VD_CNN_OP_DW3X3) {
        const int8_t *w = L->w + o;
        const size_t n = L->cout;
        return w[0] + w[n] + w[2u * n] + w[3u * n] + w[4u * n] + w[5u * n] + w[6u * n] + w[7u * n] + w[8u * n];
    }
    const size_t n = vd_cnn_k_of(L);
    const int8_t *w = L->w + o * n;
    size_t k = 0u;
    if ((n % 4u) == 0u) {   // pointwise: four weights per SXTB16 pair and two SMLAD with (1, 1)
        for (; k < n; k += 4u) {
            uint32_t x;
            memcpy(&x, w + k, 4u);
            s = (int32_t)SMLAD(SXTB16(x), 0x00010001u, (uint32_t)s);
            s = (int32_t)SMLAD(SXTB16_RORn(x, 8u), 0x00010001u, (uint32_t)s);
        }
    }
    for (; k < n; k++) {
        s += w[k];
    }
    return s;
}

bool vd__cnn_dsp_q_fill(const vd_cnn_layer_t *L, int32_t zp_in, uint8_t *area, bool sums, vd_cnn_dsp_q_t *q)
{
    if (L->act_min != -128 || L->act_max != 127) {
        return false;
    }
    vd_cnn_dsp_q_view(L, area, q);
    vd_cnn_dsp_ch_t *ch = q->ch;
    const int32_t zp2 = 2 * L->out_zp + 1;   // |2 zp + 1| <= 255
    for (uint32_t o = 0u; o < L->cout; o++) {
        const int32_t sh = L->shift[o];
        if (sh > -1 || sh < VD_CNN_DSP_SHIFT_MIN) {
            return false;
        }
        const uint32_t e = (uint32_t)-sh;   // the right shift, 1..24
        const int32_t mult = vd_cnn_rd_i32(L->mult + 4u * (size_t)o);
        // b' = bias - zp_in sum w: exact in int32 (the loader's bias bound leaves room for K 128 255).
        const int32_t ws = sums ? q->thr[o] : wsum_of(L, o);   // (thr[o] written below, after this read)
        const int32_t b = vd_rq_u32_to_i32((uint32_t)vd_cnn_rd_i32(L->bias + 4u * (size_t)o) -
                                           (uint32_t)zp_in * (uint32_t)ws);
        // cmsis.h's sum k2 + b' mult + zp 2^(32 + sh) with models/requant.h's k (vd_rq_prepare: 2^63 -
        // 2^31 mult + 2^30 + 2^(e + 30)) and k2 = k + 2^31 mult + 2^63, sh = e - 1: the 2^63 terms and the
        // 2^31 mult terms cancel (mod 2^64), leaving b' mult + 2^30 + (2 zp + 1) 2^(e - 1) 2^31, where
        // |(2 zp + 1) 2^(e - 1)| <= 255 2^23 < 2^31.
        const int32_t t = zp2 * (int32_t)((uint32_t)1 << (e - 1u));
        ch[o].k = (uint64_t)((int64_t)b * mult) + ((uint64_t)1 << 30) + ((uint64_t)(int64_t)t << 31);
        ch[o].mult = mult;
        ch[o].sh = e - 1u;
        // models/requant.h's thr (-1, or -2 for mult = 2^30) - b', clamped to int32 (the sums lie inside).
        const int64_t thr = ((mult > (int32_t)VD_RQ_MULT_MIN) ? -1 : -2) - (int64_t)b;
        q->thr[o] = (thr < INT32_MIN) ? INT32_MIN : (int32_t)thr;
    }
    return true;
}
#endif

uint32_t vd__cnn_cmsis_prep_bytes(const vd_cnn_layer_t *L)
{
#if defined(VD_CNN_DSP)
    // The layers the DSP kernels take (their vd__cnn_dsp_q_fill succeeds): a prepared area that a later
    // call trusts must have been filled, never refused.
    const uint32_t w = vd_cnn_prep_w_bytes(L);
    bool ok = w != 0u && L->act_min == -128 && L->act_max == 127;
    for (uint32_t o = 0u; o < L->cout && ok; o++) {
        ok = L->shift[o] <= -1 && L->shift[o] >= VD_CNN_DSP_SHIFT_MIN;
    }
    return ok ? w + vd_cnn_dsp_q_bytes(L) : 0u;
#else
    (void)L;   // CMSIS-NN's own kernels (-Os, no DSP extension): O(cout) set-up per call, nothing kept
    return 0u;
#endif
}
