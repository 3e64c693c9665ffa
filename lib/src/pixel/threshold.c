// SPDX-License-Identifier: MIT
// Hot-spot thresholds: constant on 8-bit and 16-bit planes, radiometric, percentile.
//
// Algorithm: one comparison per pixel, written branch-free
// (mask = 0 - (pixel >= thr)) so compilers vectorise the row loop. The
// radiometric threshold is turned into one raw threshold once per call
// (vd_calib_raw_from_ck, closed form, calib.c), so the per-pixel cost is the
// same as for raw input. Reference: paper 001 (constant threshold 150, ~30 degC).
// The percentile threshold walks the cumulative histogram once (256 steps).
// Bounds: time O(roi.w * roi.h); stack < 100 bytes; no workspace.
#include <string.h>

#include "vd/threshold.h"
#include "internal/vd_internal.h"

// Common checks: valid views, ROI inside src, dst exactly ROI-sized.
static vd_status_t check_dst(const vd_rect_t *r, const vd_image_u8_t *dst)
{
    VD_TRY(vd_image_u8_check(dst));
    VD_VERIFY(dst->width == (uint32_t)r->w && dst->height == (uint32_t)r->h, VD_ERR_ARG);
    return VD_OK;
}

vd_status_t vd_threshold_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint8_t thr, vd_image_u8_t *dst)
{
    vd_rect_t r;
    VD_TRY(vd_view_u8_check(src));
    VD_TRY(vd_rect_roi_resolve(roi, src->width, src->height, &r));
    VD_TRY(check_dst(&r, dst));
    const size_t w = (size_t)r.w;
    const uint8_t *s = src->data + (size_t)r.y * src->stride + (size_t)r.x;
    uint8_t *d = dst->data;
    for (int32_t y = 0; y < r.h; y++) {
        for (size_t x = 0; x < w; x++) {
            d[x] = (uint8_t)(0u - (uint32_t)(s[x] >= thr));
        }
        s += src->stride;
        d += dst->stride;
    }
    return VD_OK;
}

vd_status_t vd_threshold_u16(const vd_view_u16_t *src, const vd_rect_t *roi, uint16_t thr_raw, vd_image_u8_t *dst)
{
    vd_rect_t r;
    VD_TRY(vd_view_u16_check(src));
    VD_TRY(vd_rect_roi_resolve(roi, src->width, src->height, &r));
    VD_TRY(check_dst(&r, dst));
    const size_t w = (size_t)r.w;
    // Stride is in bytes and even (checked), so stride / 2 elements per row.
    const size_t step = src->stride / 2u;
    const uint16_t *s = src->data + (size_t)r.y * step + (size_t)r.x;
    uint8_t *d = dst->data;
    for (int32_t y = 0; y < r.h; y++) {
        for (size_t x = 0; x < w; x++) {
            d[x] = (uint8_t)(0u - (uint32_t)(s[x] >= thr_raw));
        }
        s += step;
        d += dst->stride;
    }
    return VD_OK;
}

vd_status_t vd_threshold_u16_ck(const vd_view_u16_t *src, const vd_rect_t *roi, const vd_calib_t *cal,
                                int32_t thr_ck, vd_image_u8_t *dst)
{
    uint16_t thr_raw = 0u;
    VD_VERIFY(cal != NULL, VD_ERR_ARG);
    vd_status_t st = vd_calib_raw_from_ck(cal, thr_ck, &thr_raw);
    if (st == VD_ERR_RANGE) {
        // Hotter than any raw value can be: every pixel is below. Check the
        // arguments as the raw path would, then clear the ROI-sized mask.
        vd_rect_t r;
        VD_TRY(vd_view_u16_check(src));
        VD_TRY(vd_rect_roi_resolve(roi, src->width, src->height, &r));
        VD_TRY(check_dst(&r, dst));
        uint8_t *d = dst->data;
        for (int32_t y = 0; y < r.h; y++) {
            memset(d, 0, (size_t)r.w);
            d += dst->stride;
        }
        return VD_OK;
    }
    VD_TRY(st);
    return vd_threshold_u16(src, roi, thr_raw, dst);
}

vd_status_t vd_threshold_percentile_u8(const uint32_t hist[256], uint32_t permille, uint8_t floor_u8, uint8_t *thr)
{
    VD_VERIFY(hist != NULL && thr != NULL, VD_ERR_ARG);
    VD_VERIFY(permille <= 1000u, VD_ERR_ARG);
    uint64_t n = 0u;
    for (uint32_t i = 0; i < 256u; i++) {
        n += hist[i];
    }
    const uint64_t target = (n * permille + 999u) / 1000u;
    uint64_t cum = 0u;
    uint32_t t = 255u;
    for (uint32_t i = 0; i < 256u; i++) {
        cum += hist[i];
        if (cum >= target) {
            t = i;
            break;
        }
    }
    *thr = (t > floor_u8) ? (uint8_t)t : floor_u8;
    return VD_OK;
}
