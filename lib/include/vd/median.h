// SPDX-License-Identifier: MIT
// 3x3 and 5x5 median filters of an 8-bit region, equal to cv2.medianBlur.
#ifndef VD_MEDIAN_H
#define VD_MEDIAN_H

#include "vd/image.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// dst(x, y) = median of the k x k window of src centred on (roi.x + x, roi.y + y),
// k = 3 (vd_median3_u8) or 5 (vd_median5_u8). Pixels outside the ROI but
// inside src are used; beyond src's edges the edge pixel is replicated. The
// result is bit-exact with cv2.medianBlur(src, k)[roi.y:roi.y+roi.h, roi.x:roi.x+roi.w].
// src: 8-bit view (any stride). roi: NULL = whole image, else inside src.
// dst: caller-owned, exactly roi.w x roi.h, must not overlap src.
// No workspace: the filter works on blocks of adjacent pixels with small
// fixed stack buffers (stack budget: worst case < 512 bytes each on
// Cortex-M7 -Os, docs/embedded.md).
// Returns VD_OK; VD_ERR_ARG for NULL/invalid views, a ROI outside src or a
// dst of another size; VD_ERR_OVERFLOW if a view's extent overflows size_t.
VD_API vd_status_t vd_median3_u8(const vd_view_u8_t *src, const vd_rect_t *roi, vd_image_u8_t *dst);
VD_API vd_status_t vd_median5_u8(const vd_view_u8_t *src, const vd_rect_t *roi, vd_image_u8_t *dst);

#ifdef __cplusplus
}
#endif
#endif
