// SPDX-License-Identifier: MIT
// Unit tests of components.h: hand-worked masks, a naive flood-fill reference
// on random masks, the thresholding labellers against the mask labeller, the
// streamed row-pair labeller against the whole-frame one, run
// budgets, capacity, workspace contracts and rules (box expansion: test_rect.c).
#include "unity.h"
#include "testutil.h"
#include "regions/components_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void setUp(void) {}
void tearDown(void) {}

#define MAXC 4096

static vd_component_t g_out[MAXC];

// Labels a whole w x h mask (stride w) with an exactly sized workspace.
static vd_status_t label_mask(const uint8_t *m, uint32_t w, uint32_t h, size_t stride, const vd_rect_t *roi,
                              vd_component_t *out, size_t cap, size_t *count)
{
    vd_view_u8_t v = {m, w, h, stride};
    vd_rect_t r = {0, 0, (int32_t)w, (int32_t)h};
    if (roi != NULL) {
        r = *roi;
    }
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size((uint32_t)r.w, (uint32_t)r.h, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    vd_status_t st = vd_components_label(&v, roi, ws, bytes, out, cap, count);
    tu_guard_check(0);
    tu_guarded_free(0);
    return st;
}

// Builds a mask from rows of '#' (foreground) and '.' characters.
static void mask_from_text(const char *const *rows, uint32_t h, uint8_t *m, uint32_t *w)
{
    *w = (uint32_t)strlen(rows[0]);
    for (uint32_t y = 0; y < h; y++) {
        for (uint32_t x = 0; x < *w; x++) {
            m[y * *w + x] = rows[y][x] == '#' ? 255u : 0u;
        }
    }
}

static void assert_comp(const vd_component_t *c, int32_t x, int32_t y, int32_t w, int32_t h, uint32_t area,
                        uint32_t cx_q8, uint32_t cy_q8)
{
    TEST_ASSERT_EQUAL_INT32(x, c->box.x);
    TEST_ASSERT_EQUAL_INT32(y, c->box.y);
    TEST_ASSERT_EQUAL_INT32(w, c->box.w);
    TEST_ASSERT_EQUAL_INT32(h, c->box.h);
    TEST_ASSERT_EQUAL_UINT32(area, c->area);
    TEST_ASSERT_EQUAL_UINT32(cx_q8, c->cx_q8);
    TEST_ASSERT_EQUAL_UINT32(cy_q8, c->cy_q8);
}

// ---------------------------------------------------------------- reference
// Naive labelling: flood fill with an explicit stack, components numbered in
// the order of their first 2x2 block (block rows, then block columns), which
// is the documented order. Centroid formula as documented.
static size_t naive_label(const uint8_t *m, uint32_t w, uint32_t h, size_t stride, int32_t ox, int32_t oy,
                          vd_component_t *out, size_t cap)
{
    uint8_t *seen = (uint8_t *)calloc((size_t)w * h, 1);
    uint32_t *stack = (uint32_t *)malloc((size_t)w * h * sizeof(uint32_t) + 4);
    TEST_ASSERT_NOT_NULL(seen);
    TEST_ASSERT_NOT_NULL(stack);
    size_t n = 0;
    for (uint32_t by = 0; by < h; by += 2) {
        for (uint32_t bx = 0; bx < w; bx += 2) {
            for (uint32_t d = 0; d < 4; d++) {
                uint32_t sx = bx + (d & 1u), sy = by + (d >> 1);
                if (sx >= w || sy >= h || m[sy * stride + sx] == 0 || seen[sy * w + sx]) {
                    continue;
                }
                uint32_t minx = sx, maxx = sx, miny = sy, maxy = sy, area = 0;
                uint64_t sumx = 0, sumy = 0;
                size_t top = 0;
                stack[top++] = sy * w + sx;
                seen[sy * w + sx] = 1;
                while (top > 0) {
                    uint32_t p = stack[--top];
                    uint32_t x = p % w, y = p / w;
                    area++;
                    sumx += x;
                    sumy += y;
                    minx = x < minx ? x : minx;
                    maxx = x > maxx ? x : maxx;
                    miny = y < miny ? y : miny;
                    maxy = y > maxy ? y : maxy;
                    for (int dy = -1; dy <= 1; dy++) {
                        for (int dx = -1; dx <= 1; dx++) {
                            int64_t nx = (int64_t)x + dx, ny = (int64_t)y + dy;
                            if (nx < 0 || ny < 0 || nx >= (int64_t)w || ny >= (int64_t)h) {
                                continue;
                            }
                            uint32_t q = (uint32_t)ny * w + (uint32_t)nx;
                            if (!seen[q] && m[(size_t)ny * stride + (size_t)nx] != 0) {
                                seen[q] = 1;
                                stack[top++] = q;
                            }
                        }
                    }
                }
                if (n < cap) {
                    vd_component_t *c = &out[n];
                    c->box.x = (int32_t)minx + ox;
                    c->box.y = (int32_t)miny + oy;
                    c->box.w = (int32_t)(maxx - minx + 1);
                    c->box.h = (int32_t)(maxy - miny + 1);
                    c->area = area;
                    c->cx_q8 = (uint32_t)((512u * sumx + area) / (2u * area)) + ((uint32_t)ox << 8);
                    c->cy_q8 = (uint32_t)((512u * sumy + area) / (2u * area)) + ((uint32_t)oy << 8);
                }
                n++;
            }
        }
    }
    free(seen);
    free(stack);
    return n;
}

static void assert_same_comps(const vd_component_t *exp, const vd_component_t *got, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        char msg[64];
        snprintf(msg, sizeof msg, "component %zu", i);
        tu_assert_rect_equal(&exp[i].box, &got[i].box, msg);
        TEST_ASSERT_EQUAL_UINT32_MESSAGE(exp[i].area, got[i].area, msg);
        TEST_ASSERT_EQUAL_UINT32_MESSAGE(exp[i].cx_q8, got[i].cx_q8, msg);
        TEST_ASSERT_EQUAL_UINT32_MESSAGE(exp[i].cy_q8, got[i].cy_q8, msg);
    }
}

// ---------------------------------------------------------------- labelling

