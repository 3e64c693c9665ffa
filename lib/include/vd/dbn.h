// SPDX-License-Identifier: MIT
// Quantised deep-belief-network verifier: loads a .vdm model in place and scores 32x32 samples.
//
// Lifetime: vd_dbn_model_t only points into the blob given to vd_dbn_load(); the
// blob (e.g. a const array in flash, see models/<name>_vdm.c) must outlive
// the model and stay unchanged. The model is read-only after loading, so one
// model can serve any number of callers at once, each with its own workspace.
// The blob format is documented in docs/model-format.md, the arithmetic in
// docs/fixed-point.md ("dbn").
#ifndef VD_DBN_H
#define VD_DBN_H

#include <stddef.h>
#include <stdint.h>

#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Newest format version this library reads and writes (field `version` of
// the .vdm header); versions VD_DBN_FORMAT_VERSION_MIN..VD_DBN_FORMAT_VERSION
// load. Version 2 adds the input normalisation byte pair (input_norm,
// norm_min_range) where version 1 had zero reserved bytes.
#define VD_DBN_FORMAT_VERSION 2u
#define VD_DBN_FORMAT_VERSION_MIN 1u
// Size in bytes of a .vdm header (versions 1 and 2) and of one layer-table entry.
#define VD_DBN_HEADER_SIZE 64u
#define VD_DBN_LAYER_ENTRY_SIZE 32u
// Magic: the bytes 'V' 'D' 'M' 'F' at offset 0.
#define VD_DBN_MAGIC_U32 0x464D4456u

// Largest number of layers (weight matrices) in a model; sets sizeof(vd_dbn_model_t).
#ifndef VD_DBN_MAX_LAYERS
#define VD_DBN_MAX_LAYERS 8u
#endif
// Largest layer width (inputs or outputs). With |w| <= 127 and inputs <= 255 an
// accumulator then stays below 16384*127*255 < 2^29, so int32 never overflows.
#define VD_DBN_MAX_UNITS 16384u
// Largest input width/height in pixels.
#define VD_DBN_MAX_INPUT_DIM 256u

// Pre-activations are requantised to Q8 and clamped to +-8.0 before the
// sigmoid table lookup.
#define VD_DBN_PREACT_Q 8
#define VD_DBN_PREACT_MAX_Q8 2048

// What the network expects as input (both are 0..255 bytes).
typedef enum vd_dbn_input {
    VD_DBN_INPUT_GREY = 1,  // grey-level crop resampled to input_w x input_h
    VD_DBN_INPUT_SHAPE = 2  // binary refine mask (0/255) resampled likewise
} vd_dbn_input_t;

// Per-sample input normalisation applied inside vd_dbn_classify (header
// field input_norm; docs/fixed-point.md "dbn").
typedef enum vd_dbn_norm {
    VD_DBN_NORM_NONE = 0,   // the sample bytes go to layer 0 as they are
    VD_DBN_NORM_MINMAX = 1  // min-max contrast stretch, see vd_dbn_stretch_u8()
} vd_dbn_norm_t;

// One fully connected layer, pointing into the blob. Multi-byte arrays are
// little-endian byte arrays (read byte-wise, so any host endianness works).
typedef struct vd_dbn_layer {
    const int8_t *weights;   // [out][in] row-major, -127..127, scale per output row
    const uint8_t *bias_le;  // int32 LE [out]: bias in accumulator units
    const uint8_t *mult_le;  // int32 LE [out]: Q31 multiplier, 2^30 .. 2^31-1
    const int8_t *shift;     // [out]: exponent, -31..7 (negative = right shift)
    uint32_t in;
    uint32_t out;
} vd_dbn_layer_t;

// A loaded model. Complete so the caller can own it (static, stack, struct
// member); fill it only with vd_dbn_load(). All pointers point into the blob.
typedef struct vd_dbn_model {
    const uint8_t *blob;      // start of the blob (NULL: not loaded)
    uint32_t size;            // total_size from the header (<= bytes given)
    uint32_t crc32;           // CRC-32 stored in (and verified against) the blob
    uint16_t format_version;  // version read from the blob (1 or 2)
    uint16_t input_w;         // network input width in pixels (32 for the paper)
    uint16_t input_h;         // network input height
    uint16_t norm_divisor;    // input real value = (pixel - norm_offset) / norm_divisor (informative;
    int16_t norm_offset;      //   already folded into layer 0's multipliers)
    vd_dbn_input_t input_mode;
    vd_dbn_norm_t input_norm; // stretch applied by vd_dbn_classify before layer 0
    uint32_t norm_min_range;  // MINMAX: smallest range the stretch divides by, 1..255; NONE: 0
    uint32_t n_layers;        // 1..VD_DBN_MAX_LAYERS
    uint32_t max_units;       // widest layer output (sizes the workspace)
    char name[17];            // model name from the header, NUL-terminated
    vd_dbn_layer_t layers[VD_DBN_MAX_LAYERS];
} vd_dbn_model_t;

