// SPDX-License-Identifier: MIT
// Constant thresholds on 8-bit and 16-bit planes and the linear radiometric calibration.
//
// Algorithm: one comparison per pixel, written branch-free
// (mask = 0 - (pixel >= thr)) so compilers vectorise the row loop. The
// radiometric threshold is turned into one raw threshold once per call
// (vd_calib_raw_from_ck, closed form), so the per-pixel cost is the same as
// for raw input. Reference: paper 001 (constant threshold 150, ~30 degC).
// The percentile threshold walks the cumulative histogram once (256 steps).
// The temperature -> grey map is ((T - lo) * mul_q16 + 2^15) >> 16 with
// mul_q16 = round(255 * 2^16 / (hi - lo)) (one multiply per pixel instead of
// a division), clamped to 0..255; the shift is a floor shift
// (internal/shift_internal.h) because T - lo may be negative.
// Bounds: time O(roi.w * roi.h); stack < 100 bytes; no workspace.
// Arithmetic: raw * gain_q16 < 2^16 * 2^31 = 2^47 and ck - offset_ck is in
// +-2^32, so (ck - offset_ck) * 65536 < 2^49: all in int64_t; in the grey
// map |T - lo| < 2^32 and mul_q16 <= 255 * 2^16 < 2^24, product < 2^56.
#include <string.h>

#include "vd/threshold.h"
#include "internal/shift_internal.h"
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
    VD_TRY(vd_roi_resolve(roi, src->width, src->height, &r));
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
    VD_TRY(vd_roi_resolve(roi, src->width, src->height, &r));
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

vd_status_t vd_calib_ck_from_raw(const vd_calib_t *cal, uint16_t raw, int32_t *ck)
{
    VD_VERIFY(cal != NULL && ck != NULL, VD_ERR_ARG);
    VD_VERIFY(cal->gain_q16 >= 0, VD_ERR_ARG);
    int64_t t = (int64_t)cal->offset_ck + vd_shr_round_i64((int64_t)raw * (int64_t)cal->gain_q16, 16u);
    VD_VERIFY(t >= (int64_t)INT32_MIN && t <= (int64_t)INT32_MAX, VD_ERR_RANGE);
    *ck = (int32_t)t;
    return VD_OK;
}

// Smallest raw with offset + floor((raw * g + 2^15) / 2^16) >= ck, for ck as int64.
// floor(v / 2^16) >= k  <=>  v >= k * 2^16 for integer k, so the condition is
// raw * g >= k * 2^16 - 2^15 with k = ck - offset: a ceiling division.
static vd_status_t raw_from_ck64(const vd_calib_t *cal, int64_t ck, uint16_t *raw)
{
    VD_VERIFY(cal != NULL && raw != NULL, VD_ERR_ARG);
    VD_VERIFY(cal->gain_q16 >= 0, VD_ERR_ARG);
    const int64_t need = (ck - (int64_t)cal->offset_ck) * 65536 - 32768;
    if (need <= 0) {
        *raw = 0u; // raw 0 is already hot enough
        return VD_OK;
    }
    VD_VERIFY(cal->gain_q16 > 0, VD_ERR_RANGE); // constant temperature below ck
    const int64_t g = (int64_t)cal->gain_q16;
    const int64_t r = (need + g - 1) / g;
    VD_VERIFY(r <= 65535, VD_ERR_RANGE);
    *raw = (uint16_t)r;
    return VD_OK;
}

vd_status_t vd_calib_raw_from_ck(const vd_calib_t *cal, int32_t ck, uint16_t *raw)
{
    return raw_from_ck64(cal, (int64_t)ck, raw);
}

vd_status_t vd_calib_raw_from_centi_celsius(const vd_calib_t *cal, int32_t centi_c, uint16_t *raw)
{
    return raw_from_ck64(cal, (int64_t)centi_c + VD_CK_PER_0C, raw);
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
        VD_TRY(vd_roi_resolve(roi, src->width, src->height, &r));
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

vd_status_t vd_calib_grey_init(vd_calib_grey_t *map, const vd_calib_t *cal, int32_t lo_ck, int32_t hi_ck)
{
    VD_VERIFY(map != NULL && cal != NULL, VD_ERR_ARG);
    VD_VERIFY(cal->gain_q16 >= 0 && lo_ck < hi_ck, VD_ERR_ARG);
    const int64_t span = (int64_t)hi_ck - lo_ck;
    map->calib = *cal;
    map->lo_ck = lo_ck;
    map->hi_ck = hi_ck;
    map->mul_q16 = ((int64_t)255 * 65536 + span / 2) / span;
    return VD_OK;
}

uint8_t vd_calib_grey_u8(const vd_calib_grey_t *map, uint16_t raw)
{
    int32_t ck = 0;
    (void)vd_calib_ck_from_raw(&map->calib, raw, &ck);   // out of int32: ck stays 0 (documented)
    const int64_t g = vd_shr_round_i64(((int64_t)ck - map->lo_ck) * map->mul_q16, 16u);
    if (g < 0) {
        return 0u;
    }
    return (g > 255) ? 255u : (uint8_t)g;
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