static void test_workspace_size(void)
{
    size_t b = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(640, 512, &b));
    TEST_ASSERT_EQUAL_size_t(1319432u, b); // value documented in components.h
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(640, 480, &b));
    TEST_ASSERT_EQUAL_size_t(1237448u, b);
    size_t small = 0, big = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(1, 1, &small));
    TEST_ASSERT_TRUE(small > 0u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(VD_MAX_DIM, VD_MAX_DIM, &big));
    TEST_ASSERT_TRUE(big > b);
    // monotone in both dimensions
    for (uint32_t w = 1; w < 40; w++) {
        for (uint32_t h = 1; h < 40; h++) {
            size_t a, c, d;
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(w, h, &a));
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(w + 1, h, &c));
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(w, h + 1, &d));
            TEST_ASSERT_TRUE(a <= c && a <= d);
        }
    }
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size(0, 10, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size(10, 0, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size(VD_MAX_DIM + 1u, 10, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size(10, VD_MAX_DIM + 1u, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size(10, 10, NULL));
}

static void test_single_pixel_and_empty(void)
{
    static uint8_t m[7 * 9];
    size_t n = 99;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, 7, 9, 7, NULL, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    m[5 * 7 + 3] = 1; // any nonzero value is foreground
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, 7, 9, 7, NULL, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    assert_comp(&g_out[0], 3, 5, 1, 1, 1, 768, 1280);
    // 1x1 image
    uint8_t one = 255;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(&one, 1, 1, 1, NULL, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    assert_comp(&g_out[0], 0, 0, 1, 1, 1, 0, 0);
}

static void test_full_image(void)
{
    static uint8_t m[37 * 23];
    memset(m, 255, sizeof m);
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, 37, 23, 37, NULL, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    assert_comp(&g_out[0], 0, 0, 37, 23, 37u * 23u, 18u * 256u, 11u * 256u);
}

static void test_diagonal_only_connectivity(void)
{
    static const char *const rows[] = {
        "#.....#",
        ".#...#.",
        "..#.#..",
        "...#...",
        ".......",
        "#.#.#.#",
    };
    static uint8_t m[7 * 6];
    uint32_t w;
    mask_from_text(rows, 6, m, &w);
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, w, 6, w, NULL, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(5u, n); // the V joins only through diagonals; the dots are apart
    // V: x sum 0+6+1+5+2+4+3 = 21, y sum 0+0+1+1+2+2+3 = 9, area 7
    assert_comp(&g_out[0], 0, 0, 7, 4, 7, (512u * 21u + 7u) / 14u, (512u * 9u + 7u) / 14u);
    assert_comp(&g_out[1], 0, 5, 1, 1, 1, 0, 5u * 256u);
    assert_comp(&g_out[2], 2, 5, 1, 1, 1, 2u * 256u, 5u * 256u);
    assert_comp(&g_out[4], 6, 5, 1, 1, 1, 6u * 256u, 5u * 256u);
}

static void test_checkerboard_is_one_component(void)
{
    static uint8_t m[31 * 17];
    uint32_t area = 0;
    for (uint32_t y = 0; y < 17; y++) {
        for (uint32_t x = 0; x < 31; x++) {
            m[y * 31 + x] = ((x + y) & 1u) ? 0u : 255u;
            area += ((x + y) & 1u) ? 0u : 1u;
        }
    }
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, 31, 17, 31, NULL, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_UINT32(area, g_out[0].area);
    TEST_ASSERT_EQUAL_INT32(31, g_out[0].box.w);
    TEST_ASSERT_EQUAL_INT32(17, g_out[0].box.h);
    TEST_ASSERT_EQUAL_UINT32(15u * 256u, g_out[0].cx_q8); // symmetric about (15, 8)
    TEST_ASSERT_EQUAL_UINT32(8u * 256u, g_out[0].cy_q8);
}

static void test_u_shapes_merge_late(void)
{
    // Two bars that meet only on the last row, a nested U inside, a dot.
    static const char *const rows[] = {
        "#.......#..",
        "#.#...#.#.#",
        "#.#...#.#..",
        "#.#####.#..",
        "#.......#..",
        "#########..",
    };
    static uint8_t m[11 * 6];
    uint32_t w;
    mask_from_text(rows, 6, m, &w);
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, w, 6, w, NULL, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(3u, n);
    TEST_ASSERT_EQUAL_INT32(0, g_out[0].box.x);
    TEST_ASSERT_EQUAL_INT32(9, g_out[0].box.w);
    TEST_ASSERT_EQUAL_INT32(6, g_out[0].box.h);
    TEST_ASSERT_EQUAL_UINT32(6u + 6u + 7u, g_out[0].area);
    assert_comp(&g_out[1], 2, 1, 5, 3, 9, 4u * 256u, (512u * (1u * 2 + 2u * 2 + 3u * 5) + 9u) / 18u);
    assert_comp(&g_out[2], 10, 1, 1, 1, 1, 10u * 256u, 256u);
    vd_component_t ref[8];
    TEST_ASSERT_EQUAL_size_t(3u, naive_label(m, w, 6, w, 0, 0, ref, 8));
    assert_same_comps(ref, g_out, 3);
}

static void test_block_order_not_pixel_order(void)
{
    // (10, 0) comes first in pixel raster order, but (0, 1) lies in the first
    // 2x2 block, so OpenCV (and vd) number it first.
    static uint8_t m[20 * 4];
    m[0 * 20 + 10] = 255;
    m[1 * 20 + 0] = 255;
    m[2 * 20 + 5] = 255; // next block row: last
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, 20, 4, 20, NULL, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(3u, n);
    assert_comp(&g_out[0], 0, 1, 1, 1, 1, 0, 256);
    assert_comp(&g_out[1], 10, 0, 1, 1, 1, 2560, 0);
    assert_comp(&g_out[2], 5, 2, 1, 1, 1, 1280, 512);
}

static void test_spiral(void)
{
    enum { S = 41 };
    static uint8_t m[S * S];
    memset(m, 0, sizeof m);
    // square spiral of 1-px wall with 1-px gaps, drawn inwards
    int32_t x0 = 0, y0 = 0, x1 = S - 1, y1 = S - 1;
    uint32_t area = 0;
    for (int guard = 0; guard < S && x0 <= x1 && y0 <= y1; guard++) {
        for (int32_t x = x0; x <= x1; x++) { m[y0 * S + x] = 255; }
        for (int32_t y = y0; y <= y1; y++) { m[y * S + x1] = 255; }
        for (int32_t x = x0; x <= x1; x++) { m[y1 * S + x] = 255; }
        for (int32_t y = y0 + 2; y <= y1; y++) { m[y * S + x0] = 255; }
        if (x0 + 2 <= x1) { m[(y0 + 2) * S + x0 + 1] = 255; }
        x0 += 2; y0 += 2; x1 -= 2; y1 -= 2;
    }
    for (size_t i = 0; i < sizeof m; i++) { area += m[i] ? 1u : 0u; }
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, S, S, S, NULL, g_out, MAXC, &n));
    vd_component_t ref[64];
    size_t nr = naive_label(m, S, S, S, 0, 0, ref, 64);
    TEST_ASSERT_EQUAL_size_t(nr, n);
    assert_same_comps(ref, g_out, n);
    TEST_ASSERT_EQUAL_size_t(1u, n); // the spiral is one wall
    TEST_ASSERT_EQUAL_UINT32(area, g_out[0].area);
}

static void test_centroid_round_half_up(void)
{
    // column x = 0, rows 0..510 (511 px) + pixel (1, 0): area 512, sum x = 1,
    // 256 * 1 / 512 = 0.5 -> 1; sum y = 130305, 256 * 130305 / 512 = 65152.5 -> 65153.
    static uint8_t m[2 * 511];
    for (int y = 0; y < 511; y++) { m[y * 2] = 255; }
    m[1] = 255;
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, 2, 511, 2, NULL, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    assert_comp(&g_out[0], 0, 0, 2, 511, 512, 1, 65153);
    // three pixels x = 0, 1, 1: 512 / 3 = 170.67 -> 171
    static uint8_t t[2 * 2] = {255, 255, 0, 255};
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(t, 2, 2, 2, NULL, g_out, MAXC, &n));
    assert_comp(&g_out[0], 0, 0, 2, 2, 3, 171, 85);
}

