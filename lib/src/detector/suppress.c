// SPDX-License-Identifier: MIT
// Overlap suppression: greedy NMS over detections sorted by score, and the merge's overlap test.
//
// Algorithm: stable insertion sort by score_q8 (descending), then the greedy
// pass of classic NMS (as in paper 001's final step and most detectors): a
// box is kept unless its IoU with a box kept before it exceeds the threshold.
// IoU is vd_rect_iou_q15 (Q15, rounded down, image.h).
// Bounds: time O(n^2) for n detections (the detector's n <= max_candidates
// <= 4096; 64 by default); stack one vd_detection_t (48 bytes) and a few
// words; no workspace, no recursion.
#include "vd/suppress.h"

#include "internal/vd_internal.h"

vd_status_t vd_suppress_nms(vd_detection_t *d, size_t n, uint32_t iou_q15, size_t max_keep, size_t *kept,
                            vd_suppress_stats_t *stats)
{
    VD_VERIFY(kept != NULL, VD_ERR_ARG);
    *kept = 0u;
    VD_VERIFY(d != NULL || n == 0u, VD_ERR_ARG);
    vd_suppress_stats_t st = {0u, 0u};
    // Stable: an element moves only past strictly lower scores.
    for (size_t i = 1; i < n; i++) {
        const vd_detection_t v = d[i];
        size_t j = i;
        while (j > 0u && d[j - 1u].score_q8 < v.score_q8) {
            d[j] = d[j - 1u];
            j--;
        }
        d[j] = v;
    }
    size_t k = 0u;
    for (size_t i = 0; i < n; i++) {
        bool ok = true;
        for (size_t j = 0; j < k; j++) {
            if (vd_rect_iou_q15(&d[i].box, &d[j].box) > iou_q15) {
                ok = false;
                break;
            }
        }
        if (!ok) {
            st.suppressed++;
            continue;
        }
        if (k >= max_keep) {
            st.overflow++;
            continue;
        }
        d[k++] = d[i];
    }
    *kept = k;
    if (stats != NULL) {
        *stats = st;
    }
    return VD_OK;
}

bool vd_suppress_overlaps(const vd_rect_t *box, const vd_detection_t *list, size_t n, uint32_t iou_q15)
{
    if (box == NULL || list == NULL) {
        return false;
    }
    for (size_t i = 0; i < n; i++) {
        if (vd_rect_iou_q15(box, &list[i].box) > iou_q15) {
            return true;
        }
    }
    return false;
}
