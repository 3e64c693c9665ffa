// SPDX-License-Identifier: MIT
// File back end: PGM 8/16-bit, raw Y16, PNG/JPEG, directories and lists, and every malformed-file case.
#include "unity.h"
#include "testutil.h"
#include "port_testutil.h"
#include "vd_port/capture.h"
#include "vd_port/file.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static vd_capture_t g_cap;
static char g_err[256];

void setUp(void)
{
    memset(&g_cap, 0, sizeof(g_cap));
    g_err[0] = '\0';
    (void)pt_tmpdir();
}

void tearDown(void)
{
    vd_capture_close(&g_cap);
    pt_tmpdir_remove();
}

static vd_status_t decode_str(const void *buf, size_t len, vd_decoded_t *d)
{
    g_err[0] = '\0';
    return vd_image_decode((const uint8_t *)buf, len, d, g_err, sizeof(g_err));
}

// --- PGM ---------------------------------------------------------------------------------------

static void test_pgm_8bit_with_comments(void)
{
    const char file[] = "P5\n# made by a test\n3 # width\n2\n# maxval next\n255\n\x01\x02\x03\xfd\xfe\xff";
    vd_decoded_t d;
    TEST_ASSERT_EQUAL_INT(VD_OK, decode_str(file, sizeof(file) - 1u, &d));
    TEST_ASSERT_EQUAL_UINT32(3u, d.width);
    TEST_ASSERT_EQUAL_UINT32(2u, d.height);
    TEST_ASSERT_EQUAL_INT(VD_PIX_U8, d.format);
    const uint8_t want[6] = {1, 2, 3, 253, 254, 255};
    TEST_ASSERT_EQUAL_UINT8_ARRAY(want, d.data, 6);
    vd_decoded_free(&d);
    TEST_ASSERT_NULL(d.data);
}

static void test_pgm_16bit_big_endian_to_host(void)
{
    const uint8_t px[8] = {0x01, 0x02, 0xFF, 0xFE, 0x00, 0x07, 0x80, 0x00};
    uint8_t buf[64];
    const char *hdr = "P5 2 2 65535\n";
    size_t hl = strlen(hdr);
    memcpy(buf, hdr, hl);
    memcpy(buf + hl, px, sizeof(px));
    vd_decoded_t d;
    TEST_ASSERT_EQUAL_INT(VD_OK, decode_str(buf, hl + sizeof(px), &d));
    TEST_ASSERT_EQUAL_INT(VD_PIX_U16, d.format);
    const uint16_t want[4] = {0x0102u, 0xFFFEu, 0x0007u, 0x8000u};
    TEST_ASSERT_EQUAL_UINT16_ARRAY(want, d.data, 4);
    vd_decoded_free(&d);
    // maxval 256..65535 is 2 bytes per sample; 255 and below is 1 byte.
    memcpy(buf, "P5 2 1 256\n", 11);
    memcpy(buf + 11, px, 4);
    TEST_ASSERT_EQUAL_INT(VD_OK, decode_str(buf, 15, &d));
    TEST_ASSERT_EQUAL_INT(VD_PIX_U16, d.format);
    TEST_ASSERT_EQUAL_UINT16(0x0102u, ((const uint16_t *)d.data)[0]);
    vd_decoded_free(&d);
    memcpy(buf, "P5 2 1 100\n", 11);
    TEST_ASSERT_EQUAL_INT(VD_OK, decode_str(buf, 13, &d));
    TEST_ASSERT_EQUAL_INT(VD_PIX_U8, d.format);
    vd_decoded_free(&d);
}

typedef struct bad_case {
    const char *text;
    vd_status_t st;
    const char *needle;
} bad_case_t;

