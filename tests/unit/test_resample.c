// SPDX-License-Identifier: MIT
// Unit tests of the fixed-point resampler and the box average: hand-worked cases, naive references, golden vectors,
// argument checks.
#include "unity.h"
#include "testutil.h"

#include <string.h>

#include "../data/resample_golden.h"
#include "internal/recip_internal.h"

void setUp(void) {}
void tearDown(void) {}

static void test_4x4_to_2x2_area_average(void)
{
    const uint8_t src[16] = {0, 10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120, 130, 140, 150};
    const vd_view_u8_t v = {src, 4, 4, 4};
    uint8_t dst[4];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, NULL, dst, 2, 2));
    // (0+10+40+50)/4 = 25, (20+30+60+70)/4 = 45, (80+90+120+130)/4 = 105, 125.
    const uint8_t want[4] = {25, 45, 105, 125};
    TEST_ASSERT_EQUAL_UINT8_ARRAY(want, dst, 4);
}

static void test_rounding_half_up(void)
{
    // 2x2 -> 1x1: sums 2, 6 -> 0.5 -> 1, 1.5 -> 2; 1 -> 0.25 -> 0.
    const uint8_t a[4] = {1, 0, 1, 0};
    const uint8_t b[4] = {1, 2, 1, 2};
    const uint8_t c[4] = {1, 0, 0, 0};
    vd_view_u8_t v = {a, 2, 2, 2};
    uint8_t d;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, NULL, &d, 1, 1));
    TEST_ASSERT_EQUAL_UINT8(1u, d);
    v.data = b;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, NULL, &d, 1, 1));
    TEST_ASSERT_EQUAL_UINT8(2u, d);
    v.data = c;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, NULL, &d, 1, 1));
    TEST_ASSERT_EQUAL_UINT8(0u, d);
}

static void test_3_to_2_fractional_area(void)
{
    // Output 0 covers [0, 1.5): (0 + 90/2) / 1.5 = 30; output 1 covers [1.5, 3): (45 + 200) / 1.5 = 163.3 -> 163.
    const uint8_t src[3] = {0, 90, 200};
    const vd_view_u8_t v = {src, 3, 1, 3};
    uint8_t dst[2];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, NULL, dst, 2, 1));
    TEST_ASSERT_EQUAL_UINT8(30u, dst[0]);
    TEST_ASSERT_EQUAL_UINT8(163u, dst[1]);
}

static void test_2x2_to_4x4_bilinear(void)
{
    // Per axis: out 0 = p0, out 1 = 0.75 p0 + 0.25 p1, out 2 = 0.25 p0 + 0.75 p1, out 3 = p1.
    // Rows after the horizontal pass: {0, 25, 75, 100} and {200, 160, 80, 40};
    // row 1 = 0.75 r0 + 0.25 r1 = {50, 58.75, 76.25, 85}, row 2 = {150, 126.25, 78.75, 55}.
    const uint8_t src[4] = {0, 100, 200, 40};
    const vd_view_u8_t v = {src, 2, 2, 2};
    uint8_t dst[16];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, NULL, dst, 4, 4));
    const uint8_t want[16] = {0, 25, 75, 100, 50, 59, 76, 85, 150, 126, 79, 55, 200, 160, 80, 40};
    TEST_ASSERT_EQUAL_UINT8_ARRAY(want, dst, 16);
}

static void test_roi_with_stride_and_copy(void)
{
    static uint8_t img[7 * 10];
    for (uint32_t i = 0; i < sizeof img; i++) {
        img[i] = (uint8_t)(i * 7u);
    }
    const vd_view_u8_t v = {img, 7, 6, 10}; // stride 10 > width 7
    const vd_rect_t roi = {2, 1, 4, 3};
    uint8_t dst[12];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, &roi, dst, 4, 3)); // same size: copy
    for (uint32_t y = 0; y < 3; y++) {
        TEST_ASSERT_EQUAL_UINT8_ARRAY(img + (y + 1u) * 10u + 2u, dst + y * 4u, 4);
    }
}

