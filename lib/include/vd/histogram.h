// SPDX-License-Identifier: MIT
// 256-bin histogram of an 8-bit region (Otsu, the percentile threshold and refinement count with it), and
// percentiles of a 16-bit plane (the detector's per-frame grey window).
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

// Two percentiles of a 16-bit plane, exactly, with 256 counters: the high
// bytes are counted first, then the low bytes of the samples in the bin that
// holds each percentile (two or three passes over src).
// With n = width * height and cum(v) = samples <= v, *lo is the smallest v
// with cum(v) > floor(n * lo_permille / 1000), *hi likewise with hi_permille
// (65535 when none, i.e. hi_permille = 1000): the rule of the CNN's
// percentile stretch (docs/fixed-point.md), so lo_permille 0 gives the
// smallest sample.
// src: whole 16-bit view; hist: caller-owned scratch of 256 counters
// (overwritten); 0 <= lo_permille <= hi_permille <= 1000.
// Returns VD_OK; VD_ERR_ARG for NULL pointers, an invalid view or permilles
// out of order or range, VD_ERR_OVERFLOW if the view's extent overflows
// (outputs unchanged).
VD_API vd_status_t vd_histogram_percentiles_u16(const vd_view_u16_t *src, uint32_t lo_permille,
                                                uint32_t hi_permille, uint32_t hist[256], uint16_t *lo,
                                                uint16_t *hi);

#ifdef __cplusplus
}
#endif
#endif
