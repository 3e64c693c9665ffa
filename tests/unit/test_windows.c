// SPDX-License-Identifier: MIT
// Unit tests of windows.h: hand-worked grids, bands and the ground model, a naive reference on random
// configurations, capacity, and argument checks; the pre-filter's levels and the ranking against naive
// references, its workspace contract.
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

// ---------------------------------------------------------------- pre-filter and ranking

#define PW 50u   // 12 x 9 cells; the last 2 columns and 1 row are not covered
#define PH 37u

static uint8_t g_px[PH][PW];
static uint16_t g_px16[PH][PW];
static uint64_t g_pf_ws[(2u * 13u * 10u * 4u) / 8u];

static vd_frame_t frame8(void)
{
    vd_frame_t f = {g_px, PW, PH, PW, VD_PIX_U8, 0, 0};
    return f;
}

static void prefilter8(vd_windows_prefilter_t *pf)
{
    const vd_frame_t f = frame8();
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_prefilter_init(pf, &f, NULL, g_pf_ws, sizeof(g_pf_ws)));
}

// Cells of one axis under [p, p + len) by membership: those lying entirely
// inside; when none does, the one before the first cell ending beyond the window.
static void naive_cells(uint32_t p, uint32_t len, uint32_t g, uint32_t *c0, uint32_t *c1)
{
    uint32_t n = 0u;
    for (uint32_t c = 0; c < g; c++) {
        if (4u * c >= p && 4u * c + 4u <= p + len) {
            *c0 = (n == 0u) ? c : *c0;
            *c1 = c + 1u;
            n++;
        }
    }
    if (n == 0u) {
        uint32_t last = (p + len) / 4u;
        last = (last > g) ? g : last;
        *c0 = (last > 0u) ? last - 1u : 0u;
        *c1 = *c0 + 1u;
    }
}

// Cell mean g by direct summation, rounded half up (16-bit: raw mean, then grey).
static uint32_t naive_mean(uint32_t cx, uint32_t cy, const vd_calib_grey_t *grey)
{
    uint32_t sum = 0u;
    for (uint32_t j = 0; j < 4u; j++) {
        for (uint32_t i = 0; i < 4u; i++) {
            sum += (grey != NULL) ? g_px16[cy * 4u + j][cx * 4u + i] : g_px[cy * 4u + j][cx * 4u + i];
        }
    }
    const uint32_t m = (sum + 8u) / 16u;
    return (grey != NULL) ? vd_calib_grey_u8(grey, (uint16_t)m) : m;
}

static uint32_t naive_level(const vd_rect_t *b, const vd_calib_grey_t *grey)
{
    uint32_t x0 = 0u, x1 = 0u, y0 = 0u, y1 = 0u;
    naive_cells((uint32_t)b->x, (uint32_t)b->w, PW / 4u, &x0, &x1);
    naive_cells((uint32_t)b->y, (uint32_t)b->h, PH / 4u, &y0, &y1);
    uint64_t s1 = 0u;
    uint64_t s2 = 0u;
    for (uint32_t cy = y0; cy < y1; cy++) {
        for (uint32_t cx = x0; cx < x1; cx++) {
            const uint64_t g = naive_mean(cx, cy, grey);
            s1 += g;
            s2 += g * g;
        }
    }
    const uint64_t n = (uint64_t)(x1 - x0) * (y1 - y0);
    const uint64_t var = (n * s2 - s1 * s1) / (n * n);
    uint32_t r = 0u;
    while ((uint64_t)(r + 1u) * (r + 1u) <= var) {
        r++;
    }
    return r > 255u ? 255u : r;
}

static void test_prefilter_workspace_size(void)
{
    size_t b = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_prefilter_workspace_size(640u, 512u, &b));
    TEST_ASSERT_EQUAL_size_t(166152u, b);   // 2 * 161 * 129 * 4
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_prefilter_workspace_size(PW, PH, &b));
    TEST_ASSERT_EQUAL_size_t(sizeof(g_pf_ws), b);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_prefilter_workspace_size(3u, 3u, &b));   // no whole cell
    TEST_ASSERT_EQUAL_size_t(8u, b);
    // 257 x 257 = 66 049 cells fit, 258 x 257 = 66 306 do not.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_prefilter_workspace_size(1028u, 1028u, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_prefilter_workspace_size(1032u, 1028u, &b));
    TEST_ASSERT_EQUAL_size_t(0u, b);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_prefilter_workspace_size(0u, 10u, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_prefilter_workspace_size(10u, VD_MAX_DIM + 1u, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_prefilter_workspace_size(10u, 10u, NULL));
}

