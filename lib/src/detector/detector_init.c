// SPDX-License-Identifier: MIT
// The detector's configuration (defaults and checks) and its workspace: the size query, the layout and init.
//
// The workspace is carved once in init (layout in docs/architecture.md):
// fixed tables (components, candidates, histogram, temporal, per-candidate
// state, sample and DBN scratch) plus one "overlay" reused by the stages of a
// frame in turn: the labelling workspace with its run budget, then the
// per-candidate region buffers (crop, mask, refine workspace, which the
// contour tracer reuses), then the contrast source's strip workspace and the
// window pre-filter's integrals; with the CNN source, first of all the
// network's streamed workspace (row rings; its input rows are made on demand) and decoded
// boxes (the header's max_peaks; twice that with cnn_flip, whose fusion needs
// both passes' boxes; with cfg.cnn_model2 the larger network's workspace and
// both networks' boxes). No hot mask and no buffer per frame pixel except the labeller's row buffers.
// Bounds: O(1) time and stack, plus the CNN planner (O(layers^2), ~950 bytes
// of stack, cnn.h) when the source is on; no allocation.
#include <string.h>

#include "models/cnn/cnn_internal.h"
#include "detector/detector_internal.h"
#include "internal/vd_internal.h"

#define DEF_W 640u
#define DEF_H 512u
#define DEF_REGION 176u
#define DEF_RUNS 24576u
#define DEF_WIN_MIN_STD 4u
#define DEF_DEDUP_Q15 22938u   // 0.7

