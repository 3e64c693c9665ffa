// SPDX-License-Identifier: MIT
// Unit tests of the 3x3 and 5x5 median filters (replicated borders, ROIs, strides).
#include "unity.h"
#include "testutil.h"

#include <string.h>

void setUp(void) {}
void tearDown(void) {}

typedef vd_status_t (*median_fn)(const vd_view_u8_t *, const vd_rect_t *, vd_image_u8_t *);

// Naive reference: gather the k x k window with clamped coordinates, insertion sort.
static uint8_t naive_at(const uint8_t *px, int w, int h, size_t stride, int cx, int cy, int k)
{
    uint8_t win[25];
    int n = 0, r = k / 2;
    for (int dy = -r; dy <= r; dy++) {
        for (int dx = -r; dx <= r; dx++) {
            int x = cx + dx, y = cy + dy;
            x = x < 0 ? 0 : (x >= w ? w - 1 : x);
            y = y < 0 ? 0 : (y >= h ? h - 1 : y);
            uint8_t v = px[(size_t)y * stride + (size_t)x];
            int j = n++;
            while (j > 0 && win[j - 1] > v) {
                win[j] = win[j - 1];
                j--;
            }
            win[j] = v;
        }
    }
    return win[n / 2];
}

static void test_hand_worked_3x3(void)
{
    // 3x3 image; at the corner (0,0) the replicated window is
    //   1 1 2      rows -1 and 0 both are row 0, column -1 is column 0:
    //   1 1 2      {1,1,2, 1,1,2, 4,4,9} sorted 1,1,1,1,2,2,4,4,9 -> median 2
    //   4 4 9
    // The centre sees all 9 values 1 2 3 4 9 5 7 8 6 -> sorted 1..9 -> 5.
    static const uint8_t px[9] = {1, 2, 3, 4, 9, 5, 7, 8, 6};
    uint8_t out[9];
    vd_view_u8_t v = {px, 3, 3, 3};
    vd_image_u8_t d = {out, 3, 3, 3};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_median3_u8(&v, NULL, &d));
    TEST_ASSERT_EQUAL_UINT8(2, out[0]);
    TEST_ASSERT_EQUAL_UINT8(5, out[4]);
    // 5x5 on the same image: every pixel of the 3x3 image is in every 5x5 window,
    // weighted by replication. At the centre (1,1) the window is columns
    // -1..3 -> 0,0,1,2,2 and the same for rows: counts per pixel are
    // corner 4, edge 2, centre 1 ... the values with weights:
    //   1:4 2:2 3:4 4:2 9:1 5:2 7:4 8:2 6:4 (25 in all); sorted cumulative:
    //   1(4) 2(6) 3(10) 4(12) 5(14) -> the 13th is 5.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_median5_u8(&v, NULL, &d));
    TEST_ASSERT_EQUAL_UINT8(5, out[4]);
    // A single pixel image is its own median.
    static const uint8_t one = 42;
    vd_view_u8_t v1 = {&one, 1, 1, 1};
    vd_image_u8_t d1 = {out, 1, 1, 1};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_median3_u8(&v1, NULL, &d1));
    TEST_ASSERT_EQUAL_UINT8(42, out[0]);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_median5_u8(&v1, NULL, &d1));
    TEST_ASSERT_EQUAL_UINT8(42, out[0]);
}

