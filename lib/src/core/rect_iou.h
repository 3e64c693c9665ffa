// SPDX-License-Identifier: MIT
// The rectangle intersection and IoU of vd/rect.h as inline functions, private to lib/: vd_rect_iou_q15 and
// vd_rect_clip are these, and a hot loop (the detector's box fusion, O(boxes^2) per frame) calls the IoU
// inline, so that the pairs that do not meet (most of them) cost a few compares and no call (perf: the
// call was ~2 % of a frame on AVX-512). int64 intermediates: no overflow on hostile boxes.
#ifndef VD_RECT_IOU_H
#define VD_RECT_IOU_H

#include <stdint.h>

#include "vd/rect.h"

// Intersection of a and b (w = h = 0 when they do not overlap).
static inline vd_rect_t vd__rect_intersect(const vd_rect_t *a, const vd_rect_t *b)
{
    vd_rect_t r = {0, 0, 0, 0};
    const int64_t x0 = a->x > b->x ? a->x : b->x;
    const int64_t y0 = a->y > b->y ? a->y : b->y;
    const int64_t x1 = (int64_t)a->x + a->w < (int64_t)b->x + b->w ? (int64_t)a->x + a->w : (int64_t)b->x + b->w;
    const int64_t y1 = (int64_t)a->y + a->h < (int64_t)b->y + b->h ? (int64_t)a->y + a->h : (int64_t)b->y + b->h;
    if (x1 > x0 && y1 > y0 && a->w > 0 && a->h > 0 && b->w > 0 && b->h > 0) {
        r.x = (int32_t)x0;
        r.y = (int32_t)y0;
        r.w = (int32_t)(x1 - x0);
        r.h = (int32_t)(y1 - y0);
    }
    return r;
}

// vd_rect_iou_q15: Q15 (0..32768), rounded down; 0 for boxes without area or without a common pixel.
static inline uint32_t vd__rect_iou_q15(const vd_rect_t *a, const vd_rect_t *b)
{
    // The pairs that do not meet first: four compares, no intersection, product or division.
    if (a->w <= 0 || a->h <= 0 || b->w <= 0 || b->h <= 0 || (int64_t)a->x + a->w <= b->x ||
        (int64_t)b->x + b->w <= a->x || (int64_t)a->y + a->h <= b->y || (int64_t)b->y + b->h <= a->y) {
        return 0u;
    }
    const vd_rect_t i = vd__rect_intersect(a, b);
    const uint64_t inter = (uint64_t)i.w * (uint64_t)i.h;
    const uint64_t uni = (uint64_t)a->w * (uint64_t)a->h + (uint64_t)b->w * (uint64_t)b->h - inter;
    // inter <= uni < 2^63, so inter << 15 fits in uint64.
    return (uint32_t)((inter << 15) / uni);
}

#endif
