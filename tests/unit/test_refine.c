// SPDX-License-Identifier: MIT
// Unit tests of refine.h: eq. (1) by hand and against Otsu, hole filling,
// edges, the whole region pipeline on a hand-worked image, workspace
// contracts, bad arguments.
#include "unity.h"
#include "testutil.h"
#include "vd/otsu.h"
#include "vd/refine.h"

#include <string.h>

void setUp(void) {}
void tearDown(void) {}

#define MAXW 48
#define MAXH 40

static uint8_t g_img[MAXW * MAXH];
static uint8_t g_mask[MAXW * MAXH];
static uint8_t g_ref[MAXW * MAXH];
static uint64_t g_ws[(5u * MAXW * MAXH + 1024u + 64u) / 8u];   // + 1 KiB: small ROIs' histogram

static void test_maxdist_hand_worked(void)
{
    // A 5x5 window: 10 px at 50, 10 at 100, 5 at 200; n = 25, S = 2500.
    //   T = 50:  c = 10, s = 500,  D = 500*25 - 2500*10 = -12500, D^2/(10*15) = 1041666.7
    //   T = 100: c = 20, s = 1500, D = 1500*25 - 2500*20 = -12500, D^2/(20*5) = 1562500
    // so T = 100 (class means 75 | 200 beat 50 | 133.3).
    uint32_t hist[256] = {0};
    uint8_t t = 0;
    hist[50] = 10;
    hist[100] = 10;
    hist[200] = 5;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_maxdist_from_hist(hist, &t));
    TEST_ASSERT_EQUAL_UINT8(100, t);
    // Two levels: every T in [50, 99] splits the same way; the smallest wins.
    hist[200] = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_maxdist_from_hist(hist, &t));
    TEST_ASSERT_EQUAL_UINT8(50, t);
    // 0 and 255 are valid levels.
    memset(hist, 0, sizeof hist);
    hist[0] = 12;
    hist[255] = 13;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_maxdist_from_hist(hist, &t));
    TEST_ASSERT_EQUAL_UINT8(0, t);
}

static void test_maxdist_errors(void)
{
    uint32_t hist[256] = {0};
    uint8_t t = 77;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_refine_maxdist_from_hist(hist, &t));    // empty
    hist[30] = 25;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_refine_maxdist_from_hist(hist, &t));    // one level
    hist[31] = VD_REFINE_MAXDIST_MAX_COUNT;                                        // too many pixels
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_refine_maxdist_from_hist(hist, &t));
    TEST_ASSERT_EQUAL_UINT8(77, t);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_maxdist_from_hist(NULL, &t));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_maxdist_from_hist(hist, NULL));
}

// eq. (1) is Otsu's criterion: otsu.h's independent exact implementation must
// agree on every histogram with two or more levels.
static void test_maxdist_equals_otsu_on_random_histograms(void)
{
    uint32_t st = 99u;
    for (int it = 0; it < 3000; it++) {
        uint32_t hist[256] = {0};
        const uint32_t n = 2u + tu_rand(&st) % (VD_REFINE_MAXDIST_MAX_COUNT - 1u);
        const uint32_t levels = 2u + tu_rand(&st) % 6u;
        uint8_t lv[8];
        for (uint32_t k = 0; k < levels; k++) {
            lv[k] = (uint8_t)(tu_rand(&st) & 255u);
        }
        for (uint32_t i = 0; i < n; i++) {
            hist[lv[tu_rand(&st) % levels]]++;
        }
        uint32_t used = 0;
        for (int i = 0; i < 256; i++) {
            used += hist[i] != 0u ? 1u : 0u;
        }
        uint8_t a = 0, b = 0;
        if (used < 2u) {
            TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_refine_maxdist_from_hist(hist, &a));
            continue;
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_maxdist_from_hist(hist, &a));
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_from_hist(hist, &b));
        TEST_ASSERT_EQUAL_UINT8(b, a);
    }
}

