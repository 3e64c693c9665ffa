// SPDX-License-Identifier: MIT
// int8 fully convolutional detector network: loads a .vdm (version 3) in place, runs it, decodes boxes.
//
// Lifetime: vd_cnn_model_t only points into the blob given to vd_cnn_load();
// the blob (e.g. a const array in flash) must outlive the model unchanged.
// The model is read-only after loading: any number of callers may use it at
// once, each with its own workspace. A vd_cnn_output_t points into the
// workspace of the run that filled it and is valid until that workspace is
// used again. Format: docs/model-format.md ("CNN kind"); arithmetic:
// docs/fixed-point.md ("cnn").
//
// Typical use:
//   static vd_cnn_model_t m;  vd_cnn_load(&m, blob, n);
//   vd_cnn_workspace_size(&m, 320, 256, &bytes);   // once; allocate `bytes`
//   vd_cnn_run(&m, img, 320, 256, stride, ws, bytes, &head);
//   vd_cnn_decode(&m, &head, VD_CNN_THR_DEFAULT, 0, frame_w, frame_h, boxes, cap, &n);
#ifndef VD_CNN_H
#define VD_CNN_H

#include <stddef.h>
#include <stdint.h>

#include "vd/image.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// .vdm format version of the CNN kind (versions 1-2 are the DBN, see vd/dbn.h).
#define VD_CNN_FORMAT_VERSION 3u
// Header and layer-table entry sizes in bytes; the kind byte at offset 16.
#define VD_CNN_HEADER_SIZE 128u
#define VD_CNN_LAYER_ENTRY_SIZE 32u
#define VD_CNN_KIND 2u

// Largest number of layers, 1..32 (sets sizeof(vd_cnn_model_t) and the run
// record; firmware may lower it); tensors are 0..n_layers.
#ifndef VD_CNN_MAX_LAYERS
#define VD_CNN_MAX_LAYERS 32u
#endif
#define VD_CNN_MAX_TENSORS (VD_CNN_MAX_LAYERS + 1u)
// Largest channel count of a tensor (cin, cout).
#define VD_CNN_MAX_CHANNELS 1024u
// Largest network input width/height, and largest downsample factor of a tensor.
#define VD_CNN_MAX_SIDE 4096u
#define VD_CNN_MAX_FACTOR 1024u
// Largest top-K of decoding (header max_peaks).
#define VD_CNN_MAX_PEAKS 1024u

// Decode table ranges: score Q15 0..32768; box size Q8 network pixels
// 0..4096*256; centre offset Q8 cells -256..512.
#define VD_CNN_SCORE_ONE_Q15 32768
#define VD_CNN_SIZE_MAX_Q8 (4096L * 256L)
#define VD_CNN_OFFSET_MIN_Q8 (-256)
#define VD_CNN_OFFSET_MAX_Q8 512

// vd_cnn_decode thr_i8: use the header's score_threshold_i8.
#define VD_CNN_THR_DEFAULT INT32_MIN

// vd_cnn_workspace_size_ex / vd_cnn_run_ex flag: give every tensor its own
// memory so that vd_cnn_tensor() can read any of them after the run (parity
// tests, debugging). Without it tensors share memory by liveness.
#define VD_CNN_KEEP_TENSORS 1u
// vd_cnn_workspace_size_ex / vd_cnn_run_ex flag: run the network in bands of
// head rows, every tensor but the head kept as a ring of the rows its
// consumers still read (MCUNetV2-style band inference); an upsample that
// only concats read is not stored at all (they read its source). The head is
// bit-identical to the whole-plane run; the workspace is a fraction of it
// (models/vd_cnn.vdm at 320x256: docs/embedded.md). The detector uses it.
// With VD_CNN_KEEP_TENSORS too, every tensor the head depends on is kept
// whole (for vd_cnn_tensor); tensors the head does not depend on are not
// computed.
#define VD_CNN_STREAM 2u
// vd_cnn_workspace_size_ex / vd_cnn_run_ex / vd_cnn_run_rows flag: run the
// portable C kernels even where the library was built with the optional
// x86-64 kernels (CMake option VD_CNN_X86: AVX-512 VNNI or AVX2, chosen at
// run time by a CPU check) and the CPU has them, or with the CMSIS-NN
// kernels for Cortex-M (CMake option VD_CNN_CMSIS). Both give the same bytes on every
// tensor (tests/unit/test_cnn.c); the flag exists for that parity test and
// for timing. No effect on the workspace size; ignored where neither back
// end is built.
#define VD_CNN_PORTABLE 4u

