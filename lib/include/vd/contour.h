// SPDX-License-Identifier: MIT
// Outer-contour tracing of a binary mask (Suzuki-Abe border following), point
// for point equal to cv2.findContours(mask, RETR_EXTERNAL, CHAIN_APPROX_NONE).
#ifndef VD_CONTOUR_H
#define VD_CONTOUR_H

#include <stddef.h>
#include <stdint.h>

#include "vd/image.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Freeman chain codes, OpenCV's numbering: code k moves by
//   0 (+1, 0)  1 (+1,-1)  2 (0,-1)  3 (-1,-1)  4 (-1,0)  5 (-1,+1)  6 (0,+1)  7 (+1,+1)
// in image coordinates (y down), i.e. counter-clockwise as seen on screen.
// A contour of one pixel has no move: its single code is VD_CONTOUR_CHAIN_NONE.
#define VD_CONTOUR_CHAIN_NONE 8u

// One traced contour: its points are points[first .. first + length), and
// chain[first .. first + length) when a chain array was given. `box` is the
// bounding box of the points in mask coordinates (w, h >= 1).
typedef struct vd_contour {
    uint32_t first;
    uint32_t length;
    vd_rect_t box;
} vd_contour_t;

// Workspace for vd_contour_find_external on masks up to max_width x max_height:
// one byte per pixel of the mask plus a one-pixel zero border, i.e.
// (max_width + 2) * (max_height + 2) bytes (the label/mark plane of the border
// follower). Pure function of its arguments.
// Returns VD_OK; VD_ERR_ARG if bytes is NULL or a dimension is 0 or above
// VD_MAX_DIM.
VD_API vd_status_t vd_contour_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes);

// Traces the outermost borders of the 8-connected foreground (nonzero) regions
// of `mask`; holes, and regions inside holes, are not reported. The mask is
// read as if it had a one-pixel zero border (OpenCV 4/5 behaviour), so regions
// touching the edge are closed along it.
//   mask        read-only, 1..VD_MAX_DIM per side, any stride; not modified.
//   ws, bytes   workspace of at least vd_contour_workspace_size(mask->width,
//               mask->height) bytes, VD_WORKSPACE_ALIGN aligned; scratch only.
//   points      receives the points of all contours back to back (capacity
//               points_cap). Order, start and direction equal
//               np.concatenate(cv2.findContours(mask, RETR_EXTERNAL,
//               CHAIN_APPROX_NONE)[0]); one contour never needs more than
//               4 * (pixels of its region) points.
//   chain       may be NULL; else points_cap codes: chain[i] is the Freeman
//               code from points[i] to the next point of the same contour
//               (cyclic: the last code leads back to the first point).
//   contours    receives the contours (capacity contours_cap) in cv2's order
//               (the reverse of the raster order of their first pixels).
//   n_contours, n_points  receive the numbers written (0 on argument errors).
// Returns VD_OK; VD_ERR_ARG for a NULL pointer (other than chain) or a bad
// view (capacities may be 0: then any contour gives VD_ERR_CAPACITY);
// VD_ERR_WORKSPACE for a NULL, misaligned or short workspace;
// VD_ERR_CAPACITY when the contours or their points do not fit: then the
// contours completely traced before the overflow (the first ones in raster
// order, i.e. the LAST ones of cv2's list) are written, each whole and in
// cv2's relative order, and the counts say how many;
// VD_ERR_STATE if a border trace exceeds its bound (an internal bug).
VD_API vd_status_t vd_contour_find_external(const vd_view_u8_t *mask, void *ws, size_t bytes,
                                      vd_point_t *points, uint8_t *chain, size_t points_cap,
                                      vd_contour_t *contours, size_t contours_cap,
                                      size_t *n_contours, size_t *n_points);

#ifdef __cplusplus
}
#endif
#endif