static void test_constant_and_extremes(void)
{
    static uint8_t row[VD_MAX_DIM];
    memset(row, 255, sizeof row);
    vd_view_u8_t v = {row, VD_MAX_DIM, 1, VD_MAX_DIM};
    uint8_t d[32];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, NULL, d, 1, 1));
    TEST_ASSERT_EQUAL_UINT8(255u, d[0]);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, NULL, d, 32, 1));
    for (int i = 0; i < 32; i++) {
        TEST_ASSERT_EQUAL_UINT8(255u, d[i]);
    }
    // 1x1 grown to the largest destination row.
    static uint8_t big[VD_RESAMPLE_MAX_DST];
    const uint8_t one = 77;
    vd_view_u8_t p = {&one, 1, 1, 1};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&p, NULL, big, VD_RESAMPLE_MAX_DST, 1));
    TEST_ASSERT_EQUAL_UINT8(77u, big[0]);
    TEST_ASSERT_EQUAL_UINT8(77u, big[VD_RESAMPLE_MAX_DST - 1u]);
}

static void test_args(void)
{
    static uint8_t img[16];
    const vd_view_u8_t v = {img, 4, 4, 4};
    uint8_t d[4];
    vd_rect_t roi = {1, 1, 3, 3};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(NULL, NULL, d, 2, 2));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&v, NULL, NULL, 2, 2));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&v, NULL, d, 0, 2));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&v, NULL, d, 2, 0));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&v, NULL, d, VD_RESAMPLE_MAX_DST + 1u, 1));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, &roi, d, 2, 2));
    roi.w = 4; // x + w > width
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&v, &roi, d, 2, 2));
    roi.w = 0;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&v, &roi, d, 2, 2));
    roi.w = 2;
    roi.x = -1;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&v, &roi, d, 2, 2));
    vd_view_u8_t bad = {img, 4, 4, 3}; // stride < width
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&bad, NULL, d, 2, 2));
    bad.stride = 4;
    bad.data = NULL;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&bad, NULL, d, 2, 2));
}

// Naive reference: dense per-axis weight matrices (as in the module comment),
// full double sum per output pixel.
static uint32_t naive_weight(uint32_t i, uint32_t k, uint32_t s, uint32_t d, uint32_t *total)
{
    if (s >= d) {
        *total = s;
        const uint32_t lo = i * s, hi = lo + s, a = k * d, b = a + d;
        const uint32_t from = a > lo ? a : lo, to = b < hi ? b : hi;
        return to > from ? to - from : 0u;
    }
    *total = 2u * d;
    const int32_t p = (int32_t)((2u * i + 1u) * s) - (int32_t)d; // in 1/(2d) px
    if (p <= 0) {
        return k == 0u ? 2u * d : 0u;
    }
    const uint32_t k0 = (uint32_t)p / (2u * d), frac = (uint32_t)p % (2u * d);
    if (k0 >= s - 1u) {
        return k == s - 1u ? 2u * d : 0u;
    }
    if (k == k0) {
        return 2u * d - frac;
    }
    return k == k0 + 1u ? frac : 0u;
}

static void test_naive_reference_random(void)
{
    static uint8_t img[61 * 53];
    static uint8_t got[40 * 40];
    uint32_t seed = 12345u;
    for (int t = 0; t < 300; t++) {
        const uint32_t w = 1u + tu_rand(&seed) % 61u, h = 1u + tu_rand(&seed) % 53u;
        for (uint32_t i = 0; i < w * h; i++) {
            img[i] = (uint8_t)tu_rand(&seed);
        }
        const vd_view_u8_t v = {img, w, h, w};
        vd_rect_t r;
        r.x = (int32_t)(tu_rand(&seed) % w);
        r.y = (int32_t)(tu_rand(&seed) % h);
        r.w = 1 + (int32_t)(tu_rand(&seed) % (w - (uint32_t)r.x));
        r.h = 1 + (int32_t)(tu_rand(&seed) % (h - (uint32_t)r.y));
        const uint32_t dw = 1u + tu_rand(&seed) % 40u, dh = 1u + tu_rand(&seed) % 40u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, &r, got, dw, dh));
        for (uint32_t oy = 0; oy < dh; oy++) {
            for (uint32_t ox = 0; ox < dw; ox++) {
                uint64_t acc = 0;
                uint32_t tx = 1, ty = 1;
                for (uint32_t ky = 0; ky < (uint32_t)r.h; ky++) {
                    const uint32_t wy = naive_weight(oy, ky, (uint32_t)r.h, dh, &ty);
                    for (uint32_t kx = 0; kx < (uint32_t)r.w; kx++) {
                        const uint32_t wx = naive_weight(ox, kx, (uint32_t)r.w, dw, &tx);
                        acc += (uint64_t)wx * wy * img[((uint32_t)r.y + ky) * w + (uint32_t)r.x + kx];
                    }
                }
                const uint64_t tot = (uint64_t)tx * ty;
                TEST_ASSERT_EQUAL_UINT8((uint8_t)((acc + tot / 2u) / tot), got[oy * dw + ox]);
            }
        }
    }
}