// Each default of the detector's own fields is written here once; the
// sub-settings are resolved by their modules. vd_detector_cfg_default is a
// zeroed cfg resolved.
vd_status_t vd_detector_cfg_resolve(vd_detector_cfg_t *c)
{
    VD_VERIFY(c != NULL, VD_ERR_ARG);
    if (c->max_width == 0u) { c->max_width = DEF_W; }
    if (c->max_height == 0u) { c->max_height = DEF_H; }
    VD_VERIFY(c->max_width <= VD_MAX_DIM && c->max_height <= VD_MAX_DIM, VD_ERR_ARG);
    VD_VERIFY(c->thr_mode <= VD_DETECTOR_THR_ADAPTIVE, VD_ERR_ARG);
    if (c->hot_thr_u8 == 0u) { c->hot_thr_u8 = 150u; }
    if (c->adaptive_floor_u8 == 0u) { c->adaptive_floor_u8 = 96u; }
    if (c->adaptive_permille == 0u) { c->adaptive_permille = 990u; }
    VD_VERIFY(c->adaptive_permille <= 1000u, VD_ERR_ARG);
    if (c->hot_thr_ck == 0) { c->hot_thr_ck = VD_CALIB_CK_PER_0C + 3000; }
    VD_VERIFY(c->hot_thr_ck > 0 && c->hot_thr_ck <= 1000000, VD_ERR_ARG);   // <= 10 000 K
    if (c->calib.gain_q16 == 0) { c->calib.gain_q16 = 65536; }
    VD_VERIFY(c->calib.gain_q16 > 0, VD_ERR_ARG);
    if (c->grey_lo_ck == 0) { c->grey_lo_ck = c->hot_thr_ck - 3000; }
    if (c->grey_hi_ck == 0) { c->grey_hi_ck = c->hot_thr_ck + 2100; }
    VD_VERIFY(c->grey_lo_ck < c->grey_hi_ck, VD_ERR_ARG);
    VD_VERIFY(c->grey_mode <= VD_DETECTOR_GREY_PERCENTILE, VD_ERR_ARG);
    if (c->grey_tail_permille == 0u) { c->grey_tail_permille = 1u; }
    VD_VERIFY(c->grey_tail_permille <= 499u, VD_ERR_ARG);
    if (c->grey_mode == VD_DETECTOR_GREY_PERCENTILE) {
        // Every raw value's temperature, widened by the least span, must fit an int32: then the per-frame
        // window cannot fail.
        int32_t top = 0;
        VD_VERIFY(vd_calib_ck_from_raw(&c->calib, 65535u, &top) == VD_OK, VD_ERR_ARG);
        VD_VERIFY(top <= INT32_MAX - VD_DETECTOR_GREY_MIN_SPAN_CK, VD_ERR_ARG);
        VD_VERIFY(c->calib.offset_ck >= INT32_MIN + VD_DETECTOR_GREY_MIN_SPAN_CK, VD_ERR_ARG);
    }
    VD_TRY(vd_components_rules_resolve(&c->rules));
    if (c->expand_w_q8 == 0u) { c->expand_w_q8 = VD_RECT_EXPAND_W_Q8; }
    if (c->expand_h_q8 == 0u) { c->expand_h_q8 = VD_RECT_EXPAND_H_Q8; }
    VD_VERIFY(c->expand_w_q8 >= 256u && c->expand_w_q8 <= 2048u, VD_ERR_ARG);
    VD_VERIFY(c->expand_h_q8 >= 256u && c->expand_h_q8 <= 2048u, VD_ERR_ARG);
    if (c->median_ksize == 0u) { c->median_ksize = 3u; }
    VD_VERIFY(c->median_ksize == 1u || c->median_ksize == 3u || c->median_ksize == 5u, VD_ERR_ARG);
    if (c->edge_step == 0u) { c->edge_step = 5u; }
    if (c->window == 0u) { c->window = 5u; }
    VD_VERIFY(c->window >= 3u && c->window <= VD_REFINE_MAX_WINDOW && (c->window & 1u) == 1u, VD_ERR_ARG);
    if (c->score_thr_q8 == 0u) { c->score_thr_q8 = 128u; }
    if (c->nms_iou_q15 == 0u) { c->nms_iou_q15 = 16384u; }
    VD_VERIFY(c->nms_iou_q15 <= 32768u, VD_ERR_ARG);
    if (c->max_components == 0u) { c->max_components = 256u; }
    if (c->max_candidates == 0u) { c->max_candidates = 64u; }
    VD_VERIFY(c->max_candidates <= 4096u, VD_ERR_ARG);
    if (c->max_detections == 0u) {
        c->max_detections = (uint16_t)(c->max_candidates < 32u ? c->max_candidates : 32u);
    }
    VD_VERIFY(c->max_detections <= c->max_candidates, VD_ERR_ARG);
    if (c->max_region_w == 0u) { c->max_region_w = (uint16_t)(c->max_width < DEF_REGION ? c->max_width : DEF_REGION); }
    if (c->max_region_h == 0u) { c->max_region_h = (uint16_t)(c->max_height < DEF_REGION ? c->max_height : DEF_REGION); }
    VD_VERIFY(c->max_region_w <= c->max_width && c->max_region_h <= c->max_height, VD_ERR_ARG);
    if (c->max_tracks == 0u) { c->max_tracks = 32u; }
    if (c->max_runs == 0u) { c->max_runs = DEF_RUNS; }
    VD_VERIFY(c->max_tracks <= 1024u, VD_ERR_ARG);
    if (c->sources == 0u) { c->sources = VD_DETECTOR_SRC_HOTSPOT; }
    VD_VERIFY(c->sources <= (VD_DETECTOR_SRC_ALL | VD_DETECTOR_SRC_CNN), VD_ERR_ARG);
    // CNN: the model is checked by the size query and init (they see it loaded or not).
    VD_VERIFY(c->cnn_score_thr_q15 <= (uint32_t)VD_CNN_SCORE_ONE_Q15 && c->cnn_rescore <= 1u &&
                  c->cnn_flip <= 1u && c->cnn_res <= VD_DETECTOR_CNN_RES_QUARTER && c->cnn_invert <= 1u, VD_ERR_ARG);
    VD_VERIFY((c->sources & VD_DETECTOR_SRC_CNN) == 0u || c->cnn_model != NULL, VD_ERR_ARG);
    VD_VERIFY(c->verifier <= VD_DETECTOR_VERIFIER_BOOST, VD_ERR_ARG);
    VD_VERIFY(c->verifier != VD_DETECTOR_VERIFIER_BOOST || c->boost_model != NULL, VD_ERR_ARG);
    VD_VERIFY(c->boost_thr_offset >= -(1L << 24) && c->boost_thr_offset <= (1L << 24), VD_ERR_ARG);
    if (c->win_min_std_u8 == 0u) { c->win_min_std_u8 = DEF_WIN_MIN_STD; }
    if (c->dedup_iou_q15 == 0u) { c->dedup_iou_q15 = DEF_DEDUP_Q15; }
    VD_VERIFY(c->dedup_iou_q15 <= 32768u, VD_ERR_ARG);
    // Contrast: checked even when the source is off, as before.
    VD_TRY(vd_contrast_cfg_resolve(&c->contrast));
    // Windows: checked for the largest frame (each frame resolves its own copy).
    VD_VERIFY(c->windows.frame_w <= VD_MAX_DIM && c->windows.frame_h <= VD_MAX_DIM, VD_ERR_ARG);
    vd_windows_cfg_t wc = c->windows;
    wc.frame_w = c->max_width;
    wc.frame_h = c->max_height;
    VD_TRY(vd_windows_resolve(&wc));
    if ((c->sources & VD_DETECTOR_SRC_WINDOW) != 0u) {
        size_t integrals = 0u;   // VD_ERR_ARG when the cell grid is too large for uint32 integrals
        VD_TRY(vd_windows_prefilter_workspace_size(c->max_width, c->max_height, &integrals));
    }
    return vd_temporal_cfg_resolve(&c->temporal_cfg);
}

