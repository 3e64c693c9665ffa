// SPDX-License-Identifier: MIT
// CNN kernel CONV3X3 / CONV5X5 / PW1X1 (portable C): one im2col GEMM for the three full convolutions, and
// its scratch query.
//
// Algorithm (plain C99 written for gcc/clang auto-vectorisation; HWC, so the innermost loops run over
// contiguous channels): blocks of 16 output pixels as int16 rows (x - zp_in), zero-padded to a multiple
// of 8 (for CONV3X3/5X5 the 3x3/5x5 taps gathered, padding taps 0), dotted with an int16 copy of the
// weights [cout][Kp]: four int32 reductions at a time over fixed 8-wide chunks (pmaddwd), then one
// requantisation loop per output channel over the 16 values with the channel's constants
// loop-invariant (vectorised: pmuludq, psrlq). Output channels in chunks of chunk_of (one chunk unless
// streamed, where one scratch serves every layer). The x86 back end (conv_x86.c) takes the same scratch
// and gives the same bytes.
// Reference: TFLite/CMSIS-NN int8 convolution; out = clamp(zp_out + requantize(bias + sum w (x -
// zp_in)), act_min, act_max), docs/fixed-point.md ("cnn").
// Bounds: K * cout multiply-adds and cout requantisations per output pixel (K = 9 cin, 25 cin or cin);
// the weight copy once per chunk and call. Accumulators fit int32 by the loader's bias bound (loader.c).
// Stack: two 16-value arrays per output channel block.
#include "models/cnn/cnn_internal.h"

#include <string.h>

// Output channels whose int16 weights a CONV / PW scratch holds at once:
// all of them, or at most VD_CNN_STREAM_COUT when streamed (one scratch
// serves every layer, so the largest layer's weight copy would set it).
static uint32_t chunk_of(const vd_cnn_layer_t *L, bool stream)
{
    return (stream && L->cout > VD_CNN_STREAM_COUT) ? VD_CNN_STREAM_COUT : L->cout;
}

uint64_t vd__cnn_conv_scratch(const vd_cnn_layer_t *L, bool stream, scratch_layout_t *s)
{
    const uint32_t kp = vd_cnn_round_up(vd_cnn_k_of(L), VD_CNN_KCHUNK);
    return vd__cnn_scratch_pack(L, 2u * chunk_of(L, stream) * kp, 2u * VD_CNN_NPIX * kp, s);
}

// VD_CNN_NPIX values of one channel. With the channel's constants in locals
// the loop vectorises (gcc, SSE2: pmuludq, psrlq): requantisation would
// otherwise cost as much as the multiply-adds.
VD_CNN_NOINLINE static void rq_row(const int32_t *acc, const vd_rq_ch_t *c, const rq_t *q, int8_t *z8)
{
    const int32_t zp = q->zp, lo = q->lo, hi = q->hi;
    if (q->general) {
        for (size_t p = 0u; p < VD_CNN_NPIX; p++) {
            z8[p] = vd_cnn_rq_out(vd_rq_apply(acc[p], c), zp, lo, hi);
        }
        return;
    }
    const uint64_t k = c->k;
    const uint32_t mult = c->mult, dk = c->dk, rsh = c->rsh, off = c->off, bias = (uint32_t)c->bias;
    const int32_t thr = c->thr;
    if (q->relu) {
        // lo >= 0 (act_min >= zp, every ReLU layer): vd_rq_z_nn, the form
        // without the sign term, gives the same clamped output (proof at
        // vd_rq_z_nn). Two loops: gcc vectorises both (pmuludq, psrlq).
        int32_t t[VD_CNN_NPIX];
        for (size_t p = 0u; p < VD_CNN_NPIX; p++) {
            t[p] = vd_rq_z_nn(bias + (uint32_t)acc[p], k, mult, rsh, off);
        }
        for (size_t p = 0u; p < VD_CNN_NPIX; p++) {
            z8[p] = vd_cnn_rq_out(t[p], zp, lo, hi);
        }
        return;
    }
    for (size_t p = 0u; p < VD_CNN_NPIX; p++) {
        const int32_t x = vd_rq_u32_to_i32(bias + (uint32_t)acc[p]);
        z8[p] = vd_cnn_rq_out(vd_rq_z(x, k, mult, dk, thr, rsh, off), zp, lo, hi);
    }
}

