// SPDX-License-Identifier: MIT
// Hostile inputs across modules (issue 6 item 2): degenerate, oversized and lying frames, out-of-range
// configurations, capacities 0 and 1, corrupted models. Each call must return its documented status
// without touching memory it was not given, and the same object must then process a good input
// correctly. Per-module argument tests live in each module's own test file; this file covers the
// cases every module must share and the cross-module ones (detector + model, detector + frames).
#include "unity.h"
#include "testutil.h"

#include <stdio.h>
#include <string.h>

#include "vd/vd.h"

#ifndef VD_SOURCE_DIR
#define VD_SOURCE_DIR "."
#endif

#define MAXD VD_MAX_DIM

// A full-width row and a full-height column of real pixels: frames of VD_MAX_DIM x 1 and 1 x VD_MAX_DIM.
static uint8_t g_line[MAXD];
static uint16_t g_line16[MAXD];
static uint8_t g_dst[2u * MAXD];
static uint8_t g_small[64];
static uint64_t g_ws[2u * 1024u * 1024u / 8u];  // 2 MiB, aligned

void setUp(void) {}
void tearDown(void) {}

// ---------------------------------------------------------------------------------------------
// Lying views: every pixel function gets these and must answer without reading the pixels.

typedef struct bad_view {
    const char *what;
    vd_view_u8_t v;
    vd_status_t st1;  // documented status
    vd_status_t st2;  // also documented (VD_ERR_OVERFLOW where a check reports the extent), else == st1
} bad_view_t;

static size_t bad_views(bad_view_t out[8])
{
    size_t n = 0u;
    out[n++] = (bad_view_t){"0x0", {g_small, 0u, 0u, 0u}, VD_ERR_ARG, VD_ERR_ARG};
    out[n++] = (bad_view_t){"0x1", {g_small, 0u, 1u, 1u}, VD_ERR_ARG, VD_ERR_ARG};
    out[n++] = (bad_view_t){"1x0", {g_small, 1u, 0u, 1u}, VD_ERR_ARG, VD_ERR_ARG};
    out[n++] = (bad_view_t){"null data", {NULL, 4u, 4u, 4u}, VD_ERR_ARG, VD_ERR_ARG};
    // A 64-byte buffer claiming to be larger than VD_MAX_DIM: rejected on the claim alone.
    out[n++] = (bad_view_t){"width MAX+1", {g_small, MAXD + 1u, 1u, MAXD + 1u}, VD_ERR_ARG, VD_ERR_ARG};
    out[n++] = (bad_view_t){"height MAX+1", {g_small, 1u, MAXD + 1u, 1u}, VD_ERR_ARG, VD_ERR_ARG};
    out[n++] = (bad_view_t){"stride < width", {g_small, 8u, 4u, 7u}, VD_ERR_ARG, VD_ERR_ARG};
    // stride * (height - 1) does not fit size_t.
    out[n++] = (bad_view_t){"stride overflow", {g_small, 8u, 3u, SIZE_MAX / 2u + 1u}, VD_ERR_OVERFLOW, VD_ERR_ARG};
    return n;
}

static void assert_bad(const bad_view_t *b, vd_status_t st, const char *fn)
{
    char msg[96];
    snprintf(msg, sizeof(msg), "%s on %s", fn, b->what);
    TEST_ASSERT_TRUE_MESSAGE(st == b->st1 || st == b->st2, msg);
}

