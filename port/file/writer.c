// SPDX-License-Identifier: MIT
// Host-side image writers (PGM, PNG through stb_image_write) and RGB-canvas drawing for annotated output.
//
// Writers go through a temporary file "<path>.tmp.<pid>" renamed over the
// final name after a complete write (rename(2) is atomic on one file system),
// so readers never see half an image. Drawing is clipped to the canvas.
// Bounds: O(width * height) per image; one row buffer for 16-bit PGM.
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "vd_port/writer.h"
#include "port_err.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#if defined(VD_PORT_HAVE_STB)
#include <stb_image_write.h>
#endif


static bool tmp_name(const char *path, char *tmp, size_t n)
{
    int r = snprintf(tmp, n, "%s.tmp.%ld", path, (long)getpid());
    return r > 0 && (size_t)r < n;
}

// Renames tmp over path, or removes tmp when ok is false. Returns the final status.
static vd_status_t finish(const char *tmp, const char *path, bool ok, char *err, size_t err_len)
{
    if (!ok) {
        (void)remove(tmp);
        return VD_ERR_IO;
    }
    if (rename(tmp, path) != 0) {
        vd_port_set_err(err, err_len, "%s: cannot rename from %s: %s", path, tmp, strerror(errno));
        (void)remove(tmp);
        return VD_ERR_IO;
    }
    return VD_OK;
}

vd_status_t vd_write_pgm(const char *path, const vd_frame_t *frame, char *err, size_t err_len)
{
    if (path == NULL || frame == NULL || vd_frame_check(frame) != VD_OK) {
        vd_port_set_err(err, err_len, "write PGM: NULL path or invalid frame");
        return VD_ERR_ARG;
    }
    char tmp[4200];
    if (!tmp_name(path, tmp, sizeof(tmp))) {
        vd_port_set_err(err, err_len, "write PGM: path too long");
        return VD_ERR_ARG;
    }
    FILE *fp = fopen(tmp, "wb");
    if (fp == NULL) {
        vd_port_set_err(err, err_len, "%s: cannot create: %s", tmp, strerror(errno));
        return VD_ERR_IO;
    }
    bool wide = frame->format == VD_PIX_U16;
    bool ok = fprintf(fp, "P5\n%u %u\n%u\n", (unsigned)frame->width, (unsigned)frame->height, wide ? 65535u : 255u) > 0;
    uint8_t *row = NULL;   // the big-endian row of a 16-bit frame; NULL for an 8-bit one
    if (ok && wide) {
        row = (uint8_t *)malloc((size_t)frame->width * 2u);
        ok = row != NULL;
    }
    const uint8_t *base = (const uint8_t *)frame->data;
    for (uint32_t y = 0; ok && y < frame->height; y++) {
        const uint8_t *src = base + (size_t)y * frame->stride;
        if (row != NULL) {
            const uint16_t *s16 = (const uint16_t *)(const void *)src;
            for (uint32_t x = 0; x < frame->width; x++) {
                row[2u * x] = (uint8_t)(s16[x] >> 8);   // PGM samples are big-endian
                row[2u * x + 1u] = (uint8_t)(s16[x] & 0xFFu);
            }
            ok = fwrite(row, 2u, frame->width, fp) == frame->width;
        } else {
            ok = fwrite(src, 1u, frame->width, fp) == frame->width;
        }
    }
    free(row);
    if (fclose(fp) != 0) {
        ok = false;
    }
    if (!ok) {
        vd_port_set_err(err, err_len, "%s: write failed: %s", path, strerror(errno));
    }
    return finish(tmp, path, ok, err, err_len);
}

vd_status_t vd_rgb_alloc(vd_rgb_t *img, uint32_t width, uint32_t height)
{
    if (img == NULL) {
        return VD_ERR_ARG;
    }
    memset(img, 0, sizeof(*img));
    if (width == 0u || height == 0u || width > VD_MAX_DIM || height > VD_MAX_DIM) {
        return VD_ERR_ARG;
    }
    size_t stride = (size_t)width * 3u;
    img->data = (uint8_t *)calloc((size_t)height, stride);
    if (img->data == NULL) {
        return VD_ERR_IO;
    }
    img->width = width;
    img->height = height;
    img->stride = stride;
    return VD_OK;
}

void vd_rgb_free(vd_rgb_t *img)
{
    if (img == NULL) {
        return;
    }
    free(img->data);
    memset(img, 0, sizeof(*img));
}

static bool rgb_ok(const vd_rgb_t *img)
{
    return img != NULL && img->data != NULL && img->width != 0u && img->height != 0u &&
           img->stride >= (size_t)img->width * 3u;
}

