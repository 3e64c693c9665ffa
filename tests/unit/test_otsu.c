// SPDX-License-Identifier: MIT
// Unit tests of the exact Otsu threshold and the 192-bit ratio comparison (the histogram: test_histogram.c).
#include "unity.h"
#include "testutil.h"
#include "pixel/otsu_internal.h"

#include <string.h>

void setUp(void) {}
void tearDown(void) {}

// Reference arithmetic for the tests only: naive 256-bit unsigned integers as
// 16 limbs of 16 bits (schoolbook, deliberately unlike the library's 32-bit
// split), so the same checks run on every target; 32-bit ones (armhf) have no
// __int128. Where __int128 exists, the reference itself is cross-checked
// against it (test_reference_arithmetic).
#define MP_LIMBS 16
typedef struct mp {
    uint32_t l[MP_LIMBS]; // each < 2^16, l[0] least significant
} mp_t;

static mp_t mp_u64(uint64_t v)
{
    mp_t r;
    memset(&r, 0, sizeof r);
    for (int i = 0; i < 4; i++) {
        r.l[i] = (uint32_t)(v >> (16 * i)) & 0xFFFFu;
    }
    return r;
}

// a * b mod 2^256 (every product in these tests is < 2^200).
static mp_t mp_mul(mp_t a, mp_t b)
{
    uint32_t acc[MP_LIMBS];
    memset(acc, 0, sizeof acc);
    for (int i = 0; i < MP_LIMBS; i++) {
        uint32_t carry = 0u;
        for (int j = 0; i + j < MP_LIMBS; j++) {
            // < 2^16 + (2^16-1)^2 + 2^16 < 2^32
            const uint32_t t = acc[i + j] + a.l[i] * b.l[j] + carry;
            acc[i + j] = t & 0xFFFFu;
            carry = t >> 16;
        }
    }
    mp_t r;
    memcpy(r.l, acc, sizeof acc);
    return r;
}

static int mp_cmp(mp_t a, mp_t b)
{
    for (int i = MP_LIMBS - 1; i >= 0; i--) {
        if (a.l[i] != b.l[i]) {
            return a.l[i] > b.l[i] ? 1 : -1;
        }
    }
    return 0;
}

// 64-bit word k (0 = least significant) of a.
static uint64_t mp_word(mp_t a, int k)
{
    uint64_t w = 0u;
    for (int i = 3; i >= 0; i--) {
        w = (w << 16) | a.l[4 * k + i];
    }
    return w;
}

// x^2 * d as a reference value.
static mp_t mp_sq_mul(uint64_t x, uint64_t d)
{
    return mp_mul(mp_mul(mp_u64(x), mp_u64(x)), mp_u64(d));
}

static void test_reference_arithmetic(void)
{
    // Hand-worked: (2^64-1)^2 = 2^128 - 2^65 + 1.
    mp_t sq = mp_mul(mp_u64(UINT64_MAX), mp_u64(UINT64_MAX));
    TEST_ASSERT_TRUE(mp_word(sq, 0) == 1u && mp_word(sq, 1) == UINT64_MAX - 1u && mp_word(sq, 2) == 0u);
    TEST_ASSERT_EQUAL_INT(1, mp_cmp(mp_u64(2u), mp_u64(1u)));
    TEST_ASSERT_EQUAL_INT(0, mp_cmp(mp_sq_mul(3u, 5u), mp_u64(45u)));
#if defined(__SIZEOF_INT128__)
    __extension__ typedef unsigned __int128 u128;
    uint32_t seed = 11u;
    for (int i = 0; i < 2000; i++) {
        const uint64_t a = ((uint64_t)tu_rand(&seed) << 32) | tu_rand(&seed);
        const uint64_t b = ((uint64_t)tu_rand(&seed) << 32) | tu_rand(&seed);
        const u128 p = (u128)a * b;
        const mp_t q = mp_mul(mp_u64(a), mp_u64(b));
        TEST_ASSERT_TRUE(mp_word(q, 0) == (uint64_t)p && mp_word(q, 1) == (uint64_t)(p >> 64) &&
                         mp_word(q, 2) == 0u);
    }
#endif
}

