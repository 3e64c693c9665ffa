// SPDX-License-Identifier: MIT
// Unit tests of windows.h: hand-worked grids, bands and the ground model, a naive reference on random
// configurations, capacity, and argument checks.
#include "unity.h"
#include "testutil.h"

#include <string.h>

void setUp(void) {}
void tearDown(void) {}

#define MAXW 200000

static vd_rect_t g_out[MAXW];
static vd_rect_t g_ref[MAXW];

static void base_cfg(vd_windows_cfg_t *c, uint32_t w, uint32_t h)
{
    memset(c, 0, sizeof(*c));
    c->frame_w = w;
    c->frame_h = h;
}

static void one_band(vd_windows_cfg_t *c, int32_t y0, int32_t y1, uint16_t h0, uint16_t h1)
{
    c->n_bands = 1u;
    c->bands[0].y_min = y0;
    c->bands[0].y_max = y1;
    c->bands[0].min_h = h0;
    c->bands[0].max_h = h1;
}

static void test_grid_hand_worked(void)
{
    vd_windows_cfg_t c;
    base_cfg(&c, 20, 10);
    one_band(&c, 0, 9, 4, 4);
    c.stride_q8 = 128u;   // half a window: 2 px
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_generate(&c, g_out, MAXW, &n));
    TEST_ASSERT_EQUAL_size_t(36u, n);   // rows 0,2,4,6 x columns 0..16 step 2
    TEST_ASSERT_EQUAL_INT32(0, g_out[0].x);
    TEST_ASSERT_EQUAL_INT32(0, g_out[0].y);
    TEST_ASSERT_EQUAL_INT32(4, g_out[0].w);
    TEST_ASSERT_EQUAL_INT32(4, g_out[0].h);
    TEST_ASSERT_EQUAL_INT32(2, g_out[1].x);
    TEST_ASSERT_EQUAL_INT32(16, g_out[35].x);
    TEST_ASSERT_EQUAL_INT32(6, g_out[35].y);
    uint32_t total = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_count(&c, &total));
    TEST_ASSERT_EQUAL_UINT32(36u, total);

    // A band of bottom rows 5..7 keeps rows y = 2 (bottom 5) and y = 4 (bottom 7).
    c.bands[0].y_min = 5;
    c.bands[0].y_max = 7;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_generate(&c, g_out, MAXW, &n));
    TEST_ASSERT_EQUAL_size_t(18u, n);
    TEST_ASSERT_EQUAL_INT32(2, g_out[0].y);
    TEST_ASSERT_EQUAL_INT32(4, g_out[17].y);

    // Odd margin: 21 wide, w 4, sx 2 -> leftover 17 % 2 = 1 -> ox = 0; 23 wide: 19 % 2 = 1 -> 0;
    // with sx 4 (stride 256) on 23: 19 % 4 = 3 -> ox = 1.
    base_cfg(&c, 23, 4);
    one_band(&c, 0, 3, 4, 4);
    c.stride_q8 = 256u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_generate(&c, g_out, MAXW, &n));
    TEST_ASSERT_EQUAL_size_t(5u, n);   // x = 1, 5, 9, 13, 17
    TEST_ASSERT_EQUAL_INT32(1, g_out[0].x);
    TEST_ASSERT_EQUAL_INT32(17, g_out[4].x);
}

static void test_scale_ladder_and_aspects(void)
{
    vd_windows_cfg_t c;
    base_cfg(&c, 64, 64);
    one_band(&c, 0, 63, 10, 20);
    c.stride_q8 = 512u;   // two windows: at most a few per row
    c.scale_step_q8 = 320u;   // 10 -> 13 (12.5 rounds up) -> 16 (16.25) -> 20 (20) -> 25 > 20
    c.n_aspects = 2u;
    c.aspect_q8[0] = 256u;   // square
    c.aspect_q8[1] = 128u;   // h/w 0.5: twice as wide
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_generate(&c, g_out, MAXW, &n));
    uint32_t heights[8];
    size_t nh = 0;
    for (size_t i = 0; i < n; i++) {
        if (nh == 0u || heights[nh - 1u] != (uint32_t)g_out[i].h) {
            TEST_ASSERT_TRUE(nh < 8u);
            heights[nh++] = (uint32_t)g_out[i].h;
        }
        TEST_ASSERT_TRUE(g_out[i].w == g_out[i].h || g_out[i].w == 2 * g_out[i].h);
        TEST_ASSERT_TRUE(g_out[i].x + g_out[i].w <= 64 && g_out[i].y + g_out[i].h <= 64);
    }
    TEST_ASSERT_EQUAL_size_t(4u, nh);
    TEST_ASSERT_EQUAL_UINT32(10u, heights[0]);
    TEST_ASSERT_EQUAL_UINT32(13u, heights[1]);
    TEST_ASSERT_EQUAL_UINT32(16u, heights[2]);
    TEST_ASSERT_EQUAL_UINT32(20u, heights[3]);
}

