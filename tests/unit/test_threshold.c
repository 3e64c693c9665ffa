// SPDX-License-Identifier: MIT
// Unit tests of the constant, radiometric and percentile thresholds (the calibration itself: test_calib.c).
#include "unity.h"
#include "testutil.h"

#include <string.h>

void setUp(void) {}
void tearDown(void) {}

static void test_u8_hand_worked(void)
{
    // Paper 001: thr 150 keeps pixels >= 150.
    static const uint8_t px[2 * 3] = {149, 150, 151, 0, 255, 150};
    static const uint8_t want[2 * 3] = {0, 255, 255, 0, 255, 255};
    uint8_t out[6];
    vd_view_u8_t v = {px, 3, 2, 3};
    vd_image_u8_t d = {out, 3, 2, 3};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u8(&v, NULL, 150, &d));
    TEST_ASSERT_EQUAL_UINT8_ARRAY(want, out, 6);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u8(&v, NULL, 0, &d)); // every pixel >= 0
    for (int i = 0; i < 6; i++) {
        TEST_ASSERT_EQUAL_UINT8(255, out[i]);
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u8(&v, NULL, 255, &d));
    TEST_ASSERT_EQUAL_UINT8(0, out[0]);
    TEST_ASSERT_EQUAL_UINT8(255, out[4]);
    // ROI = bottom-right 2x1 into a 2x1 dst with a wider stride.
    uint8_t small[8];
    memset(small, 0xAA, sizeof small);
    vd_image_u8_t d2 = {small, 2, 1, 8};
    vd_rect_t roi = {1, 1, 2, 1};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u8(&v, &roi, 151, &d2));
    TEST_ASSERT_EQUAL_UINT8(255, small[0]);
    TEST_ASSERT_EQUAL_UINT8(0, small[1]);
    TEST_ASSERT_EQUAL_UINT8(0xAA, small[2]); // beyond dst width: untouched
}

static void test_u8_random_vs_naive(void)
{
    static uint8_t src[70 * 41];
    static uint8_t out[70 * 41];
    uint32_t seed = 12345u;
    for (int trial = 0; trial < 200; trial++) {
        uint32_t w = 1u + tu_rand(&seed) % 60u, h = 1u + tu_rand(&seed) % 40u;
        size_t stride = w + tu_rand(&seed) % 10u; // odd strides included
        for (size_t i = 0; i < stride * h; i++) {
            src[i] = (uint8_t)tu_rand(&seed);
        }
        vd_rect_t roi;
        roi.x = (int32_t)(tu_rand(&seed) % w);
        roi.y = (int32_t)(tu_rand(&seed) % h);
        roi.w = 1 + (int32_t)(tu_rand(&seed) % (w - (uint32_t)roi.x));
        roi.h = 1 + (int32_t)(tu_rand(&seed) % (h - (uint32_t)roi.y));
        if (trial % 4 == 0) { // ROI touching the right/bottom border
            roi.w = (int32_t)w - roi.x;
            roi.h = (int32_t)h - roi.y;
        }
        uint8_t thr = (uint8_t)tu_rand(&seed);
        vd_view_u8_t v = {src, w, h, stride};
        size_t dstride = (size_t)roi.w + 3u;
        vd_image_u8_t d = {out, (uint32_t)roi.w, (uint32_t)roi.h, dstride};
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u8(&v, &roi, thr, &d));
        for (int32_t y = 0; y < roi.h; y++) {
            for (int32_t x = 0; x < roi.w; x++) {
                uint8_t s = src[(size_t)(roi.y + y) * stride + (size_t)(roi.x + x)];
                TEST_ASSERT_EQUAL_UINT8(s >= thr ? 255 : 0, out[(size_t)y * dstride + (size_t)x]);
            }
        }
    }
}

static void test_bad_arguments(void)
{
    static uint8_t px[4 * 4], out[4 * 4];
    static uint16_t px16[4 * 4];
    vd_view_u8_t v = {px, 4, 4, 4};
    vd_image_u8_t d = {out, 4, 4, 4};
    vd_view_u16_t v16 = {px16, 4, 4, 8};
    vd_calib_t cal = {65536, 0};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u8(NULL, NULL, 1, &d));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u8(&v, NULL, 1, NULL));
    vd_rect_t outside = {2, 2, 3, 1};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u8(&v, &outside, 1, &d));
    vd_rect_t empty = {0, 0, 0, 1};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u8(&v, &empty, 1, &d));
    vd_rect_t roi = {0, 0, 2, 2};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u8(&v, &roi, 1, &d)); // dst 4x4 != roi 2x2
    vd_image_u8_t d_bad = {NULL, 4, 4, 4};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u8(&v, NULL, 1, &d_bad));
    vd_view_u8_t v_zero = {px, 0, 4, 4};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u8(&v_zero, NULL, 1, &d));
    vd_view_u16_t v16_odd = {px16, 3, 4, 7}; // odd byte stride
    vd_image_u8_t d3 = {out, 3, 4, 4};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u16(&v16_odd, NULL, 1, &d3));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u16_ck(&v16_odd, NULL, &cal, 1, &d3));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u16_ck(&v16, NULL, NULL, 1, &d));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u16(&v16, &roi, 1, &d));
    // The all-zero path (threshold out of range) checks its arguments too.
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u16_ck(&v16, &roi, &cal, 70000, &d));
    uint16_t raw;
    int32_t ck;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_raw_from_ck(NULL, 0, &raw));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_raw_from_ck(&cal, 0, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_ck_from_raw(&cal, 0, NULL));
    vd_calib_t neg = {-65536, 100000};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_raw_from_ck(&neg, 0, &raw));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_ck_from_raw(&neg, 0, &ck));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u16_ck(&v16, NULL, &neg, 0, &d));
}