static void test_roi_and_stride(void)
{
    // A 12x10 mask with stride 16; ROI cuts a component in two.
    static uint8_t m[16 * 10];
    memset(m, 0xEE, sizeof m); // padding bytes beyond width must be ignored
    for (int y = 0; y < 10; y++) {
        for (int x = 0; x < 12; x++) {
            m[y * 16 + x] = 0;
        }
    }
    for (int x = 2; x < 10; x++) { m[4 * 16 + x] = 255; } // horizontal bar y = 4
    for (int y = 0; y < 10; y++) { m[y * 16 + 11] = 255; } // full column x = 11
    vd_rect_t roi = {3, 3, 5, 4}; // x 3..7, y 3..6
    size_t n = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, 12, 10, 16, &roi, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    assert_comp(&g_out[0], 3, 4, 5, 1, 5, 5u * 256u, 4u * 256u);
    vd_rect_t whole = {0, 0, 12, 10};
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, 12, 10, 16, &whole, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(2u, n);
    // bar (first block row 2) vs column (block row 0): column first
    TEST_ASSERT_EQUAL_INT32(11, g_out[0].box.x);
    TEST_ASSERT_EQUAL_INT32(2, g_out[1].box.x);
}

static void test_random_vs_naive(void)
{
    static const uint32_t sizes[][2] = {{1, 1}, {1, 17}, {23, 1}, {2, 2}, {3, 5}, {8, 8}, {9, 7}, {16, 3},
                                        {17, 16}, {33, 31}, {64, 48}, {65, 33}, {127, 9}};
    static vd_component_t ref[MAXC];
    uint32_t seed = 12345;
    static uint8_t buf[140 * 64];
    int cases = 0;
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        for (int dens = 0; dens < 6; dens++) {
            for (int rep = 0; rep < 4; rep++) {
                const uint32_t w = sizes[s][0], h = sizes[s][1];
                const size_t stride = w + (tu_rand(&seed) % 5u);
                // densities 1/16 .. 15/16, plus blobs made of random rectangles
                uint32_t thr = (uint32_t)(1 + dens * 3) * 16u;
                for (uint32_t y = 0; y < h; y++) {
                    for (size_t x = 0; x < stride; x++) {
                        uint32_t r = tu_rand(&seed);
                        buf[y * stride + x] = (x < w) ? (((r & 0xFFu) < thr) ? (uint8_t)(1u + (r >> 24) % 255u) : 0u)
                                                      : 0xFFu;
                    }
                }
                if (rep == 3) { // sparse rectangles instead of noise
                    for (uint32_t y = 0; y < h; y++) { memset(buf + y * stride, 0, w); }
                    for (int k = 0; k < 1 + dens * 3; k++) {
                        uint32_t rx = tu_rand(&seed) % w, ry = tu_rand(&seed) % h;
                        uint32_t rw = 1 + tu_rand(&seed) % 9u, rh = 1 + tu_rand(&seed) % 9u;
                        for (uint32_t y = ry; y < ry + rh && y < h; y++) {
                            for (uint32_t x = rx; x < rx + rw && x < w; x++) { buf[y * stride + x] = 255; }
                        }
                    }
                }
                vd_rect_t roi = {0, 0, (int32_t)w, (int32_t)h};
                if (rep >= 2) {
                    roi.x = (int32_t)(tu_rand(&seed) % w);
                    roi.y = (int32_t)(tu_rand(&seed) % h);
                    roi.w = 1 + (int32_t)(tu_rand(&seed) % (w - (uint32_t)roi.x));
                    roi.h = 1 + (int32_t)(tu_rand(&seed) % (h - (uint32_t)roi.y));
                }
                size_t n = 0;
                vd_status_t st = label_mask(buf, w, h, stride, &roi, g_out, MAXC, &n);
                TEST_ASSERT_EQUAL_INT(VD_OK, st);
                size_t nr = naive_label(buf + (size_t)roi.y * stride + (size_t)roi.x, (uint32_t)roi.w,
                                        (uint32_t)roi.h, stride, roi.x, roi.y, ref, MAXC);
                TEST_ASSERT_EQUAL_size_t(nr, n);
                assert_same_comps(ref, g_out, n);
                cases++;
            }
        }
    }
    TEST_ASSERT_EQUAL_INT(13 * 6 * 4, cases);
}