static void test_hand_worked_4x4(void)
{
    // 8 pixels of 10, 4 of 20, 4 of 200: N = 16, S = 80 + 80 + 800 = 960.
    // t = 10: n0 = 8,  s0 = 80:  D = 16*80  - 8*960  = -6400, d = 8*8  = 64,
    //         D^2/d = 40960000/64 = 640000.
    // t = 20: n0 = 12, s0 = 160: D = 16*160 - 12*960 = -8960, d = 12*4 = 48,
    //         D^2/d = 80281600/48 = 1672533.3  -> the maximum: Otsu = 20.
    // (class means 13.3 | 200 separate better than 10 | 107.5.)
    static const uint8_t px[16] = {10, 10, 20, 200, 10, 10, 20, 200, 10, 10, 20, 200, 10, 10, 20, 200};
    vd_view_u8_t v = {px, 4, 4, 4};
    uint8_t t = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_u8(&v, NULL, &t));
    TEST_ASSERT_EQUAL_UINT8(20, t);
    uint32_t hist[256];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_u8(&v, NULL, hist));
    TEST_ASSERT_EQUAL_UINT32(8, hist[10]);
    TEST_ASSERT_EQUAL_UINT32(4, hist[20]);
    TEST_ASSERT_EQUAL_UINT32(4, hist[200]);
    // ROI = the left 2 columns: only 10s -> one level -> 0 (OpenCV's answer).
    vd_rect_t left = {0, 0, 2, 4};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_u8(&v, &left, &t));
    TEST_ASSERT_EQUAL_UINT8(0, t);
    // ROI = columns 1..2: 10 and 20, four each -> t = 10 (first level of the split).
    vd_rect_t mid = {1, 0, 2, 4};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_u8(&v, &mid, &t));
    TEST_ASSERT_EQUAL_UINT8(10, t);
}

static void test_degenerate_histograms(void)
{
    uint32_t h[256];
    uint8_t t = 99;
    memset(h, 0, sizeof h);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_otsu_from_hist(h, &t)); // no pixels
    TEST_ASSERT_EQUAL_UINT8(99, t);
    h[255] = 7;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_from_hist(h, &t)); // constant region
    TEST_ASSERT_EQUAL_UINT8(0, t);
    h[0] = 1;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_from_hist(h, &t));
    TEST_ASSERT_EQUAL_UINT8(0, t);
    memset(h, 0, sizeof h);
    h[254] = 1;
    h[255] = 1;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_from_hist(h, &t));
    TEST_ASSERT_EQUAL_UINT8(254, t);
    // Exact tie between two different splits (symmetric 3 levels 2-1-2):
    // t = 10 and t = 20 have equal criteria; the first one is returned.
    memset(h, 0, sizeof h);
    h[10] = 2;
    h[20] = 1;
    h[30] = 2;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_from_hist(h, &t));
    TEST_ASSERT_EQUAL_UINT8(10, t);
    // Largest accepted count, and one more.
    memset(h, 0, sizeof h);
    h[0] = VD_OTSU_MAX_COUNT - 1u;
    h[255] = 1u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_from_hist(h, &t));
    TEST_ASSERT_EQUAL_UINT8(0, t);
    h[255] = 2u;
    t = 99;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_otsu_from_hist(h, &t));
    TEST_ASSERT_EQUAL_UINT8(99, t);
    for (int i = 0; i < 256; i++) {
        h[i] = 0xFFFFFFFFu; // sum beyond 2^32 must not wrap into range
    }
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_otsu_from_hist(h, &t));
}

static void test_bad_arguments(void)
{
    static uint8_t px[4 * 4];
    uint32_t h[256];
    uint8_t t;
    vd_view_u8_t v = {px, 4, 4, 4};
    vd_rect_t neg = {-1, 0, 2, 1};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_otsu_u8(&v, &neg, &t));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_otsu_u8(&v, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_otsu_from_hist(NULL, &t));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_otsu_from_hist(h, NULL));
    vd_view_u8_t bad = {px, 4, 4, 3}; // stride < width
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_otsu_u8(&bad, NULL, &t));
}

