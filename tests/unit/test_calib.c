// SPDX-License-Identifier: MIT
// Unit tests of calib.h (raw <-> centi-kelvin, the temperature -> grey map) and of the shared
// floor/rounding shift helpers (internal/shift_internal.h) the calibration uses.
#include "unity.h"
#include "testutil.h"

#include <string.h>

#include "internal/shift_internal.h"

void setUp(void) {}
void tearDown(void) {}

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

static void test_calib_random_vs_search(void)
{
    uint32_t seed = 99u;
    for (int trial = 0; trial < 60; trial++) {
        vd_calib_t c;
        c.gain_q16 = (int32_t)(tu_rand(&seed) % (trial < 30 ? 200000u : 0x7FFFFFFFu));
        c.offset_ck = (int32_t)(tu_rand(&seed) % 60000u) - 10000;
        int64_t tmax = tu_calib_temp_ck(&c, 65535u);
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
            TEST_ASSERT_TRUE(tu_calib_temp_ck(&c, raw) >= ck);
            if (raw > 0u) {
                TEST_ASSERT_TRUE(tu_calib_temp_ck(&c, raw - 1u) < ck);
            }
            int32_t t;
            if (tu_calib_temp_ck(&c, raw) <= INT32_MAX) {
                TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_ck_from_raw(&c, raw, &t));
                TEST_ASSERT_TRUE((int64_t)t == tu_calib_temp_ck(&c, raw));
            }
        }
    }
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
    // The int32 form (requantisation): -5 >> 1 = floor(-2.5) = -3, INT32_MIN >> 31 = -1.
    TEST_ASSERT_TRUE(vd_shr_floor_i32(-5, 1u) == -3);
    TEST_ASSERT_TRUE(vd_shr_floor_i32(5, 1u) == 2);
    TEST_ASSERT_TRUE(vd_shr_floor_i32(INT32_MIN, 31u) == -1);
    TEST_ASSERT_TRUE(vd_shr_floor_i32(INT32_MAX, 31u) == 0);
    TEST_ASSERT_TRUE(vd_shr_floor_i32(-1, 0u) == -1);
    uint32_t seed = 5u;
    for (int i = 0; i < 20000; i++) {
        const uint64_t u = (((uint64_t)tu_rand(&seed) << 32) | tu_rand(&seed)) >> (1u + tu_rand(&seed) % 40u);
        const int64_t x = ((u & 1u) != 0u) ? -(int64_t)(u >> 1) - 1 : (int64_t)(u >> 1);
        uint32_t n = 1u + tu_rand(&seed) % 40u;
        TEST_ASSERT_TRUE(vd_shr_floor_i64(x, n) == floor_div(x, (int64_t)1 << n));
        const int32_t x32 = (int32_t)(x % 2147483647);
        TEST_ASSERT_TRUE((int64_t)vd_shr_floor_i32(x32, n % 32u) == floor_div(x32, (int64_t)1 << (n % 32u)));
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
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&g, &cal, VD_CALIB_CK_PER_0C, VD_CALIB_CK_PER_0C + 5100));
    TEST_ASSERT_TRUE(g.mul_q16 == 3277);   // round(255 * 65536 / 5100) = round(3276.8)
    TEST_ASSERT_EQUAL_UINT8(0u, vd_calib_grey_u8(&g, (uint16_t)VD_CALIB_CK_PER_0C));
    TEST_ASSERT_EQUAL_UINT8(150u, vd_calib_grey_u8(&g, (uint16_t)(VD_CALIB_CK_PER_0C + 3000)));   // 150.01
    TEST_ASSERT_EQUAL_UINT8(255u, vd_calib_grey_u8(&g, (uint16_t)(VD_CALIB_CK_PER_0C + 5100)));
    TEST_ASSERT_EQUAL_UINT8(255u, vd_calib_grey_u8(&g, 65535u));
    // Below lo the product is negative: (-20 * 3277 + 32768) >> 16 = floor(-0.5001) = -1 -> 0.
    TEST_ASSERT_EQUAL_UINT8(0u, vd_calib_grey_u8(&g, (uint16_t)(VD_CALIB_CK_PER_0C - 20)));
    TEST_ASSERT_EQUAL_UINT8(0u, vd_calib_grey_u8(&g, 0u));
    // Rounding: 10 ck = 0.5 grey (3277 * 10 = 32770 >= 32768 rounds up), 9 ck = 0.45 grey.
    TEST_ASSERT_EQUAL_UINT8(1u, vd_calib_grey_u8(&g, (uint16_t)(VD_CALIB_CK_PER_0C + 10)));
    TEST_ASSERT_EQUAL_UINT8(0u, vd_calib_grey_u8(&g, (uint16_t)(VD_CALIB_CK_PER_0C + 9)));
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

// A random calibration (gain 0..6.1 ck per count, offset -50..350 K) and grey window (lo -50..550 K, span 1..65 536
// ck) into g; *c, *lo, *span as drawn. Every temperature of raw 0..65535 fits an int32.
static void random_map(uint32_t *seed, vd_calib_t *c, int32_t *lo, int32_t *span, vd_calib_grey_t *g)
{
    c->gain_q16 = (int32_t)(tu_rand(seed) % 400000u);
    c->offset_ck = (int32_t)(tu_rand(seed) % 40000u) - 5000;
    *lo = (int32_t)(tu_rand(seed) % 60000u) - 5000;
    *span = 1 + (int32_t)(tu_rand(seed) % 65536u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(g, c, *lo, *lo + *span));
}

