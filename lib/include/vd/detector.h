// SPDX-License-Identifier: MIT
// The FIR vehicle detector of paper 001: hot-spot candidates, contour refinement, DBN verification, overlap suppression;
// and the learned candidate source: an int8 CNN run once per frame (cnn.h).
//
// Lifetimes: the caller owns vd_detector_t, the workspace and the models; the
// workspace and the models (DBN and cfg.cnn_model, and their blobs) must
// outlive the detector. A frame only needs to live during vd_detector_run().
// Two detectors never share state (no globals); one detector must not run in
// two threads at once (two may share the read-only models).
#ifndef VD_DETECTOR_H
#define VD_DETECTOR_H

#include <stddef.h>
#include <stdint.h>
#include <stdbool.h>

#include "vd/image.h"
#include "vd/detection.h"
#include "vd/status.h"
#include "vd/threshold.h"
#include "vd/components.h"
#include "vd/refine.h"
#include "vd/boost.h"
#include "vd/dbn.h"
#include "vd/cnn.h"
#include "vd/temporal.h"
#include "vd/contrast.h"
#include "vd/windows.h"

#ifdef __cplusplus
extern "C" {
#endif

// Hot-spot threshold modes (cfg.thr_mode).
#define VD_DETECTOR_THR_CONSTANT 0u  // paper: constant threshold (hot_thr_u8 / hot_thr_ck)
#define VD_DETECTOR_THR_ADAPTIVE 1u  // 8-bit frames: max(adaptive_floor_u8, frame percentile); U16 frames stay constant

// Candidate sources a detector runs (cfg.sources, bit set).
#define VD_DETECTOR_SRC_HOTSPOT 0x01u
#define VD_DETECTOR_SRC_CONTRAST 0x02u
#define VD_DETECTOR_SRC_WINDOW 0x04u
#define VD_DETECTOR_SRC_CNN 0x08u        // the int8 network (cfg.cnn_model)
// The three sources of the paper pipeline (hot spots, contrast, windows). It
// stays 0x07 without the CNN, so "all" keeps its meaning for existing users;
// add VD_DETECTOR_SRC_CNN explicitly.
#define VD_DETECTOR_SRC_ALL 0x07u

// Stages timed through cfg.clock_us (index into vd_detector_stats_t.time_us).
enum {
    VD_DETECTOR_STAGE_THRESHOLD = 0,  // histogram/percentile + hot mask
    VD_DETECTOR_STAGE_COMPONENTS,     // labelling + rules + expansion
    VD_DETECTOR_STAGE_REFINE,         // region plane (crop/map/decimate) + vd_refine_region
    VD_DETECTOR_STAGE_CONTOUR,        // vd_contour_find_external
    VD_DETECTOR_STAGE_SAMPLE,         // 32x32 sample (and the shape-mode refine)
    VD_DETECTOR_STAGE_DBN,            // vd_dbn_classify
    VD_DETECTOR_STAGE_NMS,            // sort + overlap suppression
    VD_DETECTOR_STAGE_TEMPORAL,       // vd_temporal_update incl. recovery probes
    VD_DETECTOR_STAGE_CONTRAST,       // contrast source: map, threshold, labelling, merge
    VD_DETECTOR_STAGE_WINDOWS,        // window source: cell integral image, pre-filter, ranking, merge
    VD_DETECTOR_STAGE_CNN,            // CNN source: the input plane (cfg.cnn_res), vd_cnn_run, vd_cnn_decode, merge
    VD_DETECTOR_STAGE_TOTAL,          // (indices before CNN keep their values; TOTAL and COUNT moved up by one)
    VD_DETECTOR_STAGE_COUNT
};

// cfg.cnn_res: frame pixels per network input pixel and axis 2, 1 and 4.
#define VD_DETECTOR_CNN_RES_HALF 0u
#define VD_DETECTOR_CNN_RES_FULL 1u
#define VD_DETECTOR_CNN_RES_QUARTER 2u

// Settings, grouped by concern. A zeroed struct (or vd_detector_cfg_default())
// gives the paper's values; each field gives its zero meaning and range, and
// docs/architecture.md "Detector settings" explains the CNN, verifier and
// merge rules. Out-of-range values make vd_detector_workspace_size() /
// vd_detector_init() return VD_ERR_ARG. Field order may change between 0.x
// minor versions (docs/changelog.md): set fields by name after
// vd_detector_cfg_default() or a zeroed struct.
typedef struct vd_detector_cfg {
    // Frame size (sizes the workspace).
    uint32_t max_width;          // largest frame width, 1..VD_MAX_DIM; 0 = 640
    uint32_t max_height;         // largest frame height, 1..VD_MAX_DIM; 0 = 512

    // Candidate sources and their merge.
    uint8_t sources;             // VD_DETECTOR_SRC_* bit set, 0..15; 0 = VD_DETECTOR_SRC_HOTSPOT (paper)
    uint16_t dedup_iou_q15;      // merge: drop a candidate with IoU > this to a listed box, 1..32768; 0 = 22938 (0.7)
    // Hot spots: threshold (8-bit and 16-bit frames), rules, expansion, refinement.
    uint8_t thr_mode;            // VD_DETECTOR_THR_CONSTANT (0, paper) or VD_DETECTOR_THR_ADAPTIVE
    uint8_t hot_thr_u8;          // 8-bit constant threshold, hot = pixel >= thr; 0 = 150 (paper, ~30 C); also a
                                 //   16-bit frame's in its own grey window (grey_mode, below)
    uint8_t adaptive_floor_u8;   // adaptive mode: lowest threshold; 0 = 96
    uint16_t adaptive_permille;  // adaptive mode: percentile p in 1/1000, 1..1000; 0 = 990 (p99)
    int32_t hot_thr_ck;          // 16-bit frames in the fixed window: threshold in centi-kelvin, > 0; 0 = 30315 (30.00 C)
    vd_calib_t calib;            // raw -> centi-kelvin, gain_q16 > 0; gain_q16 0 = {65536, offset_ck} (TLinear)
    int32_t grey_lo_ck;          // 16-bit frames: temperature mapped to grey 0; 0 = hot_thr_ck - 3000
    int32_t grey_hi_ck;          // temperature mapped to grey 255, > grey_lo_ck; 0 = hot_thr_ck + 2100 (grey 150)
    uint8_t grey_mode;           // 16-bit frames: VD_DETECTOR_GREY_FIXED (0: grey_lo_ck..grey_hi_ck, a radiometric
                                 //   camera) or VD_DETECTOR_GREY_PERCENTILE (each frame's own window, for raw counts)
    uint16_t grey_tail_permille; // percentile mode: samples at grey 0 and at 255, each end, 1..499; 0 = 1 (0.1 %)
    vd_components_rules_t rules; // all four fields 0 = paper (aspect h/w 0.3..1.5, area >= 120)
    uint16_t expand_w_q8;        // candidate expansion, Q8, 256..2048; 0 = 384 (1.5x, paper)
    uint16_t expand_h_q8;        // 0 = 512 (2x, paper)
    uint8_t median_ksize;        // refine median: 0 = 3 (paper), 1 = none, 3 or 5
    uint8_t edge_step;           // refine: every n-th edge point, 1..255; 0 = 5 (paper)
    uint8_t window;              // refine: local window, odd 3..VD_REFINE_MAX_WINDOW; 0 = 5 (paper)
    // Contrast and window sources.
    vd_contrast_cfg_t contrast;  // contrast source (8-bit frames only); zero = contrast.h defaults
    uint8_t win_min_std_u8;      // window pre-filter: std of the 4x4-cell means >= this, 1..255; 0 = 4
    vd_windows_cfg_t windows;    // window source (windows.h); frame_w/frame_h and max_windows ignored

    // CNN source (VD_DETECTOR_SRC_CNN).
    const vd_cnn_model_t *cnn_model;   // vd_cnn_load'ed; required with the source, must outlive the detector
    const vd_cnn_model_t *cnn_model2;  // second network fused with the first (ensemble); NULL = none
    uint16_t cnn_score_thr_q15;  // drop boxes with score_q15 < this, 1..32768; 0 = the deciding header's threshold
    uint8_t cnn_rescore;         // 0: CNN boxes skip the verifier; 1: verified as windows (needs a DBN model)
    uint8_t cnn_flip;            // 0: one pass; 1: fused horizontal-flip pass (twice the network's time)
    uint8_t cnn_res;             // the networks' input: VD_DETECTOR_CNN_RES_HALF (0, the 2x2 box average of the
                                 //   frame: the scale the shipped networks trained at), _FULL (1: the frame itself,
                                 //   for a camera whose vehicles are about half the training data's size; 4x the
                                 //   multiply-adds and a network workspace for twice the width) or _QUARTER (2: the
                                 //   4x4 box average, for vehicles about twice that size; a quarter of the
                                 //   multiply-adds); docs/results/cameras.md
    uint8_t cnn_invert;          // 0: the networks read the plane as it is (white-hot: warm is bright, as they
                                 //   trained); 1: each plane value v as 255 - v, for a black-hot camera (whose
                                 //   frames as they are cost the shipped pair most of its AP: docs/results/cameras.md)

    // Verifier.
    uint8_t verifier;            // VD_DETECTOR_VERIFIER_*, 0..1; 0 = DBN
    uint8_t score_thr_q8;        // DBN: kept when score_q8 >= this, 1..255; 0 = 128 (p >= 0.5)
    const vd_boost_model_t *boost_model;  // vd_boost_load'ed; required with VD_DETECTOR_VERIFIER_BOOST
    int32_t boost_thr_offset;    // boosted verifier: added to the model's threshold, -2^24..2^24; 0 = none

    // Suppression and temporal analysis.
    uint16_t nms_iou_q15;        // suppress a box whose IoU with a better one is > this, 1..32768; 0 = 16384 (0.5)
    bool temporal;               // run temporal analysis (temporal.h) inside vd_detector_run
    uint16_t max_tracks;         // temporal track table, 1..1024; 0 = 32
    vd_temporal_cfg_t temporal_cfg;  // zero = temporal.h defaults; VD_TEMPORAL_SCORES (track-aware scores, the demo's
                                     //   default) is dropped without a DBN model and without the CNN source
                                     //   (no scores to fuse); unverified detections keep their score

    // Budgets (overflows: stats.overflow_*, VD_ERR_CAPACITY).
    uint32_t max_runs;           // labelling runs (8 B each), >= 1; 0 = 24576 (2.4x the most measured)
    uint16_t max_components;     // components labelled per frame, 1..65535; 0 = 256
    uint16_t max_candidates;     // candidates verified per frame, all sources together, 1..4096; 0 = 64
    uint16_t max_detections;     // detections kept after NMS, 1..max_candidates; 0 = 32
    uint16_t max_region_w;       // refine region (7 B/px), 1..max_width; 0 = min(176, max_width); larger: decimated
    uint16_t max_region_h;       // 1..max_height; 0 = min(176, max_height)

    // Observers (NULL = off).
    uint32_t (*clock_us)(void *user);  // free-running microsecond clock for stats.time_us (wraps)
    void *clock_user;
    void (*on_candidate)(void *user, const vd_detection_t *cand);  // each merged candidate before verification
    void *candidate_user;
} vd_detector_cfg_t;

// cfg.cnn_flip / cfg.cnn_model2: boxes of two passes are fused when their
// IoU (Q15, rounded down as vd_rect_iou_q15) is at least this (0.3).
#define VD_DETECTOR_CNN_FLIP_IOU_Q15 9830u

// Values of vd_detector_cfg_t.grey_mode. In percentile mode a 16-bit frame's
// grey window runs from the raw value at grey_tail_permille to the one at
// 1000 - grey_tail_permille (vd_histogram_percentiles_u16), through calib, at
// least VD_DETECTOR_GREY_MIN_SPAN_CK wide (widened about its middle: a flat
// frame stays mid-grey instead of amplifying noise). Such a frame is not
// radiometric, so hot_thr_ck means nothing there: the hot-spot source takes
// the 8-bit threshold (hot_thr_u8, or in adaptive mode the percentile of the
// frame's grey levels) and labels the raw values at or above the smallest raw
// at that grey level (vd_calib_grey_raw_at): the hot pixels of the frame's
// 8-bit view, exactly. stats.grey_lo_raw / grey_hi_raw report the window,
// stats.hot_thr_u8 / hot_thr_raw the thresholds (it
// thresholded raw counts at hot_thr_ck's raw value, until 2026-11-30).
#define VD_DETECTOR_GREY_FIXED 0u
#define VD_DETECTOR_GREY_PERCENTILE 1u
#define VD_DETECTOR_GREY_MIN_SPAN_CK 255

// Values of vd_detector_cfg_t.verifier.
#define VD_DETECTOR_VERIFIER_DBN 0u
#define VD_DETECTOR_VERIFIER_BOOST 1u


// Per-frame counts and times of the last vd_detector_run.
typedef struct vd_detector_stats {
    uint32_t hot_thr_u8;         // threshold used on 8-bit frames (16-bit in their own grey window: its grey level)
    uint32_t hot_thr_raw;        // raw threshold used on 16-bit frames; 65536: no raw value is hot
    uint32_t hot_pixels;         // pixels >= threshold (in the labelled rows)
    uint32_t components;         // components labelled (<= max_components)
    uint32_t kept;               // passed the aspect/area rules
    uint32_t refined;            // candidates with a non-empty refined contour
    uint32_t verified;           // score >= score_thr (all refined without a model)
    uint32_t suppressed;         // removed by overlap suppression
    uint32_t detections;         // written to the output (incl. recovered)
    uint32_t recovered;          // appended by temporal recovery
    uint32_t decimated;          // regions refined on a reduced plane
    uint32_t overflow_components;  // bit 0: more hot-spot components than max_components existed; bit 1: same
                                   //   for the contrast source's labelling
    uint32_t overflow_candidates;  // candidates dropped beyond max_candidates
    uint32_t overflow_contours;    // regions whose contour buffers overflowed
    uint32_t overflow_detections;  // detections dropped beyond max_detections or cap
    uint32_t overflow_tracks;      // temporal: untracked detections + dropped recoveries
    uint32_t runs;                 // horizontal runs of hot pixels labelled (<= max_runs)
    uint32_t overflow_runs;        // rows NOT labelled because the run budget ran out (0 = none)
    uint32_t cand_hotspot;         // merged candidates per source (hot spots: with a refined contour)
    uint32_t cand_contrast;
    uint32_t cand_window;
    uint32_t windows;              // windows enumerated (window source)
    uint32_t windows_passed;       // windows passing the pre-filter (before the budget)
    uint32_t deduplicated;         // hot-spot/contrast/window candidates dropped by the merge (IoU > dedup_iou)
    uint32_t cnn_boxes;            // CNN boxes decoded (peaks >= the threshold, at most the header's max_peaks
                                   //   per pass; with cnn_flip nA + nB, both passes at their lower decode
                                   //   threshold, before clipping and fusion)
    uint32_t cand_cnn;             // CNN boxes merged (clipped to the frame, within max_candidates; with
                                   //   cnn_flip the fused boxes >= the score threshold)
    uint32_t grey_lo_raw;          // 16-bit frames, VD_DETECTOR_GREY_PERCENTILE: this frame's raw value at grey 0
    uint32_t grey_hi_raw;          //   and the one at grey 255 (before widening to the least span); else 0
    uint32_t time_us[VD_DETECTOR_STAGE_COUNT];  // per stage, 0 without clock_us
} vd_detector_stats_t;

// Detector object. Complete so the caller can own it; fields are private.
typedef struct vd_detector {
    vd_detector_cfg_t cfg;       // resolved (no zero defaults left)
    const vd_dbn_model_t *model;
    uint16_t raw_thr;            // resolved 16-bit threshold
    bool raw_never_hot;          // threshold above the calibrated range
    vd_calib_grey_t grey;        // 16-bit frames: temperature -> grey map (grey_lo_ck, grey_hi_ck)
    uint32_t in_w, in_h;         // model input (32 x 32)
    // Workspace slices (carved once in init).
    vd_component_t *comps;
    vd_detection_t *cand;        // verified candidates before NMS (max_candidates)
    vd_temporal_obs_t *obs;      // max_detections + max_tracks
    vd_track_t *tracks;
    uint32_t *hist;              // 256 bins
    uint8_t *sample;             // in_w * in_h
    void *dbn_ws;                // DBN workspace, or the boosted verifier's (cfg.verifier)
    size_t dbn_ws_bytes;
    uint8_t *overlay;            // labelling scratch (run budget), reused per candidate for region buffers
    size_t overlay_bytes;
    void *scratch;               // per-candidate state (private: lib/src/detector/detector_internal.h)
    void *contrast_ws;           // contrast source workspace, in the overlay (NULL when the source is off)
    size_t contrast_ws_bytes;
    void *cnn_ws;                // CNN source (in the overlay; NULL when off): streamed vd_cnn_run_rows
                                 //   workspace for the largest input (no input plane: rows on demand),
    size_t cnn_ws_bytes;
    void *cnn_park;              // cfg.cnn_model2: what each network's run record keeps (outside the overlay),
                                 //   put into cnn_ws for its passes, so each network keeps its plan
    vd_cnn_box_t *cnn_boxes;     //   decoded boxes (header max_peaks; twice that with cnn_flip: pass A in
                                 //   [0, max_peaks), pass B in [max_peaks, 2 max_peaks)); cfg.cnn_model2's
                                 //   follow, laid out the same way with its own max_peaks
    size_t cnn_boxes_cap;
    int32_t cnn_thr_i8;          // int8 heatmap threshold of the decode: the logit of T, or of
                                 //   max(1, 2T - 32768) with cnn_flip (of max(1, P T - (P - 1) 32768) with
                                 //   cnn_model2)
    int32_t cnn2_thr_i8;         // cfg.cnn_model2's decode threshold (its own logit of the same score)
    bool cnn2_never;             // no logit of cfg.cnn_model2 reaches its decode score: it adds no box
    uint32_t cnn_thr_score_q15;  // T: cnn_score_thr_q15, or the header threshold's score (cnn_flip drops
                                 //   fused boxes below it)
    bool cnn_never;              // threshold above every score, or frames under 2 x 2: the network never runs
    size_t cc_ws_bytes;
    size_t refine_ws_bytes;
    size_t contour_ws_bytes;
    size_t points_cap;
    size_t contours_cap;
    vd_temporal_t temporal;
    const vd_frame_t *frame;     // during run only (recovery probe)
    vd_detector_stats_t stats;
} vd_detector_t;

// Fills *cfg with the explicit defaults (same result as a zeroed cfg).
VD_API void vd_detector_cfg_default(vd_detector_cfg_t *cfg);

// Resolves cfg in place, as vd_detector_workspace_size and vd_detector_init
// do with their copy: zero fields take the defaults documented above (rules,
// contrast and temporal_cfg through vd_components_rules_resolve,
// vd_contrast_cfg_resolve and vd_temporal_cfg_resolve), then every range is
// checked. `windows` is checked for max_width x max_height but kept as given
// (each frame resolves its own copy). vd_detector_cfg_default() is a zeroed
// cfg resolved.
// Returns VD_OK; VD_ERR_ARG for NULL cfg or a value out of range.
VD_API vd_status_t vd_detector_cfg_resolve(vd_detector_cfg_t *cfg);

// Workspace bytes for `cfg` (NULL = defaults) and the model's input size and
// mode: a pure function of both (model NULL = no DBN scratch). Layout in
// docs/architecture.md "Detector": fixed tables (components, candidates,
// histogram, temporal, DBN) plus one overlay = max(labelling workspace with
// max_runs runs, per-candidate region buffers of 7 bytes per pixel of
// max_region_w x max_region_h). No buffer scales with the frame size except
// the labeller's row buffers (~12 B per column). Defaults at 640 x 512:
// 228 448 bytes (223.1 KiB) on 64-bit hosts, bounded by the region buffers.
// Sources: windows add nothing at 640 x 512 (their two cell integrals,
// 2 x 4 x (W/4+1) x (H/4+1) bytes = 166 152, share the overlay); nor does
// contrast (vd_contrast_workspace_size, row strips: 49 664 bytes at 640 x 512,
// E in the overlay, used between the hot-spot refinement and the windows).
// CNN: the network runs first in a frame, in the overlay, which must then
// also hold D = vd_cnn_workspace_size_ex(nw, nh, VD_CNN_STREAM) (row rings; no
// input plane: its rows are made from the frame on demand) + max_peaks boxes,
// with nw, nh = floor(max_width / 2), floor(max_height / 2) rounded up to the
// model's alignment; the overlay is max(A, B, C, D, E). A
// smaller frame runs the network at its own size inside that plan (the
// planner's size grows with the input: measured on every aligned size of the
// shipped model and 150 random ones; vd_cnn_run would answer VD_ERR_WORKSPACE
// otherwise). cnn_flip adds max_peaks boxes to D (max_peaks * sizeof(vd_cnn_box_t)
// bytes; pass A's boxes must survive pass B's decode), so the total grows by
// that much when D is the overlay's largest part and by less (or nothing)
// otherwise; its second network pass reuses D's network workspace.
// cfg.cnn_model2: D's network workspace is the larger of the two networks'
// (they run in turn) and its boxes are both networks' (max_peaks, twice that
// with cnn_flip, each).
// Returns VD_OK; VD_ERR_ARG for NULL bytes, a cfg value out of range, the CNN
// source without cfg.cnn_model, cnn_rescore without a DBN model, or a network
// input above VD_CNN_MAX_SIDE (or twice it above VD_MAX_DIM); VD_ERR_MODEL
// for a model not filled by vd_dbn_load or a cnn_model not filled by
// vd_cnn_load; VD_ERR_OVERFLOW if the size does not fit size_t.
VD_API vd_status_t vd_detector_workspace_size(const vd_detector_cfg_t *cfg, const vd_dbn_model_t *model, size_t *bytes);

// Initialises `det`: validates and copies cfg (NULL = defaults), resolves the
// 16-bit threshold with the calibration, and carves `ws` once.
//   model  a loaded DBN model, or NULL: every refined candidate passes with score
//          255 and VD_DETECTION_FLAG_UNVERIFIED (useful before a model exists; CNN
//          boxes keep the network's score unless cnn_rescore, which needs it).
//   ws     VD_WORKSPACE_ALIGN-aligned, >= vd_detector_workspace_size(cfg, model).
// Returns VD_OK; VD_ERR_ARG for NULL det or a cfg out of range;
// VD_ERR_MODEL as vd_detector_workspace_size; VD_ERR_WORKSPACE for a NULL,
// misaligned or short workspace.
VD_API vd_status_t vd_detector_init(vd_detector_t *det, const vd_detector_cfg_t *cfg, const vd_dbn_model_t *model,
                             void *ws, size_t bytes);

// Runs the pipeline on one frame (VD_PIX_U8 or VD_PIX_U16, at most
// max_width x max_height): the CNN source, hot spots, contrast and windows
// merged into one candidate list, verification, overlap suppression, temporal
// analysis; docs/architecture.md "Detector" gives each step and its budget.
//   out, cap  caller array; detections best score first, recovered last.
//   count     out: detections written.
// Returns VD_OK; VD_ERR_ARG for NULL det/frame/count, out NULL with cap > 0,
// a frame failing vd_frame_check or larger than max_width x max_height;
// VD_ERR_FORMAT for an unknown pixel format; VD_ERR_STATE if det was not
// initialised; VD_ERR_CAPACITY when any budget overflowed (components,
// candidates, runs, contour buffers, max_detections, cap, track table): everything
// written is valid and the stats say which budget; other statuses of the
// stages are passed on (then *count = 0).
// Stack: no recursion; the worst case per target is generated in docs/embedded.md.
VD_API vd_status_t vd_detector_run(vd_detector_t *det, const vd_frame_t *frame, vd_detection_t *out, size_t cap,
                            size_t *count);

// Counts and times of the last run (NULL for a NULL det).
VD_API const vd_detector_stats_t *vd_detector_last_stats(const vd_detector_t *det);

#ifdef __cplusplus
}
#endif
#endif
