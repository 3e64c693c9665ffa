// SPDX-License-Identifier: MIT
// Unit tests of outer-contour tracing: hand-worked shapes, order, capacity,
// workspace contract, bad arguments, invariants on random masks.
#include "unity.h"
#include "testutil.h"

#include <string.h>

void setUp(void) {}
void tearDown(void) {}

#define MAXW 32
#define MAXH 32
#define PCAP 4096
#define CCAP 256

static uint8_t g_mask[MAXW * MAXH];
static uint64_t g_ws[((MAXW + 2) * (MAXH + 2) + 7) / 8];
static vd_point_t g_pts[PCAP];
static uint8_t g_chain[PCAP];
static vd_contour_t g_cs[CCAP];
static size_t g_nc, g_np;

static vd_status_t find(uint32_t w, uint32_t h, size_t pcap, size_t ccap)
{
    vd_view_u8_t v = {g_mask, w, h, w};
    memset(g_pts, 0x55, sizeof g_pts);
    memset(g_chain, 0x55, sizeof g_chain);
    return vd_contour_find_external(&v, g_ws, sizeof g_ws, g_pts, g_chain, pcap, g_cs, ccap, &g_nc, &g_np);
}

static void set(uint32_t w, int x, int y)
{
    g_mask[(size_t)y * w + (size_t)x] = 255u;
}

static void expect_contour(size_t idx, const int (*xy)[2], const uint8_t *codes, size_t n)
{
    TEST_ASSERT_TRUE(idx < g_nc);
    TEST_ASSERT_EQUAL_UINT32(n, g_cs[idx].length);
    for (size_t i = 0; i < n; i++) {
        const size_t k = g_cs[idx].first + i;
        TEST_ASSERT_EQUAL_INT(xy[i][0], g_pts[k].x);
        TEST_ASSERT_EQUAL_INT(xy[i][1], g_pts[k].y);
        TEST_ASSERT_EQUAL_UINT8(codes[i], g_chain[k]);
    }
}

static void test_square_3x3(void)
{
    memset(g_mask, 0, sizeof g_mask);
    for (int y = 1; y <= 3; y++) {
        for (int x = 1; x <= 3; x++) {
            set(5, x, y);
        }
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, find(5, 5, PCAP, CCAP));
    TEST_ASSERT_EQUAL_size_t(1, g_nc);
    TEST_ASSERT_EQUAL_size_t(8, g_np);
    // Down the left side, along the bottom, up the right, back along the top.
    static const int xy[8][2] = {{1, 1}, {1, 2}, {1, 3}, {2, 3}, {3, 3}, {3, 2}, {3, 1}, {2, 1}};
    static const uint8_t codes[8] = {6, 6, 0, 0, 2, 2, 4, 4};
    expect_contour(0, xy, codes, 8);
    TEST_ASSERT_EQUAL_INT32(1, g_cs[0].box.x);
    TEST_ASSERT_EQUAL_INT32(1, g_cs[0].box.y);
    TEST_ASSERT_EQUAL_INT32(3, g_cs[0].box.w);
    TEST_ASSERT_EQUAL_INT32(3, g_cs[0].box.h);
}

static void test_l_shape(void)
{
    // x=1, y=1..4 and y=4, x=2..3: the foot is walked out and back.
    memset(g_mask, 0, sizeof g_mask);
    for (int y = 1; y <= 4; y++) {
        set(6, 1, y);
    }
    set(6, 2, 4);
    set(6, 3, 4);
    TEST_ASSERT_EQUAL_INT(VD_OK, find(6, 6, PCAP, CCAP));
    TEST_ASSERT_EQUAL_size_t(1, g_nc);
    static const int xy[9][2] = {{1, 1}, {1, 2}, {1, 3}, {1, 4}, {2, 4}, {3, 4}, {2, 4}, {1, 3}, {1, 2}};
    static const uint8_t codes[9] = {6, 6, 6, 0, 0, 4, 3, 2, 2};
    expect_contour(0, xy, codes, 9);
    TEST_ASSERT_EQUAL_INT32(3, g_cs[0].box.w);
    TEST_ASSERT_EQUAL_INT32(4, g_cs[0].box.h);
}

static void test_diagonal_line(void)
{
    memset(g_mask, 0, sizeof g_mask);
    set(5, 1, 1);
    set(5, 2, 2);
    set(5, 3, 3);
    TEST_ASSERT_EQUAL_INT(VD_OK, find(5, 5, PCAP, CCAP));
    static const int xy[4][2] = {{1, 1}, {2, 2}, {3, 3}, {2, 2}};
    static const uint8_t codes[4] = {7, 7, 3, 3};
    expect_contour(0, xy, codes, 4);
}