static void test_pgm_malformed_headers(void)
{
    static const bad_case_t cases[] = {
        {"", VD_ERR_FORMAT, "empty"},
        {"P", VD_ERR_FORMAT, "P5"},
        {"P6\n1 1\n255\nabc", VD_ERR_FORMAT, "P6"},
        {"P2\n1 1\n255\n7", VD_ERR_FORMAT, "P2"},
        {"P5", VD_ERR_FORMAT, "truncated"},
        {"P5\n", VD_ERR_FORMAT, "truncated"},
        {"P5\n4", VD_ERR_FORMAT, "truncated"},
        {"P5\n4 3", VD_ERR_FORMAT, "truncated"},
        {"P5\n4 3 255", VD_ERR_FORMAT, "truncated"},
        {"P54 3 255\n", VD_ERR_FORMAT, "whitespace"},
        {"P5\nx 3 255\n", VD_ERR_FORMAT, "width"},
        {"P5\n4 -3 255\n", VD_ERR_FORMAT, "height"},
        {"P5\n4 3 255x", VD_ERR_FORMAT, "whitespace"},
        {"P5\n0 3 255\n", VD_ERR_FORMAT, "size"},
        {"P5\n4 0 255\n", VD_ERR_FORMAT, "size"},
        {"P5\n8193 1 255\n", VD_ERR_FORMAT, "size"},
        {"P5\n1 99999 255\n", VD_ERR_FORMAT, "size"},
        {"P5\n1234567890 1 255\n", VD_ERR_FORMAT, "digits"},
        {"P5\n4 3 0\n", VD_ERR_FORMAT, "maxval"},
        {"P5\n4 3 65536\n", VD_ERR_FORMAT, "maxval"},
        {"P5\n4 3 255\n0123456789a", VD_ERR_FORMAT, "truncated"},
        {"P5\n2 2 65535\n0123456", VD_ERR_FORMAT, "truncated"},
        {"P5\n8192 8192 65535\n", VD_ERR_FORMAT, "truncated"},
        {"P5 # comment to the end", VD_ERR_FORMAT, "truncated"},
        {"hello world", VD_ERR_FORMAT, "unknown"},
    };
    for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
        vd_decoded_t d;
        vd_status_t st = decode_str(cases[i].text, strlen(cases[i].text), &d);
        char msg[300];
        (void)snprintf(msg, sizeof(msg), "case %zu \"%s\": got \"%s\"", i, cases[i].text, g_err);
        TEST_ASSERT_EQUAL_INT_MESSAGE(cases[i].st, st, msg);
        TEST_ASSERT_NOT_NULL_MESSAGE(strstr(g_err, cases[i].needle), msg);
        TEST_ASSERT_NULL(d.data);
    }
    vd_decoded_t d;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_image_decode(NULL, 4, &d, NULL, 0));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_image_decode((const uint8_t *)"P5", 2, NULL, NULL, 0));
}

// Every prefix and many random byte flips of a good file: a status, never a crash (ASan/valgrind).
static void test_pgm_prefixes_and_bit_flips(void)
{
    uint8_t buf[64];
    const char *hdr = "P5\n# c\n4 3\n65535\n";
    size_t hl = strlen(hdr);
    memcpy(buf, hdr, hl);
    for (size_t i = 0; i < 24u; i++) {
        buf[hl + i] = (uint8_t)(i * 11u);
    }
    size_t n = hl + 24u;
    vd_decoded_t d;
    TEST_ASSERT_EQUAL_INT(VD_OK, decode_str(buf, n, &d));
    vd_decoded_free(&d);
    for (size_t len = 0; len < n; len++) {
        TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, decode_str(buf, len, &d));
        TEST_ASSERT_TRUE(g_err[0] != '\0');
    }
    uint32_t seed = 12345u;
    uint8_t m[64];
    for (int k = 0; k < 2000; k++) {
        memcpy(m, buf, n);
        size_t at = tu_rand(&seed) % hl;   // header bytes
        m[at] ^= (uint8_t)(1u << (tu_rand(&seed) % 8u));
        vd_status_t st = decode_str(m, n, &d);
        if (st == VD_OK) {
            TEST_ASSERT_TRUE(d.width >= 1u && d.width <= VD_MAX_DIM && d.height >= 1u && d.height <= VD_MAX_DIM);
            vd_decoded_free(&d);
        } else {
            TEST_ASSERT_TRUE(st == VD_ERR_FORMAT || st == VD_ERR_OVERFLOW);
            TEST_ASSERT_NULL(d.data);
        }
    }
}

