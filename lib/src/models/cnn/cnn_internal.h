// SPDX-License-Identifier: MIT
// What the rooms of the CNN (lib/src/models/cnn/) share: the workspace run record, the layer chain, tensor
// rings, the kernels' entry points and scratch queries; and the decode-table lookup the detector needs.
//
// The rooms, in the order a frame meets them (vd/cnn.h is the API):
//   loader.c      .vdm version 3 in place: header, layer chain, per-channel values (vd_cnn_load);
//                 the state check every other entry point starts with (vd__cnn_model_ok)
//   plan.c        the workspace: items, lifetimes, first-fit offsets (vd__cnn_plan_make), its size
//                 queries, vd_cnn_macs, vd_cnn_tensor (reads the run record back)
//   schedule.c    the streamed executor's row schedule (VD_CNN_STREAM): ring heights, sub-steps
//   executor.c    vd_cnn_run*: tensor 0, then each layer's rows through its kernel (whole plane or
//                 streamed), picking a back end per layer call
//   kernels/      one op per file, each with its scratch query: input (tensor 0), conv (CONV3X3,
//                 CONV5X5, PW1X1), dw3x3, maxpool2, upsample2, concat; scratch.c the layout and
//                 requantisation constants of a weighted layer. Back ends beside the portable C:
//                 *_x86*.c (CMake VD_CNN_X86; conv_x86.c's GEMM one gemm_x86_<set>.c per instruction
//                 set; x86.h, x86.c their shared part) and *_cmsis.c (CMake
//                 VD_CNN_CMSIS: CMSIS-NN on Cortex-M; cmsis.h, cmsis.c), dispatched in executor.c.
//   decode.c      heatmap peaks, top-K, boxes; score threshold -> logit threshold
// Private to lib/; tests include it. Types are unprefixed as in detector/detector_internal.h;
// functions shared between rooms are vd_cnn_*.
#ifndef VD_CNN_INTERNAL_H
#define VD_CNN_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "vd/cnn.h"
#include "models/blob_internal.h"
#include "models/requant.h"

#if VD_CNN_MAX_LAYERS < 1 || VD_CNN_MAX_LAYERS > 32
#error "VD_CNN_MAX_LAYERS must be 1..32 (format version 3; tensor indices and lifetimes are bytes)"
#endif

// Workspace plan items: item 0 tensor 0, item 1 the stretch histogram, then
// per layer l its output tensor (2 + 2l) and its scratch (3 + 2l).
#define VD_CNN_MAX_ITEMS (2u + 2u * VD_CNN_MAX_LAYERS)
// Every item starts at a multiple of this (from the workspace start) and its
// length is rounded up to it.
#define VD_CNN_ITEM_ALIGN 16u
#define VD_CNN_REC_MAGIC 0x524E4E43u   // "CNNR"
#define VD_CNN_PLAN_MAGIC 0x504E4E43u  // "CNNP": a plan made ahead of any run (vd__cnn_plan_ahead), no tensors
// Output pixels per block of the CONV3X3 / PW1X1 kernel (a multiple of 4), and its K chunk
// (K is zero-padded to a multiple of it).
#define VD_CNN_NPIX 16u
#define VD_CNN_KCHUNK 8u
// Channels per pass of the depthwise kernel (weight copies padded to it).
#define VD_CNN_DWB 16u
// Streamed (VD_CNN_STREAM): the plan's band B, head rows per pull and input rows per push sub-step. A
// taller band means fewer sub-steps and kernel calls per run (set-up and row overhead amortised) and
// taller rings. The plan takes B = 1 when its workspace exceeds VD_CNN_BAND_CAP, else the tallest of
// VD_CNN_BAND_MAX, VD_CNN_BAND_MAX / 2, .., 2 whose workspace stays within it, else 1 (plan.c): the shipped
// pair, whose rings are what puts the detector at its 256 KiB bar, keeps 1 row; vd_cnn_compact takes 4.
#ifndef VD_CNN_BAND_MAX
#define VD_CNN_BAND_MAX 4u
#endif
#ifndef VD_CNN_BAND_CAP
#define VD_CNN_BAND_CAP (192u * 1024u)
#endif
#if VD_CNN_BAND_MAX < 1 || VD_CNN_BAND_MAX > 64
#error "VD_CNN_BAND_MAX must be 1..64"
#endif
// Streamed: output channels per int16 weight copy of a CONV / PW layer
// (the one shared scratch holds 2 * this * K bytes of weights).
#ifndef VD_CNN_STREAM_COUT
#define VD_CNN_STREAM_COUT 64u
#endif
// Streamed with the CMSIS back end: the layers' prepared areas (vd__cnn_cmsis_prep_bytes) are planned,
// the layers with the most output rows (kernel calls) first, as long as the workspace stays within this
// many bytes (plan.c); 0: none.
#ifndef VD_CNN_PREP_CAP
#define VD_CNN_PREP_CAP (224u * 1024u)
#endif
// Stretch histogram (uint32[256]) and its int8 lookup table.
#define VD_CNN_HIST_BYTES (256u * 4u + 256u)

