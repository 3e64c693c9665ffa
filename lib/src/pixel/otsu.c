// SPDX-License-Identifier: MIT
// Otsu's threshold of a histogram (histogram.c counts it) computed exactly in integers.
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
// time: one criterion evaluation per occupied level (a pre-test on 21-bit
// truncations decides almost all; near-ties take the exact 192-bit
// comparison); stack: vd_otsu_u8 1 KiB (the histogram) plus vd_histogram_u8's
// (histogram.c); < 200 bytes in vd_otsu_from_hist; no workspace.
#include <string.h>

#include "vd/otsu.h"
#include "internal/vd_internal.h"
#include "pixel/otsu_internal.h"

// Number of significant bits of v (0 for 0).
static uint32_t bit_length(uint64_t v)
{
    uint32_t b = 0u;
    while (b < 64u && (v >> b) != 0u) {
        b++;
    }
    return b;
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
    // Fast pre-test: a = |D| <= n*sum and d <= n^2/4 are truncated to 21
    // bits (a' = a >> sa, d' = d >> sd, so a' <= a / 2^sa < a' + 1); then
    //   a'^2 * bd' * 2^c <= a^2 * bd < (a'+1)^2 * (bd'+1) * 2^c, c = 2sa + sd,
    // and the same for b^2 * d, all products < 2^63. When these intervals
    // decide the comparison it is exact; only near-ties run the 192-bit
    // comparison. Same result, a few dozen instructions per level.
    const uint32_t ba = bit_length(n * sum), bd = bit_length(n * n / 4u);
    const uint32_t sa = ba > 21u ? ba - 21u : 0u, sd = bd > 21u ? bd - 21u : 0u;
    int64_t n0 = 0, s0 = 0;
    uint64_t best_a = 0u, best_d = 1u; // criterion 0/1: any real split beats it
    uint64_t best_at = 0u, best_dt = 1u >> sd;   // best_a >> sa, best_d >> sd
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
        const uint64_t at = a >> sa, dt = d >> sd;
        // x = a^2 * best_d against y = best_a^2 * d.
        const uint64_t x_hi = (at + 1u) * (at + 1u) * (best_dt + 1u);
        const uint64_t y_lo = best_at * best_at * dt;
        if (x_hi <= y_lo) {
            continue;   // x < y: not better
        }
        const uint64_t x_lo = at * at * best_dt;
        const uint64_t y_hi = (best_at + 1u) * (best_at + 1u) * (dt + 1u);
        if (x_lo > y_hi || vd_ratio_sq_gt(a, d, best_a, best_d)) {
            best_a = a;
            best_d = d;
            best_at = at;
            best_dt = dt;
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
