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

#if defined(VD_CNN_DSP)
// The DSP kernel (cmsis.h): one output pixel, four channels per step, the nine taps as four pairs (k,
// k + 1) and tap 8. Per pair: the two taps' input words x = (a0 a1 a2 a3), x' = (b0 b1 b2 b3), PKHBT
// (a0 a1 b0 b1) and PKHTB (a2 a3 b2 b3), whose SXTB16 and SXTB16 ROR 8 are the 16-bit pairs (a_c, b_c)
// of channels 0..3, each one SMLAD with the channel's weight pair (w_k, w_k+1); tap 8 SXTB16 (channels
// 0, 2), ROR 8 (1, 3) and SMLABB / SMLATT. wx per group of four channels: for pair p four words (channel
// c: w[2p][c] | w[2p + 1][c] << 16), then tap 8's (w0 | w2 << 16), (w1 | w3 << 16): 18 words. The sums
// start at 0 (the bias and - zp_in sum w are in the requantisation constants: padding taps read zrow,
// zp_in bytes, and add zero).
static inline uint32_t dsp_ld(const int8_t *p)
{
    uint32_t x;
    memcpy(&x, p, 4u);
    return x;
}

static inline void dsp_store(const int32_t a[4], const vd_cnn_dsp_q_t *q, size_t c, int8_t *o, bool relu)
{
    if (relu) {
        vd_cnn_dsp_out4_relu(a[0], a[1], a[2], a[3], q->ch + c, o + c);
        return;
    }
    for (size_t i = 0u; i < 4u; i++) {
        o[c + i] = vd_cnn_dsp_out(a[i], &q->ch[c + i], q->thr[c + i], relu);
    }
}

// Channels beyond a multiple of four: the plain sums.
static inline void dsp_rest(const int8_t *const t[9], const int8_t *w, const vd_cnn_dsp_q_t *q, size_t c, size_t cn,
                            int8_t *o, bool relu)
{
    for (; c < cn; c++) {
        int32_t a = 0;
        for (size_t k = 0u; k < 9u; k++) {
            a += (int32_t)t[k][c] * (int32_t)w[k * cn + c];
        }
        o[c] = vd_cnn_dsp_out(a, &q->ch[c], relu ? 0 : q->thr[c], relu);
    }
}

// A pixel from its nine tap pointers (padding columns or rows: zrow), in C.
static inline void dsp_pixel(const int8_t *const t[9], const uint32_t *wx, const int8_t *w, const vd_cnn_dsp_q_t *q,
                             size_t cn, int8_t *o, bool relu)
{
    size_t c = 0u;
    for (; c + 4u <= cn; c += 4u, wx += 18) {
        uint32_t a[4] = {0u, 0u, 0u, 0u};
        for (size_t p = 0u; p < 4u; p++) {
            const uint32_t x = dsp_ld(t[2u * p] + c), x2 = dsp_ld(t[2u * p + 1u] + c);
            const uint32_t lo = (x & 0xFFFFu) | (x2 << 16), hi = (x2 & 0xFFFF0000u) | (x >> 16);
            const uint32_t *wp = wx + 4u * p;
            a[0] = SMLAD(SXTB16(lo), wp[0], a[0]);
            a[1] = SMLAD(SXTB16_RORn(lo, 8u), wp[1], a[1]);
            a[2] = SMLAD(SXTB16(hi), wp[2], a[2]);
            a[3] = SMLAD(SXTB16_RORn(hi, 8u), wp[3], a[3]);
        }
        const uint32_t x = dsp_ld(t[8] + c);
        const int32_t x02 = (int32_t)SXTB16(x), x13 = (int32_t)SXTB16_RORn(x, 8u);
        const int32_t s[4] = {__smlabb(x02, (int32_t)wx[16], (int32_t)a[0]),
                              __smlabb(x13, (int32_t)wx[17], (int32_t)a[1]),
                              __smlatt(x02, (int32_t)wx[16], (int32_t)a[2]),
                              __smlatt(x13, (int32_t)wx[17], (int32_t)a[3])};
        dsp_store(s, q, c, o, relu);
    }
    dsp_rest(t, w, q, c, cn, o, relu);
}