// Every flag of the _ex calls.
#define VD_CNN_RUN_FLAGS \
    (VD_CNN_KEEP_TENSORS | VD_CNN_STREAM | VD_CNN_PORTABLE | VD_CNN_REUSE_PLAN | VD_CNN_SAME_HIST | VD_CNN_HEAD_RING)
// Run flags that do not change a plan (a plan's flags are the others).
#define VD_CNN_RUN_ONLY_FLAGS (VD_CNN_REUSE_PLAN | VD_CNN_SAME_HIST)
#define VD_CNN_INPUT_ZP (-128)   // zero point of tensor 0 (pixel - 128)
// vd_cnn_plan_t.live of an upsample fused into the concats that read it (schedule.c).
#define VD_CNN_LIVE_FUSED 2u

// Keeps a kernel out of its caller. Inlined into the layer loop, gcc -O3
// vectorises the pixel-block loop of gemm_block instead of the dot products
// and the whole network runs 2.5x slower (measured, gcc 12). A hint only:
// compilers without the attribute get plain C.
#if defined(__GNUC__)
#define VD_CNN_NOINLINE __attribute__((noinline))
#else
#define VD_CNN_NOINLINE
#endif

// The run record at the start of the workspace: the plan of the run and,
// after a complete run, the key vd_cnn_tensor checks. Offsets are from the
// workspace start; item lifetimes are steps (0 = input, l + 1 = layer l).
typedef struct vd_cnn_plan {
    // First, what VD_CNN_REUSE_PLAN keeps (VD_CNN_PLAN_KEY_BYTES: a pair's detector parks them per network).
    uint32_t magic;           // VD_CNN_REC_MAGIC after a complete run, else 0
    uint32_t flags;
    uint32_t width;
    uint32_t height;
    uint32_t crc;             // model identity
    uint32_t size;
    uint32_t rows_crc;        // CRC-32 of rows, h, live (tensors 0..n) and band: the next run's check before reuse
    // Per tensor: rows kept (ring height; the height for a whole plane, 0 if never computed).
    uint16_t rows[VD_CNN_MAX_TENSORS];
    uint8_t band;             // streamed: head rows per pull, input rows per push (1..VD_CNN_BAND_MAX)
    // Recomputed by every run.
    uint32_t n_items;
    uint32_t total;           // workspace bytes, record included
    uint32_t off[VD_CNN_MAX_ITEMS];
    uint32_t len[VD_CNN_MAX_ITEMS];
    uint8_t first[VD_CNN_MAX_ITEMS];
    uint8_t last[VD_CNN_MAX_ITEMS];
    // Per tensor: height, and the row schedule's counters.
    uint16_t h[VD_CNN_MAX_TENSORS];
    uint16_t done[VD_CNN_MAX_TENSORS];   // rows produced so far
    uint16_t need[VD_CNN_MAX_TENSORS];   // rows needed for the current head target
    uint16_t req[VD_CNN_MAX_TENSORS];    // rows made by the current sub-step
    uint8_t live[VD_CNN_MAX_TENSORS];    // 1: the head depends on it; 2: also, an upsample fused into its concats
} vd_cnn_plan_t;