void vd_detector_cfg_default(vd_detector_cfg_t *cfg)
{
    if (cfg == NULL) {
        return;
    }
    memset(cfg, 0, sizeof(*cfg));
    const vd_status_t st = vd_detector_cfg_resolve(cfg);   // the defaults always resolve
    VD_ASSERT(st == VD_OK);
    (void)st;
}

// A resolved copy of cfg (NULL = defaults).
static vd_status_t resolved(const vd_detector_cfg_t *cfg, vd_detector_cfg_t *c)
{
    if (cfg == NULL) {
        memset(c, 0, sizeof(*c));
    } else {
        *c = *cfg;
    }
    return vd_detector_cfg_resolve(c);
}

static void region_bufs(const vd_detector_t *det, region_bufs_t *b)
{
    size_t rsz = (size_t)det->cfg.max_region_w * det->cfg.max_region_h;
    vd_arena_t a = {det->overlay, det->overlay_bytes, 0u};   // overlay is aligned (carved by init)
    b->crop = (uint8_t *)vd_arena_take(&a, rsz);
    b->rmask = (uint8_t *)vd_arena_take(&a, rsz);
    const size_t work_at = a.used;
    b->refine_ws = vd_arena_take(&a, det->refine_ws_bytes);
    a.used = work_at;   // the tracer's buffers overlay the refine workspace (see overlay_size)
    b->contour_ws = vd_arena_take(&a, det->contour_ws_bytes);
    b->points = (vd_point_t *)vd_arena_take(&a, det->points_cap * sizeof(vd_point_t));
    b->contours = (vd_contour_t *)vd_arena_take(&a, det->contours_cap * sizeof(vd_contour_t));
    VD_ASSERT(b->refine_ws != NULL && b->contours != NULL);
}

static void refine_cfg_of(const vd_detector_t *det, vd_refine_cfg_t *rc)
{
    rc->median_ksize = (det->cfg.median_ksize == 1u) ? 0u : det->cfg.median_ksize;
    rc->edge_step = det->cfg.edge_step;
    rc->window = det->cfg.window;
}

// Byte sizes of every workspace slice.
typedef struct layout {
    size_t comps, cand, obs, tracks, hist, sample, dbn, scratch;
    size_t cc, crop, rmask, refine, contour, points, contours;
    size_t contrast, integral;
    size_t cnn_ws, cnn_boxes, cnn_park;
    size_t points_cap, contours_cap, cnn_boxes_cap;
    int32_t cnn_thr_i8, cnn2_thr_i8;
    uint32_t cnn_thr_score_q15;
    bool cnn_never, cnn2_never;
} layout_t;

