// SPDX-License-Identifier: MIT
// Recorded-frame back end and image decoders: PGM (P5 8/16-bit), raw Y16/8-bit, PNG/JPEG (stb_image).
#ifndef VD_PORT_FILE_H
#define VD_PORT_FILE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "vd_port/capture.h"

#ifdef __cplusplus
extern "C" {
#endif

// Largest file the readers load (bytes). One 8192x8192 16-bit frame is 128 MiB.
#define VD_FILE_MAX_BYTES (256u * 1024u * 1024u)
// Longest path / list line accepted.
#define VD_FILE_MAX_PATH 4096u
// Most frames in one directory or list.
#define VD_FILE_MAX_FRAMES 1000000u

// How vd_file_open() interprets its argument.
typedef enum vd_file_kind {
    VD_FILE_AUTO = 0,   // directory -> DIR, "*.txt"/"*.lst" -> LIST, else SINGLE
    VD_FILE_DIR = 1,
    VD_FILE_LIST = 2,
    VD_FILE_SINGLE = 3
} vd_file_kind_t;

// Opens a recorded sequence (see vd_capture_open for the naming rules; opts supplies raw_*
// and same_size; NULL = defaults). Directories are scanned and lists read at open, files are
// decoded one by one by next(). Returns VD_OK (state OPEN); VD_ERR_ARG (NULL path, raw size
// out of range); VD_ERR_IO (cannot open/read, no frames); VD_ERR_FORMAT (list line too long);
// the error text names the path.
vd_status_t vd_file_open(vd_capture_t *cap, const char *path, vd_file_kind_t kind, const vd_capture_opts_t *opts);

// Frames a file capture (vd_file_open, or vd_capture_open on a recorded input) will hand out
// from start to end, for progress displays: one per image path, size / frame size per raw file
// (".raw", ".y16", ".gray", ".bin" with a raw size given). An estimate when a file later fails to
// decode (it is skipped) or an image file turns out to hold raw frames.
// Returns VD_OK; VD_ERR_ARG (NULL, or cap is not an open file capture, e.g. V4L2).
vd_status_t vd_file_frame_total(const vd_capture_t *cap, uint64_t *frames);

// Moves a streaming file capture (started, no frame held) `frames` frames on without reading them: image paths
// are passed over, raw frames by their count (the file's size / frame size, as vd_file_frame_total counts
// them), so next() hands out the frame that many places later, its seq counted as if the skipped ones had
// been read. Why: a measurement spread over a long recording (vd_fir_demo --cnn-full-res auto) need not
// decode the frames between its samples. Past the end: VD_ERR_RANGE with vd_capture_at_end() true.
// Returns VD_OK; VD_ERR_ARG (NULL, or not a file capture); VD_ERR_STATE (not streaming, or a frame held);
// VD_ERR_IO (a raw file to skip into cannot be opened).
vd_status_t vd_file_skip(vd_capture_t *cap, uint64_t frames);

// A decoded image: malloc'd pixels (host byte order), stride = width * bytes per pixel.
typedef struct vd_decoded {
    void *data;
    uint32_t width;
    uint32_t height;
    vd_pixfmt_t format;
} vd_decoded_t;

// Decodes one image held in memory: PGM P5 (maxval 1..255 -> U8, 256..65535 -> U16 from
// big-endian), PNG (8-bit -> U8, 16-bit -> U16; colour is converted to grey by stb_image)
// or JPEG (U8). Sample values are kept as stored (no scaling by maxval).
// err (may be NULL) receives a one-line reason on failure.
// Returns VD_OK (*out filled; free with vd_decoded_free); VD_ERR_ARG (NULL buf/out);
// VD_ERR_FORMAT (unknown magic, bad header, maxval 0 or > 65535, width/height 0 or > VD_MAX_DIM,
// truncated pixel data, decoder failure); VD_ERR_OVERFLOW (size arithmetic); VD_ERR_IO (out of memory).
vd_status_t vd_image_decode(const uint8_t *buf, size_t len, vd_decoded_t *out, char *err, size_t err_len);

// Parses only a PGM P5 header: size, maxval and the offset of the pixel data.
// Returns VD_OK; VD_ERR_ARG (NULL); VD_ERR_FORMAT (as above, also when the data is truncated);
// VD_ERR_OVERFLOW.
vd_status_t vd_pgm_parse_header(const uint8_t *buf, size_t len, uint32_t *width, uint32_t *height,
                                uint32_t *maxval, size_t *data_offset, char *err, size_t err_len);

// Splits a raw file of `len` bytes into frames of width x height samples of `format`.
// Returns VD_OK with *n_frames >= 1; VD_ERR_ARG (NULL, width/height 0 or > VD_MAX_DIM, bad
// format); VD_ERR_FORMAT (len 0 or not a multiple of the frame size); VD_ERR_OVERFLOW.
vd_status_t vd_raw_frame_count(size_t len, uint32_t width, uint32_t height, vd_pixfmt_t format,
                               size_t *n_frames, char *err, size_t err_len);

// Frees d->data and zeroes *d. NULL is ignored.
void vd_decoded_free(vd_decoded_t *d);

// Reads a whole file (at most VD_FILE_MAX_BYTES) into malloc'd memory (*buf, free() it).
// Returns VD_OK; VD_ERR_ARG; VD_ERR_IO (open/read failure, too large, out of memory).
vd_status_t vd_file_read_all(const char *path, uint8_t **buf, size_t *len, char *err, size_t err_len);

#ifdef __cplusplus
}
#endif
#endif
