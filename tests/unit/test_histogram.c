// SPDX-License-Identifier: MIT
// Unit tests of histogram.h: a hand-worked region that takes every path of the counter
// (uniform 8-pixel words, mixed words, the tail, a ROI with stride), a naive count on random views;
// the 16-bit percentiles on a hand-worked plane and against a sort on random ones.
#include "unity.h"
#include "testutil.h"

#include <stdlib.h>
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

// 5 x 2 samples, stride 6 samples (12 B), padding 0xAAAA (43690) that must not count.
// Sorted: 2, 3, 256, 257, 258, 260, 511, 1000, 1000, 65535 (n = 10); percentile p is
// sorted[floor(10 p / 1000)], 65535 when that index is 10.
static void test_percentiles_u16_hand_worked(void)
{
    static uint16_t px[2 * 6];
    static const uint16_t vals[10] = {1000u, 258u, 257u, 65535u, 2u, 256u, 1000u, 3u, 511u, 260u};
    for (size_t i = 0; i < 12u; i++) {
        px[i] = 0xAAAAu;
    }
    for (size_t i = 0; i < 10u; i++) {
        px[(i / 5u) * 6u + i % 5u] = vals[i];
    }
    vd_view_u16_t v = {px, 5, 2, 12};
    uint32_t h[256];
    uint16_t lo = 0u, hi = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_percentiles_u16(&v, 0u, 1000u, h, &lo, &hi));
    TEST_ASSERT_EQUAL_UINT16(2u, lo);        // k = 0: the smallest sample
    TEST_ASSERT_EQUAL_UINT16(65535u, hi);    // k = 10 = n: none, 65535
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_percentiles_u16(&v, 100u, 899u, h, &lo, &hi));
    TEST_ASSERT_EQUAL_UINT16(3u, lo);        // k = 1 (bin 0)
    TEST_ASSERT_EQUAL_UINT16(1000u, hi);     // k = floor(8.99) = 8 (bin 3; with the padding counted: 43690)
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_percentiles_u16(&v, 250u, 500u, h, &lo, &hi));
    TEST_ASSERT_EQUAL_UINT16(256u, lo);      // k = 2 and k = 5 fall in the same high-byte bin (1): one recount
    TEST_ASSERT_EQUAL_UINT16(260u, hi);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_percentiles_u16(&v, 300u, 300u, h, &lo, &hi));
    TEST_ASSERT_EQUAL_UINT16(257u, lo);
    TEST_ASSERT_EQUAL_UINT16(257u, hi);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_percentiles_u16(&v, 1000u, 1000u, h, &lo, &hi));
    TEST_ASSERT_EQUAL_UINT16(65535u, lo);
    TEST_ASSERT_EQUAL_UINT16(65535u, hi);
}

static int cmp_u16(const void *a, const void *b)
{
    const uint16_t x = *(const uint16_t *)a, y = *(const uint16_t *)b;
    return (x > y) - (x < y);
}

static void test_percentiles_u16_random_vs_sort(void)
{
    static uint16_t px[50 * 40], sorted[50 * 40];
    uint32_t seed = 23u;
    for (int trial = 0; trial < 300; trial++) {
        uint32_t w = 1u + tu_rand(&seed) % 40u, h = 1u + tu_rand(&seed) % 40u;
        size_t stride = w + tu_rand(&seed) % 10u;   // in samples
        // Narrow ranges (inside one high-byte bin), camera-like ones, the whole 16 bits.
        uint32_t base = tu_rand(&seed) % 60000u, range = 1u + tu_rand(&seed) % ((trial % 3 == 0) ? 200u : 5000u);
        if (trial % 7 == 0) {
            base = 0u;
            range = 65536u;
        }
        for (size_t i = 0; i < sizeof px / sizeof px[0]; i++) {
            px[i] = (uint16_t)((base + tu_rand(&seed) % range) & 0xFFFFu);
        }
        size_t n = 0u;
        for (uint32_t y = 0; y < h; y++) {
            for (uint32_t x = 0; x < w; x++) {
                sorted[n++] = px[(size_t)y * stride + x];
            }
        }
        qsort(sorted, n, sizeof sorted[0], cmp_u16);
        const uint32_t a = tu_rand(&seed) % 1001u, b = tu_rand(&seed) % 1001u;
        const uint32_t plo = a < b ? a : b, phi = a < b ? b : a;
        const size_t klo = (size_t)(((uint64_t)n * plo) / 1000u), khi = (size_t)(((uint64_t)n * phi) / 1000u);
        vd_view_u16_t v = {px, w, h, stride * 2u};
        uint32_t hist[256];
        uint16_t lo = 0u, hi = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_percentiles_u16(&v, plo, phi, hist, &lo, &hi));
        TEST_ASSERT_EQUAL_UINT16(klo < n ? sorted[klo] : 65535u, lo);
        TEST_ASSERT_EQUAL_UINT16(khi < n ? sorted[khi] : 65535u, hi);
    }
}

static void test_percentiles_u16_bad_arguments(void)
{
    static uint16_t px[4 * 4];
    uint32_t h[256];
    uint16_t lo = 7u, hi = 7u;
    vd_view_u16_t v = {px, 4, 4, 8};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_percentiles_u16(NULL, 0u, 1000u, h, &lo, &hi));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_percentiles_u16(&v, 0u, 1000u, NULL, &lo, &hi));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_percentiles_u16(&v, 0u, 1000u, h, NULL, &hi));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_percentiles_u16(&v, 0u, 1000u, h, &lo, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_percentiles_u16(&v, 600u, 500u, h, &lo, &hi));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_percentiles_u16(&v, 0u, 1001u, h, &lo, &hi));
    vd_view_u16_t odd = {px, 4, 4, 9};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_percentiles_u16(&odd, 0u, 1000u, h, &lo, &hi));
    vd_view_u16_t narrow = {px, 4, 4, 6};   // stride below the row
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_histogram_percentiles_u16(&narrow, 0u, 1000u, h, &lo, &hi));
    TEST_ASSERT_EQUAL_UINT16(7u, lo);
    TEST_ASSERT_EQUAL_UINT16(7u, hi);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_hand_worked_paths);
    RUN_TEST(test_random_vs_naive);
    RUN_TEST(test_bad_arguments);
    RUN_TEST(test_percentiles_u16_hand_worked);
    RUN_TEST(test_percentiles_u16_random_vs_sort);
    RUN_TEST(test_percentiles_u16_bad_arguments);
    return UNITY_END();
}