static void test_pixel_functions_reject_lying_views(void)
{
    bad_view_t bv[8];
    const size_t n = bad_views(bv);
    for (size_t i = 0u; i < n; i++) {
        vd_image_u8_t dst = {g_dst, bv[i].v.width ? bv[i].v.width : 1u, bv[i].v.height ? bv[i].v.height : 1u,
                             bv[i].v.width ? bv[i].v.width : 1u};
        uint32_t hist[256];
        uint8_t thr = 0u;
        assert_bad(&bv[i], vd_view_u8_check(&bv[i].v), "vd_view_u8_check");
        assert_bad(&bv[i], vd_threshold_u8(&bv[i].v, NULL, 150u, &dst), "vd_threshold_u8");
        assert_bad(&bv[i], vd_histogram_u8(&bv[i].v, NULL, hist), "vd_histogram_u8");
        assert_bad(&bv[i], vd_otsu_u8(&bv[i].v, NULL, &thr), "vd_otsu_u8");
        assert_bad(&bv[i], vd_median3_u8(&bv[i].v, NULL, &dst), "vd_median3_u8");
        assert_bad(&bv[i], vd_median5_u8(&bv[i].v, NULL, &dst), "vd_median5_u8");
        assert_bad(&bv[i], vd_resample_u8(&bv[i].v, NULL, g_dst, 8u, 8u), "vd_resample_u8");
        assert_bad(&bv[i], vd_refine_edges_u8(&bv[i].v, NULL, &dst), "vd_refine_edges_u8");
        size_t cnt = 9u, nc = 9u, np = 9u;
        vd_component_t comps[4];
        vd_point_t pts[16];
        vd_contour_t cs[4];
        assert_bad(&bv[i], vd_components_label(&bv[i].v, NULL, g_ws, sizeof(g_ws), comps, 4u, &cnt),
                   "vd_components_label");
        TEST_ASSERT_EQUAL_size_t(0u, cnt);
        assert_bad(&bv[i], vd_contour_find_external(&bv[i].v, g_ws, sizeof(g_ws), pts, NULL, 16u, cs, 4u, &nc, &np),
                   "vd_contour_find_external");
        vd_image_u8_t mask = dst;
        assert_bad(&bv[i], vd_refine_region(&bv[i].v, NULL, NULL, g_ws, sizeof(g_ws), &mask, NULL),
                   "vd_refine_region");
        // Same claim through a writable image.
        vd_image_u8_t img = {(uint8_t *)(uintptr_t)bv[i].v.data, bv[i].v.width, bv[i].v.height, bv[i].v.stride};
        assert_bad(&bv[i], vd_image_u8_check(&img), "vd_image_u8_check");
        assert_bad(&bv[i], vd_refine_fill_holes_u8(&img, g_ws, sizeof(g_ws)), "vd_refine_fill_holes_u8");
    }
}

static void test_sizes_queries_at_and_past_max_dim(void)
{
    size_t b = 0u;
    // At VD_MAX_DIM the size either fits (64-bit hosts) or is reported as overflow (32-bit), never wraps.
    vd_status_t st = vd_components_workspace_size(MAXD, MAXD, &b);
    TEST_ASSERT_TRUE(st == VD_OK || st == VD_ERR_OVERFLOW);
    if (st == VD_OK) {
        TEST_ASSERT_TRUE(b >= (size_t)MAXD * MAXD);
    }
    st = vd_refine_workspace_size(MAXD, MAXD, &b);
    TEST_ASSERT_TRUE(st == VD_OK || st == VD_ERR_OVERFLOW);
    if (st == VD_OK) {
        TEST_ASSERT_TRUE(b >= 5u * (size_t)MAXD * MAXD);
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contour_workspace_size(MAXD, MAXD, &b));
    TEST_ASSERT_EQUAL_size_t(((size_t)MAXD + 2u) * ((size_t)MAXD + 2u), b);
    st = vd_refine_fill_holes_workspace_size(MAXD, MAXD, &b);
    TEST_ASSERT_TRUE(st == VD_OK || st == VD_ERR_OVERFLOW);
    const uint32_t bad[3][2] = {{0u, 1u}, {1u, 0u}, {MAXD + 1u, 1u}};
    for (int i = 0; i < 3; i++) {
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size(bad[i][0], bad[i][1], &b));
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_contour_workspace_size(bad[i][0], bad[i][1], &b));
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_workspace_size(bad[i][0], bad[i][1], &b));
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_fill_holes_workspace_size(bad[i][0], bad[i][1], &b));
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_workspace_size(bad[i][1], bad[i][0], &b));
    }
}

// VD_MAX_DIM x 1 and 1 x VD_MAX_DIM frames with real pixels: a bar of 100 hot pixels at 4000.
static void test_max_dim_line_frames(void)
{
    memset(g_line, 10, sizeof(g_line));
    memset(g_line + 4000, 200, 100);
    const vd_view_u8_t views[2] = {{g_line, MAXD, 1u, MAXD}, {g_line, 1u, MAXD, 1u}};
    for (int k = 0; k < 2; k++) {
        const vd_view_u8_t *v = &views[k];
        vd_image_u8_t dst = {g_dst, v->width, v->height, v->width};
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u8(v, NULL, 150u, &dst));
        TEST_ASSERT_EQUAL_UINT8(0u, g_dst[3999]);
        TEST_ASSERT_EQUAL_UINT8(255u, g_dst[4000]);
        TEST_ASSERT_EQUAL_UINT8(255u, g_dst[4099]);
        TEST_ASSERT_EQUAL_UINT8(0u, g_dst[4100]);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_median3_u8(v, NULL, &dst));
        TEST_ASSERT_EQUAL_UINT8(200u, g_dst[4050]);
        uint8_t t = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_otsu_u8(v, NULL, &t));
        TEST_ASSERT_TRUE(t >= 10u && t < 200u);
        size_t wsb = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size(v->width, v->height, &wsb));
        TEST_ASSERT_TRUE(wsb <= sizeof(g_ws));
        vd_component_t c[2];
        size_t n = 0u;
        const vd_view_u8_t mv = *v;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_label(&mv, NULL, g_ws, wsb, c, 2u, &n));
        TEST_ASSERT_EQUAL_size_t(1u, n);  // every pixel is nonzero: one component
        TEST_ASSERT_EQUAL_UINT32(MAXD, c[0].area);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_contour_workspace_size(v->width, v->height, &wsb));
        static vd_point_t pts[2u * MAXD];
        vd_contour_t cs[2];
        size_t nc = 0u, np = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_contour_find_external(&mv, g_ws, wsb, pts, NULL, 2u * MAXD, cs, 2u, &nc, &np));
        TEST_ASSERT_EQUAL_size_t(1u, nc);
        TEST_ASSERT_EQUAL_INT32((int32_t)v->width, cs[0].box.w);
        TEST_ASSERT_EQUAL_INT32((int32_t)v->height, cs[0].box.h);
        uint8_t s[32 * 32];
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(v, NULL, s, 32u, 32u));
    }
}