// Bytes at the start of a record that VD_CNN_REUSE_PLAN keeps (magic .. band); the rest a run recomputes.
#define VD_CNN_PLAN_KEY_BYTES ((uint32_t)offsetof(vd_cnn_plan_t, n_items))

// Bytes of the record (items start after it).
#define VD_CNN_REC_BYTES \
    ((uint32_t)((sizeof(vd_cnn_plan_t) + VD_CNN_ITEM_ALIGN - 1u) / VD_CNN_ITEM_ALIGN * VD_CNN_ITEM_ALIGN))

// ------------------------------------------------------------ bytes, ops

static inline int32_t vd_cnn_rd_i32(const uint8_t *p)
{
    return vd_rq_u32_to_i32(vd_blob_u32(p));
}

static inline uint32_t vd_cnn_round_up(uint32_t n, uint32_t a)
{
    return (n + a - 1u) / a * a;
}

static inline bool vd_cnn_weighted(uint32_t op)
{
    return op == VD_CNN_OP_CONV3X3 || op == VD_CNN_OP_DW3X3 || op == VD_CNN_OP_PW1X1 || op == VD_CNN_OP_CONV5X5;
}

// Full convolutions with a spatial kernel (taps gathered into int16 rows).
static inline bool vd_cnn_spatial_conv(uint32_t op)
{
    return op == VD_CNN_OP_CONV3X3 || op == VD_CNN_OP_CONV5X5;
}

// K of the accumulator bound (multiply-adds per output value).
static inline uint32_t vd_cnn_k_of(const vd_cnn_layer_t *L)
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

// ------------------------------------------------------------ layer chain (loader.c)

// Tensor shapes implied by the layers: channels, downsample factor, zero point.
typedef struct chain {
    uint16_t chan[VD_CNN_MAX_TENSORS];
    uint16_t f[VD_CNN_MAX_TENSORS];
    int8_t zp[VD_CNN_MAX_TENSORS];
} chain_t;

// State check of a model struct (every entry point but vd_cnn_load): false
// unless run and decode stay inside the tensors; fills c.
bool vd__cnn_model_ok(const vd_cnn_model_t *m, chain_t *c);
// A network input size the model takes (1..VD_CNN_MAX_SIDE, multiples of m->align).
bool vd__cnn_size_ok(const vd_cnn_model_t *m, uint32_t width, uint32_t height);

// ------------------------------------------------------------ plan (plan.c, schedule.c)

static inline uint32_t vd_cnn_item_of_tensor(uint32_t t)
{
    return (t == 0u) ? 0u : 2u + 2u * (t - 1u);
}

// Bytes of `rows` rows of tensor t at input width `width`.
static inline uint64_t vd_cnn_tensor_bytes(const chain_t *c, uint32_t t, uint32_t width, uint32_t rows)
{
    return (uint64_t)(width / c->f[t]) * (uint64_t)rows * (uint64_t)c->chan[t];
}

// Where layer l's prepared area (the CMSIS back end's, vd__cnn_cmsis_prep_bytes) lies in a streamed plan:
// its offset, and its bytes in *len (0: none; always 0 whole plane and without the CMSIS back end). Layers
// l >= 1 have item 3 + 2l (their scratch item, unused when streamed: item 3 is the one shared scratch);
// layer 0's sits in item 1 between the histogram and the row buffer (plan.c).
static inline uint32_t vd_cnn_prep_at(const vd_cnn_model_t *m, const vd_cnn_plan_t *p, uint32_t l, uint32_t *len)
{
    *len = 0u;
    if ((p->flags & VD_CNN_STREAM) == 0u) {
        return 0u;
    }
    if (l > 0u) {
        *len = p->len[3u + 2u * l];
        return p->off[3u + 2u * l];
    }
    const uint32_t hist =
        (m->input_norm != VD_CNN_NORM_NONE) ? vd_cnn_round_up(VD_CNN_HIST_BYTES, VD_CNN_ITEM_ALIGN) : 0u;
    *len = p->len[1] - hist - vd_cnn_round_up(p->width, VD_CNN_ITEM_ALIGN);
    return p->off[1] + hist;
}