static void test_capacity(void)
{
    static uint8_t m[8 * 8];
    for (int i = 0; i < 4; i++) { m[(2 * i) * 8 + 2 * i] = 255; m[(2 * i) * 8 + 7 - (i & 1)] = 255; }
    static vd_component_t all[16];
    size_t n_all = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, 8, 8, 8, NULL, all, 16, &n_all));
    TEST_ASSERT_TRUE(n_all > 2u);
    size_t n = 99;
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, label_mask(m, 8, 8, 8, NULL, NULL, 0, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    vd_component_t one[2];
    memset(one, 0x5A, sizeof one);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, label_mask(m, 8, 8, 8, NULL, one, 1, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    assert_same_comps(all, one, 1);
    TEST_ASSERT_EQUAL_HEX8(0x5A, ((uint8_t *)&one[1])[0]); // nothing beyond cap
    vd_component_t exact[16];
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, label_mask(m, 8, 8, 8, NULL, exact, n_all - 1u, &n));
    TEST_ASSERT_EQUAL_size_t(n_all - 1u, n);
    assert_same_comps(all, exact, n);
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(m, 8, 8, 8, NULL, exact, n_all, &n));
    TEST_ASSERT_EQUAL_size_t(n_all, n);
    // empty mask with cap 0 is fine
    static uint8_t z[4 * 4];
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(z, 4, 4, 4, NULL, NULL, 0, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
}

typedef struct ws_ctx {
    const vd_view_u8_t *v;
    const vd_rect_t *roi;
} ws_ctx_t;

static vd_status_t run_label(void *ws, size_t bytes, void *ctx)
{
    const ws_ctx_t *c = (const ws_ctx_t *)ctx;
    size_t n;
    return vd_components_label(c->v, c->roi, ws, bytes, g_out, MAXC, &n);
}

static void test_workspace_contract(void)
{
    static uint8_t m[50 * 30];
    uint32_t seed = 7;
    for (size_t i = 0; i < sizeof m; i++) { m[i] = (tu_rand(&seed) & 1u) ? 255u : 0u; }
    for (size_t i = 0; i < 50; i += 2) { m[i] = 255; m[i + 1] = 0; } // a worst-case run row
    vd_view_u8_t v = {m, 50, 30, 50};
    size_t bytes;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(50, 30, &bytes));
    ws_ctx_t ctx = {&v, NULL};
    tu_check_workspace_contract(bytes, run_label, &ctx);
    vd_rect_t roi = {3, 5, 41, 19};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(41, 19, &bytes));
    ctx.roi = &roi;
    tu_check_workspace_contract(bytes, run_label, &ctx);
    // checkerboard = the worst case of runs, filling the run array exactly
    for (size_t y = 0; y < 30; y++) {
        for (size_t x = 0; x < 50; x++) { m[y * 50 + x] = ((x + y) & 1u) ? 0u : 255u; }
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(50, 30, &bytes));
    ctx.roi = NULL;
    tu_check_workspace_contract(bytes, run_label, &ctx);
    // a larger workspace (sized for the maximum) also works for a small ROI
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(50, 30, &bytes));
    void *ws = tu_guarded_alloc(1, bytes);
    size_t n;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_label(&v, &roi, ws, bytes, g_out, MAXC, &n));
    tu_guard_check(1);
    tu_guarded_free(1);
}

static void test_bad_arguments(void)
{
    static uint8_t m[8 * 8];
    static uint64_t ws[4096];
    vd_view_u8_t v = {m, 8, 8, 8};
    size_t n = 77;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label(NULL, NULL, ws, sizeof ws, g_out, MAXC, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label(&v, NULL, ws, sizeof ws, g_out, MAXC, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label(&v, NULL, ws, sizeof ws, NULL, 3, &n));
    vd_rect_t out_of = {4, 4, 5, 2};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label(&v, &out_of, ws, sizeof ws, g_out, MAXC, &n));
    vd_rect_t zero = {0, 0, 0, 2};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label(&v, &zero, ws, sizeof ws, g_out, MAXC, &n));
    vd_view_u8_t bad = {m, 8, 8, 7}; // stride below width
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label(&bad, NULL, ws, sizeof ws, g_out, MAXC, &n));
    bad.stride = 8;
    bad.data = NULL;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label(&bad, NULL, ws, sizeof ws, g_out, MAXC, &n));
    vd_view_u8_t odd = {m, 3, 5, 3}; // odd stride is fine for 8-bit
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_label(&odd, NULL, ws, sizeof ws, g_out, MAXC, &n));
}

// ---------------------------------------------------------------- thresholding labellers

// Mask of plane >= thr (0/255), same stride, for comparison with the mask API.
static uint8_t g_plane8[160 * 64];
static uint16_t g_plane16[160 * 64];
static uint8_t g_ref_mask[160 * 64];

// Number of horizontal runs of nonzero pixels in a w x h mask.
static uint32_t count_runs(const uint8_t *m, uint32_t w, uint32_t h, size_t stride)
{
    uint32_t n = 0;
    for (uint32_t y = 0; y < h; y++) {
        for (uint32_t x = 0; x < w; x++) {
            if (m[y * stride + x] != 0u && (x == 0u || m[y * stride + x - 1u] == 0u)) {
                n++;
            }
        }
    }
    return n;
}

