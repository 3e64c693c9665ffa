// SPDX-License-Identifier: MIT
// Hot-spot thresholds: constant 8-bit, 16-bit raw and radiometric (calib.h), percentile.
#ifndef VD_THRESHOLD_H
#define VD_THRESHOLD_H

#include <stdint.h>

#include "vd/calib.h"
#include "vd/image.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Binary mask of the hot pixels of an 8-bit image: dst = src >= thr ? 255 : 0
// (paper 001: thr 150 keeps pixels >= 150). Bit-exact with
// cv2.threshold(src, thr - 1, 255, THRESH_BINARY)[roi] (thr 0 sets every pixel).
// src: 8-bit view (any stride >= width). roi: NULL for the whole image, else
// must lie inside src. dst: caller-owned, exactly roi.w x roi.h, must not
// overlap src (dst == src with the same stride and a NULL roi is allowed:
// each pixel is read before it is written).
// Returns VD_OK; VD_ERR_ARG for NULL/invalid views, a ROI outside src or a dst
// of another size; VD_ERR_OVERFLOW if a view's extent overflows size_t.
VD_API vd_status_t vd_threshold_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint8_t thr, vd_image_u8_t *dst);

// Same for a 16-bit raw plane: dst = src >= thr_raw ? 255 : 0.
// src: 16-bit view, even stride, 2-byte aligned data. Other arguments and
// statuses as vd_threshold_u8.
VD_API vd_status_t vd_threshold_u16(const vd_view_u16_t *src, const vd_rect_t *roi, uint16_t thr_raw, vd_image_u8_t *dst);

// Radiometric hot-spot mask: dst = temperature(src) >= thr_ck ? 255 : 0,
// evaluated as one raw comparison (vd_calib_raw_from_ck). A threshold hotter
// than the calibration can express (raw 65535 is still colder) gives an all-0
// mask and VD_OK: no pixel can be that hot, so the mask is exact.
// Other arguments as vd_threshold_u16. Returns VD_OK; VD_ERR_ARG for NULL
// pointers, a negative gain, invalid views, a ROI outside src or a dst of
// another size; VD_ERR_OVERFLOW as vd_threshold_u16.
VD_API vd_status_t vd_threshold_u16_ck(const vd_view_u16_t *src, const vd_rect_t *roi, const vd_calib_t *cal,
                                int32_t thr_ck, vd_image_u8_t *dst);

// Percentile threshold of a histogram: the smallest level t such that at
// least ceil(N * permille / 1000) of the N counted pixels are <= t (N = the
// sum of hist), raised to floor_u8: *thr = max(floor_u8, t). The
// detector's adaptive hot-spot threshold (permille 990, floor 96, on the
// frame's vd_histogram_u8, histogram.h) and contrast.h's percentile mode.
//   hist      256 counts (any total, uint64 arithmetic).
//   permille  0..1000 (0 gives t = 0, so *thr = floor_u8).
// Returns VD_OK; VD_ERR_ARG for NULL pointers or permille > 1000.
VD_API vd_status_t vd_threshold_percentile_u8(const uint32_t hist[256], uint32_t permille, uint8_t floor_u8, uint8_t *thr);

#ifdef __cplusplus
}
#endif
#endif
