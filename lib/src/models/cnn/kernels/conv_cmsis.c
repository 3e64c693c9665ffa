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

#if defined(VD_CNN_DSP)
// The DSP kernel (cmsis.h) of pointwise layers (K = cin a multiple of 4) and 3x3 layers with one input
// channel. Pointwise: per output pixel its K input bytes widened once into xs, words j: SXTB16 of input
// word j/2 (values 0, 2 of it) for even j, SXTB16 ROR 8 (values 1, 3) for odd j; the weights widened
// once per call (or per run: dsp_layer) in the same pairs, per group of four output channels
// interleaved [k word pair][channel][2] (one LDRD per channel and pair), then per group SMLAD into four
// sums from 0 (the bias and - zp_in sum w are in the requantisation constants: padding taps read zp_in
// and add zero).
static inline uint64_t dsp_ld2(const uint32_t *p)
{
    uint64_t v;
    memcpy(&v, p, 8u);
    return v;
}

static inline uint32_t dsp_lo(uint64_t v)
{
    return (uint32_t)v;
}

static inline uint32_t dsp_hi(uint64_t v)
{
    return (uint32_t)(v >> 32);
}

static inline void dsp_px(const uint32_t *xs, const uint32_t *wq, size_t nw, const vd_cnn_dsp_q_t *q, size_t cn,
                          int8_t *o, bool relu)
{
    size_t c = 0u;
    const uint32_t *xe = xs + nw;
    for (; c + 4u <= cn; c += 4u) {
        uint32_t a0 = 0u, a1 = 0u, a2 = 0u, a3 = 0u;
        const uint32_t *x = xs;
        uint32_t xa, xb, w0, w1;
        // Per two words (four input values): LDRD of the input, four LDRD of the weights, eight SMLAD.
        // In assembly: gcc 12 loads all eight weight words first and spills them.
        __asm__("1:\n\t"
                "ldrd %[xa], %[xb], [%[x]], #8\n\t"
                "ldrd %[w0], %[w1], [%[w]], #8\n\t"
                "smlad %[a0], %[xa], %[w0], %[a0]\n\t"
                "smlad %[a0], %[xb], %[w1], %[a0]\n\t"
                "ldrd %[w0], %[w1], [%[w]], #8\n\t"
                "smlad %[a1], %[xa], %[w0], %[a1]\n\t"
                "smlad %[a1], %[xb], %[w1], %[a1]\n\t"
                "ldrd %[w0], %[w1], [%[w]], #8\n\t"
                "smlad %[a2], %[xa], %[w0], %[a2]\n\t"
                "smlad %[a2], %[xb], %[w1], %[a2]\n\t"
                "ldrd %[w0], %[w1], [%[w]], #8\n\t"
                "smlad %[a3], %[xa], %[w0], %[a3]\n\t"
                "smlad %[a3], %[xb], %[w1], %[a3]\n\t"
                "cmp %[x], %[xe]\n\t"
                "bne 1b"
                : [a0] "+r"(a0), [a1] "+r"(a1), [a2] "+r"(a2), [a3] "+r"(a3), [x] "+r"(x), [w] "+r"(wq),
                  [xa] "=&r"(xa), [xb] "=&r"(xb), [w0] "=&r"(w0), [w1] "=&r"(w1)
                : [xe] "r"(xe)
                : "cc", "memory");
        const vd_cnn_dsp_ch_t *ch = q->ch + c;
        if (relu) {
            vd_cnn_dsp_out4_relu((int32_t)a0, (int32_t)a1, (int32_t)a2, (int32_t)a3, ch, o + c);
            continue;
        }
        o[c] = vd_cnn_dsp_out((int32_t)a0, &ch[0], relu ? 0 : q->thr[c], relu);
        o[c + 1u] = vd_cnn_dsp_out((int32_t)a1, &ch[1], relu ? 0 : q->thr[c + 1u], relu);
        o[c + 2u] = vd_cnn_dsp_out((int32_t)a2, &ch[2], relu ? 0 : q->thr[c + 2u], relu);
        o[c + 3u] = vd_cnn_dsp_out((int32_t)a3, &ch[3], relu ? 0 : q->thr[c + 3u], relu);
    }
    for (; c < cn; c++) {   // channels beyond a multiple of four: [k word][2] each
        uint32_t a = 0u;
        for (size_t j = 0u; j < nw; j++, wq++) {
            a = SMLAD(xs[j], wq[0], a);
        }
        o[c] = vd_cnn_dsp_out((int32_t)a, &q->ch[c], relu ? 0 : q->thr[c], relu);
    }
}

static uint32_t dsp_pair(int32_t lo, int32_t hi)
{
    return (uint32_t)(uint16_t)(int16_t)lo | ((uint32_t)(uint16_t)(int16_t)hi << 16);
}