static void test_ground_model(void)
{
    // Horizon at row 0, k = 1, tolerance 1 (exact): a 4-px window must have its bottom at row 4.
    vd_windows_cfg_t c;
    base_cfg(&c, 20, 10);
    one_band(&c, 0, 9, 4, 4);
    c.stride_q8 = 64u;   // 1 px steps
    c.horizon_y = 0;
    c.ground_k_q8 = 256u;
    c.ground_tol_q8 = 256u;
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_generate(&c, g_out, MAXW, &n));
    TEST_ASSERT_EQUAL_size_t(17u, n);
    for (size_t i = 0; i < n; i++) {
        TEST_ASSERT_EQUAL_INT32(1, g_out[i].y);
        TEST_ASSERT_EQUAL_INT32((int32_t)i, g_out[i].x);
    }
    // Tolerance 2: h = 4 is accepted for expected heights 2..8, i.e. bottom rows 2..8; y = bottom - 3 >= 0.
    c.ground_tol_q8 = 512u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_generate(&c, g_out, MAXW, &n));
    TEST_ASSERT_EQUAL_size_t(17u * 6u, n);   // bottoms 3..8 (y 0..5): bottom 2 needs y = -1
    TEST_ASSERT_EQUAL_INT32(0, g_out[0].y);
    TEST_ASSERT_EQUAL_INT32(5, g_out[n - 1u].y);
    // Horizon below the frame: nothing is below it.
    c.horizon_y = 40;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_generate(&c, g_out, MAXW, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
}

// Naive reference: every position of every ladder height and aspect, grid membership by modulo,
// acceptance with the inequalities of windows.h written out directly.
static size_t naive(const vd_windows_cfg_t *in, vd_rect_t *out)
{
    vd_windows_cfg_t c = *in;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_resolve(&c));
    uint32_t lo = 100000u;
    uint32_t hi = 0u;
    for (uint32_t b = 0; b < c.n_bands; b++) {
        lo = c.bands[b].min_h < lo ? c.bands[b].min_h : lo;
        hi = c.bands[b].max_h > hi ? c.bands[b].max_h : hi;
    }
    size_t n = 0;
    for (uint32_t h = lo; h <= hi;) {
        for (uint32_t a = 0; a < c.n_aspects && h <= c.frame_h; a++) {
            uint32_t w = (h * 256u + c.aspect_q8[a] / 2u) / c.aspect_q8[a];
            if (w == 0u) { w = 1u; }
            if (w > c.frame_w) { continue; }
            uint32_t sx = (w * c.stride_q8) / 256u;
            uint32_t sy = (h * c.stride_q8) / 256u;
            if (sx == 0u) { sx = 1u; }
            if (sy == 0u) { sy = 1u; }
            uint32_t ox = ((c.frame_w - w) % sx) / 2u;
            uint32_t oy = ((c.frame_h - h) % sy) / 2u;
            for (uint32_t y = 0; y + h <= c.frame_h; y++) {
                if (y < oy || (y - oy) % sy != 0u) { continue; }
                int64_t yb = (int64_t)y + h - 1;
                bool ok = false;
                for (uint32_t b = 0; b < c.n_bands; b++) {
                    ok = ok || (yb >= c.bands[b].y_min && yb <= c.bands[b].y_max && h >= c.bands[b].min_h &&
                                h <= c.bands[b].max_h);
                }
                if (ok && c.ground_k_q8 != 0u) {
                    int64_t d = yb - c.horizon_y;
                    // e/t <= h <= e*t with e = k*d/256, t = tol/256, multiplied out by 256^2.
                    ok = d > 0 && (int64_t)h * 256 * c.ground_tol_q8 >= (int64_t)c.ground_k_q8 * d * 256 &&
                         (int64_t)h * 65536 <= (int64_t)c.ground_k_q8 * d * c.ground_tol_q8;
                }
                if (!ok) { continue; }
                for (uint32_t x = 0; x + w <= c.frame_w; x++) {
                    if (x < ox || (x - ox) % sx != 0u) { continue; }
                    vd_rect_t r = {(int32_t)x, (int32_t)y, (int32_t)w, (int32_t)h};
                    if (n < MAXW) { out[n] = r; }
                    n++;
                }
            }
        }
        uint32_t nx = (h * c.scale_step_q8 + 128u) / 256u;
        h = nx > h ? nx : h + 1u;
    }
    return n;
}

