// SPDX-License-Identifier: MIT
// The detector's candidate sources: hot-spot labelling, contrast components and ranked sliding windows, merged
// into one candidate list.
//
// Algorithm: hot spots (paper 001 section 2) are the 8-connected components
// of pixels >= the threshold (constant, or the adaptive max(floor, p-th
// percentile), threshold.h; 16-bit frames in the fixed window: the raw value
// of hot_thr_ck; in their own window (not radiometric, where a temperature
// means nothing): the raw value at the 8-bit threshold's grey level, the
// percentile taken over the frame's grey levels, so the hot pixels are those
// of the frame's 8-bit view),
// labelled straight from the frame with a run budget (components.h). The
// other sources (issue 7) are appended to the list that the refined hot spots
// start: contrast components (contrast.h, 8-bit frames) and the best
// pre-filtered sliding windows (windows.h), each unless a listed box overlaps
// it by IoU > dedup_iou (suppress.h), all within max_candidates.
// Bounds: O(W*H) for the histogram, labelling, contrast map and cell
// integrals; O(windows * (1 + max_candidates)) for the two window walks and
// the merge. Stack: small frames (the window visitor's context is 24 bytes);
// no recursion.
#include <string.h>

#include "vd/otsu.h"
#include "vd/suppress.h"
#include "detector/detector_internal.h"
#include "internal/vd_internal.h"

// The 8-bit hot threshold: constant, or max(floor, p-th percentile) of the
// frame's histogram (adaptive mode).
static uint32_t threshold_u8(vd_detector_t *det, const vd_view_u8_t *v)
{
    if (det->cfg.thr_mode != VD_DETECTOR_THR_ADAPTIVE) {
        return det->cfg.hot_thr_u8;
    }
    // The view was checked by the caller, permille by vd_detector_cfg_resolve: neither call can fail.
    uint8_t t = 0u;
    vd_status_t st = vd_histogram_u8(v, NULL, det->hist);
    VD_ASSERT(st == VD_OK);
    st = vd_threshold_percentile_u8(det->hist, det->cfg.adaptive_permille, det->cfg.adaptive_floor_u8, &t);
    VD_ASSERT(st == VD_OK);
    (void)st;
    return t;
}

// The 8-bit threshold of a 16-bit frame in its own grey window (det->grey, set for this frame): constant, or
// max(floor, the grey level of the frame's p-th percentile sample). The map never falls as raw rises, so that grey
// level is the p-th percentile of the frame's grey levels (at vd_histogram_percentiles_u16's rank floor(n p / 1000),
// one sample above threshold_u8's when n p / 1000 is whole); no pass maps every sample.
static uint32_t threshold_grey(vd_detector_t *det, const vd_view_u16_t *v)
{
    if (det->cfg.thr_mode != VD_DETECTOR_THR_ADAPTIVE) {
        return det->cfg.hot_thr_u8;
    }
    uint16_t p = 0u, q = 0u;
    const uint32_t permille = det->cfg.adaptive_permille;
    const vd_status_t st = vd_histogram_percentiles_u16(v, permille, permille, det->hist, &p, &q);
    VD_ASSERT(st == VD_OK);   // view checked by the caller, permille by vd_detector_cfg_resolve
    (void)st;
    const uint32_t t = vd_calib_grey_u8(&det->grey, p);
    return (t > det->cfg.adaptive_floor_u8) ? t : det->cfg.adaptive_floor_u8;
}

// Hot-spot components straight from the frame (no mask: the labeller
// compares with the threshold as it run-length encodes), with the run budget
// of the overlay. Sets the threshold, hot pixel, run and overflow stats.
vd_status_t vd__detector_hot_components(vd_detector_t *det, const vd_frame_t *f, size_t *n, uint32_t *t0)
{
    vd_detector_stats_t *s = &det->stats;
    vd_components_stats_t *cs = &((cand_ctx_t *)det->scratch)->cs;
    memset(cs, 0, sizeof(*cs));
    vd_status_t st;
    *n = 0u;
    if (f->format == VD_PIX_U8) {
        vd_view_u8_t v;
        VD_TRY(vd_frame_view_u8(f, &v));
        const uint32_t thr = threshold_u8(det, &v);
        s->hot_thr_u8 = thr;
        vd__detector_clock_add(det, VD_DETECTOR_STAGE_THRESHOLD, t0);
        st = vd_components_label_thr_u8(&v, NULL, (uint8_t)thr, det->overlay, det->cc_ws_bytes, det->comps,
                                        det->cfg.max_components, n, cs);
    } else {
        vd_view_u16_t v16;
        VD_TRY(vd_frame_view_u16(f, &v16));
        uint16_t raw = det->raw_thr;
        bool never = det->raw_never_hot;
        if (det->cfg.grey_mode == VD_DETECTOR_GREY_PERCENTILE) {
            const uint32_t thr = threshold_grey(det, &v16);
            s->hot_thr_u8 = thr;
            st = vd_calib_grey_raw_at(&det->grey, (uint8_t)thr, &raw);
            VD_ASSERT(st == VD_OK || st == VD_ERR_RANGE);   // the calibration was bounded by vd_detector_cfg_resolve
            never = (st != VD_OK);
        }
        s->hot_thr_raw = never ? 65536u : raw;
        vd__detector_clock_add(det, VD_DETECTOR_STAGE_THRESHOLD, t0);
        if (never) {
            return VD_OK;
        }
        st = vd_components_label_thr_u16(&v16, NULL, raw, det->overlay, det->cc_ws_bytes, det->comps,
                                         det->cfg.max_components, n, cs);
    }
    if (st != VD_OK && st != VD_ERR_CAPACITY) {
        return st;
    }
    s->hot_pixels = cs->pixels;
    s->runs = cs->runs;
    if (cs->labels > det->cfg.max_components) {
        s->overflow_components = 1u;
    }
    if (cs->rows < f->height) {
        // Run budget exhausted: keep the components of rows [0, rows) that
        // end above the last labelled row (the others may continue below).
        s->overflow_runs = f->height - cs->rows;
        size_t k = 0u;
        for (size_t i = 0; i < *n; i++) {
            if ((uint32_t)(det->comps[i].box.y + det->comps[i].box.h) < cs->rows) {
                det->comps[k++] = det->comps[i];
            }
        }
        *n = k;
    }
    return st;
}

