// SPDX-License-Identifier: MIT
// Rectangle helpers: ROI resolution, clipping, IoU (O(1) each) and the paper's candidate-box
// expansion (paper 001 section 3, step 1). int64 intermediates: no overflow on hostile boxes.
#include "vd/rect.h"
#include "internal/shift_internal.h"
#include "internal/vd_internal.h"

vd_status_t vd_rect_roi_resolve(const vd_rect_t *roi, uint32_t width, uint32_t height, vd_rect_t *out)
{
    VD_VERIFY(out != NULL, VD_ERR_ARG);
    VD_VERIFY(width >= 1u && height >= 1u && width <= VD_MAX_DIM && height <= VD_MAX_DIM, VD_ERR_ARG);
    if (roi == NULL) {
        out->x = 0;
        out->y = 0;
        out->w = (int32_t)width;
        out->h = (int32_t)height;
        return VD_OK;
    }
    VD_VERIFY(roi->x >= 0 && roi->y >= 0 && roi->w > 0 && roi->h > 0, VD_ERR_ARG);
    // Compare in int64 so x + w cannot overflow for hostile values.
    VD_VERIFY((int64_t)roi->x + (int64_t)roi->w <= (int64_t)width, VD_ERR_ARG);
    VD_VERIFY((int64_t)roi->y + (int64_t)roi->h <= (int64_t)height, VD_ERR_ARG);
    *out = *roi;
    return VD_OK;
}

// Intersection of a and b (w = h = 0 when they do not overlap).
static vd_rect_t rect_intersect(const vd_rect_t *a, const vd_rect_t *b)
{
    vd_rect_t r = {0, 0, 0, 0};
    int64_t x0 = a->x > b->x ? a->x : b->x;
    int64_t y0 = a->y > b->y ? a->y : b->y;
    int64_t x1 = (int64_t)a->x + a->w < (int64_t)b->x + b->w ? (int64_t)a->x + a->w : (int64_t)b->x + b->w;
    int64_t y1 = (int64_t)a->y + a->h < (int64_t)b->y + b->h ? (int64_t)a->y + a->h : (int64_t)b->y + b->h;
    if (x1 > x0 && y1 > y0 && a->w > 0 && a->h > 0 && b->w > 0 && b->h > 0) {
        r.x = (int32_t)x0;
        r.y = (int32_t)y0;
        r.w = (int32_t)(x1 - x0);
        r.h = (int32_t)(y1 - y0);
    }
    return r;
}

bool vd_rect_clip(vd_rect_t *r, uint32_t width, uint32_t height)
{
    vd_rect_t frame = {0, 0, (int32_t)width, (int32_t)height};
    *r = rect_intersect(r, &frame);
    return r->w > 0 && r->h > 0;
}

uint32_t vd_rect_iou_q15(const vd_rect_t *a, const vd_rect_t *b)
{
    if (a->w <= 0 || a->h <= 0 || b->w <= 0 || b->h <= 0) {
        return 0u;
    }
    vd_rect_t i = rect_intersect(a, b);
    uint64_t inter = (uint64_t)i.w * (uint64_t)i.h;
    if (inter == 0u) {
        return 0u;   // most pairs the fusion and suppression compare: no 64-bit division for them
    }
    uint64_t uni = (uint64_t)a->w * (uint64_t)a->h + (uint64_t)b->w * (uint64_t)b->h - inter;
    // inter <= uni < 2^63, so inter << 15 fits in uint64.
    return (uint32_t)((inter << 15) / uni);
}

// One axis of vd_rect_expand: [*pos, *pos + *len) scaled by s_q8 about its
// centre and clipped to [0, limit). false if nothing is left. int64 holds
// every intermediate: |pos| < 2^31, len * s_q8 < 2^47.
static bool expand_axis(int32_t pos, int32_t len, uint16_t s_q8, uint32_t limit, int32_t *opos, int32_t *olen)
{
    int64_t nl = ((int64_t)len * (int64_t)s_q8 * 2 + 256) / 512; // round-half-up(len * s / 256)
    if (nl < 1) {
        nl = 1;
    }
    const int64_t g = nl - (int64_t)len;
    const int64_t left = vd_shr_floor_i64(g, 1u); // floor(g / 2), g may be negative
    int64_t lo = (int64_t)pos - left;
    int64_t hi = lo + nl; // exclusive
    if (lo < 0) {
        lo = 0;
    }
    if (hi > (int64_t)limit) {
        hi = (int64_t)limit;
    }
    if (hi <= lo) {
        return false;
    }
    *opos = (int32_t)lo;
    *olen = (int32_t)(hi - lo);
    return true;
}

vd_status_t vd_rect_expand(const vd_rect_t *in, uint16_t wscale_q8, uint16_t hscale_q8, uint32_t frame_w,
                           uint32_t frame_h, vd_rect_t *out)
{
    VD_VERIFY(in != NULL && out != NULL, VD_ERR_ARG);
    VD_VERIFY(in->w > 0 && in->h > 0 && wscale_q8 > 0u && hscale_q8 > 0u, VD_ERR_ARG);
    VD_VERIFY(frame_w >= 1u && frame_h >= 1u && frame_w <= VD_MAX_DIM && frame_h <= VD_MAX_DIM, VD_ERR_ARG);
    vd_rect_t res;
    VD_VERIFY(expand_axis(in->x, in->w, wscale_q8, frame_w, &res.x, &res.w), VD_ERR_ARG);
    VD_VERIFY(expand_axis(in->y, in->h, hscale_q8, frame_h, &res.y, &res.h), VD_ERR_ARG);
    *out = res;
    return VD_OK;
}