// vd_cnn_run_ex / vd_cnn_run_rows flag: keep the ring heights of the previous run in the same workspace
// when that run completed with the same model, size and flags (without this one): the streamed row
// schedule's sizing walk, most of a plan's cost (~0.8 M instructions per frame of vd_cnn_compact on a
// Cortex-M7, docs/embedded.md). What is kept is checked (a CRC and bounds; the workspace is caller
// memory), so any content is safe and the results are the same bytes. The run reads the workspace's first
// bytes before writing them: the workspace must hold what an earlier vd_cnn_run* call left, or be zeroed
// by the caller (memory checkers report reads of never-written memory). No effect on the workspace size.
// The detector uses it.
#define VD_CNN_REUSE_PLAN 8u
// vd_cnn_run_ex / vd_cnn_run_rows flag, with VD_CNN_STREAM and VD_CNN_REUSE_PLAN: the caller promises that
// this run's input has the grey-level histogram of the previous run in the same workspace (the detector's
// mirrored pass: the same pixels in another order), so the run takes that run's normalisation table
// (percentile stretch or equalisation) instead of reading its whole input once more for a histogram.
// Honoured only when the plan is kept from a complete run (VD_CNN_REUSE_PLAN: same model, size and other
// flags); otherwise the table is made as without it. A broken promise gives the earlier input's table
// (other values, never a read or write outside the workspace). No effect on the workspace size.
#define VD_CNN_SAME_HIST 16u
// vd_cnn_workspace_size_ex / vd_cnn_run_rows_decode flag, with VD_CNN_STREAM and without
// VD_CNN_KEEP_TENSORS: the head too is a ring, of the rows the decoder still reads (band + 2: a row's
// peaks are decided once the row below it exists), and its rows are decoded as they are made, so no
// whole head is stored (models/vd_cnn.vdm at 320x256: 25 600 B less; at 640x512: 102 400 B). Only
// vd_cnn_run_rows_decode takes it (the other runs return the whole head); the boxes are the same bytes
// as vd_cnn_run_rows + vd_cnn_decode. The detector uses it.
#define VD_CNN_HEAD_RING 32u

// Layer ops (field `op` of a layer entry).
typedef enum vd_cnn_op {
    VD_CNN_OP_CONV3X3 = 1,   // full 3x3 convolution, padding 1, stride 1 or 2
    VD_CNN_OP_DW3X3 = 2,     // depthwise 3x3, padding 1, stride 1 or 2
    VD_CNN_OP_PW1X1 = 3,     // pointwise 1x1
    VD_CNN_OP_MAXPOOL2 = 4,  // 2x2 max-pool, stride 2
    VD_CNN_OP_UPSAMPLE2 = 5, // nearest x2 upsample
    VD_CNN_OP_CONCAT = 6,    // channel concatenation of tensors `in` and `in2`
    VD_CNN_OP_CONV5X5 = 7    // full 5x5 convolution, padding 2, stride 1 or 2 (paper 003's network)
} vd_cnn_op_t;

// Input normalisation (header input_norm).
typedef enum vd_cnn_norm {
    VD_CNN_NORM_NONE = 0,       // q = pixel - 128
    VD_CNN_NORM_PERCENTILE = 1, // per-frame percentile stretch (docs/fixed-point.md "cnn")
    VD_CNN_NORM_EQUALISE = 2    // per-frame histogram equalisation (mid-rank; docs/fixed-point.md "cnn")
} vd_cnn_norm_t;