// One 3x3 tap row of a one-channel layer as a word: bytes ix0 .. ix0 + 3 of row r (NULL: padding),
// zp outside the row (the fourth byte's weight is 0).
static uint32_t dsp_tap_word(const int8_t *r, int32_t ix0, int32_t wi, int8_t zp)
{
    uint32_t x = 0u;
    if (r != NULL && ix0 >= 0 && ix0 + 4 <= wi) {
        memcpy(&x, r + ix0, 4u);
        return x;
    }
    for (int32_t i = 0; i < 4; i++) {
        const int32_t ix = ix0 + i;
        const int8_t v = (r != NULL && ix >= 0 && ix < wi) ? r[ix] : zp;
        x |= (uint32_t)(uint8_t)v << (8 * i);
    }
    return x;
}

// One-channel 3x3 layers: a pixel's three tap-row words t0..t2 (taps x0..x2 of a row and a fourth byte)
// widened in registers to five words of 16-bit pairs, nine taps and one zero weight: SXTB16 of each
// (x0, x2), and the x1 values of rows 0 and 1 packed into one word (PKHBT) beside row 2's (x1, x3); per
// channel five weight words [ (w00, w02) (w10, w12) (w20, w22) (w01, w11) (w21, 0) ] and a pad word,
// five SMLAD.
// One channel's sum: its five weight words (at *w, advanced by 6 words) against x0..x4. In assembly:
// gcc 12 keeps x0..x4 on the stack and reloads them per channel.
static inline int32_t dsp_one_dot(const uint32_t **w, uint32_t x0, uint32_t x1, uint32_t x2, uint32_t x3, uint32_t x4)
{
    int32_t a;
    uint32_t w0, w1;
    const uint32_t *p = *w;
    __asm__("ldrd %[w0], %[w1], [%[p]], #8\n\t"
            "smuad %[a], %[x0], %[w0]\n\t"
            "smlad %[a], %[x1], %[w1], %[a]\n\t"
            "ldrd %[w0], %[w1], [%[p]], #8\n\t"
            "smlad %[a], %[x2], %[w0], %[a]\n\t"
            "smlad %[a], %[x3], %[w1], %[a]\n\t"
            "ldr %[w0], [%[p]], #8\n\t"
            "smlad %[a], %[x4], %[w0], %[a]"
            : [a] "=&r"(a), [w0] "=&r"(w0), [w1] "=&r"(w1), [p] "+r"(p)
            : [x0] "r"(x0), [x1] "r"(x1), [x2] "r"(x2), [x3] "r"(x3), [x4] "r"(x4)
            : "memory");
    *w = p;
    return a;
}

// One output channel of a one-channel 3x3 layer (label 1: loops over the channels): five SMLAD over the
// widened taps x0..x4, then cmsis.h's vd_cnn_dsp_out4_relu requantisation and the store. Shared by the
// single-pixel block and the run block below.
#define VD_DSP_C1_CHANNEL                                                                                     \
    "1:\n\t"                                                                                                  \
    "ldrd %[w0], %[w1], [%[w]], #8\n\t"                                                                       \
    "smuad %[a], %[x0], %[w0]\n\t"                                                                            \
    "smlad %[a], %[x1], %[w1], %[a]\n\t"                                                                      \
    "ldrd %[w0], %[w1], [%[w]], #8\n\t"                                                                       \
    "smlad %[a], %[x2], %[w0], %[a]\n\t"                                                                      \
    "smlad %[a], %[x3], %[w1], %[a]\n\t"                                                                      \
    "ldr %[w0], [%[w]], #8\n\t"                                                                               \
    "smlad %[a], %[x4], %[w0], %[a]\n\t"                                                                      \
    "ldrd %[t0], %[t1], [%[ch]], #8\n\t"                                                                      \
    "ldrd %[w0], %[w1], [%[ch]], #8\n\t"                                                                      \
    "smlal %[t0], %[t1], %[a], %[w0]\n\t"                                                                     \
    "asr %[t1], %[t1], %[w1]\n\t"                                                                             \
    "ssat %[t1], #8, %[t1]\n\t"                                                                               \
    "strb %[t1], [%[o]], #1\n\t"

