// SPDX-License-Identifier: MIT
// Fuzz harness: refine (paper 001 §3) and its steps on arbitrary grey regions, ROIs and settings.
//
// Input layout: w, h (1..48), row padding, flags (ROI given, short workspace,
// cfg NULL), ROI bytes, cfg bytes, 16 histogram bytes, then pixels. Expected
// statuses follow refine.h: a valid ROI and cfg give VD_OK and a 0/255 mask,
// anything else VD_ERR_ARG / VD_ERR_WORKSPACE. vd_refine_fill_holes_u8, vd_refine_edges_u8
// and vd_refine_maxdist_from_hist are run on the same data.
#include "fuzz_common.h"
#include "vd/refine.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader_t r;
    fz_init(&r, data, size);
    const uint32_t w = 1u + fz_u8(&r) % 48u;
    const uint32_t h = 1u + fz_u8(&r) % 48u;
    const size_t stride = w + fz_u8(&r) % 8u;
    const uint8_t flags = fz_u8(&r);
    vd_rect_t roi = {0, 0, (int32_t)w, (int32_t)h};
    if (flags & 1u) {
        roi.x = (int8_t)fz_u8(&r);
        roi.y = (int8_t)fz_u8(&r);
        roi.w = (int8_t)fz_u8(&r);
        roi.h = (int8_t)fz_u8(&r);
    }
    vd_refine_cfg_t cfg;
    cfg.median_ksize = fz_u8(&r);
    cfg.edge_step = fz_u8(&r);
    cfg.window = fz_u8(&r);
    if (flags & 8u) {
        // Mostly valid settings, so the deep path is reached often.
        static const uint8_t k_med[4] = {0u, 3u, 5u, 3u};
        cfg.median_ksize = k_med[cfg.median_ksize & 3u];
        cfg.edge_step = (uint8_t)(1u + cfg.edge_step % 8u);
        cfg.window = (uint8_t)(3u + 2u * (cfg.window % 7u));
    }
    uint32_t hist[256];
    memset(hist, 0, sizeof(hist));
    for (int i = 0; i < 16; i++) {
        const uint8_t b = fz_u8(&r);
        hist[(uint8_t)(b * 17u)] += (uint32_t)(b & 31u);
    }
    const uint8_t pixel_mode = fz_u8(&r);

    uint8_t *img = fz_alloc(fz_plane_bytes(stride, h, w));
    fz_fill_plane(&r, img, w, h, stride, (pixel_mode & 1u) != 0u, (uint8_t)(pixel_mode | 1u));
    vd_view_u8_t v = {img, w, h, stride};

    const int roi_ok = roi.w > 0 && roi.h > 0 && roi.x >= 0 && roi.y >= 0 && (int64_t)roi.x + roi.w <= (int64_t)w &&
                       (int64_t)roi.y + roi.h <= (int64_t)h;
    const int null_cfg = (flags & 4u) != 0u;
    const int cfg_ok = null_cfg || ((cfg.median_ksize == 0u || cfg.median_ksize == 3u || cfg.median_ksize == 5u) &&
                                    cfg.edge_step >= 1u && (cfg.window & 1u) && cfg.window >= 3u &&
                                    cfg.window <= VD_REFINE_MAX_WINDOW);
    const uint32_t rw = roi_ok ? (uint32_t)roi.w : w, rh = roi_ok ? (uint32_t)roi.h : h;

    size_t wsb = 0u;
    FZ_CHECK(vd_refine_workspace_size(rw, rh, &wsb) == VD_OK);
    const int short_ws = (flags & 2u) != 0u;
    const size_t give = short_ws ? wsb - 1u : wsb;
    void *ws = fz_alloc(give);
    const size_t mstride = rw + (flags >> 5);
    uint8_t *mbuf = fz_alloc(fz_plane_bytes(mstride, rh, rw));
    vd_image_u8_t m = {mbuf, rw, rh, mstride};
    vd_refine_stats_t stats;
    vd_status_t st = vd_refine_region(&v, (flags & 1u) ? &roi : NULL, null_cfg ? NULL : &cfg, ws, give, &m,
                                      (flags & 16u) ? NULL : &stats);
    if (!roi_ok || !cfg_ok) {
        FZ_CHECK(st == VD_ERR_ARG);
    } else if (short_ws) {
        FZ_CHECK(st == VD_ERR_WORKSPACE);
    } else {
        FZ_CHECK(st == VD_OK);
        uint32_t fg = 0u;
        for (uint32_t y = 0u; y < rh; y++) {
            for (uint32_t x = 0u; x < rw; x++) {
                const uint8_t p = mbuf[(size_t)y * mstride + x];
                FZ_CHECK(p == 0u || p == 255u);
                fg += p == 255u;
            }
        }
        if (!(flags & 16u)) {
            FZ_CHECK(stats.fg_pixels == fg && stats.edge_points <= rw * rh);
        }
        // Steps on their own: edges of the result, holes filled in place.
        vd_view_u8_t mv = vd_image_u8_view(&m);
        uint8_t *ebuf = fz_alloc((size_t)rw * rh);
        vd_image_u8_t e = {ebuf, rw, rh, rw};
        FZ_CHECK(vd_refine_edges_u8(&mv, NULL, &e) == VD_OK);
        size_t fb = 0u;
        FZ_CHECK(vd_refine_fill_holes_workspace_size(rw, rh, &fb) == VD_OK);
        void *fws = fz_alloc(fb);
        FZ_CHECK(vd_refine_fill_holes_u8(&m, fws, fb) == VD_OK);
        for (uint32_t y = 0u; y < rh; y++) {
            for (uint32_t x = 0u; x < rw; x++) {
                const uint8_t p = mbuf[(size_t)y * mstride + x];
                FZ_CHECK(p == 0u || p == 255u);
                // Filling only adds foreground, so every edge pixel is still foreground.
                FZ_CHECK(ebuf[(size_t)y * rw + x] == 0u || p == 255u);
            }
        }
        free(fws);
        free(ebuf);
    }
    // Eq. (1) on a fuzzed histogram: VD_OK gives a split between two occurring levels.
    uint64_t n = 0u;
    int levels = 0, lo = -1, hi = -1;
    for (int i = 0; i < 256; i++) {
        n += hist[i];
        if (hist[i]) {
            levels++;
            lo = lo < 0 ? i : lo;
            hi = i;
        }
    }
    uint8_t t = 0u;
    vd_status_t hs = vd_refine_maxdist_from_hist(hist, &t);
    if (n == 0u || n > VD_REFINE_MAXDIST_MAX_COUNT || levels < 2) {
        FZ_CHECK(hs == VD_ERR_RANGE);
    } else {
        FZ_CHECK(hs == VD_OK && (int)t >= lo && (int)t < hi);
    }
    free(mbuf);
    free(ws);
    free(img);
    return 0;
}
