// SPDX-License-Identifier: MIT
// Writers: PGM/PNG round trips through the readers, atomic replacement, RGB canvas drawing.
#include "unity.h"
#include "port_testutil.h"
#include "vd_port/file.h"
#include "vd_port/writer.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char g_err[256];

void setUp(void)
{
    g_err[0] = '\0';
    (void)pt_tmpdir();
}

void tearDown(void)
{
    pt_tmpdir_remove();
}

static vd_decoded_t read_back(const char *path)
{
    uint8_t *buf;
    size_t len;
    vd_decoded_t d;
    memset(&d, 0, sizeof(d));
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_file_read_all(path, &buf, &len, g_err, sizeof(g_err)), g_err);
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_image_decode(buf, len, &d, g_err, sizeof(g_err)), g_err);
    free(buf);
    return d;
}

// Counts entries of the scratch directory (to see that no temporary file is left).
static int dir_entries(void)
{
    DIR *d = opendir(pt_path(""));
    TEST_ASSERT_NOT_NULL(d);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        n += e->d_name[0] != '.' ? 1 : 0;
    }
    (void)closedir(d);
    return n;
}

static void test_pgm_round_trip_8_and_16(void)
{
    // 8-bit with a padded stride: only width bytes per row are written.
    uint8_t px8[3 * 8];
    for (int i = 0; i < 24; i++) {
        px8[i] = (uint8_t)(i * 10);
    }
    vd_frame_t f = {px8, 5u, 3u, 8u, VD_PIX_U8, 0u, 0u};
    const char *p = pt_path("a.pgm");
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_write_pgm(p, &f, g_err, sizeof(g_err)), g_err);
    vd_decoded_t d = read_back(p);
    TEST_ASSERT_EQUAL_UINT32(5u, d.width);
    TEST_ASSERT_EQUAL_UINT32(3u, d.height);
    TEST_ASSERT_EQUAL_INT(VD_PIX_U8, d.format);
    for (uint32_t y = 0; y < 3u; y++) {
        TEST_ASSERT_EQUAL_UINT8_ARRAY(px8 + y * 8u, (const uint8_t *)d.data + y * 5u, 5);
    }
    vd_decoded_free(&d);
    // 16-bit: big-endian in the file, host order again after reading.
    uint16_t px16[6] = {0u, 1u, 255u, 256u, 0x1234u, 65535u};
    vd_frame_t g = {px16, 3u, 2u, 6u, VD_PIX_U16, 0u, 0u};
    p = pt_path("b.pgm");
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_write_pgm(p, &g, g_err, sizeof(g_err)));
    uint8_t raw[64];
    long n = pt_read(p, raw, sizeof(raw));
    TEST_ASSERT_EQUAL_INT(13 + 12, n);   // "P5\n3 2\n65535\n" + 12 bytes
    TEST_ASSERT_EQUAL_HEX8(0x12u, raw[13 + 8]);
    TEST_ASSERT_EQUAL_HEX8(0x34u, raw[13 + 9]);
    d = read_back(p);
    TEST_ASSERT_EQUAL_INT(VD_PIX_U16, d.format);
    TEST_ASSERT_EQUAL_UINT16_ARRAY(px16, d.data, 6);
    vd_decoded_free(&d);
    TEST_ASSERT_EQUAL_INT(2, dir_entries());
}

static void test_write_failures_leave_nothing(void)
{
    uint8_t px[4] = {1, 2, 3, 4};
    vd_frame_t f = {px, 2u, 2u, 2u, VD_PIX_U8, 0u, 0u};
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_write_pgm(pt_path("no/such/dir/x.pgm"), &f, g_err, sizeof(g_err)));
    TEST_ASSERT_NOT_NULL(strstr(g_err, "no/such/dir"));
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_write_png_grey(pt_path("no/such/dir/x.png"), &f, g_err, sizeof(g_err)));
    TEST_ASSERT_EQUAL_INT(0, dir_entries());
    vd_frame_t bad = f;
    bad.stride = 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_write_pgm(pt_path("x.pgm"), &bad, g_err, sizeof(g_err)));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_write_pgm(NULL, &f, NULL, 0));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_write_png_grey(pt_path("x.png"), NULL, NULL, 0));
    uint16_t px16[4] = {0};
    vd_frame_t w = {px16, 2u, 2u, 4u, VD_PIX_U16, 0u, 0u};
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_write_png_grey(pt_path("x.png"), &w, g_err, sizeof(g_err)));
    TEST_ASSERT_EQUAL_INT(0, dir_entries());
    // Replacing an existing file works (rename over it).
    (void)pt_write("keep.pgm", "old", 3u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_write_pgm(pt_path("keep.pgm"), &f, g_err, sizeof(g_err)));
    vd_decoded_t d = read_back(pt_path("keep.pgm"));
    TEST_ASSERT_EQUAL_UINT8_ARRAY(px, d.data, 4);
    vd_decoded_free(&d);
    TEST_ASSERT_EQUAL_INT(1, dir_entries());
}

