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
// SXTB16 / SMLAD / SMLABB arithmetic with the weights widened once per call and a shorter requantisation.
// Not in -Os builds: there gcc neither unrolls the tap loops nor specialises the inlined requantisation
// per layer kind, and the kernels took more instructions than CMSIS-NN's (95.7 M against 82.1 M per
// frame on the Cortex-M7 MinSizeRel firmware), so -Os keeps CMSIS-NN's kernels and their smaller code.
#if defined(ARM_MATH_DSP) && defined(__ARM_FEATURE_SAT) && defined(__GNUC__) && !defined(__OPTIMIZE_SIZE__)
#include <arm_acle.h>
#define VD_CNN_DSP 1

// One output channel's requantisation in the DSP kernels' form: models/requant.h's one-shift form
// vd_rq_z (ReLU layers: vd_rq_z_nn) as one signed multiply-accumulate (SMLAL) and one arithmetic shift of
// its high word. With x the int32 sum (bias included), vd computes v = (x + 2^31) mult + k (mod 2^64) and
// z = (v >> rsh) - 2^(63 - rsh); here k2 = k + 2^31 mult + 2^63, so x mult + k2 = v + 2^63 (mod 2^64),
// whose high word read as int32 is hi(v) - 2^31 exactly, and for rsh = 32 + sh (sh 0..31)
// floor((hi(v) - 2^31) / 2^sh) = (hi(v) >> sh) - 2^(31 - sh) = z. Only for channels with shift <= -1
// (rsh >= 32) and no left shift: vd_cnn_dsp_q_fill refuses other layers.
typedef struct vd_cnn_dsp_ch {
    uint64_t k2;     // k + 2^31 mult + 2^63 (mod 2^64)
    int32_t mult;    // Q31 multiplier
    uint32_t sh;     // rsh - 32
    int32_t thr;     // vd_rq_ch_t's thr: x <= thr takes k2 - 2^31 (the rounding's sign term; not for ReLU)
    int32_t pad;
} vd_cnn_dsp_ch_t;

typedef struct vd_cnn_dsp_q {
    const vd_cnn_dsp_ch_t *ch;
    int32_t *bias;   // per channel (kernels fold - zp_in sum w into it)
    int32_t zp, lo, hi;
    bool relu;       // lo >= 0: no sign term (models/requant.h vd_rq_z_nn)
    bool sat8;       // lo == 0 and hi == 255 (so zp = -128 = act_min, act_max = 127): one USAT clamps
} vd_cnn_dsp_q_t;

// Bytes of the constants (28 per output channel): they take the place of the portable kernels'
// vd_rq_ch_t constants in the layer's scratch, which are larger.
static inline uint32_t vd_cnn_dsp_q_bytes(const vd_cnn_layer_t *L)
{
    return vd_cnn_round_up((uint32_t)(L->cout * (sizeof(vd_cnn_dsp_ch_t) + 4u)), VD_CNN_ITEM_ALIGN);
}

// The constants of layer L at area (8-byte aligned, vd_cnn_dsp_q_bytes long); false (area partly
// written) when a channel's shift is outside [VD_RQ_SHIFT_MIN, -1].
bool vd_cnn_dsp_q_fill(const vd_cnn_layer_t *L, uint8_t *area, vd_cnn_dsp_q_t *q);

// The output byte of sum acc (bias included) of channel c; relu and sat8 are the layer's (constants at
// the call sites, so each kernel has one loop per case).
static inline int8_t vd_cnn_dsp_out(int32_t acc, const vd_cnn_dsp_ch_t *c, const vd_cnn_dsp_q_t *q, bool relu,
                                    bool sat8)
{
    uint64_t k = c->k2;
    if (!relu && acc <= c->thr) {
        k -= (uint64_t)1 << 31;
    }
    const uint64_t v = (uint64_t)((int64_t)acc * c->mult) + k;
    // gcc's >> of a negative int is arithmetic (this code is gcc/clang on Arm only): one ASR.
    const int32_t z = (int32_t)(uint32_t)(v >> 32) >> c->sh;
    if (sat8) {
        return (int8_t)((int32_t)__usat(z, 8) - 128);   // zp is -128 (hi = act_max - zp = 255)
    }
    return vd_cnn_rq_out(z, q->zp, q->lo, q->hi);
}
#endif

#endif