// *q = the logit threshold of network m for decode score lo (>= 1), or
// *never when no logit of m scores that high.
static vd_status_t decode_thr(const vd_cnn_model_t *m, uint32_t lo, int32_t *q, bool *never)
{
    const vd_status_t st = vd_cnn_thr_from_score(m, lo, q);
    if (st == VD_ERR_RANGE) {
        *never = true;
        return VD_OK;
    }
    return st;
}

// Checks that m is loaded (score 0 always maps to -128) and adds its
// streamed workspace for the largest frame to the max in l->cnn_ws.
static vd_status_t plan_net(const vd_detector_cfg_t *c, const vd_cnn_model_t *m, layout_t *l, bool *no_plane)
{
    int32_t thr = 0;
    vd_status_t st = vd_cnn_thr_from_score(m, 0u, &thr);
    VD_VERIFY(st != VD_ERR_STATE, VD_ERR_MODEL);
    VD_TRY(st);
    uint32_t nw = 0u;
    uint32_t nh = 0u;
    const uint32_t d = vd__detector_cnn_div(c);
    vd__detector_cnn_input_size(m, d, c->max_width, c->max_height, &nw, &nh);
    if (nw == 0u || nh == 0u) {
        *no_plane = true;   // no half-resolution pixel in any frame
        return VD_OK;
    }
    // Decoding scales to d nw x d nh, which must be a valid frame size.
    VD_VERIFY(nw <= VD_CNN_MAX_SIDE && nh <= VD_CNN_MAX_SIDE && nw <= VD_MAX_DIM / d && nh <= VD_MAX_DIM / d,
              VD_ERR_ARG);
    // Streamed: the network keeps row rings, and its input rows are made on
    // demand from the frame (no input plane).
    size_t ws = 0u;
    st = vd_cnn_workspace_size_ex(m, nw, nh, VD_DETECTOR_CNN_FLAGS, &ws);
    VD_VERIFY(st != VD_ERR_STATE, VD_ERR_MODEL);
    VD_TRY(st);
    l->cnn_ws = (ws > l->cnn_ws) ? ws : l->cnn_ws;   // the networks run in turn
    return VD_OK;
}

// The CNN source's slices (they overlay the others: the network runs before
// labelling) and its resolved thresholds: T, the score threshold in Q15
// (cnn_score_thr_q15, or the decode-table score of the header's logit
// threshold: cnn_model2's for a pair), and the logit threshold of the
// decode: that of T, or, when P passes are averaged into a final score (2
// with cnn_flip or cnn_model2, 4 with both), that of max(1, P T - (P - 1)
// 32768) (one pass below it cannot lift the mean to T), for each network
// through its own score table.
static vd_status_t plan_cnn(const vd_detector_cfg_t *c, layout_t *l)
{
    const vd_cnn_model_t *m = c->cnn_model;
    const vd_cnn_model_t *m2 = c->cnn_model2;
    bool no_plane = false;
    VD_TRY(plan_net(c, m, l, &no_plane));
    if (m2 != NULL) {
        VD_TRY(plan_net(c, m2, l, &no_plane));
    }
    // A pair's default operating point is the second network's header
    // threshold: it is chosen for the pair, and the first network's header
    // keeps the threshold of that network alone.
    const vd_cnn_model_t *mt = (m2 != NULL) ? m2 : m;
    l->cnn_thr_i8 = m->score_threshold_i8;
    l->cnn_thr_score_q15 = vd__cnn_score_of_logit(mt, mt->score_threshold_i8);
    const uint32_t passes = (c->cnn_flip != 0u ? 2u : 1u) * (m2 != NULL ? 2u : 1u);
    if (c->cnn_score_thr_q15 != 0u) {
        l->cnn_thr_score_q15 = c->cnn_score_thr_q15;
        // No logit scores that high: nothing to run for (a fused score is at
        // most the larger of the networks' top scores).
        VD_TRY(decode_thr(m, c->cnn_score_thr_q15, &l->cnn_thr_i8, &l->cnn_never));
        if (m2 != NULL) {
            int32_t q2 = 0;
            VD_TRY(decode_thr(m2, c->cnn_score_thr_q15, &q2, &l->cnn2_never));
            l->cnn_never = l->cnn2_never = l->cnn_never && l->cnn2_never;
        }
    }
    if (passes > 1u && !l->cnn_never) {
        // lo = max(1, P T - (P - 1) 32768); T <= 32768 and P <= 4, so P T fits.
        const uint32_t pt = passes * l->cnn_thr_score_q15;
        const uint32_t sub = (passes - 1u) * (uint32_t)VD_CNN_SCORE_ONE_Q15;
        const uint32_t lo = (pt > sub) ? pt - sub : 1u;
        // lo <= T, so this fails only when no logit scores lo or more.
        VD_TRY(decode_thr(m, lo, &l->cnn_thr_i8, &l->cnn_never));
        if (m2 != NULL) {
            VD_TRY(decode_thr(m2, lo, &l->cnn2_thr_i8, &l->cnn2_never));
        }
    }
    if (no_plane) {
        l->cnn_never = true;
        l->cnn2_never = true;
        l->cnn_ws = 0u;
        return VD_OK;
    }
    // A pair parks what VD_CNN_REUSE_PLAN keeps of each network's run record (each keeps its plan: one
    // sizing walk less per network and frame, ~0.8 M instructions of vd_cnn on x86).
    l->cnn_park = (m2 != NULL) ? 2u * (size_t)VD_CNN_PLAN_KEY_BYTES : 0u;
    // With cnn_flip pass A's boxes [0, K) survive pass B's decode into [K, 2K);
    // cnn_model2's boxes follow the first network's.
    const size_t f = (c->cnn_flip != 0u) ? 2u : 1u;
    l->cnn_boxes_cap = ((size_t)m->max_peaks + (m2 != NULL ? (size_t)m2->max_peaks : 0u)) * f;
    l->cnn_boxes = l->cnn_boxes_cap * sizeof(vd_cnn_box_t);
    return VD_OK;
}

