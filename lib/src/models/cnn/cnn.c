// SPDX-License-Identifier: MIT
// int8 CNN: in-place .vdm (version 3) validation, liveness-planned workspace, HWC kernels, decoding.
//
// Algorithm: a fully convolutional network over int8 HWC tensors (channels
// innermost). Tensor 0 is the grey frame as int8 (pixel - 128, or a per-frame
// percentile stretch), layer i writes tensor i+1 with one of six ops:
// 3x3 convolution and depthwise 3x3 (padding 1, stride 1/2), pointwise 1x1,
// 2x2 max-pool, x2 nearest upsample, channel concat, 5x5 convolution
// (padding 2, stride 1/2; op 7, paper 003's feature network). Weighted ops compute
//   out = clamp(zp_out + requantize(bias + sum w * (x - zp_in)), act_min, act_max)
// with TFLite's double-rounding requantisation (internal/requant.h, folded
// into one 64-bit floor shift per value). Decoding (CenterNet-like): 3x3
// local maxima of the heatmap channel with a raster-order tie rule, top-K by
// insertion, boxes from Q8 decode tables, rounded to frame pixels; a score
// threshold maps to a logit threshold by binary search of the score table.
// Kernels (plain C99 written for gcc/clang auto-vectorisation; HWC, so the
// innermost loops run over contiguous channels):
//  * CONV3X3 / CONV5X5 / PW1X1: blocks of 16 output pixels as int16 rows (x - zp_in),
//    zero-padded to a multiple of 8 (for CONV3X3/5X5 the 3x3/5x5 taps gathered,
//    padding taps 0), dotted with an int16 copy of the weights [cout][Kp]:
//    four int32 reductions at a time over fixed 8-wide chunks (pmaddwd),
//    then one requantisation loop per output channel over the 16 values with
//    the channel's constants loop-invariant (vectorised: pmuludq, psrlq).
//  * DW3X3: per output pixel, 9 tap pointers (a padding tap points at a row
//    filled with zp_in), 16 channels per pass with the 9 products written
//    out; |w x| <= 128 * 128 fits int16, so x - zp_in is hoisted into the
//    bias (bias - zp_in sum w) and products are 16-bit multiplies; without a
//    weight of -128 two products still fit int16 and are added before
//    widening.
// Optional x86-64 kernels (CMake VD_CNN_X86, lib/src/cnn_x86.c: AVX-512
// VNNI or AVX2, picked per call by a CPU check unless VD_CNN_PORTABLE) take
// over CONV / PW / DW in layer_rows with the same scratch and the same bytes.
// Reference: TFLite/CMSIS-NN int8 quantisation; the numpy integer reference
// tools/vdtools/formats/cnn_ref.py (bit-exact); format docs/model-format.md ("CNN
// kind"), arithmetic docs/fixed-point.md ("cnn").
// Bounds: load O(total_size) (CRC, per-channel arrays, decode table) plus
// O((4 L + 1)^2) overlap checks. Run: vd_cnn_macs() multiply-adds, one
// requantisation per output value, O(width*height) for the input; the plan
// (O(items^2), items <= 2 + 2 L) lives in the workspace's run record.
// Streamed (VD_CNN_STREAM, the "row schedule" section below): the same
// kernels on ring-buffer rows, so the head is bit-identical; the schedule
// adds O((H0 + Hn) L) counter updates per run, the plan's ring sizing
// O((H0 + Hn) L^2). Stack (Cortex-M7 -Os, worst call chain): load ~420 B,
// run ~1.1 KiB, workspace query ~1.5 KiB (the plan), vd_cnn_tensor ~320 B
// (reads the run record), decode ~380 B. Accumulators: |sum w (x - zp)|
// <= K * 128 * 255 < 2^31 for K <= 25 * 1024, and the loader's bias bound
// |bias| <= INT32_MAX - K * 128 * 255 makes the whole sum fit int32 for every
// int8 weight including -128 (the addition is still done modulo 2^32, so a
// wrong bound could never be undefined behaviour).
#include "vd/cnn.h"

#include "models/cnn/cnn_internal.h"
#include "internal/blob_internal.h"
#include "internal/crc32.h"
#include "internal/requant.h"
#include "internal/vd_internal.h"
#if defined(VD_CNN_X86)
#include "models/cnn/cnn_x86.h"
#endif

#include <string.h>

#if VD_CNN_MAX_LAYERS < 1 || VD_CNN_MAX_LAYERS > 32
#error "VD_CNN_MAX_LAYERS must be 1..32 (format version 3; tensor indices and lifetimes are bytes)"
#endif

// Keeps a kernel out of its caller. Inlined into the layer loop, gcc -O3
// vectorises the pixel-block loop of gemm_block instead of the dot products
// and the whole network runs 2.5x slower (measured, gcc 12); the layer
// kernels kept apart also keep vd_cnn_run's frame small (their locals are
// not summed). A hint only: compilers without the attribute get plain C.
#if defined(__GNUC__)
#define CNN_NOINLINE __attribute__((noinline))
#else
#define CNN_NOINLINE
#endif

// Header fields.
// Bytes 0..15: the container (magic, version, sizes; internal/blob_internal.h checks it).
#define H_CRC 12u
#define H_KIND 16u
#define H_NORM 17u
#define H_N_LAYERS 18u
#define H_OUT_CH 19u
#define H_IN_W 20u
#define H_IN_H 22u
#define H_NORM_LO 24u
#define H_NORM_HI 26u
#define H_NORM_MIN 28u
#define H_IN_ZP 30u
#define H_OUT_STRIDE 31u
#define H_LAYER_TABLE 32u
#define H_DECODE 36u
#define H_THR 40u
#define H_RES0 41u
#define H_MAX_PEAKS 42u
#define H_FLAGS 44u
#define H_NAME 48u
#define H_NAME_LEN 16u
#define H_RES1 64u

// Layer entry fields.
#define E_OP 0u
#define E_STRIDE 1u
#define E_IN 2u
#define E_IN2 3u
#define E_CIN 4u
#define E_COUT 6u
#define E_ZP 8u
#define E_AMIN 9u
#define E_AMAX 10u
#define E_RES0 11u
#define E_W 12u
#define E_BIAS 16u
#define E_MULT 20u
#define E_SHIFT 24u
#define E_RES1 28u

#define CNN_FLAGS (VD_CNN_KEEP_TENSORS | VD_CNN_STREAM | VD_CNN_PORTABLE)   // every flag of the _ex calls
#define MAX_ABS_PRODUCT (128L * 255L)   // weights may be -128: |w (x - zp)| <= 128 * 255
#define INPUT_ZP (-128)


// ------------------------------------------------------------ byte reading

static int32_t rd_i32(const uint8_t *p)
{
    return vd_rq_u32_to_i32(vd_blob_u32(p));
}

static int8_t u8_to_i8(uint8_t u)
{
    return (u <= 127u) ? (int8_t)u : (int8_t)((int32_t)u - 256);
}

static uint32_t round_up(uint32_t n, uint32_t a)
{
    return (n + a - 1u) / a * a;
}

// ------------------------------------------------------------ layer chain

// Tensor shapes implied by the layers: channels, downsample factor, zero point.
typedef struct chain {
    uint16_t chan[VD_CNN_MAX_TENSORS];
    uint16_t f[VD_CNN_MAX_TENSORS];
    int8_t zp[VD_CNN_MAX_TENSORS];
} chain_t;

static bool weighted(uint32_t op)
{
    return op == VD_CNN_OP_CONV3X3 || op == VD_CNN_OP_DW3X3 || op == VD_CNN_OP_PW1X1 || op == VD_CNN_OP_CONV5X5;
}

// Full convolutions with a spatial kernel (taps gathered into int16 rows).
static bool spatial_conv(uint32_t op)
{
    return op == VD_CNN_OP_CONV3X3 || op == VD_CNN_OP_CONV5X5;
}

// Pure copies (no weights, no requantisation).
static bool copy_op(uint32_t op)
{
    return op == VD_CNN_OP_MAXPOOL2 || op == VD_CNN_OP_UPSAMPLE2 || op == VD_CNN_OP_CONCAT;
}

// K of the accumulator bound (multiply-adds per output value).
static uint32_t k_of(const vd_cnn_layer_t *L)
{
    switch (L->op) {
    case VD_CNN_OP_CONV3X3:
        return 9u * L->cin;
    case VD_CNN_OP_DW3X3:
        return 9u;
    case VD_CNN_OP_PW1X1:
        return L->cin;
    case VD_CNN_OP_CONV5X5:
        return 25u * L->cin;
    default:
        return 0u;
    }
}

// Byte lengths of the four arrays of a layer (weights, bias, mult, shift).
static void array_lens(const vd_cnn_layer_t *L, uint32_t len[4])
{
    const uint32_t cout = L->cout;
    len[0] = (L->op == VD_CNN_OP_DW3X3) ? 9u * cout : k_of(L) * cout;
    len[1] = weighted(L->op) ? 4u * cout : 0u;
    len[2] = len[1];
    len[3] = weighted(L->op) ? cout : 0u;
}

// Structural rules of layer l given the tensors before it; on success the
// shape of tensor l+1 is appended to c. Shared by the loader and the state
// check of run, so a model struct that was not made by vd_cnn_load cannot
// index outside its tensors.
static bool chain_step(const vd_cnn_layer_t *L, uint32_t l, chain_t *c)
{
    const uint32_t op = L->op;
    if (op < VD_CNN_OP_CONV3X3 || op > VD_CNN_OP_CONV5X5) {
        return false;
    }
    const uint32_t max_stride = (spatial_conv(op) || op == VD_CNN_OP_DW3X3) ? 2u : 1u;
    if (L->stride < 1u || L->stride > max_stride || L->in > l) {
        return false;
    }
    if (op == VD_CNN_OP_CONCAT ? L->in2 > l : L->in2 != 0u) {
        return false;
    }
    if (L->cin < 1u || L->cin > VD_CNN_MAX_CHANNELS || L->cout < 1u || L->cout > VD_CNN_MAX_CHANNELS) {
        return false;
    }
    if (L->cin != c->chan[L->in] || L->act_min > L->act_max) {
        return false;
    }
    uint32_t f = c->f[L->in];
    if (spatial_conv(op) || op == VD_CNN_OP_DW3X3) {
        f *= L->stride;
    } else if (op == VD_CNN_OP_MAXPOOL2) {
        f *= 2u;
    } else if (op == VD_CNN_OP_UPSAMPLE2) {
        if (f < 2u) {
            return false;
        }
        f /= 2u;
    }
    if (f > VD_CNN_MAX_FACTOR) {
        return false;
    }
    if ((op == VD_CNN_OP_DW3X3 || op == VD_CNN_OP_MAXPOOL2 || op == VD_CNN_OP_UPSAMPLE2) && L->cout != L->cin) {
        return false;
    }
    if (copy_op(op)) {
        // Copies without requantising: same scale and zero point, no clamp.
        if (L->act_min != -128 || L->act_max != 127 || L->out_zp != c->zp[L->in]) {
            return false;
        }
        if (L->w != NULL || L->bias != NULL || L->mult != NULL || L->shift != NULL) {
            return false;
        }
    } else if (L->w == NULL || L->bias == NULL || L->mult == NULL || L->shift == NULL) {
        return false;
    }
    if (op == VD_CNN_OP_CONCAT) {
        const uint32_t b = L->in2;
        if ((uint32_t)L->cout != (uint32_t)L->cin + c->chan[b] || c->f[b] != c->f[L->in] || c->zp[b] != c->zp[L->in]) {
            return false;
        }
    }
    c->chan[l + 1u] = L->cout;
    c->f[l + 1u] = (uint16_t)f;
    c->zp[l + 1u] = L->out_zp;
    return true;
}

