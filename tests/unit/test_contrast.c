// SPDX-License-Identifier: MIT
// Unit tests of contrast.h: a hand-worked map, a naive box-mean reference on random frames (odd strides),
// warm and cold candidates, percentile threshold, the row-strip candidates against the whole-frame
// computation (map, threshold, vd_components_label, rules), workspace contract and argument checks.
#include "unity.h"
#include "testutil.h"

#include <string.h>

void setUp(void) {}
void tearDown(void) {}

#define MAXPX (135 * 260)

static uint8_t g_src[MAXPX + 64];
static uint8_t g_dst[MAXPX];
static uint8_t g_ref[MAXPX];
static vd_component_t g_comps[256];

static void test_map_hand_worked(void)
{
    uint8_t px[25];
    memset(px, 10, sizeof(px));
    px[12] = 100;   // centre of 5 x 5
    vd_view_u8_t v = {px, 5, 5, 5};
    uint8_t out[25];
    vd_image_u8_t d = {out, 5, 5, 5};
    // uint64_t storage: a workspace must be VD_WORKSPACE_ALIGN (8) aligned, and a uint32_t
    // array is only 4-aligned on 32-bit targets (armhf: VD_ERR_WORKSPACE).
    uint64_t col[3];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_map_u8(&v, 1u, VD_CONTRAST_BOTH, col, sizeof(col), &d));
    TEST_ASSERT_EQUAL_UINT8(80, out[12]);   // mean (8*10 + 100)/9 = 20
    TEST_ASSERT_EQUAL_UINT8(10, out[6]);    // (1,1): its 3x3 holds the centre -> mean 20
    TEST_ASSERT_EQUAL_UINT8(0, out[0]);     // corner: 2x2 of 10
    TEST_ASSERT_EQUAL_UINT8(0, out[5]);     // (0,1): 2 cols x 3 rows of 10
    // (1,0): cols 0..2, rows 0..1 = 6 pixels of 10 -> 0; (2,1): 3x3 with the centre -> 10.
    TEST_ASSERT_EQUAL_UINT8(0, out[1]);
    TEST_ASSERT_EQUAL_UINT8(10, out[7]);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_map_u8(&v, 1u, VD_CONTRAST_WARM, col, sizeof(col), &d));
    TEST_ASSERT_EQUAL_UINT8(80, out[12]);
    TEST_ASSERT_EQUAL_UINT8(0, out[6]);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_map_u8(&v, 1u, VD_CONTRAST_COLD, col, sizeof(col), &d));
    TEST_ASSERT_EQUAL_UINT8(0, out[12]);
    TEST_ASSERT_EQUAL_UINT8(10, out[6]);
    // Radius larger than the frame: one mean over everything ((340 + 12) / 25 = 14).
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_map_u8(&v, 9u, VD_CONTRAST_BOTH, col, sizeof(col), &d));
    TEST_ASSERT_EQUAL_UINT8(86, out[12]);
    TEST_ASSERT_EQUAL_UINT8(4, out[0]);
}

// Naive reference: the clipped box mean summed pixel by pixel.
static void naive_map(const uint8_t *s, uint32_t w, uint32_t h, size_t stride, uint32_t r, uint8_t pol, uint8_t *o)
{
    for (uint32_t y = 0; y < h; y++) {
        for (uint32_t x = 0; x < w; x++) {
            uint32_t sum = 0, n = 0;
            for (int32_t yy = (int32_t)y - (int32_t)r; yy <= (int32_t)(y + r); yy++) {
                for (int32_t xx = (int32_t)x - (int32_t)r; xx <= (int32_t)(x + r); xx++) {
                    if (yy >= 0 && xx >= 0 && yy < (int32_t)h && xx < (int32_t)w) {
                        sum += s[(size_t)yy * stride + (size_t)xx];
                        n++;
                    }
                }
            }
            int32_t mean = (int32_t)((sum + n / 2u) / n);
            int32_t d = (int32_t)s[y * stride + x] - mean;
            if (pol == VD_CONTRAST_COLD) { d = -d; }
            if (pol == VD_CONTRAST_BOTH && d < 0) { d = -d; }
            o[y * w + x] = (uint8_t)(d > 0 ? d : 0);
        }
    }
}

