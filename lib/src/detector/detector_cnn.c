// SPDX-License-Identifier: MIT
// The detector's learned candidate source: the frame at half resolution (or, with cfg.cnn_res, at full or
// quarter resolution) through the int8 CNN, decoded boxes into the merged candidate list.
//
// Algorithm (issue 10, CenterNet-style detection with cnn.h): the frame is
// box-averaged 2x2, row by row as the streamed network asks for them
// (vd_cnn_run_rows, VD_CNN_STREAM) (8-bit: (a + b + c + d + 2) >> 2; 16-bit: the rounded raw
// mean through the detector's grey map), the floor(W/2) x floor(H/2) plane is
// (cfg.cnn_res FULL: the frame itself, 16-bit through the grey map, and every
// "2" below reads 1: a frame whose cars are half the size looks to the network
// as the frames it trained on; QUARTER: 4x4 box averages, (sum + 8) >> 4, and
// every "2" reads 4, for cars twice the size; tests/unit/test_detector_cnn.c)
// padded to multiples of the model's alignment by repeating its last column
// and row (numpy np.pad mode "edge"), the network runs once, its heatmap
// peaks are decoded at the header's top-K into a 2 nw x 2 nh frame and each
// box is clipped to the real frame (dropped when nothing is left). With
// cfg.cnn_flip (horizontal-flip test-time augmentation) the two passes are
// fused instead: pass A on the plane and pass B on the mirrored plane (each
// row's floor(W/2) pixels reversed, then padded the same way), both decoded
// at the logit threshold of the score max(1, 2T - 32768), T being the score
// threshold in Q15 (a fused score is the mean of two, so a box below T can
// end above it); B's boxes are mirrored back about x = floor(W/2) in frame
// pixels, both sets clipped, then matched greedily in A's decode order (the
// unused B box of largest IoU >= VD_DETECTOR_CNN_FLIP_IOU_Q15, ties to the first):
// a matched pair averages its corners and scores, an unmatched box keeps its
// corners and half its score (the other pass voted 0), and fused boxes below
// T are dropped
// (fuse_boxes). With cfg.cnn_model2 each network runs its passes in turn on
// the same frame (its own alignment, decode threshold and top-K; two flip
// passes fused in place without a threshold), then the two networks' boxes
// are fused by the same rule at T. This is exactly
// tools/vdtools/evaluation/cnn_eval.py Int8.__call__ (net_input, decode,
// clip; flip=True: fuse_flip; Pair) and tools/vdtools/evaluation/cnn_detector.py
// (boxes, pair_boxes), which tests/python compares with.
// Bounds: O(W*H) for the plane and padding, vd_cnn_macs() multiply-adds for
// the network, O(Wo*Ho*(1 + max_peaks)) for decoding, O(max_peaks) for the
// merge -- the first three twice with cnn_flip, whose fusion computes at most
// max_peaks^2 IoUs (10 000 for the shipped models' top-100), and per network
// with cnn_model2 (then at most (2 K1) (2 K2) IoUs more). Memory: the
// overlay (network workspace, max_peaks boxes, 2 max_peaks with cnn_flip: pass
// A's survive pass B's decode; see detector_init.c), the workspace shared by
// both passes. Stack: this file's frames plus vd_cnn_run_rows (~1.1 KiB on
// Cortex-M7 -Os, docs/embedded.md); no recursion.
#include <string.h>

#include "vd/resample.h"
#include "detector/detector_internal.h"
#include "models/cnn/cnn_internal.h"
#include "internal/vd_internal.h"

uint32_t vd__detector_cnn_div(const vd_detector_cfg_t *c)
{
    // VD_DETECTOR_CNN_RES_HALF, _FULL, _QUARTER (resolve() refuses other values)
    return (c->cnn_res == VD_DETECTOR_CNN_RES_FULL) ? 1u : (c->cnn_res == VD_DETECTOR_CNN_RES_QUARTER) ? 4u : 2u;
}

