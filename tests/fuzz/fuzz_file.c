// SPDX-License-Identifier: MIT
// Fuzz harness: the recorded-frame readers of port/file (PGM P5 8/16-bit, raw Y16/8-bit) in memory and through the capture API.
//
// Input: a control byte, then the payload. Mode (ctl % 4):
//   0  vd_image_decode on the payload, cross-checked with vd_pgm_parse_header
//      (payloads with a PNG or JPEG signature are skipped: those go to the
//      third-party stb_image, out of scope here);
//   1  vd_pgm_parse_header and vd_raw_frame_count with fuzzed sizes;
//   2  the payload written to a temporary .raw file and read through
//      vd_capture_open/start/next/release/stop/start (vd_file_skip)/close with
//      fuzzed raw_width/raw_height/format/endianness;
//   3  the same for a .pgm file.
// Every frame handed out must pass vd_frame_check and is read completely.
#include "fuzz_common.h"
#include "vd_port/capture.h"
#include "vd_port/file.h"

#include <unistd.h>

static volatile uint32_t g_sink;

static void touch_frame(const vd_frame_t *f)
{
    FZ_CHECK(vd_frame_check(f) == VD_OK);
    const size_t row = (size_t)f->width * (f->format == VD_PIX_U16 ? 2u : 1u);
    uint32_t s = 0u;
    for (uint32_t y = 0u; y < f->height; y++) {
        const uint8_t *p = (const uint8_t *)f->data + (size_t)y * f->stride;
        for (size_t x = 0u; x < row; x++) {
            s += p[x];
        }
    }
    g_sink += s;
}

static const char *tmp_path(const char *ext)
{
    static char path[256];
    const char *dir = getenv("TMPDIR");
    snprintf(path, sizeof(path), "%s/vd_fuzz_file_%ld%s", dir ? dir : "/tmp", (long)getpid(), ext);
    return path;
}