static vd_status_t fill(uint8_t *m, uint32_t w, uint32_t h, size_t stride)
{
    vd_image_u8_t img = {m, w, h, stride};
    size_t bytes = 0;
    vd_status_t st = vd_refine_fill_holes_workspace_size(w, h, &bytes);
    return st != VD_OK ? st : vd_refine_fill_holes_u8(&img, g_ws, bytes);
}

static void test_fill_holes_ring_and_diamond(void)
{
    // 7x7: ring on 1..5 with a gap at the right; a second ring closed.
    static const char *in[7] = {
        ".......",
        ".#####.",
        ".#...#.",
        ".#.#.#.",
        ".#...#.",
        ".#####.",
        ".......",
    };
    for (int y = 0; y < 7; y++) {
        for (int x = 0; x < 7; x++) {
            g_mask[y * 7 + x] = in[y][x] == '#' ? 200u : 0u;   // any nonzero is foreground
        }
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, fill(g_mask, 7, 7, 7));
    for (int y = 0; y < 7; y++) {
        for (int x = 0; x < 7; x++) {
            const uint8_t want = (x >= 1 && x <= 5 && y >= 1 && y <= 5) ? 255u : 0u;
            TEST_ASSERT_EQUAL_UINT8(want, g_mask[y * 7 + x]);
        }
    }
    // Ring open to the border (gap at (5,3) then (6,3) is outside): nothing filled.
    memset(g_mask, 0, 49);
    for (int y = 0; y < 7; y++) {
        for (int x = 0; x < 7; x++) {
            g_mask[y * 7 + x] = (in[y][x] == '#' && !(x == 5 && y == 3)) ? 255u : 0u;
        }
    }
    memcpy(g_ref, g_mask, 49);
    TEST_ASSERT_EQUAL_INT(VD_OK, fill(g_mask, 7, 7, 7));
    TEST_ASSERT_EQUAL_MEMORY(g_ref, g_mask, 49);
    // Diamond: the centre touches the outside only diagonally -> a hole
    // (background is 4-connected). Stride 6 > width 5.
    memset(g_mask, 0, sizeof g_mask);
    g_mask[1 * 6 + 2] = g_mask[2 * 6 + 1] = g_mask[2 * 6 + 3] = g_mask[3 * 6 + 2] = 255u;
    g_mask[2 * 6 + 5] = 123u;   // padding byte beyond the width: untouched
    TEST_ASSERT_EQUAL_INT(VD_OK, fill(g_mask, 5, 5, 6));
    TEST_ASSERT_EQUAL_UINT8(255, g_mask[2 * 6 + 2]);
    TEST_ASSERT_EQUAL_UINT8(0, g_mask[1 * 6 + 1]);
    TEST_ASSERT_EQUAL_UINT8(123, g_mask[2 * 6 + 5]);
}

// Naive reference: propagate "reached from the border" by repeated sweeps
// until nothing changes (bounded by w*h sweeps).
static void fill_naive(uint8_t *m, uint32_t w, uint32_t h)
{
    static uint8_t reach[MAXW * MAXH];
    memset(reach, 0, sizeof reach);
    for (uint32_t y = 0; y < h; y++) {
        for (uint32_t x = 0; x < w; x++) {
            const size_t i = (size_t)y * w + x;
            reach[i] = (m[i] == 0u && (x == 0u || y == 0u || x == w - 1u || y == h - 1u)) ? 1u : 0u;
        }
    }
    for (uint32_t pass = 0; pass < w * h; pass++) {
        bool changed = false;
        for (uint32_t y = 0; y < h; y++) {
            for (uint32_t x = 0; x < w; x++) {
                const size_t i = (size_t)y * w + x;
                if (m[i] != 0u || reach[i] != 0u) {
                    continue;
                }
                if ((x > 0u && reach[i - 1u]) || (x + 1u < w && reach[i + 1u]) || (y > 0u && reach[i - w]) ||
                    (y + 1u < h && reach[i + w])) {
                    reach[i] = 1u;
                    changed = true;
                }
            }
        }
        if (!changed) {
            break;
        }
    }
    for (size_t i = 0; i < (size_t)w * h; i++) {
        m[i] = reach[i] ? 0u : 255u;
    }
}