static void test_png_grey_and_rgb(void)
{
    uint8_t px[6] = {0, 50, 100, 150, 200, 250};
    vd_frame_t f = {px, 3u, 2u, 3u, VD_PIX_U8, 0u, 0u};
    const char *p = pt_path("g.png");
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_write_png_grey(p, &f, g_err, sizeof(g_err)), g_err);
    vd_decoded_t d = read_back(p);
    TEST_ASSERT_EQUAL_INT(VD_PIX_U8, d.format);
    TEST_ASSERT_EQUAL_UINT8_ARRAY(px, d.data, 6);
    vd_decoded_free(&d);

    vd_rgb_t img;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rgb_alloc(&img, 3u, 2u));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rgb_from_frame(&img, &f, 0u, 0u));
    TEST_ASSERT_EQUAL_UINT8(150u, img.data[img.stride + 0u]);
    TEST_ASSERT_EQUAL_UINT8(150u, img.data[img.stride + 2u]);
    p = pt_path("c.png");
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_write_png_rgb(p, &img, g_err, sizeof(g_err)));
    d = read_back(p);   // stb converts grey RGB back to the same grey
    TEST_ASSERT_EQUAL_UINT8_ARRAY(px, d.data, 6);
    vd_decoded_free(&d);
    vd_rgb_free(&img);
    vd_rgb_free(&img);   // twice is fine
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rgb_alloc(&img, 0u, 2u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rgb_alloc(&img, VD_MAX_DIM + 1u, 2u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_write_png_rgb(p, &img, NULL, 0));
}

static void test_rgb_tone_map_u16(void)
{
    uint16_t px[4] = {1000u, 2000u, 3000u, 1500u};
    vd_frame_t f = {px, 4u, 1u, 8u, VD_PIX_U16, 0u, 0u};
    vd_rgb_t img;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rgb_alloc(&img, 4u, 1u));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rgb_from_frame(&img, &f, 0u, 0u));   // auto: 1000..3000
    TEST_ASSERT_EQUAL_UINT8(0u, img.data[0]);
    TEST_ASSERT_EQUAL_UINT8(127u, img.data[3]);
    TEST_ASSERT_EQUAL_UINT8(255u, img.data[6]);
    TEST_ASSERT_EQUAL_UINT8(63u, img.data[9]);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rgb_from_frame(&img, &f, 1500u, 2500u));
    TEST_ASSERT_EQUAL_UINT8(0u, img.data[0]);
    TEST_ASSERT_EQUAL_UINT8(127u, img.data[3]);
    TEST_ASSERT_EQUAL_UINT8(255u, img.data[6]);
    uint16_t flat[4] = {7u, 7u, 7u, 7u};
    f.data = flat;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rgb_from_frame(&img, &f, 0u, 0u));
    TEST_ASSERT_EQUAL_UINT8(128u, img.data[0]);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rgb_from_frame(&img, &f, 5u, 4u));
    f.width = 3u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rgb_from_frame(&img, &f, 0u, 0u));   // size mismatch
    vd_rgb_free(&img);
}

static uint32_t count_colour(const vd_rgb_t *img, uint8_t r, uint8_t g, uint8_t b)
{
    uint32_t n = 0u;
    for (uint32_t y = 0; y < img->height; y++) {
        for (uint32_t x = 0; x < img->width; x++) {
            const uint8_t *p = img->data + y * img->stride + x * 3u;
            n += (p[0] == r && p[1] == g && p[2] == b) ? 1u : 0u;
        }
    }
    return n;
}

static void test_draw_rect_and_text_clip(void)
{
    vd_rgb_t img;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rgb_alloc(&img, 20u, 10u));
    vd_rect_t r = {2, 2, 5, 4};
    vd_rgb_draw_rect(&img, &r, 255u, 0u, 0u, 1u);
    TEST_ASSERT_EQUAL_UINT32(2u * 5u + 2u * 2u, count_colour(&img, 255u, 0u, 0u));   // outline of 5x4
    TEST_ASSERT_EQUAL_UINT8(255u, img.data[2u * img.stride + 2u * 3u]);
    TEST_ASSERT_EQUAL_UINT8(0u, img.data[3u * img.stride + 3u * 3u]);             // inside untouched
    vd_rect_t out = {-5, 5, 100, 100};   // mostly outside: clipped, no crash
    vd_rgb_draw_rect(&img, &out, 0u, 255u, 0u, 3u);
    TEST_ASSERT_TRUE(count_colour(&img, 0u, 255u, 0u) > 0u);
    vd_rect_t far = {INT32_MAX - 2, INT32_MIN, 5, 5};
    vd_rgb_draw_rect(&img, &far, 0u, 0u, 255u, 2u);
    TEST_ASSERT_EQUAL_UINT32(0u, count_colour(&img, 0u, 0u, 255u));
    memset(img.data, 0, img.stride * img.height);
    vd_rgb_draw_text(&img, 1, 1, "0.9", 255u, 255u, 0u, 1u);
    // '0' has 12 ink pixels, '.' 1, '9' 12 (3x5 font)
    TEST_ASSERT_EQUAL_UINT32(25u, count_colour(&img, 255u, 255u, 0u));
    vd_rgb_draw_text(&img, 15, 8, "CONFIRMED ~", 255u, 255u, 255u, 2u);   // runs off the canvas: clipped
    vd_rgb_draw_text(&img, -100, -100, "x", 255u, 255u, 255u, 1u);
    vd_rgb_draw_text(NULL, 0, 0, "x", 1u, 1u, 1u, 1u);
    vd_rgb_draw_rect(NULL, &r, 1u, 1u, 1u, 1u);
    vd_rgb_free(&img);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_pgm_round_trip_8_and_16);
    RUN_TEST(test_write_failures_leave_nothing);
    RUN_TEST(test_png_grey_and_rgb);
    RUN_TEST(test_rgb_tone_map_u16);
    RUN_TEST(test_draw_rect_and_text_clip);
    return UNITY_END();
}