vd_status_t vd_rgb_from_frame(vd_rgb_t *img, const vd_frame_t *frame, uint32_t lo, uint32_t hi)
{
    if (!rgb_ok(img) || frame == NULL || lo > hi) {
        return VD_ERR_ARG;
    }
    vd_status_t st = vd_frame_check(frame);
    if (st != VD_OK) {
        return st;
    }
    if (frame->width != img->width || frame->height != img->height) {
        return VD_ERR_ARG;
    }
    const uint8_t *base = (const uint8_t *)frame->data;
    if (frame->format == VD_PIX_U8) {
        for (uint32_t y = 0; y < frame->height; y++) {
            const uint8_t *s = base + (size_t)y * frame->stride;
            uint8_t *d = img->data + (size_t)y * img->stride;
            for (uint32_t x = 0; x < frame->width; x++) {
                d[3u * x] = d[3u * x + 1u] = d[3u * x + 2u] = s[x];
            }
        }
        return VD_OK;
    }
    if (lo == 0u && hi == 0u) {
        lo = 65535u;
        for (uint32_t y = 0; y < frame->height; y++) {
            const uint16_t *s = (const uint16_t *)(const void *)(base + (size_t)y * frame->stride);
            for (uint32_t x = 0; x < frame->width; x++) {
                lo = s[x] < lo ? s[x] : lo;
                hi = s[x] > hi ? s[x] : hi;
            }
        }
    }
    for (uint32_t y = 0; y < frame->height; y++) {
        const uint16_t *s = (const uint16_t *)(const void *)(base + (size_t)y * frame->stride);
        uint8_t *d = img->data + (size_t)y * img->stride;
        for (uint32_t x = 0; x < frame->width; x++) {
            uint32_t v = s[x];
            uint8_t g;
            if (hi == lo) {
                g = 128u;
            } else if (v <= lo) {
                g = 0u;
            } else if (v >= hi) {
                g = 255u;
            } else {
                g = (uint8_t)(((v - lo) * 255u) / (hi - lo));
            }
            d[3u * x] = d[3u * x + 1u] = d[3u * x + 2u] = g;
        }
    }
    return VD_OK;
}

static void put_px(vd_rgb_t *img, int64_t x, int64_t y, uint8_t r, uint8_t g, uint8_t b)
{
    if (x < 0 || y < 0 || x >= (int64_t)img->width || y >= (int64_t)img->height) {
        return;
    }
    uint8_t *p = img->data + (size_t)y * img->stride + (size_t)x * 3u;
    p[0] = r;
    p[1] = g;
    p[2] = b;
}

static void fill_rect(vd_rgb_t *img, int64_t x0, int64_t y0, int64_t x1, int64_t y1, uint8_t r, uint8_t g, uint8_t b)
{
    // Clip first so the loops are bounded by the canvas.
    x0 = x0 < 0 ? 0 : x0;
    y0 = y0 < 0 ? 0 : y0;
    x1 = x1 > (int64_t)img->width ? (int64_t)img->width : x1;
    y1 = y1 > (int64_t)img->height ? (int64_t)img->height : y1;
    for (int64_t y = y0; y < y1; y++) {
        for (int64_t x = x0; x < x1; x++) {
            put_px(img, x, y, r, g, b);
        }
    }
}

void vd_rgb_draw_rect(vd_rgb_t *img, const vd_rect_t *r, uint8_t red, uint8_t green, uint8_t blue, uint32_t thickness)
{
    if (!rgb_ok(img) || r == NULL || r->w <= 0 || r->h <= 0 || thickness == 0u) {
        return;
    }
    int64_t x0 = r->x;
    int64_t y0 = r->y;
    int64_t x1 = x0 + r->w;
    int64_t y1 = y0 + r->h;
    int64_t t = thickness;
    fill_rect(img, x0, y0, x1, y0 + t, red, green, blue);
    fill_rect(img, x0, y1 - t, x1, y1, red, green, blue);
    fill_rect(img, x0, y0, x0 + t, y1, red, green, blue);
    fill_rect(img, x1 - t, y0, x1, y1, red, green, blue);
}

// 3x5 glyphs, rows top to bottom, '1' = ink.
typedef struct glyph {
    char c;
    const char *rows;
} glyph_t;