static void test_random_vs_naive(void)
{
    uint32_t seed = 12345u;
    for (int it = 0; it < 120; it++) {
        vd_windows_cfg_t c;
        base_cfg(&c, 8u + tu_rand(&seed) % 120u, 8u + tu_rand(&seed) % 100u);
        c.n_bands = (uint8_t)(1u + tu_rand(&seed) % VD_WINDOWS_MAX_BANDS);
        for (uint32_t b = 0; b < c.n_bands; b++) {
            int32_t y0 = (int32_t)(tu_rand(&seed) % (c.frame_h + 10u)) - 5;
            c.bands[b].y_min = y0;
            c.bands[b].y_max = y0 + (int32_t)(tu_rand(&seed) % c.frame_h);
            c.bands[b].min_h = (uint16_t)(1u + tu_rand(&seed) % 20u);
            c.bands[b].max_h = (uint16_t)(c.bands[b].min_h + tu_rand(&seed) % 60u);
        }
        c.n_aspects = (uint8_t)(tu_rand(&seed) % (VD_WINDOWS_MAX_ASPECTS + 1u));
        for (uint32_t a = 0; a < VD_WINDOWS_MAX_ASPECTS; a++) {
            c.aspect_q8[a] = (uint16_t)(64u + tu_rand(&seed) % 961u);
        }
        c.scale_step_q8 = (uint16_t)(288u + tu_rand(&seed) % 300u);
        c.stride_q8 = (uint16_t)(16u + tu_rand(&seed) % 497u);
        if (tu_rand(&seed) % 2u) {
            c.horizon_y = (int32_t)(tu_rand(&seed) % c.frame_h) - 10;
            c.ground_k_q8 = (uint16_t)(64u + tu_rand(&seed) % 800u);
            c.ground_tol_q8 = (uint16_t)(256u + tu_rand(&seed) % 1000u);
        }
        c.max_windows = 1048576u;
        size_t nr = naive(&c, g_ref);
        size_t n = 0;
        vd_status_t st = vd_windows_generate(&c, g_out, MAXW, &n);
        TEST_ASSERT_TRUE(nr <= MAXW);
        TEST_ASSERT_EQUAL_INT(VD_OK, st);
        TEST_ASSERT_EQUAL_size_t(nr, n);
        if (n > 0u) {   // Unity rejects a zero-length comparison; n == nr == 0 is already checked
            TEST_ASSERT_EQUAL_MEMORY(g_ref, g_out, n * sizeof(vd_rect_t));
        }
        uint32_t total = 0;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_count(&c, &total));
        TEST_ASSERT_EQUAL_UINT32((uint32_t)nr, total);
    }
}

