// SPDX-License-Identifier: MIT
// CNN kernel DW3X3 (portable C): depthwise 3x3 convolution, padding 1, stride 1 or 2, and its scratch query.
//
// Algorithm: per output pixel, 9 tap pointers (a padding tap points at a row filled with zp_in), 16
// channels per pass with the 9 products written out; |w x| <= 128 * 128 fits int16, so x - zp_in is
// hoisted into the bias (bias - zp_in sum w) and products are 16-bit multiplies; without a weight of
// -128 two products still fit int16 and are added before widening. The x86 back end (dw3x3_x86.c)
// takes the same scratch and gives the same bytes.
// Reference: TFLite/CMSIS-NN int8 depthwise convolution (depth multiplier 1), docs/fixed-point.md ("cnn").
// Bounds: 9 multiply-adds and one requantisation per output value; the weight copy once per call.
// Stack: one pass of VD_CNN_DWB int32 sums.
#include "models/cnn/cnn_internal.h"

#include <string.h>

uint64_t vd__cnn_dw3x3_scratch(const vd_cnn_layer_t *L, scratch_layout_t *s)
{
    const uint32_t cp = vd_cnn_round_up(L->cout, VD_CNN_DWB);
    return vd__cnn_scratch_pack(L, 2u * 9u * cp, cp, s);
}

// Depthwise sums of n channels from c0 (16 or 8 at two call sites, so the
// loop has a constant trip count): one loop with the 9 products written
// out, as a loop over the taps would load a new base pointer per tap, which
// neither gcc nor clang vectorises. Products fit int16 (|w x| <= 128 * 128),
// so they are 16-bit multiplies. Without a weight of -128, |w x| <= 16256
// and two products still fit int16 (pairs): half the widenings to int32.
// acc is a local array of the caller, so no int8 store can alias it.
static inline void dw_sums(const int8_t *const t[9], const int16_t *w16, size_t cp, size_t c0, size_t n, bool pairs,
                           int32_t *acc)
{
    const int16_t *w0 = w16 + c0;
    const int16_t *w1 = w0 + cp, *w2 = w1 + cp, *w3 = w2 + cp, *w4 = w3 + cp;
    const int16_t *w5 = w4 + cp, *w6 = w5 + cp, *w7 = w6 + cp, *w8 = w7 + cp;
    const int8_t *x0 = t[0] + c0, *x1 = t[1] + c0, *x2 = t[2] + c0, *x3 = t[3] + c0, *x4 = t[4] + c0;
    const int8_t *x5 = t[5] + c0, *x6 = t[6] + c0, *x7 = t[7] + c0, *x8 = t[8] + c0;
    if (pairs) {
        for (size_t j = 0u; j < n; j++) {
            acc[j] = (int32_t)(int16_t)(w0[j] * x0[j] + w1[j] * x1[j]) + (int16_t)(w2[j] * x2[j] + w3[j] * x3[j]) +
                     (int16_t)(w4[j] * x4[j] + w5[j] * x5[j]) + (int16_t)(w6[j] * x6[j] + w7[j] * x7[j]) +
                     (int16_t)(w8[j] * x8[j]);
        }
        return;
    }
    for (size_t j = 0u; j < n; j++) {
        acc[j] = (int32_t)(int16_t)(w0[j] * x0[j]) + (int16_t)(w1[j] * x1[j]) + (int16_t)(w2[j] * x2[j]) +
                 (int16_t)(w3[j] * x3[j]) + (int16_t)(w4[j] * x4[j]) + (int16_t)(w5[j] * x5[j]) +
                 (int16_t)(w6[j] * x6[j]) + (int16_t)(w7[j] * x7[j]) + (int16_t)(w8[j] * x8[j]);
    }
}