static void test_map_random_vs_naive(void)
{
    uint32_t seed = 777u;
    uint64_t col[65];   // 130 column sums, 8-aligned
    for (int it = 0; it < 60; it++) {
        uint32_t w = 1u + tu_rand(&seed) % 60u;
        uint32_t h = 1u + tu_rand(&seed) % 50u;
        size_t stride = w + tu_rand(&seed) % 7u;   // odd strides too
        uint32_t r = 1u + tu_rand(&seed) % 20u;
        uint8_t pol = (uint8_t)(tu_rand(&seed) % 3u);
        bool smooth = (tu_rand(&seed) % 2u) != 0u;
        for (size_t i = 0; i < stride * h; i++) {
            g_src[i] = smooth ? (uint8_t)(100u + tu_rand(&seed) % 40u) : (uint8_t)tu_rand(&seed);
        }
        naive_map(g_src, w, h, stride, r, pol, g_ref);
        vd_view_u8_t v = {g_src, w, h, stride};
        vd_image_u8_t d = {g_dst, w, h, w};
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_map_u8(&v, r, pol, col, w * sizeof(uint32_t), &d));
        TEST_ASSERT_EQUAL_MEMORY(g_ref, g_dst, (size_t)w * h);
    }
}

// Reference through an integral image (exact, independent of the running
// sums), fast enough for radii up to VD_CONTRAST_MAX_RADIUS.
static uint32_t g_ii[(131u * 111u) > (41u * 261u) ? 131u * 111u : 41u * 261u];

static void integral_map(const uint8_t *s, uint32_t w, uint32_t h, size_t stride, uint32_t r, uint8_t pol, uint8_t *o)
{
    const uint32_t iw = w + 1u;
    for (uint32_t x = 0; x <= w; x++) {
        g_ii[x] = 0u;
    }
    for (uint32_t y = 0; y < h; y++) {
        uint32_t row = 0u;
        g_ii[(y + 1u) * iw] = 0u;
        for (uint32_t x = 0; x < w; x++) {
            row += s[(size_t)y * stride + x];
            g_ii[(y + 1u) * iw + x + 1u] = g_ii[y * iw + x + 1u] + row;
        }
    }
    for (uint32_t y = 0; y < h; y++) {
        const uint32_t y0 = y > r ? y - r : 0u, y1 = y + r < h - 1u ? y + r : h - 1u;
        for (uint32_t x = 0; x < w; x++) {
            const uint32_t x0 = x > r ? x - r : 0u, x1 = x + r < w - 1u ? x + r : w - 1u;
            const uint32_t sum = g_ii[(y1 + 1u) * iw + x1 + 1u] - g_ii[y0 * iw + x1 + 1u] - g_ii[(y1 + 1u) * iw + x0] +
                                 g_ii[y0 * iw + x0];
            const uint32_t n = (x1 - x0 + 1u) * (y1 - y0 + 1u);
            int32_t d = (int32_t)s[(size_t)y * stride + x] - (int32_t)((sum + n / 2u) / n);
            if (pol == VD_CONTRAST_COLD) { d = -d; }
            if (pol == VD_CONTRAST_BOTH && d < 0) { d = -d; }
            o[y * w + x] = (uint8_t)(d > 0 ? d : 0);
        }
    }
}

// Wide frames (interior chunks of 64 pixels and their tails), every radius
// up to 127 (tabled border reciprocals up to r = 32, divisions beyond), frames
// narrower than the box, and the extremes: all 255 with 255-row boxes (the
// largest column sum, 255 * 255, and area, 255^2).
static void test_map_wide_and_extreme_vs_integral(void)
{
    uint32_t seed = 4321u;
    uint64_t col[70];   // up to 140 column sums
    for (int it = 0; it < 80; it++) {
        uint32_t w, h, r;
        if (it < 6) {            // tall extremes: 40 x 260, r = 127 and 120
            w = 40u;
            h = 260u;
            r = it < 3 ? 127u : 120u;
        } else {
            w = 60u + tu_rand(&seed) % 71u;   // 60 .. 130
            h = 1u + tu_rand(&seed) % 110u;
            r = it % 3 == 0 ? 1u + tu_rand(&seed) % 127u : 1u + tu_rand(&seed) % 40u;
        }
        const size_t stride = w + (size_t)(it % 5);
        const uint8_t pol = (uint8_t)(it % 3);
        const uint32_t kind = (uint32_t)it % 4u;
        for (size_t i = 0; i < stride * h; i++) {
            const uint32_t v = tu_rand(&seed);
            g_src[i] = it < 6 ? (uint8_t)(it % 2 == 0 ? 255u : (v & 1u) * 255u)
                              : (kind == 0u ? (uint8_t)v : kind == 1u ? (uint8_t)(250u + v % 6u)
                                 : kind == 2u ? (uint8_t)((v & 1u) * 255u) : (uint8_t)(v % 3u));
        }
        integral_map(g_src, w, h, stride, r, pol, g_ref);
        vd_view_u8_t v = {g_src, w, h, stride};
        vd_image_u8_t d = {g_dst, w, h, w};
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_map_u8(&v, r, pol, col, w * sizeof(uint32_t), &d));
        TEST_ASSERT_EQUAL_MEMORY(g_ref, g_dst, (size_t)w * h);
    }
}