// Group c (four channels) of n consecutive pixels whose nine taps are all inside: row pointers r0..r2
// at the first pixel's left tap column (+ c), the columns cn bytes apart (the third one by LDR's
// register offset shifted left by 1), the pixels adv bytes apart; wg the group's weights. The taps in
// assembly (14 instructions per pair of taps; in C gcc 12 keeps the tap pointers on the stack: two
// more per tap). Group-major (a run of
// pixels per group) so that the per-pixel set-up is three pointer additions.
#define VD_DSP_PAIR(ld, mul)                                                                                    \
    ld "pkhbt %[y], %[x], %[z], lsl #16\n\t"                                                                  \
    "pkhtb %[z], %[z], %[x], asr #16\n\t"                                                                     \
    "ldrd %[w0], %[w1], [%[w]], #8\n\t"                                                                       \
    "sxtb16 %[x], %[y]\n\t"                                                                                   \
    "sxtb16 %[y], %[y], ror #8\n\t" mul("a0", "x", "w0") mul("a1", "y", "w1")                                 \
    "ldrd %[w0], %[w1], [%[w]], #8\n\t"                                                                       \
    "sxtb16 %[x], %[z]\n\t"                                                                                   \
    "sxtb16 %[y], %[z], ror #8\n\t" mul("a2", "x", "w0") mul("a3", "y", "w1")
#define VD_DSP_SMUAD(a, x, w) "smuad %[" a "], %[" x "], %[" w "]\n\t"
#define VD_DSP_SMLAD(a, x, w) "smlad %[" a "], %[" x "], %[" w "], %[" a "]\n\t"

// The nine taps of four channels: four tap pairs (VD_DSP_PAIR) and the ninth tap by SMLABB / SMLATT into
// the sums a0..a3. Shared by the pixel-at-a-time block and the ReLU run block below.
#define VD_DSP_TAPS                                                                                           \
    VD_DSP_PAIR("ldr %[x], [%[r0]]\n\tldr %[z], [%[r0], %[cn]]\n\t", VD_DSP_SMUAD)                            \
    VD_DSP_PAIR("ldr %[x], [%[r0], %[cn], lsl #1]\n\tldr %[z], [%[r1]]\n\t", VD_DSP_SMLAD)                    \
    VD_DSP_PAIR("ldr %[x], [%[r1], %[cn]]\n\tldr %[z], [%[r1], %[cn], lsl #1]\n\t", VD_DSP_SMLAD)             \
    VD_DSP_PAIR("ldr %[x], [%[r2]]\n\tldr %[z], [%[r2], %[cn]]\n\t", VD_DSP_SMLAD)                            \
    "ldr %[x], [%[r2], %[cn], lsl #1]\n\t"                                                                    \
    "ldrd %[w0], %[w1], [%[w]], #8\n\t"                                                                       \
    "sxtb16 %[y], %[x]\n\t"                                                                                   \
    "sxtb16 %[x], %[x], ror #8\n\t"                                                                           \
    "smlabb %[a0], %[y], %[w0], %[a0]\n\t"                                                                    \
    "smlatt %[a2], %[y], %[w0], %[a2]\n\t"                                                                    \
    "smlabb %[a1], %[x], %[w1], %[a1]\n\t"                                                                    \
    "smlatt %[a3], %[x], %[w1], %[a3]\n\t"

