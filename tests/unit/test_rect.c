// SPDX-License-Identifier: MIT
// Unit tests of rect.h: ROI resolution, clipping, IoU and the paper's box expansion (hand-worked).
#include "unity.h"

#include <stdint.h>

#include "vd/rect.h"

void setUp(void) {}
void tearDown(void) {}

static void test_roi_resolve(void)
{
    vd_rect_t out;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_roi_resolve(NULL, 640, 480, &out));
    TEST_ASSERT_EQUAL_INT32(640, out.w);
    TEST_ASSERT_EQUAL_INT32(480, out.h);
    vd_rect_t r = {630, 470, 10, 10};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_roi_resolve(&r, 640, 480, &out));
    r.w = 11;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_roi_resolve(&r, 640, 480, &out));
    vd_rect_t hostile = {INT32_MAX, 0, INT32_MAX, 1};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_roi_resolve(&hostile, 640, 480, &out));
    vd_rect_t neg = {-1, 0, 5, 5};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_roi_resolve(&neg, 640, 480, &out));
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

static void assert_rect(int32_t x, int32_t y, int32_t w, int32_t h, const vd_rect_t *r)
{
    TEST_ASSERT_EQUAL_INT32(x, r->x);
    TEST_ASSERT_EQUAL_INT32(y, r->y);
    TEST_ASSERT_EQUAL_INT32(w, r->w);
    TEST_ASSERT_EQUAL_INT32(h, r->h);
}

static void test_expand_centre_and_rounding(void)
{
    vd_rect_t in = {10, 10, 10, 10}, out;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&in, VD_RECT_EXPAND_W_Q8, VD_RECT_EXPAND_H_Q8, 640, 480, &out));
    assert_rect(8, 5, 15, 20, &out); // w 15: 2 px left, 3 right; h 20: 5 up, 5 down
    in = (vd_rect_t){100, 100, 7, 3};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&in, 384, 512, 640, 480, &out));
    assert_rect(98, 99, 11, 6, &out); // 7 * 1.5 = 10.5 -> 11 (g 4: 2 left); 3 * 2 = 6 (g 3: 1 up)
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&in, 256, 256, 640, 480, &out));
    assert_rect(100, 100, 7, 3, &out); // identity
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&in, 128, 64, 640, 480, &out));
    assert_rect(102, 101, 4, 1, &out); // shrink: 3.5 -> 4 (g -3: floor(-1.5) = -2), 0.75 -> 1 (g -2)
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&in, 1, 1, 640, 480, &out));
    assert_rect(103, 101, 1, 1, &out); // never below 1 px
    // in place
    in = (vd_rect_t){10, 10, 10, 10};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&in, 384, 512, 640, 480, &in));
    assert_rect(8, 5, 15, 20, &in);
}

static void test_expand_clips_every_edge(void)
{
    vd_rect_t out;
    vd_rect_t left = {0, 100, 10, 10};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&left, 384, 512, 640, 480, &out));
    assert_rect(0, 95, 13, 20, &out); // x -2 clipped to 0
    vd_rect_t right = {630, 100, 10, 10};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&right, 384, 512, 640, 480, &out));
    assert_rect(628, 95, 12, 20, &out); // 628 + 15 = 643 clipped to 640
    vd_rect_t top = {100, 2, 10, 10};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&top, 384, 512, 640, 480, &out));
    assert_rect(98, 0, 15, 17, &out); // y -3 clipped to 0, bottom at 17
    vd_rect_t bottom = {100, 475, 10, 5};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&bottom, 384, 512, 640, 480, &out));
    assert_rect(98, 473, 15, 7, &out); // 473 + 10 = 483 clipped to 480
    vd_rect_t all = {0, 0, 640, 480};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&all, 384, 512, 640, 480, &out));
    assert_rect(0, 0, 640, 480, &out);
    vd_rect_t corner = {635, 476, 5, 4};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&corner, 65535, 65535, 640, 480, &out));
    TEST_ASSERT_EQUAL_INT32(0, out.x);
    TEST_ASSERT_EQUAL_INT32(0, out.y);
    TEST_ASSERT_EQUAL_INT32(640, out.w);
    TEST_ASSERT_EQUAL_INT32(480, out.h);
    // partly outside input is allowed; entirely outside after expansion is not
    vd_rect_t part = {-4, -4, 6, 6};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&part, 256, 256, 640, 480, &out));
    assert_rect(0, 0, 2, 2, &out);
    vd_rect_t away = {1000, 10, 10, 10};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&away, 384, 512, 640, 480, &out));
    vd_rect_t hostile = {INT32_MAX, INT32_MIN, INT32_MAX, INT32_MAX}; // no overflow: covers the frame
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&hostile, 65535, 65535, 640, 480, &out));
    assert_rect(0, 0, 640, 480, &out);
    vd_rect_t far_left = {INT32_MIN, 0, 1, 1};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&far_left, 65535, 256, 640, 480, &out));
}

static void test_expand_errors(void)
{
    vd_rect_t in = {10, 10, 10, 10}, out;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(NULL, 384, 512, 640, 480, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&in, 384, 512, 640, 480, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&in, 0, 512, 640, 480, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&in, 384, 0, 640, 480, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&in, 384, 512, 0, 480, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&in, 384, 512, 640, VD_MAX_DIM + 1u, &out));
    in.w = 0;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&in, 384, 512, 640, 480, &out));
    in.w = 10;
    in.h = -1;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&in, 384, 512, 640, 480, &out));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_roi_resolve);
    RUN_TEST(test_rect_iou_hand_worked);
    RUN_TEST(test_expand_centre_and_rounding);
    RUN_TEST(test_expand_clips_every_edge);
    RUN_TEST(test_expand_errors);
    return UNITY_END();
}