static void test_odd_strides(void)
{
    // 5x3 image at stride 7 (odd): padding bytes are 255 and must never be read as pixels.
    uint8_t buf[7 * 2 + 5];
    memset(buf, 255, sizeof(buf));
    for (int y = 0; y < 3; y++) {
        memset(buf + 7 * y, 0, 5);
    }
    buf[7 * 1 + 2] = 200;
    const vd_view_u8_t v = {buf, 5u, 3u, 7u};
    uint8_t out[5 * 3];
    vd_image_u8_t dst = {out, 5u, 3u, 5u};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u8(&v, NULL, 150u, &dst));
    uint32_t on = 0u;
    for (int i = 0; i < 15; i++) {
        on += out[i] == 255u;
    }
    TEST_ASSERT_EQUAL_UINT32(1u, on);
    uint32_t hist[256];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_histogram_u8(&v, NULL, hist));
    TEST_ASSERT_EQUAL_UINT32(14u, hist[0]);
    TEST_ASSERT_EQUAL_UINT32(0u, hist[255]);
    vd_component_t c[2];
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_label(&v, NULL, g_ws, sizeof(g_ws), c, 2u, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_UINT32(1u, c[0].area);
    // 16-bit: an odd byte stride and a misaligned pointer are rejected.
    const vd_view_u16_t odd = {g_line16, 4u, 2u, 9u};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_view_u16_check(&odd));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u16(&odd, NULL, 100u, &dst));
    const vd_view_u16_t mis = {(const uint16_t *)(const void *)((const uint8_t *)g_line16 + 1), 4u, 2u, 8u};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_view_u16_check(&mis));
}

static void test_u16_values_past_calibration(void)
{
    for (uint32_t i = 0u; i < MAXD; i++) {
        g_line16[i] = (uint16_t)(i & 1u ? 65535u : 0u);
    }
    const vd_view_u16_t v = {g_line16, MAXD, 1u, 2u * MAXD};
    vd_image_u8_t dst = {g_dst, MAXD, 1u, MAXD};
    const vd_calib_t tlinear = {65536, 0};
    // 65535 raw = 655.35 K: a 30 C threshold marks exactly the odd pixels.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u16_ck(&v, NULL, &tlinear, 30315, &dst));
    TEST_ASSERT_EQUAL_UINT8(0u, g_dst[0]);
    TEST_ASSERT_EQUAL_UINT8(255u, g_dst[MAXD - 1u]);
    // A threshold hotter than raw 65535 can express: all-0 mask, VD_OK (documented).
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_threshold_u16_ck(&v, NULL, &tlinear, 70000, &dst));
    for (uint32_t i = 0u; i < MAXD; i++) {
        TEST_ASSERT_EQUAL_UINT8(0u, g_dst[i]);
    }
    uint16_t raw = 1234u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_calib_raw_from_ck(&tlinear, 70000, &raw));
    TEST_ASSERT_EQUAL_UINT16(1234u, raw);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_raw_from_ck(&tlinear, INT32_MIN, &raw));
    TEST_ASSERT_EQUAL_UINT16(0u, raw);
    const vd_calib_t neg = {-1, 0};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_calib_raw_from_ck(&neg, 30000, &raw));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_threshold_u16_ck(&v, NULL, &neg, 30315, &dst));
    const vd_calib_t huge = {INT32_MAX, INT32_MAX};
    int32_t ck = 7;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_calib_ck_from_raw(&huge, 65535u, &ck));
    TEST_ASSERT_EQUAL_INT32(7, ck);
}