static inline void dsp_run_in(const int8_t *r0, const int8_t *r1, const int8_t *r2, size_t n, size_t adv,
                              const uint32_t *wg, const vd_cnn_dsp_q_t *q, size_t c, size_t cn, int8_t *o, bool relu)
{
    for (size_t i = 0u; i < n; i++, r0 += adv, r1 += adv, r2 += adv, o += cn) {
        const uint32_t *wx = wg;
        int32_t a0, a1, a2, a3;
        uint32_t x, y, z, w0, w1;
        __asm__(VD_DSP_TAPS
                : [a0] "=&r"(a0), [a1] "=&r"(a1), [a2] "=&r"(a2), [a3] "=&r"(a3), [x] "=&r"(x), [y] "=&r"(y),
                  [z] "=&r"(z), [w0] "=&r"(w0), [w1] "=&r"(w1), [w] "+r"(wx)
                : [r0] "r"(r0), [r1] "r"(r1), [r2] "r"(r2), [cn] "r"(cn)
                : "memory");
        const int32_t a[4] = {a0, a1, a2, a3};
        dsp_store(a, q, c, o, relu);
    }
}
// dsp_run_in of a ReLU layer with the pixel loop and the requantisation (cmsis.h's vd_cnn_dsp_out4_relu)
// in the same assembly block: the 14 registers hold the sums, the taps' temporaries and the row
// pointers, and the rest (weights, constants, output pointer, the row end) is read from the stack once
// per pixel instead of gcc's spills around the block (~25 instructions per pixel and group). n >= 1.
static inline void dsp_run_in_relu(const int8_t *r0, const int8_t *r1, const int8_t *r2, size_t n, size_t adv,
                                   const uint32_t *wg, const vd_cnn_dsp_ch_t *ch, size_t cn, int8_t *o)
{
    int32_t a0, a1, a2, a3;
    uint32_t x, y, z, w0, w1;
    const uint32_t *wx;
    const int8_t *r0e = r0 + n * adv;   // r0 after the last pixel
#define VD_DSP_RQ(a, i)                                                                                         \
    "ldrd %[y], %[z], [%[x]], #8\n\t"                                                                         \
    "ldrd %[w0], %[w1], [%[x]], #8\n\t"                                                                       \
    "smlal %[y], %[z], %[" a "], %[w0]\n\t"                                                                   \
    "asr %[z], %[z], %[w1]\n\t"                                                                               \
    "ssat %[z], #8, %[z]\n\t"                                                                                 \
    "strb %[z], [%[w], #" i "]\n\t"
    __asm__ __volatile__(
        "1:\n\t"
        "ldr %[w], %[wgm]\n\t"
        VD_DSP_TAPS
        "ldr %[x], %[chm]\n\t"
        "ldr %[w], %[om]\n\t"
        VD_DSP_RQ("a0", "0") VD_DSP_RQ("a1", "1") VD_DSP_RQ("a2", "2") VD_DSP_RQ("a3", "3")
        "add %[w], %[w], %[cn]\n\t"
        "str %[w], %[om]\n\t"
        "ldr %[x], %[advm]\n\t"
        "add %[r0], %[r0], %[x]\n\t"
        "add %[r1], %[r1], %[x]\n\t"
        "add %[r2], %[r2], %[x]\n\t"
        "ldr %[x], %[r0em]\n\t"
        "cmp %[r0], %[x]\n\t"
        "bne 1b"
        : [a0] "=&r"(a0), [a1] "=&r"(a1), [a2] "=&r"(a2), [a3] "=&r"(a3), [x] "=&r"(x), [y] "=&r"(y), [z] "=&r"(z),
          [w0] "=&r"(w0), [w1] "=&r"(w1), [w] "=&r"(wx), [r0] "+r"(r0), [r1] "+r"(r1), [r2] "+r"(r2), [om] "+m"(o)
        : [cn] "r"(cn), [wgm] "m"(wg), [chm] "m"(ch), [advm] "m"(adv), [r0em] "m"(r0e)
        : "cc", "memory");
#undef VD_DSP_RQ
}
#undef VD_DSP_SMLAD
#undef VD_DSP_SMUAD
#undef VD_DSP_PAIR