// The reciprocal division behind the rounded outputs (also used by
// contrast.c): exact for every x < 256 n; checked at the extremes of every
// quotient for all n <= 2^16 and on random (n, x) up to n = 2^23.
static void test_recip256_exact(void)
{
    vd_recip256_t rc;
    for (uint32_t n = 1u; n <= 65536u; n++) {
        TEST_ASSERT_TRUE(vd_recip256_init(n, &rc));
        static const uint32_t qs[] = {0u, 1u, 2u, 127u, 128u, 254u, 255u};
        for (size_t i = 0; i < sizeof qs / sizeof qs[0]; i++) {
            const uint64_t lo = (uint64_t)qs[i] * n, hi = lo + n - 1u;   // quotient qs[i]
            if (vd_recip256_div(&rc, lo) != qs[i] || vd_recip256_div(&rc, hi) != qs[i] ||
                vd_recip256_div32(rc.m, rc.k, (uint32_t)hi) != qs[i]) {
                TEST_FAIL_MESSAGE("reciprocal division wrong at a quotient boundary");
            }
        }
    }
    uint32_t seed = 99u;
    for (int t = 0; t < 200000; t++) {
        const uint32_t n = 1u + tu_rand(&seed) % VD_RECIP256_MAX_DIV;
        TEST_ASSERT_TRUE(vd_recip256_init(n, &rc));
        const uint64_t x = ((uint64_t)tu_rand(&seed) << 16 ^ tu_rand(&seed)) % (256ull * n);
        TEST_ASSERT_EQUAL_UINT32((uint32_t)(x / n), vd_recip256_div(&rc, x));
        const uint64_t top = 256ull * n - 1u;
        TEST_ASSERT_EQUAL_UINT32(255u, vd_recip256_div(&rc, top));
    }
    TEST_ASSERT_FALSE(vd_recip256_init(0u, &rc));
    TEST_ASSERT_FALSE(vd_recip256_init(VD_RECIP256_MAX_DIV + 1u, &rc));
}

// Weight totals above 2^23 take the division path: a 2 x 3 region grown to
// 4096 x 1025 (T = 8192 * 2050), sampled against the naive reference.
static void test_large_total_divides(void)
{
    static uint8_t big[4096u * 1025u];
    static const uint8_t img[6] = {0u, 255u, 37u, 201u, 128u, 9u};
    const vd_view_u8_t v = {img, 2u, 3u, 2u};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, NULL, big, 4096u, 1025u));
    for (uint32_t i = 0; i < 4096u * 1025u; i += 97u) {
        const uint32_t ox = i % 4096u, oy = i / 4096u;
        uint64_t acc = 0u;
        uint32_t tx = 1u, ty = 1u;
        for (uint32_t ky = 0; ky < 3u; ky++) {
            const uint32_t wy = naive_weight(oy, ky, 3u, 1025u, &ty);
            for (uint32_t kx = 0; kx < 2u; kx++) {
                acc += (uint64_t)naive_weight(ox, kx, 2u, 4096u, &tx) * wy * img[ky * 2u + kx];
            }
        }
        const uint64_t tot = (uint64_t)tx * ty;
        TEST_ASSERT_TRUE(tot > VD_RECIP256_MAX_DIV);
        TEST_ASSERT_EQUAL_UINT8((uint8_t)((acc + tot / 2u) / tot), big[i]);
    }
}