// One layer, pointing into the blob. Layer i reads tensor `in` (and `in2`
// for CONCAT) and produces tensor i+1. Arrays are NULL for ops 4-6.
// bias and mult point at little-endian int32 bytes and are read byte by byte
// (any host endianness, no alignment needed beyond the loader's checks).
typedef struct vd_cnn_layer {
    uint8_t op;               // vd_cnn_op_t
    uint8_t stride;           // 1, or 2 for CONV3X3/DW3X3/CONV5X5
    uint8_t in;               // input tensor index, <= layer index
    uint8_t in2;              // CONCAT: second input tensor; else 0
    uint16_t cin;             // channels of tensor `in`
    uint16_t cout;            // output channels, 1..1024
    int8_t out_zp;            // output zero point
    int8_t act_min;           // output clamp (ReLU: act_min = out_zp)
    int8_t act_max;
    const int8_t *w;          // CONV3X3 [cout][3][3][cin], DW3X3 [3][3][cout], PW1X1 [cout][cin],
                              // CONV5X5 [cout][5][5][cin]
    const uint8_t *bias;      // int32 LE [cout], accumulator units
    const uint8_t *mult;      // int32 LE [cout], Q31 2^30 .. 2^31-1
    const int8_t *shift;      // [cout], -31 .. 7
} vd_cnn_layer_t;

// A loaded model. Complete so the caller can own it; fill it only with
// vd_cnn_load(). All pointers point into the blob.
typedef struct vd_cnn_model {
    const uint8_t *blob;      // start of the blob (NULL: not loaded)
    uint32_t size;            // total_size from the header (<= bytes given)
    uint32_t crc32;           // CRC-32 stored in (and verified against) the blob
    uint16_t format_version;  // 3
    uint8_t input_norm;       // vd_cnn_norm_t
    uint8_t out_channels;     // C_out of the head tensor: 3 or 5
    uint16_t input_w;         // nominal network input size (multiples of align)
    uint16_t input_h;
    uint16_t norm_lo_permille;  // percentile stretch parameters (0 without it)
    uint16_t norm_hi_permille;
    uint16_t norm_min_range;
    int8_t input_zp;          // -128
    uint8_t out_stride;       // 4 or 8: network input pixels per head cell
    int8_t score_threshold_i8; // default heatmap threshold: an int8 code of the head (its logit quantised), not a Q format
    uint16_t max_peaks;       // default top-K, 1..1024
    uint32_t align;           // A: run sizes must be multiples of it (largest tensor downsample factor)
    char name[17];            // model name, NUL-terminated
    uint32_t n_layers;        // 1..VD_CNN_MAX_LAYERS
    vd_cnn_layer_t layers[VD_CNN_MAX_LAYERS];
    const uint8_t *decode_table;  // int32 LE [out_channels][256], indexed by int8 value + 128
    const uint8_t *prepared;  // vd_cnn_prepare's buffer (NULL: none; vd_cnn_load sets NULL)
} vd_cnn_model_t;

// A tensor of a run: HWC int8, element (y, x, c) at data[(y*w + x)*c_count + c].
typedef struct vd_cnn_output {
    const int8_t *data;       // points into the workspace
    uint32_t w;               // width, height, channels
    uint32_t h;
    uint32_t c;
    uint32_t stride;          // downsample factor: network input pixels per element (out_stride for the head)
    int32_t zp;               // zero point
} vd_cnn_output_t;

// A decoded detection.
typedef struct vd_cnn_box {
    vd_rect_t rect;           // frame pixels, clamped to the frame, w, h >= 1
    uint16_t score_q15;       // decode table score of the peak, Q15 (32768 = 1.0)
    int8_t logit;             // heatmap value of the peak
} vd_cnn_box_t;

// Validates a version-3 .vdm blob in place and fills *m with pointers into it.
// m:     caller-owned model; written only on VD_OK.
// blob:  the .vdm bytes, 4-byte aligned; must outlive *m unchanged.
// bytes: bytes available at blob (>= total_size; any excess is ignored).
// Returns VD_OK; VD_ERR_ARG for m or blob NULL, bytes == 0 or blob not 4-byte
// aligned; VD_ERR_MODEL for anything wrong in the blob: short blob, magic,
// version (1-2 are DBN blobs: vd_dbn_load), header size, total size, CRC,
// kind, header fields out of range (normalisation, sizes, zero point,
// out_stride, max_peaks, name, nonzero flags/reserved), layer table or any
// array misplaced, misaligned, overlapping or past total_size, unknown op,
// bad stride, tensor index not earlier than the layer, channel chain,
// downsample factor (> 1024, UPSAMPLE2 at factor 1, CONCAT of different
// sizes, head factor != out_stride), zero point / clamp rules, multiplier,
// shift or bias out of range, input size not a multiple of the alignment,
// decode table out of range or score not non-decreasing.
// Time O(total_size) (CRC + one pass over per-channel arrays and the decode
// table) plus O(arrays^2) overlap checks. Stack (Cortex-M7 -Os, own frame
// plus deepest call): ~420 bytes.
VD_API vd_status_t vd_cnn_load(vd_cnn_model_t *m, const void *blob, size_t bytes);

