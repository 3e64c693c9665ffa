// SPDX-License-Identifier: MIT
// Image views (8- and 16-bit, with stride), rectangles, and their checks.
#ifndef VD_IMAGE_H
#define VD_IMAGE_H

#include <stddef.h>
#include <stdint.h>
#include <stdbool.h>

#include "vd/config.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Pixel formats of a frame. VD_PIX_U16 is radiometric (e.g. Y16 / TLinear)
// in host byte order; its meaning in kelvin comes from vd_calib_t (threshold.h).
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

// Axis-aligned box in pixels, top-left origin; w, h > 0 for a valid box.
typedef struct vd_rect {
    int32_t x;
    int32_t y;
    int32_t w;
    int32_t h;
} vd_rect_t;

typedef struct vd_point {
    int16_t x;
    int16_t y;
} vd_point_t;

// Checks a view: data non-null, 1 <= width, height <= VD_MAX_DIM,
// stride >= width (bytes per pixel accounted). Returns VD_OK or VD_ERR_ARG.
vd_status_t vd_view_u8_check(const vd_view_u8_t *v);
vd_status_t vd_view_u16_check(const vd_view_u16_t *v);   // also VD_ERR_ARG for odd stride or misaligned data
vd_status_t vd_image_u8_check(const vd_image_u8_t *img);

// Checks a frame as above for its format; VD_ERR_FORMAT for an unknown format.
vd_status_t vd_frame_check(const vd_frame_t *f);

// Views of a frame's plane. VD_ERR_FORMAT if the frame is not of that format,
// VD_ERR_ARG if it fails vd_frame_check.
vd_status_t vd_frame_view_u8(const vd_frame_t *f, vd_view_u8_t *out);
vd_status_t vd_frame_view_u16(const vd_frame_t *f, vd_view_u16_t *out);

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

// Resolves an optional region of interest: roi == NULL means the whole
// width x height plane. VD_ERR_ARG if roi has w or h <= 0 or does not lie
// entirely inside [0, width) x [0, height). On success *out is the region.
vd_status_t vd_roi_resolve(const vd_rect_t *roi, uint32_t width, uint32_t height, vd_rect_t *out);

// Intersection of a and b (w = h = 0 when they do not overlap).
vd_rect_t vd_rect_intersect(const vd_rect_t *a, const vd_rect_t *b);

// Clips r to [0,width) x [0,height); false if nothing is left.
bool vd_rect_clip(vd_rect_t *r, uint32_t width, uint32_t height);

// Intersection over union as a Q15 fraction (0..32768), rounded down.
// Boxes with no area give 0.
uint32_t vd_rect_iou_q15(const vd_rect_t *a, const vd_rect_t *b);

#ifdef __cplusplus
}
#endif
#endif