static void test_fill_holes_random_vs_naive(void)
{
    uint32_t st = 4242u;
    for (int it = 0; it < 200; it++) {
        const uint32_t w = 1u + tu_rand(&st) % MAXW;
        const uint32_t h = 1u + tu_rand(&st) % MAXH;
        const uint32_t dens = 2u + tu_rand(&st) % 6u;
        for (size_t i = 0; i < (size_t)w * h; i++) {
            g_mask[i] = (tu_rand(&st) % 8u) < dens ? 255u : 0u;
        }
        memcpy(g_ref, g_mask, (size_t)w * h);
        fill_naive(g_ref, w, h);
        TEST_ASSERT_EQUAL_INT(VD_OK, fill(g_mask, w, h, w));
        TEST_ASSERT_EQUAL_MEMORY(g_ref, g_mask, (size_t)w * h);
    }
}

static void test_edges_hand_worked(void)
{
    // 3x3 square in a 5x5 mask: the 8 ring pixels are edges, the centre not.
    memset(g_mask, 0, 25);
    for (int y = 1; y <= 3; y++) {
        for (int x = 1; x <= 3; x++) {
            g_mask[y * 5 + x] = 255u;
        }
    }
    vd_view_u8_t v = {g_mask, 5, 5, 5};
    vd_image_u8_t e = {g_ref, 5, 5, 5};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_edges_u8(&v, NULL, &e));
    int n = 0;
    for (int i = 0; i < 25; i++) {
        n += g_ref[i] == 255u ? 1 : 0;
    }
    TEST_ASSERT_EQUAL_INT(8, n);
    TEST_ASSERT_EQUAL_UINT8(0, g_ref[2 * 5 + 2]);
    TEST_ASSERT_EQUAL_UINT8(255, g_ref[1 * 5 + 2]);
    // ROI = the square itself: outside the ROI is background, same 8 edges.
    vd_rect_t roi = {1, 1, 3, 3};
    vd_image_u8_t e3 = {g_ref, 3, 3, 3};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_edges_u8(&v, &roi, &e3));
    static const uint8_t want[9] = {255, 255, 255, 255, 0, 255, 255, 255, 255};
    TEST_ASSERT_EQUAL_MEMORY(want, g_ref, 9);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_edges_u8(&v, &roi, &e));   // dst not roi-sized
    roi.x = 3;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_edges_u8(&v, &roi, &e3));  // roi outside
}

// 16x12 image, background 10, an 8x6 block at (4,3) of value 200, no median.
// Otsu (two levels) gives t = 10; M = the block; E = its 24 border pixels
// (8 + 8 + 4 + 4); windows at edge indices 0, 5, 10, 15, 20 all hold the two
// levels, so T = 10 and the mask stays the block: 48 foreground pixels.
static void make_block(void)
{
    memset(g_img, 10, 16 * 12);
    for (int y = 3; y < 9; y++) {
        for (int x = 4; x < 12; x++) {
            g_img[y * 16 + x] = 200u;
        }
    }
}

static void test_refine_hand_worked_block(void)
{
    make_block();
    vd_view_u8_t src = {g_img, 16, 12, 16};
    vd_image_u8_t mask = {g_mask, 16, 12, 16};
    vd_refine_cfg_t cfg;
    vd_refine_cfg_default(&cfg);
    TEST_ASSERT_EQUAL_UINT8(3, cfg.median_ksize);
    TEST_ASSERT_EQUAL_UINT8(5, cfg.edge_step);
    TEST_ASSERT_EQUAL_UINT8(5, cfg.window);
    cfg.median_ksize = 0;
    vd_refine_stats_t st;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_region(&src, NULL, &cfg, g_ws, sizeof g_ws, &mask, &st));
    TEST_ASSERT_EQUAL_UINT8(10, st.otsu_thr);
    TEST_ASSERT_EQUAL_UINT32(24, st.edge_points);
    TEST_ASSERT_EQUAL_UINT32(5, st.local_windows);
    TEST_ASSERT_EQUAL_UINT32(48, st.fg_pixels);
    for (int y = 0; y < 12; y++) {
        for (int x = 0; x < 16; x++) {
            TEST_ASSERT_EQUAL_UINT8(g_img[y * 16 + x] == 200u ? 255u : 0u, g_mask[y * 16 + x]);
        }
    }
    // A 3x3 median keeps the block's corners? No: a corner pixel has 4 of 9
    // block neighbours, so it becomes background; 44 pixels remain.
    cfg.median_ksize = 3;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_region(&src, NULL, &cfg, g_ws, sizeof g_ws, &mask, &st));
    TEST_ASSERT_EQUAL_UINT32(44, st.fg_pixels);
    TEST_ASSERT_EQUAL_UINT8(0, g_mask[3 * 16 + 4]);
    TEST_ASSERT_EQUAL_UINT8(255, g_mask[3 * 16 + 5]);
}