// The whole chain of m; false if any rule fails or the head does not match
// the header. *align receives the largest factor.
static bool chain_make(const vd_cnn_model_t *m, chain_t *c, uint32_t *align)
{
    c->chan[0] = 1u;
    c->f[0] = 1u;
    c->zp[0] = INPUT_ZP;
    uint32_t a = 1u;
    for (uint32_t l = 0u; l < m->n_layers; l++) {
        if (!chain_step(&m->layers[l], l, c)) {
            return false;
        }
        a = (c->f[l + 1u] > a) ? c->f[l + 1u] : a;
    }
    *align = a;
    return c->chan[m->n_layers] == m->out_channels && c->f[m->n_layers] == m->out_stride;
}

// ------------------------------------------------------------------ loader

// Layer entry l of the blob as a vd_cnn_layer_t (array pointers set when
// the offsets are nonzero; they are range-checked separately). offs gets the
// four raw offsets.
static void entry_read(const uint8_t *b, uint32_t table, uint32_t l, vd_cnn_layer_t *L, uint32_t offs[4])
{
    const uint8_t *e = b + table + l * VD_CNN_LAYER_ENTRY_SIZE;
    L->op = e[E_OP];
    L->stride = e[E_STRIDE];
    L->in = e[E_IN];
    L->in2 = e[E_IN2];
    L->cin = vd_blob_u16(e + E_CIN);
    L->cout = vd_blob_u16(e + E_COUT);
    L->out_zp = u8_to_i8(e[E_ZP]);
    L->act_min = u8_to_i8(e[E_AMIN]);
    L->act_max = u8_to_i8(e[E_AMAX]);
    offs[0] = vd_blob_u32(e + E_W);
    offs[1] = vd_blob_u32(e + E_BIAS);
    offs[2] = vd_blob_u32(e + E_MULT);
    offs[3] = vd_blob_u32(e + E_SHIFT);
    L->w = offs[0] ? (const int8_t *)(const void *)(b + offs[0]) : NULL;
    L->bias = offs[1] ? b + offs[1] : NULL;
    L->mult = offs[2] ? b + offs[2] : NULL;
    L->shift = offs[3] ? (const int8_t *)(const void *)(b + offs[3]) : NULL;
}

// Per-channel checks: multiplier, shift, bias bound (no int32 overflow).
static bool values_ok(const vd_cnn_layer_t *L)
{
    const int64_t bias_max = (int64_t)INT32_MAX - (int64_t)k_of(L) * MAX_ABS_PRODUCT;
    for (uint32_t o = 0u; o < L->cout; o++) {
        const int32_t mult = rd_i32(L->mult + 4u * (size_t)o);
        const int64_t bias = rd_i32(L->bias + 4u * (size_t)o);
        const int32_t sh = L->shift[o];
        if (mult < VD_RQ_MULT_MIN || sh < VD_RQ_SHIFT_MIN || sh > VD_RQ_SHIFT_MAX) {
            return false;
        }
        if (bias > bias_max || bias < -bias_max) {
            return false;
        }
    }
    return true;
}

// Array s of the blob: s < 4 n_layers is array s % 4 of layer s / 4, s ==
// 4 n_layers the decode table. Read back from the blob so the overlap check
// needs no list on the stack.
static void segment_get(const uint8_t *b, uint32_t table, uint32_t n_layers, uint32_t dec_off, uint32_t dec_len,
                        uint32_t s, uint32_t *off, uint32_t *len)
{
    if (s == 4u * n_layers) {
        *off = dec_off;
        *len = dec_len;
        return;
    }
    vd_cnn_layer_t L;
    uint32_t offs[4], lens[4];
    entry_read(b, table, s / 4u, &L, offs);
    array_lens(&L, lens);
    *off = offs[s % 4u];
    *len = lens[s % 4u];
}

static bool decode_table_ok(const uint8_t *t, uint32_t n_ch)
{
    int32_t prev = 0;
    for (uint32_t ch = 0u; ch < n_ch; ch++) {
        for (uint32_t i = 0u; i < 256u; i++) {
            const int32_t v = rd_i32(t + 4u * (ch * 256u + i));
            if (ch == 0u) {
                // Score: Q15 probability, non-decreasing in the logit.
                if (v < 0 || v > VD_CNN_SCORE_ONE_Q15 || (i > 0u && v < prev)) {
                    return false;
                }
                prev = v;
            } else if (ch <= 2u) {
                if (v < 0 || (int64_t)v > VD_CNN_SIZE_MAX_Q8) {
                    return false;
                }
            } else if (v < VD_CNN_OFFSET_MIN_Q8 || v > VD_CNN_OFFSET_MAX_Q8) {
                return false;
            }
        }
    }
    return true;
}

vd_status_t vd_cnn_load(vd_cnn_model_t *m, const void *blob, size_t bytes)
{
    VD_VERIFY(m != NULL && blob != NULL && bytes != 0u, VD_ERR_ARG);
    VD_VERIFY(((uintptr_t)blob % 4u) == 0u, VD_ERR_ARG);
    const uint8_t *b = (const uint8_t *)blob;
    // Container, before trusting any size.
    uint16_t version;
    uint32_t total;
    VD_TRY(vd_blob_container(b, bytes, VD_CNN_FORMAT_VERSION, VD_CNN_FORMAT_VERSION, VD_CNN_HEADER_SIZE, &version,
                             &total));
    const uint32_t crc = vd_blob_u32(b + H_CRC);   // checked by vd_blob_container

    // Header fields.
    const uint32_t norm = b[H_NORM];
    const uint32_t n_layers = b[H_N_LAYERS];
    const uint32_t n_ch = b[H_OUT_CH];
    const uint32_t in_w = vd_blob_u16(b + H_IN_W);
    const uint32_t in_h = vd_blob_u16(b + H_IN_H);
    const uint32_t lo = vd_blob_u16(b + H_NORM_LO);
    const uint32_t hi = vd_blob_u16(b + H_NORM_HI);
    const uint32_t min_range = vd_blob_u16(b + H_NORM_MIN);
    const uint32_t out_stride = b[H_OUT_STRIDE];
    const uint32_t table = vd_blob_u32(b + H_LAYER_TABLE);
    const uint32_t dec_off = vd_blob_u32(b + H_DECODE);
    const uint32_t max_peaks = vd_blob_u16(b + H_MAX_PEAKS);
    VD_VERIFY(b[H_KIND] == VD_CNN_KIND, VD_ERR_MODEL);
    if (norm == VD_CNN_NORM_NONE) {
        VD_VERIFY(lo == 0u && hi == 0u && min_range == 0u, VD_ERR_MODEL);
    } else {
        VD_VERIFY(norm == VD_CNN_NORM_PERCENTILE && lo < hi && hi <= 1000u && min_range >= 1u && min_range <= 255u,
                  VD_ERR_MODEL);
    }
    VD_VERIFY(n_layers >= 1u && n_layers <= VD_CNN_MAX_LAYERS, VD_ERR_MODEL);
    VD_VERIFY(n_ch == 3u || n_ch == 5u, VD_ERR_MODEL);
    VD_VERIFY(in_w >= 1u && in_w <= VD_CNN_MAX_SIDE && in_h >= 1u && in_h <= VD_CNN_MAX_SIDE, VD_ERR_MODEL);
    VD_VERIFY(u8_to_i8(b[H_IN_ZP]) == INPUT_ZP, VD_ERR_MODEL);
    VD_VERIFY(out_stride == 4u || out_stride == 8u, VD_ERR_MODEL);
    VD_VERIFY(b[H_RES0] == 0u && vd_blob_u32(b + H_FLAGS) == 0u, VD_ERR_MODEL);
    VD_VERIFY(max_peaks >= 1u && max_peaks <= VD_CNN_MAX_PEAKS, VD_ERR_MODEL);
    VD_VERIFY(vd_blob_name_ok(b + H_NAME, H_NAME_LEN), VD_ERR_MODEL);
    VD_VERIFY(vd_blob_all_zero(b + H_RES1, VD_CNN_HEADER_SIZE - H_RES1), VD_ERR_MODEL);
    VD_VERIFY(table >= VD_CNN_HEADER_SIZE && (table % 4u) == 0u, VD_ERR_MODEL);
    VD_VERIFY((uint64_t)table + (uint64_t)n_layers * VD_CNN_LAYER_ENTRY_SIZE <= (uint64_t)total, VD_ERR_MODEL);
    const uint32_t table_end = table + n_layers * VD_CNN_LAYER_ENTRY_SIZE;
    const uint32_t dec_len = 4u * 256u * n_ch;
    VD_VERIFY(vd_blob_segment_ok(dec_off, dec_len, table_end, total), VD_ERR_MODEL);

    // Layers: fields, arrays in range, chain rules, per-channel values.
    chain_t c;
    c.chan[0] = 1u;
    c.f[0] = 1u;
    c.zp[0] = INPUT_ZP;
    uint32_t align = 1u;
    for (uint32_t l = 0u; l < n_layers; l++) {
        vd_cnn_layer_t L;
        uint32_t offs[4], lens[4];
        entry_read(b, table, l, &L, offs);
        const uint8_t *e = b + table + l * VD_CNN_LAYER_ENTRY_SIZE;
        VD_VERIFY(e[E_RES0] == 0u && vd_blob_u32(e + E_RES1) == 0u, VD_ERR_MODEL);
        // Chain first: it bounds cin and cout, so the array lengths below
        // cannot wrap (25 * 1024 * 1024 < 2^32).
        VD_VERIFY(chain_step(&L, l, &c), VD_ERR_MODEL);
        array_lens(&L, lens);
        for (uint32_t s = 0u; s < 4u; s++) {
            if (lens[s] == 0u) {
                VD_VERIFY(offs[s] == 0u, VD_ERR_MODEL);
            } else {
                VD_VERIFY(vd_blob_segment_ok(offs[s], lens[s], table_end, total), VD_ERR_MODEL);
            }
        }
        if (weighted(L.op)) {
            VD_VERIFY(values_ok(&L), VD_ERR_MODEL);
        }
        align = (c.f[l + 1u] > align) ? c.f[l + 1u] : align;
    }
    VD_VERIFY(c.chan[n_layers] == n_ch && c.f[n_layers] == out_stride, VD_ERR_MODEL);
    VD_VERIFY(in_w % align == 0u && in_h % align == 0u, VD_ERR_MODEL);

    // Disjoint arrays: a crafted blob must not alias weights with multipliers.
    const uint32_t n_seg = 4u * n_layers + 1u;
    for (uint32_t i = 0u; i < n_seg; i++) {
        uint32_t oi, li;
        segment_get(b, table, n_layers, dec_off, dec_len, i, &oi, &li);
        if (li == 0u) {
            continue;
        }
        for (uint32_t j = i + 1u; j < n_seg; j++) {
            uint32_t oj, lj;
            segment_get(b, table, n_layers, dec_off, dec_len, j, &oj, &lj);
            VD_VERIFY(lj == 0u || (uint64_t)oi + li <= oj || (uint64_t)oj + lj <= oi, VD_ERR_MODEL);
        }
    }
    VD_VERIFY(decode_table_ok(b + dec_off, n_ch), VD_ERR_MODEL);

    // Everything checked: fill *m (cannot fail from here).
    m->blob = b;
    m->size = total;
    m->crc32 = crc;
    m->format_version = (uint16_t)VD_CNN_FORMAT_VERSION;
    m->input_norm = (uint8_t)norm;
    m->out_channels = (uint8_t)n_ch;
    m->input_w = (uint16_t)in_w;
    m->input_h = (uint16_t)in_h;
    m->norm_lo_permille = (uint16_t)lo;
    m->norm_hi_permille = (uint16_t)hi;
    m->norm_min_range = (uint16_t)min_range;
    m->input_zp = INPUT_ZP;
    m->out_stride = (uint8_t)out_stride;
    m->score_threshold_q = u8_to_i8(b[H_THR]);
    m->max_peaks = (uint16_t)max_peaks;
    m->align = align;
    memcpy(m->name, b + H_NAME, H_NAME_LEN);
    m->name[H_NAME_LEN] = '\0';
    m->n_layers = n_layers;
    memset(m->layers, 0, sizeof m->layers);
    for (uint32_t l = 0u; l < n_layers; l++) {
        uint32_t offs[4];
        entry_read(b, table, l, &m->layers[l], offs);
    }
    m->decode_table = b + dec_off;
    return VD_OK;
}

