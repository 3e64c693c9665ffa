// SPDX-License-Identifier: MIT
// CNN executor: vd_cnn_run, vd_cnn_run_ex and vd_cnn_run_rows: tensor 0 from the frame, then every layer's
// rows through its kernel, whole plane or streamed, on the workspace the plan laid out.
//
// Algorithm: a fully convolutional network over int8 HWC tensors (channels innermost). Tensor 0 is the
// grey frame as int8 (pixel - 128, or a per-frame percentile stretch; kernels/input.c); layer i writes
// tensor i+1 with one of seven ops: 3x3 convolution and depthwise 3x3 (padding 1, stride 1/2), pointwise
// 1x1, 2x2 max-pool, x2 nearest upsample, channel concat, 5x5 convolution (padding 2, stride 1/2; op 7,
// paper 003's feature network). Weighted ops compute
//   out = clamp(zp_out + requantize(bias + sum w * (x - zp_in)), act_min, act_max)
// with TFLite's double-rounding requantisation (models/requant.h, folded into one 64-bit floor shift
// per value). The plan (plan.c) is made into the workspace's run record first; whole plane, the layers
// run in order; streamed (VD_CNN_STREAM), the row schedule (schedule.c) says which rows of which tensor
// to make at each sub-step, so the same kernels work on ring-buffer rows and the head is bit-identical.
// Back ends: per layer call, the x86 kernels (CMake VD_CNN_X86: AVX-512 VNNI or AVX2, by a CPU check
// unless VD_CNN_PORTABLE) take over CONV / PW / DW with the same scratch and the same bytes, and on
// Cortex-M the CMSIS-NN kernels (CMake VD_CNN_CMSIS, unless VD_CNN_PORTABLE) likewise for the layers they
// compute bit-exactly; other ops and other hosts run the portable kernels.
// Reference: TFLite/CMSIS-NN int8 quantisation; the numpy integer reference
// tools/vdtools/formats/cnn_ref.py (bit-exact); arithmetic docs/fixed-point.md ("cnn").
// Bounds: vd_cnn_macs() multiply-adds, one requantisation per output value, O(width * height) for the
// input; streamed, the schedule adds O((H0 + Hn) L) counter updates per run. Stack (Cortex-M7 -Os, worst
// call chain): run ~1.1 KiB (the kernels are separate functions, so their locals are not summed).
#include "vd/cnn.h"

#include "models/cnn/cnn_internal.h"
#include "internal/vd_internal.h"

#include <string.h>

// Tensor t in the workspace as a ring (its plan item, row bytes, ring height).
static ring_t ring_of(uint8_t *ws, const vd_cnn_plan_t *p, const chain_t *c, uint32_t t)
{
    ring_t r;
    r.base = (int8_t *)(void *)(ws + p->off[vd_cnn_item_of_tensor(t)]);
    r.row = (size_t)(p->width / c->f[t]) * c->chan[t];
    r.rows = p->rows[t];
    return r;
}

// What the streamed sub-steps need to make rows of any tensor.
typedef struct run_io {
    const in_src_t *src;
    const int8_t *lut;
    uint8_t *base;
    const chain_t *c;
    uint32_t level;   // x86 kernel set of the run (vd__cnn_x86_run_level), 0 without the x86 back end
    const vd_cnn_prep_hdr_t *prep;   // the model's prepared areas for that set (NULL: none)
} run_io_t;

// The optional x86 kernels run unless the caller asked for the portable ones or the CPU lacks AVX2: asked
// once per run (no global state), not per layer call: the CPUID behind AVX-VNNI traps to the hypervisor in
// a virtual machine (~2 us; per row and layer it took 44 % of the demo's time on one).
uint32_t vd__cnn_x86_run_level(uint32_t flags)
{
#if defined(VD_CNN_X86)
    return ((flags & VD_CNN_PORTABLE) != 0u) ? VD_CNN_X86_NONE : vd__cnn_x86_level();
#else
    (void)flags;
    return 0u;
#endif
}

// Output rows [y0, y1) of layer l; its input rows must be in their rings.
static void layer_rows(const vd_cnn_model_t *m, const chain_t *c, const vd_cnn_plan_t *p, uint8_t *base, uint32_t l,
                       uint32_t y0, uint32_t y1, uint32_t level, const vd_cnn_prep_hdr_t *ph)
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
    const uint32_t scr_item = ((p->flags & VD_CNN_STREAM) != 0u) ? 3u : 3u + 2u * l;
    uint8_t *scr = base + p->off[scr_item];
#if defined(VD_CNN_X86)
    const uint8_t *x86_prep = (ph != NULL && ph->off[l] != 0u) ? (const uint8_t *)(const void *)ph + ph->off[l] : NULL;
#else
    (void)level;
    (void)ph;
#endif
#if defined(VD_CNN_CMSIS)
    // CMSIS-NN takes the layers it computes bit-exactly unless the caller asked for the portable kernels.
    const bool cmsis = (p->flags & VD_CNN_PORTABLE) == 0u;
    // Streamed, the layer's prepared area if the plan gave it one (plan.c prep_size).
    uint32_t prep_len;
    const uint32_t prep_off = vd_cnn_prep_at(m, p, l, &prep_len);
    uint8_t *prep = (prep_len != 0u) ? base + prep_off : NULL;