static void test_configs_out_of_range(void)
{
    // Components rules: min > max, aspect min > max.
    vd_component_t c = {{0, 0, 10, 10}, 50u, 0u, 0u};
    size_t kept = 5u;
    vd_components_rules_t r = {77u, 384u, 200u, 100u};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_filter(&c, 1u, &r, &kept));
    TEST_ASSERT_EQUAL_size_t(0u, kept);
    r = (vd_components_rules_t){384u, 77u, 0u, 0u};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_filter(&c, 1u, &r, &kept));
    vd_components_rules_default(&r);
    vd_component_t neg = {{0, 0, -4, 10}, 50u, 0u, 0u};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_filter(&neg, 1u, &r, &kept));
    // Expansion: negative size, zero scale, a box far off the frame, frame too large.
    vd_rect_t e;
    const vd_rect_t nbox = {5, 5, -3, 4}, off = {-1000, -1000, 10, 10}, ok = {10, 10, 10, 10};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&nbox, 384u, 512u, 64u, 64u, &e));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&ok, 0u, 512u, 64u, 64u, &e));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&off, 384u, 512u, 64u, 64u, &e));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_rect_expand(&ok, 384u, 512u, MAXD + 1u, 64u, &e));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_rect_expand(&ok, 384u, 512u, 64u, 64u, &e));
    const vd_rect_t want = {8, 5, 15, 20};
    TEST_ASSERT_EQUAL_INT32(want.x, e.x);
    TEST_ASSERT_EQUAL_INT32(want.h, e.h);
    // Negative / empty / outside ROIs.
    uint8_t img[16 * 16];
    memset(img, 0, sizeof(img));
    const vd_view_u8_t v = {img, 16u, 16u, 16u};
    const vd_rect_t rois[5] = {{0, 0, -1, 4}, {0, 0, 4, 0}, {-1, 0, 4, 4}, {14, 0, 4, 4}, {0, 0, 17, 16}};
    for (int i = 0; i < 5; i++) {
        uint8_t t;
        size_t n = 3u;
        vd_component_t cc[2];
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_otsu_u8(&v, &rois[i], &t));
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label(&v, &rois[i], g_ws, sizeof(g_ws), cc, 2u, &n));
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&v, &rois[i], g_dst, 4u, 4u));
    }
    // Refine settings: median 1/7, edge_step 0, even / too small / too large window.
    const vd_refine_cfg_t bad_cfg[6] = {{1u, 5u, 5u}, {7u, 5u, 5u}, {3u, 0u, 5u}, {3u, 5u, 4u}, {3u, 5u, 1u},
                                        {3u, 5u, VD_REFINE_MAX_WINDOW + 2u}};
    uint8_t m[16 * 16];
    vd_image_u8_t mask = {m, 16u, 16u, 16u};
    for (int i = 0; i < 6; i++) {
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_refine_region(&v, NULL, &bad_cfg[i], g_ws, sizeof(g_ws), &mask, NULL));
    }
    // Resample: zero and too-large destinations.
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&v, NULL, g_dst, 0u, 4u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_resample_u8(&v, NULL, g_dst, 4u, VD_RESAMPLE_MAX_DST + 1u));
    // Otsu/maxdist on degenerate histograms.
    uint32_t hist[256];
    uint8_t t = 0u;
    memset(hist, 0, sizeof(hist));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_otsu_from_hist(hist, &t));
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_refine_maxdist_from_hist(hist, &t));
    hist[7] = 5u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_refine_maxdist_from_hist(hist, &t));
    hist[9] = VD_REFINE_MAXDIST_MAX_COUNT;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_refine_maxdist_from_hist(hist, &t));
}