static void test_pgm_header_parser_direct(void)
{
    const char file[] = "P5\n640 480\n255\n";
    uint32_t w, h, mv;
    size_t off;
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT,
                          vd_pgm_parse_header((const uint8_t *)file, sizeof(file) - 1u, &w, &h, &mv, &off, NULL, 0));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_pgm_parse_header(NULL, 4, &w, &h, &mv, &off, NULL, 0));
    static uint8_t big[640 * 480 + 32];
    memcpy(big, file, sizeof(file) - 1u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_pgm_parse_header(big, sizeof(file) - 1u + 640u * 480u, &w, &h, &mv, &off, g_err,
                                                     sizeof(g_err)));
    TEST_ASSERT_EQUAL_UINT32(640u, w);
    TEST_ASSERT_EQUAL_UINT32(480u, h);
    TEST_ASSERT_EQUAL_UINT32(255u, mv);
    TEST_ASSERT_EQUAL_size_t(sizeof(file) - 1u, off);
}

// --- raw ---------------------------------------------------------------------------------------

static void test_raw_frame_count(void)
{
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_raw_frame_count(4u * 3u * 2u * 5u, 4u, 3u, VD_PIX_U16, &n, g_err, sizeof(g_err)));
    TEST_ASSERT_EQUAL_size_t(5u, n);
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_raw_frame_count(25u, 4u, 3u, VD_PIX_U16, &n, g_err, sizeof(g_err)));
    TEST_ASSERT_NOT_NULL(strstr(g_err, "multiple"));
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_raw_frame_count(0u, 4u, 3u, VD_PIX_U16, &n, g_err, sizeof(g_err)));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_raw_frame_count(24u, 0u, 3u, VD_PIX_U16, &n, NULL, 0));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_raw_frame_count(24u, VD_MAX_DIM + 1u, 3u, VD_PIX_U16, &n, NULL, 0));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_raw_frame_count(24u, 4u, 3u, (vd_pixfmt_t)9, &n, NULL, 0));
}

static void test_raw_y16_multi_frame_file(void)
{
    // 3 frames of 4x2 little-endian Y16: sample = frame * 1000 + index * 257
    uint8_t raw[3 * 8 * 2];
    for (uint32_t f = 0; f < 3u; f++) {
        for (uint32_t i = 0; i < 8u; i++) {
            uint32_t v = f * 1000u + i * 257u;
            raw[(f * 8u + i) * 2u] = (uint8_t)(v & 0xFFu);
            raw[(f * 8u + i) * 2u + 1u] = (uint8_t)(v >> 8);
        }
    }
    const char *path = pt_write("clip.y16", raw, sizeof(raw));
    vd_capture_opts_t o;
    vd_capture_opts_default(&o);
    o.raw_width = 4u;
    o.raw_height = 2u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_open(&g_cap, path, &o));
    uint64_t total = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_file_frame_total(&g_cap, &total));
    TEST_ASSERT_EQUAL_UINT64(3u, total);   // 48 bytes / (4 x 2 x 2) per frame
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_file_frame_total(&g_cap, NULL));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    for (uint32_t f = 0; f < 3u; f++) {
        vd_frame_t fr;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 0, &fr));
        TEST_ASSERT_EQUAL_INT(VD_PIX_U16, fr.format);
        TEST_ASSERT_EQUAL_UINT32(4u, fr.width);
        TEST_ASSERT_EQUAL_UINT32(2u, fr.height);
        TEST_ASSERT_EQUAL_size_t(8u, fr.stride);
        TEST_ASSERT_EQUAL_UINT32(f, fr.seq);
        const uint16_t *px = (const uint16_t *)fr.data;
        for (uint32_t i = 0; i < 8u; i++) {
            TEST_ASSERT_EQUAL_UINT16(f * 1000u + i * 257u, px[i]);
        }
        char want[1100];
        (void)snprintf(want, sizeof(want), "%s#%u", path, (unsigned)f);
        TEST_ASSERT_EQUAL_STRING(want, vd_capture_frame_name(&g_cap));
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &fr));
    }
    vd_frame_t fr;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_capture_next(&g_cap, 0, &fr));
    TEST_ASSERT_TRUE(vd_capture_at_end(&g_cap));

    // Big-endian option, and a single-frame file gets its plain name.
    vd_capture_close(&g_cap);
    const uint8_t be[4] = {0x12, 0x34, 0xAB, 0xCD};
    path = pt_write("one.raw", be, sizeof(be));
    o.raw_width = 2u;
    o.raw_height = 1u;
    o.raw_big_endian = true;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_open(&g_cap, path, &o));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 0, &fr));
    TEST_ASSERT_EQUAL_UINT16(0x1234u, ((const uint16_t *)fr.data)[0]);
    TEST_ASSERT_EQUAL_UINT16(0xABCDu, ((const uint16_t *)fr.data)[1]);
    TEST_ASSERT_EQUAL_STRING(path, vd_capture_frame_name(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &fr));
}

