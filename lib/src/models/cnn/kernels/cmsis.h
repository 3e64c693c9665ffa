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
bool vd_cnn_cmsis_q_fill(const vd_cnn_layer_t *L, uint8_t *area, vd_cnn_cmsis_q_t *q);

#endif