// Appends box (source src) to the merged list unless it duplicates a box
// already there (IoU > dedup_iou). Returns true when appended.
static bool merge_box(vd_detector_t *det, size_t *n, const vd_rect_t *box, uint8_t src, uint8_t thr8)
{
    if (vd_suppress_overlaps(box, det->cand, *n, det->cfg.dedup_iou_q15)) {
        det->stats.deduplicated++;
        return false;
    }
    vd_detection_t *d = &det->cand[*n];
    memset(d, 0, sizeof(*d));
    d->box = *box;
    d->candidate = *box;
    d->source = src;
    d->hot_thr = thr8;
    (*n)++;
    return true;
}

// Contrast source (8-bit frames): components of |I - box mean| >= thr with
// the rules, into det->comps (free after the hot-spot stage), merged as is.
// Its workspace is the overlay, free between the hot-spot refinement and the
// window source.
vd_status_t vd__detector_contrast_source(vd_detector_t *det, const vd_frame_t *f, size_t *n, uint8_t thr8)
{
    if (f->format != VD_PIX_U8) {
        return VD_OK;   // no whole-frame 8-bit plane of radiometric frames (documented in detector.h)
    }
    vd_view_u8_t v;
    VD_TRY(vd_frame_view_u8(f, &v));
    size_t nc = 0u;
    vd_status_t result = VD_OK;
    vd_status_t st = vd_contrast_candidates(&v, &det->cfg.contrast, det->contrast_ws, det->contrast_ws_bytes,
                                            det->comps, det->cfg.max_components, &nc, NULL);
    if (st == VD_ERR_CAPACITY) {
        det->stats.overflow_components |= 2u;
        result = VD_ERR_CAPACITY;
    } else if (st != VD_OK) {
        return st;
    }
    for (size_t i = 0; i < nc; i++) {
        if (*n >= det->cfg.max_candidates) {
            det->stats.overflow_candidates += (uint32_t)(nc - i);
            return VD_ERR_CAPACITY;
        }
        if (merge_box(det, n, &det->comps[i].box, (uint8_t)VD_DETECTION_SOURCE_CONTRAST, thr8)) {
            det->stats.cand_contrast++;
        }
    }
    return result;
}

// Window visitor of vd_windows_rank: merges the window while the budget has room.
typedef struct win_merge {
    vd_detector_t *det;
    size_t *n;
    uint8_t thr8;
} win_merge_t;

static void window_visit(void *ctx, const vd_rect_t *b)
{
    win_merge_t *m = (win_merge_t *)ctx;
    vd_detector_t *det = m->det;
    if (*m->n < det->cfg.max_candidates && merge_box(det, m->n, b, (uint8_t)VD_DETECTION_SOURCE_WINDOW, m->thr8)) {
        det->stats.cand_window++;
    }
}

// Window source: pre-filter by cell-mean deviation, rank by it, and merge the
// best windows into the room left of max_candidates (windows.h; windows
// beyond it are dropped by design: not a capacity error).
vd_status_t vd__detector_window_source(vd_detector_t *det, const vd_frame_t *f, size_t *n, uint8_t thr8)
{
    cand_ctx_t *x = (cand_ctx_t *)det->scratch;
    x->wc = det->cfg.windows;
    x->wc.frame_w = f->width;
    x->wc.frame_h = f->height;
    VD_TRY(vd_windows_prefilter_init(&x->pf, f, &det->grey, det->overlay, det->overlay_bytes));
    const size_t room = (*n < det->cfg.max_candidates) ? det->cfg.max_candidates - *n : 0u;
    win_merge_t m = {det, n, thr8};
    vd_windows_rank_stats_t rs;
    VD_TRY(vd_windows_rank(&x->wc, &x->pf, det->cfg.win_min_std_u8, room, det->hist, window_visit, &m, &rs));
    det->stats.windows = rs.windows;
    det->stats.windows_passed = rs.passed;
    return VD_OK;
}
