// SPDX-License-Identifier: MIT
// The detector pipeline: chains threshold, components, refine, contour, resample, DBN, suppression and temporal analysis.
//
// Algorithm: paper 001 ("Night-time vehicle detection in FIR images with a
// DBN"), sections 2-4: constant hot-spot threshold (150 on 8-bit, ~30 C),
// 8-connected regions kept by aspect 0.3..1.5 and area >= 120, expanded 1.5x
// horizontally and 2x vertically; per candidate: median 3x3, Otsu, hole
// filling, edge image, local max-distance thresholds at every 5th edge point
// (refine.h), outer contour (contour.h); DBN verification of a 32x32 sample;
// then greedy overlap suppression, and paper 000 section 4 temporal analysis
// (temporal.h) when enabled. Adaptive threshold (not in the paper) for
// AGC-scaled 8-bit video: max(floor, p-th percentile of the frame).
//
// Candidate sources (issue 7; cfg.sources, default hot spots only): hot-spot
// candidates are refined first and their contour boxes start one merged list;
// then contrast components (contrast.h, 8-bit frames) and sliding windows
// (windows.h bands, streamed in vd_windows_generate's order, never stored) are
// appended unless a box already in the list overlaps them by IoU > dedup_iou;
// every candidate in the list is then sampled (32x32) and scored by the DBN.
// Windows and contrast boxes are verified as they are (no refinement). The
// window pre-filter: a 4x4-cell mean image and its integral images (sum and
// sum of squares, uint32) give each window's standard deviation of cell means
// in O(1); windows below win_min_std are skipped (flat road, sky: measured on
// MSRS/HIT-UAV training frames, a threshold of 4 keeps every window that
// matches a car and drops about half of all windows), and the rest are ranked
// by that deviation (a 256-bin histogram pass, then a collecting pass) so the
// most structured windows fill the room left in max_candidates.
//
// 16-bit frames: candidates come from the radiometric plane (threshold in
// centi-kelvin through vd_calib_t); the 8-bit plane that refine and the DBN
// need is made per region by the linear map grey = (T - lo) * 255 / (hi - lo)
// clamped to 0..255 (a fixed window around the threshold, like a Lepton AGC
// with a fixed range), computed as ((T - lo) * mul_q16 + 2^15) >> 16 with
// mul_q16 = round(255 * 2^16 / (hi - lo)): |error| <= 1 grey level.
//
// Memory: one workspace carved in init (layout in docs/architecture.md). No
// hot mask is made: components are labelled straight from the frame with a
// run budget (components.h), and that labelling workspace shares one
// "overlay" buffer with the per-candidate region buffers, which are only used
// after labelling; inside those, the contour tracer reuses the refine
// workspace.
// Regions larger than max_region_w x max_region_h are box-averaged by
// per-axis integer factors kx, ky first (one rounded division per output
// pixel, each after kx*ky >= 2 additions).
//
// Bounds: time O(W*H) for the (adaptive) histogram, labelling, the contrast
// map and the cell integrals; O(windows * (1 + max_candidates)) for the two
// window passes and the merge; plus, per candidate
// (<= max_candidates), O(region) for refine/contour and the DBN's
// multiply-adds; NMS O(max_candidates^2); temporal as temporal.h with at most
// 289 refine probes per missed confirmed track. Stack: vd_detector_run's own
// frame 136 bytes (Cortex-M7 -Os; per-candidate state is in the workspace),
// plus the deepest stage below it (refine -> median; docs/embedded.md); no
// recursion.
#include "vd/detector.h"

#include <string.h>

#include "vd/contour.h"
#include "vd/otsu.h"
#include "vd/resample.h"
#include "vd/suppress.h"
#include "internal/vd_internal.h"

// Keeps a helper's locals out of its caller's frame while the caller makes
// the deep calls (refine -> median): the stack budget of vd_detector_run.
#if defined(__GNUC__)
#define DET_NOINLINE __attribute__((noinline))
#else
#define DET_NOINLINE
#endif

#define DEF_W 640u
#define DEF_H 512u
#define DEF_REGION 176u
#define DEF_RUNS 24576u
#define DEF_WIN_MIN_STD 4u
#define DEF_DEDUP_Q15 22938u   // 0.7