// State check of a model struct: cheap, and enough that run and decode stay
// inside the tensors whatever the struct holds (the array pointers into the
// blob are trusted, as vd_cnn_load set them).
static bool model_ok(const vd_cnn_model_t *m, chain_t *c)
{
    uint32_t align = 0u;
    if (m->blob == NULL || m->decode_table == NULL || m->n_layers < 1u || m->n_layers > VD_CNN_MAX_LAYERS ||
        (m->out_channels != 3u && m->out_channels != 5u) || (m->out_stride != 4u && m->out_stride != 8u) ||
        m->input_norm > VD_CNN_NORM_PERCENTILE || m->input_zp != INPUT_ZP) {
        return false;
    }
    if (m->input_norm == VD_CNN_NORM_PERCENTILE &&
        !(m->norm_lo_permille < m->norm_hi_permille && m->norm_hi_permille <= 1000u && m->norm_min_range >= 1u &&
          m->norm_min_range <= 255u)) {
        return false;
    }
    return chain_make(m, c, &align) && align == m->align;
}

static bool size_ok(const vd_cnn_model_t *m, uint32_t width, uint32_t height)
{
    return width >= 1u && width <= VD_CNN_MAX_SIDE && height >= 1u && height <= VD_CNN_MAX_SIDE &&
           width % m->align == 0u && height % m->align == 0u;
}

// ------------------------------------------------------------------ planner

static uint32_t item_of_tensor(uint32_t t)
{
    return (t == 0u) ? 0u : 2u + 2u * (t - 1u);
}

// Scratch of a weighted layer, as offsets from its start: int16 weights,
// int16 rows (CONV3X3/PW1X1) or the zero-point row (DW3X3), then the
// per-channel requantisation constants (vd_rq_ch_t). Returns the total in bytes.
typedef struct scratch_layout {
    uint32_t w16, rows, ch;
} scratch_layout_t;

// Output channels whose int16 weights a CONV / PW scratch holds at once:
// all of them, or at most VD_CNN_STREAM_COUT when streamed (one scratch
// serves every layer, so the largest layer's weight copy would set it).
static uint32_t chunk_of(const vd_cnn_layer_t *L, bool stream)
{
    return (stream && L->cout > VD_CNN_STREAM_COUT) ? VD_CNN_STREAM_COUT : L->cout;
}

static uint64_t scratch_layout(const vd_cnn_layer_t *L, bool stream, scratch_layout_t *s)
{
    uint32_t w_bytes, r_bytes;
    if (L->op == VD_CNN_OP_DW3X3) {
        const uint32_t cp = round_up(L->cout, VD_CNN_DWB);
        w_bytes = 2u * 9u * cp;
        r_bytes = cp;
    } else if (spatial_conv(L->op) || L->op == VD_CNN_OP_PW1X1) {
        const uint32_t kp = round_up(k_of(L), VD_CNN_KCHUNK);
        w_bytes = 2u * chunk_of(L, stream) * kp;
        r_bytes = 2u * VD_CNN_NPIX * kp;
    } else {
        memset(s, 0, sizeof *s);
        return 0u;
    }
    // Each piece starts at a multiple of VD_CNN_ITEM_ALIGN; cin, cout <= 1024
    // keep every size below 2^26.
    s->w16 = 0u;
    s->rows = round_up(w_bytes, VD_CNN_ITEM_ALIGN);
    s->ch = s->rows + round_up(r_bytes, VD_CNN_ITEM_ALIGN);
    return (uint64_t)s->ch + round_up((uint32_t)(L->cout * sizeof(vd_rq_ch_t)), VD_CNN_ITEM_ALIGN);
}

// Bytes of `rows` rows of tensor t at input width `width`.
static uint64_t tensor_bytes(const chain_t *c, uint32_t t, uint32_t width, uint32_t rows)
{
    return (uint64_t)(width / c->f[t]) * (uint64_t)rows * (uint64_t)c->chan[t];
}

// ------------------------------------------------------------------ row schedule
//
// The streamed executor (VD_CNN_STREAM) keeps every tensor but the head as
// a ring of full-width rows. For head rows T = B, 2B, .. (B =
// VD_CNN_BAND_ROWS) it first pulls: walking the layers backwards, the rows
// each tensor must have so that the head has T rows (p->need; rows_read of
// the consumers' last needed row, clamped). Then it pushes in sub-steps:
// tensor 0 gains VD_CNN_BAND_IN_ROWS (1) input rows, and in layer order
// every tensor makes the rows whose input rows exist, up to its need. Pull alone would make the
// whole receptive field of the first head row in one batch per tensor (an
// encoder tensor would hold tens of rows); push alone would finish every
// decoder tensor in one batch when the last input row arrives. Together a
// tensor holds its consumers' kernel rows plus what a skip must bridge.
// The plan runs the same walk without computing (sched_next) and keeps per
// tensor the largest span from the oldest row a live consumer will still
// read to the newest row written: that is the ring height.
// Tensors the head does not depend on are never computed.
// Bounds: Hn / B pulls of O(n_layers); at most H0 + Hn + 1 sub-steps of
// O(n_layers) plus O(rows made); sizing adds O(n_layers) per batch.

// Rows [*lo, *hi] of the input tensor(s) that output row y of L reads,
// before clamping (rows outside the input are padding).
static void rows_read(const vd_cnn_layer_t *L, uint32_t y, int32_t *lo, int32_t *hi)
{
    const int32_t s = L->stride;
    const int32_t yy = (int32_t)y;
    switch (L->op) {
    case VD_CNN_OP_CONV3X3:
    case VD_CNN_OP_DW3X3:
        *lo = s * yy - 1;
        *hi = s * yy + 1;
        break;
    case VD_CNN_OP_CONV5X5:
        *lo = s * yy - 2;
        *hi = s * yy + 2;
        break;
    case VD_CNN_OP_MAXPOOL2:
        *lo = 2 * yy;
        *hi = 2 * yy + 1;
        break;
    case VD_CNN_OP_UPSAMPLE2:
        *lo = yy / 2;
        *hi = yy / 2;
        break;
    default:   // PW1X1, CONCAT
        *lo = yy;
        *hi = yy;
        break;
    }
}

// Last input row (clamped to the input's last row hlast) that output row y reads.
static uint32_t row_hi(const vd_cnn_layer_t *L, uint32_t y, uint32_t hlast)
{
    int32_t lo, hi;
    rows_read(L, y, &lo, &hi);
    (void)lo;
    return ((uint32_t)hi < hlast) ? (uint32_t)hi : hlast;
}

static bool reads(const vd_cnn_layer_t *L, uint32_t t)
{
    return L->in == t || (L->op == VD_CNN_OP_CONCAT && L->in2 == t);
}

// p->live value of an upsample fused into the concats that read it (below).
#define LIVE_FUSED 2u

// Tensor heights and liveness (p->h, p->live) of a plan. Streamed without
// VD_CNN_KEEP_TENSORS, an upsample output whose every live consumer is a
// concat is fused into them (LIVE_FUSED): never stored or computed, the
// concat reads its source's row y / 2, column x / 2 instead. That drops the
// upsampled rings, twice the source's row bytes each (models/vd_cnn.vdm at
// 320x256: 7 680 B).
static void sched_init(const vd_cnn_model_t *m, const chain_t *c, uint32_t height, uint32_t flags, vd_cnn_plan_t *p)
{
    const uint32_t n = m->n_layers;
    for (uint32_t t = 0u; t <= n; t++) {
        p->h[t] = (uint16_t)(height / c->f[t]);
        p->live[t] = (t == n) ? 1u : 0u;
    }
    for (uint32_t l = n; l-- > 0u;) {
        const vd_cnn_layer_t *L = &m->layers[l];
        if (p->live[l + 1u] != 0u) {
            p->live[L->in] = 1u;
            p->live[L->in2] = (L->op == VD_CNN_OP_CONCAT) ? 1u : p->live[L->in2];
        }
    }
    if ((flags & VD_CNN_STREAM) == 0u || (flags & VD_CNN_KEEP_TENSORS) != 0u) {
        return;
    }
    for (uint32_t l = 0u; l + 1u < n; l++) {   // never the head
        if (m->layers[l].op != VD_CNN_OP_UPSAMPLE2 || p->live[l + 1u] == 0u) {
            continue;
        }
        bool only_concat = true;
        for (uint32_t k = l + 1u; k < n && only_concat; k++) {
            const vd_cnn_layer_t *K = &m->layers[k];
            only_concat = p->live[k + 1u] == 0u || !reads(K, l + 1u) || K->op == VD_CNN_OP_CONCAT;
        }
        p->live[l + 1u] = only_concat ? (uint8_t)LIVE_FUSED : p->live[l + 1u];
    }
}

// Pull: p->need, the rows every tensor must have for `target` head rows.
static void sched_pull(const vd_cnn_model_t *m, vd_cnn_plan_t *p, uint32_t target)
{
    const uint32_t n = m->n_layers;
    for (uint32_t t = 0u; t < n; t++) {
        p->need[t] = p->done[t];
    }
    p->need[n] = (uint16_t)target;
    for (uint32_t l = n; l-- > 0u;) {
        const vd_cnn_layer_t *L = &m->layers[l];
        if (p->live[l + 1u] == 0u || p->need[l + 1u] == 0u) {
            continue;
        }
        const uint32_t r = row_hi(L, p->need[l + 1u] - 1u, p->h[L->in] - 1u) + 1u;
        p->need[L->in] = (uint16_t)((r > p->need[L->in]) ? r : p->need[L->in]);
        if (L->op == VD_CNN_OP_CONCAT) {
            p->need[L->in2] = (uint16_t)((r > p->need[L->in2]) ? r : p->need[L->in2]);
        }
    }
}

