// SPDX-License-Identifier: MIT
// Private: the detector's per-candidate state and the functions its files share (detector.c runs the frame,
// detector_init.c configures and carves the workspace, detector_sources.c fills the candidate list,
// detector_region.c refines and verifies candidates, detector_cnn.c runs the network source).
#ifndef VD_DETECTOR_INTERNAL_H
#define VD_DETECTOR_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "vd/contour.h"
#include "vd/detector.h"

// Keeps a helper's locals out of its caller's frame while the caller makes
// the deep calls (refine -> median): the stack budget of vd_detector_run.
#if defined(__GNUC__)
#define VD_DET_NOINLINE __attribute__((noinline))
#else
#define VD_DET_NOINLINE
#endif

// The networks' plan flags (workspace, plan ahead, run): streamed rows, the head a ring decoded as it is
// made (vd/cnn.h). The plan made ahead is kept by the runs only with the same flags.
#define VD_DETECTOR_CNN_FLAGS (VD_CNN_STREAM | VD_CNN_HEAD_RING)

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

// Per-candidate state (det->scratch). It lives in the workspace, not on the
// stack, so that the deepest call chain (run -> vd_refine_region -> median)
// keeps within the stack budget of vd_detector_run (docs/embedded.md).
typedef struct cand_ctx {
    // Ordered by alignment (pointer-aligned members first), so the struct has
    // no padding: its size is part of the workspace figure.
    region_bufs_t b;             // fixed once init has carved the overlay
    vd_windows_prefilter_t pf;   // window source: the current frame's integrals (in the overlay)
    region_plane_t p;
    vd_image_u8_t m;             // refine output view on b.rmask
    vd_view_u8_t mv;
    vd_rect_t region;            // expanded candidate (image coordinates)
    vd_refine_stats_t rs;
    vd_contour_t best;
    vd_rect_t vb;                // contour box in plane coordinates
    vd_components_stats_t cs;
    vd_windows_cfg_t wc;         // window source: settings for the current frame
    vd_refine_cfg_t rc;          // fixed in init
} cand_ctx_t;

// Adds the time since *t0 to a stage (cfg.clock_us; nothing without it).
static inline void vd__detector_clock_add(vd_detector_t *det, int stage, uint32_t *t0)
{
    if (det->cfg.clock_us == NULL) {
        return;
    }
    uint32_t t1 = det->cfg.clock_us(det->cfg.clock_user);
    det->stats.time_us[stage] += t1 - *t0;   // unsigned: wrap-around safe
    *t0 = t1;
}

// detector_sources.c. Each appends to det->cand[0..*n) within max_candidates.
// Hot-spot components of the frame into det->comps (*n of them; stats: threshold,
// hot pixels, runs, overflows). Returns VD_OK or VD_ERR_CAPACITY (components or runs).
vd_status_t vd__detector_hot_components(vd_detector_t *det, const vd_frame_t *f, size_t *n, uint32_t *t0);
// Contrast components merged into the list (8-bit frames). VD_OK or VD_ERR_CAPACITY.
vd_status_t vd__detector_contrast_source(vd_detector_t *det, const vd_frame_t *f, size_t *n, uint8_t thr8);
// The best pre-filtered windows merged into the room left (never a capacity error).
vd_status_t vd__detector_window_source(vd_detector_t *det, const vd_frame_t *f, size_t *n, uint8_t thr8);

// detector_cnn.c. The network's boxes appended to det->cand[*n..) (the list is
// empty when it runs: CNN boxes come first; with cfg.cnn_flip the two passes'
// boxes fused, those from the normal pass first). Uses the overlay (network
// workspace, decoded boxes), so it must run before the hot-spot labelling.
// Returns VD_OK, VD_ERR_CAPACITY (boxes beyond max_candidates, counted in
// stats.overflow_candidates) or a vd_cnn_* / resample status.
vd_status_t vd__detector_cnn_source(vd_detector_t *det, const vd_frame_t *f, size_t *n);
// Network input size for a frame of w x h: floor(w / d), floor(h / d) rounded
// up to the model's alignment (0 x 0 when either is 0); d = vd__detector_cnn_div.
void vd__detector_cnn_input_size(const vd_cnn_model_t *m, uint32_t d, uint32_t w, uint32_t h, uint32_t *nw,
                                 uint32_t *nh);
// Frame pixels per network input pixel and axis (cfg.cnn_res): 2 (half resolution), 1 (full), 4 (quarter).
uint32_t vd__detector_cnn_div(const vd_detector_cfg_t *c);

// detector_region.c.
// Hot-spot candidate: expands the component, refines the region and traces
// its contour; *ok = false when the region has no contour. Fills d's box,
// candidate region, contour length, complexity and flags (not the score).
vd_status_t vd__detector_refine_hot(vd_detector_t *det, const vd_frame_t *f, const vd_component_t *comp,
                              vd_detection_t *d, bool *ok, uint32_t *t0);
// Samples and scores one merged candidate (any source); *keep = score >= score_thr
// (always true without a model: score 255, flag UNVERIFIED; and for CNN boxes
// without cnn_rescore, which keep the network's score).
vd_status_t vd__detector_verify(vd_detector_t *det, const vd_frame_t *f, vd_detection_t *d, bool *keep, uint32_t *t0);
// Temporal recovery probe (vd_temporal_probe_fn, user = the detector): the
// complexity of `box` expanded and refined as a candidate, in det->frame.
vd_status_t vd__detector_probe(void *user, const vd_rect_t *box, uint16_t *complexity_q15);

#endif