static void test_workspace_size_runs(void)
{
    size_t b = 0, full = 0, prev = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size_runs(640, 512, 16384, &b));
    TEST_ASSERT_EQUAL_size_t(139784u, b); // value documented in components.h
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size_runs(640, 512, 24576, &b));
    TEST_ASSERT_EQUAL_size_t(205320u, b); // detector default (detector.h)
    // above the worst case: clamped to vd_components_workspace_size
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(50, 30, &full));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size_runs(50, 30, UINT32_MAX, &b));
    TEST_ASSERT_EQUAL_size_t(full, b);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size_runs(50, 30, 25u * 30u, &b));
    TEST_ASSERT_EQUAL_size_t(full, b);
    for (uint32_t r = 1; r < 100; r++) { // 8 bytes per run
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size_runs(50, 30, r, &b));
        if (r > 1) {
            TEST_ASSERT_EQUAL_size_t(prev + 8u, b);
        }
        prev = b;
    }
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size_runs(50, 30, 0, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size_runs(0, 30, 5, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size_runs(50, VD_MAX_DIM + 1u, 5, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size_runs(50, 30, 5, NULL));
}

// Labels plane >= thr both ways (thresholding labeller with a worst-case
// workspace, and the mask labeller on the materialised mask) and compares.
static void check_thr_case(int u16, uint32_t w, uint32_t h, size_t stride_px, const vd_rect_t *roi, uint16_t thr)
{
    static vd_component_t ref[MAXC];
    for (uint32_t y = 0; y < h; y++) {
        for (uint32_t x = 0; x < w; x++) {
            uint32_t v = u16 ? g_plane16[y * stride_px + x] : g_plane8[y * stride_px + x];
            g_ref_mask[y * stride_px + x] = (v >= thr) ? 255u : 0u;
        }
    }
    vd_rect_t r = {0, 0, (int32_t)w, (int32_t)h};
    if (roi != NULL) {
        r = *roi;
    }
    size_t n_ref = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(g_ref_mask, w, h, stride_px, roi, ref, MAXC, &n_ref));
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size((uint32_t)r.w, (uint32_t)r.h, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    size_t n = 0;
    vd_components_stats_t st;
    memset(&st, 0xAB, sizeof st);
    vd_status_t s;
    if (u16) {
        vd_view_u16_t v = {g_plane16, w, h, stride_px * 2u};
        s = vd_components_label_thr_u16(&v, roi, thr, ws, bytes, g_out, MAXC, &n, &st);
    } else {
        vd_view_u8_t v = {g_plane8, w, h, stride_px};
        s = vd_components_label_thr_u8(&v, roi, (uint8_t)thr, ws, bytes, g_out, MAXC, &n, &st);
    }
    tu_guard_check(0);
    tu_guarded_free(0);
    TEST_ASSERT_EQUAL_INT(VD_OK, s);
    TEST_ASSERT_EQUAL_size_t(n_ref, n);
    assert_same_comps(ref, g_out, n);
    const uint8_t *m0 = g_ref_mask + (size_t)r.y * stride_px + (size_t)r.x;
    uint32_t px = 0;
    for (int32_t y = 0; y < r.h; y++) {
        for (int32_t x = 0; x < r.w; x++) {
            px += m0[(size_t)y * stride_px + (size_t)x] != 0u;
        }
    }
    TEST_ASSERT_EQUAL_UINT32(count_runs(m0, (uint32_t)r.w, (uint32_t)r.h, stride_px), st.runs);
    TEST_ASSERT_EQUAL_UINT32(px, st.pixels);
    TEST_ASSERT_EQUAL_UINT32((uint32_t)r.h, st.rows);
    TEST_ASSERT_EQUAL_UINT32((uint32_t)n, st.labels);
}

static void test_thr_random_vs_mask(void)
{
    static const uint32_t sizes[][2] = {{1, 1}, {1, 9}, {3, 1}, {5, 5}, {7, 3}, {8, 8}, {9, 7}, {13, 4},
                                        {17, 16}, {33, 31}, {64, 48}, {131, 21}};
    // thresholds near the lane top bit and the ends (SWAR compare corner cases)
    static const uint16_t thr16[] = {0, 1, 2, 0x7FFF, 0x8000, 0x8001, 0xFFFE, 0xFFFF, 30315};
    uint32_t seed = 99;
    int cases = 0;
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        for (int rep = 0; rep < 12; rep++) {
            const uint32_t w = sizes[s][0], h = sizes[s][1];
            const size_t stride = w + (tu_rand(&seed) % 4u);
            const uint16_t t16 = thr16[(size_t)rep % (sizeof thr16 / sizeof thr16[0])];
            const uint8_t t8 = (rep < 4) ? (uint8_t)(rep == 0 ? 0u : rep == 1 ? 1u : rep == 2 ? 128u : 255u)
                                         : (uint8_t)(tu_rand(&seed) & 0xFFu);
            for (uint32_t y = 0; y < h; y++) {
                for (size_t x = 0; x < stride; x++) {
                    uint32_t r = tu_rand(&seed);
                    // clustered values around the threshold (runs of equal pixels), plus random ones
                    int near = (r & 3u) != 0u;
                    g_plane8[y * stride + x] = near ? (uint8_t)(t8 + (int)((r >> 8) % 5u) - 2) : (uint8_t)(r >> 16);
                    g_plane16[y * stride + x] =
                        near ? (uint16_t)(t16 + (int)((r >> 8) % 5u) - 2) : (uint16_t)(r >> 16);
                    if (x >= w) { // padding must be ignored
                        g_plane8[y * stride + x] = 0xFFu;
                        g_plane16[y * stride + x] = 0xFFFFu;
                    }
                }
                if ((rep & 1) != 0 && y % 3u == 0u) { // long uniform stretches: the word-at-a-time paths
                    for (uint32_t x = 0; x < w; x++) {
                        g_plane8[y * stride + x] = (uint8_t)((x / 11u) & 1u ? t8 : t8 - 1);
                        g_plane16[y * stride + x] = (uint16_t)((x / 9u) & 1u ? t16 : t16 - 1);
                    }
                }
            }
            vd_rect_t roi = {0, 0, (int32_t)w, (int32_t)h};
            if (rep >= 6) {
                roi.x = (int32_t)(tu_rand(&seed) % w);
                roi.y = (int32_t)(tu_rand(&seed) % h);
                roi.w = 1 + (int32_t)(tu_rand(&seed) % (w - (uint32_t)roi.x));
                roi.h = 1 + (int32_t)(tu_rand(&seed) % (h - (uint32_t)roi.y));
            }
            check_thr_case(0, w, h, stride, rep >= 6 ? &roi : NULL, t8);
            check_thr_case(1, w, h, stride, rep >= 6 ? &roi : NULL, t16);
            cases++;
        }
    }
    TEST_ASSERT_EQUAL_INT(12 * 12, cases);
}

