// SPDX-License-Identifier: MIT
// Unit tests of image views, frames and status texts (rectangles: test_rect.c).
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

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_status_str_covers_every_code);
    RUN_TEST(test_view_checks);
    RUN_TEST(test_view_u16_rejects_odd_stride);
    RUN_TEST(test_frame_views);
    return UNITY_END();
}
