// SPDX-License-Identifier: MIT
// CNN loader: in-place validation of a .vdm version-3 blob (vd_cnn_load), the layer chain's rules, and the
// state check every other entry point of the CNN starts with.
//
// Algorithm: the container first (magic, version, sizes, CRC; models/blob_internal.h), then the
// header fields, then every layer entry: its fields, the chain rules (chain_step: a layer reads
// earlier tensors whose channels, downsample factor and zero point fit its op; copies keep scale and
// zero point), its arrays inside the blob, and per channel the multiplier, shift and bias bound. All
// arrays and the decode table must be pairwise disjoint, and the decode table's score column
// non-decreasing. Only then is *m filled: a failed load leaves *m untouched.
// Reference: docs/model-format.md ("CNN kind").
// Bounds: O(total_size) (CRC, per-channel arrays, decode table) plus O((4 L + 1)^2) overlap checks
// (segments are read back from the blob, so no list on the stack); stack ~420 B (Cortex-M7 -Os).
// Accumulators: |sum w (x - zp)| <= K * 128 * 255 < 2^31 for K <= 25 * 1024, and the loader's bias
// bound |bias| <= INT32_MAX - K * 128 * 255 makes the whole sum fit int32 for every int8 weight
// including -128 (the kernels still add modulo 2^32, so a wrong bound could never be undefined
// behaviour).
#include "vd/cnn.h"

#include "models/cnn/cnn_internal.h"
#include "models/blob_internal.h"
#include "internal/vd_internal.h"

#include <string.h>

// Header fields.
// Bytes 0..15: the container (magic, version, sizes; models/blob_internal.h checks it).
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

#define MAX_ABS_PRODUCT (128L * 255L)   // weights may be -128: |w (x - zp)| <= 128 * 255

static int8_t u8_to_i8(uint8_t u)
{
    return (u <= 127u) ? (int8_t)u : (int8_t)((int32_t)u - 256);
}

// ------------------------------------------------------------ layer chain

// Pure copies (no weights, no requantisation).
static bool copy_op(uint32_t op)
{
    return op == VD_CNN_OP_MAXPOOL2 || op == VD_CNN_OP_UPSAMPLE2 || op == VD_CNN_OP_CONCAT;
}

