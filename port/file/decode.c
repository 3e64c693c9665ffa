// SPDX-License-Identifier: MIT
// Image decoders of the file back end: PGM P5 (8/16-bit), raw frame counting, PNG/JPEG through stb_image.
//
// PGM follows the Netpbm "pgm" specification: "P5", whitespace, width,
// whitespace, height, whitespace, maxval (1..65535), ONE whitespace byte, then
// width*height samples, 1 byte each if maxval < 256 else 2 bytes big-endian;
// '#' comments run to the end of the line and may appear wherever whitespace
// may. Every number, size product and remaining length is checked before use.
// Bounds: O(header + pixels) time, O(1) stack, one malloc of the pixel plane.
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "vd_port/file.h"
#include "port_err.h"

#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#if defined(VD_PORT_HAVE_STB)
#include <stb_image.h>
#endif


static bool is_ws(uint8_t c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r';
}

// Skips whitespace and comments; returns the new position (<= len).
static size_t skip_ws(const uint8_t *buf, size_t len, size_t pos)
{
    while (pos < len) {
        if (is_ws(buf[pos])) {
            pos++;
        } else if (buf[pos] == '#') {
            while (pos < len && buf[pos] != '\n' && buf[pos] != '\r') {
                pos++;
            }
        } else {
            break;
        }
    }
    return pos;
}

// Reads a decimal number (at most 9 digits, so no overflow). 0 on success.
static int read_uint(const uint8_t *buf, size_t len, size_t *pos, uint32_t *out)
{
    size_t p = *pos;
    uint32_t v = 0u;
    uint32_t digits = 0u;
    while (p < len && buf[p] >= '0' && buf[p] <= '9') {
        if (digits == 9u) {
            return -2;
        }
        v = v * 10u + (uint32_t)(buf[p] - '0');
        digits++;
        p++;
    }
    if (digits == 0u) {
        return -1;
    }
    *pos = p;
    *out = v;
    return 0;
}

vd_status_t vd_pgm_parse_header(const uint8_t *buf, size_t len, uint32_t *width, uint32_t *height,
                                uint32_t *maxval, size_t *data_offset, char *err, size_t err_len)
{
    if (buf == NULL || width == NULL || height == NULL || maxval == NULL || data_offset == NULL) {
        vd_port_set_err(err, err_len, "PGM: NULL argument");
        return VD_ERR_ARG;
    }
    if (len < 2u || buf[0] != 'P' || buf[1] != '5') {
        vd_port_set_err(err, err_len, "not a binary PGM (magic must be \"P5\")");
        return VD_ERR_FORMAT;
    }
    static const char *const names[3] = {"width", "height", "maxval"};
    uint32_t vals[3] = {0u, 0u, 0u};
    size_t pos = 2u;
    for (int i = 0; i < 3; i++) {
        size_t before = pos;
        pos = skip_ws(buf, len, pos);
        if (pos >= len) {
            vd_port_set_err(err, err_len, "PGM header truncated before %s", names[i]);
            return VD_ERR_FORMAT;
        }
        if (pos == before) {
            vd_port_set_err(err, err_len, "PGM header: no whitespace before %s", names[i]);
            return VD_ERR_FORMAT;
        }
        int r = read_uint(buf, len, &pos, &vals[i]);
        if (r == -2) {
            vd_port_set_err(err, err_len, "PGM header: %s has too many digits", names[i]);
            return VD_ERR_FORMAT;
        }
        if (r != 0) {
            vd_port_set_err(err, err_len, "PGM header: %s is not a number (byte 0x%02x at offset %zu)", names[i],
                    (unsigned)buf[pos], pos);
            return VD_ERR_FORMAT;
        }
    }
    if (pos >= len || !is_ws(buf[pos])) {
        vd_port_set_err(err, err_len, "PGM header: %s", pos >= len ? "truncated after maxval" : "no whitespace after maxval");
        return VD_ERR_FORMAT;
    }
    pos++;   // exactly one whitespace byte before the samples
    if (vals[0] == 0u || vals[1] == 0u || vals[0] > VD_MAX_DIM || vals[1] > VD_MAX_DIM) {
        vd_port_set_err(err, err_len, "PGM size %ux%u outside 1..%u", (unsigned)vals[0], (unsigned)vals[1], (unsigned)VD_MAX_DIM);
        return VD_ERR_FORMAT;
    }
    if (vals[2] == 0u || vals[2] > 65535u) {
        vd_port_set_err(err, err_len, "PGM maxval %u outside 1..65535", (unsigned)vals[2]);
        return VD_ERR_FORMAT;
    }
    size_t bpp = vals[2] < 256u ? 1u : 2u;
    size_t bytes;
    if ((size_t)vals[0] > SIZE_MAX / (size_t)vals[1] || (size_t)vals[0] * (size_t)vals[1] > SIZE_MAX / bpp) {
        vd_port_set_err(err, err_len, "PGM size %ux%u overflows", (unsigned)vals[0], (unsigned)vals[1]);
        return VD_ERR_OVERFLOW;
    }
    bytes = (size_t)vals[0] * (size_t)vals[1] * bpp;
    if (len - pos < bytes) {
        vd_port_set_err(err, err_len, "PGM pixel data truncated: %zu of %zu bytes", len - pos, bytes);
        return VD_ERR_FORMAT;
    }
    *width = vals[0];
    *height = vals[1];
    *maxval = vals[2];
    *data_offset = pos;
    return VD_OK;
}