static void via_capture(const uint8_t *p, size_t n, const char *ext, const vd_capture_opts_t *opts)
{
    const char *path = tmp_path(ext);
    FILE *f = fopen(path, "wb");
    if (f == NULL) {
        return;
    }
    if (n) {
        (void)fwrite(p, 1u, n, f);
    }
    fclose(f);
    vd_capture_t cap;
    vd_status_t st = vd_capture_open(&cap, path, opts);
    if (st == VD_OK) {
        for (int round = 0; round < 2; round++) {
            FZ_CHECK(vd_capture_start(&cap) == VD_OK);
            // The second round first passes over 0-4 frames (vd_file_skip), into or past a raw file.
            st = vd_file_skip(&cap, round == 1 ? (uint64_t)(n % 5u) : 0u);
            FZ_CHECK(st == VD_OK || st == VD_ERR_RANGE || st == VD_ERR_IO || st == VD_ERR_FORMAT ||
                     st == VD_ERR_OVERFLOW);
            FZ_CHECK(st != VD_ERR_RANGE || vd_capture_at_end(&cap));
            for (int k = 0; k < 10 && st != VD_ERR_RANGE; k++) {
                vd_frame_t fr;
                st = vd_capture_next(&cap, 0, &fr);
                if (st == VD_OK) {
                    touch_frame(&fr);
                    // A frame is handed out once: next() while holding it is a state error.
                    vd_frame_t again;
                    FZ_CHECK(vd_capture_next(&cap, 0, &again) == VD_ERR_STATE);
                    FZ_CHECK(vd_capture_release(&cap, &fr) == VD_OK);
                    continue;
                }
                FZ_CHECK(st == VD_ERR_RANGE || st == VD_ERR_FORMAT || st == VD_ERR_IO || st == VD_ERR_OVERFLOW);
                FZ_CHECK(vd_capture_error(&cap)[0] != '\0');
                if (st == VD_ERR_RANGE) {
                    FZ_CHECK(vd_capture_at_end(&cap));
                    break;
                }
            }
            FZ_CHECK(vd_capture_stop(&cap) == VD_OK);
        }
    } else {
        FZ_CHECK(st == VD_ERR_FORMAT || st == VD_ERR_IO || st == VD_ERR_ARG || st == VD_ERR_OVERFLOW);
        FZ_CHECK(vd_capture_error(&cap)[0] != '\0');
    }
    vd_capture_close(&cap);
    vd_capture_close(&cap);  // closing twice is safe
    (void)remove(path);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader_t r;
    fz_init(&r, data, size);
    const uint8_t ctl = fz_u8(&r);
    char err[128];
    switch (ctl % 4u) {
    case 0: {
        const uint8_t *p = r.p;
        const size_t n = r.n;
        if ((n >= 2u && p[0] == 0x89u && p[1] == 'P') || (n >= 2u && p[0] == 0xFFu && p[1] == 0xD8u)) {
            return 0;
        }
        vd_decoded_t d;
        memset(&d, 0, sizeof(d));
        vd_status_t st = vd_image_decode(p, n, &d, err, sizeof(err));
        uint32_t w = 0u, h = 0u, maxval = 0u;
        size_t off = 0u;
        vd_status_t sh = vd_pgm_parse_header(p, n, &w, &h, &maxval, &off, err, sizeof(err));
        if (st == VD_OK) {
            FZ_CHECK(d.data != NULL && d.width >= 1u && d.height >= 1u && d.width <= VD_MAX_DIM && d.height <= VD_MAX_DIM);
            FZ_CHECK(d.format == VD_PIX_U8 || d.format == VD_PIX_U16);
            if (n >= 2u && p[0] == 'P') {
                FZ_CHECK(sh == VD_OK && w == d.width && h == d.height);
                FZ_CHECK((maxval < 256u) == (d.format == VD_PIX_U8));
                const size_t bpp = maxval < 256u ? 1u : 2u;
                FZ_CHECK(off <= n && (n - off) / bpp / w >= h);
            }
            vd_frame_t f;
            memset(&f, 0, sizeof(f));
            f.data = d.data;
            f.width = d.width;
            f.height = d.height;
            f.format = d.format;
            f.stride = (size_t)d.width * (d.format == VD_PIX_U16 ? 2u : 1u);
            touch_frame(&f);
        } else {
            FZ_CHECK(st == VD_ERR_FORMAT || st == VD_ERR_OVERFLOW || st == VD_ERR_IO);
            FZ_CHECK(d.data == NULL);
        }
        vd_decoded_free(&d);
        vd_decoded_free(NULL);
        break;
    }
    case 1: {
        const uint32_t w = fz_u16(&r) * 3u;
        const uint32_t h = fz_u16(&r) * 3u;
        const vd_pixfmt_t fmt = (vd_pixfmt_t)(fz_u8(&r) % 4u);
        const size_t len = fz_u32(&r);
        size_t frames = 0u;
        vd_status_t st = vd_raw_frame_count(len, w, h, fmt, &frames, err, sizeof(err));
        if (st == VD_OK) {
            FZ_CHECK(w >= 1u && h >= 1u && w <= VD_MAX_DIM && h <= VD_MAX_DIM && frames >= 1u);
            FZ_CHECK(frames * (size_t)w * h * (fmt == VD_PIX_U16 ? 2u : 1u) == len);
        } else {
            FZ_CHECK(st == VD_ERR_ARG || st == VD_ERR_FORMAT || st == VD_ERR_OVERFLOW);
        }
        uint32_t pw, ph, mv;
        size_t off;
        st = vd_pgm_parse_header(r.p, r.n, &pw, &ph, &mv, &off, err, sizeof(err));
        if (st == VD_OK) {
            FZ_CHECK(pw >= 1u && ph >= 1u && pw <= VD_MAX_DIM && ph <= VD_MAX_DIM && mv >= 1u && mv <= 65535u);
            FZ_CHECK(off <= r.n && (r.n - off) / (mv < 256u ? 1u : 2u) / pw >= ph);
        }
        break;
    }
    case 2: {
        vd_capture_opts_t o;
        vd_capture_opts_default(&o);
        o.raw_width = 1u + fz_u8(&r) % 32u;
        o.raw_height = 1u + fz_u8(&r) % 32u;
        const uint8_t b = fz_u8(&r);
        o.raw_format = (b & 1u) ? VD_PIX_U8 : VD_PIX_U16;
        o.raw_big_endian = (b & 2u) != 0u;
        o.same_size = (b & 4u) != 0u;
        via_capture(r.p, r.n, ".raw", &o);
        break;
    }
    default: {
        vd_capture_opts_t o;
        vd_capture_opts_default(&o);
        o.same_size = (ctl & 4u) != 0u;
        via_capture(r.p, r.n, ".pgm", &o);
        break;
    }
    }
    return 0;
}
