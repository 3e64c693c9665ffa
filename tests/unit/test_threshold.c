// SPDX-License-Identifier: MIT
// Unit tests of the constant and percentile thresholds, the linear radiometric calibration and its grey map.
#include "unity.h"
#include "testutil.h"

#include <string.h>

#include "internal/shift_internal.h"

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

static void test_calib_tlinear_30c(void)
{
    // TLinear 0.01 K: temperature_ck == raw, so 30.00 degC = 303.15 K = raw 30315.
    vd_calib_t cal = {65536, 0};
    uint16_t raw = 0;
    int32_t ck = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_centi_celsius(&cal, 3000, &raw));
    TEST_ASSERT_EQUAL_UINT16(30315, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&cal, 30316, &raw));
    TEST_ASSERT_EQUAL_UINT16(30316, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_ck_from_raw(&cal, 30315, &ck));
    TEST_ASSERT_EQUAL_INT32(30315, ck);
    // -273.15 degC and below: raw 0 already qualifies.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_centi_celsius(&cal, -27315, &raw));
    TEST_ASSERT_EQUAL_UINT16(0, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&cal, INT32_MIN, &raw));
    TEST_ASSERT_EQUAL_UINT16(0, raw);
    // Top of the range: 655.35 K is raw 65535; one centi-kelvin more is unreachable.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&cal, 65535, &raw));
    TEST_ASSERT_EQUAL_UINT16(65535, raw);
    raw = 77;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_calib_raw_from_ck(&cal, 65536, &raw));
    TEST_ASSERT_EQUAL_UINT16(77, raw); // unchanged on error
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_calib_raw_from_ck(&cal, INT32_MAX, &raw));
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_calib_raw_from_centi_celsius(&cal, INT32_MAX, &raw));
}

static void test_calib_made_up_linear(void)
{
    // 0.04 K per count (gain 4 ck/count = 262144 in Q16), raw 0 = 200.00 K.
    // 30 degC = 30315 ck: need 20000 + 4*raw >= 30315 -> raw >= 2578.75 -> 2579.
    vd_calib_t cal = {4 * 65536, 20000};
    uint16_t raw = 0;
    int32_t ck = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_centi_celsius(&cal, 3000, &raw));
    TEST_ASSERT_EQUAL_UINT16(2579, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_ck_from_raw(&cal, 2579, &ck));
    TEST_ASSERT_EQUAL_INT32(30316, ck);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_ck_from_raw(&cal, 2578, &ck));
    TEST_ASSERT_EQUAL_INT32(30312, ck);
    // Highest temperature: 20000 + 4 * 65535 = 282140 ck; beyond -> RANGE.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&cal, 282140, &raw));
    TEST_ASSERT_EQUAL_UINT16(65535, raw);
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_calib_raw_from_ck(&cal, 282141, &raw));
    // Below raw 0's temperature.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&cal, 19000, &raw));
    TEST_ASSERT_EQUAL_UINT16(0, raw);
}

static void test_calib_round_half_up(void)
{
    // gain 0.5: temp(raw) = round-half-up(raw / 2): 0,1,1,2,2,3 for raw 0..5
    // (raw 1 -> 0.5 -> 1, raw 3 -> 1.5 -> 2).
    vd_calib_t half = {32768, 0};
    static const int32_t want[6] = {0, 1, 1, 2, 2, 3};
    int32_t ck;
    uint16_t raw;
    for (uint16_t r = 0; r < 6; r++) {
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_ck_from_raw(&half, r, &ck));
        TEST_ASSERT_EQUAL_INT32(want[r], ck);
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&half, 1, &raw));
    TEST_ASSERT_EQUAL_UINT16(1, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&half, 2, &raw));
    TEST_ASSERT_EQUAL_UINT16(3, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&half, 3, &raw));
    TEST_ASSERT_EQUAL_UINT16(5, raw);
    // gain 1.5: temp = 0, 2 (1.5 up), 3, 5 (4.5 up) for raw 0..3.
    vd_calib_t g15 = {98304, 0};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&g15, 1, &raw));
    TEST_ASSERT_EQUAL_UINT16(1, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&g15, 4, &raw));
    TEST_ASSERT_EQUAL_UINT16(3, raw);
    // gain 0: constant temperature = offset.
    vd_calib_t flat = {0, 30000};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&flat, 30000, &raw));
    TEST_ASSERT_EQUAL_UINT16(0, raw);
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_calib_raw_from_ck(&flat, 30001, &raw));
    // Temperature past int32: offset INT32_MAX plus anything positive.
    vd_calib_t top = {65536, INT32_MAX};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_ck_from_raw(&top, 0, &ck));
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_calib_ck_from_raw(&top, 1, &ck));
}

