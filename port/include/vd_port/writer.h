// SPDX-License-Identifier: MIT
// Host-side image writers (PGM, PNG via stb_image_write) and an RGB canvas for annotated output.
#ifndef VD_PORT_WRITER_H
#define VD_PORT_WRITER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "vd/image.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Every writer writes to "<path>.tmp.<pid>" and renames it over `path` only when
// the whole image was written, so a failure never leaves a half-written file
// under the final name. `err` (may be NULL) receives a one-line reason.

// Writes a frame as binary PGM: U8 -> P5 maxval 255; U16 -> P5 maxval 65535, big-endian
// samples (the PGM rule). Returns VD_OK; VD_ERR_ARG (NULL, invalid frame); VD_ERR_IO.
vd_status_t vd_write_pgm(const char *path, const vd_frame_t *frame, char *err, size_t err_len);

// RGB canvas: 3 bytes per pixel (R, G, B), rows `stride` bytes apart. Owned by the caller;
// vd_rgb_alloc() mallocs data, vd_rgb_free() frees it.
typedef struct vd_rgb {
    uint8_t *data;
    uint32_t width;
    uint32_t height;
    size_t stride;
} vd_rgb_t;

// Allocates a width x height canvas (black). Returns VD_OK; VD_ERR_ARG (NULL, 0 or > VD_MAX_DIM);
// VD_ERR_IO (out of memory).
vd_status_t vd_rgb_alloc(vd_rgb_t *img, uint32_t width, uint32_t height);
void vd_rgb_free(vd_rgb_t *img);   // NULL and zeroed canvases are fine

// Renders a frame as grey into img (which must be frame-sized; re-use one canvas for a sequence).
// U8 is copied. U16 is mapped linearly from [lo, hi] to [0, 255] (clamped); lo == hi == 0 picks
// the frame's min and max (a flat frame gives mid grey).
// Returns VD_OK; VD_ERR_ARG (NULL, size mismatch, lo > hi, invalid frame); VD_ERR_FORMAT.
vd_status_t vd_rgb_from_frame(vd_rgb_t *img, const vd_frame_t *frame, uint32_t lo, uint32_t hi);

// Draws the outline of r (clipped to the canvas), `thickness` pixels wide, inwards.
void vd_rgb_draw_rect(vd_rgb_t *img, const vd_rect_t *r, uint8_t red, uint8_t green, uint8_t blue, uint32_t thickness);

// Draws text with a 3x5 pixel font scaled by `scale` (>= 1), top-left at (x, y), clipped.
// Glyphs: 0-9, A-Z (lower case is drawn as upper case), space . , : - + % # / = ( ) _;
// other characters are drawn as a box.
void vd_rgb_draw_text(vd_rgb_t *img, int32_t x, int32_t y, const char *text, uint8_t red, uint8_t green,
                      uint8_t blue, uint32_t scale);

// Writes the canvas as an 8-bit RGB PNG. Returns VD_OK; VD_ERR_ARG; VD_ERR_IO (also when
// built without stb_image_write).
vd_status_t vd_write_png_rgb(const char *path, const vd_rgb_t *img, char *err, size_t err_len);

// Writes a U8 frame as an 8-bit grey PNG (U16: VD_ERR_FORMAT; use vd_write_pgm or render it
// with vd_rgb_from_frame). Returns VD_OK; VD_ERR_ARG; VD_ERR_FORMAT; VD_ERR_IO.
vd_status_t vd_write_png_grey(const char *path, const vd_frame_t *frame, char *err, size_t err_len);

#ifdef __cplusplus
}
#endif
#endif
