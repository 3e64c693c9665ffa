// SPDX-License-Identifier: MIT
// Unit tests of image views, ROI resolution, rectangles and status texts.
#include "unity.h"
#include "testutil.h"

#include <string.h>

void setUp(void) {}
void tearDown(void) {}

static void test_status_str_covers_every_code(void)
{
    for (int st = 0; st >= VD_ERR_OVERFLOW; st--) {
        const char *s = vd_status_str((vd_status_t)st);
        TEST_ASSERT_NOT_NULL(s);
        TEST_ASSERT_TRUE(strcmp(s, "unknown status") != 0);
    }
    TEST_ASSERT_EQUAL_STRING("unknown status", vd_status_str((vd_status_t)-999));
    TEST_ASSERT_EQUAL_STRING("ok", vd_status_str(VD_OK));
}

static void test_view_checks(void)
{
    static uint8_t px[16 * 4];
    vd_view_u8_t v = {px, 16, 4, 16};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_view_u8_check(&v));
    v.stride = 15; // stride smaller than width
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_view_u8_check(&v));
    v.stride = 17; // odd stride is fine for 8-bit
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_view_u8_check(&v));
    v.width = 0;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_view_u8_check(&v));
    v.width = VD_MAX_DIM + 1u;
    v.stride = v.width;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_view_u8_check(&v));
    v.width = 16;
    v.data = NULL;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_view_u8_check(&v));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_view_u8_check(NULL));
}

static void test_view_u16_rejects_odd_stride(void)
{
    static uint16_t px[8 * 2];
    vd_view_u16_t v = {px, 8, 2, 16};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_view_u16_check(&v));
    v.stride = 17;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_view_u16_check(&v));
    v.stride = 14; // smaller than 8 px * 2 bytes
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_view_u16_check(&v));
}

static void test_frame_views(void)
{
    static uint16_t px16[4 * 3];
    vd_frame_t f = {px16, 4, 3, 8, VD_PIX_U16, 7, 0};
    vd_view_u16_t v16;
    vd_view_u8_t v8;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_frame_view_u16(&f, &v16));
    TEST_ASSERT_EQUAL_UINT32(4, v16.width);
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_frame_view_u8(&f, &v8));
    f.format = (vd_pixfmt_t)9;
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_frame_check(&f));
    f.format = VD_PIX_U16;
    f.stride = 7;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_frame_view_u16(&f, &v16));
}

static void test_roi_resolve(void)
{
    vd_rect_t out;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_roi_resolve(NULL, 640, 480, &out));
    TEST_ASSERT_EQUAL_INT32(640, out.w);
    TEST_ASSERT_EQUAL_INT32(480, out.h);
    vd_rect_t r = {630, 470, 10, 10};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_roi_resolve(&r, 640, 480, &out));
    r.w = 11;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_roi_resolve(&r, 640, 480, &out));
    vd_rect_t hostile = {INT32_MAX, 0, INT32_MAX, 1};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_roi_resolve(&hostile, 640, 480, &out));
    vd_rect_t neg = {-1, 0, 5, 5};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_roi_resolve(&neg, 640, 480, &out));
}

static void test_rect_iou_hand_worked(void)
{
    vd_rect_t a = {0, 0, 10, 10};
    vd_rect_t b = {5, 0, 10, 10};   // inter 50, union 150 -> 1/3
    vd_rect_t c = {20, 20, 5, 5};
    TEST_ASSERT_EQUAL_UINT32(10922u, vd_rect_iou_q15(&a, &b));
    TEST_ASSERT_EQUAL_UINT32(32768u, vd_rect_iou_q15(&a, &a));
    TEST_ASSERT_EQUAL_UINT32(0u, vd_rect_iou_q15(&a, &c));
    vd_rect_t clip = {-5, 470, 20, 20};
    TEST_ASSERT_TRUE(vd_rect_clip(&clip, 640, 480));
    TEST_ASSERT_EQUAL_INT32(0, clip.x);
    TEST_ASSERT_EQUAL_INT32(15, clip.w);
    TEST_ASSERT_EQUAL_INT32(10, clip.h);
    vd_rect_t out = {700, 0, 5, 5};
    TEST_ASSERT_FALSE(vd_rect_clip(&out, 640, 480));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_status_str_covers_every_code);
    RUN_TEST(test_view_checks);
    RUN_TEST(test_view_u16_rejects_odd_stride);
    RUN_TEST(test_frame_views);
    RUN_TEST(test_roi_resolve);
    RUN_TEST(test_rect_iou_hand_worked);
    return UNITY_END();
}
