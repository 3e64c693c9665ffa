// SPDX-License-Identifier: MIT
// Quantised DBN: in-place .vdm validation and bit-exact fixed-point inference.
//
// Algorithm: a stack of fully connected sigmoid layers (the fine-tuned DBN of
// paper 001 section 4 / paper 000 section 3). Per output unit o:
//   acc  = bias[o] + sum_i w[o][i] * a[i]        int8 x uint8 -> int32
//   z_q8 = vd_dbn_requantize(acc, mult[o], shift[o])   (TFLite requantise,
//          lib/src/models/requant.h, shared with the CNN)
//   a'   = sigmoid(clamp(z_q8, -2048, 2048)) in Q8 (uint8; dbn_sigmoid_table.h)
// The last layer has one unit: its activation is the score.
// Input normalisation (format version 2, header field input_norm): with
// VD_DBN_NORM_MINMAX the sample is first contrast-stretched per sample,
//   r = max(max - min, norm_min_range)
//   x' = ((x - min) * 510 + r) / (2 r)       (round half up of 255 (x-min)/r)
// into a workspace buffer, so the network sees shape and contrast, not the
// AGC brightness of the frame (docs/fixed-point.md "dbn").
// Reference: TFLite/CMSIS-NN int8 quantisation (per-channel symmetric
// weights, Q31 multiplier + shift, gemmlowp rounding); the Python reference is
// tools/vdtools/formats/quantise.py quant_forward(); format in docs/model-format.md.
// Bounds: vd_dbn_load is O(total_size) (CRC-32) plus O(sum of out) for the
// per-unit checks and O(segments^2) = O((4*VD_DBN_MAX_LAYERS)^2) for the
// overlap check; vd_dbn_classify is O(sum in*out) multiply-adds plus two
// passes over the input for the stretch (one 32-bit division per pixel). Accumulators
// cannot overflow: |sum w*a| <= in*127*255 and the loader rejects biases with
// |bias| > INT32_MAX - in*127*255. Stack: the loader keeps a segment list of
// 4*VD_DBN_MAX_LAYERS pairs (256 bytes for 8 layers); classify a few words.
#include "vd/dbn.h"

#include "models/blob_internal.h"
#include "core/crc32.h"
#include "models/requant.h"
#include "internal/vd_internal.h"
#include "models/dbn_sigmoid_table.h"

#include <string.h>

// Bytes 0..15: the container (magic, version, sizes; models/blob_internal.h checks it).
#define HDR_CRC 12u
#define HDR_INPUT_W 16u
#define HDR_INPUT_H 18u
#define HDR_INPUT_MODE 20u
#define HDR_ACTIVATION 21u
#define HDR_N_LAYERS 22u
#define HDR_NORM_DIVISOR 24u
#define HDR_NORM_OFFSET 26u
#define HDR_LAYER_TABLE 28u
#define HDR_FLAGS 32u
#define HDR_INPUT_NORM 36u
#define HDR_NORM_MIN_RANGE 37u
#define HDR_RESERVED0 38u
#define HDR_NAME 40u
#define HDR_NAME_LEN 16u
#define HDR_RESERVED1 56u

#define LT_IN 0u
#define LT_OUT 4u
#define LT_WEIGHTS 8u
#define LT_BIAS 12u
#define LT_MULT 16u
#define LT_SHIFT 20u
#define LT_FLAGS 24u
#define LT_RESERVED 28u

// The one activation this version knows: sigmoid by the Q8 table.
#define ACT_SIGMOID_Q8 1u

#define SHIFT_MIN VD_RQ_SHIFT_MIN
#define SHIFT_MAX VD_RQ_SHIFT_MAX
#define MULT_MIN_Q31 VD_RQ_MULT_MIN
#define MAX_ABS_PRODUCT (127L * 255L)

#define N_SEGMENTS (4u * VD_DBN_MAX_LAYERS)