static void test_capacities_zero_and_one(void)
{
    // Three separate dots in a 9x3 mask.
    uint8_t px[9 * 3];
    memset(px, 0, sizeof(px));
    px[1] = px[4] = px[7] = 255u;
    const vd_view_u8_t v = {px, 9u, 3u, 9u};
    vd_component_t c[1];
    size_t n = 99u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_components_label(&v, NULL, g_ws, sizeof(g_ws), NULL, 0u, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_components_label(&v, NULL, g_ws, sizeof(g_ws), NULL, 1u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_components_label(&v, NULL, g_ws, sizeof(g_ws), c, 1u, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_INT32(1, c[0].box.x);  // the first in label order
    vd_point_t pts[8];
    uint8_t chain[8];
    vd_contour_t cs[4];
    size_t nc = 9u, np = 9u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_contour_find_external(&v, g_ws, sizeof(g_ws), pts, chain, 8u, cs, 0u, &nc, &np));
    TEST_ASSERT_EQUAL_size_t(0u, nc);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_contour_find_external(&v, g_ws, sizeof(g_ws), pts, chain, 0u, cs, 4u, &nc, &np));
    TEST_ASSERT_EQUAL_size_t(0u, np);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_contour_find_external(&v, g_ws, sizeof(g_ws), pts, chain, 1u, cs, 1u, &nc, &np));
    TEST_ASSERT_EQUAL_size_t(1u, nc);
    TEST_ASSERT_EQUAL_size_t(1u, np);
    TEST_ASSERT_EQUAL_UINT8(VD_CONTOUR_CHAIN_NONE, chain[0]);
    // All fit again with the same workspace.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contour_find_external(&v, g_ws, sizeof(g_ws), pts, chain, 8u, cs, 4u, &nc, &np));
    TEST_ASSERT_EQUAL_size_t(3u, nc);
    // Temporal track table: capacity 0 is rejected, 1 works.
    vd_temporal_t t;
    vd_track_t tracks[1];
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_init(&t, NULL, tracks, 0u));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tracks, 1u));
}

// ---------------------------------------------------------------------------------------------
// Model blobs (the loader's own truncation/bit-flip tests are in test_dbn.c; here: structural
// corruption behind a valid CRC, trailing bytes, and what the detector does with them).

static uint32_t g_blob[4096];
static size_t g_blob_len;

static int load_tiny(void)
{
    FILE *f = fopen(VD_SOURCE_DIR "/tests/data/golden_tiny.vdm", "rb");
    if (f == NULL) {
        return 0;
    }
    g_blob_len = fread(g_blob, 1u, sizeof(g_blob), f);
    fclose(f);
    return g_blob_len >= VD_DBN_HEADER_SIZE;
}

// A flipped header may claim any total size: repair the CRC only when it fits the buffer.
static void fix_crc(uint8_t *b, size_t len)
{
    const uint32_t total = tu_rd32(b + 8);
    if (total < 16u || total > len) {
        return;
    }
    tu_vdm_fix_crc(b);
}

static void test_model_header_flips_behind_valid_crc(void)
{
    if (!load_tiny()) {
        TEST_IGNORE_MESSAGE("tests/data/golden_tiny.vdm missing");
    }
    static uint32_t work[4096];
    uint8_t *b = (uint8_t *)work;
    uint8_t in[256 * 256];
    memset(in, 128, sizeof(in));
    size_t accepted = 0u, rejected = 0u;
    for (size_t byte = 0u; byte < VD_DBN_HEADER_SIZE; byte++) {
        for (int bit = 0; bit < 8; bit++) {
            memcpy(work, g_blob, g_blob_len);
            b[byte] ^= (uint8_t)(1u << bit);
            if (byte >= 16u) {
                fix_crc(b, g_blob_len);  // past the checksum: the structural checks must hold
            }
            vd_dbn_model_t m;
            memset(&m, 0xA5, sizeof(m));
            vd_dbn_model_t before = m;
            vd_status_t st = vd_dbn_load(&m, b, g_blob_len);
            if (byte < 16u) {
                TEST_ASSERT_EQUAL_INT_MESSAGE(VD_ERR_MODEL, st, "flip in magic/version/size/CRC");
            }
            if (st != VD_OK) {
                TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, st);
                TEST_ASSERT_EQUAL_INT(0, memcmp(&m, &before, sizeof(m)));  // untouched on failure
                rejected++;
                continue;
            }
            // Accepted (a name byte, the informative norm fields): it must still classify safely.
            accepted++;
            size_t wsb = 0u;
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_workspace_size(&m, &wsb));
            TEST_ASSERT_TRUE(wsb <= sizeof(g_ws));
            uint8_t s = 0u;
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_classify(&m, in, g_ws, wsb, &s));
        }
    }
    TEST_ASSERT_TRUE(rejected > accepted);
}