// The streamed row-pair labeller (components_internal.h, contrast.c's) gives
// vd_components_label_thr_u8's result on the whole frame: same components in
// the same order, the first cap of them, every component counted; restart
// starts over; the workspace is checked.
static void check_stream_case(uint32_t w, uint32_t h, uint8_t thr, size_t cap)
{
    static vd_component_t ref[MAXC];
    vd_view_u8_t v = {g_plane8, w, h, w};
    size_t bytes = 0, n_ref = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(w, h, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    vd_components_stats_t st;
    const vd_status_t s_ref = vd_components_label_thr_u8(&v, NULL, thr, ws, bytes, ref, cap, &n_ref, &st);
    tu_guarded_free(0);
    TEST_ASSERT_TRUE(s_ref == VD_OK || s_ref == VD_ERR_CAPACITY);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd__components_stream_workspace_size(w, &bytes));
    ws = tu_guarded_alloc(1, bytes);
    vd__components_stream_t cs;
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd__components_stream_init(&cs, w, ws, bytes - 1u, g_out, cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd__components_stream_init(&cs, w, ws, bytes, g_out, cap));
    for (int pass = 0; pass < 2; pass++) { // the second after a half frame and a restart
        if (pass == 1) {
            for (uint32_t y = 0; y < h / 2u; y += 2u) {
                vd__components_stream_pair(&cs, g_plane8 + (size_t)y * w, y + 1u < h ? g_plane8 + (size_t)(y + 1u) * w : NULL,
                                  y, (uint8_t)(thr ^ 0x55u));
            }
            vd__components_stream_restart(&cs);
        }
        for (uint32_t y = 0; y < h; y += 2u) {
            vd__components_stream_pair(&cs, g_plane8 + (size_t)y * w, y + 1u < h ? g_plane8 + (size_t)(y + 1u) * w : NULL, y,
                              thr);
        }
        const size_t n = vd__components_stream_finish(&cs);
        tu_guard_check(1);
        TEST_ASSERT_EQUAL_size_t(n_ref, n);
        TEST_ASSERT_EQUAL_UINT32(st.labels, cs.labels);
        assert_same_comps(ref, g_out, n);
    }
    tu_guarded_free(1);
}

static void test_stream_vs_whole_frame(void)
{
    static const uint32_t sizes[][2] = {{1, 1}, {1, 9}, {3, 1}, {7, 3}, {9, 7}, {17, 16}, {33, 31}, {131, 21},
                                        {160, 64}};
    uint32_t seed = 7;
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        for (int rep = 0; rep < 8; rep++) {
            const uint32_t w = sizes[s][0], h = sizes[s][1];
            const uint8_t t = (uint8_t)(rep == 0 ? 0u : rep == 1 ? 255u : 1u + (tu_rand(&seed) % 254u));
            for (uint32_t y = 0; y < h; y++) {
                for (uint32_t x = 0; x < w; x++) {
                    const uint32_t r = tu_rand(&seed);
                    // noise near the threshold, or combs (components that join late)
                    g_plane8[y * w + x] = (rep & 2) != 0 ? (uint8_t)(t + (int)((r >> 8) % 5u) - 2)
                                                         : (uint8_t)(((x % 4u) == 0u || y == h - 1u) ? t : t - 1u);
                }
            }
            static const size_t caps[] = {0u, 1u, 3u, MAXC};
            check_stream_case(w, h, t, caps[(size_t)rep % 4u]);
        }
    }
}

// Every 8-bit value against every threshold, in every lane of the 64-bit word.
static void test_thr_u8_every_value_and_threshold(void)
{
    const uint32_t w = 160, h = 16;
    for (uint32_t t = 0; t < 256u; t++) {
        for (uint32_t y = 0; y < h; y++) {
            for (uint32_t x = 0; x < w; x++) {
                g_plane8[y * w + x] = (uint8_t)((x * 37u + y * 16u + (x / 8u) * 3u) & 0xFFu);
            }
        }
        check_thr_case(0, w, h, w, NULL, (uint16_t)t);
    }
}

static void test_thr_run_budget(void)
{
    // 40 x 20 plane; rows alternate between 1 run and 5 runs.
    const uint32_t w = 40, h = 20;
    memset(g_plane8, 10, sizeof g_plane8);
    uint32_t total = 0;
    for (uint32_t y = 0; y < h; y++) {
        uint32_t runs = (y & 1u) ? 5u : 1u;
        for (uint32_t k = 0; k < runs; k++) {
            g_plane8[y * w + 1u + 7u * k] = 200u;
            g_plane8[y * w + 2u + 7u * k] = 201u;
        }
        total += runs;
    }
    TEST_ASSERT_EQUAL_UINT32(60u, total);
    vd_view_u8_t v = {g_plane8, w, h, w};
    static vd_component_t ref[MAXC];
    for (uint32_t budget = 1; budget <= total + 2u; budget++) {
        size_t bytes = 0;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size_runs(w, h, budget, &bytes));
        void *ws = tu_guarded_alloc(0, bytes);
        size_t n = 0;
        vd_components_stats_t st;
        vd_status_t s = vd_components_label_thr_u8(&v, NULL, 150, ws, bytes, g_out, MAXC, &n, &st);
        tu_guard_check(0);
        tu_guarded_free(0);
        // complete pairs of 6 runs fit: rows = 2 * floor(budget / 6)
        const uint32_t rows = budget >= total ? h : 2u * (budget / 6u);
        TEST_ASSERT_EQUAL_INT(rows == h ? VD_OK : VD_ERR_CAPACITY, s);
        TEST_ASSERT_EQUAL_UINT32(rows, st.rows);
        TEST_ASSERT_EQUAL_UINT32(3u * rows, st.runs);
        // the components are those of the crop of the labelled rows
        size_t n_ref = 0;
        if (rows > 0u) {
            for (size_t i = 0; i < (size_t)w * h; i++) {
                g_ref_mask[i] = g_plane8[i] >= 150u ? 255u : 0u;
            }
            vd_rect_t top = {0, 0, (int32_t)w, (int32_t)rows};
            TEST_ASSERT_EQUAL_INT(VD_OK, label_mask(g_ref_mask, w, h, w, &top, ref, MAXC, &n_ref));
        }
        TEST_ASSERT_EQUAL_size_t(n_ref, n);
        TEST_ASSERT_EQUAL_UINT32((uint32_t)n_ref, st.labels);
        assert_same_comps(ref, g_out, n);
    }
    // both capacities at once: stats tell them apart
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size_runs(w, h, 12, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    size_t n = 0;
    vd_components_stats_t st;
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_components_label_thr_u8(&v, NULL, 150, ws, bytes, g_out, 2, &n, &st));
    TEST_ASSERT_EQUAL_size_t(2u, n);
    TEST_ASSERT_EQUAL_UINT32(4u, st.rows);
    TEST_ASSERT_TRUE(st.labels > 2u);
    // a worst-case workspace never runs out: checkerboard
    for (uint32_t y = 0; y < h; y++) {
        for (uint32_t x = 0; x < w; x++) {
            g_plane8[y * w + x] = ((x + y) & 1u) ? 255u : 0u;
        }
    }
    tu_guarded_free(0);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(w, h, &bytes));
    ws = tu_guarded_alloc(0, bytes);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_label_thr_u8(&v, NULL, 1, ws, bytes, g_out, MAXC, &n, &st));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_UINT32(w / 2u * h, st.runs);
    TEST_ASSERT_EQUAL_UINT32(h, st.rows);
    tu_guard_check(0);
    tu_guarded_free(0);
}

