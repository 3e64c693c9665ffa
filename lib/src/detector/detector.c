// SPDX-License-Identifier: MIT
// The detector pipeline of one frame: candidate sources, refinement, verification, suppression, temporal analysis.
//
// Algorithm: paper 001 ("Night-time vehicle detection in FIR images with a
// DBN"), sections 2-4, and paper 000 section 4. vd_detector_run orchestrates:
//  0. with the CNN source (issue 10, detector_cnn.c), the network's boxes
//     start the merged candidate list; they skip the DBN unless cnn_rescore;
//  1. hot-spot components of the frame (threshold + labelling), kept by the
//     shape rules (aspect 0.3..1.5, area >= 120), the first max_candidates;
//  2. each refined (expanded 1.5x by 2x, refine.h, contour.h) into a box that
//     joins the merged candidate list (after the CNN boxes, deduplicated
//     against them), then the other sources appended (issue 7; contrast.h,
//     windows.h; cfg.sources, default hot spots only);
//  3. every merged candidate sampled at 32x32 and scored by the DBN (dbn.h),
//     kept when score >= score_thr;
//  4. stable sort by score and greedy overlap suppression (suppress.h), the
//     first max_detections;
//  5. temporal analysis when enabled (temporal.h): track ids and states, and
//     recovered targets appended, measured by refining the box as a candidate;
//     with VD_TEMPORAL_SCORES each score fused with its track's (the order
//     stays the detector's, by its own score).
// The stages live in detector_cnn.c (0), detector_sources.c (1-2) and detector_region.c (2-3);
// configuration and workspace in detector_init.c; shared state in
// detector/detector_internal.h.
//
// Bounds: time O(W*H) for threshold, labelling and the contrast/window
// sources, the network's multiply-adds once per frame (vd_cnn_macs at the
// half-resolution input; twice with cnn_flip, plus at most max_peaks^2 IoUs
// for its fusion) for the CNN source, O(windows * (1 + max_candidates))
// for the window walks and the merge, plus per candidate (<= max_candidates)
// O(region) for refine and contour and the DBN's multiply-adds; NMS
// O(max_candidates^2); temporal as temporal.h with at most 289 refine probes
// per missed confirmed track.
// Stack: vd_detector_run's own frame (per-candidate state is in the
// workspace) plus the deepest stage below it (the boosted verifier ->
// vd_cnn_run_ex's kernels, the CNN source -> vd_cnn_run_rows, refine ->
// median); no recursion; the figures are generated in docs/embedded.md.
#include "vd/detector.h"

#include <string.h>

#include "vd/histogram.h"
#include "vd/suppress.h"
#include "detector/detector_internal.h"
#include "internal/vd_internal.h"

const vd_detector_stats_t *vd_detector_last_stats(const vd_detector_t *det)
{
    return (det == NULL) ? NULL : &det->stats;
}

static uint32_t clock_now(const vd_detector_t *det)
{
    return (det->cfg.clock_us != NULL) ? det->cfg.clock_us(det->cfg.clock_user) : 0u;
}

// Stable sort by score and greedy suppression of det->cand[0..n); *kept
// survive. Out of line: its counts stay off the frame of the deep calls.
VD_DET_NOINLINE static vd_status_t suppress(vd_detector_t *det, size_t n, size_t *kept)
{
    vd_suppress_stats_t ss;
    VD_TRY(vd_suppress_nms(det->cand, n, det->cfg.nms_iou_q15, det->cfg.max_detections, kept, &ss));
    det->stats.suppressed = ss.suppressed;
    det->stats.overflow_detections += ss.overflow;
    return VD_OK;
}