static void test_model_trailing_bytes_and_detector(void)
{
    if (!load_tiny()) {
        TEST_IGNORE_MESSAGE("tests/data/golden_tiny.vdm missing");
    }
    vd_dbn_model_t m, m2;
    static uint32_t padded[4096 + 64];
    memcpy(padded, g_blob, g_blob_len);
    memset((uint8_t *)padded + g_blob_len, 0xFF, 100);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_load(&m, g_blob, g_blob_len));
    // Oversized: trailing bytes (flash padding) are documented as ignored.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_load(&m2, padded, g_blob_len + 100u));
    TEST_ASSERT_EQUAL_UINT32(m.size, m2.size);
    // A detector refuses a model that was never loaded, and a blob that failed to load leaves the
    // caller's model untouched, so the detector keeps the good one.
    vd_dbn_model_t zero;
    memset(&zero, 0, sizeof(zero));
    size_t wsb = 0u;
    vd_detector_cfg_t cfg;
    memset(&cfg, 0, sizeof(cfg));
    cfg.max_width = 64u;
    cfg.max_height = 48u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_detector_workspace_size(&cfg, &zero, &wsb));
    vd_detector_t det;
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_detector_init(&det, &cfg, &zero, g_ws, sizeof(g_ws)));
    static uint32_t trunc[4096];
    memcpy(trunc, g_blob, g_blob_len);
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_dbn_load(&m2, trunc, g_blob_len - 4u));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&cfg, &m2, &wsb));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_init(&det, &cfg, &m2, g_ws, wsb));
}

// ---------------------------------------------------------------------------------------------
// Detector: hostile frames and configs, then the same detector on a good frame.

#define DW 64u
#define DH 48u
static uint8_t g_frame[DH][DW];
static uint16_t g_frame16[DH][DW];

static vd_frame_t good_frame(void)
{
    memset(g_frame, 40, sizeof(g_frame));
    for (uint32_t y = 10u; y < 26u; y++) {
        memset(&g_frame[y][12], 210, 24);  // a 24 x 16 warm body: area 384, h/w 0.67
    }
    vd_frame_t f = {g_frame, DW, DH, DW, VD_PIX_U8, 0u, 0u};
    return f;
}

static vd_detector_cfg_t det_cfg(void)
{
    vd_detector_cfg_t c;
    memset(&c, 0, sizeof(c));
    c.max_width = DW;
    c.max_height = DH;
    return c;
}

static void expect_good_run(vd_detector_t *det, const vd_detection_t *ref, size_t ref_n)
{
    vd_frame_t f = good_frame();
    vd_detection_t out[8];
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(det, &f, out, 8u, &n));
    TEST_ASSERT_EQUAL_size_t(ref_n, n);
    for (size_t i = 0u; i < n; i++) {
        TEST_ASSERT_EQUAL_INT32(ref[i].box.x, out[i].box.x);
        TEST_ASSERT_EQUAL_INT32(ref[i].box.y, out[i].box.y);
        TEST_ASSERT_EQUAL_INT32(ref[i].box.w, out[i].box.w);
        TEST_ASSERT_EQUAL_INT32(ref[i].box.h, out[i].box.h);
        TEST_ASSERT_EQUAL_UINT8(ref[i].score_q8, out[i].score_q8);
    }
}

static void test_detector_configs_out_of_range(void)
{
    size_t wsb = 0u;
    vd_detector_t det;
    vd_detector_cfg_t c;
    const char *names[] = {"max_width > VD_MAX_DIM", "max_height > VD_MAX_DIM", "thr_mode 2", "permille 1001",
                           "negative hot_thr_ck", "negative gain", "grey_lo >= grey_hi", "aspect min > max",
                           "min_area > max_area", "expand_w < 1x", "expand_h > 8x", "median 7", "window even",
                           "window 17", "max_detections > max_candidates", "max_candidates 4097",
                           "max_region_w > max_width", "max_region_h > max_height", "max_tracks 1025",
                           "nms_iou > 1", "grey_mode 2", "grey tail 500", "cnn_invert 2", "cnn_res 3",
                           "grey tail 500, fixed window"};
    for (int i = 0; i < (int)(sizeof(names) / sizeof(names[0])); i++) {
        c = det_cfg();
        switch (i) {
        case 0: c.max_width = MAXD + 1u; break;
        case 1: c.max_height = MAXD + 1u; break;
        case 2: c.thr_mode = 2u; break;
        case 3: c.adaptive_permille = 1001u; break;
        case 4: c.hot_thr_ck = -5; break;
        case 5: c.calib.gain_q16 = -65536; break;
        case 6: c.grey_lo_ck = 31000; c.grey_hi_ck = 30000; break;
        case 7: c.rules.aspect_min_q8 = 400u; c.rules.aspect_max_q8 = 100u; break;
        case 8: c.rules.min_area = 500u; c.rules.max_area = 100u; break;
        case 9: c.expand_w_q8 = 100u; break;
        case 10: c.expand_h_q8 = 4000u; break;
        case 11: c.median_ksize = 7u; break;
        case 12: c.window = 4u; break;
        case 13: c.window = 17u; break;
        case 14: c.max_candidates = 4u; c.max_detections = 5u; break;
        case 15: c.max_candidates = 4097u; break;
        case 16: c.max_region_w = (uint16_t)(DW + 1u); break;
        case 17: c.max_region_h = (uint16_t)(DH + 1u); break;
        case 18: c.temporal = true; c.max_tracks = 1025u; break;
        case 19: c.nms_iou_q15 = 40000u; break;
        case 20: c.grey_mode = 2u; break;
        case 21: c.grey_mode = VD_DETECTOR_GREY_PERCENTILE; c.grey_tail_permille = 500u; break;
        case 22: c.cnn_invert = 2u; break;
        case 23: c.cnn_res = VD_DETECTOR_CNN_RES_QUARTER + 1u; break;
        default: c.grey_mode = VD_DETECTOR_GREY_FIXED; c.grey_tail_permille = 500u; break;
        }
        TEST_ASSERT_EQUAL_INT_MESSAGE(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &wsb), names[i]);
        TEST_ASSERT_EQUAL_INT_MESSAGE(VD_ERR_ARG, vd_detector_init(&det, &c, NULL, g_ws, sizeof(g_ws)), names[i]);
    }
}

