// SPDX-License-Identifier: MIT
// Per-layer instructions of the CNN's kernels on the board, vd's portable kernels against the CMSIS-NN
// back end (when the library has it), and a byte-for-byte check of both against the network's own
// tensors. A measurement program beside the firmware example, not part of it: it calls the CNN's
// internal kernel entry points (lib/src/models/cnn/cnn_internal.h), as the unit tests do.
//
// The flash model runs once whole plane with every tensor kept, on the first frame box-averaged to half
// size (the detector's network input). Then every weighted layer runs again from its input tensor:
//   streamed  one output row per call on rings as tall as the detector's streamed plan makes them, the
//             input rows copied into their slots before the call (the calls vd_detector_run makes), the
//             plan's one scratch and the layer's prepared area if the plan gives it one (CMSIS-NN back end:
//             set up by the call of row 0, reused by the others);
//   plane     one call for the whole output.
// Each with the portable kernel and with CMSIS-NN; every output row is compared with the kept tensor.
// Output: one "# vd_fw_layer ..." line per layer (SysTick cycles; under qemu-system-arm -icount shift=0
// 40 instructions each, main.c's calibration) and a "# vd_fw_layers ..." summary; exit 0, or 1 on a
// mismatch (tests/python/test_firmware.py runs it; tools/vdtools/generators/embedded_report.py reads it).
#include <stdint.h>
#include <string.h>

#include "vd/vd.h"
#include "models/cnn/cnn_internal.h"

#include "board.h"
#include "fw_data.h"
#include "semihost.h"

#define ARENA_BYTES (2u * 1024u * 1024u)
static uint8_t arena[ARENA_BYTES] __attribute__((aligned(64)));
static vd_cnn_model_t cnn;
static vd_cnn_plan_t plan;

// Bump allocation from the arena (16-byte aligned, as workspace items are).
static uint8_t *take(size_t *used, size_t n)
{
    const size_t at = (*used + 15u) / 16u * 16u;
    if (at + n > ARENA_BYTES) {
        return NULL;
    }
    *used = at + n;
    return arena + at;
}

static void put_kv(const char *k, uint32_t v)
{
    sh_puts(" ");
    sh_puts(k);
    sh_puts(" ");
    sh_putu(v);
}

// One kernel call of layer L: the portable kernel or (cmsis) the CMSIS-NN one, with the layer's
// prepared area prep (NULL: none; made by the call with y0 == 0, as in the executor).
static void kernel(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0,
                   uint32_t y1, bool stream, uint8_t *scr, uint32_t scr_bytes, uint8_t *prep, bool cmsis)
{
#if defined(VD_CNN_CMSIS)
    if (cmsis) {
        const bool done = (L->op == VD_CNN_OP_DW3X3)
                              ? vd__cnn_dw3x3_rows_cmsis(L, g, in, out, y0, y1, scr, scr_bytes, prep)
                              : vd__cnn_conv_rows_cmsis(L, g, in, out, y0, y1, stream, scr, prep);
        if (done) {
            return;
        }
    }
#else
    (void)cmsis;
    (void)scr_bytes;
    (void)prep;
#endif
    if (L->op == VD_CNN_OP_DW3X3) {
        vd__cnn_dw3x3_rows(L, g, in, out, y0, y1, scr);
    } else {
        vd__cnn_conv_rows(L, g, in, out, y0, y1, stream, scr);
    }
}