// CONV3X3 / PW1X1 core: VD_CNN_NPIX int16 rows of kp values (kp a multiple
// of VD_CNN_KCHUNK) against the int16 weights [cout][kp]. Per output
// channel, passes of four int32 dot products over fixed 8-wide chunks
// (pmaddwd), then one requantisation loop over the block (rq_row); writes
// npix (1..VD_CNN_NPIX) output pixels of cout channels (constants ch) at
// out, pstride bytes apart. Only the
// groups of four that hold a stored pixel are computed (a short block at the
// end of a row costs its own pixels, not 16). Indices are size_t and
// accumulators local: an int8 store may alias anything.
VD_CNN_NOINLINE static void gemm_block(const int16_t *rows, size_t kp, const int16_t *w16, const vd_rq_ch_t *ch,
                                       const rq_t *q, size_t cout, size_t pstride, int8_t *out, uint32_t npix)
{
    const size_t np4 = ((size_t)npix + 3u) / 4u * 4u;
    for (size_t o = 0u; o < cout; o++) {
        const int16_t *wo = w16 + o * kp;
        int32_t acc[VD_CNN_NPIX];
        for (size_t p = 0u; p < np4; p += 4u) {
            const int16_t *r0 = rows + p * kp;
            const int16_t *r1 = r0 + kp;
            const int16_t *r2 = r1 + kp;
            const int16_t *r3 = r2 + kp;
            int32_t a0 = 0, a1 = 0, a2 = 0, a3 = 0;
            for (size_t k = 0u; k < kp; k += VD_CNN_KCHUNK) {
                for (size_t j = 0u; j < VD_CNN_KCHUNK; j++) {
                    const int32_t wv = wo[k + j];
                    a0 += wv * r0[k + j];
                    a1 += wv * r1[k + j];
                    a2 += wv * r2[k + j];
                    a3 += wv * r3[k + j];
                }
            }
            acc[p] = a0;
            acc[p + 1u] = a1;
            acc[p + 2u] = a2;
            acc[p + 3u] = a3;
        }
        for (size_t p = np4; p < VD_CNN_NPIX; p++) {
            acc[p] = 0;   // not stored; defined for rq_row's fixed-length loop
        }
        int8_t z8[VD_CNN_NPIX];
        rq_row(acc, &ch[o], q, z8);
        int8_t *d = out + o;
        for (size_t p = 0u; p < npix; p++) {
            d[p * pstride] = z8[p];
        }
    }
}

// The ks input rows of output row oy (NULL: padding row).
static inline void conv_row_ptrs(const geom_t *g, const ring_t *in, uint32_t oy, int32_t step, int32_t ks,
                                 const int8_t *rowp[5])
{
    for (int32_t ky = 0; ky < ks; ky++) {
        const int32_t iy = (int32_t)oy * step - ks / 2 + ky;
        rowp[ky] = (iy >= 0 && iy < (int32_t)g->hi) ? vd_cnn_ring_row(in, (uint32_t)iy) : NULL;
    }
}

// The int16 GEMM rows of npix output pixels from x0 (portable and AVX2
// paths): x - zp_in per tap in the weight order [ky][kx][c], padding taps 0
// (the K..kp tails stay as the caller zeroed them). rowp: the ks input rows
// of the output row (NULL: padding row).
static inline void conv_gather(const geom_t *g, const int8_t *const rowp[5], int32_t ks, int32_t step, uint32_t x0,
                               uint32_t npix, size_t kp, int16_t *rows)
{
    const size_t ci = g->ci;
    const int16_t zp = (int16_t)g->zp_in;
    const int32_t pad = ks / 2;
    for (uint32_t i = 0u; i < npix; i++) {
        int16_t *r = rows + (size_t)i * kp;
        const int32_t ox = (int32_t)(x0 + i);
        if (ks == 1) {      // pointwise: one tap, never padding
            const int8_t *x = rowp[0] + (size_t)ox * ci;
            for (size_t c = 0u; c < ci; c++) {
                r[c] = (int16_t)(x[c] - zp);
            }
            continue;
        }
        for (int32_t ky = 0; ky < ks; ky++) {
            for (int32_t kx = 0; kx < ks; kx++) {
                const int32_t ix = ox * step - pad + kx;
                int16_t *d = r + (size_t)(ky * ks + kx) * ci;
                if (rowp[ky] == NULL || ix < 0 || ix >= (int32_t)g->wi) {
                    for (size_t c = 0u; c < ci; c++) {
                        d[c] = 0;
                    }
                } else {
                    const int8_t *x = rowp[ky] + (size_t)ix * ci;
                    for (size_t c = 0u; c < ci; c++) {
                        d[c] = (int16_t)(x[c] - zp);
                    }
                }
            }
        }
    }
}