static inline void dsp_one_px(const uint32_t t[3], const uint32_t *wq, const vd_cnn_dsp_q_t *q, size_t cn, int8_t *o,
                              bool relu)
{
    const uint32_t x0 = SXTB16(t[0]), x1 = SXTB16(t[1]), x2 = SXTB16(t[2]);
    const uint32_t y0 = SXTB16_RORn(t[0], 8u), y1 = SXTB16_RORn(t[1], 8u);
    const uint32_t x3 = (y0 & 0xFFFFu) | (y1 << 16), x4 = SXTB16_RORn(t[2], 8u);
    const vd_cnn_dsp_ch_t *ch = q->ch;
    if (relu && cn > 0u) {
        // Every channel in one assembly block: five SMLAD, then the requantisation (cmsis.h's
        // vd_cnn_dsp_out4_relu) of the channel, x0..x4 kept in registers (13 in all; the end on the stack).
        const int8_t *oe = o + cn;
        int32_t a;
        uint32_t w0, w1, t0, t1;
        __asm__ __volatile__(VD_DSP_C1_CHANNEL
                             "ldr %[t0], %[oe]\n\t"
                             "cmp %[o], %[t0]\n\t"
                             "bne 1b"
                             : [a] "=&r"(a), [w0] "=&r"(w0), [w1] "=&r"(w1), [t0] "=&r"(t0), [t1] "=&r"(t1),
                               [w] "+r"(wq), [ch] "+r"(ch), [o] "+r"(o)
                             : [x0] "r"(x0), [x1] "r"(x1), [x2] "r"(x2), [x3] "r"(x3), [x4] "r"(x4), [oe] "m"(oe)
                             : "cc", "memory");
        return;
    }
    for (size_t c = 0u; c < cn; c++) {
        const int32_t a = dsp_one_dot(&wq, x0, x1, x2, x3, x4);
        o[c] = vd_cnn_dsp_out(a, &ch[c], relu ? 0 : q->thr[c], relu);
    }
}

// n >= 1 interior pixels of a ReLU one-channel 3x3 layer in one assembly block: per pixel the three
// tap-row words from the row pointers (on the stack, advanced by step), dsp_one_px's widening, then
// every channel as in dsp_one_px (13 registers; gcc's code around a block per pixel cost ~35
// instructions more per pixel).
static inline void dsp_one_run_relu(const int8_t *r0, const int8_t *r1, const int8_t *r2, size_t step, size_t n,
                                    const uint32_t *wq, const vd_cnn_dsp_ch_t *ch0, size_t cn, int8_t *o)
{
    const int8_t *oe = o;
    uint32_t x0, x1, x2, x3, x4, w0, w1, t0, t1;
    int32_t a;
    const uint32_t *w;
    const vd_cnn_dsp_ch_t *ch;
    __asm__ __volatile__("2:\n\t"
                         "ldr %[t0], %[r0m]\n\t"
                         "ldr %[t1], %[r1m]\n\t"
                         "ldr %[w0], %[r2m]\n\t"
                         "ldr %[x0], [%[t0]]\n\t"
                         "ldr %[x1], [%[t1]]\n\t"
                         "ldr %[x2], [%[w0]]\n\t"
                         "ldr %[w1], %[stepm]\n\t"
                         "add %[t0], %[t0], %[w1]\n\t"
                         "str %[t0], %[r0m]\n\t"
                         "add %[t1], %[t1], %[w1]\n\t"
                         "str %[t1], %[r1m]\n\t"
                         "add %[w0], %[w0], %[w1]\n\t"
                         "str %[w0], %[r2m]\n\t"
                         "sxtb16 %[t0], %[x0], ror #8\n\t"
                         "sxtb16 %[t1], %[x1], ror #8\n\t"
                         "pkhbt %[x3], %[t0], %[t1], lsl #16\n\t"
                         "sxtb16 %[x4], %[x2], ror #8\n\t"
                         "sxtb16 %[x0], %[x0]\n\t"
                         "sxtb16 %[x1], %[x1]\n\t"
                         "sxtb16 %[x2], %[x2]\n\t"
                         "ldr %[w], %[wqm]\n\t"
                         "ldr %[ch], %[chm]\n\t"
                         "ldr %[t0], %[cnm]\n\t"
                         "add %[t0], %[o], %[t0]\n\t"
                         "str %[t0], %[oem]\n\t"
                         VD_DSP_C1_CHANNEL
                         "ldr %[t0], %[oem]\n\t"
                         "cmp %[o], %[t0]\n\t"
                         "bne 1b\n\t"
                         "ldr %[t0], %[nm]\n\t"
                         "subs %[t0], %[t0], #1\n\t"
                         "str %[t0], %[nm]\n\t"
                         "bne 2b"
                         : [x0] "=&r"(x0), [x1] "=&r"(x1), [x2] "=&r"(x2), [x3] "=&r"(x3), [x4] "=&r"(x4),
                           [a] "=&r"(a), [w0] "=&r"(w0), [w1] "=&r"(w1), [t0] "=&r"(t0), [t1] "=&r"(t1), [w] "=&r"(w),
                           [ch] "=&r"(ch), [o] "+r"(o), [r0m] "+m"(r0), [r1m] "+m"(r1), [r2m] "+m"(r2), [nm] "+m"(n),
                           [oem] "+m"(oe)
                         : [stepm] "m"(step), [wqm] "m"(wq), [chm] "m"(ch0), [cnm] "m"(cn)
                         : "cc", "memory");
}