static void test_single_pixel_and_order(void)
{
    // Two regions: cv2 lists the one found last in raster order first.
    memset(g_mask, 0, sizeof g_mask);
    set(7, 5, 1);
    set(7, 1, 4);
    set(7, 2, 4);
    TEST_ASSERT_EQUAL_INT(VD_OK, find(7, 6, PCAP, CCAP));
    TEST_ASSERT_EQUAL_size_t(2, g_nc);
    TEST_ASSERT_EQUAL_size_t(3, g_np);
    static const int line[2][2] = {{1, 4}, {2, 4}};
    static const uint8_t line_codes[2] = {0, 4};
    expect_contour(0, line, line_codes, 2);
    static const int dot[1][2] = {{5, 1}};
    static const uint8_t dot_codes[1] = {VD_CONTOUR_CHAIN_NONE};
    expect_contour(1, dot, dot_codes, 1);
    TEST_ASSERT_EQUAL_UINT32(0, g_cs[0].first);
    TEST_ASSERT_EQUAL_UINT32(2, g_cs[1].first);
}

static void test_ring_hides_hole_and_inner_region(void)
{
    memset(g_mask, 0, sizeof g_mask);
    for (int y = 1; y <= 5; y++) {
        for (int x = 1; x <= 5; x++) {
            if (x == 1 || x == 5 || y == 1 || y == 5 || (x == 3 && y == 3)) {
                set(7, x, y);
            }
        }
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, find(7, 7, PCAP, CCAP));
    TEST_ASSERT_EQUAL_size_t(1, g_nc);
    TEST_ASSERT_EQUAL_size_t(16, g_np);
    TEST_ASSERT_EQUAL_INT32(5, g_cs[0].box.w);
}

static void test_touches_border(void)
{
    memset(g_mask, 255, 4 * 3);
    TEST_ASSERT_EQUAL_INT(VD_OK, find(4, 3, PCAP, CCAP));
    TEST_ASSERT_EQUAL_size_t(1, g_nc);
    static const int xy[10][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 2}, {2, 2}, {3, 2}, {3, 1}, {3, 0}, {2, 0}, {1, 0}};
    static const uint8_t codes[10] = {6, 6, 0, 0, 0, 2, 2, 4, 4, 4};
    expect_contour(0, xy, codes, 10);
}

static void test_capacity(void)
{
    memset(g_mask, 0, sizeof g_mask);
    set(7, 1, 1);             // found first in raster order
    set(7, 4, 3);
    set(7, 5, 3);             // found second
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, find(7, 6, PCAP, 1));
    TEST_ASSERT_EQUAL_size_t(1, g_nc);
    TEST_ASSERT_EQUAL_size_t(1, g_np);
    TEST_ASSERT_EQUAL_INT(1, g_pts[0].x);
    // Points: the second contour (2 points) does not fit in 2 slots after the first.
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, find(7, 6, 2, CCAP));
    TEST_ASSERT_EQUAL_size_t(1, g_nc);
    TEST_ASSERT_EQUAL_size_t(1, g_np);
    TEST_ASSERT_EQUAL_INT(VD_OK, find(7, 6, 3, 2));
    TEST_ASSERT_EQUAL_size_t(2, g_nc);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, find(7, 6, 0, 0));
    TEST_ASSERT_EQUAL_size_t(0, g_nc);
    memset(g_mask, 0, sizeof g_mask);
    TEST_ASSERT_EQUAL_INT(VD_OK, find(7, 6, 0, 0));   // nothing to report
}

typedef struct ws_ctx {
    const vd_view_u8_t *v;
} ws_ctx_t;

static vd_status_t run_ws(void *ws, size_t bytes, void *ctx)
{
    const ws_ctx_t *c = (const ws_ctx_t *)ctx;
    return vd_contour_find_external(c->v, ws, bytes, g_pts, NULL, PCAP, g_cs, CCAP, &g_nc, &g_np);
}

static void test_workspace_contract(void)
{
    uint32_t st = 7u;
    for (size_t i = 0; i < 13u * 9u; i++) {
        g_mask[i] = (tu_rand(&st) & 3u) == 0u ? 255u : 0u;
    }
    vd_view_u8_t v = {g_mask, 13, 9, 13};
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contour_workspace_size(13, 9, &bytes));
    TEST_ASSERT_EQUAL_size_t(15u * 11u, bytes);
    ws_ctx_t c = {&v};
    tu_check_workspace_contract(bytes, run_ws, &c);
}