// A 64 x 64 frame of 50 with one 20 x 14 rectangle of `value` at (20, 25).
static void rect_frame(uint8_t value)
{
    memset(g_src, 50, 64u * 64u);
    for (uint32_t y = 25; y < 39; y++) {
        memset(g_src + y * 64u + 20u, value, 20u);
    }
}

static vd_status_t run_cand(const vd_contrast_cfg_t *cfg, size_t cap, size_t *n, uint8_t *thr)
{
    vd_view_u8_t v = {g_src, 64, 64, 64};
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_workspace_size(64, 64, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    vd_status_t st = vd_contrast_candidates(&v, cfg, ws, bytes, g_comps, cap, n, thr);
    tu_guard_check(0);
    tu_guarded_free(0);
    return st;
}

static void test_candidates_cold_and_warm(void)
{
    size_t n = 0;
    uint8_t thr = 0;
    rect_frame(10);   // cold: 40 below the road
    TEST_ASSERT_EQUAL_INT(VD_OK, run_cand(NULL, 256, &n, &thr));
    TEST_ASSERT_EQUAL_UINT8(24, thr);
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_INT32(20, g_comps[0].box.x);
    TEST_ASSERT_EQUAL_INT32(25, g_comps[0].box.y);
    TEST_ASSERT_EQUAL_INT32(20, g_comps[0].box.w);
    TEST_ASSERT_EQUAL_INT32(14, g_comps[0].box.h);
    TEST_ASSERT_EQUAL_UINT32(280u, g_comps[0].area);
    vd_contrast_cfg_t c;
    memset(&c, 0, sizeof(c));
    c.polarity = VD_CONTRAST_WARM;   // a cold region has no warm contrast
    TEST_ASSERT_EQUAL_INT(VD_OK, run_cand(&c, 256, &n, NULL));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    rect_frame(90);   // warm
    TEST_ASSERT_EQUAL_INT(VD_OK, run_cand(&c, 256, &n, NULL));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_INT32(20, g_comps[0].box.x);
    TEST_ASSERT_EQUAL_INT32(14, g_comps[0].box.h);
    // Rules: min_area above the rectangle removes it.
    c.rules.aspect_min_q8 = 77u;
    c.rules.aspect_max_q8 = 384u;
    c.rules.min_area = 281u;
    TEST_ASSERT_EQUAL_INT(VD_OK, run_cand(&c, 256, &n, NULL));
    TEST_ASSERT_EQUAL_size_t(0u, n);
}

static void test_candidates_percentile_and_capacity(void)
{
    rect_frame(10);
    vd_contrast_cfg_t c;
    memset(&c, 0, sizeof(c));
    c.thr_mode = VD_CONTRAST_THR_PERCENTILE;
    c.permille = 1000u;   // the largest contrast in the map
    size_t n = 0;
    uint8_t thr = 0;
    vd_status_t st = run_cand(&c, 256, &n, &thr);
    TEST_ASSERT_EQUAL_INT(VD_OK, st);
    // The reference map's maximum.
    uint64_t col[32];   // 64 column sums, 8-aligned
    vd_view_u8_t v = {g_src, 64, 64, 64};
    vd_image_u8_t d = {g_dst, 64, 64, 64};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_map_u8(&v, 16u, VD_CONTRAST_BOTH, col, sizeof(col), &d));
    uint8_t mx = 0;
    for (size_t i = 0; i < 64u * 64u; i++) {
        mx = g_dst[i] > mx ? g_dst[i] : mx;
    }
    TEST_ASSERT_EQUAL_UINT8(mx, thr);
    // Two rectangles: labelling finds a 5-px fleck in the corner (its clipped box holds much of the
    // second rectangle), the second rectangle, then the first. cap 2 -> VD_ERR_CAPACITY; the rules
    // then drop the fleck, leaving the second rectangle.
    rect_frame(10);
    for (uint32_t y = 2; y < 14; y++) {
        memset(g_src + y * 64u + 2u, 10, 16u);
    }
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, run_cand(NULL, 2, &n, NULL));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_INT32(2, g_comps[0].box.y);
    TEST_ASSERT_EQUAL_INT(VD_OK, run_cand(NULL, 256, &n, NULL));
    TEST_ASSERT_EQUAL_size_t(2u, n);
}