// Output rows [y0, y1) of a one-channel 3x3 layer (relu a constant at the call site).
static inline void dsp_one_rows(const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0, uint32_t y1,
                                int32_t step, const uint32_t *wq, const vd_cnn_dsp_q_t *q, bool relu)
{
    const int8_t zp = (int8_t)g->zp_in;
    const int32_t wi = (int32_t)g->wi;
    const size_t co = g->co;
    // Interior pixels [1, xb): ix0 = ox step - 1 >= 0 and the word's four bytes inside (ix0 + 4 <= wi).
    uint32_t xb = (wi >= 3) ? (uint32_t)(wi - 3) / (uint32_t)step + 1u : 0u;
    xb = (xb < g->wo) ? xb : g->wo;
    for (uint32_t oy = y0; oy < y1; oy++) {
        const int8_t *rowp[5];
        vd__cnn_conv_row_ptrs(g, in, oy, step, 3, rowp);
        const bool full = rowp[0] != NULL && rowp[1] != NULL && rowp[2] != NULL;
        int8_t *o = vd_cnn_ring_row(out, oy);
        for (uint32_t ox = 0u; ox < g->wo; ox++, o += co) {
            const int32_t ix0 = (int32_t)ox * step - 1;
            if (relu && full && ox == 1u && xb > 1u && co > 0u) {
                dsp_one_run_relu(rowp[0] + ix0, rowp[1] + ix0, rowp[2] + ix0, (size_t)step, xb - 1u, wq, q->ch, co, o);
                o += (size_t)(xb - 2u) * co;
                ox = xb - 1u;
                continue;
            }
            uint32_t t[3];
            if (full && ix0 >= 0 && ix0 + 4 <= wi) {
                memcpy(&t[0], rowp[0] + ix0, 4u);
                memcpy(&t[1], rowp[1] + ix0, 4u);
                memcpy(&t[2], rowp[2] + ix0, 4u);
            } else {
                for (size_t ky = 0u; ky < 3u; ky++) {
                    t[ky] = dsp_tap_word(rowp[ky], ix0, wi, zp);
                }
            }
            dsp_one_px(t, wq, q, co, o, relu);
        }
    }
}

// n >= 1 pixels of a ReLU pointwise layer with cout a multiple of 4, all in one assembly block: per pixel
// the widening into xs (LDR, two SXTB16, STRD per four input bytes), then per group of four channels
// dsp_px's loop (LDRD of the input, four LDRD of the weights, eight SMLAD per four input values) and
// the requantisation (cmsis.h's vd_cnn_dsp_out4_relu), the output pointer running on. Thirteen
// registers; the bases, the source pointer and the counters live on the stack (gcc's spills around a
// block per group cost ~10 instructions more per group). The first step of four values starts the
// sums (SMUAD), then eight values per iteration: with nw / 2 steps even one more single step first
// (dsp_pw_run_relu_e), odd none (_o): two functions, so that no group tests it.
// VD_DSP_PW / VD_DSP_PW0 (a step's multiply-adds of one sum) serve this block and dsp_pw_run_thr's.
#define VD_DSP_PW(a)                                                                                            \
    "ldrd %[w0], %[w1], [%[w]], #8\n\t"                                                                       \
    "smlad %[" a "], %[xa], %[w0], %[" a "]\n\t"                                                              \
    "smlad %[" a "], %[xb], %[w1], %[" a "]\n\t"
#define VD_DSP_PW0(a)                                                                                           \
    "ldrd %[w0], %[w1], [%[w]], #8\n\t"                                                                       \
    "smuad %[" a "], %[xa], %[w0]\n\t"                                                                        \
    "smlad %[" a "], %[xb], %[w1], %[" a "]\n\t"
#define VD_DSP_RQ(a)                                                                                            \
    "ldrd %[xa], %[xb], [%[ch]], #8\n\t"                                                                      \
    "ldrd %[w0], %[w1], [%[ch]], #8\n\t"                                                                      \
    "smlal %[xa], %[xb], %[" a "], %[w0]\n\t"                                                                 \
    "asr %[xb], %[xb], %[w1]\n\t"                                                                             \
    "ssat %[xb], #8, %[xb]\n\t"                                                                               \
    "strb %[xb], [%[o]], #1\n\t"