static void test_prefilter_level_hand_worked(void)
{
    vd_windows_prefilter_t pf;
    memset(g_px, 100, sizeof(g_px));
    prefilter8(&pf);
    const vd_rect_t all = {0, 0, (int32_t)PW, (int32_t)PH};
    TEST_ASSERT_EQUAL_UINT32(0u, vd_windows_prefilter_level(&pf, &all));   // flat: no deviation
    // Cells (0,0) = 100 and (1,0) = 120 (one pixel 116 -> mean 119.75 -> 120): sd of {100, 120} = 10.
    for (uint32_t j = 0; j < 4u; j++) {
        for (uint32_t i = 4; i < 8u; i++) {
            g_px[j][i] = 120u;
        }
    }
    g_px[0][4] = 116u;
    prefilter8(&pf);
    const vd_rect_t two = {0, 0, 8, 4};
    TEST_ASSERT_EQUAL_UINT32(10u, vd_windows_prefilter_level(&pf, &two));
    // x = 1..8 covers only cell 1 entirely: one cell, sd 0; x = 0..7 shifted by 3 rows: no whole
    // cell row inside [3, 7), so the cell row 0 (the one before floor(7 / 4) = 1) is used.
    const vd_rect_t inner = {1, 0, 8, 4};
    TEST_ASSERT_EQUAL_UINT32(0u, vd_windows_prefilter_level(&pf, &inner));
    const vd_rect_t low = {0, 3, 8, 4};
    TEST_ASSERT_EQUAL_UINT32(10u, vd_windows_prefilter_level(&pf, &low));
    // A window smaller than a cell at the origin: cell 0 alone.
    const vd_rect_t tiny = {0, 0, 2, 2};
    TEST_ASSERT_EQUAL_UINT32(0u, vd_windows_prefilter_level(&pf, &tiny));
    // A window in the uncovered right margin (x 48..49): the last cell column (11).
    g_px[0][44] = 0u;   // cell (11, 0): mean (15 * 100 + 0) / 16 = 93.75 -> 94
    prefilter8(&pf);
    const vd_rect_t margin = {44, 0, 6, 8};   // cells x [11, 12), y [0, 2): {94, 100}: sd 3
    TEST_ASSERT_EQUAL_UINT32(3u, vd_windows_prefilter_level(&pf, &margin));
    const vd_rect_t beyond = {48, 0, 2, 8};
    TEST_ASSERT_EQUAL_UINT32(3u, vd_windows_prefilter_level(&pf, &beyond));
    // Saturation at 255 is out of reach for 8-bit means (sd <= 127.5); a frame narrower than a cell gives 0.
    vd_frame_t narrow = {g_px, 3, PH, PW, VD_PIX_U8, 0, 0};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_prefilter_init(&pf, &narrow, NULL, g_pf_ws, sizeof(g_pf_ws)));
    const vd_rect_t n3 = {0, 0, 3, 8};
    TEST_ASSERT_EQUAL_UINT32(0u, vd_windows_prefilter_level(&pf, &n3));
}

// Random frames (8- and 16-bit) and windows against the naive reference.
static void test_prefilter_level_vs_naive(void)
{
    uint32_t seed = 77u;
    vd_calib_t cal = {65536, 0};
    vd_calib_grey_t grey;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&grey, &cal, 27000, 33000));
    for (int trial = 0; trial < 40; trial++) {
        const bool wide = (trial % 2) == 1;
        const uint32_t spread = 1u + tu_rand(&seed) % 256u;
        for (uint32_t y = 0; y < PH; y++) {
            for (uint32_t x = 0; x < PW; x++) {
                g_px[y][x] = (uint8_t)(tu_rand(&seed) % spread);
                g_px16[y][x] = (uint16_t)(26500u + tu_rand(&seed) % (25u * spread));
            }
        }
        vd_windows_prefilter_t pf;
        const vd_frame_t f16 = {g_px16, PW, PH, 2u * PW, VD_PIX_U16, 0, 0};
        const vd_frame_t f8 = frame8();
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_prefilter_init(&pf, wide ? &f16 : &f8, wide ? &grey : NULL,
                                                                g_pf_ws, sizeof(g_pf_ws)));
        for (int k = 0; k < 300; k++) {
            vd_rect_t b;
            b.w = (int32_t)(1u + tu_rand(&seed) % PW);
            b.h = (int32_t)(1u + tu_rand(&seed) % PH);
            b.x = (int32_t)(tu_rand(&seed) % (PW - (uint32_t)b.w + 1u));
            b.y = (int32_t)(tu_rand(&seed) % (PH - (uint32_t)b.h + 1u));
            TEST_ASSERT_EQUAL_UINT32(naive_level(&b, wide ? &grey : NULL), vd_windows_prefilter_level(&pf, &b));
        }
    }
}

typedef struct {
    size_t n;
    vd_rect_t got[MAXW / 4u];
} rank_log_t;
static rank_log_t g_log;

static void log_window(void *ctx, const vd_rect_t *win)
{
    rank_log_t *l = (rank_log_t *)ctx;
    l->got[l->n++] = *win;
}