static vd_status_t plan(const vd_detector_cfg_t *c, const vd_dbn_model_t *model, layout_t *l)
{
    memset(l, 0, sizeof(*l));
    size_t rw = c->max_region_w;
    size_t rh = c->max_region_h;
    // The components table holds hot-spot and contrast components, the
    // histogram the adaptive threshold, the window ranking and the per-frame
    // grey window: a network-only fixed-window
    // detector needs neither (8 KiB at the defaults).
    if ((c->sources & (VD_DETECTOR_SRC_HOTSPOT | VD_DETECTOR_SRC_CONTRAST)) != 0u) {
        VD_VERIFY(vd_mul_size(c->max_components, sizeof(vd_component_t), &l->comps), VD_ERR_OVERFLOW);
    }
    VD_VERIFY(vd_mul_size(c->max_candidates, sizeof(vd_detection_t), &l->cand), VD_ERR_OVERFLOW);
    if (c->temporal) {
        l->obs = ((size_t)c->max_detections + c->max_tracks) * sizeof(vd_temporal_obs_t);
        l->tracks = (size_t)c->max_tracks * sizeof(vd_track_t);
    }
    if ((c->sources & (VD_DETECTOR_SRC_HOTSPOT | VD_DETECTOR_SRC_WINDOW)) != 0u ||
        c->grey_mode == VD_DETECTOR_GREY_PERCENTILE) {
        l->hist = 256u * sizeof(uint32_t);
    }
    l->scratch = sizeof(cand_ctx_t);
    if (model != NULL) {
        VD_VERIFY(model->blob != NULL && model->input_w > 0u && model->input_h > 0u, VD_ERR_MODEL);
        VD_VERIFY(model->input_mode == VD_DBN_INPUT_GREY || model->input_mode == VD_DBN_INPUT_SHAPE, VD_ERR_MODEL);
        l->sample = (size_t)model->input_w * model->input_h;
        vd_status_t st = vd_dbn_workspace_size(model, &l->dbn);
        VD_VERIFY(st == VD_OK, VD_ERR_MODEL);
    }
    if (c->verifier == VD_DETECTOR_VERIFIER_BOOST) {
        // The boosted verifier's crop and workspace take the DBN's slices (one verifier runs).
        const vd_boost_model_t *bm = c->boost_model;
        size_t w = 0u;
        VD_VERIFY(vd_boost_workspace_size(bm, &w) == VD_OK, VD_ERR_MODEL);
        const size_t s = (size_t)bm->crop_w * bm->crop_h;
        l->sample = (s > l->sample) ? s : l->sample;
        l->dbn = (w > l->dbn) ? w : l->dbn;
    }
    VD_TRY(vd_components_workspace_size_runs(c->max_width, c->max_height, c->max_runs, &l->cc));
    l->crop = rw * rh;
    l->rmask = rw * rh;
    VD_TRY(vd_refine_workspace_size((uint32_t)rw, (uint32_t)rh, &l->refine));
    VD_TRY(vd_contour_workspace_size((uint32_t)rw, (uint32_t)rh, &l->contour));
    // Room for a few outlines around the region; more only sets CONTOUR_TRUNC.
    l->points_cap = 8u * (rw + rh);
    l->contours_cap = 64u;
    l->points = l->points_cap * sizeof(vd_point_t);
    l->contours = l->contours_cap * sizeof(vd_contour_t);
    if ((c->sources & VD_DETECTOR_SRC_CONTRAST) != 0u) {
        // Row strips (640 x 512: 49 664 bytes), inside the overlay.
        VD_TRY(vd_contrast_workspace_size(c->max_width, c->max_height, &l->contrast));
    }
    if ((c->sources & VD_DETECTOR_SRC_WINDOW) != 0u) {
        // 640 x 512: 166 152 bytes, inside the region buffers' share of the overlay.
        VD_TRY(vd_windows_prefilter_workspace_size(c->max_width, c->max_height, &l->integral));
    }
    if ((c->sources & VD_DETECTOR_SRC_CNN) != 0u) {
        // re-scoring needs a verifier
        VD_VERIFY(c->cnn_rescore == 0u || model != NULL || c->verifier == VD_DETECTOR_VERIFIER_BOOST, VD_ERR_ARG);
        VD_TRY(plan_cnn(c, l));
    }
    return VD_OK;
}