static void test_raw_bad_sizes(void)
{
    uint8_t raw[10] = {0};
    const char *path = pt_write("odd.raw", raw, sizeof(raw));
    vd_capture_opts_t o;
    vd_capture_opts_default(&o);
    o.raw_width = 2u;
    o.raw_height = 2u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_open(&g_cap, path, &o));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    vd_frame_t fr;
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_capture_next(&g_cap, 0, &fr));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "odd.raw"));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "multiple"));
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_capture_next(&g_cap, 0, &fr));
    vd_capture_close(&g_cap);
    // No raw size given: a clear format error.
    vd_capture_opts_default(&o);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_open(&g_cap, path, &o));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_capture_next(&g_cap, 0, &fr));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "raw frame size"));
    vd_capture_close(&g_cap);
    // Invalid raw options are refused at open.
    o.raw_width = 4u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_capture_open(&g_cap, path, &o));
    o.raw_height = VD_MAX_DIM + 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_capture_open(&g_cap, path, &o));
    // An 8-bit raw frame without a raw extension (unknown magic) is read as raw when a size is given.
    vd_capture_opts_default(&o);
    o.raw_width = 5u;
    o.raw_height = 2u;
    o.raw_format = VD_PIX_U8;
    const uint8_t b8[10] = {9, 8, 7, 6, 5, 4, 3, 2, 1, 0};
    path = pt_write("frame.dat", b8, sizeof(b8));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_open(&g_cap, path, &o));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 0, &fr));
    TEST_ASSERT_EQUAL_INT(VD_PIX_U8, fr.format);
    TEST_ASSERT_EQUAL_UINT8_ARRAY(b8, fr.data, 10);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &fr));
}

// --- PNG / JPEG --------------------------------------------------------------------------------

static void test_png16_and_jpeg_fixtures(void)
{
    static uint8_t buf[4096];
    long n = pt_read(VD_SOURCE_DIR "/tests/data/port_u16_5x4.png", buf, sizeof(buf));
    TEST_ASSERT_TRUE(n > 0);
    vd_decoded_t d;
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, decode_str(buf, (size_t)n, &d), g_err);
    TEST_ASSERT_EQUAL_INT(VD_PIX_U16, d.format);
    TEST_ASSERT_EQUAL_UINT32(5u, d.width);
    TEST_ASSERT_EQUAL_UINT32(4u, d.height);
    for (uint32_t i = 0; i < 20u; i++) {
        TEST_ASSERT_EQUAL_UINT16(i * 3000u + 7u, ((const uint16_t *)d.data)[i]);   // written by cv2.imwrite
    }
    vd_decoded_free(&d);
    // Truncated PNG: a status, no crash.
    for (long len = 0; len < n; len += 7) {
        vd_status_t st = decode_str(buf, (size_t)len, &d);
        TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, st);
        TEST_ASSERT_NULL(d.data);
    }
    n = pt_read(VD_SOURCE_DIR "/tests/data/port_grey_16x8.jpg", buf, sizeof(buf));
    TEST_ASSERT_TRUE(n > 0);
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, decode_str(buf, (size_t)n, &d), g_err);
    TEST_ASSERT_EQUAL_INT(VD_PIX_U8, d.format);
    TEST_ASSERT_EQUAL_UINT32(16u, d.width);
    TEST_ASSERT_EQUAL_UINT32(8u, d.height);
    const uint8_t *p = (const uint8_t *)d.data;
    TEST_ASSERT_INT_WITHIN(3, 77, p[2 * 16 + 2]);     // lossy: within a few levels
    TEST_ASSERT_INT_WITHIN(3, 200, p[5 * 16 + 13]);
    vd_decoded_free(&d);
    n = pt_read(VD_SOURCE_DIR "/tests/data/port_grey_16x8.jpg", buf, sizeof(buf));
    buf[n / 2] ^= 0xFFu;   // corrupt entropy data: decodes or fails, never crashes
    if (decode_str(buf, (size_t)n, &d) == VD_OK) {
        vd_decoded_free(&d);
    }
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, decode_str(buf, 40u, &d));
}