static void test_wide_multiply_and_ratio(void)
{
    uint32_t seed = 5u;
    for (int i = 0; i < 20000; i++) {
        uint64_t a = ((uint64_t)tu_rand(&seed) << 32) | tu_rand(&seed);
        uint64_t b = ((uint64_t)tu_rand(&seed) << 32) | tu_rand(&seed);
        if (i % 3 == 0) {
            a = UINT64_MAX - (a & 0xFF); // carries everywhere
        }
        uint64_t hi, lo;
        vd_mul_u64_wide(a, b, &hi, &lo);
        const mp_t p = mp_mul(mp_u64(a), mp_u64(b));
        TEST_ASSERT_TRUE(hi == mp_word(p, 1) && lo == mp_word(p, 0));
        // Ratios in the reference: a, b < 2^40, d < 2^46.
        uint64_t x = a >> 24, y = b >> 24;
        uint64_t dx = 1u + (((uint64_t)tu_rand(&seed) << 14) ^ tu_rand(&seed));
        uint64_t dy = (i % 5 == 0) ? dx : 1u + (((uint64_t)tu_rand(&seed) << 14) ^ tu_rand(&seed));
        if (i % 7 == 0) {
            y = x; // equal numerators: exact ties must compare false both ways
        }
        int want = mp_cmp(mp_sq_mul(x, dy), mp_sq_mul(y, dx)) > 0;
        TEST_ASSERT_EQUAL_INT(want, vd_ratio_sq_gt(x, dx, y, dy));
    }
    // Full range against the reference (products up to 2^192).
    for (int i = 0; i < 2000; i++) {
        const uint64_t x = ((uint64_t)tu_rand(&seed) << 32) | tu_rand(&seed);
        const uint64_t y = (i % 4 == 0) ? x : (((uint64_t)tu_rand(&seed) << 32) | tu_rand(&seed));
        const uint64_t dx = 1u | ((uint64_t)tu_rand(&seed) << 32) | tu_rand(&seed);
        const uint64_t dy = (i % 6 == 0) ? dx : (1u | ((uint64_t)tu_rand(&seed) << 32) | tu_rand(&seed));
        const int want = mp_cmp(mp_sq_mul(x, dy), mp_sq_mul(y, dx)) > 0;
        TEST_ASSERT_EQUAL_INT(want, vd_ratio_sq_gt(x, dx, y, dy));
    }
    // Full-range values: (2^64-1)^2 * (2^64-1) vs the same minus one in the denominator.
    TEST_ASSERT_TRUE(vd_ratio_sq_gt(UINT64_MAX, UINT64_MAX - 1u, UINT64_MAX, UINT64_MAX));
    TEST_ASSERT_FALSE(vd_ratio_sq_gt(UINT64_MAX, UINT64_MAX, UINT64_MAX, UINT64_MAX));
    TEST_ASSERT_TRUE(vd_ratio_sq_gt(UINT64_MAX, 1u, UINT64_MAX - 1u, 1u));
}

// Naive Otsu: every t with 0 < n0 < N, criterion D^2 / d compared as D^2 * d' vs D'^2 * d in
// the reference arithmetic (N < 2^14 here).
static uint8_t naive_otsu(const uint32_t h[256])
{
    int64_t n = 0, s = 0;
    for (int v = 0; v < 256; v++) {
        n += h[v];
        s += (int64_t)h[v] * v;
    }
    int64_t n0 = 0, s0 = 0;
    uint64_t ba = 0u, bd = 1u;   // best |D| and its d
    int best = 0;
    for (int t = 0; t < 256; t++) {
        n0 += h[t];
        s0 += (int64_t)h[t] * t;
        if (n0 == 0 || n0 == n) {
            continue;
        }
        int64_t dd = n * s0 - n0 * s;
        const uint64_t a = (uint64_t)(dd < 0 ? -dd : dd);
        const uint64_t den = (uint64_t)(n0 * (n - n0));
        if (mp_cmp(mp_sq_mul(a, bd), mp_sq_mul(ba, den)) > 0) {
            ba = a;
            bd = den;
            best = t;
        }
    }
    return (uint8_t)best;
}

static void test_random_vs_naive(void)
{
    static uint8_t px[90 * 70];
    uint32_t seed = 2024u;
    for (int trial = 0; trial < 300; trial++) {
        uint32_t w = 1u + tu_rand(&seed) % 80u, h = 1u + tu_rand(&seed) % 70u;
        size_t stride = w + tu_rand(&seed) % 9u;
        uint32_t levels = 1u + tu_rand(&seed) % 12u; // few levels: many plateaus and near ties
        uint8_t lv[12];
        for (uint32_t k = 0; k < levels; k++) {
            lv[k] = (uint8_t)tu_rand(&seed);
        }
        for (size_t i = 0; i < stride * h; i++) {
            px[i] = (trial % 3 == 0) ? (uint8_t)tu_rand(&seed) : lv[tu_rand(&seed) % levels];
        }
        vd_rect_t roi;
        roi.x = (int32_t)(tu_rand(&seed) % w);
        roi.y = (int32_t)(tu_rand(&seed) % h);
        roi.w = 1 + (int32_t)(tu_rand(&seed) % (w - (uint32_t)roi.x));
        roi.h = 1 + (int32_t)(tu_rand(&seed) % (h - (uint32_t)roi.y));
        vd_view_u8_t v = {px, w, h, stride};
        uint32_t hist[256], ref[256];
        memset(ref, 0, sizeof ref);
        for (int32_t y = 0; y < roi.h; y++) {
            for (int32_t x = 0; x < roi.w; x++) {
                ref[px[(size_t)(roi.y + y) * stride + (size_t)(roi.x + x)]]++;
            }
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_u8(&v, &roi, hist));
        TEST_ASSERT_EQUAL_UINT32_ARRAY(ref, hist, 256);
        uint8_t t = 0;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_u8(&v, &roi, &t));
        TEST_ASSERT_EQUAL_UINT8(naive_otsu(ref), t);
    }
}