static void test_u16_ck_mask_vs_naive(void)
{
    static uint16_t px[33 * 20];
    static uint8_t out[33 * 20];
    uint32_t seed = 7u;
    vd_calib_t c = {4 * 65536, 20000};
    for (size_t i = 0; i < 33u * 20u; i++) {
        px[i] = (uint16_t)(2500u + tu_rand(&seed) % 200u);
    }
    px[5] = 65535u; // a pixel at the top of the calibration
    vd_view_u16_t v = {px, 31, 20, 33 * 2}; // stride wider than width
    vd_rect_t roi = {0, 0, 31, 20};
    vd_image_u8_t d = {out, 31, 20, 31};
    for (int32_t thr = 29800; thr < 30900; thr += 7) {
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u16_ck(&v, &roi, &c, thr, &d));
        for (uint32_t y = 0; y < 20u; y++) {
            for (uint32_t x = 0; x < 31u; x++) {
                int64_t t = tu_calib_temp_ck(&c, px[y * 33u + x]);
                TEST_ASSERT_EQUAL_UINT8(t >= thr ? 255 : 0, out[y * 31u + x]);
            }
        }
    }
    // Hottest expressible temperature: only the 65535 pixel; one more: nothing, still VD_OK.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u16_ck(&v, NULL, &c, 282140, &d));
    TEST_ASSERT_EQUAL_UINT8(255, out[5]);
    TEST_ASSERT_EQUAL_UINT8(0, out[6]);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u16_ck(&v, NULL, &c, 282141, &d));
    for (size_t i = 0; i < 31u * 20u; i++) {
        TEST_ASSERT_EQUAL_UINT8(0, out[i]);
    }
    // Raw path equals the ck path with the converted threshold.
    uint16_t raw;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_centi_celsius(&c, 3000, &raw));
    static uint8_t out2[31 * 20];
    vd_image_u8_t d2 = {out2, 31, 20, 31};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u16(&v, NULL, raw, &d2));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u16_ck(&v, NULL, &c, 3000 + VD_CALIB_CK_PER_0C, &d));
    TEST_ASSERT_EQUAL_UINT8_ARRAY(out2, out, 31 * 20);
}

// Percentile: the element of rank ceil(N * p / 1000) of the sorted pixels, raised to the floor.
static void test_percentile_hand_worked_and_vs_sort(void)
{
    uint32_t h[256];
    uint8_t t = 0u;
    memset(h, 0, sizeof(h));
    h[20] = 18600u;   // the detector test's dark frame: 600 of 19 200 px at 90..120
    h[90] = 500u;
    h[120] = 100u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_percentile_u8(h, 990u, 50u, &t));
    TEST_ASSERT_EQUAL_UINT8(90u, t);   // rank 19 008 falls on level 90
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_percentile_u8(h, 990u, 96u, &t));
    TEST_ASSERT_EQUAL_UINT8(96u, t);   // the floor wins
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_percentile_u8(h, 1000u, 0u, &t));
    TEST_ASSERT_EQUAL_UINT8(120u, t);  // the maximum
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_percentile_u8(h, 0u, 7u, &t));
    TEST_ASSERT_EQUAL_UINT8(7u, t);    // p = 0: level 0, so the floor
    memset(h, 0, sizeof(h));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_percentile_u8(h, 500u, 3u, &t));
    TEST_ASSERT_EQUAL_UINT8(3u, t);    // empty histogram: level 0, so the floor
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_percentile_u8(NULL, 500u, 0u, &t));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_percentile_u8(h, 500u, 0u, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_percentile_u8(h, 1001u, 0u, &t));
    // Random pixel sets against counting-sort ranks.
    static uint8_t px[5000];
    uint32_t seed = 3u;
    for (int trial = 0; trial < 200; trial++) {
        uint32_t n = 1u + tu_rand(&seed) % 5000u;
        uint32_t spread = 1u + tu_rand(&seed) % 256u;
        memset(h, 0, sizeof(h));
        for (uint32_t i = 0; i < n; i++) {
            px[i] = (uint8_t)(tu_rand(&seed) % spread);
            h[px[i]]++;
        }
        uint32_t p = tu_rand(&seed) % 1001u;
        uint8_t fl = (uint8_t)(tu_rand(&seed) % 64u);
        uint32_t rank = (uint32_t)(((uint64_t)n * p + 999u) / 1000u);   // 1-based; 0 = none needed
        uint32_t level = 0u;
        if (rank > 0u) {
            uint32_t seen = 0u;   // the rank-th smallest pixel, by counting
            for (level = 0u; level < 256u; level++) {
                for (uint32_t i = 0; i < n; i++) {
                    seen += (px[i] == level) ? 1u : 0u;
                }
                if (seen >= rank) {
                    break;
                }
            }
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_percentile_u8(h, p, fl, &t));
        TEST_ASSERT_EQUAL_UINT8(level > fl ? level : fl, t);
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_u8_hand_worked);
    RUN_TEST(test_u8_random_vs_naive);
    RUN_TEST(test_bad_arguments);
    RUN_TEST(test_u16_ck_mask_vs_naive);
    RUN_TEST(test_percentile_hand_worked_and_vs_sort);
    return UNITY_END();
}
