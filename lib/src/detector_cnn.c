// SPDX-License-Identifier: MIT
// The detector's learned candidate source: the frame at half resolution through the int8 CNN, decoded boxes
// into the merged candidate list.
//
// Algorithm (issue 10, CenterNet-style detection with cnn.h): the frame is
// box-averaged 2x2, row by row as the streamed network asks for them
// (vd_cnn_run_rows, VD_CNN_STREAM) (8-bit: (a + b + c + d + 2) >> 2; 16-bit: the rounded raw
// mean through the detector's grey map), the floor(W/2) x floor(H/2) plane is
// padded to multiples of the model's alignment by repeating its last column
// and row (numpy np.pad mode "edge"), the network runs once, its heatmap
// peaks are decoded at the header's top-K into a 2 nw x 2 nh frame and each
// box is clipped to the real frame (dropped when nothing is left). With
// cfg.cnn_flip (horizontal-flip test-time augmentation) a second pass runs on
// the mirrored plane (each row's floor(W/2) pixels reversed, then padded the
// same way) and its boxes, mirrored back about x = floor(W/2) in frame
// pixels, follow the first pass's; suppression merges the two. This is
// exactly tools/vdtools/evaluation/cnn_eval.py Int8.__call__ (net_input, decode,
// clip; flip=True) and tools/vdtools/evaluation/cnn_detector.py, which tests/python compares with.
// Bounds: O(W*H) for the plane and padding, vd_cnn_macs() multiply-adds for
// the network, O(Wo*Ho*(1 + max_peaks)) for decoding, O(max_peaks) for the
// merge -- each twice with cnn_flip. Memory: the overlay (network workspace,
// boxes; see detector_init.c), the same for both passes. Stack: this file's
// frames plus vd_cnn_run_rows (~1.1 KiB on Cortex-M7 -Os, docs/embedded.md);
// no recursion.
#include <string.h>

#include "vd/resample.h"
#include "internal/detector_internal.h"
#include "internal/vd_internal.h"

void vd_det_cnn_input_size(const vd_cnn_model_t *m, uint32_t w, uint32_t h, uint32_t *nw, uint32_t *nh)
{
    const uint32_t a = m->align;   // >= 1 for a loaded model
    const uint32_t hw = w / 2u;
    const uint32_t hh = h / 2u;
    if (hw == 0u || hh == 0u) {
        *nw = 0u;
        *nh = 0u;
        return;
    }
    *nw = (hw + a - 1u) / a * a;
    *nh = (hh + a - 1u) / a * a;
}

// Rows of the half-resolution plane of f (hw x hh) padded to nw x nh by
// repeating the last real column, then the last real row, made on demand
// for vd_cnn_run_rows (the plane itself is never stored: 80 KiB at 640 x 512).
// With flip, each row's hw real pixels are reversed before the padding: the
// mirrored plane, padded as usual (its padding repeats the mirrored row's
// last pixel, i.e. the real column 0).
typedef struct cnn_rows_ctx {
    const vd_detector_t *det;
    vd_view_u8_t v8;
    vd_view_u16_t v16;
    bool wide;          // 16-bit frame
    bool flip;          // the cnn_flip pass: rows mirrored (x -> hw - 1 - x)
    uint32_t hw, hh, nw;
    vd_status_t st;     // first failure of a row (none expected: the views are checked up front)
} cnn_rows_ctx_t;

static void cnn_row(void *ctx, uint32_t y, uint8_t *dst)
{
    cnn_rows_ctx_t *r = (cnn_rows_ctx_t *)ctx;
    const uint32_t sy = (y < r->hh) ? y : r->hh - 1u;
    vd_image_u8_t d = {dst, r->hw, 1u, r->nw};
    // The ROI is the even part of the frame: an odd last column/row is not read.
    const vd_rect_t roi = {0, (int32_t)(2u * sy), (int32_t)(2u * r->hw), 2};
    const vd_status_t st = r->wide ? vd_resample_box_u16(&r->v16, &roi, 2u, 2u, &r->det->grey, &d)
                                   : vd_resample_box_u8(&r->v8, &roi, 2u, 2u, &d);
    if (st != VD_OK) {
        r->st = (r->st == VD_OK) ? st : r->st;
        memset(dst, 0, r->nw);
        return;
    }
    if (r->flip) {
        // Reversed in place: the resamplers take no mirrored view. hw >= 1 here.
        for (uint32_t i = 0u, j = r->hw - 1u; i < j; i++, j--) {
            const uint8_t t = dst[i];
            dst[i] = dst[j];
            dst[j] = t;
        }
    }
    if (r->nw > r->hw) {
        memset(dst + r->hw, dst[r->hw - 1u], r->nw - r->hw);
    }
}