// The plan of a run into p (m checked by vd__cnn_model_ok, size by vd__cnn_size_ok):
// VD_ERR_OVERFLOW if the workspace would not fit 32 bits.
vd_status_t vd__cnn_plan_make(const vd_cnn_model_t *m, const chain_t *c, uint32_t width, uint32_t height,
                             uint32_t flags, vd_cnn_plan_t *p);
// As vd__cnn_plan_make, for a run into the workspace whose record is p: with VD_CNN_REUSE_PLAN in flags,
// the ring heights of the run before are kept when its record says it completed with the same model, size
// and other flags and they pass their CRC and bounds (the schedule's sizing walk is most of a plan's cost;
// the items are placed anew either way). The plan's flags are flags without VD_CNN_RUN_ONLY_FLAGS.
// *after_run: the heights were kept from a complete run (not a plan made ahead), so the items, placed the
// same way, still hold what that run left in them (its input table: VD_CNN_SAME_HIST).
vd_status_t vd__cnn_plan_for_run(const vd_cnn_model_t *m, const chain_t *c, uint32_t width, uint32_t height,
                                 uint32_t flags, vd_cnn_plan_t *p, bool *after_run);
// The plan of a later run (m, width, height, flags with VD_CNN_STREAM as a run would take them) written into
// the record of workspace ws (bytes >= its total), marked VD_CNN_PLAN_MAGIC: the run keeps it as it keeps
// an earlier run's (VD_CNN_REUSE_PLAN), vd_cnn_tensor finds no tensor. VD_ERR_ARG / VD_ERR_STATE /
// VD_ERR_WORKSPACE as vd_cnn_run_ex. The detector calls it at init for the largest frame.
vd_status_t vd__cnn_plan_ahead(const vd_cnn_model_t *m, uint32_t width, uint32_t height, uint32_t flags, void *ws,
                               size_t bytes);
// Row schedule: ring heights p->rows (and p->h, p->live) of a plan.
void vd__cnn_sched_rows(const vd_cnn_model_t *m, const chain_t *c, uint32_t height, uint32_t flags, vd_cnn_plan_t *p);
// Tensor heights and liveness (p->h, p->live) alone: the part of vd__cnn_sched_rows a kept plan recomputes.
void vd__cnn_sched_init(const vd_cnn_model_t *m, const chain_t *c, uint32_t height, uint32_t flags, vd_cnn_plan_t *p);
// A walk of the streamed schedule: start, then sub-steps (rows p->done .. p->req to make) until false.
void vd__cnn_sched_start(vd_cnn_plan_t *p, uint32_t *target, uint32_t *max_steps);
bool vd__cnn_sched_next(const vd_cnn_model_t *m, vd_cnn_plan_t *p, uint32_t *target);

// ------------------------------------------------------------ kernels (kernels/)

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

static inline int8_t *vd_cnn_ring_row(const ring_t *r, uint32_t y)
{
    return r->base + (size_t)(y % r->rows) * r->row;
}

// Depthwise 3x3 taps, shared by the portable kernel (dw3x3.c) and the DSP one (dw3x3_cmsis.c):
// the three input rows of output row oy (NULL above / below the tensor), then per output pixel ox
// the nine tap pointers into them (channel-interleaved rows; zrow, the zero-point row, stands for
// padding), so that only the column tests remain per pixel.
static inline void vd_cnn_dw3x3_rows(const ring_t *in, uint32_t hi, uint32_t oy, int32_t step,
                                     const int8_t *rowp[3])
{
    for (int32_t ky = 0; ky < 3; ky++) {
        const int32_t iy = (int32_t)oy * step - 1 + ky;
        rowp[ky] = (iy >= 0 && iy < (int32_t)hi) ? vd_cnn_ring_row(in, (uint32_t)iy) : NULL;
    }
}

