// SPDX-License-Identifier: MIT
// 256-bin histogram of an 8-bit region; two percentiles of a 16-bit plane.
//
// Algorithm: one counter increment per pixel; 8 pixels are loaded as one
// 64-bit word and a uniform word (8 equal pixels) is one update. The 16-bit
// percentiles count high bytes, then the low bytes inside the bin that holds
// each rank: exact with 256 counters instead of 65536 (a workspace the
// detector already has), at most three passes.
// Bounds: time O(roi.w * roi.h); stack: a second 1 KiB counter plane on
// 64-bit hosts (VD_HIST_PLANES), a few words on 32-bit targets; totals
// <= 2^26 (VD_MAX_DIM^2), no overflow; no workspace. Percentiles: O(3 W H)
// time, O(1) stack besides the caller's 256 counters.
#include <string.h>

#include "vd/histogram.h"
#include "internal/vd_internal.h"

// Counter planes of vd_histogram_u8. On 64-bit hosts (out-of-order cores:
// increments of one counter serialise on store-to-load forwarding, and
// neighbouring pixels are often equal) odd pixels count into a second,
// stack plane: 10-25% faster on real frames. 32-bit targets keep the stack
// small (1 KiB less on the detector's deepest chain, docs/embedded.md).
#ifndef VD_HIST_PLANES
#if UINTPTR_MAX > 0xFFFFFFFFu
#define VD_HIST_PLANES 2
#else
#define VD_HIST_PLANES 1
#endif
#endif

vd_status_t vd_histogram_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint32_t hist[256])
{
    vd_rect_t r;
    VD_VERIFY(hist != NULL, VD_ERR_ARG);
    VD_TRY(vd_view_u8_check(src));
    VD_TRY(vd_rect_roi_resolve(roi, src->width, src->height, &r));
    memset(hist, 0, 256u * sizeof hist[0]);
    const size_t w = (size_t)r.w;
    const uint8_t *s = src->data + (size_t)r.y * src->stride + (size_t)r.x;
#if VD_HIST_PLANES == 2
    uint32_t h2[256];
    memset(h2, 0, sizeof h2);
#else
    uint32_t *const h2 = hist;
#endif
    for (int32_t y = 0; y < r.h; y++) {
        size_t x = 0;
        for (; x + 8u <= w; x += 8u) {
            uint64_t word;
            memcpy(&word, s + x, sizeof word);
            if (word == (word & 0xFFu) * 0x0101010101010101ull) {
                hist[word & 0xFFu] += 8u;   // 8 equal pixels (uniform areas): one update
                continue;
            }
            const uint8_t v0 = s[x], v1 = s[x + 1u], v2 = s[x + 2u], v3 = s[x + 3u];
            const uint8_t v4 = s[x + 4u], v5 = s[x + 5u], v6 = s[x + 6u], v7 = s[x + 7u];
            hist[v0]++;
            h2[v1]++;
            hist[v2]++;
            h2[v3]++;
            hist[v4]++;
            h2[v5]++;
            hist[v6]++;
            h2[v7]++;
        }
        for (; x < w; x++) {
            hist[s[x]]++;
        }
        s += src->stride;
    }
#if VD_HIST_PLANES == 2
    for (uint32_t v = 0; v < 256u; v++) {
        hist[v] += h2[v];   // totals <= 2^26 (VD_MAX_DIM^2): no overflow
    }
#endif
    return VD_OK;
}

// hist[v >> 8] over the plane, or with high <= 255 hist[v & 255] over its
// samples whose high byte is `high`.
static void count_u16(const vd_view_u16_t *src, uint32_t high, uint32_t hist[256])
{
    memset(hist, 0, 256u * sizeof hist[0]);
    // The view's fields in locals: the counters are uint32_t as the width is, so each store would reload it.
    const size_t w = src->width, h = src->height, stride = src->stride;
    const uint8_t *row = (const uint8_t *)src->data;
    for (size_t y = 0; y < h; y++) {
        const uint16_t *s = (const uint16_t *)(const void *)row;   // even stride, aligned (vd_view_u16_check)
        if (high > 255u) {
            for (size_t x = 0; x < w; x++) {
                hist[s[x] >> 8]++;
            }
        } else {
            for (size_t x = 0; x < w; x++) {
                if ((uint32_t)(s[x] >> 8) == high) {
                    hist[s[x] & 0xFFu]++;
                }
            }
        }
        row += stride;
    }
}

// Smallest bin b with base + cum(b) > k (256 when none); *below (if not
// NULL) = base + the counts before b.
static uint32_t rank_bin(const uint32_t hist[256], uint64_t base, uint64_t k, uint64_t *below)
{
    uint64_t cum = base;
    uint32_t b = 0;
    while (b < 256u && cum + hist[b] <= k) {
        cum += hist[b];
        b++;
    }
    if (below != NULL) {
        *below = cum;
    }
    return b;
}

vd_status_t vd_histogram_percentiles_u16(const vd_view_u16_t *src, uint32_t lo_permille, uint32_t hi_permille,
                                         uint32_t hist[256], uint16_t *lo, uint16_t *hi)
{
    VD_VERIFY(hist != NULL && lo != NULL && hi != NULL, VD_ERR_ARG);
    VD_VERIFY(lo_permille <= hi_permille && hi_permille <= 1000u, VD_ERR_ARG);
    VD_TRY(vd_view_u16_check(src));
    const uint64_t n = (uint64_t)src->width * src->height;
    const uint64_t k[2] = {n * lo_permille / 1000u, n * hi_permille / 1000u};
    uint64_t below[2];
    uint32_t bin[2];
    count_u16(src, 256u, hist);
    for (uint32_t i = 0; i < 2u; i++) {
        bin[i] = rank_bin(hist, 0u, k[i], &below[i]);
    }
    uint16_t out[2] = {65535u, 65535u};
    for (uint32_t i = 0; i < 2u; i++) {
        if (bin[i] > 255u) {
            continue;   // k = n: no sample ranks above it
        }
        if (i == 0u || bin[1] != bin[0]) {
            count_u16(src, bin[i], hist);   // else hist holds this bin's low bytes already
        }
        const uint32_t f = rank_bin(hist, below[i], k[i], NULL);   // < 256: the bin holds the rank
        out[i] = (uint16_t)((bin[i] << 8) | f);
    }
    *lo = out[0];
    *hi = out[1];
    return VD_OK;
}