// The overlay holds A = the labelling workspace (run budget) while labelling,
// then B = crop + region mask + W per candidate, where W is the refine
// workspace, reused by the contour tracer (its plane, points and contours)
// once vd_refine_region has returned; C = the window pre-filter's integrals
// between the hot-spot refinement and the verification of all candidates;
// D = the CNN's streamed workspace and boxes, before labelling (the boxes are
// copied into the candidate table before A is touched); E = the contrast
// source's workspace, after the hot-spot refinement and before C (its
// components go to the comps table, its boxes to the candidate table).
static vd_status_t overlay_size(const layout_t *l, size_t *work_out, size_t *total)
{
    size_t a = 0u;
    size_t b = 0u;
    size_t d = 0u;
    size_t tr = 0u;
    size_t rf = 0u;
    VD_VERIFY(vd_size_add_slice(&a, l->cc), VD_ERR_OVERFLOW);
    VD_VERIFY(vd_size_add_slice(&rf, l->refine), VD_ERR_OVERFLOW);
    VD_VERIFY(vd_size_add_slice(&tr, l->contour) && vd_size_add_slice(&tr, l->points) &&
              vd_size_add_slice(&tr, l->contours), VD_ERR_OVERFLOW);
    const size_t work = rf > tr ? rf : tr;
    VD_VERIFY(vd_size_add_slice(&b, l->crop) && vd_size_add_slice(&b, l->rmask) && vd_size_add_slice(&b, work),
              VD_ERR_OVERFLOW);
    VD_VERIFY(vd_size_add_slice(&d, l->cnn_ws) && vd_size_add_slice(&d, l->cnn_boxes), VD_ERR_OVERFLOW);
    *work_out = work;
    *total = a > b ? a : b;
    *total = (l->integral > *total) ? l->integral : *total;
    *total = (l->contrast > *total) ? l->contrast : *total;
    *total = (d > *total) ? d : *total;
    return VD_OK;
}