static void test_real_frames_from_shared_data(void)
{
    const char *root = tu_data_dir();
    if (root == NULL) {
        TEST_IGNORE_MESSAGE("../shared/data absent: real-frame decode not checked");
        return;
    }
    char dir[1024];
    (void)snprintf(dir, sizeof(dir), "%s/msrs/images", root);
    struct stat sb;
    if (stat(dir, &sb) != 0) {
        TEST_IGNORE_MESSAGE("../shared/data/msrs/images absent");
        return;
    }
    // The MSRS folder (PNG frames, labels in a sub-folder) opens as a directory sequence.
    vd_capture_opts_t o;
    vd_capture_opts_default(&o);
    o.same_size = true;
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_capture_open(&g_cap, dir, &o), vd_capture_error(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    for (int i = 0; i < 3; i++) {
        vd_frame_t fr;
        TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_capture_next(&g_cap, 0, &fr), vd_capture_error(&g_cap));
        TEST_ASSERT_EQUAL_UINT32(640u, fr.width);
        TEST_ASSERT_EQUAL_UINT32(480u, fr.height);
        TEST_ASSERT_EQUAL_INT(VD_PIX_U8, fr.format);
        TEST_ASSERT_NOT_NULL(strstr(vd_capture_frame_name(&g_cap), ".png"));
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &fr));
    }
    vd_capture_close(&g_cap);
    (void)snprintf(dir, sizeof(dir), "%s/hit-uav/frames/images", root);
    if (stat(dir, &sb) == 0) {
        TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_capture_open(&g_cap, dir, &o), vd_capture_error(&g_cap));
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
        vd_frame_t fr;
        TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_capture_next(&g_cap, 0, &fr), vd_capture_error(&g_cap));
        TEST_ASSERT_EQUAL_UINT32(640u, fr.width);
        TEST_ASSERT_EQUAL_UINT32(512u, fr.height);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &fr));
    }
}

// --- sequences ---------------------------------------------------------------------------------

static void write_pgm8(const char *name, uint32_t w, uint32_t h, uint8_t value)
{
    char hdr[64];
    (void)snprintf(hdr, sizeof(hdr), "P5\n%u %u\n255\n", (unsigned)w, (unsigned)h);
    uint8_t px[256];
    memset(px, value, sizeof(px));
    (void)pt_write_pgm(name, hdr, px, (size_t)w * h);
}

static void expect_frame(uint32_t seq, uint8_t value, const char *name_suffix)
{
    vd_frame_t fr;
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_capture_next(&g_cap, 0, &fr), vd_capture_error(&g_cap));
    TEST_ASSERT_EQUAL_UINT32(seq, fr.seq);
    TEST_ASSERT_EQUAL_HEX8(value, ((const uint8_t *)fr.data)[0]);
    const char *name = vd_capture_frame_name(&g_cap);
    size_t nl = strlen(name);
    size_t sl = strlen(name_suffix);
    TEST_ASSERT_TRUE_MESSAGE(nl >= sl && strcmp(name + nl - sl, name_suffix) == 0, name);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &fr));
}

