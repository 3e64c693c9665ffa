// SPDX-License-Identifier: MIT
// The CMSIS-NN back end's shared part: a layer's requantisation arrays in CMSIS-NN's form.
//
// Algorithm: the model's per-channel multiplier, shift and bias (little-endian in the blob, read as in
// kernels/scratch.c) copied into three int32 arrays, the form CMSIS-NN's kernels take
// (cmsis_nn_per_channel_quant_params, bias_data); the shift range is checked on the way (cmsis.h).
// Bounds: O(cout) per kernel call.
#include "models/cnn/kernels/cmsis.h"

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

// thr - b' clamped to int32 (the sums s lie strictly inside it, cmsis.h).
static int32_t thr_of(int64_t t)
{
    return (t < INT32_MIN) ? INT32_MIN : (t > INT32_MAX) ? INT32_MAX : (int32_t)t;
}

// Sum of output channel o's weights (DW3X3: [3][3][cout]; the others [cout][K]).
static int64_t wsum_of(const vd_cnn_layer_t *L, uint32_t o)
{
    int64_t s = 0;
    if (L->op == VD_CNN_OP_DW3X3) {
        for (size_t k = 0u; k < 9u; k++) {
            s += L->w[k * L->cout + o];
        }
        return s;
    }
    const size_t n = vd_cnn_k_of(L);
    for (size_t k = 0u; k < n; k++) {
        s += L->w[o * n + k];
    }
    return s;
}

bool vd_cnn_dsp_q_fill(const vd_cnn_layer_t *L, int32_t zp_in, uint8_t *area, vd_cnn_dsp_q_t *q)
{
    if (L->act_min != -128 || L->act_max != 127) {
        return false;
    }
    vd_cnn_dsp_ch_t *ch = (vd_cnn_dsp_ch_t *)(void *)area;
    q->ch = ch;
    q->thr = (int32_t *)(void *)(ch + L->cout);
    q->relu = L->act_min >= L->out_zp;
    for (uint32_t o = 0u; o < L->cout; o++) {
        const int32_t sh = L->shift[o];
        if (sh > -1 || sh < VD_CNN_DSP_SHIFT_MIN) {
            return false;
        }
        vd_rq_ch_t c;
        const int32_t mult = vd_cnn_rd_i32(L->mult + 4u * (size_t)o);
        // b' = bias - zp_in sum w, exact (|b'| < 2^31 by the loader's bound, |products| < 2^62).
        const int64_t b = (int64_t)vd_cnn_rd_i32(L->bias + 4u * (size_t)o) - (int64_t)zp_in * wsum_of(L, o);
        vd_rq_prepare(mult, sh, 0, &c);
        ch[o].sh = (uint32_t)c.rsh - 32u;
        ch[o].mult = mult;
        ch[o].k = c.k + ((uint64_t)(uint32_t)mult << 31) + ((uint64_t)1 << 63) + (uint64_t)(b * mult) +
                  ((uint64_t)(int64_t)L->out_zp << (32u + ch[o].sh));
        q->thr[o] = thr_of((int64_t)c.thr - b);
    }
    return true;
}
#endif