static vd_status_t decode_pgm(const uint8_t *buf, size_t len, vd_decoded_t *out, char *err, size_t err_len)
{
    uint32_t w;
    uint32_t h;
    uint32_t maxval;
    size_t off;
    vd_status_t st = vd_pgm_parse_header(buf, len, &w, &h, &maxval, &off, err, err_len);
    if (st != VD_OK) {
        return st;
    }
    size_t n = (size_t)w * (size_t)h;   // checked by the header parser
    if (maxval < 256u) {
        uint8_t *px = (uint8_t *)malloc(n);
        if (px == NULL) {
            vd_port_set_err(err, err_len, "out of memory for a %ux%u frame", (unsigned)w, (unsigned)h);
            return VD_ERR_IO;
        }
        memcpy(px, buf + off, n);
        out->data = px;
        out->format = VD_PIX_U8;
    } else {
        uint16_t *px = (uint16_t *)malloc(n * 2u);
        if (px == NULL) {
            vd_port_set_err(err, err_len, "out of memory for a %ux%u frame", (unsigned)w, (unsigned)h);
            return VD_ERR_IO;
        }
        const uint8_t *s = buf + off;
        for (size_t i = 0; i < n; i++) {
            px[i] = (uint16_t)(((uint32_t)s[2u * i] << 8) | (uint32_t)s[2u * i + 1u]);   // big-endian -> host
        }
        out->data = px;
        out->format = VD_PIX_U16;
    }
    out->width = w;
    out->height = h;
    return VD_OK;
}

static bool is_png(const uint8_t *b, size_t len)
{
    static const uint8_t sig[8] = {0x89u, 'P', 'N', 'G', 0x0Du, 0x0Au, 0x1Au, 0x0Au};
    return len >= 8u && memcmp(b, sig, 8u) == 0;
}

static bool is_jpeg(const uint8_t *b, size_t len)
{
    return len >= 3u && b[0] == 0xFFu && b[1] == 0xD8u && b[2] == 0xFFu;
}

static vd_status_t decode_stb(const uint8_t *buf, size_t len, vd_decoded_t *out, char *err, size_t err_len)
{
    const char *kind = is_png(buf, len) ? "PNG" : "JPEG";
#if defined(VD_PORT_HAVE_STB)
    if (len > (size_t)INT_MAX) {
        vd_port_set_err(err, err_len, "%s too large (%zu bytes)", kind, len);
        return VD_ERR_FORMAT;
    }
    int w = 0;
    int h = 0;
    int comp = 0;
    if (!stbi_info_from_memory(buf, (int)len, &w, &h, &comp)) {
        const char *why = stbi_failure_reason();
        vd_port_set_err(err, err_len, "%s header: %s", kind, why != NULL ? why : "unreadable");
        return VD_ERR_FORMAT;
    }
    if (w <= 0 || h <= 0 || (uint32_t)w > VD_MAX_DIM || (uint32_t)h > VD_MAX_DIM) {
        vd_port_set_err(err, err_len, "%s size %dx%d outside 1..%u", kind, w, h, (unsigned)VD_MAX_DIM);
        return VD_ERR_FORMAT;
    }
    bool wide = stbi_is_16_bit_from_memory(buf, (int)len) != 0;
    int dw = 0;
    int dh = 0;
    void *pix = wide ? (void *)stbi_load_16_from_memory(buf, (int)len, &dw, &dh, &comp, 1)
                     : (void *)stbi_load_from_memory(buf, (int)len, &dw, &dh, &comp, 1);
    if (pix == NULL) {
        const char *why = stbi_failure_reason();
        vd_port_set_err(err, err_len, "%s decode: %s", kind, why != NULL ? why : "failed");
        return VD_ERR_FORMAT;
    }
    if (dw != w || dh != h) {
        stbi_image_free(pix);
        vd_port_set_err(err, err_len, "%s decode: size changed while decoding", kind);
        return VD_ERR_FORMAT;
    }
    size_t bytes = (size_t)w * (size_t)h * (wide ? 2u : 1u);   // <= 2^27
    void *copy = malloc(bytes);
    if (copy == NULL) {
        stbi_image_free(pix);
        vd_port_set_err(err, err_len, "out of memory for a %dx%d frame", w, h);
        return VD_ERR_IO;
    }
    memcpy(copy, pix, bytes);   // own the plane with malloc so vd_decoded_free() is plain free()
    stbi_image_free(pix);
    out->data = copy;
    out->width = (uint32_t)w;
    out->height = (uint32_t)h;
    out->format = wide ? VD_PIX_U16 : VD_PIX_U8;
    return VD_OK;
#else
    (void)out;
    vd_port_set_err(err, err_len, "%s support not built (stb_image not found)", kind);
    return VD_ERR_FORMAT;
#endif
}

