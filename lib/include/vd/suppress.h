// SPDX-License-Identifier: MIT
// Overlap suppression of detections: greedy non-maximum suppression by score, and the overlap test of the
// detector's candidate merge.
#ifndef VD_SUPPRESS_H
#define VD_SUPPRESS_H

#include <stddef.h>
#include <stdint.h>
#include <stdbool.h>

#include "vd/detection.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Counts of one vd_suppress_nms call.
typedef struct vd_suppress_stats {
    uint32_t suppressed;   // dropped: IoU > iou_q15 with a detection kept before it
    uint32_t overflow;     // not suppressed, but dropped because max_keep were already kept
} vd_suppress_stats_t;

// Greedy non-maximum suppression. Sorts d[0..n) by score_q8, best first and
// stably (equal scores keep their order, e.g. the raster order of hot spots),
// then walks them once: a detection whose box has IoU (vd_rect_iou_q15) >
// iou_q15 with a detection already kept is suppressed; otherwise it is kept
// while fewer than max_keep are kept, else counted in overflow.
//   d         n detections (may be NULL when n is 0); reordered in place: the
//             kept ones end in d[0..*kept) in score order, d[*kept..n) is
//             left unspecified.
//   iou_q15   Q15 (0..32768); 32768 or more suppresses nothing.
//   max_keep  budget of kept detections (0 keeps none).
//   kept      out: number kept.
//   stats     out, may be NULL.
// Returns VD_OK; VD_ERR_ARG for NULL kept, or NULL d with n > 0 (then *kept = 0).
// Time O(n^2) (insertion sort, then IoU against the kept ones); stack: one
// vd_detection_t plus a few words; no workspace.
VD_API vd_status_t vd_suppress_nms(vd_detection_t *d, size_t n, uint32_t iou_q15, size_t max_keep, size_t *kept,
                            vd_suppress_stats_t *stats);

// True when `box` overlaps one of list[0..n) by IoU > iou_q15 (the detector
// drops such a candidate before verification). False for a NULL box or list.
// Time O(n).
VD_API bool vd_suppress_overlaps(const vd_rect_t *box, const vd_detection_t *list, size_t n, uint32_t iou_q15);

#ifdef __cplusplus
}
#endif
#endif