static inline void vd_cnn_dw3x3_taps(const int8_t *const rowp[3], uint32_t ox, int32_t step, size_t c_n,
                                     uint32_t wi, const int8_t *zrow, const int8_t *t[9])
{
    const int32_t ix0 = (int32_t)ox * step - 1;
    const bool left = ix0 >= 0, right = ix0 + 2 < (int32_t)wi;
    for (int32_t ky = 0; ky < 3; ky++) {
        const int8_t *r = rowp[ky];
        if (r == NULL) {
            t[ky * 3] = zrow;
            t[ky * 3 + 1] = zrow;
            t[ky * 3 + 2] = zrow;
            continue;
        }
        const int8_t *c1 = r + (size_t)ox * (size_t)step * c_n;   // column ix0 + 1 (always inside)
        t[ky * 3] = left ? c1 - c_n : zrow;
        t[ky * 3 + 1] = c1;
        t[ky * 3 + 2] = right ? c1 + c_n : zrow;
    }
}

// Scratch of a weighted layer, as offsets from its start: int16 weights,
// int16 rows (CONV3X3/PW1X1) or the zero-point row (DW3X3), then the
// per-channel requantisation constants (vd_rq_ch_t).
typedef struct scratch_layout {
    uint32_t w16, rows, ch;
} scratch_layout_t;

// Requantisation of one layer: per-channel constants (in its scratch) and
// the output clamp relative to the zero point.
typedef struct rq {
    const vd_rq_ch_t *ch;
    int32_t zp;
    int32_t lo;      // act_min - zp
    int32_t hi;      // act_max - zp
    bool general;    // some channel has shift > 0 (saturating left shift first)
    bool relu;       // lo >= 0: the sign correction of the rounding is not needed (conv.c rq_row)
} rq_t;

// One output value from z = requantize(sum + bias): clamp, zero point.
static inline int8_t vd_cnn_rq_out(int32_t z, int32_t zp, int32_t lo, int32_t hi)
{
    z = (z < lo) ? lo : z;
    z = (z > hi) ? hi : z;
    return (int8_t)(z + zp);
}

// kernels/scratch.c: the layout from the byte counts of the weight copy and
// the rows (returns the total in bytes), and the constants of a weighted layer
// (returned by value: a kernel's own copy, which none of its int8 stores can
// alias, so its loops keep the fields in registers).
uint64_t vd__cnn_scratch_pack(const vd_cnn_layer_t *L, uint32_t w_bytes, uint32_t r_bytes, scratch_layout_t *s);
rq_t vd__cnn_rq_setup(const vd_cnn_layer_t *L, uint8_t *scr, const scratch_layout_t *s);

// Each kernel writes output rows [y0, y1) of its layer; the input rows they
// read must be in the input ring. The scratch queries return the bytes of
// the layer's scratch (0: none) and fill its layout; `stream`: one scratch
// serves every layer of a streamed run.
uint64_t vd__cnn_conv_scratch(const vd_cnn_layer_t *L, bool stream, scratch_layout_t *s);
void vd__cnn_conv_rows(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0,
                      uint32_t y1, bool stream, uint8_t *scr);
// conv.c's int16 rows, shared with the AVX2 back end: the ks input rows of
// output row oy (NULL: padding row), and the rows of npix output pixels from x0.
void vd__cnn_conv_row_ptrs(const geom_t *g, const ring_t *in, uint32_t oy, int32_t step, int32_t ks,
                          const int8_t *rowp[5]);
void vd__cnn_conv_gather(const geom_t *g, const int8_t *const rowp[5], int32_t ks, int32_t step, uint32_t x0,
                        uint32_t npix, size_t kp, int16_t *rows);
uint64_t vd__cnn_dw3x3_scratch(const vd_cnn_layer_t *L, scratch_layout_t *s);
void vd__cnn_dw3x3_rows(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0,
                       uint32_t y1, uint8_t *scr);