// Runs the hostile frames through one detector (temporal on or off, fixed or per-frame grey window),
// then checks it still gives exactly the fresh detector's result on the good frame.
static void hostile_frames_then_good_frame(bool temporal, uint8_t grey_mode)
{
    vd_detector_cfg_t cfg = det_cfg();
    cfg.temporal = temporal;
    cfg.grey_mode = grey_mode;
    cfg.temporal_cfg.flags = VD_TEMPORAL_SCORES;   // track scores and coasting predicted boxes (issue 38)
    cfg.temporal_cfg.coast_frames = 2u;
    size_t wsb = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&cfg, NULL, &wsb));
    TEST_ASSERT_TRUE(wsb <= sizeof(g_ws));
    // Reference on a fresh detector.
    vd_detector_t det;
    vd_detection_t ref[8];
    size_t ref_n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_init(&det, &cfg, NULL, g_ws, wsb));
    vd_frame_t gf = good_frame();
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&det, &gf, ref, 8u, &ref_n));
    TEST_ASSERT_EQUAL_size_t(1u, ref_n);
    TEST_ASSERT_EQUAL_INT32(12, ref[0].box.x);
    TEST_ASSERT_EQUAL_INT32(24, ref[0].box.w);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_init(&det, &cfg, NULL, g_ws, wsb));

    vd_detection_t out[8];
    size_t n = 77u;
    vd_frame_t f;
    const struct {
        const char *what;
        vd_frame_t f;
        vd_status_t st;
    } cases[] = {
        {"0x0", {g_frame, 0u, 0u, DW, VD_PIX_U8, 0u, 0u}, VD_ERR_ARG},
        {"1x1", {g_frame, 1u, 1u, 1u, VD_PIX_U8, 0u, 0u}, VD_OK},
        {"1x1 u16 hot", {g_frame16, 1u, 1u, 2u, VD_PIX_U16, 0u, 0u}, VD_OK},
        {"wider than max_width", {g_frame, DW + 1u, 2u, DW + 1u, VD_PIX_U8, 0u, 0u}, VD_ERR_ARG},
        {"MAX+1 on a small buffer", {g_small, MAXD + 1u, 1u, MAXD + 1u, VD_PIX_U8, 0u, 0u}, VD_ERR_ARG},
        {"stride < width", {g_frame, DW, DH, DW - 1u, VD_PIX_U8, 0u, 0u}, VD_ERR_ARG},
        {"u16 odd stride", {g_frame16, 8u, 8u, 17u, VD_PIX_U16, 0u, 0u}, VD_ERR_ARG},
        {"unknown format", {g_frame, 8u, 8u, 8u, (vd_pixfmt_t)3, 0u, 0u}, VD_ERR_FORMAT},
        {"null data", {NULL, 8u, 8u, 8u, VD_PIX_U8, 0u, 0u}, VD_ERR_ARG},
        {"odd stride u8", {g_frame, 31u, 20u, 33u, VD_PIX_U8, 0u, 0u}, VD_OK},
    };
    g_frame16[0][0] = 65535u;
    for (size_t i = 0u; i < sizeof(cases) / sizeof(cases[0]); i++) {
        f = cases[i].f;
        n = 77u;
        vd_status_t st = vd_detector_run(&det, &f, out, 8u, &n);
        TEST_ASSERT_EQUAL_INT_MESSAGE(cases[i].st, st, cases[i].what);
        if (st != VD_OK) {
            TEST_ASSERT_EQUAL_size_t(0u, n);
        }
        TEST_ASSERT_NOT_NULL(vd_detector_last_stats(&det));
    }
    // Every 16-bit sample past the calibrated range (655.35 K), then all at 0 K.
    for (int k = 0; k < 2; k++) {
        for (uint32_t y = 0u; y < DH; y++) {
            for (uint32_t x = 0u; x < DW; x++) {
                g_frame16[y][x] = k ? 0u : 65535u;
            }
        }
        f = (vd_frame_t){g_frame16, DW, DH, 2u * DW, VD_PIX_U16, 0u, 0u};
        vd_status_t st = vd_detector_run(&det, &f, out, 8u, &n);
        TEST_ASSERT_TRUE(st == VD_OK || st == VD_ERR_CAPACITY);
        TEST_ASSERT_TRUE(n <= 8u);
        for (size_t i = 0u; i < n; i++) {
            TEST_ASSERT_TRUE(out[i].box.x >= 0 && out[i].box.x + out[i].box.w <= (int32_t)DW);
            TEST_ASSERT_TRUE(out[i].box.y >= 0 && out[i].box.y + out[i].box.h <= (int32_t)DH);
        }
    }
    // Capacity 0 and 1 on a frame with two targets.
    gf = good_frame();
    for (uint32_t y = 32u; y < 44u; y++) {
        memset(&g_frame[y][40], 220, 18);
    }
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_run(&det, &gf, NULL, 1u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_detector_run(&det, &gf, NULL, 0u, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_detector_run(&det, &gf, out, 1u, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_TRUE(vd_detector_last_stats(&det)->overflow_detections >= 1u);
    if (!temporal) {
        // Without temporal state the very same object must give the fresh result.
        expect_good_run(&det, ref, ref_n);
    } else {
        // Temporal state depends on the history: one good run must still find the body.
        gf = good_frame();
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&det, &gf, out, 8u, &n));
        TEST_ASSERT_TRUE(n >= 1u);
        TEST_ASSERT_EQUAL_INT32(ref[0].box.x, out[0].box.x);
        TEST_ASSERT_EQUAL_INT32(ref[0].box.w, out[0].box.w);
    }
}

