// SPDX-License-Identifier: MIT
// 256-bin histogram of an 8-bit region (Otsu, the percentile threshold and refinement count with it).
#ifndef VD_HISTOGRAM_H
#define VD_HISTOGRAM_H

#include <stdint.h>

#include "vd/image.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// hist[v] = number of pixels of value v inside the region (the 256 entries
// are overwritten, not accumulated).
// src: 8-bit view; roi: NULL = whole image, else must lie inside src;
// hist: caller-owned array of 256 counters.
// Returns VD_OK; VD_ERR_ARG for NULL pointers, an invalid view or a ROI
// outside src (hist unchanged); VD_ERR_OVERFLOW if the view's extent overflows.
VD_API vd_status_t vd_histogram_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint32_t hist[256]);

#ifdef __cplusplus
}
#endif
#endif