// A target recovered by temporal analysis, as a detection (score 0, or with VD_TEMPORAL_SCORES its track's
// decayed score).
static void recovered(const vd_detector_t *det, const vd_frame_t *f, const vd_temporal_obs_t *o, uint8_t thr8,
                      vd_detection_t *d)
{
    memset(d, 0, sizeof(*d));
    d->box = o->box;
    // A coasting track's predicted box may drift past the frame edge: report only the visible part; a
    // box wholly outside becomes the 1x1 box at its nearest frame pixel, so the detection stays well-formed.
    if (!vd_rect_clip(&d->box, f->width, f->height)) {
        const int32_t fw = (int32_t)f->width, fh = (int32_t)f->height;
        d->box.x = (o->box.x < 0) ? 0 : ((o->box.x >= fw) ? fw - 1 : o->box.x);
        d->box.y = (o->box.y < 0) ? 0 : ((o->box.y >= fh) ? fh - 1 : o->box.y);
        d->box.w = 1;
        d->box.h = 1;
    }
    (void)vd_rect_expand(&d->box, det->cfg.expand_w_q8, det->cfg.expand_h_q8, f->width, f->height, &d->candidate);
    d->track_id = o->track_id;
    d->complexity_q15 = o->complexity_q15;
    d->score_q8 = o->score_q8;
    // Recovery measures like a hot spot; a CNN-only detector labels it as its one source.
    const uint8_t src = det->cfg.sources;
    const bool cnn_only = (src & VD_DETECTOR_SRC_HOTSPOT) == 0u && (src & VD_DETECTOR_SRC_CNN) != 0u;
    d->source = cnn_only ? (uint8_t)VD_DETECTION_SOURCE_CNN : (uint8_t)VD_DETECTION_SOURCE_HOTSPOT;
    d->state = VD_TRACK_RECOVERED;
    d->flags = VD_DETECTION_FLAG_RECOVERED;
    d->hot_thr = thr8;
}

// A stage's status into the run's: VD_ERR_CAPACITY is remembered in *result
// and the run goes on (its detections are still valid); any other error is
// returned and stops the run.
static vd_status_t keep_capacity(vd_status_t st, vd_status_t *result)
{
    if (st == VD_ERR_CAPACITY) {
        *result = VD_ERR_CAPACITY;
        return VD_OK;
    }
    return st;
}

// Hot spots (steps 1-2): labelling in the overlay straight from the frame,
// the shape rules, then each kept component refined one by one (the
// labelling scratch is dead from then on: the overlay holds region buffers);
// their contour boxes join the merged list behind the n_cnn CNN boxes unless
// they duplicate one. *nc: the merged candidates so far.
static vd_status_t hot_spots(vd_detector_t *det, const vd_frame_t *frame, size_t n_cnn, size_t *nc,
                             vd_status_t *result, uint32_t *t0)
{
    vd_detector_stats_t *s = &det->stats;
    size_t n = 0u;
    if ((det->cfg.sources & VD_DETECTOR_SRC_HOTSPOT) != 0u) {
        VD_TRY(keep_capacity(vd__detector_hot_components(det, frame, &n, t0), result));
    }
    s->components = (uint32_t)n;
    size_t kept = 0u;
    VD_TRY(vd_components_filter(det->comps, n, &det->cfg.rules, &kept));
    s->kept = (uint32_t)kept;
    const size_t room = det->cfg.max_candidates - n_cnn;   // n_cnn <= max_candidates
    if (kept > room) {
        s->overflow_candidates += (uint32_t)(kept - room);
        kept = room;
        *result = VD_ERR_CAPACITY;
    }
    vd__detector_clock_add(det, VD_DETECTOR_STAGE_COMPONENTS, t0);

    const uint8_t thr8 = (uint8_t)s->hot_thr_u8;
    for (size_t i = 0; i < n_cnn; i++) {
        det->cand[i].hot_thr = thr8;
    }
    size_t m = n_cnn;
    for (size_t i = 0; i < kept; i++) {
        bool ok = false;
        VD_TRY(vd__detector_refine_hot(det, frame, &det->comps[i], &det->cand[m], &ok, t0));
        if (ok && n_cnn > 0u && vd_suppress_overlaps(&det->cand[m].box, det->cand, n_cnn, det->cfg.dedup_iou_q15)) {
            s->deduplicated++;   // the network already has this one
            ok = false;
        }
        if (ok) {
            det->cand[m].hot_thr = thr8;
            m++;
        }
    }
    s->cand_hotspot = (uint32_t)(m - n_cnn);
    *nc = m;
    return VD_OK;
}