// Validates a .vdm blob in place and fills *m with pointers into it (no copy).
// m:     caller-owned model; written only on VD_OK (left untouched otherwise).
// blob:  the .vdm bytes, 4-byte aligned; must outlive *m unchanged.
// bytes: bytes available at blob (>= the header's total_size; any excess,
//        e.g. flash padding, is ignored).
// Returns VD_OK; VD_ERR_ARG for m or blob NULL, bytes == 0 or a blob pointer
// not 4-byte aligned; VD_ERR_MODEL for anything wrong in the blob: short
// blob, magic, version, header size, total size, CRC-32, input size or mode,
// layer count, input normalisation (unknown value, a nonzero min range
// without normalisation, min range 0 with it, normalisation in a version-1
// blob), layer sizes (0, > VD_DBN_MAX_UNITS, first in != input_w*input_h,
// in != previous out, last out != 1), array offsets out of range, misaligned
// or overlapping, size overflow, multipliers/shifts out of range, a bias that
// could overflow the int32 accumulator, nonzero reserved fields.
// Time O(total_size) (CRC + one pass over per-unit arrays); stack < 1 KiB.
VD_API vd_status_t vd_dbn_load(vd_dbn_model_t *m, const void *blob, size_t bytes);

// Workspace bytes vd_dbn_classify() needs for model m (two activation
// buffers of max_units bytes, plus input_w * input_h bytes for the stretched
// sample when the model normalises its input, each rounded up to
// VD_WORKSPACE_ALIGN).
// Returns VD_OK; VD_ERR_ARG for NULL m or bytes; VD_ERR_STATE if m was not
// filled by vd_dbn_load().
VD_API vd_status_t vd_dbn_workspace_size(const vd_dbn_model_t *m, size_t *bytes);

// Scores one sample.
// m:        a loaded model (read only).
// input:    input_w * input_h bytes, row-major, contiguous, 0..255 (grey crop
//           or 0/255 mask as m->input_mode says; see tools/vdtools/data/samples.py);
//           not modified: a MINMAX model stretches a copy in the workspace.
// ws/bytes: caller workspace, VD_WORKSPACE_ALIGN-aligned, >= vd_dbn_workspace_size().
// score_q8: out, Q8 probability of "vehicle": 0..255 (p = score / 256;
//           128 is p = 0.5).
// Returns VD_OK; VD_ERR_ARG for NULL m, input or score_q8; VD_ERR_STATE if m
// is not loaded; VD_ERR_WORKSPACE for a NULL, misaligned or short workspace.
// Bit-exact with tools/vdtools/formats/quantise.py quant_forward().
// Time: sum over layers of in*out multiply-adds (1024-576-256-64-1: 753k)
// plus, for MINMAX, 2 passes and input_w*input_h divisions;
// stack < 128 bytes.
VD_API vd_status_t vd_dbn_classify(const vd_dbn_model_t *m, const uint8_t *input, void *ws, size_t bytes,
                            uint8_t *score_q8);

// Min-max contrast stretch of one sample (the VD_DBN_NORM_MINMAX step):
// lo, hi = min and max of in[0..n), r = max(hi - lo, min_range),
// out[i] = ((in[i] - lo) * 510 + r) / (2 * r)  (= round half up of 255 (in[i] - lo) / r;
// 0..255: hi maps to 255 when hi - lo >= min_range; a flat sample maps to all 0).
// in, out: n bytes each (may be the same buffer); n >= 1; min_range 1..255.
// Returns VD_OK; VD_ERR_ARG for NULL in/out, n == 0 or min_range out of range.
// Time O(n), one 32-bit division per byte; stack a few words.
VD_API vd_status_t vd_dbn_stretch_u8(const uint8_t *in, uint32_t n, uint32_t min_range, uint8_t *out);

// The requantisation step, exposed for tests and for other integer layers:
// TFLite MultiplyByQuantizedMultiplier (gemmlowp SaturatingRoundingDoublingHighMul
// then RoundingDivideByPOT: the default double-rounding path, not
// TFLITE_SINGLE_ROUNDING; same as CMSIS-NN arm_nn_requantize without
// CMSIS_NN_USE_SINGLE_ROUNDING). Returns round(acc * mult_q31 * 2^(shift-31)).
// shift must be in -31..7 and mult_q31 >= 0 (VD_ASSERT). Where shift > 0 and
// acc << shift leaves int32 (undefined in TFLite) the shifted value saturates.
VD_API int32_t vd_dbn_requantize(int32_t acc, int32_t mult_q31, int32_t shift);

// Sigmoid of a Q8 pre-activation as a Q8 probability: z_q8 is clamped to
// [-2048, 2048] (+-8.0) and looked up in the generated table
// (lib/src/models/dbn_sigmoid_table.h): min(255, round(256 * sigmoid(z / 256))).
VD_API uint8_t vd_dbn_sigmoid_q8(int32_t z_q8);

#ifdef __cplusplus
}
#endif
#endif