// One row, no median: 10 10 10 100 200 200 100 10 10.
// Global Otsu: split at 10 gives (5/9)(4/9)(150-10)^2 = 4839 > 4665 at 100,
// so t = 10 and M = x 3..6; in one row every foreground pixel is an edge
// (above and below are outside): E = {3, 4, 5, 6}; edge_step 3 selects x = 3
// and x = 6. Window (5 wide, clipped to the row) at x = 3 covers x 1..5 =
// {10, 10, 100, 200, 200}: n = 5, S = 520;
//   T = 10:  c = 2, s = 20,  D = 100 - 1040 = -940, D^2/(2*3) = 147266.7
//   T = 100: c = 3, s = 120, D = 600 - 1560 = -960, D^2/(3*2) = 153600
// so T = 100 and x 1..5 become 0 0 0 255 255; the window at x = 6 (x 4..8,
// the same levels) gives x 4..8 = 255 255 0 0 0. The local thresholds drop
// the 100s that the global one kept.
static void test_refine_local_window_overrides_global(void)
{
    static const uint8_t row[9] = {10, 10, 10, 100, 200, 200, 100, 10, 10};
    static const uint8_t want[9] = {0, 0, 0, 0, 255, 255, 0, 0, 0};
    vd_view_u8_t src = {row, 9, 1, 9};
    vd_image_u8_t mask = {g_mask, 9, 1, 9};
    vd_refine_cfg_t cfg = {0, 3, 5};
    vd_refine_stats_t st;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_region(&src, NULL, &cfg, g_ws, sizeof g_ws, &mask, &st));
    TEST_ASSERT_EQUAL_UINT8(10, st.otsu_thr);
    TEST_ASSERT_EQUAL_UINT32(4, st.edge_points);
    TEST_ASSERT_EQUAL_UINT32(2, st.local_windows);
    TEST_ASSERT_EQUAL_UINT32(2, st.fg_pixels);
    TEST_ASSERT_EQUAL_MEMORY(want, g_mask, 9);
}