// Q15 score -> Q8, rounded half up; 1.0 (32768) saturates at 255.
static uint8_t score_q8_of(uint16_t score_q15)
{
    const uint32_t q = ((uint32_t)score_q15 + 64u) >> 7;
    return (uint8_t)(q > 255u ? 255u : q);
}

// Appends the decoded boxes det->cnn_boxes[0..nb) to the candidates at *n.
// flip: the boxes of the mirrored plane, mirrored back first: [x, x + w) ->
// [2 hw - x - w, 2 hw - x) (the plane's hw columns are frame columns 0..2 hw).
// Then clipped to the frame (decode already keeps x >= 0 and the box inside
// 2 nw x 2 nh; a mirrored box may start left of 0 when it came from the
// padding); empty ones dropped, those beyond max_candidates counted.
static void append_boxes(vd_detector_t *det, const vd_frame_t *f, size_t nb, bool flip, uint32_t hw, size_t *n)
{
    const int32_t fw = (int32_t)f->width;
    const int32_t fh = (int32_t)f->height;
    const int32_t span = 2 * (int32_t)hw;   // <= VD_MAX_DIM
    // Boxes in decode order (logit descending, then raster): the best keep the budget.
    for (size_t i = 0u; i < nb; i++) {
        const vd_cnn_box_t *b = &det->cnn_boxes[i];
        int32_t x0 = flip ? span - (b->rect.x + b->rect.w) : b->rect.x;
        int32_t x1 = flip ? span - b->rect.x : b->rect.x + b->rect.w;
        x0 = (x0 > 0) ? x0 : 0;
        x1 = (x1 < fw) ? x1 : fw;
        const int32_t y1 = (b->rect.y + b->rect.h < fh) ? b->rect.y + b->rect.h : fh;
        if (x1 <= x0 || y1 <= b->rect.y) {
            continue;   // wholly in the padding
        }
        if (*n >= det->cfg.max_candidates) {
            det->stats.overflow_candidates++;
            continue;   // counted: each remaining box that would have been a candidate
        }
        vd_detection_t *d = &det->cand[*n];
        memset(d, 0, sizeof(*d));
        d->box.x = x0;
        d->box.y = b->rect.y;
        d->box.w = x1 - x0;
        d->box.h = y1 - b->rect.y;
        d->candidate = d->box;
        d->score_q8 = score_q8_of(b->score_q15);
        d->source = (uint8_t)VD_SOURCE_CNN;
        (*n)++;
        det->stats.cand_cnn++;
    }
}

vd_status_t vd_det_cnn_source(vd_detector_t *det, const vd_frame_t *f, size_t *n)
{
    if (det->cnn_never) {
        return VD_OK;
    }
    const vd_cnn_model_t *m = det->cfg.cnn_model;
    uint32_t nw = 0u;
    uint32_t nh = 0u;
    vd_det_cnn_input_size(m, f->width, f->height, &nw, &nh);
    if (nw == 0u || nh == 0u) {
        return VD_OK;   // a frame under 2 x 2 pixels has no half-resolution plane
    }
    cnn_rows_ctx_t r;
    memset(&r, 0, sizeof r);
    r.det = det;
    r.wide = f->format != VD_PIX_U8;
    r.hw = f->width / 2u;
    r.hh = f->height / 2u;
    r.nw = nw;
    r.st = VD_OK;
    if (r.wide) {
        VD_TRY(vd_frame_view_u16(f, &r.v16));
    } else {
        VD_TRY(vd_frame_view_u8(f, &r.v8));
    }
    const vd_cnn_rows_t rows = {cnn_row, &r};
    // Pass 0 on the plane; with cnn_flip pass 1 on its mirror. Both use the same
    // workspace and box array: pass 0's boxes are candidates before pass 1 decodes.
    const uint32_t passes = (det->cfg.cnn_flip != 0u) ? 2u : 1u;
    for (uint32_t p = 0u; p < passes; p++) {
        r.flip = p == 1u;
        vd_cnn_output_t head;
        VD_TRY(vd_cnn_run_rows(m, &rows, nw, nh, VD_CNN_STREAM, det->cnn_ws, det->cnn_ws_bytes, &head));
        VD_TRY(r.st);
        size_t nb = 0u;
        VD_TRY(vd_cnn_decode(m, &head, det->cnn_thr_q, 0u, 2u * nw, 2u * nh, det->cnn_boxes, det->cnn_boxes_cap,
                             &nb));
        det->stats.cnn_boxes += (uint32_t)nb;
        append_boxes(det, f, nb, r.flip, r.hw, n);
    }
    return (det->stats.overflow_candidates != 0u) ? VD_ERR_CAPACITY : VD_OK;
}