static inline void dw_store(const int32_t *acc, size_t n, size_t c0, const rq_t *q, int8_t *o)
{
    const vd_rq_ch_t *ch = q->ch + c0;
    const int32_t zp = q->zp, lo = q->lo, hi = q->hi;
    int8_t *d = o + c0;
    if (q->general) {
        for (size_t j = 0u; j < n; j++) {
            d[j] = vd_cnn_rq_out(vd_rq_apply(acc[j], &ch[j]), zp, lo, hi);
        }
        return;
    }
    if (q->relu) {
        // lo >= 0: without the sign term, as conv.c's rq_row.
        for (size_t j = 0u; j < n; j++) {
            const vd_rq_ch_t *c = &ch[j];
            const int32_t z = vd_rq_z_nn((uint32_t)c->bias + (uint32_t)acc[j], c->k, c->mult, c->rsh, c->off);
            d[j] = vd_cnn_rq_out(z, zp, lo, hi);
        }
        return;
    }
    for (size_t j = 0u; j < n; j++) {
        const vd_rq_ch_t *c = &ch[j];
        const int32_t x = vd_rq_u32_to_i32((uint32_t)c->bias + (uint32_t)acc[j]);
        d[j] = vd_cnn_rq_out(vd_rq_z(x, c->k, c->mult, c->dk, c->thr, c->rsh, c->off), zp, lo, hi);
    }
}

// Output rows [y0, y1) of a DW3X3 layer (input rows y * stride - 1 .. + 1 in the ring).
void vd__cnn_dw3x3_rows(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0,
                       uint32_t y1, uint8_t *scr)
{
    scratch_layout_t s;
    (void)vd__cnn_dw3x3_scratch(L, &s);
    const rq_t q = vd__cnn_rq_setup(L, scr, &s);
    const size_t c_n = g->co;
    const size_t cp = vd_cnn_round_up((uint32_t)c_n, VD_CNN_DWB);
    int16_t *w16 = (int16_t *)(void *)(scr + s.w16);
    int8_t *zrow = (int8_t *)(void *)(scr + s.rows);
    vd_rq_ch_t *ch = (vd_rq_ch_t *)(void *)(scr + s.ch);
    bool pairs = true;
    for (size_t c = 0u; c < c_n; c++) {
        int32_t wsum = 0;
        for (size_t k = 0u; k < 9u; k++) {
            const int8_t wv = L->w[k * c_n + c];
            w16[k * cp + c] = wv;
            wsum += wv;
            pairs = pairs && wv != -128;
        }
        // bias - zp_in * sum w, modulo 2^32 like the accumulation.
        ch[c].bias = vd_rq_u32_to_i32((uint32_t)ch[c].bias - (uint32_t)(g->zp_in * wsum));
        zrow[c] = (int8_t)g->zp_in;
    }
    const int32_t step = L->stride;
    for (uint32_t oy = y0; oy < y1; oy++) {
        const int8_t *rowp[3];
        vd_cnn_dw3x3_rows(in, g->hi, oy, step, rowp);
        int8_t *orow = vd_cnn_ring_row(out, oy);
        for (uint32_t ox = 0u; ox < g->wo; ox++) {
            const int8_t *t[9];
            vd_cnn_dw3x3_taps(rowp, ox, step, c_n, g->wi, zrow, t);
            int8_t *o = orow + (size_t)ox * c_n;
            int32_t acc[VD_CNN_DWB];
            size_t c0 = 0u;
            for (; c0 + VD_CNN_DWB <= c_n; c0 += VD_CNN_DWB) {
                dw_sums(t, w16, cp, c0, VD_CNN_DWB, pairs, acc);
                dw_store(acc, VD_CNN_DWB, c0, &q, o);
            }
            if (c0 + VD_CNN_DWB / 2u <= c_n) {
                dw_sums(t, w16, cp, c0, VD_CNN_DWB / 2u, pairs, acc);
                dw_store(acc, VD_CNN_DWB / 2u, c0, &q, o);
                c0 += VD_CNN_DWB / 2u;
            }
            if (c0 < c_n) {
                dw_sums(t, w16, cp, c0, c_n - c0, pairs, acc);
                dw_store(acc, c_n - c0, c0, &q, o);
            }
        }
    }
}
