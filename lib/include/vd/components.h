// SPDX-License-Identifier: MIT
// Connected components (8-connectivity) of a binary mask or of a thresholded
// frame, with box, area and centroid; the paper's aspect/area rules (the
// candidate-box expansion, vd_rect_expand, is in rect.h).
#ifndef VD_COMPONENTS_H
#define VD_COMPONENTS_H

#include <stddef.h>
#include <stdint.h>

#include "vd/config.h"
#include "vd/status.h"
#include "vd/image.h"

#ifdef __cplusplus
extern "C" {
#endif

// One connected component.
//   box    bounding box in IMAGE coordinates (not ROI coordinates), w, h >= 1.
//   area   number of foreground pixels (not the box area), >= 1.
//   cx_q8, cy_q8  centroid in image coordinates, Q8 pixels (256 = 1 px):
//          round-half-up(256 * sum(x) / area); the centre of pixel (x, y) is
//          (x, y), as in OpenCV, so a single pixel at (3, 5) gives (768, 1280).
typedef struct vd_component {
    vd_rect_t box;
    uint32_t area;
    uint32_t cx_q8;
    uint32_t cy_q8;
} vd_component_t;

// Workspace for vd_components_label() on a region of at most
// max_width x max_height pixels: a pure, monotone function of the two
// dimensions, so one buffer sized for the largest ROI serves every smaller one.
// It holds three row-span buffers of ceil(w/2) entries (8 bytes), ceil(h/2)+1
// row-pair offsets (4 bytes) and the worst-case number of horizontal runs,
// ceil(w/2) * h (a checkerboard), at 8 bytes each.
// For 640 x 512: 7 680 + 1 032 + 1 310 720 = 1 319 432 bytes (~1.26 MiB);
// for 640 x 480: 1 237 448 bytes. Firmware with less RAM uses the run-budget
// functions below (vd_components_workspace_size_runs).
//   bytes  out: required size in bytes.
// Returns VD_OK; VD_ERR_ARG if bytes is NULL or a dimension is 0 or above
// VD_MAX_DIM; VD_ERR_OVERFLOW if the size does not fit size_t.
VD_API vd_status_t vd_components_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes);

// Labels the 8-connected components of `mask` inside `roi` (pixels outside
// the ROI are ignored, as if the ROI were the whole image).
//   mask   read-only 8-bit view; any nonzero pixel is foreground.
//   roi    region to label, inside the mask; NULL = whole mask.
//   ws, bytes  caller workspace, VD_WORKSPACE_ALIGN-aligned, at least
//          vd_components_workspace_size(roi.w, roi.h) bytes; only used during
//          the call (contents afterwards are unspecified).
//   out    array of `cap` components, written in order of each component's
//          first 2x2 block: rows are taken in pairs (ROI rows 0-1, 2-3, ...;
//          the pairs start at the ROI's top) and, within the first pair that
//          the component touches, by its smallest x there. This is exactly the
//          label order 1..n of cv2.connectedComponentsWithStats(connectivity=8)
//          run on the ROI crop (OpenCV's default block-based algorithms), so
//          out[i] corresponds to stats[i + 1]. Entries past *count are
//          unspecified. May be NULL when cap is 0.
//   cap    capacity of out (any value, 0 allowed).
//   count  out: number of components written.
// Returns VD_OK when every component fit; VD_ERR_CAPACITY when there are more
// than cap (the first cap in the order above are written and *count = cap);
// VD_ERR_ARG for a NULL mask/count, a mask failing vd_view_u8_check, a ROI not
// inside the mask, or out NULL with cap > 0; VD_ERR_WORKSPACE for a NULL,
// misaligned or short workspace. On any error other than VD_ERR_CAPACITY,
// *count = 0 (when count is not NULL).
// Time O(roi.w * roi.h + runs * alpha) with near-constant union-find cost;
// stack O(1).
VD_API vd_status_t vd_components_label(const vd_view_u8_t *mask, const vd_rect_t *roi, void *ws, size_t bytes,
                                vd_component_t *out, size_t cap, size_t *count);

// What a thresholding labeller saw (vd_components_label_thr_u8/_u16).
//   runs    horizontal runs stored (all runs of the labelled rows).
//   pixels  foreground pixels in the labelled rows.
//   rows    ROI rows labelled: roi.h, or fewer (an even number) when the run
//           budget ran out; then the components are those of rows [0, rows)
//           exactly as if the ROI ended there, and a component touching row
//           rows - 1 may continue below.
//   labels  components found in those rows (may exceed cap).
typedef struct vd_components_stats {
    uint32_t runs;
    uint32_t pixels;
    uint32_t rows;
    uint32_t labels;
} vd_components_stats_t;

// Workspace for the thresholding labellers with a run budget: the fixed part
// of vd_components_workspace_size (span buffers and row-pair offsets, which
// depend on max_width and max_height) plus min(max_runs, ceil(w/2) * h) runs
// of 8 bytes. Any workspace of at least this size gives a budget of at least
// max_runs runs on ROIs up to max_width x max_height (a larger workspace is a
// larger budget: runs = (bytes - fixed part) / 8). For 640 x 512 and 16 384
// runs: 8 712 + 131 072 = 139 784 bytes.
//   max_runs  run budget, >= 1; values above the worst case are clamped (the
//             result then equals vd_components_workspace_size).
//   bytes     out: required size in bytes.
// Returns VD_OK; VD_ERR_ARG if bytes is NULL, max_runs is 0 or a dimension is 0
// or above VD_MAX_DIM; VD_ERR_OVERFLOW if the size does not fit size_t.
VD_API vd_status_t vd_components_workspace_size_runs(uint32_t max_width, uint32_t max_height, uint32_t max_runs,
                                              size_t *bytes);