// Ranking against a naive selection: the `room` windows of the highest levels
// (>= min_std; equal levels in generator order), reported in generator order.
static void test_rank_vs_naive(void)
{
    static uint32_t lv[MAXW];
    static uint8_t pick[MAXW];
    uint32_t seed = 31u;
    uint32_t hist[256];
    for (int trial = 0; trial < 30; trial++) {
        for (uint32_t y = 0; y < PH; y++) {
            for (uint32_t x = 0; x < PW; x++) {
                g_px[y][x] = (uint8_t)(tu_rand(&seed) % (1u + (x * 7u + y) % 97u));   // texture varies
            }
        }
        vd_windows_prefilter_t pf;
        prefilter8(&pf);
        vd_windows_cfg_t c;
        base_cfg(&c, PW, PH);
        one_band(&c, 0, (int32_t)PH - 1, 4, 30);
        c.stride_q8 = (uint16_t)(64u + tu_rand(&seed) % 200u);
        c.max_windows = 1048576u;
        size_t nw = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_generate(&c, g_ref, MAXW, &nw));
        const uint8_t min_std = (uint8_t)(tu_rand(&seed) % 20u);
        const size_t room = tu_rand(&seed) % (nw + 10u);
        uint32_t passed = 0u;
        for (size_t i = 0; i < nw; i++) {
            lv[i] = vd_windows_prefilter_level(&pf, &g_ref[i]);
            pick[i] = 0u;
            passed += (lv[i] >= min_std) ? 1u : 0u;
        }
        size_t taken = 0u;
        for (int level = 255; level >= (int)min_std && taken < room; level--) {
            for (size_t i = 0; i < nw && taken < room; i++) {
                if (lv[i] == (uint32_t)level) {
                    pick[i] = 1u;
                    taken++;
                }
            }
        }
        g_log.n = 0u;
        vd_windows_rank_stats_t st;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_rank(&c, &pf, min_std, room, hist, log_window, &g_log, &st));
        TEST_ASSERT_EQUAL_UINT32((uint32_t)nw, st.windows);
        TEST_ASSERT_EQUAL_UINT32(passed, st.passed);
        TEST_ASSERT_EQUAL_size_t(taken, g_log.n);
        size_t k = 0u;
        for (size_t i = 0; i < nw; i++) {
            if (pick[i] != 0u) {
                TEST_ASSERT_EQUAL_MEMORY(&g_ref[i], &g_log.got[k], sizeof(vd_rect_t));
                k++;
            }
        }
    }
}

static vd_status_t ws_prefilter(void *ws, size_t bytes, void *ctx)
{
    (void)ctx;
    vd_windows_prefilter_t pf;
    const vd_frame_t f = frame8();
    return vd_windows_prefilter_init(&pf, &f, NULL, ws, bytes);
}

static void test_prefilter_and_rank_arguments(void)
{
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_prefilter_workspace_size(PW, PH, &bytes));
    tu_check_workspace_contract(bytes, ws_prefilter, NULL);
    vd_windows_prefilter_t pf;
    const vd_frame_t f8 = frame8();
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_prefilter_init(NULL, &f8, NULL, g_pf_ws, sizeof(g_pf_ws)));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_prefilter_init(&pf, NULL, NULL, g_pf_ws, sizeof(g_pf_ws)));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_windows_prefilter_init(&pf, &f8, NULL, NULL, sizeof(g_pf_ws)));
    const vd_frame_t f16 = {g_px16, PW, PH, 2u * PW, VD_PIX_U16, 0, 0};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_prefilter_init(&pf, &f16, NULL, g_pf_ws, sizeof(g_pf_ws)));
    vd_frame_t bad = f8;
    bad.format = (vd_pixfmt_t)7;
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_windows_prefilter_init(&pf, &bad, NULL, g_pf_ws, sizeof(g_pf_ws)));
    prefilter8(&pf);
    vd_windows_cfg_t c;
    base_cfg(&c, PW, PH);
    uint32_t hist[256];
    vd_windows_rank_stats_t st;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_rank(NULL, &pf, 4u, 1u, hist, log_window, &g_log, &st));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_rank(&c, NULL, 4u, 1u, hist, log_window, &g_log, &st));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_rank(&c, &pf, 4u, 1u, NULL, log_window, &g_log, &st));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_rank(&c, &pf, 4u, 1u, hist, NULL, NULL, &st));
    c.stride_q8 = 1000u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_windows_rank(&c, &pf, 4u, 1u, hist, log_window, &g_log, &st));
    // Room 0: statistics only, no visitor needed.
    c.stride_q8 = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_rank(&c, &pf, 0u, 0u, hist, NULL, NULL, &st));
    uint32_t total = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_windows_count(&c, &total));
    TEST_ASSERT_EQUAL_UINT32(total, st.windows);
    TEST_ASSERT_EQUAL_UINT32(total, st.passed);   // min_std 0 passes everything
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
    RUN_TEST(test_prefilter_workspace_size);
    RUN_TEST(test_prefilter_level_hand_worked);
    RUN_TEST(test_prefilter_level_vs_naive);
    RUN_TEST(test_rank_vs_naive);
    RUN_TEST(test_prefilter_and_rank_arguments);
    return UNITY_END();
}