static vd_status_t total_size(const layout_t *l, size_t *bytes)
{
    size_t ov;
    size_t a;
    VD_TRY(overlay_size(l, &a, &ov));
    size_t t = 0u;
    VD_VERIFY(vd_size_add_slice(&t, l->comps) && vd_size_add_slice(&t, l->cand) &&
              vd_size_add_slice(&t, l->obs) && vd_size_add_slice(&t, l->tracks) &&
              vd_size_add_slice(&t, l->hist) && vd_size_add_slice(&t, l->scratch) &&
              vd_size_add_slice(&t, l->sample) && vd_size_add_slice(&t, l->dbn) &&
              vd_size_add_slice(&t, l->cnn_park) && vd_size_add_slice(&t, ov), VD_ERR_OVERFLOW);
    *bytes = t;
    return VD_OK;
}

vd_status_t vd_detector_workspace_size(const vd_detector_cfg_t *cfg, const vd_dbn_model_t *model, size_t *bytes)
{
    VD_VERIFY(bytes != NULL, VD_ERR_ARG);
    vd_detector_cfg_t c;
    VD_TRY(resolved(cfg, &c));
    layout_t l;
    VD_TRY(plan(&c, model, &l));
    return total_size(&l, bytes);
}

// Network m's plan for the largest frame into the network workspace ws (vd__cnn_plan_ahead); nothing
// without a half-resolution pixel (nw or nh 0: the network never runs).
static vd_status_t plan_ahead(const vd_cnn_model_t *m, const vd_detector_cfg_t *c, void *ws, size_t bytes)
{
    uint32_t nw = 0u;
    uint32_t nh = 0u;
    vd__detector_cnn_input_size(m, vd__detector_cnn_div(c), c->max_width, c->max_height, &nw, &nh);
    return (nw != 0u && nh != 0u) ? vd__cnn_plan_ahead(m, nw, nh, VD_DETECTOR_CNN_FLAGS, ws, bytes) : VD_OK;
}

// Slices of the arena; VD_ERR_WORKSPACE when one does not fit.
static void *take(vd_arena_t *a, size_t bytes, bool *ok)
{
    if (bytes == 0u) {
        return NULL;
    }
    void *p = vd_arena_take(a, bytes);
    if (p == NULL) {
        *ok = false;
    }
    return p;
}