// SysTick cycles of layer L over its whole output, streamed or whole plane; *bad counts the output rows
// that differ from the kept tensor `ref`.
static uint32_t time_layer(const vd_cnn_layer_t *L, const geom_t *g, const int8_t *src, const int8_t *ref,
                           uint32_t rin, uint32_t rout, uint8_t *ring_in, uint8_t *ring_out, uint8_t *scr,
                           uint32_t scr_bytes, uint8_t *prep, bool stream, bool cmsis, uint32_t *bad)
{
    const size_t in_row = (size_t)g->wi * g->ci, out_row = (size_t)g->wo * g->co;
    const int32_t ks = (L->op == VD_CNN_OP_PW1X1) ? 1 : ((L->op == VD_CNN_OP_CONV5X5) ? 5 : 3);
    ring_t in = {(int8_t *)(void *)ring_in, in_row, rin};
    const ring_t out = {(int8_t *)(void *)ring_out, out_row, rout};
    uint64_t ticks = 0u;
    if (!stream) {
        in.base = (int8_t *)(uintptr_t)src;   // the kept plane itself (kernels only read their input)
        in.rows = g->hi;
        const uint64_t t0 = fw_ticks();
        kernel(L, g, &in, &out, 0u, g->ho, false, scr, scr_bytes, NULL, cmsis);
        ticks = fw_ticks() - t0;
        for (uint32_t y = 0u; y < g->ho; y++) {
            *bad += (memcmp(ring_out + (size_t)y * out_row, ref + (size_t)y * out_row, out_row) != 0) ? 1u : 0u;
        }
        return (uint32_t)ticks;
    }
    int32_t have = -1;   // input rows [0, have] are in their slots
    for (uint32_t y = 0u; y < g->ho; y++) {
        int32_t need = (int32_t)y * L->stride + ks / 2;
        need = (need < (int32_t)g->hi - 1) ? need : (int32_t)g->hi - 1;
        for (; have < need; have++) {
            memcpy(vd_cnn_ring_row(&in, (uint32_t)(have + 1)), src + (size_t)(have + 1) * in_row, in_row);
        }
        const uint64_t t0 = fw_ticks();
        kernel(L, g, &in, &out, y, y + 1u, true, scr, scr_bytes, prep, cmsis);
        ticks += fw_ticks() - t0;
        *bad += (memcmp(vd_cnn_ring_row(&out, y), ref + (size_t)y * out_row, out_row) != 0) ? 1u : 0u;
    }
    return (uint32_t)ticks;
}

static int fail(const char *what)
{
    sh_puts("vd_fw_layers: ");
    sh_puts(what);
    sh_puts("\n");
    return 2;
}

