// SPDX-License-Identifier: MIT
// CNN kernel DW3X3 on CMSIS-NN (Cortex-M): dw3x3.c's layers through arm_depthwise_conv_3x3_s8, in the
// layer's scratch, with dw3x3.c's bytes.
//
// Algorithm: arm_depthwise_conv_3x3_s8 (the kernel arm_depthwise_conv_wrapper_s8 picks for a 3x3 filter,
// padding <= 1, depth multiplier 1 on cores without MVE; it needs no buffer) works on a plane: rows
// input_x * input_ch bytes apart, four channels per step with the DSP extension (SXTAB16 adds the input
// offset to two values at once, SMLABB/SMLATT). vd's weights [3][3][cout] are its filter layout [1, 3,
// 3, C_OUT]. Output rows are made in runs whose rows are contiguous in the output ring and whose input
// rows (y * stride - 1 .. y * stride + 1, clamped to the tensor) are contiguous in the input ring: the run
// is a sub-plane starting at its first input row, with top padding 1 only where that row is -1 (bottom
// padding follows from the sub-plane's height). A whole plane is one run. A streamed row whose three
// input rows wrap around their ring is copied into the scratch behind the requantisation arrays when
// the scratch has room (the streamed plan's one scratch is the largest layer's), else made by the
// portable kernel (dw3x3.c): the same bytes either way.
// Reference: dw3x3.c (tests/unit/test_cnn.c compares every tensor with it); CMSIS-NN's
// arm_depthwise_conv_3x3_s8.
// Bounds: 9 multiply-adds per output value; per run O(1) set-up, per copied row 3 input rows.
#include "models/cnn/kernels/cmsis.h"

#include <string.h>

// Input rows [*lo, *hi] that output rows [a, b) read, clamped to the tensor.
static void in_rows(const geom_t *g, uint32_t stride, uint32_t a, uint32_t b, uint32_t *lo, uint32_t *hi)
{
    *lo = (a * stride > 0u) ? a * stride - 1u : 0u;
    const uint32_t last = (b - 1u) * stride + 1u;
    *hi = (last < g->hi) ? last : g->hi - 1u;
}

// Rows [lo, hi] lie in consecutive slots of ring r (no wrap).
static bool contiguous(const ring_t *r, uint32_t lo, uint32_t hi)
{
    return lo % r->rows + (hi - lo) < r->rows;
}

// Output rows [a, b) from the sub-plane of input rows [lo, ..] at `plane` (rows of wi * ci bytes).
static void run_cmsis(const vd_cnn_layer_t *L, const geom_t *g, const vd_cnn_cmsis_q_t *q, const int8_t *plane,
                      uint32_t lo, uint32_t hi, const ring_t *out, uint32_t a, uint32_t b)
{
    const int32_t stride = L->stride;
    const cmsis_nn_context ctx = {NULL, 0};
    cmsis_nn_dw_conv_params dp;
    dp.input_offset = -g->zp_in;
    dp.output_offset = L->out_zp;
    dp.ch_mult = 1;
    dp.stride.w = stride;
    dp.stride.h = stride;
    dp.padding.w = 1;
    dp.padding.h = (a == 0u) ? 1 : 0;   // the tensor's row -1 (a run from a > 0 starts at a real row)
    dp.dilation.w = 1;
    dp.dilation.h = 1;
    dp.activation.min = L->act_min;
    dp.activation.max = L->act_max;
    const cmsis_nn_per_channel_quant_params qp = {q->mult, q->shift};
    const cmsis_nn_dims in_d = {1, (int32_t)(hi - lo + 1u), (int32_t)g->wi, (int32_t)g->ci};
    const cmsis_nn_dims f_d = {1, 3, 3, (int32_t)g->co};
    const cmsis_nn_dims b_d = {1, 1, 1, (int32_t)g->co};
    const cmsis_nn_dims out_d = {1, (int32_t)(b - a), (int32_t)g->wo, (int32_t)g->co};
    (void)arm_depthwise_conv_3x3_s8(&ctx, &dp, &qp, &in_d, plane, &f_d, L->w, &b_d, q->bias, &out_d,
                                    vd_cnn_ring_row(out, a));
}

bool vd_cnn_dw3x3_rows_cmsis(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                             uint32_t y0, uint32_t y1, uint8_t *scr, uint32_t scr_bytes)
{
    scratch_layout_t s;
    (void)vd_cnn_dw3x3_scratch(L, &s);
    vd_cnn_cmsis_q_t q;
    if (!vd_cnn_cmsis_q_fill(L, scr + s.ch, &q)) {
        return false;
    }
    // Room for three input rows behind the arrays (streamed: the shared scratch may be larger).
    const uint32_t copy_at = s.ch + vd_cnn_cmsis_q_bytes(L);
    const size_t row_bytes = (size_t)g->wi * g->ci;
    const bool can_copy = scr_bytes >= copy_at && scr_bytes - copy_at >= 3u * row_bytes;
    const uint32_t stride = L->stride;
    for (uint32_t a = y0; a < y1;) {
        uint32_t lo, hi;
        // The longest run from a: output rows in consecutive slots, input rows too.
        uint32_t b = a + 1u;
        in_rows(g, stride, a, b, &lo, &hi);
        const bool direct = contiguous(in, lo, hi);
        while (direct && b < y1 && (b % out->rows) != 0u) {
            uint32_t lo2, hi2;
            in_rows(g, stride, a, b + 1u, &lo2, &hi2);
            if (!contiguous(in, lo2, hi2)) {
                break;
            }
            b++;
            hi = hi2;
        }
        if (direct) {
            run_cmsis(L, g, &q, vd_cnn_ring_row(in, lo), lo, hi, out, a, b);
        } else if (can_copy) {
            int8_t *plane = (int8_t *)(void *)(scr + copy_at);
            for (uint32_t r = lo; r <= hi; r++) {
                memcpy(plane + (size_t)(r - lo) * row_bytes, vd_cnn_ring_row(in, r), row_bytes);
            }
            run_cmsis(L, g, &q, plane, lo, hi, out, a, b);
        } else {
            // The portable kernel refills the scratch with its own layout: the arrays again after it.
            vd_cnn_dw3x3_rows(L, g, in, out, a, b, scr);
            (void)vd_cnn_cmsis_q_fill(L, scr + s.ch, &q);
        }
        a = b;
    }
    return true;
}