// Naive steps 3-5 (no median) from the public pieces: Otsu, binarise, fill,
// edges, then every step-th edge pixel's window re-thresholded with
// vd_refine_maxdist_from_hist on a full 256-bin histogram. vd_refine_region visits
// only a window's occupied levels; the result must be the same, also with
// few grey levels (ties between splits).
static void refine_naive(const uint8_t *img, uint32_t w, uint32_t h, uint32_t step, uint32_t win, uint8_t *out)
{
    static uint8_t edges[MAXW * MAXH];
    static uint64_t fws[(4u * MAXW * MAXH) / 8u + 1u];
    uint32_t hist[256];
    const vd_view_u8_t src = {img, w, h, w};
    uint8_t t = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_u8(&src, NULL, &t));
    for (uint32_t i = 0; i < w * h; i++) {
        out[i] = img[i] > t ? 255u : 0u;
    }
    vd_image_u8_t m = {out, w, h, w};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_fill_holes_u8(&m, fws, sizeof fws));
    vd_image_u8_t e = {edges, w, h, w};
    const vd_view_u8_t mv = {out, w, h, w};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_edges_u8(&mv, NULL, &e));
    const int32_t half = (int32_t)win / 2;
    uint32_t k = 0u;
    for (int32_t y = 0; y < (int32_t)h; y++) {
        for (int32_t x = 0; x < (int32_t)w; x++) {
            if (edges[(uint32_t)y * w + (uint32_t)x] == 0u || (k++ % step) != 0u) {
                continue;
            }
            memset(hist, 0, sizeof hist);
            for (int32_t yy = y - half; yy <= y + half; yy++) {
                for (int32_t xx = x - half; xx <= x + half; xx++) {
                    if (yy >= 0 && yy < (int32_t)h && xx >= 0 && xx < (int32_t)w) {
                        hist[img[(uint32_t)yy * w + (uint32_t)xx]]++;
                    }
                }
            }
            uint8_t tl = 0;
            if (vd_refine_maxdist_from_hist(hist, &tl) != VD_OK) {
                continue;
            }
            for (int32_t yy = y - half; yy <= y + half; yy++) {
                for (int32_t xx = x - half; xx <= x + half; xx++) {
                    if (yy >= 0 && yy < (int32_t)h && xx >= 0 && xx < (int32_t)w) {
                        const uint32_t i = (uint32_t)yy * w + (uint32_t)xx;
                        out[i] = img[i] > tl ? 255u : 0u;
                    }
                }
            }
        }
    }
}

static void test_refine_random_vs_naive(void)
{
    uint32_t seed = 99u;
    for (int trial = 0; trial < 200; trial++) {
        const uint32_t w = 2u + tu_rand(&seed) % (MAXW - 1u), h = 2u + tu_rand(&seed) % (MAXH - 1u);
        const uint32_t levels = 2u + tu_rand(&seed) % 7u;
        uint8_t lv[8];
        for (uint32_t i = 0; i < levels; i++) {
            lv[i] = (uint8_t)tu_rand(&seed);
        }
        // Blocky images: a warm rectangle over few-level noise, or pure noise.
        const uint32_t bx = tu_rand(&seed) % w, by = tu_rand(&seed) % h;
        for (uint32_t y = 0; y < h; y++) {
            for (uint32_t x = 0; x < w; x++) {
                const bool in = (trial % 4 != 0) && x >= bx && x < bx + w / 2u && y >= by && y < by + h / 2u;
                g_img[y * w + x] = in ? (uint8_t)(200u + tu_rand(&seed) % 3u)
                                      : (trial % 2 == 0 ? lv[tu_rand(&seed) % levels] : (uint8_t)tu_rand(&seed));
            }
        }
        vd_refine_cfg_t cfg = {0u, (uint8_t)(1u + tu_rand(&seed) % 6u), (uint8_t)(3u + 2u * (tu_rand(&seed) % 7u))};
        const vd_view_u8_t src = {g_img, w, h, w};
        vd_image_u8_t mask = {g_mask, w, h, w};
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_region(&src, NULL, &cfg, g_ws, sizeof g_ws, &mask, NULL));
        refine_naive(g_img, w, h, cfg.edge_step, cfg.window, g_ref);
        TEST_ASSERT_EQUAL_MEMORY(g_ref, g_mask, (size_t)w * h);
    }
}

typedef struct rctx {
    vd_view_u8_t src;
    vd_rect_t roi;
    vd_image_u8_t mask;
} rctx_t;

static vd_status_t run_refine(void *ws, size_t bytes, void *ctx)
{
    rctx_t *c = (rctx_t *)ctx;
    return vd_refine_region(&c->src, &c->roi, NULL, ws, bytes, &c->mask, NULL);
}

static vd_status_t run_fill(void *ws, size_t bytes, void *ctx)
{
    rctx_t *c = (rctx_t *)ctx;
    return vd_refine_fill_holes_u8(&c->mask, ws, bytes);
}