// Naive: smallest raw whose temperature (computed independently) is >= ck.
static int64_t naive_temp(const vd_calib_t *c, uint32_t raw)
{
    int64_t p = (int64_t)raw * c->gain_q16;
    return (int64_t)c->offset_ck + p / 65536 + ((p % 65536) >= 32768 ? 1 : 0);
}

static void test_calib_random_vs_search(void)
{
    uint32_t seed = 99u;
    for (int trial = 0; trial < 60; trial++) {
        vd_calib_t c;
        c.gain_q16 = (int32_t)(tu_rand(&seed) % (trial < 30 ? 200000u : 0x7FFFFFFFu));
        c.offset_ck = (int32_t)(tu_rand(&seed) % 60000u) - 10000;
        int64_t tmax = naive_temp(&c, 65535u);
        for (int q = 0; q < 40; q++) {
            int64_t ck64 = (int64_t)c.offset_ck - 100 + (int64_t)(tu_rand(&seed) % (uint32_t)(tmax - c.offset_ck + 200 > 0x7FFFFFFF ? 0x7FFFFFFF : tmax - c.offset_ck + 200));
            if (ck64 > INT32_MAX) {
                continue;
            }
            int32_t ck = (int32_t)ck64;
            uint16_t raw = 0;
            vd_status_t st = vd_calib_raw_from_ck(&c, ck, &raw);
            if (tmax < ck) {
                TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, st);
                continue;
            }
            TEST_ASSERT_EQUAL_INT(VD_OK, st);
            TEST_ASSERT_TRUE(naive_temp(&c, raw) >= ck);
            if (raw > 0u) {
                TEST_ASSERT_TRUE(naive_temp(&c, raw - 1u) < ck);
            }
            int32_t t;
            if (naive_temp(&c, raw) <= INT32_MAX) {
                TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_ck_from_raw(&c, raw, &t));
                TEST_ASSERT_TRUE((int64_t)t == naive_temp(&c, raw));
            }
        }
    }
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
                int64_t t = naive_temp(&c, px[y * 33u + x]);
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
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u16_ck(&v, NULL, &c, 3000 + VD_CK_PER_0C, &d));
    TEST_ASSERT_EQUAL_UINT8_ARRAY(out2, out, 31 * 20);
}

// floor(x / d) for d > 0 by C's truncating division (a reference independent of shifts).
static int64_t floor_div(int64_t x, int64_t d)
{
    int64_t q = x / d;
    return (x % d != 0 && x < 0) ? q - 1 : q;
}

static void test_shift_helpers(void)
{
    TEST_ASSERT_TRUE(vd_shr_floor_i64(5, 1) == 2);
    TEST_ASSERT_TRUE(vd_shr_floor_i64(-5, 1) == -3);
    TEST_ASSERT_TRUE(vd_shr_floor_i64(-1, 16) == -1);
    TEST_ASSERT_TRUE(vd_shr_floor_i64(-65536, 16) == -1);
    TEST_ASSERT_TRUE(vd_shr_floor_i64(-65537, 16) == -2);
    TEST_ASSERT_TRUE(vd_shr_floor_i64(INT64_MIN, 63) == -1);
    TEST_ASSERT_TRUE(vd_shr_floor_i64(INT64_MAX, 63) == 0);
    TEST_ASSERT_TRUE(vd_shr_round_i64(3, 1) == 2);      // 1.5 -> 2
    TEST_ASSERT_TRUE(vd_shr_round_i64(-3, 1) == -1);    // -1.5 -> -1 (half up)
    TEST_ASSERT_TRUE(vd_shr_round_i64(-32769, 16) == -1);
    TEST_ASSERT_TRUE(vd_shr_round_i64(-32768, 16) == 0);
    uint32_t seed = 5u;
    for (int i = 0; i < 20000; i++) {
        const uint64_t u = (((uint64_t)tu_rand(&seed) << 32) | tu_rand(&seed)) >> (1u + tu_rand(&seed) % 40u);
        const int64_t x = ((u & 1u) != 0u) ? -(int64_t)(u >> 1) - 1 : (int64_t)(u >> 1);
        uint32_t n = 1u + tu_rand(&seed) % 40u;
        TEST_ASSERT_TRUE(vd_shr_floor_i64(x, n) == floor_div(x, (int64_t)1 << n));
        if (x < INT64_MAX / 2 && x > INT64_MIN / 2) {
            TEST_ASSERT_TRUE(vd_shr_round_i64(x, n) == floor_div(x + ((int64_t)1 << (n - 1u)), (int64_t)1 << n));
        }
    }
}

