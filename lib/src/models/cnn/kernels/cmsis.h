// SPDX-License-Identifier: MIT
// The CMSIS-NN back end's shared part (Cortex-M): CMSIS-NN's headers, the per-channel requantisation arrays
// in CMSIS-NN's form, and which layers it computes bit-exactly.
//
// Included only by the CMSIS-NN back end's files (kernels/*cmsis*.c, compiled when CMake's VD_CNN_CMSIS is
// ON): the one place besides the x86 back end that includes a header from outside lib/ (CMSIS-NN's, from
// VD_CMSIS_NN_DIR/Include; the include rule's named exception).
//
// Bit-exactness: CMSIS-NN's arm_nn_requantize(acc, mult, shift) on its default double-rounding path
// (CMSIS_NN_USE_SINGLE_ROUNDING not defined) is TFLite's MultiplyByQuantizedMultiplier, which
// models/requant.h implements (vd_rq_requantize), with the same per-channel convention: mult a Q31
// multiplier in [2^30, 2^31), shift > 0 a left shift, < 0 a rounding right shift. Two places differ: for
// shift > 0 CMSIS-NN multiplies the accumulator by 2^shift without saturating (vd saturates), and for
// shift -31 it computes (1 << 31) - 1, outside C's int; a layer with such a channel stays on the portable
// kernels. Zero points: CMSIS-NN's input_offset is -zp_in and its output_offset zp_out (added after the
// requantisation, as vd_cnn_rq_out adds the zero point), the clamp [act_min, act_max] after that: vd's
// clamp(z, act_min - zp, act_max - zp) + zp. Accumulators: CMSIS-NN sums in int32 in another order (bias
// first, or sum w x + input_offset sum w), equal modulo 2^32, and the loader's bias bound makes the
// exact sum fit int32, so the requantised values are the same.
#ifndef VD_CNN_CMSIS_H
#define VD_CNN_CMSIS_H

#include <arm_nnfunctions.h>
#include <arm_nnsupportfunctions.h>
#include <stdbool.h>
#include <stdint.h>

#include "models/cnn/cnn_internal.h"

#if defined(CMSIS_NN_USE_SINGLE_ROUNDING)
#error "vd requantises as TFLite's default path (two roundings): build CMSIS-NN without CMSIS_NN_USE_SINGLE_ROUNDING"
#endif

// Right shifts CMSIS-NN's arm_nn_divide_by_power_of_two takes within C's int (exponent <= 30).
#define VD_CNN_CMSIS_SHIFT_MIN (-30)

// A layer's requantisation in CMSIS-NN's form: three int32 arrays of cout values.
typedef struct vd_cnn_cmsis_q {
    int32_t *mult;
    int32_t *shift;
    int32_t *bias;
} vd_cnn_cmsis_q_t;

// Bytes of the arrays (12 per output channel, rounded up to VD_CNN_ITEM_ALIGN): they take the place of
// the portable kernels' vd_rq_ch_t constants in the layer's scratch, which are larger.
static inline uint32_t vd_cnn_cmsis_q_bytes(const vd_cnn_layer_t *L)
{
    return vd_cnn_round_up(12u * L->cout, VD_CNN_ITEM_ALIGN);
}

// The arrays of layer L at area (4-byte aligned, vd_cnn_cmsis_q_bytes long); false (area partly
// written) when a channel's shift is outside [VD_CNN_CMSIS_SHIFT_MIN, 0].
bool vd__cnn_cmsis_q_fill(const vd_cnn_layer_t *L, uint8_t *area, vd_cnn_cmsis_q_t *q);


// ------------------------------------------------------------------------------------------------------------
// vd's own Armv7E-M DSP kernels in the back end (dw3x3_cmsis.c, conv_cmsis.c): where CMSIS-NN's kernels spend
// most of their instructions on the compact network's small shapes (per-call and per-pixel set-up, 9 or
// 8..64 multiply-adds per output value against ~15 instructions of requantisation per value), the same
// SXTB16 / SMLAD / SMLABB arithmetic with the weights widened once per call (streamed: once per run, into
// a prepared area where plan.c gives one) and a shorter requantisation.
// Not in -Os builds: there gcc neither unrolls the tap loops nor specialises the inlined requantisation
// per layer kind, and the kernels took more instructions than CMSIS-NN's (95.7 M against 82.1 M per
// frame on the Cortex-M7 MinSizeRel firmware), so -Os keeps CMSIS-NN's kernels and their smaller code.
// (Since the kernels' hot loops are assembly blocks, the M7 -Os firmware with them measured a 36.4 M
// CNN stage against 82.1 M, flash 4840 B more; not switched: -Os stays the small build.)
// Nor at -O0 (no __OPTIMIZE__): there gcc keeps a frame pointer and cannot give the assembly blocks
// their 14 registers ("impossible constraints").
// Nor with clang: its register allocator gives up on the 14-register blocks ("inline assembly requires
// more registers than available", clang 14 for Cortex-M7), so clang builds take CMSIS-NN's kernels.
#if defined(ARM_MATH_DSP) && defined(__ARM_FEATURE_SAT) && defined(__GNUC__) && !defined(__clang__) && \
    defined(__OPTIMIZE__) && !defined(__OPTIMIZE_SIZE__)