static void test_golden_vectors(void)
{
    const vd_view_u8_t v = {golden_src, GOLDEN_SRC_W, GOLDEN_SRC_H, GOLDEN_SRC_W};
    static uint8_t out[32 * 32];
    for (uint32_t i = 0; i < GOLDEN_N_RS; i++) {
        const golden_rs_case_t *c = &golden_rs_cases[i];
        const vd_rect_t r = {c->x, c->y, c->w, c->h};
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, &r, out, c->dst_w, c->dst_h));
        TEST_ASSERT_EQUAL_UINT8_ARRAY(golden_rs_out + c->first, out, c->dst_w * c->dst_h);
    }
}

static void test_box_hand_worked(void)
{
    // 5 x 3 ROI at (1, 1) of a 7 x 5 view, k = 2 x 1: dst 2 x 3; column 5 of the ROI (x = 6) is not read.
    uint8_t src[5][7];
    for (uint32_t y = 0; y < 5u; y++) {
        for (uint32_t x = 0; x < 7u; x++) {
            src[y][x] = (uint8_t)(10u * y + x);
        }
    }
    src[2][5] = 200u;   // x = 5 is the ROI's last column: read by no 2 x 1 block
    const vd_view_u8_t v = {&src[0][0], 7, 5, 7};
    const vd_rect_t roi = {1, 1, 5, 3};
    uint8_t out[3][2];
    vd_image_u8_t d = {&out[0][0], 2, 3, 2};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u8(&v, &roi, 2, 1, &d));
    // Row 1: (11 + 12) / 2 = 11.5 -> 12 (half up), (13 + 14) / 2 = 13.5 -> 14.
    TEST_ASSERT_EQUAL_UINT8(12u, out[0][0]);
    TEST_ASSERT_EQUAL_UINT8(14u, out[0][1]);
    TEST_ASSERT_EQUAL_UINT8(22u, out[1][0]);
    TEST_ASSERT_EQUAL_UINT8(34u, out[2][1]);
    // k = 1 x 1 copies the ROI; k = roi size gives one mean.
    uint8_t copy[3][5];
    vd_image_u8_t dc = {&copy[0][0], 5, 3, 5};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u8(&v, &roi, 1, 1, &dc));
    for (uint32_t y = 0; y < 3u; y++) {
        TEST_ASSERT_EQUAL_UINT8_ARRAY(&src[1u + y][1], copy[y], 5);
    }
    uint8_t one = 0u;
    vd_image_u8_t d1 = {&one, 1, 1, 1};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u8(&v, &roi, 5, 3, &d1));
    // (11+..+15 + 21+..+25 + 31+..+35) = 345, with 200 instead of 25: 520 / 15 = 34.67 -> 35.
    TEST_ASSERT_EQUAL_UINT8(35u, one);
    // k = 2 x 2 (the CNN's half resolution, its own loop): ROI rows 1-2, columns 1-4; the ROI's
    // last row (y = 3) and column (x = 5) are not read. (11 + 12 + 21 + 22) / 4 = 16.5 -> 17 (half
    // up); (13 + 14 + 23 + 24) / 4 = 18.5 -> 19. A 2 x 2 block summing to 2 mod 4 rounds up, 1 down.
    uint8_t q[1][2];
    vd_image_u8_t dq = {&q[0][0], 2, 1, 2};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u8(&v, &roi, 2, 2, &dq));
    TEST_ASSERT_EQUAL_UINT8(17u, q[0][0]);
    TEST_ASSERT_EQUAL_UINT8(19u, q[0][1]);
    const uint8_t blk[2][2] = {{0u, 1u}, {1u, 0u}};
    const uint8_t blk1[2][2] = {{0u, 1u}, {0u, 0u}};
    const vd_view_u8_t vb = {&blk[0][0], 2, 2, 2};
    const vd_view_u8_t vb1 = {&blk1[0][0], 2, 2, 2};
    vd_image_u8_t d11 = {&one, 1, 1, 1};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u8(&vb, NULL, 2, 2, &d11));
    TEST_ASSERT_EQUAL_UINT8(1u, one);   // 2 / 4 = 0.5 -> 1
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u8(&vb1, NULL, 2, 2, &d11));
    TEST_ASSERT_EQUAL_UINT8(0u, one);   // 1 / 4 = 0.25 -> 0
}

