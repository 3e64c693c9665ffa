// SPDX-License-Identifier: MIT
// Otsu's threshold of a 256-bin histogram (histogram.h) or of an 8-bit region, equal to OpenCV's THRESH_OTSU.
#ifndef VD_OTSU_H
#define VD_OTSU_H

#include <stdint.h>

#include "vd/histogram.h"
#include "vd/image.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Largest pixel count (sum of a histogram) vd_otsu_from_hist accepts: 2^26,
// the area of an 8192 x 8192 image. It bounds the exact integer arithmetic
// (see docs/fixed-point.md).
#define VD_OTSU_MAX_COUNT (1u << 26)

// Otsu's threshold t of a histogram: the t maximising the between-class
// variance of the classes {v <= t} and {v > t}; binarise with `pixel > t`.
// The criterion is evaluated exactly in integers and the FIRST (smallest)
// maximising t is returned: this is the value cv2.threshold(...,
// THRESH_OTSU) returns on the same pixels (tested on every MSRS and HIT-UAV
// frame and on ROIs of them). Only on exact ties between different classes
// (e.g. a symmetric three-level histogram) may OpenCV, whose floating-point
// rounding decides those ties, return a later t; see docs/fixed-point.md.
// A histogram with fewer than two occupied levels (constant region) gives
// *thr = 0, as OpenCV does.
// hist: 256 counts, their sum 1 .. VD_OTSU_MAX_COUNT.
// Returns VD_OK; VD_ERR_ARG for NULL pointers or an all-zero histogram;
// VD_ERR_RANGE if the counts sum to more than VD_OTSU_MAX_COUNT (*thr unchanged).
VD_API vd_status_t vd_otsu_from_hist(const uint32_t hist[256], uint8_t *thr);

// vd_histogram_u8 + vd_otsu_from_hist over src's region (1 KiB histogram on
// the stack). Same statuses as the two.
VD_API vd_status_t vd_otsu_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint8_t *thr);

#ifdef __cplusplus
}
#endif
#endif