#include <arm_acle.h>
#define VD_CNN_DSP 1

// One output channel's requantisation in the DSP kernels' form: models/requant.h's one-shift form
// vd_rq_z (ReLU layers: vd_rq_z_nn) as one signed multiply-accumulate (SMLAL), one arithmetic shift of
// its high word and one SSAT. With x the int32 sum (bias included), vd computes v = (x + 2^31) mult + k
// (mod 2^64) and z = (v >> rsh) - 2^(63 - rsh); with k2 = k + 2^31 mult + 2^63, x mult + k2 = v + 2^63
// (mod 2^64), whose high word read as int32 is H = hi(v) - 2^31 exactly, and for rsh = 32 + sh (sh 0..30)
// floor(H / 2^sh) = (hi(v) >> sh) - 2^(31 - sh) = z. Three more terms fold into the 64-bit constant:
//  * the bias b' (the model's bias - zp_in sum w: padding taps read zp_in and add zero): with the sum of
//    products s = x - b' (exact: |s| <= K 128 128 < 2^31 for the loader's K <= 25 * 1024),
//    x mult + k2 = s mult + (k2 + b' mult), so the sums start at 0;
//  * the output zero point: H + zp 2^sh, shifted by sh, is z + zp, so zp 2^(32 + sh) in the constant
//    gives z + zp, and one SSAT to 8 bits is vd_cnn_rq_out's clamp to [act_min, act_max] = [-128, 127]
//    (the only range these kernels take). No wrap: z (and z_nn <= z + 1) lies in [-2^(31-e),
//    2^(31-e) + 1] for the right shift e = sh + 1, so H lies in [-2^30, 2^30 + 2^e) and H + zp 2^sh
//    (|zp| <= 128) in int32 for e <= 24 (VD_CNN_DSP_SHIFT_MIN);
//  * the sign term of vd_rq_z (not for ReLU layers, act_min >= zp: vd_rq_z_nn): x <= thr takes the
//    constant - 2^31, tested as s <= thr - b' (clamped to int32: |s| < 2^31).
// vd__cnn_dsp_q_fill refuses other layers (shift outside [-24, -1], a clamp other than the int8 range).
#define VD_CNN_DSP_SHIFT_MIN (-24)

typedef struct vd_cnn_dsp_ch {
    uint64_t k;      // k2 + b' mult + zp 2^(32 + sh) (mod 2^64)
    int32_t mult;    // Q31 multiplier
    uint32_t sh;     // rsh - 32
} vd_cnn_dsp_ch_t;

typedef struct vd_cnn_dsp_q {
    vd_cnn_dsp_ch_t *ch;
    int32_t *thr;    // per channel: s <= thr takes k - 2^31 (the rounding's sign term; not for ReLU)
    bool relu;       // act_min >= zp: no sign term (models/requant.h vd_rq_z_nn)
} vd_cnn_dsp_q_t;

// Bytes of the constants (20 per output channel): they take the place of the portable kernels'
// vd_rq_ch_t constants in the layer's scratch, which are larger.
static inline uint32_t vd_cnn_dsp_q_bytes(const vd_cnn_layer_t *L)
{
    return vd_cnn_round_up((uint32_t)(L->cout * (sizeof(vd_cnn_dsp_ch_t) + 4u)), VD_CNN_ITEM_ALIGN);
}

// The view of the constants at area (8-byte aligned) of layer L: what vd__cnn_dsp_q_fill sets, without
// filling them (a prepared area's later calls).
static inline void vd_cnn_dsp_q_view(const vd_cnn_layer_t *L, uint8_t *area, vd_cnn_dsp_q_t *q)
{
    q->ch = (vd_cnn_dsp_ch_t *)(void *)area;
    q->thr = (int32_t *)(void *)(q->ch + L->cout);
    q->relu = L->act_min >= L->out_zp;
}

// A layer's prepared area (vd__cnn_cmsis_prep_bytes, cnn_internal.h): its widened weights (pointwise
// 2 K cout bytes, one-channel 3x3 24 cout, depthwise 72 per group of four channels), for the depthwise
// kernel the zero-point row (cout bytes), then the constants (vd_cnn_dsp_q_bytes); each piece at a
// multiple of VD_CNN_ITEM_ALIGN. vd_cnn_prep_dw_zrow: where the zero-point row starts;
// vd_cnn_prep_w_bytes: where the constants start (0: not a layer of the DSP kernels).
static inline uint32_t vd_cnn_prep_dw_zrow(const vd_cnn_layer_t *L)
{
    return vd_cnn_round_up(72u * (L->cout / 4u), VD_CNN_ITEM_ALIGN);
}