#define VD_DSP_PW_STEP                                                                                          \
    "ldrd %[xa], %[xb], [%[x]], #8\n\t" VD_DSP_PW("a0") VD_DSP_PW("a1") VD_DSP_PW("a2") VD_DSP_PW("a3")
#define VD_DSP_PW_RUN(name, extra)                                                                              \
    static inline void name(const int8_t *src, size_t n, size_t nw, uint32_t *xs, const uint32_t *wq,           \
                            const vd_cnn_dsp_ch_t *ch0, size_t groups, int8_t *o)                               \
    {                                                                                                           \
        const uint32_t *xe = xs + nw;                                                                           \
        const vd_cnn_dsp_ch_t *che = ch0 + 4u * groups;                                                         \
        int32_t a0, a1, a2, a3;                                                                                 \
        uint32_t xa, xb, w0, w1, *x;                                                                            \
        const uint32_t *w;                                                                                      \
        const vd_cnn_dsp_ch_t *ch;                                                                              \
        __asm__ __volatile__("3:\n\t"                                                                          \
                             "ldr %[w], %[srcm]\n\t"                                                           \
                             "ldr %[x], %[xsm]\n\t"                                                            \
                             "4:\n\t"                                                                          \
                             "ldr %[xa], [%[w]], #4\n\t"                                                       \
                             "sxtb16 %[xb], %[xa]\n\t"                                                         \
                             "sxtb16 %[xa], %[xa], ror #8\n\t"                                                 \
                             "strd %[xb], %[xa], [%[x]], #8\n\t"                                               \
                             "cmp %[x], %[xe]\n\t"                                                             \
                             "bne 4b\n\t"                                                                      \
                             "str %[w], %[srcm]\n\t"                                                           \
                             "ldr %[w], %[wqm]\n\t"                                                            \
                             "ldr %[ch], %[chm]\n\t"                                                           \
                             "2:\n\t"                                                                          \
                             "ldr %[x], %[xsm]\n\t"                                                            \
                             "ldrd %[xa], %[xb], [%[x]], #8\n\t" VD_DSP_PW0("a0") VD_DSP_PW0("a1")              \
                                 VD_DSP_PW0("a2") VD_DSP_PW0("a3") extra                                        \
                             "cmp %[x], %[xe]\n\t"                                                             \
                             "beq 6f\n\t"                                                                      \
                             "1:\n\t" VD_DSP_PW_STEP VD_DSP_PW_STEP                                             \
                             "cmp %[x], %[xe]\n\t"                                                             \
                             "bne 1b\n\t"                                                                      \
                             "6:\n\t" VD_DSP_RQ("a0") VD_DSP_RQ("a1") VD_DSP_RQ("a2") VD_DSP_RQ("a3")            \
                             "ldr %[xa], %[chem]\n\t"                                                          \
                             "cmp %[ch], %[xa]\n\t"                                                            \
                             "bne 2b\n\t"                                                                      \
                             "ldr %[xa], %[nm]\n\t"                                                            \
                             "subs %[xa], %[xa], #1\n\t"                                                       \
                             "str %[xa], %[nm]\n\t"                                                            \
                             "bne 3b"                                                                           \
                             : [a0] "=&r"(a0), [a1] "=&r"(a1), [a2] "=&r"(a2), [a3] "=&r"(a3), [xa] "=&r"(xa),    \
                               [xb] "=&r"(xb), [w0] "=&r"(w0), [w1] "=&r"(w1), [x] "=&r"(x), [w] "=&r"(w),       \
                               [ch] "=&r"(ch), [o] "+r"(o), [srcm] "+m"(src), [nm] "+m"(n)                       \
                             : [xe] "r"(xe), [xsm] "m"(xs), [wqm] "m"(wq), [chm] "m"(ch0), [chem] "m"(che)       \
                             : "cc", "memory");                                                                 \
    }
VD_DSP_PW_RUN(dsp_pw_run_relu_e, VD_DSP_PW_STEP)
VD_DSP_PW_RUN(dsp_pw_run_relu_o, "")
#undef VD_DSP_PW_RUN
#undef VD_DSP_PW_STEP
#undef VD_DSP_RQ