// Push: p->req, the rows every tensor has after one sub-step: tensor 0
// VD_CNN_BAND_IN_ROWS more input rows (up to its need), then in layer order
// each computed tensor every row whose input rows exist, up to its need.
static void sched_push(const vd_cnn_model_t *m, vd_cnn_plan_t *p)
{
    const uint32_t n = m->n_layers;
    const uint32_t in_next = p->done[0] + VD_CNN_BAND_IN_ROWS;
    p->req[0] = (uint16_t)((in_next < p->need[0]) ? in_next : ((p->done[0] < p->need[0]) ? p->need[0] : p->done[0]));
    for (uint32_t t = 1u; t <= n; t++) {
        const vd_cnn_layer_t *L = &m->layers[t - 1u];
        uint32_t y = p->done[t];
        if (p->live[t] != 0u) {
            uint32_t avail = p->req[L->in];
            if (L->op == VD_CNN_OP_CONCAT && p->req[L->in2] < avail) {
                avail = p->req[L->in2];
            }
            const uint32_t hlast = (uint32_t)p->h[L->in] - 1u;
            // Bounded by the need (<= the tensor height): one row per pass.
            while (y < p->need[t] && row_hi(L, y, hlast) < avail) {
                y++;
            }
        }
        p->req[t] = (uint16_t)y;
    }
}

// The oldest input row that layer L, which makes tensor u, still reads
// (UINT32_MAX once u is complete).
static uint32_t consumer_row(const vd_cnn_layer_t *L, const vd_cnn_plan_t *p, uint32_t u)
{
    if (p->done[u] >= p->h[u]) {
        return UINT32_MAX;
    }
    int32_t lo, hi;
    rows_read(L, p->done[u], &lo, &hi);
    (void)hi;
    return (lo > 0) ? (uint32_t)lo : 0u;
}

// Oldest row of tensor u that its live consumers still read (p->req[u] when
// none). For the consumers of a fused upsample, which are never fused.
static uint32_t read_oldest(const vd_cnn_model_t *m, const vd_cnn_plan_t *p, uint32_t u)
{
    uint32_t oldest = p->req[u];
    for (uint32_t l = u; l < m->n_layers; l++) {
        if (p->live[l + 1u] != 0u && reads(&m->layers[l], u)) {
            const uint32_t r = consumer_row(&m->layers[l], p, l + 1u);
            oldest = (r < oldest) ? r : oldest;
        }
    }
    return oldest;
}

// Oldest row of tensor t that a live, unfinished consumer still reads
// (p->req[t] when none). Row y of a fused upsample of t is row y / 2 of t,
// read when the upsample's concats read it.
static uint32_t sched_oldest(const vd_cnn_model_t *m, const vd_cnn_plan_t *p, uint32_t t)
{
    uint32_t oldest = p->req[t];
    for (uint32_t l = t; l < m->n_layers; l++) {
        if (p->live[l + 1u] == 0u || !reads(&m->layers[l], t)) {
            continue;
        }
        const uint32_t r = (p->live[l + 1u] == LIVE_FUSED) ? read_oldest(m, p, l + 1u) / 2u
                                                           : consumer_row(&m->layers[l], p, l + 1u);
        oldest = (r < oldest) ? r : oldest;
    }
    return oldest;
}

// Next sub-step of the streamed schedule into p->req (rows to make: req[t]
// > done[t]; the caller makes them and sets done = req); false once the
// head is complete. *target: head rows of the current band, 0 to start
// (with p->done all 0). Each call adds an input row or completes the band's
// need (sched_push), so a walk takes at most H0 + Hn + 1 calls. The plan
// (ring sizing) and the run iterate the same way, so they make the same
// rows in the same order.
static bool sched_next(const vd_cnn_model_t *m, vd_cnn_plan_t *p, uint32_t *target)
{
    const uint32_t n = m->n_layers;
    if (p->done[n] >= *target) {
        if (*target >= p->h[n]) {
            return false;
        }
        *target = (*target + VD_CNN_BAND_ROWS < p->h[n]) ? *target + VD_CNN_BAND_ROWS : p->h[n];
        sched_pull(m, p, *target);
    }
    sched_push(m, p);
    return true;
}

static void sched_start(vd_cnn_plan_t *p, uint32_t *target, uint32_t *max_steps)
{
    memset(p->done, 0, sizeof p->done);
    memset(p->req, 0, sizeof p->req);
    *target = 0u;
    *max_steps = (uint32_t)p->h[0] + p->h[0] + 2u;   // H0 + Hn + 1 < 2 H0 + 2
}

// p->rows: ring heights. Whole plane: every tensor's height. Streamed: the
// walk above; the head (read by vd_cnn_decode) stays whole, and with
// VD_CNN_KEEP_TENSORS every computed tensor does.
static void sched_rows(const vd_cnn_model_t *m, const chain_t *c, uint32_t height, uint32_t flags, vd_cnn_plan_t *p)
{
    const uint32_t n = m->n_layers;
    sched_init(m, c, height, flags, p);
    const bool stream = (flags & VD_CNN_STREAM) != 0u;
    const bool keep = (flags & VD_CNN_KEEP_TENSORS) != 0u;
    for (uint32_t t = 0u; t <= n; t++) {
        p->rows[t] = (!stream || ((keep || t == n) && p->live[t] != 0u)) ? p->h[t] : 0u;
    }
    if (!stream) {
        return;
    }
    // Ring heights: per tensor the largest span from the oldest row a live
    // consumer still reads to the newest row made.
    uint32_t target, max_steps;
    sched_start(p, &target, &max_steps);
    for (uint32_t k = 0u; k < max_steps && sched_next(m, p, &target); k++) {
        for (uint32_t t = 0u; t <= n; t++) {
            if (p->req[t] > p->done[t]) {
                const uint32_t span = p->req[t] - sched_oldest(m, p, t);
                p->rows[t] = (uint16_t)((span > p->rows[t]) ? span : p->rows[t]);
                p->done[t] = p->req[t];
            }
        }
    }
    VD_ASSERT(p->done[n] == p->h[n]);
    for (uint32_t t = 0u; t <= n; t++) {
        // A computed tensor is read, so some batch had a span >= 1; the
        // floor only keeps ring_row's modulo defined whatever happens. A
        // fused upsample has no rows.
        const uint32_t min_rows = (p->live[t] == LIVE_FUSED || p->live[t] == 0u) ? 0u : 1u;
        p->rows[t] = (p->live[t] == LIVE_FUSED) ? 0u : (uint16_t)((p->rows[t] < min_rows) ? min_rows : p->rows[t]);
    }
}

// Deterministic first-fit liveness planner. Items are placed in index order
// (tensor 0, histogram, then per layer its output and its scratch), each at
// the lowest offset (multiple of VD_CNN_ITEM_ALIGN) where it overlaps no placed
// item whose lifetime intersects its own. A list of placed items sorted by
// offset makes one item O(items), the plan O(items^2).
static vd_status_t plan_make(const vd_cnn_model_t *m, const chain_t *c, uint32_t width, uint32_t height,
                             uint32_t flags, vd_cnn_plan_t *p)
{
    const uint32_t n = m->n_layers;
    const bool keep = (flags & VD_CNN_KEEP_TENSORS) != 0u;
    const bool stream = (flags & VD_CNN_STREAM) != 0u;
    sched_rows(m, c, height, flags, p);
    // Streamed, every item lives for the whole run (the layers interleave)
    // and one scratch, sized for the largest layer, serves all of them.
    uint64_t scratch_max = 0u;
    for (uint32_t l = 0u; l < n && stream; l++) {
        scratch_layout_t s;
        const uint64_t len = scratch_layout(&m->layers[l], true, &s);
        scratch_max = (len > scratch_max) ? len : scratch_max;
    }
    uint8_t last_read[VD_CNN_MAX_TENSORS];
    for (uint32_t t = 0u; t <= n; t++) {
        last_read[t] = (uint8_t)t;
    }
    for (uint32_t l = 0u; l < n; l++) {
        const vd_cnn_layer_t *L = &m->layers[l];
        last_read[L->in] = (uint8_t)(l + 1u);
        if (L->op == VD_CNN_OP_CONCAT) {
            last_read[L->in2] = (uint8_t)(l + 1u);
        }
    }
    p->n_items = 2u + 2u * n;
    for (uint32_t i = 0u; i < p->n_items; i++) {
        uint64_t len;
        uint32_t first, last;
        if (i == 0u) {
            len = (uint64_t)width * p->rows[0];
            first = 0u;
            last = keep ? n : last_read[0];
        } else if (i == 1u) {
            len = (m->input_norm == VD_CNN_NORM_PERCENTILE) ? VD_CNN_HIST_BYTES : 0u;
            len += stream ? round_up(width, VD_CNN_ITEM_ALIGN) : 0u;   // row buffer of vd_cnn_run_rows
            first = 0u;
            last = 0u;
        } else if (i % 2u == 0u) {
            const uint32_t t = i / 2u;   // tensor t = layer t-1's output
            len = tensor_bytes(c, t, width, p->rows[t]);
            first = t;
            last = (keep || t == n) ? n : last_read[t];
        } else if (stream) {
            len = (i == 3u) ? scratch_max : 0u;
            first = 0u;
            last = 0u;
        } else {
            scratch_layout_t s;
            len = scratch_layout(&m->layers[i / 2u - 1u], false, &s);
            first = i / 2u;
            last = first;
        }
        if (stream) {
            first = 0u;
            last = n;
        }
        VD_VERIFY(len <= (uint64_t)UINT32_MAX - 2u * VD_CNN_ITEM_ALIGN, VD_ERR_OVERFLOW);
        p->len[i] = round_up((uint32_t)len, VD_CNN_ITEM_ALIGN);
        p->first[i] = (uint8_t)first;
        p->last[i] = (uint8_t)last;
    }

    uint8_t order[VD_CNN_MAX_ITEMS];   // placed items by offset
    uint32_t n_placed = 0u;
    uint64_t end = 0u;
    for (uint32_t i = 0u; i < p->n_items; i++) {
        p->off[i] = 0u;
        if (p->len[i] == 0u) {
            continue;
        }
        uint64_t off = 0u;
        uint32_t pos = 0u;   // insertion point in order[]
        for (uint32_t k = 0u; k < n_placed; k++) {
            const uint32_t j = order[k];
            if (p->first[j] > p->last[i] || p->first[i] > p->last[j]) {
                continue;   // never live at the same time
            }
            if (off + p->len[i] <= p->off[j]) {
                break;      // fits in the gap before j
            }
            const uint64_t e = (uint64_t)p->off[j] + p->len[j];
            off = (e > off) ? e : off;
        }
        VD_VERIFY(off + p->len[i] <= (uint64_t)UINT32_MAX - VD_CNN_REC_BYTES, VD_ERR_OVERFLOW);
        p->off[i] = (uint32_t)off;
        while (pos < n_placed && p->off[order[pos]] <= p->off[i]) {
            pos++;
        }
        for (uint32_t k = n_placed; k > pos; k--) {
            order[k] = order[k - 1u];
        }
        order[pos] = (uint8_t)i;
        n_placed++;
        end = (off + p->len[i] > end) ? off + p->len[i] : end;
    }
    for (uint32_t i = 0u; i < p->n_items; i++) {
        p->off[i] += VD_CNN_REC_BYTES;
    }
    VD_VERIFY(end + VD_CNN_REC_BYTES <= (uint64_t)UINT32_MAX && end + VD_CNN_REC_BYTES <= (uint64_t)SIZE_MAX,
              VD_ERR_OVERFLOW);
    p->total = (uint32_t)(end + VD_CNN_REC_BYTES);
    p->flags = flags;
    p->width = width;
    p->height = height;
    p->crc = m->crc32;
    p->size = m->size;
    return VD_OK;
}