// The two helpers above for the AVX2 back end (conv_x86.c), whose GEMM reads the
// same int16 rows; static inline above, so this file's loop compiles as if alone.
void vd__cnn_conv_row_ptrs(const geom_t *g, const ring_t *in, uint32_t oy, int32_t step, int32_t ks,
                          const int8_t *rowp[5])
{
    conv_row_ptrs(g, in, oy, step, ks, rowp);
}

void vd__cnn_conv_gather(const geom_t *g, const int8_t *const rowp[5], int32_t ks, int32_t step, uint32_t x0,
                        uint32_t npix, size_t kp, int16_t *rows)
{
    conv_gather(g, rowp, ks, step, x0, npix, kp, rows);
}

// Output rows [y0, y1) of a CONV3X3 / CONV5X5 / PW1X1 layer; the input rows
// they read (y * stride - pad .. + pad, clamped) must be in the input ring.
// Output channels in chunks of chunk_of(L, stream) (one chunk unless
// streamed): per chunk the int16 weights, then every pixel block.
void vd__cnn_conv_rows(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                      uint32_t y0, uint32_t y1, bool stream, uint8_t *scr)
{
    scratch_layout_t s;
    (void)vd__cnn_conv_scratch(L, stream, &s);
    const rq_t q = vd__cnn_rq_setup(L, scr, &s);
    const size_t k = vd_cnn_k_of(L);
    const size_t kp = vd_cnn_round_up((uint32_t)k, VD_CNN_KCHUNK);
    int16_t *w16 = (int16_t *)(void *)(scr + s.w16);
    int16_t *rows = (int16_t *)(void *)(scr + s.rows);
    // Zero once: the K..kp tails stay zero, and rows of a short last block
    // hold finite values whose results are not stored.
    memset(rows, 0, (size_t)VD_CNN_NPIX * kp * sizeof(int16_t));
    const int32_t step = L->stride;
    const bool pw = L->op == VD_CNN_OP_PW1X1;
    const int32_t ks = pw ? 1 : ((L->op == VD_CNN_OP_CONV5X5) ? 5 : 3);   // kernel side
    const size_t chunk = chunk_of(L, stream);
    for (size_t o0 = 0u; o0 < g->co; o0 += chunk) {
        const size_t n_o = (g->co - o0 < chunk) ? g->co - o0 : chunk;
        for (size_t o = 0u; o < n_o; o++) {
            const int8_t *src = L->w + (o0 + o) * k;
            int16_t *dst = w16 + o * kp;
            for (size_t i = 0u; i < k; i++) {
                dst[i] = src[i];
            }
            for (size_t i = k; i < kp; i++) {
                dst[i] = 0;
            }
        }
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rowp[5];
            conv_row_ptrs(g, in, oy, step, ks, rowp);
            int8_t *orow = vd_cnn_ring_row(out, oy) + o0;
            for (uint32_t x0 = 0u; x0 < g->wo; x0 += VD_CNN_NPIX) {
                const uint32_t npix = (g->wo - x0 < VD_CNN_NPIX) ? g->wo - x0 : VD_CNN_NPIX;
                conv_gather(g, rowp, ks, step, x0, npix, kp, rows);
                gemm_block(rows, kp, w16, q.ch + o0, &q, n_o, g->co, orow + (size_t)x0 * g->co, npix);
            }
        }
    }
}