static void test_directory_sorted_with_restart(void)
{
    write_pgm8("003.pgm", 4u, 3u, 33u);
    write_pgm8("001.pgm", 4u, 3u, 11u);
    write_pgm8("002.PGM", 4u, 3u, 22u);   // extension case does not matter
    write_pgm8(".hidden.pgm", 4u, 3u, 99u);
    (void)pt_write("notes.txt", "not a frame\n", 12u);
    TEST_ASSERT_EQUAL_INT(0, mkdir(pt_path("sub.pgm"), 0700));   // a directory named like a frame
    char dir[600];
    (void)snprintf(dir, sizeof(dir), "%s/", pt_path(""));      // trailing slash is fine
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_capture_open(&g_cap, dir, NULL), vd_capture_error(&g_cap));
    uint64_t total = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_file_frame_total(&g_cap, &total));
    TEST_ASSERT_EQUAL_UINT64(3u, total);   // the three frames, not the hidden file, notes or sub-directory
    vd_capture_t closed;
    memset(&closed, 0, sizeof(closed));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_file_frame_total(&closed, &total));   // not a file capture
    for (int round = 0; round < 2; round++) {
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
        expect_frame(0u, 11u, "/001.pgm");
        expect_frame(1u, 22u, "/002.PGM");
        expect_frame(2u, 33u, "/003.pgm");
        vd_frame_t fr;
        TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_capture_next(&g_cap, 0, &fr));
        TEST_ASSERT_TRUE(vd_capture_at_end(&g_cap));
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));
        TEST_ASSERT_FALSE(vd_capture_at_end(&g_cap));
    }
    vd_capture_counters_t k;
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(6u, k.frames);
    TEST_ASSERT_EQUAL_UINT64(0u, k.errors);
}

static void test_directory_with_bad_files_skips_them(void)
{
    write_pgm8("a.pgm", 4u, 3u, 1u);
    (void)pt_write_pgm("b.pgm", "P5\n4 3\n255\n", "short", 5u);      // truncated
    (void)pt_write("c.png", "\x89PNG\r\n\x1a\n garbage", 17u);        // corrupt PNG
    (void)pt_write("d.jpg", "", 0u);                                   // empty
    (void)pt_write_pgm("e.pgm", "P5\n4 3\n0\n", "xxxxxxxxxxxx", 12u); // maxval 0
    write_pgm8("f.pgm", 4u, 3u, 6u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_open(&g_cap, pt_path(""), NULL));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    expect_frame(0u, 1u, "/a.pgm");
    static const char *const bad[4] = {"b.pgm", "c.png", "d.jpg", "e.pgm"};
    for (int i = 0; i < 4; i++) {
        vd_frame_t fr;
        TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_capture_next(&g_cap, 0, &fr));
        TEST_ASSERT_NULL(fr.data);
        TEST_ASSERT_NOT_NULL_MESSAGE(strstr(vd_capture_error(&g_cap), bad[i]), vd_capture_error(&g_cap));
        TEST_ASSERT_EQUAL_INT(VD_CAPTURE_STREAMING, vd_capture_get_state(&g_cap));
    }
    expect_frame(5u, 6u, "/f.pgm");   // seq keeps counting the skipped files
    vd_capture_counters_t k;
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(2u, k.frames);
    TEST_ASSERT_EQUAL_UINT64(4u, k.errors);
}

static void test_directory_without_frames_and_missing_paths(void)
{
    (void)pt_write("readme.txt", "x", 1u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_open(&g_cap, pt_path(""), NULL));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "no frames"));
    TEST_ASSERT_EQUAL_INT(VD_CAPTURE_CLOSED, vd_capture_get_state(&g_cap));
    vd_capture_close(&g_cap);
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_open(&g_cap, pt_path("nope.pgm"), NULL));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "nope.pgm"));
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_open(&g_cap, pt_path("nodir/"), NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_capture_open(&g_cap, "", NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_capture_open(&g_cap, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_capture_open(NULL, "x", NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_file_open(&g_cap, pt_path("readme.txt"), VD_FILE_DIR, NULL));
}

// Frame `seq` of the skip test's clip.y16 (4x2 Y16, sample 0 = frame x 1000) named "...clip.y16#frame".
static void expect_raw(uint32_t seq, uint32_t frame)
{
    vd_frame_t fr;
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_capture_next(&g_cap, 0, &fr), vd_capture_error(&g_cap));
    TEST_ASSERT_EQUAL_UINT32(seq, fr.seq);
    TEST_ASSERT_EQUAL_INT(VD_PIX_U16, fr.format);
    TEST_ASSERT_EQUAL_UINT16(frame * 1000u, ((const uint16_t *)fr.data)[0]);
    char want[32];
    (void)snprintf(want, sizeof(want), "clip.y16#%u", (unsigned)frame);
    const char *name = vd_capture_frame_name(&g_cap);
    TEST_ASSERT_TRUE_MESSAGE(strlen(name) >= strlen(want) && strcmp(name + strlen(name) - strlen(want), want) == 0, name);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &fr));
}