// Workspace bytes vd_cnn_run() needs for input size width x height: the input
// tensor, every activation, the stretch histogram and per-layer scratch
// (int16 weight copies, requantisation constants), placed by a deterministic
// first-fit liveness planner (a tensor lives from the layer that writes it to
// its last reader; the head tensor to the end), plus a small run record.
// Pure function of (m, width, height).
// Returns VD_OK; VD_ERR_ARG for NULL m/bytes or a size that is 0, > 4096 or
// not a multiple of m->align; VD_ERR_STATE if m is not loaded;
// VD_ERR_OVERFLOW if the total does not fit 32 bits.
// Time O(n_layers^2), streamed plus O((height + head height) n_layers^2) for
// the ring sizing; stack ~1.5 KiB (the plan; an init-time call).
VD_API vd_status_t vd_cnn_workspace_size(const vd_cnn_model_t *m, uint32_t width, uint32_t height, size_t *bytes);

// As vd_cnn_workspace_size, with flags (0, VD_CNN_KEEP_TENSORS, VD_CNN_STREAM
// or both). VD_ERR_ARG also for any other flag bit.
VD_API vd_status_t vd_cnn_workspace_size_ex(const vd_cnn_model_t *m, uint32_t width, uint32_t height, uint32_t flags,
                                     size_t *bytes);

// Optional host speed-up: the bytes vd_cnn_prepare needs for m on this CPU. Only the x86-64 kernel sets
// (CMake VD_CNN_X86) use prepared weights; elsewhere, or on a CPU without AVX2, *bytes is 0.
// Returns VD_OK; VD_ERR_ARG for NULL m/bytes; VD_ERR_STATE if m is not loaded. Time O(n_layers).
VD_API vd_status_t vd_cnn_prepared_size(const vd_cnn_model_t *m, size_t *bytes);

// Packs the weights of every CONV3X3 / CONV5X5 / PW1X1 layer of m for the x86 kernel set this CPU runs,
// with their requantisation constants (and DW3X3 layers' constants), into buf and points m->prepared at
// it, so that runs read them
// instead of repacking them for every band of rows (about a tenth of a streamed frame's time on x86;
// docs/performance.md). Runs give the same bytes with or without it; runs with VD_CNN_PORTABLE ignore it.
// buf: VD_WORKSPACE_ALIGN-aligned (64 suits the kernels' cache lines), >= vd_cnn_prepared_size() bytes,
// owned by the caller, unchanged and alive while m is used (it holds the model's blob address and CRC,
// which every run checks). bytes 0 (the size on other back ends): m->prepared stays NULL and buf may be
// NULL. A model whose memory must stay small (an ECU's) simply never calls this.
// Returns VD_OK; VD_ERR_ARG for NULL m; VD_ERR_STATE if m is not loaded; VD_ERR_WORKSPACE for a NULL,
// misaligned or short buf where bytes are needed. Time O(weights); stack ~4 KiB (one tile's constants).
VD_API vd_status_t vd_cnn_prepare(vd_cnn_model_t *m, void *buf, size_t bytes);

// Runs the network on one grey plane.
// img:      width x height uint8 pixels, row stride stride_bytes (>= width),
//           not inside ws; width, height: multiples of m->align, 1..4096
//           (network input size; resample the frame first if it differs).
// ws/bytes: caller workspace, VD_WORKSPACE_ALIGN-aligned, >= vd_cnn_workspace_size().
// out:      the head tensor (w = width / out_stride, h likewise, c = out_channels),
//           pointing into ws.
// Returns VD_OK; VD_ERR_ARG for NULL img/out or bad sizes/stride; VD_ERR_STATE
// if m is not loaded; VD_ERR_WORKSPACE for a NULL, misaligned or short ws;
// VD_ERR_OVERFLOW as vd_cnn_workspace_size.
// Bit-exact with the numpy integer reference (tools/vdtools/formats/cnn_ref.py).
// Time: vd_cnn_macs() multiply-adds plus one requantisation per output value;
// stack ~1.1 KiB on Cortex-M7 -Os (the plan lives in the workspace's run
// record, not on the stack).
VD_API vd_status_t vd_cnn_run(const vd_cnn_model_t *m, const uint8_t *img, uint32_t width, uint32_t height,
                       uint32_t stride_bytes, void *ws, size_t bytes, vd_cnn_output_t *out);

