// SPDX-License-Identifier: MIT
// File capture back end: a sequence of recorded frames (directory, list file, one image or raw file).
//
// open builds the list of paths (directory entries with a frame extension,
// sorted by strcmp; or the lines of a list file; or one path). next decodes
// the next path into one frame buffer owned by the capture (images through
// vd_image_decode, raw files frame by frame with fread), so memory is one
// frame plus the path list. A file that fails is skipped: next reports it
// (VD_ERR_IO / VD_ERR_FORMAT, the text names the file) and the following call
// continues with the next file. seq counts every frame attempted, so skipped
// files leave gaps. Bounds: VD_FILE_MAX_FRAMES paths of VD_FILE_MAX_PATH bytes,
// one file of VD_FILE_MAX_BYTES at a time.
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "vd_port/file.h"

#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

typedef struct file_impl {
    char **paths;
    size_t n_paths;
    size_t cap_paths;
    vd_capture_opts_t opts;
    size_t next_path;          // index of the next path to open
    FILE *raw_fp;              // raw file being split into frames
    size_t raw_frames;
    size_t raw_index;          // next frame in raw_fp
    const char *raw_path;
    void *pixels;              // current frame plane
    size_t pixels_bytes;
    uint32_t seq;
    uint32_t width;
    uint32_t height;
    vd_pixfmt_t format;
    bool have_first;           // first frame's size known (same_size)
    uint32_t first_w;
    uint32_t first_h;
    vd_pixfmt_t first_fmt;
    char name[VD_FILE_MAX_PATH + 32u];
    char err[VD_CAPTURE_ERROR_LEN];
} file_impl_t;

static file_impl_t *impl_of(const vd_capture_t *cap)
{
    return (file_impl_t *)cap->impl;
}

static const char *ext_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(path, '.');
    if (dot == NULL || (slash != NULL && dot < slash)) {
        return "";
    }
    return dot;
}

static bool ext_in(const char *path, const char *const *exts, size_t n)
{
    const char *e = ext_of(path);
    for (size_t i = 0; i < n; i++) {
        if (strcasecmp(e, exts[i]) == 0) {
            return true;
        }
    }
    return false;
}

static const char *const k_image_exts[] = {".pgm", ".png", ".jpg", ".jpeg"};
static const char *const k_raw_exts[] = {".raw", ".y16", ".gray", ".bin"};
static const char *const k_list_exts[] = {".txt", ".lst"};

static bool is_raw_name(const char *path)
{
    return ext_in(path, k_raw_exts, sizeof(k_raw_exts) / sizeof(k_raw_exts[0]));
}

static void impl_free(file_impl_t *f)
{
    if (f == NULL) {
        return;
    }
    for (size_t i = 0; i < f->n_paths; i++) {
        free(f->paths[i]);
    }
    free(f->paths);
    if (f->raw_fp != NULL) {
        (void)fclose(f->raw_fp);
    }
    free(f->pixels);
    free(f);
}

static vd_status_t add_path(vd_capture_t *cap, file_impl_t *f, const char *dir, const char *name, size_t name_len)
{
    if (f->n_paths >= VD_FILE_MAX_FRAMES) {
        return vd_capture_fail(cap, VD_ERR_IO, "more than %u frames", (unsigned)VD_FILE_MAX_FRAMES);
    }
    size_t dl = dir != NULL ? strlen(dir) : 0u;
    size_t total = dl + 1u + name_len + 1u;
    if (total > VD_FILE_MAX_PATH) {
        return vd_capture_fail(cap, VD_ERR_FORMAT, "path too long (%zu bytes, limit %u)", total, (unsigned)VD_FILE_MAX_PATH);
    }
    if (f->n_paths == f->cap_paths) {
        size_t nc = f->cap_paths == 0u ? 64u : f->cap_paths * 2u;
        char **np = (char **)realloc(f->paths, nc * sizeof(*np));
        if (np == NULL) {
            return vd_capture_fail(cap, VD_ERR_IO, "out of memory for the frame list");
        }
        f->paths = np;
        f->cap_paths = nc;
    }
    char *p = (char *)malloc(total);
    if (p == NULL) {
        return vd_capture_fail(cap, VD_ERR_IO, "out of memory for the frame list");
    }
    if (dl != 0u) {
        memcpy(p, dir, dl);
        p[dl] = '/';
        memcpy(p + dl + 1u, name, name_len);
        p[dl + 1u + name_len] = '\0';
    } else {
        memcpy(p, name, name_len);
        p[name_len] = '\0';
    }
    f->paths[f->n_paths++] = p;
    return VD_OK;
}