void vd__cnn_maxpool2_rows(const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0, uint32_t y1);
void vd__cnn_upsample2_rows(const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0, uint32_t y1);
// ua / ub (0 or 1): operand a / b is a fused upsample and its ring the
// upsample's source, read at row y >> 1, column x >> 1.
void vd__cnn_concat_rows(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *a, uint32_t ua, const ring_t *b,
                        uint32_t ub, const ring_t *out, uint32_t y0, uint32_t y1);

// Where the grey input rows come from (kernels/input.c): a plane (img,
// stride) or a caller's row function writing into buf (vd_cnn_run_rows).
typedef struct in_src {
    const uint8_t *img;
    uint32_t stride;
    const vd_cnn_rows_t *rows;
    uint8_t *buf;        // width bytes (row function only)
} in_src_t;

// The input normalisation's lookup table (percentile stretch or equalisation) from a histogram of the whole
// plane in hist_area (VD_CNN_HIST_BYTES); kept: the table the previous run left there (VD_CNN_SAME_HIST),
// the input not read. NULL without a normalisation.
const int8_t *vd__cnn_norm_table(const vd_cnn_model_t *m, const in_src_t *src, uint32_t w, uint32_t h,
                                uint8_t *hist_area, bool kept);
// Rows [y0, y1) of tensor 0: pixel - 128, or lut[pixel].
void vd__cnn_input_rows(const in_src_t *src, uint32_t w, const int8_t *lut, const ring_t *t0, uint32_t y0, uint32_t y1);

// ------------------------------------------------------------ x86 back end (kernels/*x86*.c, CMake VD_CNN_X86)

// Kernel sets by what the CPU (and OS) supports.
#define VD_CNN_X86_NONE 0u     // portable C
#define VD_CNN_X86_AVX2 1u     // AVX2: 256-bit, int16 vpmaddwd
#define VD_CNN_X86_AVXVNNI 2u  // AVX2 and AVX-VNNI (VEX vpdpbusd on 256 bits: CPUs without AVX-512, e.g. Alder Lake)
#define VD_CNN_X86_AVX512 3u   // AVX-512 F, BW, VL and VNNI: vpdpbusd / vpdpwssd
// The best set this CPU runs (a CPU check per call, no cached global).
uint32_t vd__cnn_x86_level(void);
// The set a run with these flags takes (executor.c): VD_CNN_X86_NONE with VD_CNN_PORTABLE or without the
// x86 back end, else vd__cnn_x86_level(). Declared in every build (0 where VD_CNN_X86 is off).
uint32_t vd__cnn_x86_run_level(uint32_t flags);
// vd__cnn_conv_rows and vd__cnn_dw3x3_rows on the set `level` (not NONE):
// the same scratch, the same bytes.
// prep: the layer's area of a vd_cnn_prepare buffer made for `level` (NULL: made per call), both kernels.
void vd__cnn_conv_rows_x86(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0,
                          uint32_t y1, bool stream, uint8_t *scr, uint32_t level, const uint8_t *prep);
// Bytes of a CONV / PW / DW layer's prepared area for `level` (a multiple of 64), and when dst is not NULL
// (VD_WORKSPACE_ALIGN-aligned) the area itself: the layer's requantisation flags, then per tile of <= 64
// output channels its constants and packed weights (CONV / PW) or per pass its constants (DW), as the
// kernels make them per call (x86.c). zp_in: the layer's input zero point.
size_t vd__cnn_x86_prep_layer(const vd_cnn_layer_t *L, int32_t zp_in, uint32_t level, uint8_t *dst);
void vd__cnn_dw3x3_rows_x86(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                           uint32_t y0, uint32_t y1, uint8_t *scr, uint32_t level, const uint8_t *prep);