// The whole-frame computation the strips replaced: the map of the frame,
// the threshold (fixed or percentile), vd_components_label on the mask, the
// rules. Returns its status; *n, *thr as vd_contrast_candidates.
#define CAND_CAP 4096u
static vd_component_t g_ref_comps[CAND_CAP];
static vd_component_t g_new_comps[CAND_CAP];
static uint64_t g_cc_ws[144000u / 8u];     // vd_components_workspace_size(260, 135) = 143 800
static uint64_t g_strip_ws[21000u / 8u];   // vd_contrast_workspace_size(260, 135) = 20 784

static vd_status_t whole_frame_candidates(const vd_view_u8_t *v, const vd_contrast_cfg_t *cfg, size_t cap,
                                          size_t *n, uint8_t *thr)
{
    vd_contrast_cfg_t c = *cfg;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_cfg_resolve(&c));
    const uint32_t w = v->width;
    const uint32_t h = v->height;
    uint64_t col[(VD_MAX_DIM * 4u) / 8u];
    vd_image_u8_t m = {g_ref, w, h, w};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_map_u8(v, c.radius, c.polarity, col, sizeof(col), &m));
    uint32_t t = c.thr_u8;
    if (c.thr_mode == VD_CONTRAST_THR_PERCENTILE) {
        uint32_t hist[256];
        memset(hist, 0, sizeof(hist));
        for (size_t i = 0; i < (size_t)w * h; i++) {
            hist[g_ref[i]]++;
        }
        uint8_t t8 = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_percentile_u8(hist, c.permille, (uint8_t)t, &t8));
        t = t8;
    }
    *thr = (uint8_t)t;
    for (size_t i = 0; i < (size_t)w * h; i++) {
        g_ref[i] = g_ref[i] >= t ? 255u : 0u;
    }
    size_t ccb = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(w, h, &ccb));
    TEST_ASSERT_TRUE(ccb <= sizeof(g_cc_ws));
    vd_view_u8_t mv = {g_ref, w, h, w};
    size_t nl = 0u;
    vd_status_t st = vd_components_label(&mv, NULL, g_cc_ws, ccb, g_ref_comps, cap, &nl);
    TEST_ASSERT_TRUE(st == VD_OK || st == VD_ERR_CAPACITY);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_filter(g_ref_comps, nl, &c.rules, n));
    return st;
}

