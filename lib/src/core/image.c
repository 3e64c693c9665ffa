// SPDX-License-Identifier: MIT
// Checks of image views and frames. O(1) each.
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