vd_status_t vd_image_decode(const uint8_t *buf, size_t len, vd_decoded_t *out, char *err, size_t err_len)
{
    if (out == NULL) {
        vd_port_set_err(err, err_len, "decode: NULL output");
        return VD_ERR_ARG;
    }
    memset(out, 0, sizeof(*out));
    if (buf == NULL) {
        vd_port_set_err(err, err_len, "decode: NULL buffer");
        return VD_ERR_ARG;
    }
    if (len == 0u) {
        vd_port_set_err(err, err_len, "empty file");
        return VD_ERR_FORMAT;
    }
    if (len >= 2u && buf[0] == 'P' && buf[1] == '5') {
        return decode_pgm(buf, len, out, err, err_len);
    }
    if (len >= 2u && buf[0] == 'P' && buf[1] >= '1' && buf[1] <= '7') {
        vd_port_set_err(err, err_len, "Netpbm P%c is not supported (only binary greymap P5)", (char)buf[1]);
        return VD_ERR_FORMAT;
    }
    if (is_png(buf, len) || is_jpeg(buf, len)) {
        return decode_stb(buf, len, out, err, err_len);
    }
    vd_port_set_err(err, err_len, "unknown image format (not PGM P5, PNG or JPEG)");
    return VD_ERR_FORMAT;
}

vd_status_t vd_raw_frame_count(size_t len, uint32_t width, uint32_t height, vd_pixfmt_t format,
                               size_t *n_frames, char *err, size_t err_len)
{
    if (n_frames == NULL || width == 0u || height == 0u || width > VD_MAX_DIM || height > VD_MAX_DIM ||
        (format != VD_PIX_U8 && format != VD_PIX_U16)) {
        vd_port_set_err(err, err_len, "raw: bad arguments (size %ux%u, format %d)", (unsigned)width, (unsigned)height, (int)format);
        return VD_ERR_ARG;
    }
    size_t fb = (size_t)width * (size_t)height * (format == VD_PIX_U16 ? 2u : 1u);   // <= 2^27
    if (len == 0u) {
        vd_port_set_err(err, err_len, "raw file is empty");
        return VD_ERR_FORMAT;
    }
    if (len % fb != 0u) {
        vd_port_set_err(err, err_len, "raw file size %zu is not a multiple of the %ux%u frame size %zu", len, (unsigned)width,
                (unsigned)height, fb);
        return VD_ERR_FORMAT;
    }
    *n_frames = len / fb;
    return VD_OK;
}

void vd_decoded_free(vd_decoded_t *d)
{
    if (d == NULL) {
        return;
    }
    free(d->data);
    memset(d, 0, sizeof(*d));
}

vd_status_t vd_file_read_all(const char *path, uint8_t **buf, size_t *len, char *err, size_t err_len)
{
    if (path == NULL || buf == NULL || len == NULL) {
        vd_port_set_err(err, err_len, "read: NULL argument");
        return VD_ERR_ARG;
    }
    *buf = NULL;
    *len = 0u;
    FILE *fp = fopen(path, "rb");
    if (fp == NULL) {
        vd_port_set_err(err, err_len, "%s: cannot open: %s", path, strerror(errno));
        return VD_ERR_IO;
    }
    struct stat sb;
    if (fstat(fileno(fp), &sb) != 0 || !S_ISREG(sb.st_mode)) {
        (void)fclose(fp);
        vd_port_set_err(err, err_len, "%s: not a regular file", path);
        return VD_ERR_IO;
    }
    if (sb.st_size < 0 || (uint64_t)sb.st_size > (uint64_t)VD_FILE_MAX_BYTES) {
        (void)fclose(fp);
        vd_port_set_err(err, err_len, "%s: file too large (%lld bytes, limit %u)", path, (long long)sb.st_size,
                (unsigned)VD_FILE_MAX_BYTES);
        return VD_ERR_IO;
    }
    size_t n = (size_t)sb.st_size;
    uint8_t *p = (uint8_t *)malloc(n != 0u ? n : 1u);
    if (p == NULL) {
        (void)fclose(fp);
        vd_port_set_err(err, err_len, "%s: out of memory (%zu bytes)", path, n);
        return VD_ERR_IO;
    }
    size_t got = n != 0u ? fread(p, 1u, n, fp) : 0u;
    int bad = ferror(fp);
    (void)fclose(fp);
    if (got != n || bad != 0) {
        free(p);
        vd_port_set_err(err, err_len, "%s: read error (%zu of %zu bytes)", path, got, n);
        return VD_ERR_IO;
    }
    *buf = p;
    *len = n;
    return VD_OK;
}