static inline uint32_t vd_cnn_prep_w_bytes(const vd_cnn_layer_t *L)
{
    if (L->op == VD_CNN_OP_PW1X1 && (L->cin % 4u) == 0u) {
        return vd_cnn_round_up(2u * L->cin * L->cout, VD_CNN_ITEM_ALIGN);
    }
    if (L->op == VD_CNN_OP_CONV3X3 && L->cin == 1u) {
        return vd_cnn_round_up(24u * L->cout, VD_CNN_ITEM_ALIGN);
    }
    if (L->op == VD_CNN_OP_DW3X3) {
        return vd_cnn_prep_dw_zrow(L) + vd_cnn_round_up(L->cout, VD_CNN_ITEM_ALIGN);
    }
    return 0u;
}

// The constants of layer L (input zero point zp_in) at area (8-byte aligned, vd_cnn_dsp_q_bytes long);
// false (area partly written) when a channel's shift is outside [VD_CNN_DSP_SHIFT_MIN, -1] or the clamp
// is not [-128, 127]. sums: the caller has put each channel's weight sum at vd_cnn_dsp_q_sums(L, area)
// (a kernel that reads every weight anyway, once per call); else they are summed here.
bool vd__cnn_dsp_q_fill(const vd_cnn_layer_t *L, int32_t zp_in, uint8_t *area, bool sums, vd_cnn_dsp_q_t *q);

// Where vd__cnn_dsp_q_fill takes the weight sums from (its thr array, written channel by channel after
// the channel's sum is read).
static inline int32_t *vd_cnn_dsp_q_sums(const vd_cnn_layer_t *L, uint8_t *area)
{
    return (int32_t *)(void *)(area + sizeof(vd_cnn_dsp_ch_t) * L->cout);
}

// The output byte of channel c from its sum of products s (no bias); relu is the layer's (a constant at
// the call sites, so each kernel has one loop per case).
static inline int8_t vd_cnn_dsp_out(int32_t s, const vd_cnn_dsp_ch_t *c, int32_t thr, bool relu)
{
    uint64_t k = c->k;
    if (!relu && s <= thr) {
        k -= (uint64_t)1 << 31;
    }
    // hi:lo = s mult + k (SMLAL), z = hi >> sh (ASR: arithmetic), SSAT 8. In assembly: gcc 12 widens
    // s to 64 bits when s comes out of an SMLAD chain and multiplies with MUL, MLA, UMULL and ADC.
    uint32_t lo = (uint32_t)k, hi = (uint32_t)(k >> 32);
    int32_t r;
    __asm__("smlal %0, %1, %3, %4\n\tasr %1, %1, %5\n\tssat %2, #8, %1"
            : "+r"(lo), "+r"(hi), "=r"(r)
            : "r"(s), "r"(c->mult), "r"(c->sh));
    return (int8_t)r;
}

// vd_cnn_dsp_out of four consecutive channels of a ReLU layer (the sums a[0..3] of channels ch[0..3]) into
// o[0..3]: per value LDRD of k, LDRD of mult and sh, SMLAL, ASR, SSAT, STRB (in C gcc 12 recomputes the
// constants' addresses and loads them in three).
static inline void vd_cnn_dsp_out4_relu(int32_t a0, int32_t a1, int32_t a2, int32_t a3, const vd_cnn_dsp_ch_t *ch,
                                        int8_t *o)
{
    uint32_t lo, hi, m, sh;
#define VD_DSP_RQ(a, i)                                                                                         \
    "ldrd %[lo], %[hi], [%[ch]], #8\n\t"                                                                     \
    "ldrd %[m], %[sh], [%[ch]], #8\n\t"                                                                      \
    "smlal %[lo], %[hi], %[" a "], %[m]\n\t"                                                                 \
    "asr %[hi], %[hi], %[sh]\n\t"                                                                            \
    "ssat %[hi], #8, %[hi]\n\t"                                                                              \
    "strb %[hi], [%[o], #" i "]\n\t"
    __asm__ __volatile__(VD_DSP_RQ("a0", "0") VD_DSP_RQ("a1", "1") VD_DSP_RQ("a2", "2") VD_DSP_RQ("a3", "3")
            : [lo] "=&r"(lo), [hi] "=&r"(hi), [m] "=&r"(m), [sh] "=&r"(sh), [ch] "+r"(ch)
            : [a0] "r"(a0), [a1] "r"(a1), [a2] "r"(a2), [a3] "r"(a3), [o] "r"(o)
            : "memory");
#undef VD_DSP_RQ
}
#endif

#endif
