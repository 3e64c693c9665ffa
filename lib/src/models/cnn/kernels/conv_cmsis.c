// SPDX-License-Identifier: MIT
// CNN kernel CONV3X3 / CONV5X5 / PW1X1 on CMSIS-NN (Cortex-M): conv.c's layers through CMSIS-NN's int8
// GEMM, in conv.c's scratch, with conv.c's bytes.
//
// Algorithm: arm_nn_mat_mult_nt_t_s8 is the GEMM under CMSIS-NN's convolutions (arm_convolve_1x1_s8_fast
// as gcc builds it, arm_convolve_s8 on MVE cores): lhs rows of K int8 values against the weights
// [cout][K], read in place from the model (CMSIS-NN's filter layout [C_OUT, HK, WK, C_IN] is vd's), as
// bias + input_offset * sum w + sum w x, then arm_nn_requantize, the output offset and the clamp. With
// the DSP extension: SXTB16 and SMLAD (two 16-bit products per instruction), 2 pixels x 2 channels x 4 K
// per step. Pointwise layers hand it their input rows in place (one call per run of rows contiguous in
// both rings; a whole plane is one run). 3x3 and 5x5 layers gather each output pixel's taps as an int8
// row [ky][kx][c] (a row of the tap window is one contiguous span of its input row; padding taps are
// zp_in, which the input offset makes a zero term) into the scratch, as many pixels as conv.c's int16
// weights and rows would take (>= 34, <= one output row), and call the GEMM per block: arm_convolve_s8's
// im2col, but from ring-row pointers, so streamed row bands need no contiguous input rows.
// Reference: conv.c (tests/unit/test_cnn.c compares every tensor with it); CMSIS-NN's arm_convolve_s8.
// Bounds: K cout multiply-adds per output pixel; per GEMM call K cout additions (CMSIS-NN's weight sums
// for the offset term); 3 cout words of requantisation arrays per kernel call.
#include "models/cnn/kernels/cmsis.h"

#include <string.h>

// Copies n bytes (a tap span: ks * cin, often < 16) without a call for the short ones.
static inline void span_copy(int8_t *d, const int8_t *s, size_t n)
{
    if (n >= 32u) {
        memcpy(d, s, n);
        return;
    }
    for (size_t i = 0u; i < n; i++) {
        d[i] = s[i];
    }
}

static inline void span_fill(int8_t *d, int8_t v, size_t n)
{
    for (size_t i = 0u; i < n; i++) {
        d[i] = v;
    }
}

// The int8 tap rows of npix output pixels from x0 of an output row whose ks input rows are rowp (NULL:
// padding row): per pixel K = ks * ks * ci values in the weights' order [ky][kx][c], padding taps zp.
static void gather(const geom_t *g, const int8_t *const rowp[5], int32_t ks, int32_t step, uint32_t x0,
                   uint32_t npix, int8_t *patch)
{
    const size_t ci = g->ci;
    const size_t span = (size_t)ks * ci;   // one row of the tap window
    const int8_t zp = (int8_t)g->zp_in;
    const int32_t pad = ks / 2;
    for (uint32_t i = 0u; i < npix; i++) {
        const int32_t ix0 = (int32_t)(x0 + i) * step - pad;
        const bool inside = ix0 >= 0 && ix0 + ks <= (int32_t)g->wi;
        for (int32_t ky = 0; ky < ks; ky++, patch += span) {
            const int8_t *r = rowp[ky];
            if (r == NULL) {
                span_fill(patch, zp, span);
            } else if (inside) {
                span_copy(patch, r + (size_t)ix0 * ci, span);
            } else {
                for (int32_t kx = 0; kx < ks; kx++) {
                    const int32_t ix = ix0 + kx;
                    int8_t *d = patch + (size_t)kx * ci;
                    if (ix < 0 || ix >= (int32_t)g->wi) {
                        span_fill(d, zp, ci);
                    } else {
                        span_copy(d, r + (size_t)ix * ci, ci);
                    }
                }
            }
        }
    }
}

// Rows y .. of both rings that are contiguous in each (no ring wrap), at most up to y1.
static uint32_t run_end(const ring_t *a, const ring_t *b, uint32_t y, uint32_t y1)
{
    const uint32_t ea = y + (a->rows - y % a->rows);
    const uint32_t eb = y + (b->rows - y % b->rows);
    const uint32_t e = (ea < eb) ? ea : eb;
    return (e < y1) ? e : y1;
}

bool vd_cnn_conv_rows_cmsis(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                            uint32_t y0, uint32_t y1, bool stream, uint8_t *scr)
{
    scratch_layout_t s;
    (void)vd_cnn_conv_scratch(L, stream, &s);   // conv.c's layout: the patches take its weights and rows
    vd_cnn_cmsis_q_t q;
    if (!vd_cnn_cmsis_q_fill(L, scr + s.ch, &q)) {
        return false;
    }
    const int32_t k = (int32_t)vd_cnn_k_of(L);
    const int32_t co = (int32_t)g->co;
    const int32_t in_off = -g->zp_in;
    if (L->op == VD_CNN_OP_PW1X1) {   // stride 1 (loader.c): output pixel i reads input pixel i
        for (uint32_t y = y0; y < y1;) {
            const uint32_t e = run_end(in, out, y, y1);
            (void)arm_nn_mat_mult_nt_t_s8(vd_cnn_ring_row(in, y), L->w, q.bias, vd_cnn_ring_row(out, y), q.mult,
                                          q.shift, (int32_t)(g->wo * (e - y)), co, k, in_off, L->out_zp,
                                          L->act_min, L->act_max, co, k);
            y = e;
        }
        return true;
    }
    const int32_t ks = (L->op == VD_CNN_OP_CONV5X5) ? 5 : 3;
    const int32_t step = L->stride;
    uint32_t nb = s.ch / (uint32_t)k;   // pixels per GEMM call
    nb = (nb < g->wo) ? nb : g->wo;
    int8_t *patch = (int8_t *)(void *)scr;
    for (uint32_t oy = y0; oy < y1; oy++) {
        const int8_t *rowp[5];
        vd_cnn_conv_row_ptrs(g, in, oy, step, ks, rowp);
        int8_t *orow = vd_cnn_ring_row(out, oy);
        for (uint32_t x0 = 0u; x0 < g->wo; x0 += nb) {
            const uint32_t n = (g->wo - x0 < nb) ? g->wo - x0 : nb;
            gather(g, rowp, ks, step, x0, n, patch);
            (void)arm_nn_mat_mult_nt_t_s8(patch, L->w, q.bias, orow + (size_t)x0 * g->co, q.mult, q.shift,
                                          (int32_t)n, co, k, in_off, L->out_zp, L->act_min, L->act_max, co, k);
        }
    }
    return true;
}