// dsp_pw_run_relu_e / _o for a layer with the rounding's sign term (not ReLU: cmsis.h's vd_cnn_dsp_out with thr)
// and any cout: groups of four channels as there, then the rem = cout % 4 channels one at a time (their
// weights [word] each). Per value the requantisation adds the thr load and the conditional - 2^31
// (CMP, ITE, MOV, SUBS, SBC).
static inline void dsp_pw_run_thr(const int8_t *src, size_t n, size_t nw, uint32_t *xs, const uint32_t *wq,
                                  const vd_cnn_dsp_ch_t *ch0, const int32_t *thr0, size_t groups, size_t rem, int8_t *o)
{
    const uint32_t *xe = xs + nw;
    const size_t odd = (nw / 2u) % 2u == 0u;   // after the first step of four values, an odd count left
    size_t gc = 0u;
    const int32_t *thr = thr0;
    int32_t a0, a1, a2, a3;
    uint32_t xa, xb, w0, w1, *x;
    const uint32_t *w;
    const vd_cnn_dsp_ch_t *ch;
#define VD_DSP_RQT(a)                                                                                           \
    "ldr %[x], %[thrm]\n\t"                                                                                   \
    "ldr %[w1], [%[x]], #4\n\t"                                                                               \
    "str %[x], %[thrm]\n\t"                                                                                   \
    "cmp %[" a "], %[w1]\n\t"                                                                                 \
    "ite le\n\t"                                                                                              \
    "movle %[x], #0x80000000\n\t"                                                                             \
    "movgt %[x], #0\n\t"                                                                                      \
    "ldrd %[xa], %[xb], [%[ch]], #8\n\t"                                                                      \
    "subs %[xa], %[xa], %[x]\n\t"                                                                             \
    "sbc %[xb], %[xb], #0\n\t"                                                                                \
    "ldrd %[w0], %[w1], [%[ch]], #8\n\t"                                                                      \
    "smlal %[xa], %[xb], %[" a "], %[w0]\n\t"                                                                 \
    "asr %[xb], %[xb], %[w1]\n\t"                                                                             \
    "ssat %[xb], #8, %[xb]\n\t"                                                                               \
    "strb %[xb], [%[o]], #1\n\t"
    __asm__ __volatile__(
        "3:\n\t"
        "ldr %[w], %[srcm]\n\t"
        "ldr %[x], %[xsm]\n\t"
        "4:\n\t"
        "ldr %[xa], [%[w]], #4\n\t"
        "sxtb16 %[xb], %[xa]\n\t"
        "sxtb16 %[xa], %[xa], ror #8\n\t"
        "strd %[xb], %[xa], [%[x]], #8\n\t"
        "cmp %[x], %[xe]\n\t"
        "bne 4b\n\t"
        "str %[w], %[srcm]\n\t"
        "ldr %[w], %[wqm]\n\t"
        "ldr %[ch], %[chm]\n\t"
        "ldr %[xa], %[thr0m]\n\t"
        "str %[xa], %[thrm]\n\t"
        "ldr %[xa], %[gm]\n\t"
        "cmp %[xa], #0\n\t"
        "beq 7f\n\t"
        "str %[xa], %[gcm]\n\t"
        "2:\n\t"
        "ldr %[x], %[xsm]\n\t"
        "ldrd %[xa], %[xb], [%[x]], #8\n\t"
        VD_DSP_PW0("a0") VD_DSP_PW0("a1") VD_DSP_PW0("a2") VD_DSP_PW0("a3")
        "ldr %[xa], %[oddm]\n\t"
        "cmp %[xa], #0\n\t"
        "beq 5f\n\t"
        "ldrd %[xa], %[xb], [%[x]], #8\n\t"
        VD_DSP_PW("a0") VD_DSP_PW("a1") VD_DSP_PW("a2") VD_DSP_PW("a3")
        "5:\n\t"
        "cmp %[x], %[xe]\n\t"
        "beq 6f\n\t"
        "1:\n\t"
        "ldrd %[xa], %[xb], [%[x]], #8\n\t"
        VD_DSP_PW("a0") VD_DSP_PW("a1") VD_DSP_PW("a2") VD_DSP_PW("a3")
        "ldrd %[xa], %[xb], [%[x]], #8\n\t"
        VD_DSP_PW("a0") VD_DSP_PW("a1") VD_DSP_PW("a2") VD_DSP_PW("a3")
        "cmp %[x], %[xe]\n\t"
        "bne 1b\n\t"
        "6:\n\t"
        VD_DSP_RQT("a0") VD_DSP_RQT("a1") VD_DSP_RQT("a2") VD_DSP_RQT("a3")
        "ldr %[xa], %[gcm]\n\t"
        "subs %[xa], %[xa], #1\n\t"
        "str %[xa], %[gcm]\n\t"
        "bne 2b\n\t"
        "7:\n\t"                               // the rem single channels
        "ldr %[xa], %[remm]\n\t"
        "cmp %[xa], #0\n\t"
        "beq 8f\n\t"
        "str %[xa], %[gcm]\n\t"
        "5:\n\t"
        "ldr %[x], %[xsm]\n\t"
        "mov %[a0], #0\n\t"
        "6:\n\t"
        "ldrd %[xa], %[xb], [%[x]], #8\n\t"
        VD_DSP_PW("a0")
        "cmp %[x], %[xe]\n\t"
        "bne 6b\n\t"
        VD_DSP_RQT("a0")
        "ldr %[xa], %[gcm]\n\t"
        "subs %[xa], %[xa], #1\n\t"
        "str %[xa], %[gcm]\n\t"
        "bne 5b\n\t"
        "8:\n\t"
        "ldr %[xa], %[nm]\n\t"
        "subs %[xa], %[xa], #1\n\t"
        "str %[xa], %[nm]\n\t"
        "bne 3b"
        : [a0] "=&r"(a0), [a1] "=&r"(a1), [a2] "=&r"(a2), [a3] "=&r"(a3), [xa] "=&r"(xa), [xb] "=&r"(xb),
          [w0] "=&r"(w0), [w1] "=&r"(w1), [x] "=&r"(x), [w] "=&r"(w), [ch] "=&r"(ch), [o] "+r"(o),
          [srcm] "+m"(src), [nm] "+m"(n), [gcm] "+m"(gc), [thrm] "+m"(thr)
        : [xe] "r"(xe), [xsm] "m"(xs), [wqm] "m"(wq), [chm] "m"(ch0), [gm] "m"(groups), [oddm] "m"(odd),
          [thr0m] "m"(thr0), [remm] "m"(rem)
        : "cc", "memory");
#undef VD_DSP_RQT
#undef VD_DSP_PW0
#undef VD_DSP_PW
}