static void test_grey_map_hand_worked(void)
{
    // The detector's defaults: TLinear, grey 0 at 0 C, 255 at 51 C, the 30 C threshold at grey 150.
    vd_calib_t cal = {65536, 0};
    vd_calib_grey_t g;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&g, &cal, VD_CK_PER_0C, VD_CK_PER_0C + 5100));
    TEST_ASSERT_TRUE(g.mul_q16 == 3277);   // round(255 * 65536 / 5100) = round(3276.8)
    TEST_ASSERT_EQUAL_UINT8(0u, vd_calib_grey_u8(&g, (uint16_t)VD_CK_PER_0C));
    TEST_ASSERT_EQUAL_UINT8(150u, vd_calib_grey_u8(&g, (uint16_t)(VD_CK_PER_0C + 3000)));   // 150.01
    TEST_ASSERT_EQUAL_UINT8(255u, vd_calib_grey_u8(&g, (uint16_t)(VD_CK_PER_0C + 5100)));
    TEST_ASSERT_EQUAL_UINT8(255u, vd_calib_grey_u8(&g, 65535u));
    // Below lo the product is negative: (-20 * 3277 + 32768) >> 16 = floor(-0.5001) = -1 -> 0.
    TEST_ASSERT_EQUAL_UINT8(0u, vd_calib_grey_u8(&g, (uint16_t)(VD_CK_PER_0C - 20)));
    TEST_ASSERT_EQUAL_UINT8(0u, vd_calib_grey_u8(&g, 0u));
    // Rounding: 10 ck = 0.5 grey (3277 * 10 = 32770 >= 32768 rounds up), 9 ck = 0.45 grey.
    TEST_ASSERT_EQUAL_UINT8(1u, vd_calib_grey_u8(&g, (uint16_t)(VD_CK_PER_0C + 10)));
    TEST_ASSERT_EQUAL_UINT8(0u, vd_calib_grey_u8(&g, (uint16_t)(VD_CK_PER_0C + 9)));
    // A gain of 2 ck per count and an offset: raw 100 = 1000 + 200 ck.
    vd_calib_t c2 = {2 * 65536, 1000};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&g, &c2, 1000, 1255));
    TEST_ASSERT_TRUE(g.mul_q16 == 65536);
    TEST_ASSERT_EQUAL_UINT8(200u, vd_calib_grey_u8(&g, 100u));
    // Arguments.
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_grey_init(NULL, &cal, 0, 1));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_grey_init(&g, NULL, 0, 1));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_grey_init(&g, &cal, 5, 5));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_grey_init(&g, &cal, 6, 5));
    vd_calib_t neg = {-1, 0};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_grey_init(&g, &neg, 0, 5));
}

// Random calibrations and windows against a division-based reference, and within
// 1 grey level of the exact ratio for windows up to 65 536 ck.
static void test_grey_map_random_vs_naive(void)
{
    uint32_t seed = 11u;
    for (int trial = 0; trial < 200; trial++) {
        vd_calib_t c;
        c.gain_q16 = (int32_t)(tu_rand(&seed) % 400000u);
        c.offset_ck = (int32_t)(tu_rand(&seed) % 40000u) - 5000;
        int32_t lo = (int32_t)(tu_rand(&seed) % 60000u) - 5000;
        int32_t span = 1 + (int32_t)(tu_rand(&seed) % 65536u);
        vd_calib_grey_t g;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&g, &c, lo, lo + span));
        int64_t mul = floor_div((int64_t)255 * 65536 + span / 2, span);
        TEST_ASSERT_TRUE(g.mul_q16 == mul);
        for (int k = 0; k < 300; k++) {
            uint16_t raw = (uint16_t)tu_rand(&seed);
            int32_t t = 0;
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_ck_from_raw(&c, raw, &t));
            int64_t q = floor_div(((int64_t)t - lo) * mul + 32768, 65536);
            uint8_t want = (uint8_t)(q < 0 ? 0 : (q > 255 ? 255 : q));
            TEST_ASSERT_EQUAL_UINT8(want, vd_calib_grey_u8(&g, raw));
            // |grey - exact| <= 1: 255 * (t - lo) within 1 * span of grey * span, clamped.
            int64_t e = ((int64_t)t - lo) * 255;
            int64_t lo_e = e - span;
            int64_t hi_e = e + span;
            int64_t gs = (int64_t)want * span;
            TEST_ASSERT_TRUE((gs >= lo_e || want == 255u) && (gs <= hi_e || want == 0u));
        }
    }
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
    RUN_TEST(test_calib_tlinear_30c);
    RUN_TEST(test_calib_made_up_linear);
    RUN_TEST(test_calib_round_half_up);
    RUN_TEST(test_calib_random_vs_search);
    RUN_TEST(test_u16_ck_mask_vs_naive);
    RUN_TEST(test_shift_helpers);
    RUN_TEST(test_grey_map_hand_worked);
    RUN_TEST(test_grey_map_random_vs_naive);
    RUN_TEST(test_percentile_hand_worked_and_vs_sort);
    return UNITY_END();
}