// A vd_cnn_prepare buffer's header (prepared.c): what it was made for, and each layer's area (0: none).
#define VD_CNN_PREP_MAGIC 0x50524550u   // "PREP"
#define VD_CNN_PREP_HDR 192u            // header bytes (>= sizeof, a multiple of 64)
typedef struct vd_cnn_prep_hdr {
    uint32_t magic;
    uint32_t level;          // x86 kernel set
    uint32_t crc32;          // the model's
    uint32_t bytes;          // the whole buffer's
    const uint8_t *blob;     // the model's
    uint32_t off[VD_CNN_MAX_LAYERS];
} vd_cnn_prep_hdr_t;
// The prepared areas a run at x86 level `level` reads: *hdr NULL when m has none or they are for another
// level (VD_CNN_PORTABLE runs); false when m->prepared's header does not match m (another model's buffer,
// or a damaged header: its layout is made again and compared).
bool vd__cnn_prepared_for(const vd_cnn_model_t *m, const chain_t *c, uint32_t level, const vd_cnn_prep_hdr_t **hdr);

// ------------------------------------------------------ CMSIS-NN back end (kernels/*cmsis*.c, CMake VD_CNN_CMSIS)

// vd__cnn_conv_rows and vd__cnn_dw3x3_rows on CMSIS-NN's kernels, with the layer's scratch (the same item
// as the portable kernels', scr_bytes long: the portable layout's size, or more when streamed) and the
// same bytes. False (nothing written) when the layer is not one CMSIS-NN computes bit-exactly (a channel
// with shift > 0 or < -30): the caller runs the portable kernel.
// prep: NULL (the DSP kernels' set-up, weights widened and requantisation constants, made in scr on every
// call), or the layer's prepared area (vd__cnn_cmsis_prep_bytes(L) > 0 bytes, 16-byte aligned): the call
// with y0 == 0 makes the set-up there, and the layer's later calls (y0 > 0: a run's calls of a layer go
// up its rows from 0, schedule.c) read it back, so the area must be untouched in between.
bool vd__cnn_conv_rows_cmsis(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                            uint32_t y0, uint32_t y1, bool stream, uint8_t *scr, uint8_t *prep);
bool vd__cnn_dw3x3_rows_cmsis(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                             uint32_t y0, uint32_t y1, uint8_t *scr, uint32_t scr_bytes, uint8_t *prep);
// Bytes of layer L's prepared area (multiple of VD_CNN_ITEM_ALIGN); 0 when its kernel keeps none (not a
// layer of the DSP kernels, or a build without them: -Os, no DSP extension).
uint32_t vd__cnn_cmsis_prep_bytes(const vd_cnn_layer_t *L);

// ------------------------------------------------------------ decode (decode.c)

// Decoded heatmap score (Q15, 0..32768) of int8 value v (-128..127) of a
// model vd_cnn_load filled (its score table is checked there); the table
// vd_cnn_thr_from_score searches.
uint32_t vd__cnn_score_of_logit(const vd_cnn_model_t *m, int32_t v);

// An incremental decode (vd_cnn_decode row by row): the head's rows arrive in order, and rows
// [next, avail - 1) (all of them once avail == h) are decided as they can be: a row's peak test reads the
// rows above and below it. A peak's box is made when it enters the top-K, from its cell, so the head row
// need not outlive the decision.
typedef struct dec_state {
    const vd_cnn_model_t *m;
    vd_cnn_box_t *boxes;
    size_t k;              // top-K: min(max_peaks, capacity)
    size_t n;              // boxes so far (<= k)
    int32_t thr;           // int8 heatmap threshold
    uint32_t w, h;         // head grid (channels and stride: the model's)
    uint32_t frame_w, frame_h;
    uint32_t next;         // first row not yet decided
} dec_state_t;

// Checks the decode parameters for a head of w x h cells of loaded model m and fills *d (no row decided).
// VD_ERR_ARG as vd_cnn_decode.
vd_status_t vd__cnn_decode_start(const vd_cnn_model_t *m, uint32_t w, uint32_t h, const vd_cnn_decode_opts_t *o,
                                 vd_cnn_box_t *boxes, size_t capacity, dec_state_t *d);
// Decides the rows that can be, given head rows [0, avail) with row y at
// ring + (y % ring_rows) * (w * c_n) for the rows still in the ring.
void vd__cnn_decode_rows(dec_state_t *d, const int8_t *ring, uint32_t ring_rows, uint32_t avail);

#endif