// Random calibrations and windows against a division-based reference, and within
// 1 grey level of the exact ratio for windows up to 65 536 ck.
static void test_grey_map_random_vs_naive(void)
{
    uint32_t seed = 11u;
    for (int trial = 0; trial < 200; trial++) {
        vd_calib_t c;
        int32_t lo = 0, span = 0;
        vd_calib_grey_t g;
        random_map(&seed, &c, &lo, &span, &g);
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

// vd_calib_grey_raw_at, hand-worked: the window 1000..4000 ck of TLinear (the detector's per-frame window of its
// test frame): mul = round(255 * 65536 / 3000) = 5571. Grey 150: (150 * 65536 - 32768) / 5571 = 1758.7 -> 1759,
// so 1000 + 1759 = 2759 ck = raw 2759; grey(2759) = (1759 * 5571 + 32768) >> 16 = 150, grey(2758) = 149.
// Grey 128: 1499.9 -> 1500 -> raw 2500. Grey 255: 2993.9 -> 2994 -> raw 3994.
static void test_grey_raw_at_hand_worked(void)
{
    vd_calib_t cal = {65536, 0};
    vd_calib_grey_t g;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&g, &cal, 1000, 4000));
    TEST_ASSERT_TRUE(g.mul_q16 == 5571);
    uint16_t raw = 7u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_raw_at(&g, 150u, &raw));
    TEST_ASSERT_EQUAL_UINT16(2759u, raw);
    TEST_ASSERT_EQUAL_UINT8(150u, vd_calib_grey_u8(&g, 2759u));
    TEST_ASSERT_EQUAL_UINT8(149u, vd_calib_grey_u8(&g, 2758u));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_raw_at(&g, 128u, &raw));
    TEST_ASSERT_EQUAL_UINT16(2500u, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_raw_at(&g, 255u, &raw));
    TEST_ASSERT_EQUAL_UINT16(3994u, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_raw_at(&g, 0u, &raw));
    TEST_ASSERT_EQUAL_UINT16(0u, raw);
    // A window above every raw value's temperature: 65407..65662 ck (a flat frame of 65535 widened about its
    // middle) puts raw 65535 at grey 128, so grey 150 is never reached and *raw stays as it was.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&g, &cal, 65407, 65662));
    TEST_ASSERT_EQUAL_UINT8(128u, vd_calib_grey_u8(&g, 65535u));
    raw = 7u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_calib_grey_raw_at(&g, 150u, &raw));
    TEST_ASSERT_EQUAL_UINT16(7u, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_raw_at(&g, 128u, &raw));
    TEST_ASSERT_EQUAL_UINT16(65535u, raw);
    // Arguments: NULLs, a map not from vd_calib_grey_init, a negative gain.
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_grey_raw_at(NULL, 1u, &raw));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_grey_raw_at(&g, 1u, NULL));
    vd_calib_grey_t zero;
    memset(&zero, 0, sizeof(zero));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_grey_raw_at(&zero, 1u, &raw));
    g.calib.gain_q16 = -1;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_grey_raw_at(&g, 1u, &raw));
}

// Every grey level of random maps (calibrations whose temperatures fit int32) against an exhaustive walk of the
// 65 536 raw values: raw_at is the first raw at or above the level, RANGE exactly when none is.
static void test_grey_raw_at_exhaustive(void)
{
    uint32_t seed = 23u;
    for (int trial = 0; trial < 40; trial++) {
        vd_calib_t c;
        int32_t lo = 0, span = 0;
        vd_calib_grey_t g;
        random_map(&seed, &c, &lo, &span, &g);
        uint32_t first[257];
        for (uint32_t k = 0; k < 257u; k++) {
            first[k] = 65536u;
        }
        uint32_t level = 0u;   // the levels below it have their first raw
        for (uint32_t r = 0u; r < 65536u; r++) {
            const uint8_t v = vd_calib_grey_u8(&g, (uint16_t)r);
            while (level <= v) {
                first[level++] = r;
            }
        }
        for (uint32_t k = 0; k < 256u; k++) {
            uint16_t raw = 0u;
            const vd_status_t st = vd_calib_grey_raw_at(&g, (uint8_t)k, &raw);
            if (first[k] == 65536u) {
                TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, st);
            } else {
                TEST_ASSERT_EQUAL_INT(VD_OK, st);
                TEST_ASSERT_EQUAL_UINT32(first[k], raw);
            }
        }
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_calib_tlinear_30c);
    RUN_TEST(test_calib_made_up_linear);
    RUN_TEST(test_calib_round_half_up);
    RUN_TEST(test_calib_random_vs_search);
    RUN_TEST(test_shift_helpers);
    RUN_TEST(test_grey_map_hand_worked);
    RUN_TEST(test_grey_map_random_vs_naive);
    RUN_TEST(test_grey_raw_at_hand_worked);
    RUN_TEST(test_grey_raw_at_exhaustive);
    return UNITY_END();
}