static void test_bad_args(void)
{
    size_t bytes;
    vd_view_u8_t v = {g_mask, 5, 5, 5};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contour_workspace_size(0, 5, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contour_workspace_size(5, VD_MAX_DIM + 1u, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contour_workspace_size(5, 5, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contour_find_external(NULL, g_ws, sizeof g_ws, g_pts, NULL, PCAP, g_cs,
                                                                CCAP, &g_nc, &g_np));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contour_find_external(&v, g_ws, sizeof g_ws, NULL, NULL, PCAP, g_cs,
                                                                CCAP, &g_nc, &g_np));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contour_find_external(&v, g_ws, sizeof g_ws, g_pts, NULL, PCAP, NULL,
                                                                CCAP, &g_nc, &g_np));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contour_find_external(&v, g_ws, sizeof g_ws, g_pts, NULL, PCAP, g_cs,
                                                                CCAP, NULL, &g_np));
    g_np = 99;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contour_find_external(&v, g_ws, sizeof g_ws, g_pts, NULL, PCAP, g_cs,
                                                                CCAP, &g_nc, NULL));
    v.stride = 4;   // stride < width
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contour_find_external(&v, g_ws, sizeof g_ws, g_pts, NULL, PCAP, g_cs,
                                                                CCAP, &g_nc, &g_np));
    TEST_ASSERT_EQUAL_size_t(0, g_nc);
    TEST_ASSERT_EQUAL_size_t(0, g_np);
    v.stride = 7;   // odd stride is fine
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contour_find_external(&v, g_ws, sizeof g_ws, g_pts, NULL, PCAP, g_cs, CCAP,
                                                           &g_nc, &g_np));
}

// Invariants on random masks: every point is foreground, consecutive points
// follow the chain code (cyclically), boxes hold their points, the number of
// contours never exceeds the 8-connected regions, and all points < 4*w*h.
static void test_random_invariants(void)
{
    uint32_t st = 12345u;
    for (int iter = 0; iter < 300; iter++) {
        const uint32_t w = 1u + tu_rand(&st) % MAXW;
        const uint32_t h = 1u + tu_rand(&st) % MAXH;
        const uint32_t dens = tu_rand(&st) % 8u;
        for (size_t i = 0; i < (size_t)w * h; i++) {
            g_mask[i] = (tu_rand(&st) % 8u) < dens ? (uint8_t)(1u + tu_rand(&st) % 255u) : 0u;
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, find(w, h, PCAP, CCAP));
        TEST_ASSERT_TRUE(g_np <= 4u * w * h);
        size_t total = 0;
        for (size_t c = 0; c < g_nc; c++) {
            const vd_contour_t *k = &g_cs[c];
            TEST_ASSERT_TRUE(k->length >= 1u);
            total += k->length;
            for (uint32_t i = 0; i < k->length; i++) {
                const vd_point_t p = g_pts[k->first + i];
                TEST_ASSERT_TRUE(p.x >= 0 && p.y >= 0 && (uint32_t)p.x < w && (uint32_t)p.y < h);
                TEST_ASSERT_TRUE(g_mask[(size_t)p.y * w + (size_t)p.x] != 0u);
                TEST_ASSERT_TRUE(p.x >= k->box.x && p.x < k->box.x + k->box.w);
                TEST_ASSERT_TRUE(p.y >= k->box.y && p.y < k->box.y + k->box.h);
                const uint8_t code = g_chain[k->first + i];
                if (k->length == 1u) {
                    TEST_ASSERT_EQUAL_UINT8(VD_CONTOUR_CHAIN_NONE, code);
                    continue;
                }
                static const int dx[8] = {1, 1, 0, -1, -1, -1, 0, 1};
                static const int dy[8] = {0, -1, -1, -1, 0, 1, 1, 1};
                TEST_ASSERT_TRUE(code < 8u);
                const vd_point_t q = g_pts[k->first + (i + 1u) % k->length];
                TEST_ASSERT_EQUAL_INT(p.x + dx[code], q.x);
                TEST_ASSERT_EQUAL_INT(p.y + dy[code], q.y);
            }
        }
        TEST_ASSERT_EQUAL_size_t(g_np, total);
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_square_3x3);
    RUN_TEST(test_l_shape);
    RUN_TEST(test_diagonal_line);
    RUN_TEST(test_single_pixel_and_order);
    RUN_TEST(test_ring_hides_hole_and_inner_region);
    RUN_TEST(test_touches_border);
    RUN_TEST(test_capacity);
    RUN_TEST(test_workspace_contract);
    RUN_TEST(test_bad_args);
    RUN_TEST(test_random_invariants);
    return UNITY_END();
}