void vd__detector_cnn_input_size(const vd_cnn_model_t *m, uint32_t d, uint32_t w, uint32_t h, uint32_t *nw,
                                 uint32_t *nh)
{
    const uint32_t a = m->align;   // >= 1 for a loaded model
    const uint32_t hw = w / d;
    const uint32_t hh = h / d;
    if (hw == 0u || hh == 0u) {
        *nw = 0u;
        *nh = 0u;
        return;
    }
    *nw = (hw + a - 1u) / a * a;
    *nh = (hh + a - 1u) / a * a;
}

// Rows of the half-resolution plane of f (hw x hh), inverted (255 - v) with
// cfg.cnn_invert, padded to nw x nh by
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
    bool invert;        // cfg.cnn_invert: each plane value v as 255 - v (a black-hot camera)
    uint32_t d;         // frame pixels per plane pixel and axis (vd__detector_cnn_div)
    uint32_t hw, hh, nw;
    vd_status_t st;     // first failure of a row (none expected: the views are checked up front)
} cnn_rows_ctx_t;

static void cnn_row(void *ctx, uint32_t y, uint8_t *dst)
{
    cnn_rows_ctx_t *r = (cnn_rows_ctx_t *)ctx;
    const uint32_t sy = (y < r->hh) ? y : r->hh - 1u;
    vd_image_u8_t d = {dst, r->hw, 1u, r->nw};
    // The ROI is the part of the frame d divides: a last partial block of columns/rows is not read.
    const vd_rect_t roi = {0, (int32_t)(r->d * sy), (int32_t)(r->d * r->hw), (int32_t)r->d};
    const vd_status_t st = r->wide ? vd_resample_box_u16(&r->v16, &roi, r->d, r->d, &r->det->grey, &d)
                                   : vd_resample_box_u8(&r->v8, &roi, r->d, r->d, &d);
    if (st != VD_OK) {
        r->st = (r->st == VD_OK) ? st : r->st;
        memset(dst, 0, r->nw);
        return;
    }
    if (r->invert) {
        for (uint32_t i = 0u; i < r->hw; i++) {
            dst[i] = (uint8_t)(255u - dst[i]);
        }
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
static uint8_t score_q8_of(uint32_t score_q15)
{
    const uint32_t q = (score_q15 + 64u) >> 7;
    return (uint8_t)(q > 255u ? 255u : q);
}

// Clips the decoded boxes b[0..nb) to the frame in place and returns how many
// are left (order kept, empty ones dropped). flip: the boxes of the mirrored
// plane, mirrored back first: [x, x + w) -> [d hw - x - w, d hw - x) (the
// plane's hw columns are frame columns 0..d hw). Decode already keeps x, y >= 0
// and the box inside d nw x d nh; a mirrored box may start left of 0 when it
// came from the padding, and any box may reach into the padding.
static size_t clip_boxes(vd_cnn_box_t *b, size_t nb, bool flip, uint32_t span_px, const vd_frame_t *f)
{
    const int32_t fw = (int32_t)f->width;
    const int32_t fh = (int32_t)f->height;
    const int32_t span = (int32_t)span_px;   // d hw <= VD_MAX_DIM
    size_t kept = 0u;
    for (size_t i = 0u; i < nb; i++) {
        const vd_rect_t r = b[i].rect;
        int32_t x0 = flip ? span - (r.x + r.w) : r.x;
        int32_t x1 = flip ? span - r.x : r.x + r.w;
        x0 = (x0 > 0) ? x0 : 0;
        x1 = (x1 < fw) ? x1 : fw;
        const int32_t y1 = (r.y + r.h < fh) ? r.y + r.h : fh;
        if (x1 <= x0 || y1 <= r.y) {
            continue;   // wholly in the padding
        }
        b[kept] = b[i];
        b[kept].rect.x = x0;
        b[kept].rect.w = x1 - x0;
        b[kept].rect.h = y1 - r.y;
        kept++;
    }
    return kept;
}

// Appends one box (frame pixels, non-empty) with its Q15 score to the
// candidates at *n, or counts it when max_candidates are taken.
static void push_box(vd_detector_t *det, const vd_rect_t *box, uint32_t score_q15, size_t *n)
{
    if (*n >= det->cfg.max_candidates) {
        det->stats.overflow_candidates++;
        return;   // counted: each remaining box that would have been a candidate
    }
    vd_detection_t *d = &det->cand[*n];
    memset(d, 0, sizeof(*d));
    d->box = *box;
    d->candidate = *box;
    d->score_q8 = score_q8_of(score_q15);
    d->source = (uint8_t)VD_DETECTION_SOURCE_CNN;
    (*n)++;
    det->stats.cand_cnn++;
}

// True when a and b share a pixel (their IoU can be above 0). Most pairs fuse_boxes compares do not, and
// this inline test spares them the call to vd_rect_iou_q15 (perf: the call was ~2 % of a frame on
// AVX-512). It is here, not in vd_rect_iou_q15 or an inline copy of it: that function takes any boxes and
// so needs int64 sums, whereas these boxes lie inside the frame and int32 is exact; an int64 test inline
// grew the Cortex-M0+ library by 258 B, the whole IoU inline by 502 B (this one: 40 B).
static inline bool rects_meet(const vd_rect_t *a, const vd_rect_t *b)
{
    return a->x < b->x + b->w && b->x < a->x + a->w && a->y < b->y + b->h && b->y < a->y + a->h;
}

// Two box sets fused (cfg.cnn_flip's rule; also the two networks of
// cfg.cnn_model2): a[0..na) and b[0..nb) in decode order. For each a[i] in
// turn, the unused b[j] with the largest IoU >= VD_DETECTOR_CNN_FLIP_IOU_Q15 (ties:
// lowest j) is its match: corners averaged (left/top rounded down,
// right/bottom rounded up, so the box stays non-empty and inside the frame),
// score (sa + sb + 1) >> 1; unmatched a[i] keep their box with score
// (sa + 1) >> 1 (the other pass's vote is 0). Then each unused b[j] in order,
// score (sb + 1) >> 1. A used b[j] is marked in place by rect.w = 0 (clipped
// boxes have w >= 1). out == NULL: fused boxes scoring >= the score threshold
// T (det->cnn_thr_score_q15) become candidates in that order (push_box).
// Else every fused box is written to out[0..) in that order and the count
// returned; out may be a itself when b lies at or after a + na (the write
// index never passes the box being read: a[i] -> out[<= i], b[j] ->
// out[<= na + j]). na * nb IoUs.
static size_t fuse_boxes(vd_detector_t *det, vd_cnn_box_t *a, size_t na, vd_cnn_box_t *b, size_t nb,
                         vd_cnn_box_t *out, size_t *n)
{
    const uint32_t thr = det->cnn_thr_score_q15;
    size_t w = 0u;
    for (size_t i = 0u; i < na; i++) {
        size_t best = nb;
        uint32_t best_iou = 0u;
        for (size_t j = 0u; j < nb; j++) {
            const bool meet = b[j].rect.w != 0 && rects_meet(&a[i].rect, &b[j].rect);
            const uint32_t iou = meet ? vd_rect_iou_q15(&a[i].rect, &b[j].rect) : 0u;
            if (iou >= VD_DETECTOR_CNN_FLIP_IOU_Q15 && iou > best_iou) {   // strict: ties keep the lowest j
                best = j;
                best_iou = iou;
            }
        }
        vd_cnn_box_t f = a[i];
        uint32_t sum = a[i].score_q15;
        if (best < nb) {
            // Corners x0, y0 rounded down, exclusive x1, y1 rounded up; all >= 0.
            const vd_rect_t *q = &b[best].rect;
            vd_rect_t *r = &f.rect;
            const int32_t x1 = (r->x + r->w + q->x + q->w + 1) >> 1;
            const int32_t y1 = (r->y + r->h + q->y + q->h + 1) >> 1;
            r->x = (r->x + q->x) >> 1;
            r->y = (r->y + q->y) >> 1;
            r->w = x1 - r->x;
            r->h = y1 - r->y;
            sum += b[best].score_q15;
            b[best].rect.w = 0;   // used
        }
        const uint32_t s = (sum + 1u) >> 1;   // unmatched: the other pass's vote is 0
        if (out != NULL) {
            f.score_q15 = (uint16_t)s;   // <= 32768
            out[w++] = f;
        } else if (s >= thr) {
            push_box(det, &f.rect, s, n);
        }
    }
    for (size_t j = 0u; j < nb; j++) {
        const uint32_t s = ((uint32_t)b[j].score_q15 + 1u) >> 1;
        if (b[j].rect.w == 0) {
            continue;
        }
        if (out != NULL) {
            vd_cnn_box_t f = b[j];
            f.score_q15 = (uint16_t)s;
            out[w++] = f;
        } else if (s >= thr) {
            push_box(det, &b[j].rect, s, n);
        }
    }
    return w;
}

// One network's passes on the frame's plane (r: its row maker, r->nw that
// network's padded width): pass 0 on the plane into boxes[0, k), with
// cnn_flip pass 1 on its mirror into [k, 2k), decoded at thr_i8; the passes
// share the network workspace. *kept: the clipped boxes of each pass.
static vd_status_t run_passes(vd_detector_t *det, const vd_cnn_model_t *m, int32_t thr_i8, cnn_rows_ctx_t *r,
                              uint32_t nw, uint32_t nh, const vd_frame_t *f, vd_cnn_box_t *boxes, size_t k,
                              uint32_t passes, size_t kept[2])
{
    const vd_cnn_rows_t rows = {cnn_row, r};
    r->nw = nw;
    for (uint32_t p = 0u; p < passes; p++) {
        r->flip = p == 1u;
        // The mirrored pass reads the same pixels (without width padding, which repeats another column):
        // it keeps pass 0's input table.
        const uint32_t same = (r->flip && r->hw == nw) ? VD_CNN_SAME_HIST : 0u;
        // The head is decoded as its rows are made (a ring of them: VD_CNN_HEAD_RING).
        const vd_cnn_decode_opts_t dec = {thr_i8, 0u, r->d * nw, r->d * nh};
        size_t nb = 0u;
        VD_TRY(vd_cnn_run_rows_decode(m, &rows, nw, nh, VD_DETECTOR_CNN_FLAGS | VD_CNN_REUSE_PLAN | same,
                                      det->cnn_ws, det->cnn_ws_bytes, &dec, boxes + (size_t)p * k, k, &nb));
        VD_TRY(r->st);
        det->stats.cnn_boxes += (uint32_t)nb;
        kept[p] = clip_boxes(boxes + (size_t)p * k, nb, r->flip, r->d * r->hw, f);
    }
    return VD_OK;
}

// The boxes of one network of a cfg.cnn_model2 pair at boxes[0..): its passes
// (two fused in place, without a threshold, with cnn_flip); *count of them.
// park: the network's parked plan key (VD_CNN_PLAN_KEY_BYTES of its run record), or NULL.
static vd_status_t net_boxes(vd_detector_t *det, const vd_cnn_model_t *m, int32_t thr_i8, bool never,
                             cnn_rows_ctx_t *r, const vd_frame_t *f, vd_cnn_box_t *boxes, size_t k,
                             uint8_t *park, size_t *count)
{
    *count = 0u;
    if (never) {
        return VD_OK;
    }
    uint32_t nw = 0u;
    uint32_t nh = 0u;
    vd__detector_cnn_input_size(m, r->d, f->width, f->height, &nw, &nh);
    const uint32_t passes = (det->cfg.cnn_flip != 0u) ? 2u : 1u;
    size_t kept[2] = {0u, 0u};
    // This network's parked plan in, and out again after its passes (each network keeps its own plan).
    if (park != NULL) {
        memcpy(det->cnn_ws, park, VD_CNN_PLAN_KEY_BYTES);
    }
    const vd_status_t st = run_passes(det, m, thr_i8, r, nw, nh, f, boxes, k, passes, kept);
    if (park != NULL) {
        memcpy(park, det->cnn_ws, VD_CNN_PLAN_KEY_BYTES);
    }
    VD_TRY(st);
    *count = (passes == 2u) ? fuse_boxes(det, boxes, kept[0], boxes + k, kept[1], boxes, NULL) : kept[0];
    return VD_OK;
}

vd_status_t vd__detector_cnn_source(vd_detector_t *det, const vd_frame_t *f, size_t *n)
{
    if (det->cnn_never && (det->cfg.cnn_model2 == NULL || det->cnn2_never)) {
        return VD_OK;
    }
    const vd_cnn_model_t *m = det->cfg.cnn_model;
    uint32_t nw = 0u;
    uint32_t nh = 0u;
    const uint32_t d = vd__detector_cnn_div(&det->cfg);
    vd__detector_cnn_input_size(m, d, f->width, f->height, &nw, &nh);
    if (nw == 0u || nh == 0u) {
        return VD_OK;   // a frame under 2 x 2 pixels has no half-resolution plane
    }
    cnn_rows_ctx_t r;
    memset(&r, 0, sizeof r);
    r.det = det;
    r.wide = f->format != VD_PIX_U8;
    r.invert = det->cfg.cnn_invert != 0u;
    r.d = d;
    r.hw = f->width / d;
    r.hh = f->height / d;
    r.st = VD_OK;
    if (r.wide) {
        VD_TRY(vd_frame_view_u16(f, &r.v16));
    } else {
        VD_TRY(vd_frame_view_u8(f, &r.v8));
    }
    const uint32_t passes = (det->cfg.cnn_flip != 0u) ? 2u : 1u;
    if (det->cfg.cnn_model2 != NULL) {
        // Network 1's boxes in [0, K1 passes), network 2's after them, each
        // set fused over its own passes first (init sized the array so).
        const vd_cnn_model_t *m2 = det->cfg.cnn_model2;
        vd_cnn_box_t *b2 = det->cnn_boxes + (size_t)m->max_peaks * passes;
        uint8_t *park = (uint8_t *)det->cnn_park;   // init carved both keys for the pair
        size_t n1 = 0u;
        size_t n2 = 0u;
        VD_TRY(net_boxes(det, m, det->cnn_thr_i8, det->cnn_never, &r, f, det->cnn_boxes, m->max_peaks, park, &n1));
        VD_TRY(net_boxes(det, m2, det->cnn2_thr_i8, det->cnn2_never, &r, f, b2, m2->max_peaks,
                         park + VD_CNN_PLAN_KEY_BYTES, &n2));
        (void)fuse_boxes(det, det->cnn_boxes, n1, b2, n2, NULL, n);
        return (det->stats.overflow_candidates != 0u) ? VD_ERR_CAPACITY : VD_OK;
    }
    // Pass 0 on the plane into boxes [0, K); with cnn_flip pass 1 on its
    // mirror into [K, 2K), both decoded at det->cnn_thr_i8.
    const size_t k = det->cnn_boxes_cap / passes;
    size_t kept[2] = {0u, 0u};
    VD_TRY(run_passes(det, m, det->cnn_thr_i8, &r, nw, nh, f, det->cnn_boxes, k, passes, kept));
    if (passes == 2u) {
        (void)fuse_boxes(det, det->cnn_boxes, kept[0], det->cnn_boxes + k, kept[1], NULL, n);
    } else {
        // Decode order (logit descending, then raster): the best keep the budget.
        for (size_t i = 0u; i < kept[0]; i++) {
            push_box(det, &det->cnn_boxes[i].rect, det->cnn_boxes[i].score_q15, n);
        }
    }
    return (det->stats.overflow_candidates != 0u) ? VD_ERR_CAPACITY : VD_OK;
}
