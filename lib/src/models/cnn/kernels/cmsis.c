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

bool vd_cnn_dsp_q_fill(const vd_cnn_layer_t *L, uint8_t *area, vd_cnn_dsp_q_t *q)
{
    vd_cnn_dsp_ch_t *ch = (vd_cnn_dsp_ch_t *)(void *)area;
    q->ch = ch;
    q->bias = (int32_t *)(void *)(ch + L->cout);
    for (uint32_t o = 0u; o < L->cout; o++) {
        const int32_t sh = L->shift[o];
        if (sh > -1 || sh < VD_RQ_SHIFT_MIN) {
            return false;
        }
        vd_rq_ch_t c;
        const int32_t mult = vd_cnn_rd_i32(L->mult + 4u * (size_t)o);
        vd_rq_prepare(mult, sh, vd_cnn_rd_i32(L->bias + 4u * (size_t)o), &c);
        ch[o].k2 = c.k + ((uint64_t)(uint32_t)mult << 31) + ((uint64_t)1 << 63);
        ch[o].mult = mult;
        ch[o].sh = (uint32_t)c.rsh - 32u;
        ch[o].thr = c.thr;
        ch[o].pad = 0;
        q->bias[o] = c.bias;
    }
    q->zp = L->out_zp;
    q->lo = L->act_min - L->out_zp;
    q->hi = L->act_max - L->out_zp;
    q->relu = q->lo >= 0;
    q->sat8 = q->lo == 0 && q->hi == 255;
    return true;
}
#endif
