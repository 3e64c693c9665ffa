// SPDX-License-Identifier: MIT
// Connected components of a binary mask (8-connectivity) with box, area and
// centroid; the paper's aspect/area rules; candidate-box expansion.
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
// It holds the worst-case number of horizontal runs, ceil(w/2) * h (a
// checkerboard), at 8 bytes each, plus three row-span buffers of ceil(w/2)
// entries (8 bytes) and ceil(h/2)+1 segment offsets (4 bytes).
// For 640 x 512: 1 310 720 + 3 x 2 560 + 1 032 = 1 319 432 bytes (~1.26 MiB);
// for 640 x 480: 1 237 448 bytes.
//   bytes  out: required size in bytes.
// Returns VD_OK; VD_ERR_ARG if bytes is NULL or a dimension is 0 or above
// VD_MAX_DIM; VD_ERR_OVERFLOW if the size does not fit size_t.
vd_status_t vd_components_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes);

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
vd_status_t vd_components_label(const vd_view_u8_t *mask, const vd_rect_t *roi, void *ws, size_t bytes,
                                vd_component_t *out, size_t cap, size_t *count);

// Shape rules of paper 001 for hot-spot candidates.
//   aspect_min_q8, aspect_max_q8  bounds on box.h / box.w (height over width)
//          in Q8; paper 0.3 .. 1.5 -> 77 .. 384. The component's aspect is
//          aspect_q8 = round-half-up(256 * h / w) and it passes when
//          aspect_min_q8 <= aspect_q8 <= aspect_max_q8 (both ends inclusive, so
//          h/w = 0.3 exactly, aspect_q8 = round(76.8) = 77, passes).
//   min_area  smallest pixel count kept (paper 120), inclusive.
//   max_area  largest pixel count kept, inclusive; 0 = no limit.
typedef struct vd_cc_rules {
    uint16_t aspect_min_q8;
    uint16_t aspect_max_q8;
    uint32_t min_area;
    uint32_t max_area;
} vd_cc_rules_t;

// Fills *rules with the paper's values: aspect 77..384 (0.3..1.5), min_area 120,
// max_area 0 (no limit). Does nothing if rules is NULL.
void vd_cc_rules_default(vd_cc_rules_t *rules);

// Keeps the components that pass `rules`, compacting comps[0..n) in place and
// preserving their order (stable).
//   comps  array of n components (may be NULL when n is 0); boxes need w, h >= 1.
//   rules  the rules; aspect_min_q8 <= aspect_max_q8 and (max_area == 0 or
//          min_area <= max_area).
//   kept   out: number of components now at comps[0..kept).
// Returns VD_OK; VD_ERR_ARG for NULL rules/kept, NULL comps with n > 0,
// inconsistent rules or a component with w or h <= 0 (nothing is modified
// then and *kept = 0).
vd_status_t vd_components_filter(vd_component_t *comps, size_t n, const vd_cc_rules_t *rules, size_t *kept);

// Paper scales for vd_rect_expand: 1.5x horizontally, 2x vertically.
#define VD_EXPAND_W_Q8 384u
#define VD_EXPAND_H_Q8 512u

// Scales a box about its centre and clips it to the frame.
//   in     box with w, h >= 1 (any position; it may lie partly outside).
//   wscale_q8, hscale_q8  scale factors in Q8, >= 1 (256 = unchanged;
//          paper: VD_EXPAND_W_Q8, VD_EXPAND_H_Q8).
//   frame_w, frame_h  frame size, 1..VD_MAX_DIM.
//   out    result (may alias in).
// Rounding, per axis (shown for x): new_w = max(1, round-half-up(w * s / 256));
// the growth g = new_w - w is split floor(g/2) to the left and the rest to the
// right (an odd extra pixel goes right), i.e. new_x = x - floor(g/2); the box is
// then clipped to [0, frame_w) x [0, frame_h). Example: {10, 10, 10, 10} with
// 384/512 gives {8, 5, 15, 20}.
// Returns VD_OK; VD_ERR_ARG for NULL pointers, w or h <= 0, a zero scale, a
// frame size out of range, or an expanded box that misses the frame entirely.
vd_status_t vd_rect_expand(const vd_rect_t *in, uint16_t wscale_q8, uint16_t hscale_q8, uint32_t frame_w,
                           uint32_t frame_h, vd_rect_t *out);

#ifdef __cplusplus
}
#endif
#endif