static void test_workspace_contracts(void)
{
    uint32_t st = 5u;
    for (size_t i = 0; i < sizeof g_img; i++) {
        g_img[i] = (uint8_t)(tu_rand(&st) & 255u);
    }
    // Odd sizes so the slices need alignment padding.
    rctx_t c = {{g_img, MAXW, MAXH, MAXW}, {3, 5, 13, 11}, {g_mask, 13, 11, 13}};
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_workspace_size(13, 11, &bytes));
    // Plane 144 (143 aligned) + max(fill stack 4*143, 144 + histogram 1024).
    TEST_ASSERT_EQUAL_size_t(144u + 144u + 1024u, bytes);
    tu_check_workspace_contract(bytes, run_refine, &c);
    // From 342 pixels on the histogram fits beside the edge image: 5*w*h + alignment.
    rctx_t big = {{g_img, MAXW, MAXH, MAXW}, {0, 0, 24, 15}, {g_mask, 24, 15, 24}};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_workspace_size(24, 15, &bytes));
    TEST_ASSERT_EQUAL_size_t(360u + 4u * 360u, bytes);
    tu_check_workspace_contract(bytes, run_refine, &big);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_workspace_size(13, 11, &bytes));
    tu_check_workspace_contract(bytes, run_refine, &c);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_fill_holes_workspace_size(13, 11, &bytes));
    TEST_ASSERT_EQUAL_size_t(4u * 143u, bytes);
    tu_check_workspace_contract(bytes, run_fill, &c);
}

static void test_bad_args(void)
{
    make_block();
    vd_view_u8_t src = {g_img, 16, 12, 16};
    vd_image_u8_t mask = {g_mask, 16, 12, 16};
    vd_refine_cfg_t cfg;
    size_t bytes;
    vd_refine_cfg_default(&cfg);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_workspace_size(0, 3, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_workspace_size(3, 3, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_fill_holes_workspace_size(3, VD_MAX_DIM + 1u, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_region(NULL, NULL, &cfg, g_ws, sizeof g_ws, &mask, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_region(&src, NULL, &cfg, g_ws, sizeof g_ws, NULL, NULL));
    vd_rect_t roi = {10, 0, 8, 12};   // beyond the right edge
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_region(&src, &roi, &cfg, g_ws, sizeof g_ws, &mask, NULL));
    roi.x = 2;   // inside, but the mask is not roi-sized
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_region(&src, &roi, &cfg, g_ws, sizeof g_ws, &mask, NULL));
    static const vd_refine_cfg_t bad[] = {{4, 5, 5}, {1, 5, 5}, {3, 0, 5}, {3, 5, 4}, {3, 5, 1},
                                          {3, 5, 17}, {5, 5, 0}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_region(&src, NULL, &bad[i], g_ws, sizeof g_ws, &mask, NULL));
    }
    src.stride = 15;   // stride < width
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_region(&src, NULL, &cfg, g_ws, sizeof g_ws, &mask, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_fill_holes_u8(NULL, g_ws, sizeof g_ws));
    vd_image_u8_t zero = {g_mask, 0, 4, 4};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_fill_holes_u8(&zero, g_ws, sizeof g_ws));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_edges_u8(NULL, NULL, &mask));
    // cfg NULL = defaults; odd strides everywhere.
    src.stride = 17;
    static uint8_t big[17 * 12];
    for (int y = 0; y < 12; y++) {
        memcpy(big + y * 17, g_img + y * 16, 16);
    }
    src.data = big;
    vd_image_u8_t m2 = {g_mask, 16, 12, 19};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_refine_region(&src, NULL, NULL, g_ws, sizeof g_ws, &m2, NULL));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_maxdist_hand_worked);
    RUN_TEST(test_maxdist_errors);
    RUN_TEST(test_maxdist_equals_otsu_on_random_histograms);
    RUN_TEST(test_fill_holes_ring_and_diamond);
    RUN_TEST(test_fill_holes_random_vs_naive);
    RUN_TEST(test_refine_random_vs_naive);
    RUN_TEST(test_edges_hand_worked);
    RUN_TEST(test_refine_hand_worked_block);
    RUN_TEST(test_refine_local_window_overrides_global);
    RUN_TEST(test_workspace_contracts);
    RUN_TEST(test_bad_args);
    return UNITY_END();
}