// Byte lengths of the four arrays of a layer (weights, bias, mult, shift).
static void array_lens(const vd_cnn_layer_t *L, uint32_t len[4])
{
    const uint32_t cout = L->cout;
    len[0] = (L->op == VD_CNN_OP_DW3X3) ? 9u * cout : vd_cnn_k_of(L) * cout;
    len[1] = vd_cnn_weighted(L->op) ? 4u * cout : 0u;
    len[2] = len[1];
    len[3] = vd_cnn_weighted(L->op) ? cout : 0u;
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
    const uint32_t max_stride = (vd_cnn_spatial_conv(op) || op == VD_CNN_OP_DW3X3) ? 2u : 1u;
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
    if (vd_cnn_spatial_conv(op) || op == VD_CNN_OP_DW3X3) {
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
    c->zp[0] = VD_CNN_INPUT_ZP;
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
    const int64_t bias_max = (int64_t)INT32_MAX - (int64_t)vd_cnn_k_of(L) * MAX_ABS_PRODUCT;
    for (uint32_t o = 0u; o < L->cout; o++) {
        const int32_t mult = vd_cnn_rd_i32(L->mult + 4u * (size_t)o);
        const int64_t bias = vd_cnn_rd_i32(L->bias + 4u * (size_t)o);
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
            const int32_t v = vd_cnn_rd_i32(t + 4u * (ch * 256u + i));
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

// The header fields vd_cnn_load checks and keeps.
typedef struct header {
    uint32_t norm, n_layers, n_ch, in_w, in_h, lo, hi, min_range, out_stride, max_peaks;
    uint32_t table, table_end, dec_off, dec_len;
} header_t;

// Header fields of a blob whose container is valid (total bytes), checked.
static vd_status_t header_read(const uint8_t *b, uint32_t total, header_t *h)
{
    h->norm = b[H_NORM];
    h->n_layers = b[H_N_LAYERS];
    h->n_ch = b[H_OUT_CH];
    h->in_w = vd_blob_u16(b + H_IN_W);
    h->in_h = vd_blob_u16(b + H_IN_H);
    h->lo = vd_blob_u16(b + H_NORM_LO);
    h->hi = vd_blob_u16(b + H_NORM_HI);
    h->min_range = vd_blob_u16(b + H_NORM_MIN);
    h->out_stride = b[H_OUT_STRIDE];
    h->table = vd_blob_u32(b + H_LAYER_TABLE);
    h->dec_off = vd_blob_u32(b + H_DECODE);
    h->max_peaks = vd_blob_u16(b + H_MAX_PEAKS);
    VD_VERIFY(b[H_KIND] == VD_CNN_KIND, VD_ERR_MODEL);
    if (h->norm == VD_CNN_NORM_NONE || h->norm == VD_CNN_NORM_EQUALISE) {
        VD_VERIFY(h->lo == 0u && h->hi == 0u && h->min_range == 0u, VD_ERR_MODEL);
    } else {
        VD_VERIFY(h->norm == VD_CNN_NORM_PERCENTILE && h->lo < h->hi && h->hi <= 1000u && h->min_range >= 1u &&
                      h->min_range <= 255u,
                  VD_ERR_MODEL);
    }
    VD_VERIFY(h->n_layers >= 1u && h->n_layers <= VD_CNN_MAX_LAYERS, VD_ERR_MODEL);
    VD_VERIFY(h->n_ch == 3u || h->n_ch == 5u, VD_ERR_MODEL);
    VD_VERIFY(h->in_w >= 1u && h->in_w <= VD_CNN_MAX_SIDE && h->in_h >= 1u && h->in_h <= VD_CNN_MAX_SIDE,
              VD_ERR_MODEL);
    VD_VERIFY(u8_to_i8(b[H_IN_ZP]) == VD_CNN_INPUT_ZP, VD_ERR_MODEL);
    VD_VERIFY(h->out_stride == 4u || h->out_stride == 8u, VD_ERR_MODEL);
    VD_VERIFY(b[H_RES0] == 0u && vd_blob_u32(b + H_FLAGS) == 0u, VD_ERR_MODEL);
    VD_VERIFY(h->max_peaks >= 1u && h->max_peaks <= VD_CNN_MAX_PEAKS, VD_ERR_MODEL);
    VD_VERIFY(vd_blob_name_ok(b + H_NAME, H_NAME_LEN), VD_ERR_MODEL);
    VD_VERIFY(vd_blob_all_zero(b + H_RES1, VD_CNN_HEADER_SIZE - H_RES1), VD_ERR_MODEL);
    VD_VERIFY(h->table >= VD_CNN_HEADER_SIZE && (h->table % 4u) == 0u, VD_ERR_MODEL);
    VD_VERIFY((uint64_t)h->table + (uint64_t)h->n_layers * VD_CNN_LAYER_ENTRY_SIZE <= (uint64_t)total, VD_ERR_MODEL);
    h->table_end = h->table + h->n_layers * VD_CNN_LAYER_ENTRY_SIZE;
    h->dec_len = 4u * 256u * h->n_ch;
    VD_VERIFY(vd_blob_segment_ok(h->dec_off, h->dec_len, h->table_end, total), VD_ERR_MODEL);
    return VD_OK;
}

// Layers: fields, arrays in range, chain rules, per-channel values; *align
// receives the largest downsample factor.
static vd_status_t layers_check(const uint8_t *b, uint32_t total, const header_t *h, uint32_t *align)
{
    chain_t c;
    c.chan[0] = 1u;
    c.f[0] = 1u;
    c.zp[0] = VD_CNN_INPUT_ZP;
    uint32_t a = 1u;
    for (uint32_t l = 0u; l < h->n_layers; l++) {
        vd_cnn_layer_t L;
        uint32_t offs[4], lens[4];
        entry_read(b, h->table, l, &L, offs);
        const uint8_t *e = b + h->table + l * VD_CNN_LAYER_ENTRY_SIZE;
        VD_VERIFY(e[E_RES0] == 0u && vd_blob_u32(e + E_RES1) == 0u, VD_ERR_MODEL);
        // Chain first: it bounds cin and cout, so the array lengths below
        // cannot wrap (25 * 1024 * 1024 < 2^32).
        VD_VERIFY(chain_step(&L, l, &c), VD_ERR_MODEL);
        array_lens(&L, lens);
        for (uint32_t s = 0u; s < 4u; s++) {
            if (lens[s] == 0u) {
                VD_VERIFY(offs[s] == 0u, VD_ERR_MODEL);
            } else {
                VD_VERIFY(vd_blob_segment_ok(offs[s], lens[s], h->table_end, total), VD_ERR_MODEL);
            }
        }
        if (vd_cnn_weighted(L.op)) {
            VD_VERIFY(values_ok(&L), VD_ERR_MODEL);
        }
        a = (c.f[l + 1u] > a) ? c.f[l + 1u] : a;
    }
    VD_VERIFY(c.chan[h->n_layers] == h->n_ch && c.f[h->n_layers] == h->out_stride, VD_ERR_MODEL);
    VD_VERIFY(h->in_w % a == 0u && h->in_h % a == 0u, VD_ERR_MODEL);
    *align = a;
    return VD_OK;
}

// Disjoint arrays: a crafted blob must not alias weights with multipliers.
static bool segments_disjoint(const uint8_t *b, const header_t *h)
{
    const uint32_t n_seg = 4u * h->n_layers + 1u;
    for (uint32_t i = 0u; i < n_seg; i++) {
        uint32_t oi, li;
        segment_get(b, h->table, h->n_layers, h->dec_off, h->dec_len, i, &oi, &li);
        if (li == 0u) {
            continue;
        }
        for (uint32_t j = i + 1u; j < n_seg; j++) {
            uint32_t oj, lj;
            segment_get(b, h->table, h->n_layers, h->dec_off, h->dec_len, j, &oj, &lj);
            if (!(lj == 0u || (uint64_t)oi + li <= oj || (uint64_t)oj + lj <= oi)) {
                return false;
            }
        }
    }
    return true;
}

// *m from a checked blob of `total` bytes (cannot fail).
static void model_fill(vd_cnn_model_t *m, const uint8_t *b, uint32_t total, const header_t *h, uint32_t align)
{
    m->blob = b;
    m->size = total;
    m->crc32 = vd_blob_u32(b + H_CRC);   // checked by vd_blob_container
    m->format_version = (uint16_t)VD_CNN_FORMAT_VERSION;
    m->input_norm = (uint8_t)h->norm;
    m->out_channels = (uint8_t)h->n_ch;
    m->input_w = (uint16_t)h->in_w;
    m->input_h = (uint16_t)h->in_h;
    m->norm_lo_permille = (uint16_t)h->lo;
    m->norm_hi_permille = (uint16_t)h->hi;
    m->norm_min_range = (uint16_t)h->min_range;
    m->input_zp = VD_CNN_INPUT_ZP;
    m->out_stride = (uint8_t)h->out_stride;
    m->score_threshold_i8 = u8_to_i8(b[H_THR]);
    m->max_peaks = (uint16_t)h->max_peaks;
    m->align = align;
    memcpy(m->name, b + H_NAME, H_NAME_LEN);
    m->name[H_NAME_LEN] = '\0';
    m->n_layers = h->n_layers;
    memset(m->layers, 0, sizeof m->layers);
    for (uint32_t l = 0u; l < h->n_layers; l++) {
        uint32_t offs[4];
        entry_read(b, h->table, l, &m->layers[l], offs);
    }
    m->decode_table = b + h->dec_off;
    m->prepared = NULL;   // vd_cnn_prepare's, for this blob only
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
    header_t h;
    VD_TRY(header_read(b, total, &h));
    uint32_t align;
    VD_TRY(layers_check(b, total, &h, &align));
    VD_VERIFY(segments_disjoint(b, &h), VD_ERR_MODEL);
    VD_VERIFY(decode_table_ok(b + h.dec_off, h.n_ch), VD_ERR_MODEL);
    // Everything checked: fill *m (cannot fail from here).
    model_fill(m, b, total, &h, align);
    return VD_OK;
}

// State check of a model struct: cheap, and enough that run and decode stay
// inside the tensors whatever the struct holds (the array pointers into the
// blob are trusted, as vd_cnn_load set them).
bool vd__cnn_model_ok(const vd_cnn_model_t *m, chain_t *c)
{
    uint32_t align = 0u;
    if (m->blob == NULL || m->decode_table == NULL || m->n_layers < 1u || m->n_layers > VD_CNN_MAX_LAYERS ||
        (m->out_channels != 3u && m->out_channels != 5u) || (m->out_stride != 4u && m->out_stride != 8u) ||
        m->input_norm > VD_CNN_NORM_EQUALISE || m->input_zp != VD_CNN_INPUT_ZP) {
        return false;
    }
    if (m->input_norm == VD_CNN_NORM_PERCENTILE &&
        !(m->norm_lo_permille < m->norm_hi_permille && m->norm_hi_permille <= 1000u && m->norm_min_range >= 1u &&
          m->norm_min_range <= 255u)) {
        return false;
    }
    return chain_make(m, c, &align) && align == m->align;
}

bool vd__cnn_size_ok(const vd_cnn_model_t *m, uint32_t width, uint32_t height)
{
    return width >= 1u && width <= VD_CNN_MAX_SIDE && height >= 1u && height <= VD_CNN_MAX_SIDE &&
           width % m->align == 0u && height % m->align == 0u;
}