// Two's-complement reinterpretation without implementation-defined casts.
static int32_t u32_to_i32(uint32_t u)
{
    if (u <= (uint32_t)INT32_MAX) {
        return (int32_t)u;
    }
    return -(int32_t)(~u) - 1;
}

static int32_t rd_i32(const uint8_t *p)
{
    return u32_to_i32(vd_blob_u32(p));
}

static int16_t rd_i16(const uint8_t *p)
{
    uint16_t u = vd_blob_u16(p);
    return (u <= (uint16_t)INT16_MAX) ? (int16_t)u : (int16_t)(-(int32_t)(uint16_t)~u - 1);
}

int32_t vd_dbn_requantize(int32_t acc, int32_t mult_q31, int32_t shift)
{
    return vd_rq_requantize(acc, mult_q31, shift);
}

// t(k) for k = z + 2048 in 0..2048 (z <= 0): the number of the table's steps at or below k, by
// bisection of the sorted steps (at most 8 halvings of 128). The steps (256 B) replace the 2 049-entry
// table the Cortex-M0+ size budget could not keep; the values are the same (the generator checks each k).
static uint32_t sigmoid_half(uint32_t k)
{
    uint32_t lo = 0u;
    uint32_t hi = VD_DBN_SIGMOID_STEPS;
    while (lo < hi) {
        const uint32_t mid = (lo + hi) >> 1;
        if (vd_dbn_sigmoid_q8_edges[mid] <= k) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

uint8_t vd_dbn_sigmoid_q8(int32_t z_q8)
{
    if (z_q8 < -VD_DBN_SIGMOID_IN_MAX) {
        z_q8 = -VD_DBN_SIGMOID_IN_MAX;
    } else if (z_q8 > VD_DBN_SIGMOID_IN_MAX) {
        z_q8 = VD_DBN_SIGMOID_IN_MAX;
    }
    if (z_q8 <= 0) {
        return (uint8_t)sigmoid_half((uint32_t)(z_q8 + VD_DBN_SIGMOID_IN_MAX));
    }
    // The z > 0 half by the identity the generator checks: min(255, 256 - t(-z)).
    const uint32_t mirror = 256u - sigmoid_half((uint32_t)(VD_DBN_SIGMOID_IN_MAX - z_q8));
    return (uint8_t)((mirror > 255u) ? 255u : mirror);
}

// ------------------------------------------------------------------ loader

typedef struct segment {
    uint32_t off;
    uint32_t len;
} segment_t;

// Per-unit checks of one layer: multiplier, shift, bias bound.
static bool layer_values_ok(const vd_dbn_layer_t *l)
{
    const int64_t bias_max = (int64_t)INT32_MAX - (int64_t)l->in * MAX_ABS_PRODUCT;
    for (uint32_t o = 0u; o < l->out; o++) {
        const int32_t mult = rd_i32(l->mult_le + 4u * (size_t)o);
        const int64_t bias = rd_i32(l->bias_le + 4u * (size_t)o);
        const int32_t sh = l->shift[o];
        if (mult < MULT_MIN_Q31 || sh < SHIFT_MIN || sh > SHIFT_MAX) {
            return false;
        }
        if (bias > bias_max || bias < -bias_max) {
            return false;
        }
    }
    return true;
}

vd_status_t vd_dbn_load(vd_dbn_model_t *m, const void *blob, size_t bytes)
{
    VD_VERIFY(m != NULL && blob != NULL && bytes != 0u, VD_ERR_ARG);
    VD_VERIFY(((uintptr_t)blob % 4u) == 0u, VD_ERR_ARG);
    const uint8_t *b = (const uint8_t *)blob;
    // Container, before trusting any size.
    uint16_t version;
    uint32_t total;
    VD_TRY(vd_blob_container(b, bytes, VD_DBN_FORMAT_VERSION_MIN, VD_DBN_FORMAT_VERSION, VD_DBN_HEADER_SIZE, &version,
                             &total));
    const uint32_t crc = vd_blob_u32(b + HDR_CRC);   // checked by vd_blob_container

    // Header fields.
    const uint16_t in_w = vd_blob_u16(b + HDR_INPUT_W);
    const uint16_t in_h = vd_blob_u16(b + HDR_INPUT_H);
    const uint8_t mode = b[HDR_INPUT_MODE];
    const uint32_t n_layers = vd_blob_u16(b + HDR_N_LAYERS);
    const uint16_t norm_div = vd_blob_u16(b + HDR_NORM_DIVISOR);
    const uint32_t table = vd_blob_u32(b + HDR_LAYER_TABLE);
    VD_VERIFY(in_w >= 1u && in_w <= VD_DBN_MAX_INPUT_DIM, VD_ERR_MODEL);
    VD_VERIFY(in_h >= 1u && in_h <= VD_DBN_MAX_INPUT_DIM, VD_ERR_MODEL);
    VD_VERIFY(mode == (uint8_t)VD_DBN_INPUT_GREY || mode == (uint8_t)VD_DBN_INPUT_SHAPE, VD_ERR_MODEL);
    VD_VERIFY(b[HDR_ACTIVATION] == ACT_SIGMOID_Q8, VD_ERR_MODEL);
    VD_VERIFY(n_layers >= 1u && n_layers <= VD_DBN_MAX_LAYERS, VD_ERR_MODEL);
    VD_VERIFY(norm_div >= 1u, VD_ERR_MODEL);
    VD_VERIFY(vd_blob_u32(b + HDR_FLAGS) == 0u && vd_blob_u16(b + HDR_RESERVED0) == 0u, VD_ERR_MODEL);
    // Version 1 had these two bytes reserved (zero): no normalisation.
    const uint8_t norm = b[HDR_INPUT_NORM];
    const uint8_t min_range = b[HDR_NORM_MIN_RANGE];
    if (norm == (uint8_t)VD_DBN_NORM_NONE) {
        VD_VERIFY(min_range == 0u, VD_ERR_MODEL);
    } else {
        VD_VERIFY(version >= 2u && norm == (uint8_t)VD_DBN_NORM_MINMAX && min_range >= 1u, VD_ERR_MODEL);
    }
    VD_VERIFY(vd_blob_all_zero(b + HDR_RESERVED1, VD_DBN_HEADER_SIZE - HDR_RESERVED1), VD_ERR_MODEL);
    VD_VERIFY(vd_blob_name_ok(b + HDR_NAME, HDR_NAME_LEN), VD_ERR_MODEL);
    VD_VERIFY(table >= VD_DBN_HEADER_SIZE && table <= total && (table % 4u) == 0u, VD_ERR_MODEL);
    VD_VERIFY((uint64_t)table + (uint64_t)n_layers * VD_DBN_LAYER_ENTRY_SIZE <= (uint64_t)total, VD_ERR_MODEL);
    const uint32_t table_end = table + n_layers * VD_DBN_LAYER_ENTRY_SIZE;

    // Layer table: sizes chain, arrays in range, aligned, disjoint.
    vd_dbn_model_t tmp;
    memset(&tmp, 0, sizeof tmp);
    segment_t seg[N_SEGMENTS];
    uint32_t n_seg = 0u;
    uint32_t prev_out = (uint32_t)in_w * (uint32_t)in_h;
    uint32_t max_units = 0u;
    for (uint32_t l = 0u; l < n_layers; l++) {
        const uint8_t *e = b + table + l * VD_DBN_LAYER_ENTRY_SIZE;
        const uint32_t n_in = vd_blob_u32(e + LT_IN);
        const uint32_t n_out = vd_blob_u32(e + LT_OUT);
        const uint32_t offs[4] = {vd_blob_u32(e + LT_WEIGHTS), vd_blob_u32(e + LT_BIAS), vd_blob_u32(e + LT_MULT),
                                  vd_blob_u32(e + LT_SHIFT)};
        VD_VERIFY(vd_blob_u32(e + LT_FLAGS) == 0u && vd_blob_u32(e + LT_RESERVED) == 0u, VD_ERR_MODEL);
        VD_VERIFY(n_in == prev_out && n_in >= 1u && n_in <= VD_DBN_MAX_UNITS, VD_ERR_MODEL);
        VD_VERIFY(n_out >= 1u && n_out <= VD_DBN_MAX_UNITS, VD_ERR_MODEL);
        const uint64_t lens[4] = {(uint64_t)n_in * n_out, 4u * (uint64_t)n_out, 4u * (uint64_t)n_out,
                                  (uint64_t)n_out};
        for (uint32_t s = 0u; s < 4u; s++) {
            VD_VERIFY(vd_blob_segment_ok(offs[s], lens[s], table_end, total), VD_ERR_MODEL);
            seg[n_seg].off = offs[s];
            seg[n_seg].len = (uint32_t)lens[s];
            n_seg++;
        }
        vd_dbn_layer_t *ly = &tmp.layers[l];
        ly->weights = (const int8_t *)(const void *)(b + offs[0]);
        ly->bias_le = b + offs[1];
        ly->mult_le = b + offs[2];
        ly->shift = (const int8_t *)(const void *)(b + offs[3]);
        ly->in = n_in;
        ly->out = n_out;
        VD_VERIFY(layer_values_ok(ly), VD_ERR_MODEL);
        if (n_out > max_units) {
            max_units = n_out;
        }
        prev_out = n_out;
    }
    VD_VERIFY(prev_out == 1u, VD_ERR_MODEL);
    // Disjoint arrays: a crafted blob must not alias weights with multipliers.
    for (uint32_t i = 0u; i < n_seg; i++) {
        for (uint32_t j = i + 1u; j < n_seg; j++) {
            const uint64_t ai = seg[i].off, bi = ai + seg[i].len;
            const uint64_t aj = seg[j].off, bj = aj + seg[j].len;
            VD_VERIFY(bi <= aj || bj <= ai, VD_ERR_MODEL);
        }
    }

    tmp.blob = b;
    tmp.size = total;
    tmp.crc32 = crc;
    tmp.format_version = version;
    tmp.input_w = in_w;
    tmp.input_h = in_h;
    tmp.norm_divisor = norm_div;
    tmp.norm_offset = rd_i16(b + HDR_NORM_OFFSET);
    tmp.input_norm = (norm == (uint8_t)VD_DBN_NORM_MINMAX) ? VD_DBN_NORM_MINMAX : VD_DBN_NORM_NONE;
    tmp.norm_min_range = min_range;
    tmp.input_mode = (mode == (uint8_t)VD_DBN_INPUT_GREY) ? VD_DBN_INPUT_GREY : VD_DBN_INPUT_SHAPE;
    tmp.n_layers = n_layers;
    tmp.max_units = max_units;
    memcpy(tmp.name, b + HDR_NAME, HDR_NAME_LEN);
    tmp.name[HDR_NAME_LEN] = '\0';
    *m = tmp;
    return VD_OK;
}

// ---------------------------------------------------------------- inference

static bool model_loaded(const vd_dbn_model_t *m)
{
    return m->blob != NULL && m->n_layers >= 1u && m->n_layers <= VD_DBN_MAX_LAYERS && m->max_units >= 1u &&
           m->max_units <= VD_DBN_MAX_UNITS && m->input_w >= 1u && m->input_w <= VD_DBN_MAX_INPUT_DIM &&
           m->input_h >= 1u && m->input_h <= VD_DBN_MAX_INPUT_DIM &&
           (m->input_norm == VD_DBN_NORM_NONE || (m->input_norm == VD_DBN_NORM_MINMAX && m->norm_min_range >= 1u));
}

vd_status_t vd_dbn_stretch_u8(const uint8_t *in, uint32_t n, uint32_t min_range, uint8_t *out)
{
    VD_VERIFY(in != NULL && out != NULL && n >= 1u && min_range >= 1u && min_range <= 255u, VD_ERR_ARG);
    uint32_t lo = 255u;
    uint32_t hi = 0u;
    for (uint32_t i = 0u; i < n; i++) {
        lo = (in[i] < lo) ? in[i] : lo;
        hi = (in[i] > hi) ? in[i] : hi;
    }
    const uint32_t r = (hi - lo > min_range) ? hi - lo : min_range;
    // (v - lo) <= r, so the quotient <= (510 r + r) / (2 r) < 256; numerator < 2^17.
    for (uint32_t i = 0u; i < n; i++) {
        out[i] = (uint8_t)((((uint32_t)in[i] - lo) * 510u + r) / (2u * r));
    }
    return VD_OK;
}

vd_status_t vd_dbn_workspace_size(const vd_dbn_model_t *m, size_t *bytes)
{
    VD_VERIFY(m != NULL && bytes != NULL, VD_ERR_ARG);
    VD_VERIFY(model_loaded(m), VD_ERR_STATE);
    size_t total = 0u;
    VD_VERIFY(vd_size_add_slice(&total, m->max_units), VD_ERR_OVERFLOW);
    VD_VERIFY(vd_size_add_slice(&total, m->max_units), VD_ERR_OVERFLOW);
    if (m->input_norm != VD_DBN_NORM_NONE) {
        VD_VERIFY(vd_size_add_slice(&total, (size_t)m->input_w * m->input_h), VD_ERR_OVERFLOW);
    }
    *bytes = total;
    return VD_OK;
}

// One layer: out[o] = sigmoid(requantize(bias + w[o] . in)).
static void layer_forward(const vd_dbn_layer_t *l, const uint8_t *in, uint8_t *out)
{
    for (uint32_t o = 0u; o < l->out; o++) {
        const int8_t *w = l->weights + (size_t)o * l->in;
        int32_t acc = rd_i32(l->bias_le + 4u * (size_t)o);
        for (uint32_t i = 0u; i < l->in; i++) {
            acc += (int32_t)w[i] * (int32_t)in[i];
        }
        const int32_t z_q8 = vd_rq_requantize(acc, rd_i32(l->mult_le + 4u * (size_t)o), l->shift[o]);
        out[o] = vd_dbn_sigmoid_q8(z_q8);
    }
}

vd_status_t vd_dbn_classify(const vd_dbn_model_t *m, const uint8_t *input, void *ws, size_t bytes,
                            uint8_t *score_q8)
{
    VD_VERIFY(m != NULL && input != NULL && score_q8 != NULL, VD_ERR_ARG);
    VD_VERIFY(model_loaded(m), VD_ERR_STATE);
    size_t need;
    VD_TRY(vd_dbn_workspace_size(m, &need));
    vd_arena_t arena;
    VD_TRY(vd_arena_init(&arena, ws, bytes));
    VD_VERIFY(bytes >= need, VD_ERR_WORKSPACE);
    uint8_t *buf[2];
    buf[0] = (uint8_t *)vd_arena_take(&arena, m->max_units);
    buf[1] = (uint8_t *)vd_arena_take(&arena, m->max_units);
    VD_VERIFY(buf[0] != NULL && buf[1] != NULL, VD_ERR_WORKSPACE);

    const uint8_t *a = input;
    if (m->input_norm != VD_DBN_NORM_NONE) {
        const uint32_t n_in = (uint32_t)m->input_w * m->input_h;
        uint8_t *x = (uint8_t *)vd_arena_take(&arena, n_in);
        VD_VERIFY(x != NULL, VD_ERR_WORKSPACE);
        VD_TRY(vd_dbn_stretch_u8(input, n_in, m->norm_min_range, x));
        a = x;
    }
    uint32_t cur = 0u;
    for (uint32_t l = 0u; l < m->n_layers; l++) {
        layer_forward(&m->layers[l], a, buf[cur]);
        a = buf[cur];
        cur ^= 1u;
    }
    *score_q8 = a[0];
    return VD_OK;
}
