// SPDX-License-Identifier: MIT
// Unit tests of histogram.h: a hand-worked region that takes every path of the counter
// (uniform 8-pixel words, mixed words, the tail, a ROI with stride), a naive count on random views.
#include "unity.h"
#include "testutil.h"

#include <string.h>

void setUp(void) {}
void tearDown(void) {}

// 19 x 2 view, stride 24. Row 0: 8 x 7 (one uniform word), then 1..8 (a mixed
// word), then 9, 9, 9 (tail). Row 1: 8 x 0, 8 x 255, 3 x 255.
// Whole view: 7 -> 8, 1..8 -> 1 each (7 -> 9 in total), 9 -> 3, 0 -> 8, 255 -> 11.
static void test_hand_worked_paths(void)
{
    static uint8_t px[2 * 24];
    memset(px, 0xAA, sizeof px);   // padding that must not be counted (0xAA = 170)
    for (int i = 0; i < 8; i++) {
        px[i] = 7;
        px[8 + i] = (uint8_t)(1 + i);
        px[24 + i] = 0;
        px[24 + 8 + i] = 255;
    }
    for (int i = 16; i < 19; i++) {
        px[i] = 9;
        px[24 + i] = 255;
    }
    vd_view_u8_t v = {px, 19, 2, 24};
    uint32_t hist[256];
    memset(hist, 0xFF, sizeof hist);   // overwritten, not accumulated
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_u8(&v, NULL, hist));
    TEST_ASSERT_EQUAL_UINT32(9u, hist[7]);
    TEST_ASSERT_EQUAL_UINT32(1u, hist[1]);
    TEST_ASSERT_EQUAL_UINT32(1u, hist[8]);
    TEST_ASSERT_EQUAL_UINT32(3u, hist[9]);
    TEST_ASSERT_EQUAL_UINT32(8u, hist[0]);
    TEST_ASSERT_EQUAL_UINT32(11u, hist[255]);
    TEST_ASSERT_EQUAL_UINT32(0u, hist[170]);
    uint32_t total = 0u;
    for (int i = 0; i < 256; i++) {
        total += hist[i];
    }
    TEST_ASSERT_EQUAL_UINT32(38u, total);
    // ROI columns 14..17 of row 0 only: 7, 8, 9, 9.
    vd_rect_t roi = {14, 0, 4, 1};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_u8(&v, &roi, hist));
    TEST_ASSERT_EQUAL_UINT32(1u, hist[7]);
    TEST_ASSERT_EQUAL_UINT32(1u, hist[8]);
    TEST_ASSERT_EQUAL_UINT32(2u, hist[9]);
    TEST_ASSERT_EQUAL_UINT32(0u, hist[255]);
}

static void test_random_vs_naive(void)
{
    static uint8_t px[70 * 40];
    uint32_t seed = 11u;
    for (int trial = 0; trial < 200; trial++) {
        uint32_t w = 1u + tu_rand(&seed) % 60u, h = 1u + tu_rand(&seed) % 40u;
        size_t stride = w + tu_rand(&seed) % 10u;
        uint32_t levels = 1u + tu_rand(&seed) % 256u;   // few levels: many uniform words
        for (size_t i = 0; i < sizeof px; i++) {
            px[i] = (uint8_t)(tu_rand(&seed) % levels);
        }
        vd_view_u8_t v = {px, w, h, stride};
        vd_rect_t roi;
        roi.x = (int32_t)(tu_rand(&seed) % w);
        roi.y = (int32_t)(tu_rand(&seed) % h);
        roi.w = 1 + (int32_t)(tu_rand(&seed) % (w - (uint32_t)roi.x));
        roi.h = 1 + (int32_t)(tu_rand(&seed) % (h - (uint32_t)roi.y));
        uint32_t hist[256], ref[256];
        memset(ref, 0, sizeof ref);
        for (int32_t y = roi.y; y < roi.y + roi.h; y++) {
            for (int32_t x = roi.x; x < roi.x + roi.w; x++) {
                ref[px[(size_t)y * stride + (size_t)x]]++;
            }
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_u8(&v, &roi, hist));
        TEST_ASSERT_EQUAL_UINT32_ARRAY(ref, hist, 256);
    }
}

static void test_bad_arguments(void)
{
    static uint8_t px[4 * 4];
    uint32_t h[256];
    vd_view_u8_t v = {px, 4, 4, 4};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_u8(NULL, NULL, h));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_u8(&v, NULL, NULL));
    vd_rect_t outside = {3, 0, 2, 1};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_u8(&v, &outside, h));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_hand_worked_paths);
    RUN_TEST(test_random_vs_naive);
    RUN_TEST(test_bad_arguments);
    return UNITY_END();
}