// Fills zero fields with defaults and checks ranges; sub-settings are resolved
// by their own modules. Each default is written here once: the explicit
// defaults (vd_detector_cfg_default) are a zeroed cfg resolved.
static vd_status_t resolve_cfg(const vd_detector_cfg_t *in, vd_detector_cfg_t *c)
{
    if (in == NULL) {
        memset(c, 0, sizeof(*c));
    } else {
        *c = *in;
    }
    if (c->max_width == 0u) { c->max_width = DEF_W; }
    if (c->max_height == 0u) { c->max_height = DEF_H; }
    VD_VERIFY(c->max_width <= VD_MAX_DIM && c->max_height <= VD_MAX_DIM, VD_ERR_ARG);
    VD_VERIFY(c->thr_mode <= VD_DETECTOR_THR_ADAPTIVE, VD_ERR_ARG);
    if (c->hot_thr_u8 == 0u) { c->hot_thr_u8 = 150u; }
    if (c->adaptive_floor_u8 == 0u) { c->adaptive_floor_u8 = 96u; }
    if (c->adaptive_permille == 0u) { c->adaptive_permille = 990u; }
    VD_VERIFY(c->adaptive_permille <= 1000u, VD_ERR_ARG);
    if (c->hot_thr_ck == 0) { c->hot_thr_ck = VD_CK_PER_0C + 3000; }
    VD_VERIFY(c->hot_thr_ck > 0 && c->hot_thr_ck <= 1000000, VD_ERR_ARG);   // <= 10 000 K
    if (c->calib.gain_q16 == 0) { c->calib.gain_q16 = 65536; }
    VD_VERIFY(c->calib.gain_q16 > 0, VD_ERR_ARG);
    if (c->grey_lo_ck == 0) { c->grey_lo_ck = c->hot_thr_ck - 3000; }
    if (c->grey_hi_ck == 0) { c->grey_hi_ck = c->hot_thr_ck + 2100; }
    VD_VERIFY(c->grey_lo_ck < c->grey_hi_ck, VD_ERR_ARG);
    VD_TRY(vd_cc_rules_resolve(&c->rules));
    if (c->expand_w_q8 == 0u) { c->expand_w_q8 = VD_EXPAND_W_Q8; }
    if (c->expand_h_q8 == 0u) { c->expand_h_q8 = VD_EXPAND_H_Q8; }
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
    VD_VERIFY(c->sources <= VD_DETECTOR_SRC_ALL, VD_ERR_ARG);
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
    const vd_status_t st = resolve_cfg(NULL, cfg);   // the defaults always resolve
    VD_ASSERT(st == VD_OK);
    (void)st;
}

// The 8-bit plane of one region: `view` with `roi` (in view coordinates),
// and the per-axis factors mapping roi pixels to image pixels.
typedef struct region_plane {
    vd_view_u8_t view;
    vd_rect_t roi;
    vd_rect_t region;   // image coordinates
    uint32_t kx, ky;
} region_plane_t;

// Region buffers carved from the overlay (valid after labelling).
typedef struct region_bufs {
    uint8_t *crop;
    uint8_t *rmask;
    void *refine_ws;
    void *contour_ws;
    vd_point_t *points;
    vd_contour_t *contours;
} region_bufs_t;

// Per-candidate state. It lives in the workspace, not on the stack, so that
// the deepest call chain (run -> vd_refine_region -> median) keeps within the
// stack budget of vd_detector_run (docs/embedded.md).
typedef struct cand_ctx {
    // Ordered by alignment (pointer-aligned members first), so the struct has
    // no padding: its size is part of the workspace figure.
    region_bufs_t b;         // fixed once init has carved the overlay
    vd_windows_prefilter_t pf;   // window source: the current frame's integrals (in the overlay)
    region_plane_t p;
    vd_image_u8_t m;         // refine output view on b.rmask
    vd_view_u8_t mv;
    vd_rect_t region;        // expanded candidate (image coordinates)
    vd_refine_stats_t rs;
    vd_contour_t best;
    vd_rect_t vb;            // contour box in plane coordinates
    vd_cc_stats_t cs;
    vd_windows_cfg_t wc;     // window source: settings for the current frame
    vd_refine_cfg_t rc;      // fixed in init
} cand_ctx_t;

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
    size_t points_cap, contours_cap;
} layout_t;