typedef struct thr_ctx {
    int u16;
    const vd_rect_t *roi;
} thr_ctx_t;

static vd_status_t run_label_thr(void *ws, size_t bytes, void *ctx)
{
    const thr_ctx_t *c = (const thr_ctx_t *)ctx;
    size_t n;
    if (c->u16) {
        vd_view_u16_t v = {g_plane16, 50, 30, 100};
        return vd_components_label_thr_u16(&v, c->roi, 1000, ws, bytes, g_out, MAXC, &n, NULL);
    }
    vd_view_u8_t v = {g_plane8, 50, 30, 50};
    return vd_components_label_thr_u8(&v, c->roi, 100, ws, bytes, g_out, MAXC, &n, NULL);
}

static void test_thr_workspace_contract(void)
{
    // One hot run: the smallest workspace (budget 1 run) is enough.
    memset(g_plane8, 0, sizeof g_plane8);
    memset(g_plane16, 0, sizeof g_plane16);
    for (uint32_t x = 10; x < 30; x++) {
        g_plane8[12 * 50 + x] = 100u;
        g_plane16[12 * 50 + x] = 1000u;
    }
    vd_rect_t roi = {5, 7, 41, 19};
    for (int u16 = 0; u16 < 2; u16++) {
        thr_ctx_t ctx = {u16, NULL};
        size_t bytes;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size_runs(50, 30, 1, &bytes));
        tu_check_workspace_contract(bytes, run_label_thr, &ctx);
        ctx.roi = &roi;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size_runs(41, 19, 1, &bytes));
        tu_check_workspace_contract(bytes, run_label_thr, &ctx);
    }
}

static void test_thr_bad_arguments(void)
{
    static uint64_t ws[4096];
    vd_view_u8_t v = {g_plane8, 8, 8, 8};
    vd_view_u16_t v16 = {g_plane16, 8, 8, 16};
    size_t n = 77;
    vd_components_stats_t st;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label_thr_u8(NULL, NULL, 1, ws, sizeof ws, g_out, MAXC, &n, &st));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label_thr_u8(&v, NULL, 1, ws, sizeof ws, g_out, MAXC, NULL, &st));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label_thr_u8(&v, NULL, 1, ws, sizeof ws, NULL, 3, &n, &st));
    vd_rect_t out_of = {4, 4, 5, 2};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label_thr_u8(&v, &out_of, 1, ws, sizeof ws, g_out, MAXC, &n, &st));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG,
                          vd_components_label_thr_u16(&v16, &out_of, 1, ws, sizeof ws, g_out, MAXC, &n, &st));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label_thr_u16(NULL, NULL, 1, ws, sizeof ws, g_out, MAXC, &n, &st));
    vd_view_u16_t odd = {g_plane16, 8, 8, 17}; // odd stride for 16-bit
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label_thr_u16(&odd, NULL, 1, ws, sizeof ws, g_out, MAXC, &n, &st));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE,
                          vd_components_label_thr_u8(&v, NULL, 1, NULL, sizeof ws, g_out, MAXC, &n, &st));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_components_label_thr_u16(&v16, NULL, 1, ws, 8, g_out, MAXC, &n, &st));
    vd_view_u8_t odd8 = {g_plane8, 3, 5, 3}; // odd stride is fine for 8-bit
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_label_thr_u8(&odd8, NULL, 1, ws, sizeof ws, g_out, MAXC, &n, NULL));
}

// ---------------------------------------------------------------- rules

static vd_component_t comp_box(int32_t w, int32_t h, uint32_t area)
{
    vd_component_t c;
    memset(&c, 0, sizeof c);
    c.box.w = w;
    c.box.h = h;
    c.area = area;
    return c;
}

static size_t filter_one(vd_component_t c, const vd_components_rules_t *r)
{
    size_t kept = 99;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_filter(&c, 1, r, &kept));
    return kept;
}