vd_status_t vd_cnn_workspace_size_ex(const vd_cnn_model_t *m, uint32_t width, uint32_t height, uint32_t flags,
                                     size_t *bytes)
{
    VD_VERIFY(m != NULL && bytes != NULL && (flags & ~CNN_FLAGS) == 0u, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(model_ok(m, &c), VD_ERR_STATE);
    VD_VERIFY(size_ok(m, width, height), VD_ERR_ARG);
    vd_cnn_plan_t p;
    VD_TRY(plan_make(m, &c, width, height, flags, &p));
    *bytes = p.total;
    return VD_OK;
}

vd_status_t vd_cnn_workspace_size(const vd_cnn_model_t *m, uint32_t width, uint32_t height, size_t *bytes)
{
    return vd_cnn_workspace_size_ex(m, width, height, 0u, bytes);
}

vd_status_t vd_cnn_macs(const vd_cnn_model_t *m, uint32_t width, uint32_t height, uint64_t *macs)
{
    VD_VERIFY(m != NULL && macs != NULL, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(model_ok(m, &c), VD_ERR_STATE);
    VD_VERIFY(size_ok(m, width, height), VD_ERR_ARG);
    uint64_t sum = 0u;
    for (uint32_t l = 0u; l < m->n_layers; l++) {
        const vd_cnn_layer_t *L = &m->layers[l];
        const uint64_t px = (uint64_t)(width / c.f[l + 1u]) * (height / c.f[l + 1u]);
        const uint64_t per = (L->op == VD_CNN_OP_DW3X3) ? 9u * (uint64_t)L->cout : (uint64_t)k_of(L) * L->cout;
        sum += px * per;
    }
    *macs = sum;
    return VD_OK;
}

// ------------------------------------------------------------------ kernels

// Requantisation of one layer: per-channel constants (in its scratch) and
// the output clamp relative to the zero point.
typedef struct rq {
    const vd_rq_ch_t *ch;
    int32_t zp;
    int32_t lo;      // act_min - zp
    int32_t hi;      // act_max - zp
    bool general;    // some channel has shift > 0 (saturating left shift first)
    bool relu;       // lo >= 0: the sign correction of the rounding is not needed (rq_row)
} rq_t;

// One output value from z = requantize(sum + bias): clamp, zero point.
static inline int8_t rq_out(int32_t z, int32_t zp, int32_t lo, int32_t hi)
{
    z = (z < lo) ? lo : z;
    z = (z > hi) ? hi : z;
    return (int8_t)(z + zp);
}

// VD_CNN_NPIX values of one channel. With the channel's constants in locals
// the loop vectorises (gcc, SSE2: pmuludq, psrlq): requantisation would
// otherwise cost as much as the multiply-adds.
CNN_NOINLINE static void rq_row(const int32_t *acc, const vd_rq_ch_t *c, const rq_t *q, int8_t *z8)
{
    const int32_t zp = q->zp, lo = q->lo, hi = q->hi;
    if (q->general) {
        for (size_t p = 0u; p < VD_CNN_NPIX; p++) {
            z8[p] = rq_out(vd_rq_apply(acc[p], c), zp, lo, hi);
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
            z8[p] = rq_out(t[p], zp, lo, hi);
        }
        return;
    }
    for (size_t p = 0u; p < VD_CNN_NPIX; p++) {
        const int32_t x = vd_rq_u32_to_i32(bias + (uint32_t)acc[p]);
        z8[p] = rq_out(vd_rq_z(x, k, mult, dk, thr, rsh, off), zp, lo, hi);
    }
}

// Fills the scratch constants of a weighted layer; returns the view on them.
static void rq_setup(const vd_cnn_layer_t *L, uint8_t *scr, const scratch_layout_t *s, rq_t *q)
{
    vd_rq_ch_t *ch = (vd_rq_ch_t *)(void *)(scr + s->ch);
    for (uint32_t o = 0u; o < L->cout; o++) {
        vd_rq_prepare(rd_i32(L->mult + 4u * (size_t)o), L->shift[o], rd_i32(L->bias + 4u * (size_t)o), &ch[o]);
    }
    q->ch = ch;
    q->general = false;
    for (uint32_t o = 0u; o < L->cout; o++) {
        q->general = q->general || ch[o].lsh != 0u;
    }
    q->zp = L->out_zp;
    q->lo = L->act_min - L->out_zp;
    q->hi = L->act_max - L->out_zp;
    q->relu = q->lo >= 0;
}

// Geometry of one layer's input and output tensors.
typedef struct geom {
    uint32_t wi, hi, ci;   // input width, height, channels
    uint32_t wo, ho, co;   // output
    int32_t zp_in;
} geom_t;

// A tensor in the workspace as a ring of `rows` full-width rows: row y at
// slot y % rows. A whole plane is the ring with rows = height (slot = y).
typedef struct ring {
    int8_t *base;
    size_t row;        // bytes per row (w * c)
    uint32_t rows;     // slots, >= 1 for every tensor that is read or written
} ring_t;

static inline int8_t *ring_row(const ring_t *r, uint32_t y)
{
    return r->base + (size_t)(y % r->rows) * r->row;
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
CNN_NOINLINE static void gemm_block(const int16_t *rows, size_t kp, const int16_t *w16, const vd_rq_ch_t *ch,
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
        rowp[ky] = (iy >= 0 && iy < (int32_t)g->hi) ? ring_row(in, (uint32_t)iy) : NULL;
    }
}

// The int16 GEMM rows of npix output pixels from x0 (portable and AVX2
// paths): x - zp_in per tap in the weight order [ky][kx][c], padding taps 0
// (the K..kp tails stay as the caller zeroed them). rowp: the ks input rows
// of the output row (NULL: padding row).
static inline void conv_rows(const geom_t *g, const int8_t *const rowp[5], int32_t ks, int32_t step, uint32_t x0,
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

#if defined(VD_CNN_X86)
// Layer-wide requantisation flags of the x86 kernels (as rq_setup's).
static vd_cnn_x86_rq_t x86_rq(const vd_cnn_layer_t *L)
{
    vd_cnn_x86_rq_t q;
    q.zp = L->out_zp;
    q.lo = L->act_min - L->out_zp;
    q.hi = L->act_max - L->out_zp;
    q.general = false;
    for (uint32_t o = 0u; o < L->cout; o++) {
        q.general = q.general || L->shift[o] > 0;
    }
    q.sign = q.general || q.lo < 0;
    return q;
}

// run_conv_pw on the AVX2 GEMM: the portable int16 rows (x - zp_in, padding
// 0) and, per tile of <= 64 output channels, int16 weight pairs
// [k2 / 2][n][2] (2 n k2 <= the int16 copy's 2 chunk kp bytes).
static void run_conv_pw_avx2(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                             uint32_t y0, uint32_t y1, uint8_t *scr, const scratch_layout_t *s)
{
    const size_t k = k_of(L);
    const size_t kp = round_up((uint32_t)k, VD_CNN_KCHUNK);
    int16_t *wp = (int16_t *)(void *)(scr + s->w16);
    int16_t *rows = (int16_t *)(void *)(scr + s->rows);
    memset(rows, 0, (size_t)VD_CNN_NPIX * kp * sizeof(int16_t));
    const vd_cnn_x86_rq_t xq = x86_rq(L);
    const int32_t step = L->stride;
    const bool pw = L->op == VD_CNN_OP_PW1X1;
    const int32_t ks = pw ? 1 : ((L->op == VD_CNN_OP_CONV5X5) ? 5 : 3);
    for (size_t o0 = 0u; o0 < g->co; o0 += VD_CNN_X86_TILE) {
        const size_t n_o = (g->co - o0 < VD_CNN_X86_TILE) ? g->co - o0 : VD_CNN_X86_TILE;
        vd_cnn_x86_pack16(L->w + o0 * k, k, n_o, wp);
        vd_cnn_x86_rqv_t cv[VD_CNN_X86_TILE / VD_CNN_X86_LANES];
        for (size_t v = 0u; v * VD_CNN_X86_LANES < n_o; v++) {
            uint32_t ch_of[VD_CNN_X86_LANES];
            const size_t n_l = (n_o - v * 16u < 16u) ? n_o - v * 16u : 16u;
            for (size_t j = 0u; j < n_l; j++) {
                ch_of[j] = (uint32_t)(o0 + v * 16u + j);
            }
            vd_cnn_x86_rqv_fill(&cv[v], L, ch_of, NULL, (uint32_t)n_l);
        }
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rowp[5];
            conv_row_ptrs(g, in, oy, step, ks, rowp);
            int8_t *orow = ring_row(out, oy) + o0;
            for (uint32_t x0 = 0u; x0 < g->wo; x0 += VD_CNN_NPIX) {
                const uint32_t npix = (g->wo - x0 < VD_CNN_NPIX) ? g->wo - x0 : VD_CNN_NPIX;
                conv_rows(g, rowp, ks, step, x0, npix, kp, rows);
                vd_cnn_x86_gemm16(rows, kp, k, wp, n_o, cv, &xq, g->co, orow + (size_t)x0 * g->co, npix);
            }
        }
    }
}

// run_conv_pw on the AVX-512 VNNI GEMM (lib/src/cnn_x86.c), same scratch:
// per tile of <= 64 output channels the int8 weights packed [k4 / 4][n][4]
// (n k4 <= the int16 copy's 2 chunk kp bytes), per block of 16 pixels the
// rows as unsigned bytes x + 128, k4 apart (16 k4 <= the int16 rows' bytes);
// padding taps are zp_in + 128 and the bias loses (zp_in + 128) sum w, so
// the int32 sums equal the portable ones modulo 2^32 (cnn_x86.c).
CNN_NOINLINE static void run_conv_pw_x86(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in,
                                         const ring_t *out, uint32_t y0, uint32_t y1, uint8_t *scr,
                                         const scratch_layout_t *s, uint32_t level)
{
    if (level != VD_CNN_X86_AVX512) {
        run_conv_pw_avx2(L, g, in, out, y0, y1, scr, s);
        return;
    }
    const size_t k = k_of(L);
    const size_t k4 = round_up((uint32_t)k, 4u);
    int8_t *wp = (int8_t *)(void *)(scr + s->w16);
    uint8_t *rows = scr + s->rows;
    memset(rows, 0, (size_t)VD_CNN_NPIX * k4);   // the k..k4 tails stay 0 (their weights are 0 too)
    const uint8_t upad = (uint8_t)(g->zp_in + 128);
    const vd_cnn_x86_rq_t xq = x86_rq(L);
    const size_t ci = g->ci;
    const int32_t step = L->stride;
    const bool pw = L->op == VD_CNN_OP_PW1X1;
    const int32_t ks = pw ? 1 : ((L->op == VD_CNN_OP_CONV5X5) ? 5 : 3);
    const int32_t pad = ks / 2;
    const bool in_place = pw && ci % 4u == 0u;
    for (size_t o0 = 0u; o0 < g->co; o0 += VD_CNN_X86_TILE) {
        const size_t n_o = (g->co - o0 < VD_CNN_X86_TILE) ? g->co - o0 : VD_CNN_X86_TILE;
        int32_t corr[VD_CNN_X86_TILE];
        uint32_t wsum[VD_CNN_X86_TILE];
        vd_cnn_x86_pack(L->w + o0 * k, k, n_o, wp, wsum);
        for (size_t o = 0u; o < n_o; o++) {
            corr[o] = vd_rq_u32_to_i32(wsum[o] * (uint32_t)(g->zp_in + 128));   // modulo 2^32, as the sums
        }
        vd_cnn_x86_rqv_t cv[VD_CNN_X86_TILE / VD_CNN_X86_LANES];
        for (size_t v = 0u; v * VD_CNN_X86_LANES < n_o; v++) {
            uint32_t ch_of[VD_CNN_X86_LANES];
            const size_t n_l = (n_o - v * 16u < 16u) ? n_o - v * 16u : 16u;
            for (size_t j = 0u; j < n_l; j++) {
                ch_of[j] = (uint32_t)(o0 + v * 16u + j);
            }
            vd_cnn_x86_rqv_fill(&cv[v], L, ch_of, corr + v * 16u, (uint32_t)n_l);
        }
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rowp[5];
            conv_row_ptrs(g, in, oy, step, ks, rowp);
            int8_t *orow = ring_row(out, oy) + o0;
            for (uint32_t x0 = 0u; x0 < g->wo; x0 += VD_CNN_NPIX) {
                const uint32_t npix = (g->wo - x0 < VD_CNN_NPIX) ? g->wo - x0 : VD_CNN_NPIX;
                if (in_place) {
                    // The input pixels are the rows (x, flipped to x + 128 in the kernel).
                    vd_cnn_x86_gemm((const uint8_t *)(const void *)(rowp[0] + (size_t)x0 * ci), ci, true, k4, wp,
                                    n_o, cv, &xq, g->co, orow + (size_t)x0 * g->co, npix);
                    continue;
                }
                for (uint32_t i = 0u; i < npix; i++) {
                    uint8_t *r = rows + (size_t)i * k4;
                    const int32_t ox = (int32_t)(x0 + i);
                    if (pw) {
                        const int8_t *x = rowp[0] + (size_t)ox * ci;
                        for (size_t c = 0u; c < ci; c++) {
                            r[c] = (uint8_t)((uint8_t)x[c] ^ 0x80u);
                        }
                        continue;
                    }
                    const int32_t ix0 = ox * step - pad;
                    const bool inside = ix0 >= 0 && ix0 + ks <= (int32_t)g->wi;
                    for (int32_t ky = 0; ky < ks; ky++) {
                        uint8_t *d = r + (size_t)(ky * ks) * ci;
                        if (inside && rowp[ky] != NULL) {
                            // ks taps of ci channels, contiguous in the input row.
                            const int8_t *x = rowp[ky] + (size_t)ix0 * ci;
                            for (size_t c = 0u; c < (size_t)ks * ci; c++) {
                                d[c] = (uint8_t)((uint8_t)x[c] ^ 0x80u);
                            }
                            continue;
                        }
                        for (int32_t kx = 0; kx < ks; kx++) {
                            const int32_t ix = ix0 + kx;
                            uint8_t *dk = d + (size_t)kx * ci;
                            if (rowp[ky] == NULL || ix < 0 || ix >= (int32_t)g->wi) {
                                memset(dk, upad, ci);
                            } else {
                                const int8_t *x = rowp[ky] + (size_t)ix * ci;
                                for (size_t c = 0u; c < ci; c++) {
                                    dk[c] = (uint8_t)((uint8_t)x[c] ^ 0x80u);
                                }
                            }
                        }
                    }
                }
                vd_cnn_x86_gemm(rows, k4, false, k4, wp, n_o, cv, &xq, g->co, orow + (size_t)x0 * g->co, npix);
            }
        }
    }
}

// run_dw on the AVX-512 VNNI kernel: the scratch holds only the zero-point row.
CNN_NOINLINE static void run_dw_x86(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                                    uint32_t y0, uint32_t y1, uint8_t *scr, uint32_t level)
{
    scratch_layout_t s;
    (void)scratch_layout(L, false, &s);
    int8_t *zr = (int8_t *)(void *)(scr + s.rows);
    memset(zr, g->zp_in, g->co);
    const vd_cnn_x86_dw_t d = {in->base, in->row, in->rows, g->wi, g->hi, out->base, out->row, out->rows,
                               g->wo, L->stride, g->co, g->zp_in, zr};
    const vd_cnn_x86_rq_t xq = x86_rq(L);
    if (level == VD_CNN_X86_AVX512) {
        vd_cnn_x86_dw_rows(&d, L, &xq, y0, y1);
    } else {
        vd_cnn_x86_dw_rows_avx2(&d, L, &xq, y0, y1);
    }
}
#endif

// Output rows [y0, y1) of a CONV3X3 / CONV5X5 / PW1X1 layer; the input rows
// they read (y * stride - pad .. + pad, clamped) must be in the input ring.
// Output channels in chunks of chunk_of(L, stream) (one chunk unless
// streamed): per chunk the int16 weights, then every pixel block.
CNN_NOINLINE static void run_conv_pw(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                                     uint32_t y0, uint32_t y1, bool stream, uint8_t *scr)
{
    scratch_layout_t s;
    (void)scratch_layout(L, stream, &s);
    rq_t q;
    rq_setup(L, scr, &s, &q);
    const size_t k = k_of(L);
    const size_t kp = round_up((uint32_t)k, VD_CNN_KCHUNK);
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
            int8_t *orow = ring_row(out, oy) + o0;
            for (uint32_t x0 = 0u; x0 < g->wo; x0 += VD_CNN_NPIX) {
                const uint32_t npix = (g->wo - x0 < VD_CNN_NPIX) ? g->wo - x0 : VD_CNN_NPIX;
                conv_rows(g, rowp, ks, step, x0, npix, kp, rows);
                gemm_block(rows, kp, w16, q.ch + o0, &q, n_o, g->co, orow + (size_t)x0 * g->co, npix);
            }
        }
    }
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
            d[j] = rq_out(vd_rq_apply(acc[j], &ch[j]), zp, lo, hi);
        }
        return;
    }
    if (q->relu) {
        // lo >= 0: without the sign term, as rq_row.
        for (size_t j = 0u; j < n; j++) {
            const vd_rq_ch_t *c = &ch[j];
            d[j] = rq_out(vd_rq_z_nn((uint32_t)c->bias + (uint32_t)acc[j], c->k, c->mult, c->rsh, c->off), zp, lo,
                          hi);
        }
        return;
    }
    for (size_t j = 0u; j < n; j++) {
        const vd_rq_ch_t *c = &ch[j];
        const int32_t x = vd_rq_u32_to_i32((uint32_t)c->bias + (uint32_t)acc[j]);
        d[j] = rq_out(vd_rq_z(x, c->k, c->mult, c->dk, c->thr, c->rsh, c->off), zp, lo, hi);
    }
}