static vd_status_t plan(const vd_detector_cfg_t *c, const vd_model_t *model, layout_t *l)
{
    memset(l, 0, sizeof(*l));
    size_t rw = c->max_region_w;
    size_t rh = c->max_region_h;
    VD_VERIFY(vd_mul_size(c->max_components, sizeof(vd_component_t), &l->comps), VD_ERR_OVERFLOW);
    VD_VERIFY(vd_mul_size(c->max_candidates, sizeof(vd_detection_t), &l->cand), VD_ERR_OVERFLOW);
    if (c->temporal) {
        l->obs = ((size_t)c->max_detections + c->max_tracks) * sizeof(vd_temporal_obs_t);
        l->tracks = (size_t)c->max_tracks * sizeof(vd_track_t);
    }
    l->hist = 256u * sizeof(uint32_t);
    l->scratch = sizeof(cand_ctx_t);
    if (model != NULL) {
        VD_VERIFY(model->blob != NULL && model->input_w > 0u && model->input_h > 0u, VD_ERR_MODEL);
        VD_VERIFY(model->input_mode == VD_DBN_INPUT_GREY || model->input_mode == VD_DBN_INPUT_SHAPE, VD_ERR_MODEL);
        l->sample = (size_t)model->input_w * model->input_h;
        vd_status_t st = vd_dbn_workspace_size(model, &l->dbn);
        VD_VERIFY(st == VD_OK, VD_ERR_MODEL);
    }
    VD_TRY(vd_components_workspace_size_runs(c->max_width, c->max_height, c->max_runs, &l->cc));
    l->crop = rw * rh;
    l->rmask = rw * rh;
    VD_TRY(vd_refine_workspace_size((uint32_t)rw, (uint32_t)rh, &l->refine));
    VD_TRY(vd_contours_workspace_size((uint32_t)rw, (uint32_t)rh, &l->contour));
    // Room for a few outlines around the region; more only sets CONTOUR_TRUNC.
    l->points_cap = 8u * (rw + rh);
    l->contours_cap = 64u;
    l->points = l->points_cap * sizeof(vd_point_t);
    l->contours = l->contours_cap * sizeof(vd_contour_t);
    if ((c->sources & VD_DETECTOR_SRC_CONTRAST) != 0u) {
        VD_TRY(vd_contrast_workspace_size(c->max_width, c->max_height, &l->contrast));
    }
    if ((c->sources & VD_DETECTOR_SRC_WINDOW) != 0u) {
        // 640 x 512: 166 152 bytes, inside the region buffers' share of the overlay.
        VD_TRY(vd_windows_prefilter_workspace_size(c->max_width, c->max_height, &l->integral));
    }
    return VD_OK;
}

// The overlay holds A = the labelling workspace (run budget) while labelling,
// then B = crop + region mask + W per candidate, where W is the refine
// workspace, reused by the contour tracer (its plane, points and contours)
// once vd_refine_region has returned; C = the window pre-filter's integrals
// between the hot-spot refinement and the verification of all candidates.
static vd_status_t overlay_size(const layout_t *l, size_t *work_out, size_t *total)
{
    size_t a = 0u;
    size_t b = 0u;
    size_t tr = 0u;
    size_t rf = 0u;
    VD_VERIFY(vd_size_add_slice(&a, l->cc), VD_ERR_OVERFLOW);
    VD_VERIFY(vd_size_add_slice(&rf, l->refine), VD_ERR_OVERFLOW);
    VD_VERIFY(vd_size_add_slice(&tr, l->contour) && vd_size_add_slice(&tr, l->points) &&
              vd_size_add_slice(&tr, l->contours), VD_ERR_OVERFLOW);
    const size_t work = rf > tr ? rf : tr;
    VD_VERIFY(vd_size_add_slice(&b, l->crop) && vd_size_add_slice(&b, l->rmask) && vd_size_add_slice(&b, work),
              VD_ERR_OVERFLOW);
    *work_out = work;
    *total = a > b ? a : b;
    *total = (l->integral > *total) ? l->integral : *total;
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
              vd_size_add_slice(&t, l->sample) &&
              vd_size_add_slice(&t, l->dbn) && vd_size_add_slice(&t, l->contrast) &&
              vd_size_add_slice(&t, ov), VD_ERR_OVERFLOW);
    *bytes = t;
    return VD_OK;
}