static void test_box_u16_grey(void)
{
    // TLinear, grey 0 at 0 C, 255 at 51 C: three pixels at 30.00 C and one at 30.02 C have the
    // mean raw 30315.5 -> 30316 (half up), grey 150; the second block's mean 32767.5 -> 32768 is hot.
    uint16_t px[2][4] = {{30315u, 30315u, 0u, 0u}, {30315u, 30317u, 65535u, 65535u}};
    const vd_view_u16_t v = {&px[0][0], 4, 2, 8};
    vd_calib_t cal = {65536, 0};
    vd_calib_grey_t g;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&g, &cal, VD_CALIB_CK_PER_0C, VD_CALIB_CK_PER_0C + 5100));
    uint8_t out[2];
    vd_image_u8_t d = {out, 2, 1, 2};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u16(&v, NULL, 2, 2, &g, &d));
    TEST_ASSERT_EQUAL_UINT8(vd_calib_grey_u8(&g, 30316u), out[0]);
    TEST_ASSERT_EQUAL_UINT8(150u, out[0]);
    TEST_ASSERT_EQUAL_UINT8(255u, out[1]);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_box_u16(&v, NULL, 2, 2, NULL, &d));
}

// Naive block means on random views, factors and ROIs (both formats).
static void test_box_random_vs_naive(void)
{
    static uint8_t p8[40 * 37];
    static uint16_t p16[40 * 37];
    static uint8_t out[40 * 37];
    uint32_t seed = 21u;
    vd_calib_t cal = {3 * 65536 / 2, -1000};
    vd_calib_grey_t g;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&g, &cal, 20000, 60000));
    int n4 = 0;   // trials of the 4 x 4 factors
    for (int trial = 0; trial < 600; trial++) {
        for (size_t i = 0; i < sizeof(p8); i++) {
            p8[i] = (uint8_t)tu_rand(&seed);
            p16[i] = (uint16_t)tu_rand(&seed);
        }
        const uint32_t w = 1u + tu_rand(&seed) % 37u;   // stride 40 (bytes for u8, pixels for u16)
        const uint32_t h = 1u + tu_rand(&seed) % 37u;
        vd_rect_t r;
        r.w = (int32_t)(1u + tu_rand(&seed) % w);
        r.h = (int32_t)(1u + tu_rand(&seed) % h);
        r.x = (int32_t)(tu_rand(&seed) % (w - (uint32_t)r.w + 1u));
        r.y = (int32_t)(tu_rand(&seed) % (h - (uint32_t)r.h + 1u));
        uint32_t kx = 1u + tu_rand(&seed) % (uint32_t)r.w;
        uint32_t ky = 1u + tu_rand(&seed) % (uint32_t)r.h;
        if ((trial & 2) != 0 && r.w >= 2 && r.h >= 2) {
            kx = ky = 2u;   // half of the trials: the 2 x 2 fast path (8-bit) and its 16-bit twin
        } else if ((trial & 8) != 0 && r.w >= 4 && r.h >= 4) {
            kx = ky = 4u;   // the 4 x 4 fast path (8-bit; the CNN's quarter-resolution rows)
            n4++;
        } else if ((trial & 4) != 0) {
            kx = ky = 1u;   // a quarter: the 1 x 1 path (the CNN's full-resolution rows), both formats
        }
        const uint32_t cw = (uint32_t)r.w / kx;
        const uint32_t ch = (uint32_t)r.h / ky;
        const bool wide = (trial & 1) != 0;
        vd_image_u8_t d = {out, cw, ch, cw + 3u};
        if (wide) {
            const vd_view_u16_t v = {p16, w, h, 80};
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u16(&v, &r, kx, ky, &g, &d));
        } else {
            const vd_view_u8_t v = {p8, w, h, 40};
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u8(&v, &r, kx, ky, &d));
        }
        for (uint32_t cy = 0; cy < ch; cy++) {
            for (uint32_t cx = 0; cx < cw; cx++) {
                uint64_t sum = 0u;
                for (uint32_t y = 0; y < ky; y++) {
                    for (uint32_t x = 0; x < kx; x++) {
                        const size_t at = ((size_t)r.y + cy * ky + y) * 40u + (size_t)r.x + cx * kx + x;
                        sum += wide ? p16[at] : p8[at];
                    }
                }
                const uint64_t n = (uint64_t)kx * ky;
                const uint32_t mean = (uint32_t)(sum / n + ((sum % n) * 2u >= n ? 1u : 0u));
                const uint8_t want = wide ? vd_calib_grey_u8(&g, (uint16_t)mean) : (uint8_t)mean;
                TEST_ASSERT_EQUAL_UINT8(want, out[cy * (cw + 3u) + cx]);
            }
        }
    }
    TEST_ASSERT_TRUE(n4 >= 60);   // the fast path was exercised (half of the trials are 16-bit)
}