#endif
    switch (L->op) {
    case VD_CNN_OP_CONV3X3:
    case VD_CNN_OP_CONV5X5:
    case VD_CNN_OP_PW1X1:
#if defined(VD_CNN_X86)
        if (level != VD_CNN_X86_NONE) {
            vd__cnn_conv_rows_x86(L, &g, &in, &o, y0, y1, (p->flags & VD_CNN_STREAM) != 0u, scr, level, x86_prep);
            break;
        }
#endif
#if defined(VD_CNN_CMSIS)
        if (cmsis && vd__cnn_conv_rows_cmsis(L, &g, &in, &o, y0, y1, (p->flags & VD_CNN_STREAM) != 0u, scr, prep)) {
            break;
        }
#endif
        vd__cnn_conv_rows(L, &g, &in, &o, y0, y1, (p->flags & VD_CNN_STREAM) != 0u, scr);
        break;
    case VD_CNN_OP_DW3X3:
#if defined(VD_CNN_X86)
        if (level != VD_CNN_X86_NONE) {
            vd__cnn_dw3x3_rows_x86(L, &g, &in, &o, y0, y1, scr, level, x86_prep);
            break;
        }
#endif
#if defined(VD_CNN_CMSIS)
        if (cmsis && vd__cnn_dw3x3_rows_cmsis(L, &g, &in, &o, y0, y1, scr, p->len[scr_item], prep)) {
            break;
        }
#endif
        vd__cnn_dw3x3_rows(L, &g, &in, &o, y0, y1, scr);
        break;
    case VD_CNN_OP_MAXPOOL2:
        vd__cnn_maxpool2_rows(&g, &in, &o, y0, y1);
        break;
    case VD_CNN_OP_UPSAMPLE2: {
        vd__cnn_upsample2_rows(&g, &in, &o, y0, y1);
        break;
    }
    default: {
        const uint32_t ua = (p->live[L->in] == VD_CNN_LIVE_FUSED) ? 1u : 0u;
        const uint32_t ub = (p->live[L->in2] == VD_CNN_LIVE_FUSED) ? 1u : 0u;
        // A fused upsample's source: the input of the layer that makes it.
        const ring_t a = ring_of(base, p, c, (ua != 0u) ? m->layers[L->in - 1u].in : L->in);
        const ring_t b = ring_of(base, p, c, (ub != 0u) ? m->layers[L->in2 - 1u].in : L->in2);
        vd__cnn_concat_rows(L, &g, &a, ua, &b, ub, &o, y0, y1);
        break;
    }
    }
}

// Rows [p->done[t], p->req[t]) of tensor t (a sub-step of the schedule).
static void produce(const vd_cnn_model_t *m, const vd_cnn_plan_t *p, const run_io_t *io, uint32_t t)
{
    if (t == 0u) {
        const ring_t t0 = ring_of(io->base, p, io->c, 0u);
        vd__cnn_input_rows(io->src, p->width, io->lut, &t0, p->done[0], p->req[0]);
    } else if (p->live[t] != VD_CNN_LIVE_FUSED) {   // a fused upsample is read through by its concats
        layer_rows(m, io->c, p, io->base, t - 1u, p->done[t], p->req[t], io->level, io->prep);
    }
}

// What vd_cnn_run_rows_decode asks of run_any: the decode's parameters, and its state (set by run_any
// once the model and size are checked).
typedef struct dec_req {
    const vd_cnn_decode_opts_t *opts;
    vd_cnn_box_t *boxes;
    size_t capacity;
    dec_state_t st;
} dec_req_t;

