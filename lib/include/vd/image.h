// SPDX-License-Identifier: MIT
// Image types (frames, 8- and 16-bit views with stride, writable images) and their checks; each
// function is named after the type it takes (vd_frame_*, vd_view_*, vd_image_*). Rectangles: rect.h.
#ifndef VD_IMAGE_H
#define VD_IMAGE_H

#include <stddef.h>
#include <stdint.h>
#include <stdbool.h>

#include "vd/config.h"
#include "vd/status.h"
#include "vd/rect.h"

#ifdef __cplusplus
extern "C" {
#endif

// Pixel formats of a frame. VD_PIX_U16 is radiometric (e.g. Y16 / TLinear)
// in host byte order; its meaning in kelvin comes from vd_calib_t (calib.h).
typedef enum vd_pixfmt {
    VD_PIX_U8 = 1,
    VD_PIX_U16 = 2
} vd_pixfmt_t;

// A read-only frame as handed out by a port: a view on the port's buffer,
// valid until the port reclaims it. `stride` is in BYTES between rows
// (>= width * bytes per pixel; for U16 it must be even).
typedef struct vd_frame {
    const void *data;
    uint32_t width;
    uint32_t height;
    size_t stride;
    vd_pixfmt_t format;
    uint32_t seq;          // sequence number from the source (gaps = drops)
    uint64_t timestamp_us; // source timestamp in microseconds, 0 if unknown
} vd_frame_t;

// Read-only 8-bit plane; stride in bytes.
typedef struct vd_view_u8 {
    const uint8_t *data;
    uint32_t width;
    uint32_t height;
    size_t stride;
} vd_view_u8_t;

// Read-only 16-bit plane; stride in BYTES (even).
typedef struct vd_view_u16 {
    const uint16_t *data;
    uint32_t width;
    uint32_t height;
    size_t stride;
} vd_view_u16_t;

// Writable 8-bit plane (masks, scratch images); stride in bytes.
typedef struct vd_image_u8 {
    uint8_t *data;
    uint32_t width;
    uint32_t height;
    size_t stride;
} vd_image_u8_t;

// Checks a view: data non-null, 1 <= width, height <= VD_MAX_DIM,
// stride >= width (bytes per pixel accounted). Returns VD_OK or VD_ERR_ARG.
VD_API vd_status_t vd_view_u8_check(const vd_view_u8_t *v);
VD_API vd_status_t vd_view_u16_check(const vd_view_u16_t *v);   // also VD_ERR_ARG for odd stride or misaligned data
VD_API vd_status_t vd_image_u8_check(const vd_image_u8_t *img);

// Checks a frame as above for its format; VD_ERR_FORMAT for an unknown format.
VD_API vd_status_t vd_frame_check(const vd_frame_t *f);

// Views of a frame's plane. VD_ERR_FORMAT if the frame is not of that format,
// VD_ERR_ARG if it fails vd_frame_check.
VD_API vd_status_t vd_frame_view_u8(const vd_frame_t *f, vd_view_u8_t *out);
VD_API vd_status_t vd_frame_view_u16(const vd_frame_t *f, vd_view_u16_t *out);

// Read-only view of a writable image (no check; the image must be valid).
static inline vd_view_u8_t vd_image_u8_view(const vd_image_u8_t *img)
{
    vd_view_u8_t v;
    v.data = img->data;
    v.width = img->width;
    v.height = img->height;
    v.stride = img->stride;
    return v;
}

#ifdef __cplusplus
}
#endif
#endif