// As vd_cnn_run, with flags (0, VD_CNN_KEEP_TENSORS, VD_CNN_STREAM or both;
// the workspace must be sized by vd_cnn_workspace_size_ex with the same flags).
VD_API vd_status_t vd_cnn_run_ex(const vd_cnn_model_t *m, const uint8_t *img, uint32_t width, uint32_t height,
                          uint32_t stride_bytes, uint32_t flags, void *ws, size_t bytes, vd_cnn_output_t *out);

// A source of network input rows for vd_cnn_run_rows: row(ctx, y, dst)
// writes row y (0..height-1) of the width x height grey plane to dst (width
// bytes, inside the workspace). It is called for every row in order for the
// percentile histogram (models with that normalisation), then again for
// each row, in order, as the network needs it; it must return the same
// bytes each time and cannot fail (a caller records its own errors in ctx).
typedef struct vd_cnn_rows {
    void (*row)(void *ctx, uint32_t y, uint8_t *dst);
    void *ctx;
} vd_cnn_rows_t;

// As vd_cnn_run_ex, with the input plane made row by row by `rows` instead
// of read from memory (the detector makes its half-resolution rows this way
// and holds no input plane). flags must include VD_CNN_STREAM.
// Returns as vd_cnn_run_ex; VD_ERR_ARG also for NULL rows / rows->row or
// flags without VD_CNN_STREAM.
VD_API vd_status_t vd_cnn_run_rows(const vd_cnn_model_t *m, const vd_cnn_rows_t *rows, uint32_t width, uint32_t height,
                            uint32_t flags, void *ws, size_t bytes, vd_cnn_output_t *out);

// Tensor `index` (0 = preprocessed input, i+1 = output of layer i) of the
// last run made with ws at width x height. With VD_CNN_KEEP_TENSORS every
// tensor is available (streamed: every tensor the head depends on); without
// it only tensors that no later layer overwrote (always the head; streamed,
// only the head).
// Returns VD_OK; VD_ERR_ARG for NULL arguments, bad sizes or index >
// n_layers; VD_ERR_STATE if m is not loaded, ws holds no run of this model
// at this size, or the tensor was overwritten; VD_ERR_WORKSPACE for a short ws.
// The plan is read back from the run record in ws (bounds-checked against
// bytes). Stack ~320 bytes.
VD_API vd_status_t vd_cnn_tensor(const vd_cnn_model_t *m, const void *ws, size_t bytes, uint32_t width, uint32_t height,
                          uint32_t index, vd_cnn_output_t *t);

// Decodes the head tensor into boxes in frame coordinates.
// out:       the head from vd_cnn_run (c == out_channels, stride == out_stride).
// thr_i8:    int8 heatmap threshold -128..127, or VD_CNN_THR_DEFAULT (header's).
// max_peaks: top-K, 0 = header's.
// frame_w/h: frame size the boxes are scaled to, 1..VD_MAX_DIM (the network
//            input is out->w * out_stride x out->h * out_stride).
// boxes:     capacity entries (may be NULL when capacity is 0); K =
//            min(max_peaks, capacity) best peaks, by logit descending, then
//            raster order. *count receives the number written.
// Peaks: heatmap (channel 0) >= thr_i8, > the 4 neighbours before in raster
// order, >= the 4 after (outside the grid ignored). Box: centre
// (x + offset) * out_stride, size from the decode table, rounded half up to
// frame pixels and clamped (docs/fixed-point.md "cnn").
// Returns VD_OK (fewer peaks than K is not an error: top-K drops the rest by
// design); VD_ERR_ARG for NULL m/out/count (or boxes with capacity > 0),
// out not matching m, thr_i8 or frame size out of range; VD_ERR_STATE if m is
// not loaded. Time O(Wo*Ho*(1 + K)) worst case; no workspace; stack a few words.
VD_API vd_status_t vd_cnn_decode(const vd_cnn_model_t *m, const vd_cnn_output_t *out, int32_t thr_i8, uint32_t max_peaks,
                          uint32_t frame_w, uint32_t frame_h, vd_cnn_box_t *boxes, size_t capacity, size_t *count);