// Pointwise rows [y0, y1) (relu a constant at the call site).
static inline void dsp_pw_rows(const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0, uint32_t y1,
                               size_t kw, uint32_t *xs, const uint32_t *wq, const vd_cnn_dsp_q_t *q, bool relu)
{
    const size_t co = g->co;
    const size_t nw = kw / 2u;   // widened words per pixel
    for (uint32_t y = y0; y < y1;) {   // stride 1 (loader.c): output pixel i reads input pixel i
        const uint32_t e = run_end(in, out, y, y1);
        const int8_t *src = vd_cnn_ring_row(in, y);
        int8_t *dst = vd_cnn_ring_row(out, y);
        const size_t npix = (size_t)g->wo * (e - y);
        if (relu && (co % 4u) == 0u) {
            if ((nw / 2u) % 2u == 0u) {
                dsp_pw_run_relu_e(src, npix, nw, xs, wq, q->ch, co / 4u, dst);
            } else {
                dsp_pw_run_relu_o(src, npix, nw, xs, wq, q->ch, co / 4u, dst);
            }
            y = e;
            continue;
        }
        if (!relu && npix > 0u) {
            dsp_pw_run_thr(src, npix, nw, xs, wq, q->ch, q->thr, co / 4u, co % 4u, dst);
            y = e;
            continue;
        }
        for (size_t i = 0u; i < npix; i++, src += kw, dst += co) {
            for (size_t j = 0u; j < nw; j += 2u) {
                uint32_t x;
                memcpy(&x, src + 2u * j, 4u);
                xs[j] = SXTB16(x);
                xs[j + 1u] = SXTB16_RORn(x, 8u);
            }
            dsp_px(xs, wq, nw, q, co, dst, relu);
        }
        y = e;
    }
}

