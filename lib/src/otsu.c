// SPDX-License-Identifier: MIT
// Histogram of an 8-bit region and Otsu's threshold computed exactly in integers.
//
// Algorithm: Otsu (1979), "A threshold selection method from gray-level
// histograms". For a split after level t, with N pixels of total S = sum v,
// n0 pixels of sum s0 at levels <= t, the between-class variance is
//   sigma_B^2(t) = (N*s0 - n0*S)^2 / (N^2 * n0 * (N - n0)).
// N^2 is common to every t, so t maximises D^2 / d with D = N*s0 - n0*S and
// d = n0*(N - n0). Candidates are compared by exact cross-multiplication in
// 192 bits (internal/otsu_internal.h); the first maximum wins (strict >), the
// tie rule of OpenCV's getThreshVal_Otsu_8u, and levels with n0 == 0 or
// n0 == N are skipped as OpenCV does. Levels with an empty bin give the same
// (D, d) as the level before them, so they are skipped without changing the
// result. Reference for the expected values: cv2.threshold(THRESH_OTSU).
// Bounds: N <= 2^26 (VD_OTSU_MAX_COUNT), S < 2^34, |D| < 2^60, d < 2^52;
// time O(pixels) for the histogram + 256 criterion evaluations (each two
// 64x64->128 products and two 128x64 products); stack ~1.1 KiB in vd_otsu_u8
// (the histogram), < 200 bytes otherwise; no workspace.
#include <string.h>

#include "vd/otsu.h"
#include "internal/vd_internal.h"
#include "internal/otsu_internal.h"

vd_status_t vd_histogram_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint32_t hist[256])
{
    vd_rect_t r;
    VD_VERIFY(hist != NULL, VD_ERR_ARG);
    VD_TRY(vd_view_u8_check(src));
    VD_TRY(vd_roi_resolve(roi, src->width, src->height, &r));
    memset(hist, 0, 256u * sizeof hist[0]);
    const size_t w = (size_t)r.w;
    const uint8_t *s = src->data + (size_t)r.y * src->stride + (size_t)r.x;
    for (int32_t y = 0; y < r.h; y++) {
        size_t x = 0;
        // Four independent loads per step; increments of equal values
        // serialise anyway, so a second histogram plane is not worth its stack.
        for (; x + 4u <= w; x += 4u) {
            const uint8_t v0 = s[x], v1 = s[x + 1u], v2 = s[x + 2u], v3 = s[x + 3u];
            hist[v0]++;
            hist[v1]++;
            hist[v2]++;
            hist[v3]++;
        }
        for (; x < w; x++) {
            hist[s[x]]++;
        }
        s += src->stride;
    }
    return VD_OK;
}

vd_status_t vd_otsu_from_hist(const uint32_t hist[256], uint8_t *thr)
{
    VD_VERIFY(hist != NULL && thr != NULL, VD_ERR_ARG);
    uint64_t n = 0u, sum = 0u;
    for (uint32_t v = 0u; v < 256u; v++) {
        n += hist[v];
        sum += (uint64_t)hist[v] * v;
    }
    VD_VERIFY(n > 0u, VD_ERR_ARG);
    VD_VERIFY(n <= (uint64_t)VD_OTSU_MAX_COUNT, VD_ERR_RANGE);

    // n <= 2^26 and sum < 2^34: every product below is < 2^60, exact in int64.
    const int64_t nn = (int64_t)n, ss = (int64_t)sum;
    int64_t n0 = 0, s0 = 0;
    uint64_t best_a = 0u, best_d = 1u; // criterion 0/1: any real split beats it
    uint32_t best_t = 0u;             // OpenCV's answer when nothing splits
    for (uint32_t t = 0u; t < 256u; t++) {
        if (hist[t] == 0u) {
            continue; // same (D, d) as level t-1: cannot win with strict >
        }
        n0 += (int64_t)hist[t];
        s0 += (int64_t)hist[t] * (int64_t)t;
        if (n0 == nn) {
            break; // class 2 empty from here on (OpenCV skips these levels)
        }
        const int64_t diff = nn * s0 - n0 * ss;
        const uint64_t a = diff < 0 ? (uint64_t)(-diff) : (uint64_t)diff;
        const uint64_t d = (uint64_t)n0 * (uint64_t)(nn - n0);
        if (vd_ratio_sq_gt(a, d, best_a, best_d)) {
            best_a = a;
            best_d = d;
            best_t = t;
        }
    }
    *thr = (uint8_t)best_t;
    return VD_OK;
}

vd_status_t vd_otsu_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint8_t *thr)
{
    uint32_t hist[256];
    VD_VERIFY(thr != NULL, VD_ERR_ARG);
    VD_TRY(vd_histogram_u8(src, roi, hist));
    return vd_otsu_from_hist(hist, thr);
}