int main(void)
{
    if (vd_cnn_load(&cnn, vd_fw_model, vd_fw_model_bytes) != VD_OK) {
        return fail("vd_cnn_load");
    }
    // The detector's network input: the first frame box-averaged 2x2, cut to the model's alignment.
    const vd_fw_frame_t *f = &vd_fw_frames[0];
    const uint32_t w = f->width / 2u / cnn.align * cnn.align, h = f->height / 2u / cnn.align * cnn.align;
    size_t used = 0u;
    uint8_t *img = take(&used, (size_t)w * h);
    const vd_view_u8_t src = {f->data, f->width, f->height, f->width};
    vd_image_u8_t half = {img, w, h, w};
    const vd_rect_t roi = {0, 0, (int32_t)(2u * w), (int32_t)(2u * h)};
    if (f->u16 != 0u || img == NULL || vd_resample_box_u8(&src, &roi, 2u, 2u, &half) != VD_OK) {
        return fail("input");
    }
    size_t ws_bytes = 0u;
    if (vd_cnn_workspace_size_ex(&cnn, w, h, VD_CNN_KEEP_TENSORS, &ws_bytes) != VD_OK) {
        return fail("workspace size");
    }
    uint8_t *ws = take(&used, ws_bytes);
    vd_cnn_output_t head;
    if (ws == NULL || vd_cnn_run_ex(&cnn, img, w, h, w, VD_CNN_KEEP_TENSORS, ws, ws_bytes, &head) != VD_OK) {
        return fail("whole-plane run");
    }
    chain_t c;
    if (!vd__cnn_model_ok(&cnn, &c) || vd__cnn_plan_make(&cnn, &c, w, h, VD_CNN_STREAM, &plan) != VD_OK) {
        return fail("streamed plan");
    }
    const uint32_t stream_scr = plan.len[3];
    uint32_t bad_total = 0u, port_sum[2] = {0u, 0u}, cmsis_sum[2] = {0u, 0u};
    uint64_t macs_total = 0u;
    for (uint32_t l = 0u; l < cnn.n_layers; l++) {
        const vd_cnn_layer_t *L = &cnn.layers[l];
        if (!vd_cnn_weighted(L->op)) {
            continue;
        }
        vd_cnn_output_t ti, to;
        if (vd_cnn_tensor(&cnn, ws, ws_bytes, w, h, L->in, &ti) != VD_OK ||
            vd_cnn_tensor(&cnn, ws, ws_bytes, w, h, l + 1u, &to) != VD_OK) {
            return fail("tensor");
        }
        const geom_t g = {ti.w, ti.h, ti.c, to.w, to.h, to.c, ti.zp};
        scratch_layout_t sl;
        const uint32_t plane_scr = (uint32_t)((L->op == VD_CNN_OP_DW3X3) ? vd__cnn_dw3x3_scratch(L, &sl)
                                                                         : vd__cnn_conv_scratch(L, false, &sl));
        const size_t mark = used;
        const uint32_t rin_rows = (plan.rows[L->in] != 0u) ? plan.rows[L->in] : g.hi;   // 0: never stored
        uint8_t *scr = take(&used, (stream_scr > plane_scr) ? stream_scr : plane_scr);
        uint32_t prep_len;   // the layer's prepared area in the streamed plan (0: none)
        (void)vd_cnn_prep_at(&cnn, &plan, l, &prep_len);
        uint8_t *prep = (prep_len != 0u) ? take(&used, prep_len) : NULL;
        uint8_t *rin = take(&used, (size_t)g.wi * g.ci * rin_rows);
        uint8_t *rout = take(&used, (size_t)g.wo * g.co * g.ho);
        if (scr == NULL || rin == NULL || rout == NULL || (prep_len != 0u && prep == NULL)) {
            return fail("arena");
        }
        uint32_t t[2][2], bad = 0u;   // [streamed, plane][portable, cmsis]
        for (uint32_t mode = 0u; mode < 2u; mode++) {
            const bool stream = mode == 0u;
            for (uint32_t k = 0u; k < 2u; k++) {
                memset(rout, 0x5A, (size_t)g.wo * g.co * g.ho);
                t[mode][k] = time_layer(L, &g, ti.data, to.data, rin_rows, stream ? plan.rows[l + 1u] : g.ho,
                                        rin, rout, scr, stream ? stream_scr : plane_scr, prep, stream, k == 1u, &bad);
            }
            port_sum[mode] += t[mode][0];
            cmsis_sum[mode] += t[mode][1];
        }
        const uint64_t macs = (uint64_t)g.wo * g.ho * g.co * vd_cnn_k_of(L);
        macs_total += macs;
        sh_puts("# vd_fw_layer");
        put_kv("index", l);
        put_kv("op", L->op);
        put_kv("stride", L->stride);
        put_kv("cin", g.ci);
        put_kv("cout", g.co);
        put_kv("wo", g.wo);
        put_kv("ho", g.ho);
        put_kv("macs", (uint32_t)macs);
        put_kv("stream_portable", t[0][0]);
        put_kv("stream_cmsis", t[0][1]);
        put_kv("plane_portable", t[1][0]);
        put_kv("plane_cmsis", t[1][1]);
        put_kv("bad_rows", bad);
        sh_puts("\n");
        bad_total += bad;
        used = mark;
    }
    sh_puts("# vd_fw_layers");
#if defined(VD_CNN_CMSIS)
    put_kv("cmsis", 1u);
#else
    put_kv("cmsis", 0u);
#endif
    put_kv("macs", (uint32_t)macs_total);
    put_kv("stream_portable", port_sum[0]);
    put_kv("stream_cmsis", cmsis_sum[0]);
    put_kv("plane_portable", port_sum[1]);
    put_kv("plane_cmsis", cmsis_sum[1]);
    put_kv("bad_rows", bad_total);
    sh_puts("\n");
    return (bad_total == 0u) ? 0 : 1;
}