static const glyph_t k_font[] = {
    {'0', "111101101101111"}, {'1', "010110010010111"}, {'2', "111001111100111"}, {'3', "111001111001111"},
    {'4', "101101111001001"}, {'5', "111100111001111"}, {'6', "111100111101111"}, {'7', "111001001001001"},
    {'8', "111101111101111"}, {'9', "111101111001111"}, {'A', "010101111101101"}, {'B', "110101110101110"},
    {'C', "011100100100011"}, {'D', "110101101101110"}, {'E', "111100110100111"}, {'F', "111100110100100"},
    {'G', "011100101101011"}, {'H', "101101111101101"}, {'I', "111010010010111"}, {'J', "001001001101010"},
    {'K', "101101110101101"}, {'L', "100100100100111"}, {'M', "101111111101101"}, {'N', "110101101101101"},
    {'O', "010101101101010"}, {'P', "110101110100100"}, {'Q', "010101101110011"}, {'R', "110101110101101"},
    {'S', "011100010001110"}, {'T', "111010010010010"}, {'U', "101101101101111"}, {'V', "101101101101010"},
    {'W', "101101111111101"}, {'X', "101101010101101"}, {'Y', "101101010010010"}, {'Z', "111001010100111"},
    {' ', "000000000000000"}, {'.', "000000000000010"}, {',', "000000000010100"}, {':', "000010000010000"},
    {'-', "000000111000000"}, {'+', "000010111010000"}, {'%', "101001010100101"}, {'#', "101111101111101"},
    {'/', "001001010100100"}, {'=', "000111000111000"}, {'(', "001010010010001"}, {')', "100010010010100"},
    {'_', "000000000000111"},
};

static const char *glyph_rows(char c)
{
    if (c >= 'a' && c <= 'z') {
        c = (char)(c - 'a' + 'A');
    }
    for (size_t i = 0; i < sizeof(k_font) / sizeof(k_font[0]); i++) {
        if (k_font[i].c == c) {
            return k_font[i].rows;
        }
    }
    return "111111111111111";
}

void vd_rgb_draw_text(vd_rgb_t *img, int32_t x, int32_t y, const char *text, uint8_t red, uint8_t green,
                      uint8_t blue, uint32_t scale)
{
    if (!rgb_ok(img) || text == NULL || scale == 0u || scale > 64u) {
        return;
    }
    int64_t s = scale;
    int64_t cx = x;
    for (size_t k = 0; text[k] != '\0' && k < 1024u; k++) {
        const char *rows = glyph_rows(text[k]);
        for (int64_t gy = 0; gy < 5; gy++) {
            for (int64_t gx = 0; gx < 3; gx++) {
                if (rows[gy * 3 + gx] == '1') {
                    fill_rect(img, cx + gx * s, (int64_t)y + gy * s, cx + (gx + 1) * s, (int64_t)y + (gy + 1) * s, red,
                              green, blue);
                }
            }
        }
        cx += 4 * s;
        if (cx >= (int64_t)img->width) {
            break;
        }
    }
}

static vd_status_t write_png(const char *path, uint32_t w, uint32_t h, int comp, const uint8_t *data, size_t stride,
                             char *err, size_t err_len)
{
#if defined(VD_PORT_HAVE_STB)
    char tmp[4200];
    if (!tmp_name(path, tmp, sizeof(tmp))) {
        vd_port_set_err(err, err_len, "write PNG: path too long");
        return VD_ERR_ARG;
    }
    if (stride > (size_t)0x7FFFFFFF) {
        vd_port_set_err(err, err_len, "write PNG: stride too large");
        return VD_ERR_ARG;
    }
    errno = 0;
    bool ok = stbi_write_png(tmp, (int)w, (int)h, comp, data, (int)stride) != 0;
    if (!ok) {
        vd_port_set_err(err, err_len, "%s: PNG write failed%s%s", path, errno != 0 ? ": " : "", errno != 0 ? strerror(errno) : "");
    }
    return finish(tmp, path, ok, err, err_len);
#else
    (void)w;
    (void)h;
    (void)comp;
    (void)data;
    (void)stride;
    vd_port_set_err(err, err_len, "%s: PNG output not built (stb_image_write not found)", path);
    return VD_ERR_IO;
#endif
}

vd_status_t vd_write_png_rgb(const char *path, const vd_rgb_t *img, char *err, size_t err_len)
{
    if (path == NULL || !rgb_ok(img)) {
        vd_port_set_err(err, err_len, "write PNG: NULL path or invalid canvas");
        return VD_ERR_ARG;
    }
    return write_png(path, img->width, img->height, 3, img->data, img->stride, err, err_len);
}

vd_status_t vd_write_png_grey(const char *path, const vd_frame_t *frame, char *err, size_t err_len)
{
    if (path == NULL || frame == NULL || vd_frame_check(frame) != VD_OK) {
        vd_port_set_err(err, err_len, "write PNG: NULL path or invalid frame");
        return VD_ERR_ARG;
    }
    if (frame->format != VD_PIX_U8) {
        vd_port_set_err(err, err_len, "write PNG: only 8-bit frames (use vd_write_pgm for 16-bit)");
        return VD_ERR_FORMAT;
    }
    return write_png(path, frame->width, frame->height, 1, (const uint8_t *)frame->data, frame->stride, err, err_len);
}