// Output rows [y0, y1) with the DSP kernel (the tap pointers of vd_cnn_dw3x3_taps, as dw3x3.c).
static inline void dsp_rows(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                            uint32_t y0, uint32_t y1, const uint32_t *wx, const int8_t *zrow, const vd_cnn_dsp_q_t *q,
                            bool relu)
{
    const size_t c_n = g->co;
    const int32_t step = L->stride;
    const bool fast = (c_n % 4u) == 0u;
    for (uint32_t oy = y0; oy < y1; oy++) {
        const int8_t *rowp[3];
        vd_cnn_dw3x3_rows(in, g->hi, oy, step, rowp);
        int8_t *orow = vd_cnn_ring_row(out, oy);
        const bool rows = fast && rowp[0] != NULL && rowp[1] != NULL && rowp[2] != NULL;
        // Interior pixels [xa, xb): all three columns inside (ix0 = ox step - 1 >= 0, ix0 + 2 < wi).
        const uint32_t xa = 1u;
        uint32_t xb = ((uint32_t)g->wi - 2u) / (uint32_t)step + 1u;
        xb = (xb < g->wo) ? xb : g->wo;
        if (rows && g->wi >= 3u && xb > xa) {
            const size_t at = ((size_t)xa * (size_t)step - 1u) * c_n;
            for (size_t c = 0u; c < c_n; c += 4u) {
                if (relu) {
                    dsp_run_in_relu(rowp[0] + at + c, rowp[1] + at + c, rowp[2] + at + c, xb - xa, (size_t)step * c_n,
                                    wx + (c / 4u) * 18u, q->ch + c, c_n, orow + (size_t)xa * c_n + c);
                    continue;
                }
                dsp_run_in(rowp[0] + at + c, rowp[1] + at + c, rowp[2] + at + c, xb - xa, (size_t)step * c_n,
                           wx + (c / 4u) * 18u, q, c, c_n, orow + (size_t)xa * c_n, relu);
            }
        } else {
            xb = 0u;   // every pixel below
        }
        for (uint32_t ox = 0u; ox < g->wo; ox++) {
            if (ox == xa && xb > xa) {
                ox = xb - 1u;
                continue;
            }
            const int8_t *t[9];
            vd_cnn_dw3x3_taps(rowp, ox, step, c_n, g->wi, zrow, t);
            dsp_pixel(t, wx, L->w, q, c_n, orow + (size_t)ox * c_n, relu);
        }
    }
}

// The DSP kernel's set-up: the zero-point row zrow, the widened weights wx and the requantisation
// constants at qa (vd__cnn_dsp_q_fill); false when the layer is outside its range (cmsis.h).
static bool dsp_prepare(const vd_cnn_layer_t *L, int32_t zp_in, uint32_t *wx, int8_t *zrow, uint8_t *qa,
                        vd_cnn_dsp_q_t *q)
{
    const size_t c_n = L->cout;
    for (size_t c = 0u; c < c_n; c++) {
        zrow[c] = (int8_t)zp_in;
    }
    // Widened weights per group of four channels, from words of four channels: taps x = w[2p][c..c+3],
    // y = w[2p+1][c..c+3] give the channels' pairs (x_c, y_c) as dsp_pixel_in gives the inputs' (PKHBT /
    // PKHTB, SXTB16); the weight sums for vd__cnn_dsp_q_fill on the way (SMLAD with (1, 1); tap 8's lanes
    // by hand).
    int32_t *sums = vd_cnn_dsp_q_sums(L, qa);
    for (size_t c = 0u; c + 4u <= c_n; c += 4u) {
        uint32_t *d = wx + (c / 4u) * 18u;
        const int8_t *w = L->w + c;
        uint32_t a[4] = {0u, 0u, 0u, 0u};   // |sum| <= 9 128
        for (size_t p = 0u; p < 4u; p++, d += 4) {   // (w[2p][c], w[2p + 1][c]) per channel c
            uint32_t x, y;
            memcpy(&x, w + 2u * p * c_n, 4u);
            memcpy(&y, w + (2u * p + 1u) * c_n, 4u);
            const uint32_t lo = (x & 0xFFFFu) | (y << 16), hi = (y & 0xFFFF0000u) | (x >> 16);
            d[0] = SXTB16(lo);
            d[1] = SXTB16_RORn(lo, 8u);
            d[2] = SXTB16(hi);
            d[3] = SXTB16_RORn(hi, 8u);
            for (size_t i = 0u; i < 4u; i++) {
                a[i] = SMLAD(d[i], 0x00010001u, a[i]);
            }
        }
        uint32_t x;   // tap 8: (w0, w2) is SXTB16 of the word w0..w3, (w1, w3) ROR 8
        memcpy(&x, w + 8u * c_n, 4u);
        d[0] = SXTB16(x);
        d[1] = SXTB16_RORn(x, 8u);
        sums[c] = (int32_t)a[0] + w[8u * c_n];
        sums[c + 1u] = (int32_t)a[1] + w[8u * c_n + 1u];
        sums[c + 2u] = (int32_t)a[2] + w[8u * c_n + 2u];
        sums[c + 3u] = (int32_t)a[3] + w[8u * c_n + 3u];
    }
    // (Channels beyond a multiple of four: the fill sums every channel itself.)
    return vd__cnn_dsp_q_fill(L, zp_in, qa, (c_n % 4u) == 0u, q);
}