// Output rows [y0, y1) of a DW3X3 layer (input rows y * stride - 1 .. + 1 in the ring).
CNN_NOINLINE static void run_dw(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                                uint32_t y0, uint32_t y1, uint8_t *scr)
{
    scratch_layout_t s;
    (void)scratch_layout(L, false, &s);   // no chunks: the same layout either way
    rq_t q;
    rq_setup(L, scr, &s, &q);
    const size_t c_n = g->co;
    const size_t cp = round_up((uint32_t)c_n, VD_CNN_DWB);
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
    const size_t pstep = (size_t)step * c_n;   // input bytes per output pixel along a row
    for (uint32_t oy = y0; oy < y1; oy++) {
        // Row pointers of the three input rows (NULL above/below the tensor);
        // per pixel only the column tests remain.
        const int8_t *rowp[3];
        for (int32_t ky = 0; ky < 3; ky++) {
            const int32_t iy = (int32_t)oy * step - 1 + ky;
            rowp[ky] = (iy >= 0 && iy < (int32_t)g->hi) ? ring_row(in, (uint32_t)iy) : NULL;
        }
        int8_t *orow = ring_row(out, oy);
        for (uint32_t ox = 0u; ox < g->wo; ox++) {
            const int8_t *t[9];
            const int32_t ix0 = (int32_t)ox * step - 1;
            const bool left = ix0 >= 0, right = ix0 + 2 < (int32_t)g->wi;
            for (int32_t ky = 0; ky < 3; ky++) {
                const int8_t *r = rowp[ky];
                if (r == NULL) {
                    t[ky * 3] = zrow;
                    t[ky * 3 + 1] = zrow;
                    t[ky * 3 + 2] = zrow;
                    continue;
                }
                const int8_t *c1 = r + (size_t)ox * pstep;   // column ix0 + 1 (always inside)
                t[ky * 3] = left ? c1 - c_n : zrow;
                t[ky * 3 + 1] = c1;
                t[ky * 3 + 2] = right ? c1 + c_n : zrow;
            }
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

// Output rows [y0, y1) of the copy ops (input rows 2y..2y+1, y / 2, y).
static void run_maxpool(const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0, uint32_t y1)
{
    const uint32_t c_n = g->co;
    for (uint32_t y = y0; y < y1; y++) {
        const int8_t *r0 = ring_row(in, 2u * y);
        const int8_t *r1 = ring_row(in, 2u * y + 1u);
        int8_t *orow = ring_row(out, y);
        for (uint32_t x = 0u; x < g->wo; x++) {
            const int8_t *a = r0 + (size_t)(2u * x) * c_n;
            const int8_t *b = a + c_n;
            const int8_t *c = r1 + (size_t)(2u * x) * c_n;
            const int8_t *d = c + c_n;
            int8_t *o = orow + (size_t)x * c_n;
            for (uint32_t k = 0u; k < c_n; k++) {
                const int8_t m1 = (a[k] > b[k]) ? a[k] : b[k];
                const int8_t m2 = (c[k] > d[k]) ? c[k] : d[k];
                o[k] = (m1 > m2) ? m1 : m2;
            }
        }
    }
}

static void run_upsample(const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0, uint32_t y1)
{
    const uint32_t c_n = g->co;
    for (uint32_t y = y0; y < y1; y++) {
        const int8_t *src = ring_row(in, y / 2u);
        int8_t *o = ring_row(out, y);
        for (uint32_t x = 0u; x < g->wo; x++) {
            memcpy(o + (size_t)x * c_n, src + (size_t)(x / 2u) * c_n, c_n);
        }
    }
}

// ua / ub (0 or 1): operand a / b is a fused upsample and its ring the
// upsample's source, read at row y >> 1, column x >> 1.
static void run_concat(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *a, uint32_t ua, const ring_t *b,
                       uint32_t ub, const ring_t *out, uint32_t y0, uint32_t y1)
{
    const uint32_t ca = L->cin;
    const uint32_t cb = (uint32_t)L->cout - L->cin;
    for (uint32_t y = y0; y < y1; y++) {
        const int8_t *ra = ring_row(a, y >> ua);
        const int8_t *rb = ring_row(b, y >> ub);
        int8_t *o = ring_row(out, y);
        for (uint32_t x = 0u; x < g->wo; x++) {
            memcpy(o + (size_t)x * L->cout, ra + (size_t)(x >> ua) * ca, ca);
            memcpy(o + (size_t)x * L->cout + ca, rb + (size_t)(x >> ub) * cb, cb);
        }
    }
}

// Where the grey input rows come from: a plane (img, stride) or a caller's
// row function writing into buf (vd_cnn_run_rows).
typedef struct in_src {
    const uint8_t *img;
    uint32_t stride;
    const vd_cnn_rows_t *rows;
    uint8_t *buf;        // width bytes (row function only)
} in_src_t;

static const uint8_t *src_row(const in_src_t *s, uint32_t y)
{
    if (s->img != NULL) {
        return s->img + (size_t)y * s->stride;
    }
    s->rows->row(s->rows->ctx, y, s->buf);
    return s->buf;
}

// Tensor 0 from the grey plane: q = pixel - 128, or the percentile stretch
// through a 256-entry table (256 divisions per frame, none per pixel).
// norm_table makes the table from a histogram of the whole plane (one pass
// over every row; NULL without a stretch); input_rows writes rows [y0, y1)
// of tensor 0.
CNN_NOINLINE static const int8_t *norm_table(const vd_cnn_model_t *m, const in_src_t *src, uint32_t w, uint32_t h,
                                             uint8_t *hist_area)
{
    if (m->input_norm != VD_CNN_NORM_PERCENTILE) {
        return NULL;
    }
    uint32_t *hist = (uint32_t *)(void *)hist_area;
    int8_t *lut = (int8_t *)(void *)(hist_area + 256u * 4u);
    memset(hist, 0, 256u * sizeof(uint32_t));
    for (uint32_t y = 0u; y < h; y++) {
        const uint8_t *row = src_row(src, y);
        for (uint32_t x = 0u; x < w; x++) {
            hist[row[x]]++;
        }
    }
    const uint64_t n = (uint64_t)w * h;
    const uint64_t t_lo = n * m->norm_lo_permille / 1000u;
    const uint64_t t_hi = n * m->norm_hi_permille / 1000u;
    uint64_t cum = 0u;
    uint32_t lo = 255u, hi = 255u;
    bool have_lo = false, have_hi = false;
    for (uint32_t v = 0u; v < 256u; v++) {
        cum += hist[v];
        if (!have_lo && cum > t_lo) {
            lo = v;
            have_lo = true;
        }
        if (!have_hi && cum > t_hi) {
            hi = v;
            have_hi = true;
        }
    }
    // t_hi >= t_lo, so hi >= lo.
    const uint32_t r = (hi - lo > m->norm_min_range) ? hi - lo : m->norm_min_range;
    for (uint32_t v = 0u; v < 256u; v++) {
        uint32_t p = 0u;
        if (v > lo) {
            p = ((v - lo) * 510u + r) / (2u * r);
            p = (p > 255u) ? 255u : p;
        }
        lut[v] = (int8_t)((int32_t)p - 128);
    }
    return lut;
}

static void input_rows(const in_src_t *src, uint32_t w, const int8_t *lut, const ring_t *t0, uint32_t y0, uint32_t y1)
{
    for (uint32_t y = y0; y < y1; y++) {
        const uint8_t *row = src_row(src, y);
        int8_t *d = ring_row(t0, y);
        if (lut == NULL) {
            for (uint32_t x = 0u; x < w; x++) {
                d[x] = (int8_t)((int32_t)row[x] - 128);
            }
        } else {
            for (uint32_t x = 0u; x < w; x++) {
                d[x] = lut[row[x]];
            }
        }
    }
}

// ------------------------------------------------------------------ run

static ring_t ring_of(uint8_t *ws, const vd_cnn_plan_t *p, const chain_t *c, uint32_t t)
{
    ring_t r;
    r.base = (int8_t *)(void *)(ws + p->off[item_of_tensor(t)]);
    r.row = (size_t)(p->width / c->f[t]) * c->chan[t];
    r.rows = p->rows[t];
    return r;
}

typedef struct run_io {
    const in_src_t *src;
    const int8_t *lut;
    uint8_t *base;
    const chain_t *c;
} run_io_t;

// The optional x86 kernels run unless the caller asked for the portable
// ones or the CPU lacks AVX-512 VNNI (checked per call: no global state).
#if defined(VD_CNN_X86)
static uint32_t x86_level(uint32_t flags)
{
    return ((flags & VD_CNN_PORTABLE) != 0u) ? VD_CNN_X86_NONE : vd_cnn_x86_level();
}
#endif

// Output rows [y0, y1) of layer l; its input rows must be in their rings.
static void layer_rows(const vd_cnn_model_t *m, const chain_t *c, const vd_cnn_plan_t *p, uint8_t *base, uint32_t l,
                       uint32_t y0, uint32_t y1)
{
    const vd_cnn_layer_t *L = &m->layers[l];
    geom_t g;
    g.wi = p->width / c->f[L->in];
    g.hi = p->height / c->f[L->in];
    g.ci = c->chan[L->in];
    g.wo = p->width / c->f[l + 1u];
    g.ho = p->height / c->f[l + 1u];
    g.co = c->chan[l + 1u];
    g.zp_in = c->zp[L->in];
    const ring_t in = ring_of(base, p, c, L->in);
    const ring_t o = ring_of(base, p, c, l + 1u);
    // The streamed plan has one scratch for all layers (item 3), refilled per call.
    uint8_t *scr = base + p->off[((p->flags & VD_CNN_STREAM) != 0u) ? 3u : 3u + 2u * l];
#if defined(VD_CNN_X86)
    const uint32_t level = x86_level(p->flags);
#endif
    switch (L->op) {
    case VD_CNN_OP_CONV3X3:
    case VD_CNN_OP_CONV5X5:
    case VD_CNN_OP_PW1X1:
#if defined(VD_CNN_X86)
        if (level != VD_CNN_X86_NONE) {
            scratch_layout_t s;
            (void)scratch_layout(L, (p->flags & VD_CNN_STREAM) != 0u, &s);
            run_conv_pw_x86(L, &g, &in, &o, y0, y1, scr, &s, level);
            break;
        }
#endif
        run_conv_pw(L, &g, &in, &o, y0, y1, (p->flags & VD_CNN_STREAM) != 0u, scr);
        break;
    case VD_CNN_OP_DW3X3:
#if defined(VD_CNN_X86)
        if (level != VD_CNN_X86_NONE) {
            run_dw_x86(L, &g, &in, &o, y0, y1, scr, level);
            break;
        }
#endif
        run_dw(L, &g, &in, &o, y0, y1, scr);
        break;
    case VD_CNN_OP_MAXPOOL2:
        run_maxpool(&g, &in, &o, y0, y1);
        break;
    case VD_CNN_OP_UPSAMPLE2: {
        run_upsample(&g, &in, &o, y0, y1);
        break;
    }
    default: {
        const uint32_t ua = (p->live[L->in] == LIVE_FUSED) ? 1u : 0u;
        const uint32_t ub = (p->live[L->in2] == LIVE_FUSED) ? 1u : 0u;
        // A fused upsample's source: the input of the layer that makes it.
        const ring_t a = ring_of(base, p, c, (ua != 0u) ? m->layers[L->in - 1u].in : L->in);
        const ring_t b = ring_of(base, p, c, (ub != 0u) ? m->layers[L->in2 - 1u].in : L->in2);
        run_concat(L, &g, &a, ua, &b, ub, &o, y0, y1);
        break;
    }
    }
}

// Rows [p->done[t], p->req[t]) of tensor t (a sub-step of the schedule).
static void produce(const vd_cnn_model_t *m, const vd_cnn_plan_t *p, const run_io_t *io, uint32_t t)
{
    if (t == 0u) {
        const ring_t t0 = ring_of(io->base, p, io->c, 0u);
        input_rows(io->src, p->width, io->lut, &t0, p->done[0], p->req[0]);
    } else if (p->live[t] != LIVE_FUSED) {   // a fused upsample is read through by its concats
        layer_rows(m, io->c, p, io->base, t - 1u, p->done[t], p->req[t]);
    }
}

// vd_cnn_run_ex and vd_cnn_run_rows: exactly one of img, rows is set.
static vd_status_t run_any(const vd_cnn_model_t *m, const uint8_t *img, const vd_cnn_rows_t *rows, uint32_t width,
                           uint32_t height, uint32_t stride_bytes, uint32_t flags, void *ws, size_t bytes,
                           vd_cnn_output_t *out)
{
    VD_VERIFY(m != NULL && out != NULL && (flags & ~CNN_FLAGS) == 0u, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(model_ok(m, &c), VD_ERR_STATE);
    VD_VERIFY(size_ok(m, width, height) && (rows != NULL || stride_bytes >= width), VD_ERR_ARG);
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % (uintptr_t)VD_WORKSPACE_ALIGN) == 0u, VD_ERR_WORKSPACE);
    VD_VERIFY(bytes >= VD_CNN_REC_BYTES, VD_ERR_WORKSPACE);
    uint8_t *base = (uint8_t *)ws;
    vd_cnn_plan_t *p = (vd_cnn_plan_t *)ws;
    p->magic = 0u;
    VD_TRY(plan_make(m, &c, width, height, flags, p));
    VD_VERIFY(bytes >= p->total, VD_ERR_WORKSPACE);

    // Streamed, item 1 ends with a row buffer for a row function.
    uint8_t *buf = (rows != NULL) ? base + p->off[1] + p->len[1] - round_up(width, VD_CNN_ITEM_ALIGN) : NULL;
    const in_src_t src = {img, stride_bytes, rows, buf};
    const int8_t *lut = norm_table(m, &src, width, height, base + p->off[1]);
    const ring_t t0 = ring_of(base, p, &c, 0u);
    const uint32_t n = m->n_layers;
    if ((flags & VD_CNN_STREAM) == 0u) {
        input_rows(&src, width, lut, &t0, 0u, height);
        for (uint32_t l = 0u; l < n; l++) {
            layer_rows(m, &c, p, base, l, 0u, height / c.f[l + 1u]);
        }
    } else {
        const run_io_t io = {&src, lut, base, &c};
        uint32_t target, max_steps;
        sched_start(p, &target, &max_steps);
        for (uint32_t k = 0u; k < max_steps && sched_next(m, p, &target); k++) {
            for (uint32_t t = 0u; t <= n; t++) {
                if (p->req[t] > p->done[t]) {
                    produce(m, p, &io, t);
                    p->done[t] = p->req[t];
                }
            }
        }
        VD_ASSERT(p->done[n] == p->h[n]);
    }
    out->data = ring_of(base, p, &c, n).base;
    out->w = width / c.f[n];
    out->h = height / c.f[n];
    out->c = c.chan[n];
    out->stride = c.f[n];
    out->zp = c.zp[n];
    p->magic = VD_CNN_REC_MAGIC;
    return VD_OK;
}

vd_status_t vd_cnn_run_ex(const vd_cnn_model_t *m, const uint8_t *img, uint32_t width, uint32_t height,
                          uint32_t stride_bytes, uint32_t flags, void *ws, size_t bytes, vd_cnn_output_t *out)
{
    VD_VERIFY(img != NULL, VD_ERR_ARG);
    return run_any(m, img, NULL, width, height, stride_bytes, flags, ws, bytes, out);
}

vd_status_t vd_cnn_run_rows(const vd_cnn_model_t *m, const vd_cnn_rows_t *rows, uint32_t width, uint32_t height,
                            uint32_t flags, void *ws, size_t bytes, vd_cnn_output_t *out)
{
    VD_VERIFY(rows != NULL && rows->row != NULL && (flags & VD_CNN_STREAM) != 0u, VD_ERR_ARG);
    return run_any(m, NULL, rows, width, height, 0u, flags, ws, bytes, out);
}

vd_status_t vd_cnn_run(const vd_cnn_model_t *m, const uint8_t *img, uint32_t width, uint32_t height,
                       uint32_t stride_bytes, void *ws, size_t bytes, vd_cnn_output_t *out)
{
    return vd_cnn_run_ex(m, img, width, height, stride_bytes, 0u, ws, bytes, out);
}

vd_status_t vd_cnn_tensor(const vd_cnn_model_t *m, const void *ws, size_t bytes, uint32_t width, uint32_t height,
                          uint32_t index, vd_cnn_output_t *t)
{
    VD_VERIFY(m != NULL && t != NULL, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(model_ok(m, &c), VD_ERR_STATE);
    VD_VERIFY(size_ok(m, width, height) && index <= m->n_layers, VD_ERR_ARG);
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % (uintptr_t)VD_WORKSPACE_ALIGN) == 0u, VD_ERR_WORKSPACE);
    VD_VERIFY(bytes >= VD_CNN_REC_BYTES, VD_ERR_WORKSPACE);
    const vd_cnn_plan_t *p = (const vd_cnn_plan_t *)ws;
    VD_VERIFY(p->magic == VD_CNN_REC_MAGIC && p->width == width && p->height == height && p->crc == m->crc32 &&
                  p->size == m->size && (p->flags & ~CNN_FLAGS) == 0u && p->n_items == 2u + 2u * m->n_layers,
              VD_ERR_STATE);
    VD_VERIFY(bytes >= p->total, VD_ERR_WORKSPACE);
    // The plan is read back from the record the run wrote (no plan on the
    // stack: this call is on the detector's path through the boosted
    // verifier). The record is caller memory, so what is used is checked:
    // the tensor lies inside the workspace, after the record, whole.
    const uint32_t it = item_of_tensor(index);
    const uint64_t tb = tensor_bytes(&c, index, width, height / c.f[index]);
    VD_VERIFY(p->rows[index] == height / c.f[index] && p->len[it] >= tb && p->off[it] >= VD_CNN_REC_BYTES &&
                  (uint64_t)p->off[it] + p->len[it] <= p->total,
              VD_ERR_STATE);   // streamed: only whole tensors (the head, or every one with KEEP_TENSORS)
    for (uint32_t j = 0u; j < p->n_items; j++) {
        const bool later = p->first[j] > p->last[it];
        const bool overlap = p->len[j] != 0u && (uint64_t)p->off[j] < (uint64_t)p->off[it] + p->len[it] &&
                             (uint64_t)p->off[it] < (uint64_t)p->off[j] + p->len[j];
        VD_VERIFY(!(later && overlap), VD_ERR_STATE);
    }
    t->data = (const int8_t *)((const uint8_t *)ws + p->off[it]);
    t->w = width / c.f[index];
    t->h = height / c.f[index];
    t->c = c.chan[index];
    t->stride = c.f[index];
    t->zp = c.zp[index];
    return VD_OK;
}

// ------------------------------------------------------------------ decode

static int32_t table_at(const vd_cnn_model_t *m, uint32_t ch, int32_t v)
{
    return rd_i32(m->decode_table + 4u * (ch * 256u + (uint32_t)(v + 128)));
}

uint32_t vd_cnn_score_of_logit(const vd_cnn_model_t *m, int32_t v)
{
    return (uint32_t)table_at(m, 0u, v);
}

// floor(a / d) for d > 0 (C division truncates toward zero).
static int64_t floor_div(int64_t a, int64_t d)
{
    int64_t q = a / d;
    if ((a % d) != 0 && a < 0) {
        q -= 1;
    }
    return q;
}

static int64_t clamp64(int64_t v, int64_t lo, int64_t hi)
{
    return (v < lo) ? lo : ((v > hi) ? hi : v);
}

// Heatmap peak test: > the neighbours before (y, x) in raster order, >= the
// ones after, so a plateau yields exactly its first cell in raster order.
static bool is_peak(const int8_t *hm, uint32_t w, uint32_t h, uint32_t c_n, uint32_t x, uint32_t y)
{
    const int32_t v = hm[((size_t)y * w + x) * c_n];
    for (int32_t dy = -1; dy <= 1; dy++) {
        for (int32_t dx = -1; dx <= 1; dx++) {
            const int32_t ny = (int32_t)y + dy;
            const int32_t nx = (int32_t)x + dx;
            if ((dy == 0 && dx == 0) || ny < 0 || nx < 0 || ny >= (int32_t)h || nx >= (int32_t)w) {
                continue;
            }
            const int32_t nv = hm[((size_t)ny * w + (size_t)nx) * c_n];
            const bool before = dy < 0 || (dy == 0 && dx < 0);
            if (before ? !(v > nv) : !(v >= nv)) {
                return false;
            }
        }
    }
    return true;
}

vd_status_t vd_cnn_decode(const vd_cnn_model_t *m, const vd_cnn_output_t *out, int32_t thr_q, uint32_t max_peaks,
                          uint32_t frame_w, uint32_t frame_h, vd_cnn_box_t *boxes, size_t capacity, size_t *count)
{
    VD_VERIFY(m != NULL && out != NULL && count != NULL && (boxes != NULL || capacity == 0u), VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(model_ok(m, &c), VD_ERR_STATE);
    const uint32_t s = m->out_stride;
    VD_VERIFY(out->data != NULL && out->c == m->out_channels && out->stride == s && out->w >= 1u &&
                  out->h >= 1u && out->w <= VD_CNN_MAX_SIDE / s && out->h <= VD_CNN_MAX_SIDE / s,
              VD_ERR_ARG);
    VD_VERIFY(frame_w >= 1u && frame_w <= VD_MAX_DIM && frame_h >= 1u && frame_h <= VD_MAX_DIM, VD_ERR_ARG);
    int32_t thr = m->score_threshold_q;
    if (thr_q != VD_CNN_THR_DEFAULT) {
        VD_VERIFY(thr_q >= -128 && thr_q <= 127, VD_ERR_ARG);
        thr = thr_q;
    }
    uint32_t k_max = (max_peaks == 0u) ? m->max_peaks : max_peaks;
    const size_t k = ((size_t)k_max < capacity) ? (size_t)k_max : capacity;
    const uint32_t w = out->w, h = out->h, c_n = out->c;
    const int8_t *hm = out->data;

    // 1-2. Peaks in raster order into the top-K array (logit descending,
    // then raster order: an equal logit found later goes after).
    size_t n = 0u;
    for (uint32_t y = 0u; y < h && k > 0u; y++) {
        for (uint32_t x = 0u; x < w; x++) {
            const int32_t v = hm[((size_t)y * w + x) * c_n];
            if (v < thr || (n == k && v <= boxes[k - 1u].logit) || !is_peak(hm, w, h, c_n, x, y)) {
                continue;
            }
            size_t pos = n;
            while (pos > 0u && boxes[pos - 1u].logit < v) {
                pos--;
            }
            const size_t keep = (n < k) ? n : k - 1u;   // entries that stay
            if (keep > pos) {
                memmove(&boxes[pos + 1u], &boxes[pos], (keep - pos) * sizeof boxes[0]);
            }
            boxes[pos].rect.x = (int32_t)x;   // grid cell until step 3
            boxes[pos].rect.y = (int32_t)y;
            boxes[pos].rect.w = 0;
            boxes[pos].rect.h = 0;
            boxes[pos].logit = (int8_t)v;
            boxes[pos].score_q15 = 0u;
            n = keep + 1u;
        }
    }

    // 3. Boxes, in frame pixels (int64 throughout).
    const int64_t den_x = (int64_t)w * s * 256;   // network input width in Q8
    const int64_t den_y = (int64_t)h * s * 256;
    for (size_t i = 0u; i < n; i++) {
        vd_cnn_box_t *b = &boxes[i];
        const uint32_t x = (uint32_t)b->rect.x, y = (uint32_t)b->rect.y;
        const int8_t *cell = hm + ((size_t)y * w + x) * c_n;
        const int64_t off_x = (c_n == 5u) ? table_at(m, 3u, cell[3]) : 128;
        const int64_t off_y = (c_n == 5u) ? table_at(m, 4u, cell[4]) : 128;
        const int64_t cx = ((int64_t)x * 256 + off_x) * s;
        const int64_t cy = ((int64_t)y * 256 + off_y) * s;
        const int64_t bw = table_at(m, 1u, cell[1]);
        const int64_t bh = table_at(m, 2u, cell[2]);
        const int64_t x0n = cx - bw / 2, x1n = x0n + bw;
        const int64_t y0n = cy - bh / 2, y1n = y0n + bh;
        const int64_t x0 = clamp64(floor_div(x0n * frame_w + den_x / 2, den_x), 0, (int64_t)frame_w - 1);
        const int64_t x1 = clamp64(floor_div(x1n * frame_w + den_x / 2, den_x), x0 + 1, frame_w);
        const int64_t y0 = clamp64(floor_div(y0n * frame_h + den_y / 2, den_y), 0, (int64_t)frame_h - 1);
        const int64_t y1 = clamp64(floor_div(y1n * frame_h + den_y / 2, den_y), y0 + 1, frame_h);
        b->rect.x = (int32_t)x0;
        b->rect.y = (int32_t)y0;
        b->rect.w = (int32_t)(x1 - x0);
        b->rect.h = (int32_t)(y1 - y0);
        b->score_q15 = (uint16_t)table_at(m, 0u, b->logit);
    }
    *count = n;
    return VD_OK;
}

vd_status_t vd_cnn_thr_from_score(const vd_cnn_model_t *m, uint32_t score_q15, int32_t *thr_q)
{
    VD_VERIFY(m != NULL && thr_q != NULL && score_q15 <= (uint32_t)VD_CNN_SCORE_ONE_Q15, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(model_ok(m, &c), VD_ERR_STATE);
    // Lower bound in the non-decreasing score table (the loader checked the order).
    int32_t lo = -128;
    int32_t hi = 128;   // one past 127: "no logit reaches it"
    while (lo < hi) {
        const int32_t mid = lo + (hi - lo) / 2;
        if ((uint32_t)table_at(m, 0u, mid) >= score_q15) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    VD_VERIFY(lo <= 127, VD_ERR_RANGE);
    *thr_q = lo;
    return VD_OK;
}