static void test_detector_hostile_frames_then_good_frame(void)
{
    hostile_frames_then_good_frame(false, VD_DETECTOR_GREY_FIXED);
    hostile_frames_then_good_frame(true, VD_DETECTOR_GREY_FIXED);
    hostile_frames_then_good_frame(false, VD_DETECTOR_GREY_PERCENTILE);   // flat 16-bit frames: widened window
    hostile_frames_then_good_frame(true, VD_DETECTOR_GREY_PERCENTILE);
}

static void test_detector_max_width_frame(void)
{
    vd_detector_cfg_t cfg;
    memset(&cfg, 0, sizeof(cfg));
    cfg.max_width = MAXD;
    cfg.max_height = 1u;
    size_t wsb = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&cfg, NULL, &wsb));
    TEST_ASSERT_TRUE(wsb <= sizeof(g_ws));
    vd_detector_t det;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_init(&det, &cfg, NULL, g_ws, wsb));
    memset(g_line, 10, sizeof(g_line));
    memset(g_line + 4000, 200, 100);
    vd_frame_t f = {g_line, MAXD, 1u, MAXD, VD_PIX_U8, 0u, 0u};
    vd_detection_t out[4];
    size_t n = 9u;
    vd_status_t st = vd_detector_run(&det, &f, out, 4u, &n);
    TEST_ASSERT_TRUE(st == VD_OK || st == VD_ERR_CAPACITY);
    TEST_ASSERT_EQUAL_size_t(0u, n);  // a 100 x 1 bar fails the aspect rule
    TEST_ASSERT_EQUAL_UINT32(100u, vd_detector_last_stats(&det)->hot_pixels);
    f.height = 2u;  // taller than max_height
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_run(&det, &f, out, 4u, &n));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_pixel_functions_reject_lying_views);
    RUN_TEST(test_sizes_queries_at_and_past_max_dim);
    RUN_TEST(test_max_dim_line_frames);
    RUN_TEST(test_odd_strides);
    RUN_TEST(test_u16_values_past_calibration);
    RUN_TEST(test_configs_out_of_range);
    RUN_TEST(test_capacities_zero_and_one);
    RUN_TEST(test_model_header_flips_behind_valid_crc);
    RUN_TEST(test_model_trailing_bytes_and_detector);
    RUN_TEST(test_detector_configs_out_of_range);
    RUN_TEST(test_detector_hostile_frames_then_good_frame);
    RUN_TEST(test_detector_max_width_frame);
    return UNITY_END();
}