static void test_capacity(void)
{
    vd_windows_cfg_t c;
    base_cfg(&c, 640, 480);   // defaults: one band 10..200 over every row
    uint32_t total = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_count(&c, &total));
    TEST_ASSERT_TRUE(total > 2048u);
    size_t n = 0;
    // Default budget (2048) applies.
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_windows_generate(&c, g_out, MAXW, &n));
    TEST_ASSERT_EQUAL_size_t(2048u, n);
    // Caller cap below the budget: the first 5 in order, guard after them intact.
    c.max_windows = 1048576u;
    size_t all = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_generate(&c, g_ref, MAXW, &all));
    TEST_ASSERT_EQUAL_size_t(total, all);
    vd_rect_t guard = {-7, -7, -7, -7};
    g_out[5] = guard;
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_windows_generate(&c, g_out, 5, &n));
    TEST_ASSERT_EQUAL_size_t(5u, n);
    TEST_ASSERT_EQUAL_MEMORY(g_ref, g_out, 5u * sizeof(vd_rect_t));
    TEST_ASSERT_EQUAL_INT32(-7, g_out[5].x);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_windows_generate(&c, NULL, 0, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
}

static void test_arguments(void)
{
    vd_windows_cfg_t c;
    size_t n = 99;
    uint32_t total = 99;
    base_cfg(&c, 64, 48);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_generate(NULL, g_out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_generate(&c, g_out, 4, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_generate(&c, NULL, 4, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_count(&c, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_count(NULL, &total));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_resolve(NULL));
    vd_windows_cfg_t bad;
#define EXPECT_BAD(stmt) do { bad = c; stmt; TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_generate(&bad, g_out, 4, &n)); \
        TEST_ASSERT_EQUAL_size_t(0u, n); } while (0)
    EXPECT_BAD(bad.frame_w = 0u);
    EXPECT_BAD(bad.frame_h = VD_MAX_DIM + 1u);
    EXPECT_BAD(bad.scale_step_q8 = 287u);
    EXPECT_BAD(bad.scale_step_q8 = 1025u);
    EXPECT_BAD(bad.stride_q8 = 15u);
    EXPECT_BAD(bad.stride_q8 = 513u);
    EXPECT_BAD(bad.ground_tol_q8 = 255u);
    EXPECT_BAD(bad.max_windows = 1048577u);
    EXPECT_BAD(bad.n_bands = 5u);
    EXPECT_BAD(bad.n_aspects = 5u);
    EXPECT_BAD((bad.n_aspects = 1u, bad.aspect_q8[0] = 63u));
    EXPECT_BAD((bad.n_aspects = 1u, bad.aspect_q8[0] = 1025u));
    EXPECT_BAD(one_band(&bad, 0, 10, 20, 10));
    EXPECT_BAD(one_band(&bad, 10, 9, 10, 20));
    EXPECT_BAD(one_band(&bad, 0, 10, 0, 20));
    EXPECT_BAD(bad.horizon_y = -(int32_t)VD_MAX_DIM - 1);
    // 1..8192 with step 1.125 needs ~77 heights > VD_WINDOWS_MAX_SCALES.
    EXPECT_BAD((one_band(&bad, 0, 47, 1, 8192), bad.scale_step_q8 = 288u));
#undef EXPECT_BAD
    // Resolve fills the defaults.
    bad = c;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_resolve(&bad));
    TEST_ASSERT_EQUAL_UINT32(1u, bad.n_bands);
    TEST_ASSERT_EQUAL_UINT32(10u, bad.bands[0].min_h);
    TEST_ASSERT_EQUAL_UINT32(200u, bad.bands[0].max_h);
    TEST_ASSERT_EQUAL_INT32(47, bad.bands[0].y_max);
    TEST_ASSERT_EQUAL_UINT32(256u, bad.aspect_q8[0]);
    TEST_ASSERT_EQUAL_UINT32(320u, bad.scale_step_q8);
    TEST_ASSERT_EQUAL_UINT32(64u, bad.stride_q8);
    TEST_ASSERT_EQUAL_UINT32(512u, bad.ground_tol_q8);
    TEST_ASSERT_EQUAL_UINT32(2048u, bad.max_windows);
    // Windows taller than the frame are skipped, not an error.
    base_cfg(&c, 30, 8);
    one_band(&c, 0, 7, 9, 12);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_generate(&c, g_out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_grid_hand_worked);
    RUN_TEST(test_scale_ladder_and_aspects);
    RUN_TEST(test_ground_model);
    RUN_TEST(test_random_vs_naive);
    RUN_TEST(test_capacity);
    RUN_TEST(test_arguments);
    return UNITY_END();
}