// vd_file_skip: images passed over by path, raw frames by count (into the middle of a raw file, out of one that
// is open), seq as if every frame had been read, the end, and the states it refuses.
static void test_skip_over_images_and_raw_frames(void)
{
    write_pgm8("a.pgm", 4u, 2u, 11u);
    write_pgm8("b.pgm", 4u, 2u, 22u);
    write_pgm8("c.pgm", 4u, 2u, 33u);
    uint8_t raw[3 * 8 * 2];
    memset(raw, 0, sizeof(raw));
    for (uint32_t f = 0; f < 3u; f++) {   // sample 0 of frame f: f x 1000, little-endian
        raw[f * 16u] = (uint8_t)((f * 1000u) & 0xFFu);
        raw[f * 16u + 1u] = (uint8_t)((f * 1000u) >> 8);
    }
    (void)pt_write("clip.y16", raw, sizeof(raw));
    const char *list = pt_write("frames.lst", "a.pgm\nclip.y16\nb.pgm\nc.pgm\n", 27u);
    vd_capture_opts_t o;
    vd_capture_opts_default(&o);
    o.raw_width = 4u;
    o.raw_height = 2u;
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_capture_open(&g_cap, list, &o), vd_capture_error(&g_cap));
    uint64_t total = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_file_frame_total(&g_cap, &total));
    TEST_ASSERT_EQUAL_UINT64(6u, total);   // 3 images + 3 raw frames
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_file_skip(&g_cap, 1u));   // not started
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_file_skip(&g_cap, 0u));
    vd_frame_t fr;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 0, &fr));
    TEST_ASSERT_EQUAL_UINT32(0u, fr.seq);
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_file_skip(&g_cap, 1u));   // a frame held
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &fr));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_file_skip(&g_cap, 2u));   // raw frames 0 and 1: into the raw file
    expect_raw(3u, 2u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_file_skip(&g_cap, 1u));   // b.pgm
    expect_frame(5u, 33u, "/c.pgm");
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_file_skip(&g_cap, 1u));
    TEST_ASSERT_TRUE(vd_capture_at_end(&g_cap));
    // Again from the start: over a.pgm to raw frame 0, then out of the open raw file over one frame.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_file_skip(&g_cap, 1u));
    expect_raw(1u, 0u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_file_skip(&g_cap, 1u));
    expect_raw(3u, 2u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_file_skip(&g_cap, 2u));   // b.pgm, c.pgm: exactly to the end
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_capture_next(&g_cap, 0, &fr));
    TEST_ASSERT_TRUE(vd_capture_at_end(&g_cap));
    // A skip past the end of a raw file that is open, and the arguments refused.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_file_skip(&g_cap, 100u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_file_skip(NULL, 1u));
    vd_capture_t closed;
    memset(&closed, 0, sizeof(closed));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_file_skip(&closed, 1u));
}

static void test_list_file(void)
{
    write_pgm8("x1.pgm", 2u, 2u, 10u);
    write_pgm8("x2.pgm", 2u, 2u, 20u);
    TEST_ASSERT_EQUAL_INT(0, mkdir(pt_path("sub"), 0700));
    write_pgm8("sub/x3.pgm", 2u, 2u, 30u);
    char text[2048];
    (void)snprintf(text, sizeof(text), "# frames\r\n  x2.pgm  \r\n\r\nsub/x3.pgm\n%s\nmissing.pgm\n", pt_path("x1.pgm"));
    const char *list = pt_write("frames.lst", text, strlen(text));
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_capture_open(&g_cap, list, NULL), vd_capture_error(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    expect_frame(0u, 20u, "/x2.pgm");
    expect_frame(1u, 30u, "/sub/x3.pgm");
    expect_frame(2u, 10u, "/x1.pgm");
    vd_frame_t fr;
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_next(&g_cap, 0, &fr));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "missing.pgm"));
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_capture_next(&g_cap, 0, &fr));
    vd_capture_close(&g_cap);
    // Empty list, binary list, over-long line.
    list = pt_write("empty.txt", "# nothing\n\n", 11u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_open(&g_cap, list, NULL));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "no frames"));
    list = pt_write("bin.txt", "a\0b\n", 4u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_capture_open(&g_cap, list, NULL));
    char *longline = (char *)malloc(VD_FILE_MAX_PATH + 10u);
    TEST_ASSERT_NOT_NULL(longline);
    memset(longline, 'a', VD_FILE_MAX_PATH + 9u);
    longline[VD_FILE_MAX_PATH + 9u] = '\n';
    list = pt_write("long.txt", longline, VD_FILE_MAX_PATH + 10u);
    free(longline);
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_capture_open(&g_cap, list, NULL));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "too long"));
}