// vd_cnn_decode's parameters for vd_cnn_run_rows_decode.
typedef struct vd_cnn_decode_opts {
    int32_t thr_i8;        // int8 heatmap threshold -128..127, or VD_CNN_THR_DEFAULT (header's)
    uint32_t max_peaks;    // top-K, 0 = header's
    uint32_t frame_w;      // frame size the boxes are scaled to, 1..VD_MAX_DIM
    uint32_t frame_h;
} vd_cnn_decode_opts_t;

// vd_cnn_run_rows then vd_cnn_decode in one streamed pass: each head row is decoded as soon as the row
// below it is made, so with VD_CNN_HEAD_RING the head needs only a ring of rows (the workspace must be
// sized by vd_cnn_workspace_size_ex with the same flags). flags: VD_CNN_STREAM required, VD_CNN_KEEP_TENSORS
// refused; the others as vd_cnn_run_rows. boxes / capacity / *count as vd_cnn_decode, the same bytes.
// Returns as vd_cnn_run_rows, and VD_ERR_ARG as vd_cnn_decode for dec (NULL, thr_i8 or frame size out of
// range), boxes NULL with capacity > 0 or NULL count, all checked before the run. With VD_CNN_HEAD_RING
// vd_cnn_tensor cannot read the head afterwards (VD_ERR_STATE) unless its ring is the whole head.
// Time: vd_cnn_run_rows plus vd_cnn_decode; stack: vd_cnn_run_rows' plus the decoder state (~60 B).
VD_API vd_status_t vd_cnn_run_rows_decode(const vd_cnn_model_t *m, const vd_cnn_rows_t *rows, uint32_t width,
                                          uint32_t height, uint32_t flags, void *ws, size_t bytes,
                                          const vd_cnn_decode_opts_t *dec, vd_cnn_box_t *boxes, size_t capacity,
                                          size_t *count);

// The int8 heatmap threshold of a score threshold: the smallest logit v in
// -128..127 whose decoded score (decode table channel 0) is >= score_q15.
// The loader checks that the score table never decreases, so for vd_cnn_decode
// "logit >= *thr_i8" is exactly "box score_q15 >= score_q15": a probability
// threshold becomes a thr_i8 without changing which peaks top-K sees.
//   score_q15  0..32768 (32768 = 1.0; 0 gives -128, every peak).
//   thr_i8     out: -128..127; written only on VD_OK.
// Returns VD_OK; VD_ERR_ARG for NULL m/thr_i8 or score_q15 > 32768;
// VD_ERR_STATE if m is not loaded; VD_ERR_RANGE when even logit 127 scores
// below score_q15 (no box can pass).
// Time O(n_layers) (model check) + 8 table reads (binary search); stack a few words.
VD_API vd_status_t vd_cnn_thr_from_score(const vd_cnn_model_t *m, uint32_t score_q15, int32_t *thr_i8);

// Multiply-adds of one run at width x height (CONV3X3 9*cin*cout, DW3X3 9*c,
// PW1X1 cin*cout, CONV5X5 25*cin*cout per output pixel).
// Returns VD_OK; VD_ERR_ARG / VD_ERR_STATE as vd_cnn_workspace_size.
VD_API vd_status_t vd_cnn_macs(const vd_cnn_model_t *m, uint32_t width, uint32_t height, uint64_t *macs);

// The kernel set vd_cnn_run* takes on this CPU without VD_CNN_PORTABLE, for figures that say what ran:
// "avx512-vnni", "avx-vnni" or "avx2" (x86-64 builds with the x86 back end, CMake VD_CNN_X86: a CPU check,
// made by every run), "cmsis-nn" (builds with the CMSIS-NN back end, VD_CNN_CMSIS; the layers CMSIS-NN cannot
// compute exactly run the portable kernels), else "portable". A static string, never NULL; cannot fail.
VD_API const char *vd_cnn_kernel_set(void);

#ifdef __cplusplus
}
#endif
#endif