// Step 3: the observer sees every merged candidate, then verification
// compacts det->cand[0..nc) in place to the *nv kept.
static vd_status_t verify_all(vd_detector_t *det, const vd_frame_t *frame, size_t nc, size_t *nv, uint32_t *t0)
{
    if (det->cfg.on_candidate != NULL) {
        for (size_t i = 0; i < nc; i++) {
            det->cfg.on_candidate(det->cfg.candidate_user, &det->cand[i]);
        }
    }
    size_t k = 0u;
    for (size_t i = 0; i < nc; i++) {
        bool keep = false;
        VD_TRY(vd__detector_verify(det, frame, &det->cand[i], &keep, t0));
        if (keep) {
            if (k != i) {
                det->cand[k] = det->cand[i];
            }
            k++;
        }
    }
    *nv = k;
    return VD_OK;
}

// Step 5: temporal analysis of the nk suppressed detections; track ids and
// states into det->cand, recovered targets after them in det->obs; *total:
// detections with the recovered ones.
static vd_status_t track(vd_detector_t *det, const vd_frame_t *frame, size_t nk, size_t *total,
                         vd_status_t *result, uint32_t *t0)
{
    vd_detector_stats_t *s = &det->stats;
    for (size_t i = 0; i < nk; i++) {
        memset(&det->obs[i], 0, sizeof(det->obs[i]));
        det->obs[i].box = det->cand[i].box;
        det->obs[i].complexity_q15 = det->cand[i].complexity_q15;
        det->obs[i].score_q8 = det->cand[i].score_q8;
    }
    det->frame = frame;
    size_t nobs = 0u;
    const vd_status_t st =
        vd_temporal_update(&det->temporal, det->obs, nk, nk + det->cfg.max_tracks, &nobs, vd__detector_probe, det);
    det->frame = NULL;
    VD_TRY(keep_capacity(st, result));
    s->overflow_tracks = det->temporal.stats.overflow;
    for (size_t i = 0; i < nk; i++) {
        det->cand[i].track_id = det->obs[i].track_id;
        det->cand[i].state = det->obs[i].state;
        if ((det->cand[i].flags & VD_DETECTION_FLAG_UNVERIFIED) == 0u) {
            det->cand[i].score_q8 = det->obs[i].score_q8;   // fused with the track's (VD_TEMPORAL_SCORES), else as was
        }
    }
    *total = nobs;
    s->recovered = (uint32_t)(nobs - nk);
    vd__detector_clock_add(det, VD_DETECTOR_STAGE_TEMPORAL, t0);
    return VD_OK;
}

// VD_DETECTOR_GREY_PERCENTILE on a 16-bit frame: the grey map of this frame,
// from its raw values at the two tails (widened about its middle to the least
// span); resolve() bounded the calibration so that no step can fail.
static vd_status_t grey_window(vd_detector_t *det, const vd_frame_t *frame)
{
    vd_view_u16_t v;
    VD_TRY(vd_frame_view_u16(frame, &v));
    const uint32_t tail = det->cfg.grey_tail_permille;
    uint16_t lo = 0u, hi = 0u;
    VD_TRY(vd_histogram_percentiles_u16(&v, tail, 1000u - tail, det->hist, &lo, &hi));
    det->stats.grey_lo_raw = lo;
    det->stats.grey_hi_raw = hi;
    int32_t lo_ck = 0, hi_ck = 0;
    VD_TRY(vd_calib_ck_from_raw(&det->cfg.calib, lo, &lo_ck));
    VD_TRY(vd_calib_ck_from_raw(&det->cfg.calib, hi, &hi_ck));
    if ((int64_t)hi_ck - lo_ck < VD_DETECTOR_GREY_MIN_SPAN_CK) {
        lo_ck = (int32_t)(((int64_t)lo_ck + hi_ck - VD_DETECTOR_GREY_MIN_SPAN_CK) / 2);
        hi_ck = lo_ck + VD_DETECTOR_GREY_MIN_SPAN_CK;
    }
    return vd_calib_grey_init(&det->grey, &det->cfg.calib, lo_ck, hi_ck);
}

