// SPDX-License-Identifier: MIT
// Fixed-point resampling: a candidate region to the network input size (32x32), and box averaging by integer
// factors (regions larger than a buffer, cell means).
#ifndef VD_RESAMPLE_H
#define VD_RESAMPLE_H

#include <stddef.h>
#include <stdint.h>

#include "vd/image.h"
#include "vd/status.h"
#include "vd/threshold.h"

#ifdef __cplusplus
extern "C" {
#endif

// Largest accepted destination width/height. Keeps every weight total below
// 2^15 (see resample.c) so products stay inside the integer types used.
#define VD_RESAMPLE_MAX_DST 4096u

// Resamples the region `roi` of `src` (NULL = whole view) to a dst_w x dst_h
// image, separably and independently per axis:
// - an axis that shrinks or keeps its size (roi length S >= dst length D) uses
//   the exact area average (box filter): output sample i covers the source
//   interval [i*S/D, (i+1)*S/D) and every source pixel is weighted by its exact
//   overlap with it (integer weights in units of 1/D pixel, total S);
// - an axis that grows (S < D) uses bilinear interpolation with pixel centres
//   at +0.5 (as cv2.INTER_LINEAR): source position (i+0.5)*S/D - 0.5, clamped
//   to [0, S-1], with exact weights in units of 1/(2D) pixel (total 2D).
// The output is round-half-up(sum(wx*wy*pixel) / (Tx*Ty)) computed exactly in
// integers, so the result depends on nothing but the inputs (bit-exact with
// tools/vdtools/data/samples.py's reference). Equal sizes copy the region.
//
// src:   8-bit view (data non-null, 1..VD_MAX_DIM per side, stride >= width).
// roi:   region inside src, or NULL for the whole view.
// dst:   caller buffer of dst_w * dst_h bytes, row-major and contiguous
//        (stride dst_w); must not overlap src. Written only on VD_OK.
// dst_w, dst_h: 1..VD_RESAMPLE_MAX_DST.
// Returns VD_OK; VD_ERR_ARG for a NULL src/dst, an invalid view, a ROI not
// inside the view, or a zero/too large dst size.
// Time O(roi area + dst_w*dst_h) for shrinking, O(dst_w*dst_h) for growing;
// stack < 256 bytes; no workspace.
VD_API vd_status_t vd_resample_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint8_t *dst,
                           uint32_t dst_w, uint32_t dst_h);

// Box average by integer factors (decimation):
//   dst(cx, cy) = round-half-up(sum of the kx x ky block of src whose top-left
//                 pixel is (roi.x + cx*kx, roi.y + cy*ky), divided by kx*ky),
// exact in integers (uint64 sum). dst is (roi.w / kx) x (roi.h / ky): the
// last roi.w % kx columns and roi.h % ky rows of the ROI are not read. The
// detector uses it for regions larger than its region buffers (k = the ceiling
// of region / bound per axis) and for the 4x4 cell means of the window
// pre-filter (windows.h).
//   src     8-bit view; roi NULL = whole view, else inside it.
//   kx, ky  1..roi.w and 1..roi.h (so dst has at least one pixel).
//   dst     writable, exactly (roi.w / kx) x (roi.h / ky), any stride; must
//           not overlap src. Written only on VD_OK.
// Returns VD_OK; VD_ERR_ARG for NULL pointers, invalid views, a ROI outside
// src, a factor out of range or a dst of another size.
// Time O(roi area); stack < 100 bytes; no workspace.
VD_API vd_status_t vd_resample_box_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint32_t kx, uint32_t ky,
                               vd_image_u8_t *dst);

// The same for a 16-bit plane: each rounded block mean (0..65535) is mapped
// to grey through `grey` (vd_calib_grey_u8, calib.h), which must come
// from vd_calib_grey_init. Other arguments, statuses and bounds as
// vd_resample_box_u8 (VD_ERR_ARG also for a NULL grey).
VD_API vd_status_t vd_resample_box_u16(const vd_view_u16_t *src, const vd_rect_t *roi, uint32_t kx, uint32_t ky,
                                const vd_calib_grey_t *grey, vd_image_u8_t *dst);

#ifdef __cplusplus
}
#endif
#endif