// Frame content: 0 noise (many tiny components, merges everywhere), 1 smooth
// with random rectangles, 2 combs and spirals of lines (components that are
// two until a lower row joins them), 3 a constant frame with rare dots.
static void fill_frame(uint32_t w, uint32_t h, size_t stride, uint32_t kind, uint32_t *seed)
{
    for (size_t i = 0; i < stride * h; i++) {
        g_src[i] = kind == 0u ? (uint8_t)tu_rand(seed) : (uint8_t)(100u + tu_rand(seed) % 6u);
    }
    if (kind == 1u) {
        for (uint32_t k = tu_rand(seed) % 12u; k > 0u; k--) {
            uint32_t x0 = tu_rand(seed) % w, y0 = tu_rand(seed) % h;
            uint32_t x1 = x0 + 1u + tu_rand(seed) % 30u, y1 = y0 + 1u + tu_rand(seed) % 20u;
            uint8_t val = (uint8_t)tu_rand(seed);
            for (uint32_t y = y0; y < y1 && y < h; y++) {
                for (uint32_t x = x0; x < x1 && x < w; x++) {
                    g_src[y * stride + x] = val;
                }
            }
        }
    } else if (kind == 2u) {
        const uint32_t step = 2u + tu_rand(seed) % 5u;
        for (uint32_t y = 0; y < h; y++) {
            for (uint32_t x = 0; x < w; x++) {
                // Vertical teeth joined at the bottom, and rings around the centre.
                const uint32_t dx = x > w / 2u ? x - w / 2u : w / 2u - x;
                const uint32_t dy = y > h / 2u ? y - h / 2u : h / 2u - y;
                const uint32_t ring = (dx > dy ? dx : dy) % step == 0u;
                if ((x % step == 0u && y < h - 1u) || y == h - 1u || ring) {
                    g_src[y * stride + x] = 200u;
                }
            }
        }
    } else if (kind == 3u) {
        for (uint32_t k = tu_rand(seed) % 40u; k > 0u; k--) {
            g_src[(tu_rand(seed) % h) * stride + tu_rand(seed) % w] = 255u;
        }
    }
}

static void test_candidates_strips_vs_whole_frame(void)
{
    uint32_t seed = 4242u;
    for (int it = 0; it < 400; it++) {
        // Odd sizes, 1-row and 1-column frames, heights that are odd (a last pair of one row).
        uint32_t w = 1u + tu_rand(&seed) % 260u;
        uint32_t h = 1u + tu_rand(&seed) % 135u;
        if (it % 17 == 0) { w = 1u; }
        if (it % 19 == 0) { h = 1u; }
        const size_t stride = w + tu_rand(&seed) % 5u;
        fill_frame(w, h, stride, tu_rand(&seed) % 4u, &seed);
        vd_contrast_cfg_t c;
        memset(&c, 0, sizeof(c));
        const uint32_t rr = tu_rand(&seed) % 4u;
        c.radius = (uint16_t)(rr == 0u ? VD_CONTRAST_MAX_RADIUS : 1u + tu_rand(&seed) % (rr == 1u ? 4u : 40u));
        c.polarity = (uint8_t)(tu_rand(&seed) % 3u);
        c.thr_mode = (uint8_t)(tu_rand(&seed) % 2u);
        c.thr_u8 = (uint8_t)(1u + tu_rand(&seed) % 60u);
        c.permille = (uint16_t)(500u + tu_rand(&seed) % 501u);
        if (tu_rand(&seed) % 2u != 0u) {   // rules that keep nearly everything
            c.rules.aspect_min_q8 = 0u;
            c.rules.aspect_max_q8 = 65535u;
            c.rules.min_area = 1u;
        }
        // Caps: none, tiny (capacity errors: the first cap in label order), or room for all.
        const uint32_t ck = tu_rand(&seed) % 3u;
        const size_t cap = ck == 0u ? CAND_CAP : (ck == 1u ? tu_rand(&seed) % 9u : 256u);
        vd_view_u8_t v = {g_src, w, h, stride};
        size_t n_ref = 0u;
        uint8_t thr_ref = 0u;
        const vd_status_t st_ref = whole_frame_candidates(&v, &c, cap, &n_ref, &thr_ref);
        size_t bytes = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_workspace_size(w, h, &bytes));
        TEST_ASSERT_TRUE(bytes <= sizeof(g_strip_ws));
        memset(g_new_comps, 0xA5, sizeof(g_new_comps));
        size_t n = 99u;
        uint8_t thr = 0u;
        const vd_status_t st = vd_contrast_candidates(&v, &c, g_strip_ws, bytes, g_new_comps, cap, &n, &thr);
        TEST_ASSERT_EQUAL_INT(st_ref, st);
        TEST_ASSERT_EQUAL_UINT8(thr_ref, thr);
        TEST_ASSERT_EQUAL_size_t(n_ref, n);
        if (n > 0u) {
            TEST_ASSERT_EQUAL_MEMORY(g_ref_comps, g_new_comps, n * sizeof(vd_component_t));
        }
    }
}