// Labels the 8-connected components of the pixels >= thr of an 8-bit plane
// inside `roi`, without a mask: the same labeller, components and order as
// vd_components_label() on the mask (src >= thr) (i.e. cv2.threshold(src,
// thr - 1, 255, THRESH_BINARY) then cv2.connectedComponentsWithStats), with a
// run budget set by the workspace size.
//   src    read-only 8-bit view (a frame); any stride.
//   roi    region to label, inside src; NULL = whole view.
//   thr    foreground is pixel >= thr (0 = every pixel).
//   ws, bytes  VD_WORKSPACE_ALIGN-aligned workspace of at least
//          vd_components_workspace_size_runs(roi.w, roi.h, 1) bytes; its run
//          budget is min((bytes - fixed part) / 8, ceil(roi.w/2) * roi.h), so a
//          workspace from vd_components_workspace_size_runs(W, H, R) gives >= R
//          runs for any ROI up to W x H, and one from
//          vd_components_workspace_size(roi.w, roi.h) can never run out.
//   out, cap, count  as vd_components_label.
//   stats  may be NULL; filled on VD_OK and VD_ERR_CAPACITY.
// Run budget: row pairs (0-1, 2-3, ...) are labelled while their runs fit.
// The pair that does not fit ends the scan: the components of the rows before
// it are written (rows = stats->rows < roi.h) and VD_ERR_CAPACITY is returned,
// so an overflow is never silent. Callers tell the two capacity cases apart
// by stats: rows < roi.h (run budget) and labels > cap (component capacity).
// Returns VD_OK; VD_ERR_CAPACITY (run budget or cap, see above); VD_ERR_ARG
// for a NULL src/count, a view failing vd_view_u8_check, a ROI not inside src,
// or out NULL with cap > 0; VD_ERR_WORKSPACE for a NULL, misaligned or short
// workspace. On any error other than VD_ERR_CAPACITY, *count = 0.
// Time O(roi.w * roi.h) (8 pixels per 64-bit word over uniform stretches) plus
// near-linear union-find over the runs; stack O(1).
VD_API vd_status_t vd_components_label_thr_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint8_t thr, void *ws,
                                       size_t bytes, vd_component_t *out, size_t cap, size_t *count,
                                       vd_components_stats_t *stats);

// As vd_components_label_thr_u8 on a 16-bit plane (radiometric frames):
// foreground is pixel >= thr (raw units; vd_calib_raw_from_ck gives the raw
// value of a temperature). src must pass vd_view_u16_check (even stride,
// aligned data), else VD_ERR_ARG. 4 pixels per 64-bit word.
VD_API vd_status_t vd_components_label_thr_u16(const vd_view_u16_t *src, const vd_rect_t *roi, uint16_t thr, void *ws,
                                        size_t bytes, vd_component_t *out, size_t cap, size_t *count,
                                        vd_components_stats_t *stats);

// Shape rules of paper 001 for hot-spot candidates.
//   aspect_min_q8, aspect_max_q8  bounds on box.h / box.w (height over width)
//          in Q8; paper 0.3 .. 1.5 -> 77 .. 384. The component's aspect is
//          aspect_q8 = round-half-up(256 * h / w) and it passes when
//          aspect_min_q8 <= aspect_q8 <= aspect_max_q8 (both ends inclusive, so
//          h/w = 0.3 exactly, aspect_q8 = round(76.8) = 77, passes).
//   min_area  smallest pixel count kept (paper 120), inclusive.
//   max_area  largest pixel count kept, inclusive; 0 = no limit.
typedef struct vd_components_rules {
    uint16_t aspect_min_q8;
    uint16_t aspect_max_q8;
    uint32_t min_area;
    uint32_t max_area;
} vd_components_rules_t;

// Fills *rules with the paper's values: aspect 77..384 (0.3..1.5), min_area 120,
// max_area 0 (no limit). Does nothing if rules is NULL.
VD_API void vd_components_rules_default(vd_components_rules_t *rules);

// Resolves rules in place: all four fields 0 take vd_components_rules_default's
// values (any other combination is kept as given), then the rules are checked.
// Returns VD_OK; VD_ERR_ARG for NULL rules, aspect_min_q8 > aspect_max_q8, or
// max_area != 0 with min_area > max_area.
VD_API vd_status_t vd_components_rules_resolve(vd_components_rules_t *rules);

// Keeps the components that pass `rules`, compacting comps[0..n) in place and
// preserving their order (stable).
//   comps  array of n components (may be NULL when n is 0); boxes need w, h >= 1.
//   rules  the rules; aspect_min_q8 <= aspect_max_q8 and (max_area == 0 or
//          min_area <= max_area).
//   kept   out: number of components now at comps[0..kept).
// Returns VD_OK; VD_ERR_ARG for NULL rules/kept, NULL comps with n > 0,
// inconsistent rules or a component with w or h <= 0 (nothing is modified
// then and *kept = 0).
VD_API vd_status_t vd_components_filter(vd_component_t *comps, size_t n, const vd_components_rules_t *rules, size_t *kept);

#ifdef __cplusplus
}
#endif
#endif