vd_status_t vd_detector_init(vd_detector_t *det, const vd_detector_cfg_t *cfg, const vd_dbn_model_t *model,
                             void *ws, size_t bytes)
{
    VD_VERIFY(det != NULL, VD_ERR_ARG);
    vd_detector_cfg_t c;
    VD_TRY(resolved(cfg, &c));
    layout_t l;
    VD_TRY(plan(&c, model, &l));
    size_t need;
    VD_TRY(total_size(&l, &need));
    vd_arena_t arena;
    VD_TRY(vd_arena_init(&arena, ws, bytes));
    VD_VERIFY(bytes >= need, VD_ERR_WORKSPACE);

    memset(det, 0, sizeof(*det));
    det->cfg = c;
    det->model = model;
    bool ok = true;
    det->comps = (vd_component_t *)take(&arena, l.comps, &ok);
    det->cand = (vd_detection_t *)take(&arena, l.cand, &ok);
    det->obs = (vd_temporal_obs_t *)take(&arena, l.obs, &ok);
    det->tracks = (vd_track_t *)take(&arena, l.tracks, &ok);
    det->hist = (uint32_t *)take(&arena, l.hist, &ok);
    det->scratch = take(&arena, l.scratch, &ok);
    det->sample = (uint8_t *)take(&arena, l.sample, &ok);
    det->dbn_ws = take(&arena, l.dbn, &ok);
    det->dbn_ws_bytes = l.dbn;
    det->cnn_park = take(&arena, l.cnn_park, &ok);
    size_t work;
    VD_TRY(overlay_size(&l, &work, &det->overlay_bytes));
    det->overlay = (uint8_t *)take(&arena, det->overlay_bytes, &ok);
    if (!ok) {
        memset(det, 0, sizeof(*det));
        return VD_ERR_WORKSPACE;   // unreachable when bytes >= need; kept as a guard
    }
    det->cc_ws_bytes = l.cc;
    if (l.contrast != 0u) {
        det->contrast_ws = det->overlay;   // E of overlay_size
        det->contrast_ws_bytes = l.contrast;
    }
    det->refine_ws_bytes = l.refine;
    det->contour_ws_bytes = l.contour;
    det->points_cap = l.points_cap;
    det->contours_cap = l.contours_cap;
    if (l.cnn_ws != 0u) {
        vd_arena_t a = {det->overlay, det->overlay_bytes, 0u};   // D of overlay_size
        det->cnn_ws = vd_arena_take(&a, l.cnn_ws);
        det->cnn_ws_bytes = l.cnn_ws;
        // Each network's plan for the largest frame, kept by a first frame of that size as by the later
        // ones (the sizing walk: ~1.2 M instructions of vd_cnn_compact on a Cortex-M7): a pair's second
        // network first, then the first network's, which writes the record VD_CNN_REUSE_PLAN reads first
        // (vd/cnn.h); a pair parks both keys.
        vd_status_t pst = VD_OK;
        uint8_t *park = (uint8_t *)det->cnn_park;
        if (c.cnn_model2 != NULL) {
            pst = plan_ahead(c.cnn_model2, &c, det->cnn_ws, l.cnn_ws);
            memcpy(park + VD_CNN_PLAN_KEY_BYTES, det->cnn_ws, VD_CNN_PLAN_KEY_BYTES);
        }
        pst = (pst == VD_OK) ? plan_ahead(c.cnn_model, &c, det->cnn_ws, l.cnn_ws) : pst;
        if (park != NULL) {
            memcpy(park, det->cnn_ws, VD_CNN_PLAN_KEY_BYTES);
        }
        if (pst != VD_OK) {
            memset(det, 0, sizeof(*det));
            return pst;   // not expected: plan_net sized the workspace with the same call
        }
        det->cnn_boxes = (vd_cnn_box_t *)vd_arena_take(&a, l.cnn_boxes);
        det->cnn_boxes_cap = l.cnn_boxes_cap;
        VD_ASSERT(det->cnn_boxes != NULL);
    }
    det->cnn_thr_i8 = l.cnn_thr_i8;
    det->cnn_thr_score_q15 = l.cnn_thr_score_q15;
    det->cnn_never = l.cnn_never;
    det->cnn2_thr_i8 = l.cnn2_thr_i8;
    det->cnn2_never = l.cnn2_never;
    cand_ctx_t *x = (cand_ctx_t *)det->scratch;
    memset(x, 0, sizeof(*x));
    region_bufs(det, &x->b);
    refine_cfg_of(det, &x->rc);
    if (model != NULL) {
        det->in_w = model->input_w;
        det->in_h = model->input_h;
    }
    if (c.verifier == VD_DETECTOR_VERIFIER_BOOST) {
        det->in_w = c.boost_model->crop_w;
        det->in_h = c.boost_model->crop_h;
    }
    // 16-bit threshold in raw units; above the calibrated range nothing is hot.
    uint16_t raw = 0u;
    vd_status_t st = vd_calib_raw_from_ck(&c.calib, c.hot_thr_ck, &raw);
    if (st == VD_ERR_RANGE) {
        det->raw_never_hot = true;
    } else if (st != VD_OK) {
        memset(det, 0, sizeof(*det));
        return VD_ERR_ARG;
    }
    det->raw_thr = raw;
    if (vd_calib_grey_init(&det->grey, &c.calib, c.grey_lo_ck, c.grey_hi_ck) != VD_OK) {
        memset(det, 0, sizeof(*det));
        return VD_ERR_ARG;   // unreachable after vd_detector_cfg_resolve; kept as a guard
    }
    if (c.temporal) {
        // Track scores need scores: without a DBN model and without the CNN source every detection is
        // unverified (255), so temporal analysis keeps paper 000's confirmation after confirm_frames.
        if (model == NULL && (c.sources & VD_DETECTOR_SRC_CNN) == 0u) {
            c.temporal_cfg.flags = (uint8_t)(c.temporal_cfg.flags & ~VD_TEMPORAL_SCORES);
        }
        VD_TRY(vd_temporal_init(&det->temporal, &c.temporal_cfg, det->tracks, c.max_tracks));
    }
    return VD_OK;
}
