// SPDX-License-Identifier: MIT
// Checks and small geometry on image views and rectangles. O(1) each.
#include "vd/image.h"
#include "internal/vd_internal.h"

static vd_status_t check_plane(const void *data, uint32_t w, uint32_t h, size_t stride, size_t bpp)
{
    size_t row;
    VD_VERIFY(data != NULL, VD_ERR_ARG);
    VD_VERIFY(w >= 1u && h >= 1u && w <= VD_MAX_DIM && h <= VD_MAX_DIM, VD_ERR_ARG);
    VD_VERIFY(vd_mul_size((size_t)w, bpp, &row), VD_ERR_OVERFLOW);
    VD_VERIFY(stride >= row, VD_ERR_ARG);
    // The last byte addressed is stride*(h-1)+row-1: it must be representable.
    size_t span;
    VD_VERIFY(vd_mul_size(stride, (size_t)h - 1u, &span) && vd_add_size(span, row, &span), VD_ERR_OVERFLOW);
    return VD_OK;
}

vd_status_t vd_view_u8_check(const vd_view_u8_t *v)
{
    VD_VERIFY(v != NULL, VD_ERR_ARG);
    return check_plane(v->data, v->width, v->height, v->stride, 1u);
}

vd_status_t vd_view_u16_check(const vd_view_u16_t *v)
{
    VD_VERIFY(v != NULL, VD_ERR_ARG);
    VD_VERIFY((v->stride & 1u) == 0u, VD_ERR_ARG);
    VD_VERIFY(((uintptr_t)v->data & 1u) == 0u, VD_ERR_ARG);
    return check_plane(v->data, v->width, v->height, v->stride, 2u);
}

vd_status_t vd_image_u8_check(const vd_image_u8_t *img)
{
    VD_VERIFY(img != NULL, VD_ERR_ARG);
    return check_plane(img->data, img->width, img->height, img->stride, 1u);
}

vd_status_t vd_frame_check(const vd_frame_t *f)
{
    VD_VERIFY(f != NULL, VD_ERR_ARG);
    if (f->format == VD_PIX_U8) {
        return check_plane(f->data, f->width, f->height, f->stride, 1u);
    }
    if (f->format == VD_PIX_U16) {
        VD_VERIFY((f->stride & 1u) == 0u && ((uintptr_t)f->data & 1u) == 0u, VD_ERR_ARG);
        return check_plane(f->data, f->width, f->height, f->stride, 2u);
    }
    return VD_ERR_FORMAT;
}

vd_status_t vd_frame_view_u8(const vd_frame_t *f, vd_view_u8_t *out)
{
    VD_VERIFY(f != NULL && out != NULL, VD_ERR_ARG);
    VD_VERIFY(f->format == VD_PIX_U8, VD_ERR_FORMAT);
    VD_TRY(vd_frame_check(f));
    out->data = (const uint8_t *)f->data;
    out->width = f->width;
    out->height = f->height;
    out->stride = f->stride;
    return VD_OK;
}

vd_status_t vd_frame_view_u16(const vd_frame_t *f, vd_view_u16_t *out)
{
    VD_VERIFY(f != NULL && out != NULL, VD_ERR_ARG);
    VD_VERIFY(f->format == VD_PIX_U16, VD_ERR_FORMAT);
    VD_TRY(vd_frame_check(f));
    out->data = (const uint16_t *)f->data;
    out->width = f->width;
    out->height = f->height;
    out->stride = f->stride;
    return VD_OK;
}

vd_status_t vd_roi_resolve(const vd_rect_t *roi, uint32_t width, uint32_t height, vd_rect_t *out)
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

vd_rect_t vd_rect_intersect(const vd_rect_t *a, const vd_rect_t *b)
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
    *r = vd_rect_intersect(r, &frame);
    return r->w > 0 && r->h > 0;
}

uint32_t vd_rect_iou_q15(const vd_rect_t *a, const vd_rect_t *b)
{
    if (a->w <= 0 || a->h <= 0 || b->w <= 0 || b->h <= 0) {
        return 0u;
    }
    vd_rect_t i = vd_rect_intersect(a, b);
    uint64_t inter = (uint64_t)i.w * (uint64_t)i.h;
    uint64_t uni = (uint64_t)a->w * (uint64_t)a->h + (uint64_t)b->w * (uint64_t)b->h - inter;
    // inter <= uni < 2^63, so inter << 15 fits in uint64.
    return (uint32_t)((inter << 15) / uni);
}