// vd_cnn_run_ex, vd_cnn_run_rows and vd_cnn_run_rows_decode: exactly one of img, rows is set; dec (streamed
// only): decode the head rows as they are made (the only way a ring head, VD_CNN_HEAD_RING, is read).
static vd_status_t run_any(const vd_cnn_model_t *m, const uint8_t *img, const vd_cnn_rows_t *rows, uint32_t width,
                           uint32_t height, uint32_t stride_bytes, uint32_t flags, void *ws, size_t bytes,
                           vd_cnn_output_t *out, dec_req_t *dec)
{
    VD_VERIFY(m != NULL && out != NULL && (flags & ~VD_CNN_RUN_FLAGS) == 0u, VD_ERR_ARG);
    // A ring head is read only by the decoder; the decoder runs in the streamed schedule, on a ring or a
    // whole head (never with KEEP_TENSORS, whose head the caller reads).
    VD_VERIFY((flags & VD_CNN_HEAD_RING) == 0u || dec != NULL, VD_ERR_ARG);
    VD_VERIFY(dec == NULL || ((flags & VD_CNN_STREAM) != 0u && (flags & VD_CNN_KEEP_TENSORS) == 0u), VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(vd__cnn_model_ok(m, &c), VD_ERR_STATE);
    VD_VERIFY(vd__cnn_size_ok(m, width, height) && (rows != NULL || stride_bytes >= width), VD_ERR_ARG);
    const uint32_t level = vd__cnn_x86_run_level(flags);
    const vd_cnn_prep_hdr_t *ph;
    VD_VERIFY(vd__cnn_prepared_for(m, &c, level, &ph), VD_ERR_STATE);
    if (dec != NULL) {
        const uint32_t f = c.f[m->n_layers];
        VD_TRY(vd__cnn_decode_start(m, width / f, height / f, dec->opts, dec->boxes, dec->capacity, &dec->st));
    }
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % (uintptr_t)VD_WORKSPACE_ALIGN) == 0u, VD_ERR_WORKSPACE);
    VD_VERIFY(bytes >= VD_CNN_REC_BYTES, VD_ERR_WORKSPACE);
    uint8_t *base = (uint8_t *)ws;
    vd_cnn_plan_t *p = (vd_cnn_plan_t *)ws;
    bool after_run = false;
    VD_TRY(vd__cnn_plan_for_run(m, &c, width, height, flags, p, &after_run));
    VD_VERIFY(bytes >= p->total, VD_ERR_WORKSPACE);

    // Streamed, item 1 ends with a row buffer for a row function.
    uint8_t *buf = (rows != NULL) ? base + p->off[1] + p->len[1] - vd_cnn_round_up(width, VD_CNN_ITEM_ALIGN) : NULL;
    const in_src_t src = {img, stride_bytes, rows, buf};
    // Streamed, every item lives for the whole run, so a kept plan's item 1 still holds the last table.
    const bool same = after_run && (flags & (VD_CNN_SAME_HIST | VD_CNN_STREAM)) == (VD_CNN_SAME_HIST | VD_CNN_STREAM);
    const int8_t *lut = vd__cnn_norm_table(m, &src, width, height, base + p->off[1], same);
    const ring_t t0 = ring_of(base, p, &c, 0u);
    const uint32_t n = m->n_layers;
    if ((flags & VD_CNN_STREAM) == 0u) {
        vd__cnn_input_rows(&src, width, lut, &t0, 0u, height);
        for (uint32_t l = 0u; l < n; l++) {
            layer_rows(m, &c, p, base, l, 0u, height / c.f[l + 1u], level, ph);
        }
    } else {
        const run_io_t io = {&src, lut, base, &c, level, ph};
        uint32_t target, max_steps;
        vd__cnn_sched_start(p, &target, &max_steps);
        for (uint32_t k = 0u; k < max_steps && vd__cnn_sched_next(m, p, &target); k++) {
            for (uint32_t t = 0u; t <= n; t++) {
                if (p->req[t] > p->done[t]) {
                    produce(m, p, &io, t);
                    p->done[t] = p->req[t];
                }
            }
            if (dec != NULL) {
                vd__cnn_decode_rows(&dec->st, ring_of(base, p, &c, n).base, p->rows[n], p->done[n]);
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
    return run_any(m, img, NULL, width, height, stride_bytes, flags, ws, bytes, out, NULL);
}

vd_status_t vd_cnn_run_rows(const vd_cnn_model_t *m, const vd_cnn_rows_t *rows, uint32_t width, uint32_t height,
                            uint32_t flags, void *ws, size_t bytes, vd_cnn_output_t *out)
{
    VD_VERIFY(rows != NULL && rows->row != NULL && (flags & VD_CNN_STREAM) != 0u, VD_ERR_ARG);
    return run_any(m, NULL, rows, width, height, 0u, flags, ws, bytes, out, NULL);
}

vd_status_t vd_cnn_run_rows_decode(const vd_cnn_model_t *m, const vd_cnn_rows_t *rows, uint32_t width,
                                   uint32_t height, uint32_t flags, void *ws, size_t bytes,
                                   const vd_cnn_decode_opts_t *dec, vd_cnn_box_t *boxes, size_t capacity,
                                   size_t *count)
{
    VD_VERIFY(rows != NULL && rows->row != NULL && count != NULL, VD_ERR_ARG);
    dec_req_t d;
    d.opts = dec;
    d.boxes = boxes;
    d.capacity = capacity;
    vd_cnn_output_t head;
    VD_TRY(run_any(m, NULL, rows, width, height, 0u, flags, ws, bytes, &head, &d));
    *count = d.st.n;
    return VD_OK;
}

vd_status_t vd_cnn_run(const vd_cnn_model_t *m, const uint8_t *img, uint32_t width, uint32_t height,
                       uint32_t stride_bytes, void *ws, size_t bytes, vd_cnn_output_t *out)
{
    return vd_cnn_run_ex(m, img, width, height, stride_bytes, 0u, ws, bytes, out);
}

const char *vd_cnn_kernel_set(void)
{
#if defined(VD_CNN_X86)
    switch (vd__cnn_x86_level()) {
    case VD_CNN_X86_AVX512:
        return "avx512-vnni";
    case VD_CNN_X86_AVXVNNI:
        return "avx-vnni";
    case VD_CNN_X86_AVX2:
        return "avx2";
    default:
        return "portable";
    }
#elif defined(VD_CNN_CMSIS)
    return "cmsis-nn";
#else
    return "portable";
#endif
}