static void test_rules_default_and_boundaries(void)
{
    vd_components_rules_t r;
    memset(&r, 0xFF, sizeof r);
    vd_components_rules_default(&r);
    TEST_ASSERT_EQUAL_UINT16(77, r.aspect_min_q8);
    TEST_ASSERT_EQUAL_UINT16(384, r.aspect_max_q8);
    TEST_ASSERT_EQUAL_UINT32(120, r.min_area);
    TEST_ASSERT_EQUAL_UINT32(0, r.max_area);
    vd_components_rules_default(NULL); // no crash
    // aspect h/w = 0.3 exactly (76.8 -> 77) and 1.5 exactly (384) pass
    TEST_ASSERT_EQUAL_size_t(1u, filter_one(comp_box(10, 3, 500), &r));
    TEST_ASSERT_EQUAL_size_t(1u, filter_one(comp_box(20, 30, 500), &r));
    // Q8 boundaries: 77/256 passes, 76/256 fails; 384/256 passes, 385/256 fails
    TEST_ASSERT_EQUAL_size_t(1u, filter_one(comp_box(256, 77, 500), &r));
    TEST_ASSERT_EQUAL_size_t(0u, filter_one(comp_box(256, 76, 500), &r));
    TEST_ASSERT_EQUAL_size_t(1u, filter_one(comp_box(256, 384, 500), &r));
    TEST_ASSERT_EQUAL_size_t(0u, filter_one(comp_box(256, 385, 500), &r));
    // rounding half up: 256 * 153 / 512 = 76.5 -> 77 passes; 76.49.. fails
    TEST_ASSERT_EQUAL_size_t(1u, filter_one(comp_box(512, 153, 500), &r));
    TEST_ASSERT_EQUAL_size_t(0u, filter_one(comp_box(513, 153, 500), &r));
    // 256 * 769 / 512 = 384.5 -> 385 fails; 384.25 -> 384 passes
    TEST_ASSERT_EQUAL_size_t(0u, filter_one(comp_box(512, 769, 500), &r));
    TEST_ASSERT_EQUAL_size_t(1u, filter_one(comp_box(1024, 1537, 500), &r));
    // area exactly 120 passes, 119 fails
    TEST_ASSERT_EQUAL_size_t(1u, filter_one(comp_box(20, 20, 120), &r));
    TEST_ASSERT_EQUAL_size_t(0u, filter_one(comp_box(20, 20, 119), &r));
    // max_area inclusive
    r.max_area = 400;
    TEST_ASSERT_EQUAL_size_t(1u, filter_one(comp_box(20, 20, 400), &r));
    TEST_ASSERT_EQUAL_size_t(0u, filter_one(comp_box(20, 20, 401), &r));
    // configurable aspect
    r.aspect_min_q8 = 256;
    r.aspect_max_q8 = 256;
    TEST_ASSERT_EQUAL_size_t(1u, filter_one(comp_box(20, 20, 200), &r));
    TEST_ASSERT_EQUAL_size_t(0u, filter_one(comp_box(20, 21, 200), &r));
}

static void test_filter_stable_and_errors(void)
{
    vd_components_rules_t r;
    vd_components_rules_default(&r);
    vd_component_t c[6] = {comp_box(10, 10, 50), comp_box(10, 10, 150), comp_box(100, 10, 900),
                           comp_box(12, 12, 140), comp_box(5, 50, 200), comp_box(16, 16, 256)};
    for (int i = 0; i < 6; i++) { c[i].box.x = i; }
    size_t kept = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_filter(c, 6, &r, &kept));
    TEST_ASSERT_EQUAL_size_t(3u, kept);
    TEST_ASSERT_EQUAL_INT32(1, c[0].box.x);
    TEST_ASSERT_EQUAL_INT32(3, c[1].box.x);
    TEST_ASSERT_EQUAL_INT32(5, c[2].box.x);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_filter(NULL, 0, &r, &kept));
    TEST_ASSERT_EQUAL_size_t(0u, kept);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_filter(NULL, 2, &r, &kept));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_filter(c, 2, NULL, &kept));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_filter(c, 2, &r, NULL));
    vd_component_t bad[2] = {comp_box(10, 10, 200), comp_box(0, 10, 200)};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_filter(bad, 2, &r, &kept));
    TEST_ASSERT_EQUAL_size_t(0u, kept);
    TEST_ASSERT_EQUAL_INT32(10, bad[0].box.w); // untouched
    vd_components_rules_t inv = r;
    inv.aspect_min_q8 = 400;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_filter(c, 2, &inv, &kept));
    inv = r;
    inv.max_area = 100; // below min_area 120
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_filter(c, 2, &inv, &kept));
}

static void test_rules_resolve(void)
{
    vd_components_rules_t r;
    vd_components_rules_t d;
    vd_components_rules_default(&d);
    memset(&r, 0, sizeof(r));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_rules_resolve(&r));
    TEST_ASSERT_EQUAL_MEMORY(&d, &r, sizeof(r));
    TEST_ASSERT_EQUAL_UINT16(77u, r.aspect_min_q8);
    TEST_ASSERT_EQUAL_UINT16(384u, r.aspect_max_q8);
    TEST_ASSERT_EQUAL_UINT32(120u, r.min_area);
    TEST_ASSERT_EQUAL_UINT32(0u, r.max_area);
    // Any non-zero field: kept as given (no partial defaults).
    memset(&r, 0, sizeof(r));
    r.min_area = 50u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_rules_resolve(&r));
    TEST_ASSERT_EQUAL_UINT16(0u, r.aspect_min_q8);
    TEST_ASSERT_EQUAL_UINT16(0u, r.aspect_max_q8);
    TEST_ASSERT_EQUAL_UINT32(50u, r.min_area);
    r.aspect_min_q8 = 300u;
    r.aspect_max_q8 = 299u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_rules_resolve(&r));
    r.aspect_max_q8 = 300u;
    r.max_area = 49u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_rules_resolve(&r));
    r.max_area = 50u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_rules_resolve(&r));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_rules_resolve(NULL));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_workspace_size);
    RUN_TEST(test_single_pixel_and_empty);
    RUN_TEST(test_full_image);
    RUN_TEST(test_diagonal_only_connectivity);
    RUN_TEST(test_checkerboard_is_one_component);
    RUN_TEST(test_u_shapes_merge_late);
    RUN_TEST(test_block_order_not_pixel_order);
    RUN_TEST(test_spiral);
    RUN_TEST(test_centroid_round_half_up);
    RUN_TEST(test_roi_and_stride);
    RUN_TEST(test_random_vs_naive);
    RUN_TEST(test_capacity);
    RUN_TEST(test_workspace_contract);
    RUN_TEST(test_bad_arguments);
    RUN_TEST(test_workspace_size_runs);
    RUN_TEST(test_thr_random_vs_mask);
    RUN_TEST(test_thr_u8_every_value_and_threshold);
    RUN_TEST(test_stream_vs_whole_frame);
    RUN_TEST(test_thr_run_budget);
    RUN_TEST(test_thr_workspace_contract);
    RUN_TEST(test_thr_bad_arguments);
    RUN_TEST(test_rules_default_and_boundaries);
    RUN_TEST(test_filter_stable_and_errors);
    RUN_TEST(test_rules_resolve);
    return UNITY_END();
}