static void test_same_size_and_16bit_sequence(void)
{
    write_pgm8("1.pgm", 4u, 3u, 1u);
    write_pgm8("2.pgm", 5u, 3u, 2u);
    uint8_t px16[4 * 3 * 2];
    memset(px16, 0x11, sizeof(px16));
    (void)pt_write_pgm("3.pgm", "P5\n4 3\n65535\n", px16, sizeof(px16));
    write_pgm8("4.pgm", 4u, 3u, 4u);
    vd_capture_opts_t o;
    vd_capture_opts_default(&o);
    o.same_size = true;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_open(&g_cap, pt_path(""), &o));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    expect_frame(0u, 1u, "/1.pgm");
    vd_frame_t fr;
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_capture_next(&g_cap, 0, &fr));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "5x3"));
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_capture_next(&g_cap, 0, &fr));   // 16-bit after 8-bit
    expect_frame(3u, 4u, "/4.pgm");
    vd_capture_close(&g_cap);
    // Without same_size every frame comes with its own size and format.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_open(&g_cap, pt_path(""), NULL));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    for (uint32_t i = 0; i < 4u; i++) {
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 0, &fr));
        uint32_t w, h;
        vd_pixfmt_t f;
        vd_capture_format(&g_cap, &w, &h, &f);
        TEST_ASSERT_EQUAL_UINT32(fr.width, w);
        TEST_ASSERT_EQUAL_INT(fr.format, f);
        if (i == 2u) {
            TEST_ASSERT_EQUAL_INT(VD_PIX_U16, fr.format);
            TEST_ASSERT_EQUAL_UINT16(0x1111u, ((const uint16_t *)fr.data)[11]);
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &fr));
    }
}

static void test_dev_path_that_is_a_folder_reads_files(void)
{
    char dir[] = "/dev/shm/vd_port_test_XXXXXX";
    if (mkdtemp(dir) == NULL) {
        TEST_IGNORE_MESSAGE("/dev/shm not writable");
        return;
    }
    char path[64];
    (void)snprintf(path, sizeof(path), "%s/f.pgm", dir);
    FILE *fp = fopen(path, "wb");
    TEST_ASSERT_NOT_NULL(fp);
    (void)fputs("P5 1 1 255\n\x2a", fp);
    (void)fclose(fp);
    vd_status_t st = vd_capture_open(&g_cap, dir, NULL);
    if (st == VD_OK) {
        st = vd_capture_start(&g_cap);
    }
    vd_frame_t fr;
    if (st == VD_OK) {
        st = vd_capture_next(&g_cap, 0, &fr);
    }
    vd_capture_close(&g_cap);
    (void)remove(path);
    (void)rmdir(dir);
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, st, vd_capture_error(&g_cap));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_pgm_8bit_with_comments);
    RUN_TEST(test_pgm_16bit_big_endian_to_host);
    RUN_TEST(test_pgm_malformed_headers);
    RUN_TEST(test_pgm_prefixes_and_bit_flips);
    RUN_TEST(test_pgm_header_parser_direct);
    RUN_TEST(test_raw_frame_count);
    RUN_TEST(test_raw_y16_multi_frame_file);
    RUN_TEST(test_raw_bad_sizes);
    RUN_TEST(test_png16_and_jpeg_fixtures);
    RUN_TEST(test_real_frames_from_shared_data);
    RUN_TEST(test_directory_sorted_with_restart);
    RUN_TEST(test_directory_with_bad_files_skips_them);
    RUN_TEST(test_directory_without_frames_and_missing_paths);
    RUN_TEST(test_list_file);
    RUN_TEST(test_skip_over_images_and_raw_frames);
    RUN_TEST(test_same_size_and_16bit_sequence);
    RUN_TEST(test_dev_path_that_is_a_folder_reads_files);
    return UNITY_END();
}