static void check_random(median_fn fn, int k, uint32_t seed0)
{
    static uint8_t px[280 * 40];
    static uint8_t out[280 * 40];
    uint32_t seed = seed0;
    // Widths around the strip boundaries (3x3: 64-pixel blocks; 5x5: strips
    // of S5 = 128 (SIMD hosts) or 4 (scalar) outputs, which need S5 + 4 columns).
    static const uint32_t widths[] = {1,   2,   3,   4,   5,   7,   8,   9,   12,  63,  64,  65,  66, 67, 68,
                                      127, 128, 129, 130, 131, 132, 133, 150, 255, 256, 257, 259, 260, 270};
    const int n_widths = (int)(sizeof widths / sizeof widths[0]);
    for (int trial = 0; trial < 160; trial++) {
        uint32_t w = trial < n_widths ? widths[trial] : 1u + tu_rand(&seed) % 270u;
        uint32_t h = 1u + tu_rand(&seed) % 30u;
        size_t stride = w + tu_rand(&seed) % 7u;
        int mode = trial % 4;
        for (size_t i = 0; i < stride * h; i++) {
            uint32_t r = tu_rand(&seed);
            px[i] = mode == 0 ? (uint8_t)r : mode == 1 ? (uint8_t)((r & 1u) * 255u) : mode == 2 ? (uint8_t)(r % 5u) : (uint8_t)(i & 0xFF);
        }
        vd_rect_t roi = {0, 0, (int32_t)w, (int32_t)h};
        if (trial % 3 != 0) {
            roi.x = (int32_t)(tu_rand(&seed) % w);
            roi.y = (int32_t)(tu_rand(&seed) % h);
            roi.w = 1 + (int32_t)(tu_rand(&seed) % (w - (uint32_t)roi.x));
            roi.h = 1 + (int32_t)(tu_rand(&seed) % (h - (uint32_t)roi.y));
            if (trial % 5 == 1) { // ROI on the right/bottom border
                roi.w = (int32_t)w - roi.x;
                roi.h = (int32_t)h - roi.y;
            }
        }
        vd_view_u8_t v = {px, w, h, stride};
        size_t dstride = (size_t)roi.w + (size_t)(trial % 3);
        memset(out, 0xCD, sizeof out);
        vd_image_u8_t d = {out, (uint32_t)roi.w, (uint32_t)roi.h, dstride};
        TEST_ASSERT_EQUAL_INT(VD_OK, fn(&v, &roi, &d));
        for (int32_t y = 0; y < roi.h; y++) {
            for (int32_t x = 0; x < roi.w; x++) {
                uint8_t want = naive_at(px, (int)w, (int)h, stride, roi.x + x, roi.y + y, k);
                TEST_ASSERT_EQUAL_UINT8(want, out[(size_t)y * dstride + (size_t)x]);
            }
            for (size_t x = (size_t)roi.w; x < dstride; x++) {
                TEST_ASSERT_EQUAL_HEX8(0xCD, out[(size_t)y * dstride + x]); // padding untouched
            }
        }
    }
}

static void test_median3_random_vs_naive(void) { check_random(vd_median3_u8, 3, 31u); }
static void test_median5_random_vs_naive(void) { check_random(vd_median5_u8, 5, 55u); }

static void test_constant_and_two_level(void)
{
    static uint8_t px[70 * 9], out[70 * 9];
    vd_view_u8_t v = {px, 70, 9, 70};
    vd_image_u8_t d = {out, 70, 9, 70};
    memset(px, 77, sizeof px);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_median5_u8(&v, NULL, &d));
    for (size_t i = 0; i < sizeof out; i++) {
        TEST_ASSERT_EQUAL_UINT8(77, out[i]);
    }
    // Left half 0, right half 255 (edge at x = 35): a vertical step survives both filters.
    for (int y = 0; y < 9; y++) {
        for (int x = 0; x < 70; x++) {
            px[y * 70 + x] = x < 35 ? 0 : 255;
        }
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_median3_u8(&v, NULL, &d));
    TEST_ASSERT_EQUAL_UINT8_ARRAY(px, out, sizeof px);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_median5_u8(&v, NULL, &d));
    TEST_ASSERT_EQUAL_UINT8_ARRAY(px, out, sizeof px);
    // A lone hot pixel is removed.
    memset(px, 10, sizeof px);
    px[4 * 70 + 20] = 250;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_median3_u8(&v, NULL, &d));
    TEST_ASSERT_EQUAL_UINT8(10, out[4 * 70 + 20]);
}

static void test_bad_arguments(void)
{
    static uint8_t px[8 * 8], out[8 * 8];
    vd_view_u8_t v = {px, 8, 8, 8};
    vd_image_u8_t d = {out, 8, 8, 8};
    median_fn fns[2] = {vd_median3_u8, vd_median5_u8};
    for (int i = 0; i < 2; i++) {
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, fns[i](NULL, NULL, &d));
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, fns[i](&v, NULL, NULL));
        vd_rect_t outside = {4, 4, 5, 4};
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, fns[i](&v, &outside, &d));
        vd_rect_t roi = {0, 0, 4, 4};
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, fns[i](&v, &roi, &d)); // dst 8x8 != 4x4
        vd_view_u8_t zero = {px, 8, 0, 8};
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, fns[i](&zero, NULL, &d));
        vd_image_u8_t short_stride = {out, 8, 8, 7};
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, fns[i](&v, NULL, &short_stride));
        vd_image_u8_t null_dst = {NULL, 8, 8, 8};
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, fns[i](&v, NULL, &null_dst));
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_hand_worked_3x3);
    RUN_TEST(test_median3_random_vs_naive);
    RUN_TEST(test_median5_random_vs_naive);
    RUN_TEST(test_constant_and_two_level);
    RUN_TEST(test_bad_arguments);
    return UNITY_END();
}