// The strip workspace depends on the width only (a few row buffers), and is
// far below the whole-frame map and labelling it replaced.
static void test_candidates_workspace_is_strips(void)
{
    size_t a = 0u, b = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_workspace_size(640u, 512u, &a));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_workspace_size(640u, 1u, &b));
    TEST_ASSERT_EQUAL_size_t(a, b);
    TEST_ASSERT_EQUAL_size_t(49664u, a);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_workspace_size(641u, 512u, &b));
    TEST_ASSERT_TRUE(b > a);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_workspace_size(VD_MAX_DIM, VD_MAX_DIM, &b));
    TEST_ASSERT_TRUE(b < 700000u);
}

static vd_status_t ws_map(void *ws, size_t bytes, void *ctx)
{
    (void)ctx;
    vd_view_u8_t v = {g_src, 40, 30, 40};
    vd_image_u8_t d = {g_dst, 40, 30, 40};
    return vd_contrast_map_u8(&v, 4u, VD_CONTRAST_BOTH, ws, bytes, &d);
}

static vd_status_t ws_cand(void *ws, size_t bytes, void *ctx)
{
    vd_view_u8_t v = {g_src, 40, 30, 40};
    size_t n = 0;
    return vd_contrast_candidates(&v, (const vd_contrast_cfg_t *)ctx, ws, bytes, g_comps, 256, &n, NULL);
}

static void test_workspace_contract(void)
{
    memset(g_src, 50, 40u * 30u);
    size_t b = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_map_workspace_size(40, &b));
    TEST_ASSERT_EQUAL_size_t(160u, b);
    tu_check_workspace_contract(b, ws_map, NULL);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_workspace_size(40, 30, &b));
    tu_check_workspace_contract(b, ws_cand, NULL);
    // Percentile mode (the histogram slice) and a noisy frame (every node slice in use).
    for (size_t i = 0; i < 40u * 30u; i++) {
        g_src[i] = (uint8_t)(i * 73u % 251u);
    }
    vd_contrast_cfg_t c;
    memset(&c, 0, sizeof(c));
    c.thr_mode = VD_CONTRAST_THR_PERCENTILE;
    tu_check_workspace_contract(b, ws_cand, &c);
    // Column sums (2 B), two map rows (2 B), three run rows (3 x 8 B per 2 columns),
    // 3 nodes per 2 columns (4 + 4 + 32 B), the histogram.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_workspace_size(640, 480, &b));
    TEST_ASSERT_EQUAL_size_t(1280u + 1280u + 3u * 2560u + 2u * 3840u + 30720u + 1024u, b);
}

static void test_arguments(void)
{
    uint64_t col[32];   // 64 column sums, 8-aligned
    vd_view_u8_t v = {g_src, 40, 30, 40};
    vd_image_u8_t d = {g_dst, 40, 30, 40};
    size_t b = 0;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_workspace_size(0, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_workspace_size(VD_MAX_DIM + 1u, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_workspace_size(40, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_workspace_size(40, 0, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_workspace_size(40, 30, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_u8(NULL, 4u, 0u, col, sizeof(col), &d));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_u8(&v, 4u, 0u, col, sizeof(col), NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_u8(&v, 0u, 0u, col, sizeof(col), &d));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_u8(&v, VD_CONTRAST_MAX_RADIUS + 1u, 0u, col, sizeof(col), &d));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_u8(&v, 4u, 3u, col, sizeof(col), &d));
    vd_image_u8_t small = {g_dst, 39, 30, 40};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_u8(&v, 4u, 0u, col, sizeof(col), &small));
    vd_image_u8_t alias = {g_src, 40, 30, 40};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_u8(&v, 4u, 0u, col, sizeof(col), &alias));
    vd_view_u8_t bad = {g_src, 40, 30, 39};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_map_u8(&bad, 4u, 0u, col, sizeof(col), &d));

    static uint64_t ws[(64u * 64u + 4096u + 2048u + 140000u) / 8u];
    size_t n = 99;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_candidates(&v, NULL, ws, sizeof(ws), g_comps, 4, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_candidates(NULL, NULL, ws, sizeof(ws), g_comps, 4, &n, NULL));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_candidates(&v, NULL, ws, sizeof(ws), NULL, 4, &n, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_candidates(&bad, NULL, ws, sizeof(ws), g_comps, 4, &n, NULL));
    vd_contrast_cfg_t c;
    memset(&c, 0, sizeof(c));
    c.radius = VD_CONTRAST_MAX_RADIUS + 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_candidates(&v, &c, ws, sizeof(ws), g_comps, 4, &n, NULL));
    memset(&c, 0, sizeof(c));
    c.polarity = 3u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_candidates(&v, &c, ws, sizeof(ws), g_comps, 4, &n, NULL));
    memset(&c, 0, sizeof(c));
    c.thr_mode = 2u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_candidates(&v, &c, ws, sizeof(ws), g_comps, 4, &n, NULL));
    memset(&c, 0, sizeof(c));
    c.permille = 1001u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_candidates(&v, &c, ws, sizeof(ws), g_comps, 4, &n, NULL));
    memset(&c, 0, sizeof(c));
    c.rules.aspect_min_q8 = 300u;
    c.rules.aspect_max_q8 = 100u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_candidates(&v, &c, ws, sizeof(ws), g_comps, 4, &n, NULL));
    // cap 0 with NULL out is allowed.
    memset(g_src, 50, 40u * 30u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_candidates(&v, NULL, ws, sizeof(ws), NULL, 0, &n, NULL));
    TEST_ASSERT_EQUAL_size_t(0u, n);
}

