// SPDX-License-Identifier: MIT
// 256-bin histogram of an 8-bit region.
//
// Algorithm: one counter increment per pixel; 8 pixels are loaded as one
// 64-bit word and a uniform word (8 equal pixels) is one update.
// Bounds: time O(roi.w * roi.h); stack: a second 1 KiB counter plane on
// 64-bit hosts (VD_HIST_PLANES), a few words on 32-bit targets; totals
// <= 2^26 (VD_MAX_DIM^2), no overflow; no workspace.
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