static int cmp_paths(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

static vd_status_t scan_dir(vd_capture_t *cap, file_impl_t *f, const char *dir)
{
    DIR *d = opendir(dir);
    if (d == NULL) {
        return vd_capture_fail(cap, VD_ERR_IO, "%s: cannot open directory: %s", dir, strerror(errno));
    }
    bool want_raw = f->opts.raw_width != 0u;
    vd_status_t st = VD_OK;
    for (;;) {   // bounded by the directory size and VD_FILE_MAX_FRAMES (add_path)
        errno = 0;
        struct dirent *e = readdir(d);
        if (e == NULL) {
            if (errno != 0) {
                st = vd_capture_fail(cap, VD_ERR_IO, "%s: reading directory: %s", dir, strerror(errno));
            }
            break;
        }
        if (e->d_name[0] == '.') {
            continue;
        }
        if (!ext_in(e->d_name, k_image_exts, sizeof(k_image_exts) / sizeof(k_image_exts[0])) &&
            !(want_raw && is_raw_name(e->d_name))) {
            continue;
        }
        st = add_path(cap, f, dir, e->d_name, strlen(e->d_name));
        if (st != VD_OK) {
            break;
        }
        struct stat sb;
        if (stat(f->paths[f->n_paths - 1u], &sb) != 0 || !S_ISREG(sb.st_mode)) {
            free(f->paths[--f->n_paths]);   // skip sub-directories and dangling links named like frames
        }
    }
    (void)closedir(d);
    if (st != VD_OK) {
        return st;
    }
    if (f->n_paths == 0u) {
        return vd_capture_fail(cap, VD_ERR_IO, "%s: no frames in directory (looked for *.pgm *.png *.jpg *.jpeg%s)", dir,
                               want_raw ? " *.raw *.y16 *.gray *.bin" : "");
    }
    qsort(f->paths, f->n_paths, sizeof(f->paths[0]), cmp_paths);
    return VD_OK;
}

static vd_status_t read_list(vd_capture_t *cap, file_impl_t *f, const char *list)
{
    uint8_t *buf;
    size_t len;
    vd_status_t st = vd_file_read_all(list, &buf, &len, f->err, sizeof(f->err));
    if (st != VD_OK) {
        return vd_capture_fail(cap, st, "%s", f->err);
    }
    if (memchr(buf, '\0', len) != NULL) {
        free(buf);
        return vd_capture_fail(cap, VD_ERR_FORMAT, "%s: not a text list (NUL byte)", list);
    }
    // Relative entries are relative to the list's directory.
    char dir[VD_FILE_MAX_PATH];
    const char *slash = strrchr(list, '/');
    bool rel_dir = slash != NULL;
    if (rel_dir) {
        size_t dl = (size_t)(slash - list);
        if (dl >= sizeof(dir)) {
            free(buf);
            return vd_capture_fail(cap, VD_ERR_FORMAT, "%s: path too long", list);
        }
        memcpy(dir, list, dl);
        dir[dl] = '\0';
        if (dl == 0u) {
            dir[0] = '/';
            dir[1] = '\0';
        }
    }
    size_t pos = 0u;
    size_t line_no = 0u;
    while (pos < len && st == VD_OK) {
        size_t end = pos;
        while (end < len && buf[end] != '\n') {
            end++;
        }
        line_no++;
        size_t a = pos;
        size_t b = end;
        pos = end + 1u;
        while (a < b && (buf[a] == ' ' || buf[a] == '\t')) {
            a++;
        }
        while (b > a && (buf[b - 1u] == '\r' || buf[b - 1u] == ' ' || buf[b - 1u] == '\t')) {
            b--;
        }
        if (a == b || buf[a] == '#') {
            continue;
        }
        if (b - a >= VD_FILE_MAX_PATH) {
            st = vd_capture_fail(cap, VD_ERR_FORMAT, "%s:%zu: line too long", list, line_no);
            break;
        }
        bool absolute = buf[a] == '/';
        st = add_path(cap, f, (absolute || !rel_dir) ? NULL : dir, (const char *)buf + a, b - a);
    }
    free(buf);
    if (st == VD_OK && f->n_paths == 0u) {
        st = vd_capture_fail(cap, VD_ERR_IO, "%s: the list names no frames", list);
    }
    return st;
}

static void close_raw(file_impl_t *f)
{
    if (f->raw_fp != NULL) {
        (void)fclose(f->raw_fp);
    }
    f->raw_fp = NULL;
    f->raw_frames = 0u;
    f->raw_index = 0u;
    f->raw_path = NULL;
}

static vd_status_t ensure_pixels(vd_capture_t *cap, file_impl_t *f, size_t bytes)
{
    if (f->pixels_bytes >= bytes) {
        return VD_OK;
    }
    free(f->pixels);
    f->pixels = malloc(bytes);
    f->pixels_bytes = f->pixels != NULL ? bytes : 0u;
    if (f->pixels == NULL) {
        return vd_capture_fail(cap, VD_ERR_IO, "out of memory for a %zu-byte frame", bytes);
    }
    return VD_OK;
}

// Reads frame raw_index of the open raw file into the pixel buffer.
static vd_status_t read_raw_frame(vd_capture_t *cap, file_impl_t *f)
{
    uint32_t w = f->opts.raw_width;
    uint32_t h = f->opts.raw_height;
    bool wide = f->opts.raw_format == VD_PIX_U16;
    size_t fb = (size_t)w * (size_t)h * (wide ? 2u : 1u);
    size_t k = f->raw_index++;
    const char *path = f->raw_path;
    if (f->raw_frames > 1u) {
        (void)snprintf(f->name, sizeof(f->name), "%s#%zu", path, k);
    } else {
        (void)snprintf(f->name, sizeof(f->name), "%s", path);
    }
    vd_status_t st = ensure_pixels(cap, f, fb);
    if (st == VD_OK) {
        if (fseek(f->raw_fp, (long)(k * fb), SEEK_SET) != 0 || fread(f->pixels, 1u, fb, f->raw_fp) != fb) {
            st = vd_capture_fail(cap, VD_ERR_IO, "%s: read error at frame %zu", f->name, k);
        }
    }
    if (f->raw_index >= f->raw_frames) {
        close_raw(f);
    }
    if (st != VD_OK) {
        return st;
    }
    if (wide) {
        const uint8_t *s = (const uint8_t *)f->pixels;
        uint16_t *d = (uint16_t *)f->pixels;
        size_t n = fb / 2u;
        for (size_t i = 0; i < n; i++) {   // in place: reads bytes 2i, 2i+1 before writing sample i
            uint32_t b0 = s[2u * i];
            uint32_t b1 = s[2u * i + 1u];
            d[i] = f->opts.raw_big_endian ? (uint16_t)((b0 << 8) | b1) : (uint16_t)((b1 << 8) | b0);
        }
    }
    f->width = w;
    f->height = h;
    f->format = wide ? VD_PIX_U16 : VD_PIX_U8;
    return VD_OK;
}

// Opens a raw file at its first frame without reading it.
static vd_status_t open_raw_file(vd_capture_t *cap, file_impl_t *f, const char *path)
{
    if (f->opts.raw_width == 0u) {
        (void)snprintf(f->name, sizeof(f->name), "%s", path);
        return vd_capture_fail(cap, VD_ERR_FORMAT, "%s: raw file, but no raw frame size was given", path);
    }
    FILE *fp = fopen(path, "rb");
    if (fp == NULL) {
        return vd_capture_fail(cap, VD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    }
    struct stat sb;
    if (fstat(fileno(fp), &sb) != 0 || !S_ISREG(sb.st_mode) || sb.st_size < 0) {
        (void)fclose(fp);
        return vd_capture_fail(cap, VD_ERR_IO, "%s: not a regular file", path);
    }
    size_t n = 0u;
    if ((uint64_t)sb.st_size > (uint64_t)LONG_MAX) {
        (void)fclose(fp);
        return vd_capture_fail(cap, VD_ERR_IO, "%s: file too large", path);
    }
    vd_status_t st = vd_raw_frame_count((size_t)sb.st_size, f->opts.raw_width, f->opts.raw_height, f->opts.raw_format, &n,
                                        f->err, sizeof(f->err));
    if (st != VD_OK) {
        (void)fclose(fp);
        return vd_capture_fail(cap, st, "%s: %s", path, f->err);
    }
    f->raw_fp = fp;
    f->raw_frames = n;
    f->raw_index = 0u;
    f->raw_path = path;
    return VD_OK;
}

static vd_status_t open_raw(vd_capture_t *cap, file_impl_t *f, const char *path)
{
    vd_status_t st = open_raw_file(cap, f, path);
    return st == VD_OK ? read_raw_frame(cap, f) : st;
}

// Same magic checks as vd_image_decode: Netpbm "P1".."P7", PNG signature, JPEG SOI.
static bool looks_like_image(const uint8_t *b, size_t len)
{
    static const uint8_t png[8] = {0x89u, 'P', 'N', 'G', 0x0Du, 0x0Au, 0x1Au, 0x0Au};
    return (len >= 2u && b[0] == 'P' && b[1] >= '1' && b[1] <= '7') || (len >= 8u && memcmp(b, png, 8u) == 0) ||
           (len >= 3u && b[0] == 0xFFu && b[1] == 0xD8u && b[2] == 0xFFu);
}

static vd_status_t decode_file(vd_capture_t *cap, file_impl_t *f, const char *path)
{
    (void)snprintf(f->name, sizeof(f->name), "%s", path);
    if (is_raw_name(path)) {
        return open_raw(cap, f, path);
    }
    uint8_t *buf;
    size_t len;
    vd_status_t st = vd_file_read_all(path, &buf, &len, f->err, sizeof(f->err));
    if (st != VD_OK) {
        return vd_capture_fail(cap, st, "%s", f->err);
    }
    vd_decoded_t dec;
    st = vd_image_decode(buf, len, &dec, f->err, sizeof(f->err));
    bool unknown = st == VD_ERR_FORMAT && !looks_like_image(buf, len);
    free(buf);
    if (st != VD_OK) {
        if (unknown && f->opts.raw_width != 0u) {
            return open_raw(cap, f, path);   // not an image: the caller said raw frames have a known size
        }
        return vd_capture_fail(cap, st, "%s: %s", path, f->err);
    }
    free(f->pixels);
    f->pixels = dec.data;
    f->pixels_bytes = (size_t)dec.width * (size_t)dec.height * (dec.format == VD_PIX_U16 ? 2u : 1u);
    f->width = dec.width;
    f->height = dec.height;
    f->format = dec.format;
    return VD_OK;
}

static vd_status_t file_start(vd_capture_t *cap)
{
    file_impl_t *f = impl_of(cap);
    close_raw(f);
    f->next_path = 0u;
    f->seq = 0u;
    f->have_first = false;
    return VD_OK;
}

static vd_status_t file_next(vd_capture_t *cap, int32_t timeout_ms, vd_frame_t *frame)
{
    file_impl_t *f = impl_of(cap);
    (void)timeout_ms;
    vd_status_t st;
    if (f->raw_fp != NULL) {
        st = read_raw_frame(cap, f);
    } else if (f->next_path < f->n_paths) {
        st = decode_file(cap, f, f->paths[f->next_path++]);
    } else {
        cap->at_end = true;
        return vd_capture_fail(cap, VD_ERR_RANGE, "end of the recording (%zu files, %u frames)", f->n_paths,
                               (unsigned)f->seq);
    }
    uint32_t seq = f->seq++;
    if (st != VD_OK) {
        return st;
    }
    if (f->opts.same_size) {
        if (!f->have_first) {
            f->have_first = true;
            f->first_w = f->width;
            f->first_h = f->height;
            f->first_fmt = f->format;
        } else if (f->width != f->first_w || f->height != f->first_h || f->format != f->first_fmt) {
            return vd_capture_fail(cap, VD_ERR_FORMAT, "%s: frame is %ux%u %u-bit, the sequence started with %ux%u %u-bit",
                                   f->name, (unsigned)f->width, (unsigned)f->height, f->format == VD_PIX_U16 ? 16u : 8u,
                                   (unsigned)f->first_w, (unsigned)f->first_h, f->first_fmt == VD_PIX_U16 ? 16u : 8u);
        }
    }
    frame->data = f->pixels;
    frame->width = f->width;
    frame->height = f->height;
    frame->stride = (size_t)f->width * (f->format == VD_PIX_U16 ? 2u : 1u);
    frame->format = f->format;
    frame->seq = seq;
    frame->timestamp_us = 0u;
    return VD_OK;
}

static vd_status_t file_release(vd_capture_t *cap, const vd_frame_t *frame)
{
    (void)cap;
    (void)frame;
    return VD_OK;   // the buffer is simply reused by the next frame
}

static vd_status_t file_stop(vd_capture_t *cap)
{
    close_raw(impl_of(cap));
    return VD_OK;
}

static void file_close(vd_capture_t *cap)
{
    impl_free(impl_of(cap));
    cap->impl = NULL;
}

static const char *file_frame_name(const vd_capture_t *cap)
{
    return impl_of(cap)->name;
}

static void file_format(const vd_capture_t *cap, uint32_t *w, uint32_t *h, vd_pixfmt_t *fmt)
{
    const file_impl_t *f = impl_of(cap);
    *w = f->width;
    *h = f->height;
    *fmt = f->format;
}

static const vd_capture_ops_t g_file_ops = {
    "file", file_start, file_next, file_release, file_stop, file_close, file_frame_name, file_format
};

// Frames raw path i holds (size / frame size; at least 1, as vd_file_frame_total counts), or 1 for an image.
static uint64_t frames_of_path(const file_impl_t *f, size_t i)
{
    const uint64_t fb = (uint64_t)f->opts.raw_width * f->opts.raw_height * (f->opts.raw_format == VD_PIX_U16 ? 2u : 1u);
    struct stat sb;
    if (fb != 0u && is_raw_name(f->paths[i]) && stat(f->paths[i], &sb) == 0 && sb.st_size > 0 &&
        (uint64_t)sb.st_size >= fb) {
        return (uint64_t)sb.st_size / fb;
    }
    return 1u;
}

vd_status_t vd_file_frame_total(const vd_capture_t *cap, uint64_t *frames)
{
    if (cap == NULL || frames == NULL || cap->ops != &g_file_ops || cap->impl == NULL) {
        return VD_ERR_ARG;
    }
    const file_impl_t *f = impl_of(cap);
    uint64_t n = 0u;
    // One stat() per raw file: bounded by VD_FILE_MAX_FRAMES paths.
    for (size_t i = 0; i < f->n_paths; i++) {
        n += frames_of_path(f, i);
    }
    *frames = n;
    return VD_OK;
}

vd_status_t vd_file_skip(vd_capture_t *cap, uint64_t frames)
{
    if (cap == NULL || cap->ops != &g_file_ops || cap->impl == NULL) {
        return VD_ERR_ARG;
    }
    if (cap->state != VD_CAPTURE_STREAMING) {
        return vd_capture_fail(cap, VD_ERR_STATE, "skip: the capture is not streaming, or a frame is held");
    }
    file_impl_t *f = impl_of(cap);
    uint64_t left = frames;
    // Bounded: one step per raw file left open, then one per path (VD_FILE_MAX_FRAMES).
    if (left > 0u && f->raw_fp != NULL) {
        const uint64_t in_file = (uint64_t)(f->raw_frames - f->raw_index);
        const uint64_t k = left < in_file ? left : in_file;
        f->raw_index += (size_t)k;
        f->seq += (uint32_t)k;
        left -= k;
        if (f->raw_index >= f->raw_frames) {
            close_raw(f);
        }
    }
    while (left > 0u && f->next_path < f->n_paths) {
        const size_t i = f->next_path;
        const uint64_t n = frames_of_path(f, i);
        if (n <= left) {
            f->next_path++;
            f->seq += (uint32_t)n;
            left -= n;
            continue;
        }
        f->next_path++;   // the skip ends inside this raw file: open it there
        vd_status_t st = open_raw_file(cap, f, f->paths[i]);
        if (st != VD_OK) {
            return st;
        }
        f->raw_index = (size_t)left;
        f->seq += (uint32_t)left;
        left = 0u;
        if (f->raw_index >= f->raw_frames) {   // the file is shorter than its size said: at its end
            close_raw(f);
        }
    }
    if (left > 0u) {
        cap->at_end = true;
        return vd_capture_fail(cap, VD_ERR_RANGE, "end of the recording (%zu files, %u frames)", f->n_paths,
                               (unsigned)f->seq);
    }
    return VD_OK;
}

vd_status_t vd_file_open(vd_capture_t *cap, const char *path, vd_file_kind_t kind, const vd_capture_opts_t *opts)
{
    if (cap == NULL) {
        return VD_ERR_ARG;
    }
    memset(cap, 0, sizeof(*cap));
    if (path == NULL || path[0] == '\0') {
        return vd_capture_fail(cap, VD_ERR_ARG, "no input path given");
    }
    vd_capture_opts_t o;
    if (opts != NULL) {
        o = *opts;
    } else {
        vd_capture_opts_default(&o);
    }
    if (o.raw_format == 0) {
        o.raw_format = VD_PIX_U16;
    }
    if ((o.raw_width == 0u) != (o.raw_height == 0u) || o.raw_width > VD_MAX_DIM || o.raw_height > VD_MAX_DIM ||
        (o.raw_format != VD_PIX_U8 && o.raw_format != VD_PIX_U16)) {
        return vd_capture_fail(cap, VD_ERR_ARG, "%s: raw frame size %ux%u or format invalid (size 1..%u)", path,
                               (unsigned)o.raw_width, (unsigned)o.raw_height, (unsigned)VD_MAX_DIM);
    }
    if (strlen(path) >= VD_FILE_MAX_PATH) {
        return vd_capture_fail(cap, VD_ERR_ARG, "input path too long");
    }
    struct stat sb;
    if (stat(path, &sb) != 0) {
        return vd_capture_fail(cap, VD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    }
    if (kind == VD_FILE_AUTO) {
        if (S_ISDIR(sb.st_mode)) {
            kind = VD_FILE_DIR;
        } else if (ext_in(path, k_list_exts, sizeof(k_list_exts) / sizeof(k_list_exts[0]))) {
            kind = VD_FILE_LIST;
        } else {
            kind = VD_FILE_SINGLE;
        }
    }
    if (kind != VD_FILE_DIR && !S_ISREG(sb.st_mode)) {
        return vd_capture_fail(cap, VD_ERR_IO, "%s: not a regular file", path);
    }
    if (kind == VD_FILE_DIR && !S_ISDIR(sb.st_mode)) {
        return vd_capture_fail(cap, VD_ERR_IO, "%s: not a directory", path);
    }
    file_impl_t *f = (file_impl_t *)calloc(1u, sizeof(*f));
    if (f == NULL) {
        return vd_capture_fail(cap, VD_ERR_IO, "out of memory");
    }
    f->opts = o;
    vd_status_t st;
    if (kind == VD_FILE_DIR) {
        // Drop trailing slashes so names read "dir/file".
        char dir[VD_FILE_MAX_PATH];
        (void)snprintf(dir, sizeof(dir), "%s", path);
        size_t dl = strlen(dir);
        while (dl > 1u && dir[dl - 1u] == '/') {
            dir[--dl] = '\0';
        }
        st = scan_dir(cap, f, dir);
    } else if (kind == VD_FILE_LIST) {
        st = read_list(cap, f, path);
    } else {
        st = add_path(cap, f, NULL, path, strlen(path));
    }
    if (st != VD_OK) {
        char keep[VD_CAPTURE_ERROR_LEN];
        memcpy(keep, cap->error, sizeof(keep));
        impl_free(f);
        memset(cap, 0, sizeof(*cap));
        memcpy(cap->error, keep, sizeof(keep));
        return st;
    }
    vd_capture_attach(cap, &g_file_ops, f);
    return VD_OK;
}