static void test_box_args(void)
{
    uint8_t px[6 * 4] = {0};
    uint8_t out[6 * 4];
    const vd_view_u8_t v = {px, 6, 4, 6};
    const vd_rect_t roi = {1, 0, 5, 4};
    vd_image_u8_t d = {out, 2, 2, 2};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u8(&v, &roi, 2, 2, &d));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_box_u8(NULL, &roi, 2, 2, &d));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_box_u8(&v, &roi, 2, 2, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_box_u8(&v, &roi, 0, 2, &d));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_box_u8(&v, &roi, 2, 0, &d));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_box_u8(&v, &roi, 6, 2, &d));   // k > roi.w
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_box_u8(&v, &roi, 3, 2, &d));   // dst should be 1 x 2
    const vd_rect_t outside = {2, 0, 5, 4};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_box_u8(&v, &outside, 2, 2, &d));
    uint16_t px16[4] = {0};
    const vd_view_u16_t v16 = {px16, 2, 2, 3};   // odd stride
    vd_calib_t cal = {65536, 0};
    vd_calib_grey_t g;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&g, &cal, 0, 100));
    vd_image_u8_t d1 = {out, 1, 1, 1};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_box_u16(&v16, NULL, 2, 2, &g, &d1));
}

// The 2 x 2 fast path (four outputs per step, 16-bit lanes on Armv7E-M / Armv7-A) at the values where a
// lane's sum or its rounding could go wrong: sums 0..1020 from bytes near 0 and 255, every phase of a
// row against the four-output blocks, widths 1..23 (tails), odd source offsets (unaligned words).
static void test_box_2x2_extremes(void)
{
    static const uint8_t vals[8] = {0, 1, 2, 3, 127, 253, 254, 255};
    static uint8_t p8[4 * 50];
    static uint8_t out[25];
    uint32_t seed = 77u;
    for (int trial = 0; trial < 2000; trial++) {
        for (size_t i = 0; i < sizeof(p8); i++) {
            p8[i] = vals[tu_rand(&seed) % 8u];
        }
        if (trial < 8) {
            memset(p8, vals[trial], sizeof(p8));   // constant planes
        }
        const uint32_t ow = 1u + tu_rand(&seed) % 23u;
        const uint32_t x0 = tu_rand(&seed) % 3u;
        const vd_view_u8_t v = {p8, 50, 4, 50};
        const vd_rect_t r = {(int32_t)x0, 1, (int32_t)(2u * ow), 2};
        vd_image_u8_t d = {out, ow, 1, 25};
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_box_u8(&v, &r, 2, 2, &d));
        for (uint32_t cx = 0; cx < ow; cx++) {
            const uint8_t *a = p8 + 50u + x0 + 2u * cx;
            const uint32_t sum = (uint32_t)a[0] + a[1] + a[50] + a[51];
            TEST_ASSERT_EQUAL_UINT8((sum + 2u) / 4u, out[cx]);
        }
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_4x4_to_2x2_area_average);
    RUN_TEST(test_rounding_half_up);
    RUN_TEST(test_3_to_2_fractional_area);
    RUN_TEST(test_2x2_to_4x4_bilinear);
    RUN_TEST(test_roi_with_stride_and_copy);
    RUN_TEST(test_constant_and_extremes);
    RUN_TEST(test_args);
    RUN_TEST(test_naive_reference_random);
    RUN_TEST(test_golden_vectors);
    RUN_TEST(test_recip256_exact);
    RUN_TEST(test_large_total_divides);
    RUN_TEST(test_box_hand_worked);
    RUN_TEST(test_box_u16_grey);
    RUN_TEST(test_box_random_vs_naive);
    RUN_TEST(test_box_2x2_extremes);
    RUN_TEST(test_box_args);
    return UNITY_END();
}