// The DSP kernels' set-up of a pointwise (one: one-channel 3x3) layer: the widened weights at wq, the
// requantisation constants at qa (vd__cnn_dsp_q_fill); false when the layer is outside its range.
static bool dsp_prepare(const vd_cnn_layer_t *L, int32_t zp_in, bool one, uint32_t *wq, uint8_t *qa,
                        vd_cnn_dsp_q_t *q)
{
    const size_t co = L->cout;
    uint32_t *d = wq;
    if (one) {
        if (!vd__cnn_dsp_q_fill(L, zp_in, qa, false, q)) {
            return false;
        }   // per channel [ (w00, w02) (w10, w12) (w20, w22) (w01, w11) (w21, 0) 0 ] (dsp_one_px)
        for (size_t o = 0u; o < co; o++) {
            const int8_t *w = L->w + o * 9u;
            *d++ = dsp_pair(w[0], w[2]);
            *d++ = dsp_pair(w[3], w[5]);
            *d++ = dsp_pair(w[6], w[8]);
            *d++ = dsp_pair(w[1], w[4]);
            *d++ = dsp_pair(w[7], 0);
            *d++ = 0u;
        }
        return true;
    }
    // Widened weights: groups of four channels [word pair][channel][2], then single channels [word].
    // (The pair (w0, w2) of weight bytes w0..w3 is SXTB16 of their word, (w1, w3) SXTB16 ROR 8: four
    // instructions per four weights; the weight sums for vd__cnn_dsp_q_fill on the way, two SMLAD with
    // (1, 1) per four weights.)
    const size_t cin = L->cin;
    int32_t *sums = vd_cnn_dsp_q_sums(L, qa);
    size_t o = 0u;
    for (; o + 4u <= co; o += 4u) {
        uint32_t a[4] = {0u, 0u, 0u, 0u};   // |sum| <= K 128 < 2^31
        for (size_t k = 0u; k < cin; k += 4u) {   // input bytes k .. k + 3
            for (size_t c = 0u; c < 4u; c++, d += 2) {
                uint32_t x;
                memcpy(&x, L->w + (o + c) * cin + k, 4u);
                d[0] = SXTB16(x);
                d[1] = SXTB16_RORn(x, 8u);
                a[c] = SMLAD(d[0], 0x00010001u, SMLAD(d[1], 0x00010001u, a[c]));
            }
        }
        for (size_t c = 0u; c < 4u; c++) {
            sums[o + c] = (int32_t)a[c];
        }
    }
    for (; o < co; o++) {
        uint32_t a = 0u;
        for (size_t k = 0u; k < cin; k += 4u, d += 2) {
            uint32_t x;
            memcpy(&x, L->w + o * cin + k, 4u);
            d[0] = SXTB16(x);
            d[1] = SXTB16_RORn(x, 8u);
            a = SMLAD(d[0], 0x00010001u, SMLAD(d[1], 0x00010001u, a));
        }
        sums[o] = (int32_t)a;
    }
    return vd__cnn_dsp_q_fill(L, zp_in, qa, true, q);
}

// Pointwise (cin % 4 == 0) and one-channel 3x3 layers; false when the layer is neither, its weights do
// not fit conv.c's weight piece (without a prepared area), or it is outside the DSP requantisation's
// range (cmsis.h). The set-up goes into prep when there is one (cnn_internal.h: made when y0 == 0, read
// back by the later calls), else into the scratch on every call (streamed calls are one output row).
static bool dsp_layer(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0,
                      uint32_t y1, bool stream, uint8_t *scr, uint8_t *prep)
{
    const bool pw = L->op == VD_CNN_OP_PW1X1 && (L->cin % 4u) == 0u;
    const bool one = L->op == VD_CNN_OP_CONV3X3 && L->cin == 1u;
    if (!pw && !one) {
        return false;
    }
    scratch_layout_t s;
    (void)vd__cnn_conv_scratch(L, stream, &s);
    const size_t kw = one ? 12u : L->cin;   // bytes per widened pixel (one: 6 words per channel)
    if ((prep == NULL && (size_t)(s.rows - s.w16) < 2u * kw * g->co) || (size_t)(s.ch - s.rows) < 2u * kw) {
        return false;
    }
    vd_cnn_dsp_q_t q;
    uint32_t *wq = (uint32_t *)(void *)((prep != NULL) ? prep : scr + s.w16);
    uint8_t *qa = (prep != NULL) ? prep + vd_cnn_prep_w_bytes(L) : scr + s.ch;
    if (prep != NULL && y0 > 0u) {
        vd_cnn_dsp_q_view(L, qa, &q);   // made by the layer's call with y0 == 0
    } else if (!dsp_prepare(L, g->zp_in, one, wq, qa, &q)) {
        return false;
    }
    if (one) {
        const int32_t step = L->stride;
        if (q.relu) {
            dsp_one_rows(g, in, out, y0, y1, step, wq, &q, true);
        } else {
            dsp_one_rows(g, in, out, y0, y1, step, wq, &q, false);
        }
        return true;
    }
    uint32_t *xs = (uint32_t *)(void *)(scr + s.rows);
    if (q.relu) {
        dsp_pw_rows(g, in, out, y0, y1, kw, xs, wq, &q, true);
    } else {
        dsp_pw_rows(g, in, out, y0, y1, kw, xs, wq, &q, false);
    }
    return true;
}
#endif

bool vd__cnn_conv_rows_cmsis(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                            uint32_t y0, uint32_t y1, bool stream, uint8_t *scr, uint8_t *prep)
{
#if defined(VD_CNN_DSP)
    if (dsp_layer(L, g, in, out, y0, y1, stream, scr, prep)) {
        return true;
    }
#else
    (void)prep;   // no DSP kernels: no prepared area (vd__cnn_cmsis_prep_bytes)
#endif
    scratch_layout_t s;
    (void)vd__cnn_conv_scratch(L, stream, &s);   // conv.c's layout: the patches take its weights and rows
    vd_cnn_cmsis_q_t q;
    if (!vd__cnn_cmsis_q_fill(L, scr + s.ch, &q)) {
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
        vd__cnn_conv_row_ptrs(g, in, oy, step, ks, rowp);
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