// The DSP kernel: its set-up in the layer's prepared area when there is one (cmsis.h's layout; made
// when y0 == 0, read back by the later calls: cnn_internal.h), else in the scratch on every call
// (streamed calls are one output row): the widened weights in dw3x3.c's int16 weight piece (18 bytes per
// channel either way), zrow in its row piece, the constants in its constants piece. False when the
// layer is outside the DSP requantisation's range (cmsis.h).
static bool dsp_layer(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0,
                      uint32_t y1, uint8_t *scr, uint8_t *prep)
{
    scratch_layout_t s;
    (void)vd__cnn_dw3x3_scratch(L, &s);
    uint32_t *wx = (uint32_t *)(void *)((prep != NULL) ? prep : scr + s.w16);
    int8_t *zrow = (int8_t *)(void *)((prep != NULL) ? prep + vd_cnn_prep_dw_zrow(L) : scr + s.rows);
    uint8_t *qa = (prep != NULL) ? prep + vd_cnn_prep_w_bytes(L) : scr + s.ch;
    vd_cnn_dsp_q_t q;
    if (prep != NULL && y0 > 0u) {
        vd_cnn_dsp_q_view(L, qa, &q);   // made by the layer's call with y0 == 0
    } else if (!dsp_prepare(L, g->zp_in, wx, zrow, qa, &q)) {
        return false;
    }
    if (q.relu) {
        dsp_rows(L, g, in, out, y0, y1, wx, zrow, &q, true);
    } else {
        dsp_rows(L, g, in, out, y0, y1, wx, zrow, &q, false);
    }
    return true;
}
#endif

bool vd__cnn_dw3x3_rows_cmsis(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                             uint32_t y0, uint32_t y1, uint8_t *scr, uint32_t scr_bytes, uint8_t *prep)
{
#if defined(VD_CNN_DSP)
    if (dsp_layer(L, g, in, out, y0, y1, scr, prep)) {
        return true;
    }
#else
    (void)prep;   // no DSP kernels: no prepared area (vd__cnn_cmsis_prep_bytes)
#endif
    scratch_layout_t s;
    (void)vd__cnn_dw3x3_scratch(L, &s);
    vd_cnn_cmsis_q_t q;
    if (!vd__cnn_cmsis_q_fill(L, scr + s.ch, &q)) {
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
            vd__cnn_dw3x3_rows(L, g, in, out, a, b, scr);
            (void)vd__cnn_cmsis_q_fill(L, scr + s.ch, &q);
        }
        a = b;
    }
    return true;
}