vd_status_t vd_detector_workspace_size(const vd_detector_cfg_t *cfg, const vd_model_t *model, size_t *bytes)
{
    VD_VERIFY(bytes != NULL, VD_ERR_ARG);
    vd_detector_cfg_t c;
    VD_TRY(resolve_cfg(cfg, &c));
    layout_t l;
    VD_TRY(plan(&c, model, &l));
    return total_size(&l, bytes);
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

vd_status_t vd_detector_init(vd_detector_t *det, const vd_detector_cfg_t *cfg, const vd_model_t *model,
                             void *ws, size_t bytes)
{
    VD_VERIFY(det != NULL, VD_ERR_ARG);
    vd_detector_cfg_t c;
    VD_TRY(resolve_cfg(cfg, &c));
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
    det->contrast_ws = take(&arena, l.contrast, &ok);
    det->contrast_ws_bytes = l.contrast;
    size_t work;
    VD_TRY(overlay_size(&l, &work, &det->overlay_bytes));
    det->overlay = (uint8_t *)take(&arena, det->overlay_bytes, &ok);
    if (!ok) {
        memset(det, 0, sizeof(*det));
        return VD_ERR_WORKSPACE;   // unreachable when bytes >= need; kept as a guard
    }
    det->cc_ws_bytes = l.cc;
    det->refine_ws_bytes = l.refine;
    det->contour_ws_bytes = l.contour;
    det->points_cap = l.points_cap;
    det->contours_cap = l.contours_cap;
    cand_ctx_t *x = (cand_ctx_t *)det->scratch;
    memset(x, 0, sizeof(*x));
    region_bufs(det, &x->b);
    refine_cfg_of(det, &x->rc);
    if (model != NULL) {
        det->in_w = model->input_w;
        det->in_h = model->input_h;
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
        return VD_ERR_ARG;   // unreachable after resolve_cfg; kept as a guard
    }
    if (c.temporal) {
        VD_TRY(vd_temporal_init(&det->temporal, &c.temporal_cfg, det->tracks, c.max_tracks));
    }
    return VD_OK;
}

const vd_detector_stats_t *vd_detector_last_stats(const vd_detector_t *det)
{
    return (det == NULL) ? NULL : &det->stats;
}

static uint32_t clock_now(const vd_detector_t *det)
{
    return (det->cfg.clock_us != NULL) ? det->cfg.clock_us(det->cfg.clock_user) : 0u;
}

static void clock_add(vd_detector_t *det, int stage, uint32_t *t0)
{
    if (det->cfg.clock_us == NULL) {
        return;
    }
    uint32_t t1 = det->cfg.clock_us(det->cfg.clock_user);
    det->stats.time_us[stage] += t1 - *t0;   // unsigned: wrap-around safe
    *t0 = t1;
}


// Builds the region plane in the overlay's crop buffer when needed (16-bit
// frames, or regions above max_region_*); 8-bit regions that fit are read
// from the frame directly so the median sees the pixels around the ROI.
DET_NOINLINE static vd_status_t make_plane(vd_detector_t *det, const vd_frame_t *f, const vd_rect_t *region,
                              uint8_t *crop, region_plane_t *p)
{
    uint32_t rw = (uint32_t)region->w;
    uint32_t rh = (uint32_t)region->h;
    uint32_t mw = det->cfg.max_region_w;
    uint32_t mh = det->cfg.max_region_h;
    p->region = *region;
    p->kx = (rw + mw - 1u) / mw;
    p->ky = (rh + mh - 1u) / mh;
    if (f->format == VD_PIX_U8 && p->kx == 1u && p->ky == 1u) {
        VD_TRY(vd_frame_view_u8(f, &p->view));
        p->roi = *region;
        return VD_OK;
    }
    const uint32_t cw = rw / p->kx;
    const uint32_t ch = rh / p->ky;
    vd_image_u8_t out = {crop, cw, ch, cw};
    if (f->format == VD_PIX_U8) {
        vd_view_u8_t v;
        VD_TRY(vd_frame_view_u8(f, &v));
        VD_TRY(vd_resample_box_u8(&v, region, p->kx, p->ky, &out));
    } else {
        vd_view_u16_t v;
        VD_TRY(vd_frame_view_u16(f, &v));
        VD_TRY(vd_resample_box_u16(&v, region, p->kx, p->ky, &det->grey, &out));
    }
    p->view = vd_image_u8_view(&out);
    p->roi.x = 0;
    p->roi.y = 0;
    p->roi.w = (int32_t)cw;
    p->roi.h = (int32_t)ch;
    return VD_OK;
}

// Refines x->region into x->b.rmask; sets x->p (its plane), x->m and x->rs.
static vd_status_t refine_region(vd_detector_t *det, const vd_frame_t *f, cand_ctx_t *x)
{
    VD_TRY(make_plane(det, f, &x->region, x->b.crop, &x->p));
    x->m.data = x->b.rmask;
    x->m.width = (uint32_t)x->p.roi.w;
    x->m.height = (uint32_t)x->p.roi.h;
    x->m.stride = (size_t)x->p.roi.w;
    return vd_refine_region(&x->p.view, &x->p.roi, &x->rc, x->b.refine_ws, det->refine_ws_bytes, &x->m, &x->rs);
}

// Complexity (temporal.h) of a refined region: edge pixels / region pixels.
// A mask that is empty or covers the whole region has no object outline (a
// uniform region makes Otsu keep everything and its only "edges" are the
// region border), so it counts as 0, which never resembles a vehicle.
static uint16_t region_complexity(const vd_refine_stats_t *rs, const region_plane_t *p)
{
    uint32_t area = (uint32_t)p->roi.w * (uint32_t)p->roi.h;
    if (rs->fg_pixels == 0u || rs->fg_pixels >= area) {
        return 0u;
    }
    return vd_temporal_complexity_q15(rs->edge_points, area);
}

// Temporal recovery probe: the complexity of the expanded box, refined as a candidate.
static vd_status_t detector_probe(void *user, const vd_rect_t *box, uint16_t *complexity_q15)
{
    vd_detector_t *det = (vd_detector_t *)user;
    cand_ctx_t *x = (cand_ctx_t *)det->scratch;
    const vd_frame_t *f = det->frame;
    VD_TRY(vd_rect_expand(box, det->cfg.expand_w_q8, det->cfg.expand_h_q8, f->width, f->height, &x->region));
    VD_TRY(refine_region(det, f, x));
    *complexity_q15 = region_complexity(&x->rs, &x->p);
    return VD_OK;
}

// The 8-bit hot threshold: constant, or max(floor, p-th percentile) of the
// frame's histogram (adaptive mode).
static uint32_t threshold_u8(vd_detector_t *det, const vd_view_u8_t *v)
{
    if (det->cfg.thr_mode != VD_DETECTOR_THR_ADAPTIVE) {
        return det->cfg.hot_thr_u8;
    }
    // The view was checked by the caller, permille by resolve_cfg: neither call can fail.
    uint8_t t = 0u;
    vd_status_t st = vd_histogram_u8(v, NULL, det->hist);
    VD_ASSERT(st == VD_OK);
    st = vd_threshold_percentile_u8(det->hist, det->cfg.adaptive_permille, det->cfg.adaptive_floor_u8, &t);
    VD_ASSERT(st == VD_OK);
    (void)st;
    return t;
}

// Hot-spot components straight from the frame (no mask: the labeller
// compares with the threshold as it run-length encodes), with the run budget
// of the overlay. Sets the threshold, hot pixel, run and overflow stats.
// Returns VD_OK or VD_ERR_CAPACITY (components or runs; stats say which).
DET_NOINLINE static vd_status_t hot_components(vd_detector_t *det, const vd_frame_t *f, size_t *n, uint32_t *t0)
{
    vd_detector_stats_t *s = &det->stats;
    vd_cc_stats_t *cs = &((cand_ctx_t *)det->scratch)->cs;
    memset(cs, 0, sizeof(*cs));
    vd_status_t st;
    *n = 0u;
    if (f->format == VD_PIX_U8) {
        vd_view_u8_t v;
        VD_TRY(vd_frame_view_u8(f, &v));
        const uint32_t thr = threshold_u8(det, &v);
        s->hot_thr_u8 = thr;
        clock_add(det, VD_DET_STAGE_THRESHOLD, t0);
        st = vd_components_label_thr_u8(&v, NULL, (uint8_t)thr, det->overlay, det->cc_ws_bytes, det->comps,
                                        det->cfg.max_components, n, cs);
    } else {
        vd_view_u16_t v16;
        VD_TRY(vd_frame_view_u16(f, &v16));
        s->hot_thr_raw = det->raw_thr;
        clock_add(det, VD_DET_STAGE_THRESHOLD, t0);
        if (det->raw_never_hot) {
            return VD_OK;
        }
        st = vd_components_label_thr_u16(&v16, NULL, det->raw_thr, det->overlay, det->cc_ws_bytes, det->comps,
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

// Index of the contour with the largest box area (then length; first wins).
static size_t largest_contour(const vd_contour_t *c, size_t n)
{
    size_t best = 0u;
    for (size_t i = 1; i < n; i++) {
        uint64_t ai = (uint64_t)c[i].box.w * (uint64_t)c[i].box.h;
        uint64_t ab = (uint64_t)c[best].box.w * (uint64_t)c[best].box.h;
        if (ai > ab || (ai == ab && c[i].length > c[best].length)) {
            best = i;
        }
    }
    return best;
}

// Hot-spot candidate: expands the component, refines the region and traces
// its contour; *ok = false when the region has no contour. Fills d's box,
// candidate region, contour length, complexity and flags (not the score).
DET_NOINLINE static vd_status_t refine_hot(vd_detector_t *det, const vd_frame_t *f, const vd_component_t *comp,
                                           vd_detection_t *d, bool *ok, uint32_t *t0)
{
    cand_ctx_t *x = (cand_ctx_t *)det->scratch;
    *ok = false;
    memset(d, 0, sizeof(*d));
    if (vd_rect_expand(&comp->box, det->cfg.expand_w_q8, det->cfg.expand_h_q8, f->width, f->height, &x->region) !=
        VD_OK) {
        return VD_OK;   // cannot happen for a component inside the frame
    }
    VD_TRY(refine_region(det, f, x));
    const region_plane_t *p = &x->p;
    if (p->kx > 1u || p->ky > 1u) {
        d->flags |= VD_DET_FLAG_DECIMATED;
        det->stats.decimated++;
    }
    clock_add(det, VD_DET_STAGE_REFINE, t0);

    x->mv = vd_image_u8_view(&x->m);
    size_t nc = 0u;
    size_t np = 0u;
    vd_status_t st = vd_contours_find_external(&x->mv, x->b.contour_ws, det->contour_ws_bytes, x->b.points, NULL,
                                               det->points_cap, x->b.contours, det->contours_cap, &nc, &np);
    if (st == VD_ERR_CAPACITY) {
        d->flags |= VD_DET_FLAG_CONTOUR_TRUNC;
        det->stats.overflow_contours++;
    } else if (st != VD_OK) {
        return st;
    }
    clock_add(det, VD_DET_STAGE_CONTOUR, t0);
    if (nc == 0u) {
        return VD_OK;
    }
    det->stats.refined++;
    x->best = x->b.contours[largest_contour(x->b.contours, nc)];
    const vd_contour_t *c = &x->best;
    uint32_t kmax = p->kx > p->ky ? p->kx : p->ky;
    d->box.x = x->region.x + c->box.x * (int32_t)p->kx;
    d->box.y = x->region.y + c->box.y * (int32_t)p->ky;
    d->box.w = c->box.w * (int32_t)p->kx;
    d->box.h = c->box.h * (int32_t)p->ky;
    d->candidate = x->region;
    d->contour_length = c->length * kmax;
    d->complexity_q15 = region_complexity(&x->rs, p);
    d->source = (uint8_t)VD_SOURCE_HOTSPOT;
    *ok = true;
    return VD_OK;
}

// Samples and scores one merged candidate (any source); *keep = score >=
// score_thr (always true without a model: score 255, flag UNVERIFIED).
// The plane is rebuilt from d->candidate: hot spots are sampled under their
// contour box inside the refined region, windows and contrast candidates
// (candidate == box) as the whole box.
DET_NOINLINE static vd_status_t verify_candidate(vd_detector_t *det, const vd_frame_t *f, vd_detection_t *d,
                                                 bool *keep, uint32_t *t0)
{
    cand_ctx_t *x = (cand_ctx_t *)det->scratch;
    *keep = false;
    if (det->model == NULL) {
        d->score_q8 = 255u;
        d->flags |= VD_DET_FLAG_UNVERIFIED;
        det->stats.verified++;
        *keep = true;
        return VD_OK;
    }
    const region_plane_t *p = &x->p;
    VD_TRY(make_plane(det, f, &d->candidate, x->b.crop, &x->p));
    if (d->source != VD_SOURCE_HOTSPOT && (p->kx > 1u || p->ky > 1u)) {
        d->flags |= VD_DET_FLAG_DECIMATED;
    }
    // The box in plane coordinates (exact: a hot-spot box is region + k * contour box).
    x->vb.x = p->roi.x + (d->box.x - d->candidate.x) / (int32_t)p->kx;
    x->vb.y = p->roi.y + (d->box.y - d->candidate.y) / (int32_t)p->ky;
    x->vb.w = d->box.w / (int32_t)p->kx;
    x->vb.h = d->box.h / (int32_t)p->ky;
    x->vb.w = (x->vb.w < 1) ? 1 : x->vb.w;
    x->vb.h = (x->vb.h < 1) ? 1 : x->vb.h;
    if (det->model->input_mode == VD_DBN_INPUT_GREY) {
        VD_TRY(vd_resample_u8(&p->view, &x->vb, det->sample, det->in_w, det->in_h));
    } else {
        // As samples.py: refine the box itself, then resample the whole mask.
        x->m.data = x->b.rmask;
        x->m.width = (uint32_t)x->vb.w;
        x->m.height = (uint32_t)x->vb.h;
        x->m.stride = (size_t)x->vb.w;
        VD_TRY(vd_refine_region(&p->view, &x->vb, &x->rc, x->b.refine_ws, det->refine_ws_bytes, &x->m, NULL));
        x->mv = vd_image_u8_view(&x->m);
        VD_TRY(vd_resample_u8(&x->mv, NULL, det->sample, det->in_w, det->in_h));
    }
    clock_add(det, VD_DET_STAGE_SAMPLE, t0);
    uint8_t score = 0u;
    VD_TRY(vd_dbn_classify(det->model, det->sample, det->dbn_ws, det->dbn_ws_bytes, &score));
    clock_add(det, VD_DET_STAGE_DBN, t0);
    d->score_q8 = score;
    if (score < det->cfg.score_thr_q8) {
        return VD_OK;
    }
    det->stats.verified++;
    *keep = true;
    return VD_OK;
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
// Returns VD_OK or VD_ERR_CAPACITY (components or the candidate budget).
DET_NOINLINE static vd_status_t contrast_source(vd_detector_t *det, const vd_frame_t *f, size_t *n, uint8_t thr8)
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
        if (merge_box(det, n, &det->comps[i].box, (uint8_t)VD_SOURCE_CONTRAST, thr8)) {
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
    if (*m->n < det->cfg.max_candidates && merge_box(det, m->n, b, (uint8_t)VD_SOURCE_WINDOW, m->thr8)) {
        det->stats.cand_window++;
    }
}

// Window source: pre-filter by cell-mean deviation, rank by it, and merge the
// best windows into the room left of max_candidates (windows.h; windows
// beyond it are dropped by design: not a capacity error).
DET_NOINLINE static vd_status_t window_source(vd_detector_t *det, const vd_frame_t *f, size_t *n, uint8_t thr8)
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

    // Labelling in the overlay, straight from the frame.
    size_t n = 0u;
    vd_status_t st = VD_OK;
    if ((det->cfg.sources & VD_DETECTOR_SRC_HOTSPOT) != 0u) {
        st = hot_components(det, frame, &n, &t0);
    }
    if (st == VD_ERR_CAPACITY) {
        result = VD_ERR_CAPACITY;
    } else if (st != VD_OK) {
        return st;
    }
    s->components = (uint32_t)n;
    size_t kept = 0u;
    VD_TRY(vd_components_filter(det->comps, n, &det->cfg.rules, &kept));
    s->kept = (uint32_t)kept;
    if (kept > det->cfg.max_candidates) {
        s->overflow_candidates = (uint32_t)(kept - det->cfg.max_candidates);
        kept = det->cfg.max_candidates;
        result = VD_ERR_CAPACITY;
    }
    clock_add(det, VD_DET_STAGE_COMPONENTS, &t0);

    // Hot spots: refined one by one (the labelling scratch is dead from here:
    // the overlay holds region buffers), their contour boxes start the merged list.
    uint8_t thr8 = (uint8_t)s->hot_thr_u8;
    size_t nc = 0u;
    for (size_t i = 0; i < kept; i++) {
        bool ok = false;
        VD_TRY(refine_hot(det, frame, &det->comps[i], &det->cand[nc], &ok, &t0));
        if (ok) {
            det->cand[nc].hot_thr = thr8;
            nc++;
        }
    }
    s->cand_hotspot = (uint32_t)nc;
    if ((det->cfg.sources & VD_DETECTOR_SRC_CONTRAST) != 0u) {
        st = contrast_source(det, frame, &nc, thr8);
        if (st == VD_ERR_CAPACITY) {
            result = VD_ERR_CAPACITY;
        } else if (st != VD_OK) {
            return st;
        }
        clock_add(det, VD_DET_STAGE_CONTRAST, &t0);
    }
    if ((det->cfg.sources & VD_DETECTOR_SRC_WINDOW) != 0u) {
        VD_TRY(window_source(det, frame, &nc, thr8));   // the overlay holds the integrals until here
        clock_add(det, VD_DET_STAGE_WINDOWS, &t0);
    }
    // The observer sees every merged candidate before verification (nc <= max_candidates).
    if (det->cfg.on_candidate != NULL) {
        for (size_t i = 0; i < nc; i++) {
            det->cfg.on_candidate(det->cfg.candidate_user, &det->cand[i]);
        }
    }
    // Verification of the merged list, compacted in place.
    size_t nv = 0u;
    for (size_t i = 0; i < nc; i++) {
        bool keep = false;
        VD_TRY(verify_candidate(det, frame, &det->cand[i], &keep, &t0));
        if (keep) {
            if (nv != i) {
                det->cand[nv] = det->cand[i];
            }
            nv++;
        }
    }
    size_t nk = 0u;
    vd_suppress_stats_t ss;
    VD_TRY(vd_suppress_nms(det->cand, nv, det->cfg.nms_iou_q15, det->cfg.max_detections, &nk, &ss));
    s->suppressed = ss.suppressed;
    s->overflow_detections += ss.overflow;
    clock_add(det, VD_DET_STAGE_NMS, &t0);
    if (s->overflow_detections != 0u) {
        result = VD_ERR_CAPACITY;
    }

    size_t total = nk;
    if (det->cfg.temporal) {
        for (size_t i = 0; i < nk; i++) {
            memset(&det->obs[i], 0, sizeof(det->obs[i]));
            det->obs[i].box = det->cand[i].box;
            det->obs[i].complexity_q15 = det->cand[i].complexity_q15;
        }
        det->frame = frame;
        size_t nobs = 0u;
        st = vd_temporal_update(&det->temporal, det->obs, nk, nk + det->cfg.max_tracks, &nobs, detector_probe, det);
        det->frame = NULL;
        if (st == VD_ERR_CAPACITY) {
            result = VD_ERR_CAPACITY;
        } else if (st != VD_OK) {
            return st;
        }
        s->overflow_tracks = det->temporal.stats.overflow;
        for (size_t i = 0; i < nk; i++) {
            det->cand[i].track_id = det->obs[i].track_id;
            det->cand[i].state = det->obs[i].state;
        }
        total = nobs;
        s->recovered = (uint32_t)(nobs - nk);
        clock_add(det, VD_DET_STAGE_TEMPORAL, &t0);
    }

    size_t w = total < cap ? total : cap;
    for (size_t i = 0; i < w; i++) {
        if (i < nk) {
            out[i] = det->cand[i];
            continue;
        }
        const vd_temporal_obs_t *o = &det->obs[i];
        vd_detection_t *d = &out[i];
        memset(d, 0, sizeof(*d));
        d->box = o->box;
        (void)vd_rect_expand(&o->box, det->cfg.expand_w_q8, det->cfg.expand_h_q8, frame->width, frame->height,
                             &d->candidate);
        d->track_id = o->track_id;
        d->complexity_q15 = o->complexity_q15;
        d->source = VD_SOURCE_HOTSPOT;
        d->state = VD_TRACK_RECOVERED;
        d->flags = VD_DET_FLAG_RECOVERED;
        d->hot_thr = thr8;
    }
    if (w < total) {
        s->overflow_detections += (uint32_t)(total - w);
        result = VD_ERR_CAPACITY;
    }
    s->detections = (uint32_t)w;
    *count = w;
    if (det->cfg.clock_us != NULL) {
        s->time_us[VD_DET_STAGE_TOTAL] = clock_now(det) - t_start;
    }
    return result;
}
