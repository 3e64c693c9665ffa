// SPDX-License-Identifier: MIT
// Rectangles and points: the box type and every vd_rect_* helper (ROI resolution, clipping, IoU,
// candidate-box expansion).
#ifndef VD_RECT_H
#define VD_RECT_H

#include <stdbool.h>
#include <stdint.h>

#include "vd/config.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Axis-aligned box in pixels, top-left origin; w, h > 0 for a valid box.
typedef struct vd_rect {
    int32_t x;
    int32_t y;
    int32_t w;
    int32_t h;
} vd_rect_t;

// A pixel position (contour points), image coordinates.
typedef struct vd_point {
    int16_t x;
    int16_t y;
} vd_point_t;

// Resolves an optional region of interest: roi == NULL means the whole
// width x height plane. VD_ERR_ARG if roi has w or h <= 0 or does not lie
// entirely inside [0, width) x [0, height). On success *out is the region.
VD_API vd_status_t vd_rect_roi_resolve(const vd_rect_t *roi, uint32_t width, uint32_t height, vd_rect_t *out);

// Clips r to [0,width) x [0,height); false if nothing is left.
VD_API bool vd_rect_clip(vd_rect_t *r, uint32_t width, uint32_t height);

// Intersection over union as a Q15 fraction (0..32768), rounded down.
// Boxes with no area give 0.
VD_API uint32_t vd_rect_iou_q15(const vd_rect_t *a, const vd_rect_t *b);

// Paper scales for vd_rect_expand: 1.5x horizontally, 2x vertically.
#define VD_RECT_EXPAND_W_Q8 384u
#define VD_RECT_EXPAND_H_Q8 512u

// Scales a box about its centre and clips it to the frame.
//   in     box with w, h >= 1 (any position; it may lie partly outside).
//   wscale_q8, hscale_q8  scale factors in Q8, >= 1 (256 = unchanged;
//          paper: VD_RECT_EXPAND_W_Q8, VD_RECT_EXPAND_H_Q8).
//   frame_w, frame_h  frame size, 1..VD_MAX_DIM.
//   out    result (may alias in).
// Rounding, per axis (shown for x): new_w = max(1, round-half-up(w * s / 256));
// the growth g = new_w - w is split floor(g/2) to the left and the rest to the
// right (an odd extra pixel goes right), i.e. new_x = x - floor(g/2); the box is
// then clipped to [0, frame_w) x [0, frame_h). Example: {10, 10, 10, 10} with
// 384/512 gives {8, 5, 15, 20}.
// Returns VD_OK; VD_ERR_ARG for NULL pointers, w or h <= 0, a zero scale, a
// frame size out of range, or an expanded box that misses the frame entirely.
VD_API vd_status_t vd_rect_expand(const vd_rect_t *in, uint16_t wscale_q8, uint16_t hscale_q8, uint32_t frame_w,
                           uint32_t frame_h, vd_rect_t *out);

#ifdef __cplusplus
}
#endif
#endif