vd_status_t vd_detector_run(vd_detector_t *det, const vd_frame_t *frame, vd_detection_t *out, size_t cap,
                            size_t *count)
{
    VD_VERIFY(count != NULL, VD_ERR_ARG);
    *count = 0u;
    VD_VERIFY(det != NULL && frame != NULL, VD_ERR_ARG);
    VD_VERIFY(out != NULL || cap == 0u, VD_ERR_ARG);
    VD_VERIFY(det->overlay != NULL, VD_ERR_STATE);
    VD_TRY(vd_frame_check(frame));
    VD_VERIFY(frame->width <= det->cfg.max_width && frame->height <= det->cfg.max_height, VD_ERR_ARG);

    memset(&det->stats, 0, sizeof(det->stats));
    vd_detector_stats_t *s = &det->stats;
    uint32_t t_start = clock_now(det);
    uint32_t t0 = t_start;
    vd_status_t result = VD_OK;

    if (frame->format != VD_PIX_U8 && det->cfg.grey_mode == VD_DETECTOR_GREY_PERCENTILE) {
        VD_TRY(grey_window(det, frame));   // timed with the first stage that follows
    }
    // The network first: it uses the overlay, and its boxes lead the merged list.
    size_t n_cnn = 0u;
    if ((det->cfg.sources & VD_DETECTOR_SRC_CNN) != 0u) {
        VD_TRY(keep_capacity(vd__detector_cnn_source(det, frame, &n_cnn), &result));
        vd__detector_clock_add(det, VD_DETECTOR_STAGE_CNN, &t0);
    }
    size_t nc = 0u;
    VD_TRY(hot_spots(det, frame, n_cnn, &nc, &result, &t0));
    const uint8_t thr8 = (uint8_t)s->hot_thr_u8;
    if ((det->cfg.sources & VD_DETECTOR_SRC_CONTRAST) != 0u) {
        VD_TRY(keep_capacity(vd__detector_contrast_source(det, frame, &nc, thr8), &result));
        vd__detector_clock_add(det, VD_DETECTOR_STAGE_CONTRAST, &t0);
    }
    if ((det->cfg.sources & VD_DETECTOR_SRC_WINDOW) != 0u) {
        VD_TRY(vd__detector_window_source(det, frame, &nc, thr8));   // the overlay holds the integrals until here
        vd__detector_clock_add(det, VD_DETECTOR_STAGE_WINDOWS, &t0);
    }
    size_t nv = 0u;
    VD_TRY(verify_all(det, frame, nc, &nv, &t0));
    size_t nk = 0u;
    VD_TRY(suppress(det, nv, &nk));
    vd__detector_clock_add(det, VD_DETECTOR_STAGE_NMS, &t0);
    if (s->overflow_detections != 0u) {
        result = VD_ERR_CAPACITY;
    }
    size_t total = nk;
    if (det->cfg.temporal) {
        VD_TRY(track(det, frame, nk, &total, &result, &t0));
    }

    size_t w = total < cap ? total : cap;
    for (size_t i = 0; i < w; i++) {
        if (i < nk) {
            out[i] = det->cand[i];
        } else {
            recovered(det, frame, &det->obs[i], thr8, &out[i]);
        }
    }
    if (w < total) {
        s->overflow_detections += (uint32_t)(total - w);
        result = VD_ERR_CAPACITY;
    }
    s->detections = (uint32_t)w;
    *count = w;
    if (det->cfg.clock_us != NULL) {
        s->time_us[VD_DETECTOR_STAGE_TOTAL] = clock_now(det) - t_start;
    }
    return result;
}