static void test_cfg_resolve(void)
{
    vd_contrast_cfg_t c;
    memset(&c, 0, sizeof(c));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_cfg_resolve(&c));
    TEST_ASSERT_EQUAL_UINT16(16u, c.radius);
    TEST_ASSERT_EQUAL_UINT8(24u, c.thr_u8);
    TEST_ASSERT_EQUAL_UINT16(950u, c.permille);
    TEST_ASSERT_EQUAL_UINT8(VD_CONTRAST_BOTH, c.polarity);
    TEST_ASSERT_EQUAL_UINT8(VD_CONTRAST_THR_FIXED, c.thr_mode);
    vd_components_rules_t d;
    vd_components_rules_default(&d);
    TEST_ASSERT_EQUAL_MEMORY(&d, &c.rules, sizeof(d));
    // Resolving again changes nothing; given values are kept.
    vd_contrast_cfg_t again = c;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_cfg_resolve(&again));
    TEST_ASSERT_EQUAL_MEMORY(&c, &again, sizeof(c));
    memset(&c, 0, sizeof(c));
    c.radius = VD_CONTRAST_MAX_RADIUS;
    c.polarity = VD_CONTRAST_COLD;
    c.thr_mode = VD_CONTRAST_THR_PERCENTILE;
    c.thr_u8 = 3u;
    c.permille = 1000u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contrast_cfg_resolve(&c));
    TEST_ASSERT_EQUAL_UINT16(VD_CONTRAST_MAX_RADIUS, c.radius);
    TEST_ASSERT_EQUAL_UINT8(3u, c.thr_u8);
    TEST_ASSERT_EQUAL_UINT16(1000u, c.permille);
    // Each range (the same ones vd_contrast_candidates rejects, see test_arguments).
    memset(&c, 0, sizeof(c));
    c.radius = VD_CONTRAST_MAX_RADIUS + 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_cfg_resolve(&c));
    memset(&c, 0, sizeof(c));
    c.polarity = 3u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_cfg_resolve(&c));
    memset(&c, 0, sizeof(c));
    c.thr_mode = 2u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_cfg_resolve(&c));
    memset(&c, 0, sizeof(c));
    c.permille = 1001u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_cfg_resolve(&c));
    memset(&c, 0, sizeof(c));
    c.rules.min_area = 10u;
    c.rules.max_area = 9u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_cfg_resolve(&c));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contrast_cfg_resolve(NULL));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_map_hand_worked);
    RUN_TEST(test_map_random_vs_naive);
    RUN_TEST(test_map_wide_and_extreme_vs_integral);
    RUN_TEST(test_candidates_cold_and_warm);
    RUN_TEST(test_candidates_percentile_and_capacity);
    RUN_TEST(test_candidates_strips_vs_whole_frame);
    RUN_TEST(test_candidates_workspace_is_strips);
    RUN_TEST(test_workspace_contract);
    RUN_TEST(test_arguments);
    RUN_TEST(test_cfg_resolve);
    return UNITY_END();
}