// The truncated-product pre-test of vd_otsu_from_hist must never change the
// answer: histograms with large totals (shifts > 0), exact ties (mirrored
// histograms) and plateaus against the naive full-precision search.
static void test_pretest_vs_naive(void)
{
    uint32_t h[256], seed = 4242u;
    for (int trial = 0; trial < 3000; trial++) {
        memset(h, 0, sizeof h);
        const uint32_t kind = (uint32_t)trial % 4u;
        const uint32_t scale = 1u << (tu_rand(&seed) % 19u);   // per-bin counts up to ~2^18
        if (kind == 0u) {          // dense random
            for (int v = 0; v < 256; v++) {
                h[v] = tu_rand(&seed) % (scale + 1u);
            }
        } else if (kind == 1u) {   // mirrored: exact ties between t and its mirror
            const uint32_t levels = 2u + tu_rand(&seed) % 6u;
            for (uint32_t k = 0; k < levels; k++) {
                const uint32_t v = tu_rand(&seed) % 128u, c = 1u + tu_rand(&seed) % scale;
                h[v] += c;
                h[255u - v] += c;
            }
        } else if (kind == 2u) {   // few levels, equal counts: plateaus and near ties
            const uint32_t levels = 2u + tu_rand(&seed) % 5u, c = 1u + tu_rand(&seed) % scale;
            for (uint32_t k = 0; k < levels; k++) {
                h[tu_rand(&seed) & 255u] += c + (tu_rand(&seed) % 2u);
            }
        } else {                   // two bumps, one tiny outlier
            const uint32_t a = tu_rand(&seed) % 200u, b = a + 1u + tu_rand(&seed) % (255u - a);
            for (uint32_t k = 0; k < 20u; k++) {
                h[(a + k) & 255u] += 1u + tu_rand(&seed) % scale;
                h[(b + 255u - k) % 256u] += 1u + tu_rand(&seed) % scale;
            }
            h[tu_rand(&seed) & 255u] += 1u;
        }
        uint64_t n = 0u;
        for (int v = 0; v < 256; v++) {
            n += h[v];
        }
        if (n == 0u || n > VD_OTSU_MAX_COUNT) {
            continue;
        }
        uint8_t t = 0;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_from_hist(h, &t));
        TEST_ASSERT_EQUAL_UINT8(naive_otsu(h), t);
    }
}

static void test_large_counts(void)
{
    // Near the 2^26 limit the criterion needs the full 192 bits.
    uint32_t h[256], seed = 77u;
    for (int trial = 0; trial < 50; trial++) {
        memset(h, 0, sizeof h);
        uint32_t left = VD_OTSU_MAX_COUNT;
        for (int k = 0; k < 6 && left > 0u; k++) {
            uint32_t c = tu_rand(&seed) % (left + 1u);
            h[tu_rand(&seed) & 255u] += c;
            left -= c;
        }
        h[tu_rand(&seed) & 255u] += left;
        // Reference by scaling: divide counts by 2^12 would change the answer, so
        // compare against the criterion at the returned t and at every other t.
        uint8_t t;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_from_hist(h, &t));
        int64_t n = 0, s = 0;
        for (int v = 0; v < 256; v++) {
            n += h[v];
            s += (int64_t)h[v] * v;
        }
        int64_t n0 = 0, s0 = 0, bn0 = -1, bs0 = 0;
        for (int v = 0; v <= t; v++) {
            n0 += h[v];
            s0 += (int64_t)h[v] * v;
        }
        bn0 = n0;
        bs0 = s0;
        if (bn0 == 0 || bn0 == n) {
            continue; // single level
        }
        int64_t bd = n * bs0 - bn0 * s;
        uint64_t ba = (uint64_t)(bd < 0 ? -bd : bd), bden = (uint64_t)(bn0 * (n - bn0));
        n0 = 0;
        s0 = 0;
        for (int v = 0; v < 256; v++) {
            n0 += h[v];
            s0 += (int64_t)h[v] * v;
            if (n0 == 0 || n0 == n) {
                continue;
            }
            int64_t dd = n * s0 - n0 * s;
            uint64_t a = (uint64_t)(dd < 0 ? -dd : dd), den = (uint64_t)(n0 * (n - n0));
            // No level beats t; levels before t do not even tie it.
            TEST_ASSERT_FALSE(vd_ratio_sq_gt(a, den, ba, bden));
            if (v < t) {
                TEST_ASSERT_TRUE(vd_ratio_sq_gt(ba, bden, a, den));
            }
        }
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_hand_worked_4x4);
    RUN_TEST(test_degenerate_histograms);
    RUN_TEST(test_bad_arguments);
    RUN_TEST(test_reference_arithmetic);
    RUN_TEST(test_wide_multiply_and_ratio);
    RUN_TEST(test_random_vs_naive);
    RUN_TEST(test_large_counts);
    RUN_TEST(test_pretest_vs_naive);
    return UNITY_END();
}
