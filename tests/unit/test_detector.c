// SPDX-License-Identifier: MIT
// Unit tests of the detector pipeline on synthetic frames built here (no model, no data files needed).
#include "unity.h"
#include "testutil.h"

#include <string.h>

#include "vd/detector.h"

#define FW 160u
#define FH 120u

static uint8_t g_px[FH][FW];
static uint16_t g_px16[FH][FW];
static vd_detector_t g_det;
static uint64_t g_ws[4u * 1024u * 1024u / 8u];   // 4 MiB, aligned

void setUp(void) {}
void tearDown(void) {}

static void fill(uint8_t v)
{
    memset(g_px, v, sizeof(g_px));
}

static void rect8(int32_t x, int32_t y, int32_t w, int32_t h, uint8_t v)
{
    for (int32_t j = y; j < y + h; j++) {
        for (int32_t i = x; i < x + w; i++) {
            g_px[j][i] = v;
        }
    }
}

// A car-like hot object: body 30 x 20 with hotter tyres/exhaust at the bottom.
static void car8(int32_t x, int32_t y, uint8_t body)
{
    rect8(x, y, 30, 20, body);
    rect8(x + 2, y + 15, 6, 5, (uint8_t)(body + 30u));
    rect8(x + 22, y + 15, 6, 5, (uint8_t)(body + 30u));
}

static vd_frame_t frame8(void)
{
    vd_frame_t f = {g_px, FW, FH, FW, VD_PIX_U8, 0, 0};
    return f;
}

static vd_detector_cfg_t small_cfg(void)
{
    vd_detector_cfg_t c;
    memset(&c, 0, sizeof(c));
    c.max_width = FW;
    c.max_height = FH;
    return c;
}

static void init_or_fail(const vd_detector_cfg_t *c)
{
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(c, NULL, &bytes));
    TEST_ASSERT_TRUE(bytes <= sizeof(g_ws));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_init(&g_det, c, NULL, g_ws, bytes));
}

static void test_defaults_zeroed_equals_explicit(void)
{
    vd_detector_cfg_t z;
    vd_detector_cfg_t d;
    memset(&z, 0, sizeof(z));
    vd_detector_cfg_default(&d);
    TEST_ASSERT_EQUAL_UINT32(640u, d.max_width);
    TEST_ASSERT_EQUAL_UINT32(512u, d.max_height);
    TEST_ASSERT_EQUAL_UINT8(150u, d.hot_thr_u8);
    TEST_ASSERT_EQUAL_INT32(30315, d.hot_thr_ck);
    TEST_ASSERT_EQUAL_UINT16(77u, d.rules.aspect_min_q8);
    TEST_ASSERT_EQUAL_UINT16(384u, d.rules.aspect_max_q8);
    TEST_ASSERT_EQUAL_UINT32(120u, d.rules.min_area);
    TEST_ASSERT_EQUAL_UINT16(384u, d.expand_w_q8);
    TEST_ASSERT_EQUAL_UINT16(512u, d.expand_h_q8);
    size_t a = 0u;
    size_t b = 0u;
    size_t c = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(NULL, NULL, &a));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&z, NULL, &b));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&d, NULL, &c));
    TEST_ASSERT_EQUAL_size_t(a, b);
    TEST_ASSERT_EQUAL_size_t(a, c);
}

static void test_car_kept_lamp_and_pole_rejected(void)
{
    fill(40u);
    car8(20, 30, 180u);
    rect8(100, 10, 6, 6, 250u);   // street lamp: 36 px < 120
    rect8(130, 20, 6, 60, 220u);  // pole: h/w = 10 > 1.5
    vd_detector_cfg_t c = small_cfg();
    init_or_fail(&c);
    vd_frame_t f = frame8();
    vd_detection_t out[8];
    size_t n = 99u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 8, &n));
    const vd_detector_stats_t *s = vd_detector_last_stats(&g_det);
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_UINT32(3u, s->components);
    TEST_ASSERT_EQUAL_UINT32(1u, s->kept);
    TEST_ASSERT_EQUAL_UINT32(1u, s->refined);
    TEST_ASSERT_EQUAL_UINT32(1u, s->verified);
    TEST_ASSERT_EQUAL_UINT32(150u, s->hot_thr_u8);
    TEST_ASSERT_EQUAL_UINT32(600u + 36u + 360u, s->hot_pixels);
    TEST_ASSERT_EQUAL_INT32(20, out[0].box.x);
    TEST_ASSERT_EQUAL_INT32(30, out[0].box.y);
    TEST_ASSERT_EQUAL_INT32(30, out[0].box.w);
    TEST_ASSERT_EQUAL_INT32(20, out[0].box.h);
    // Outline of the 30 x 20 rectangle has 2 * (29 + 19) = 96 points; the local
    // max-distance windows at the hot tyres carve the two bottom corners a little.
    TEST_ASSERT_TRUE(out[0].contour_length >= 80u && out[0].contour_length <= 96u);
    TEST_ASSERT_EQUAL_UINT8(255u, out[0].score_q8);
    TEST_ASSERT_TRUE((out[0].flags & VD_DET_FLAG_UNVERIFIED) != 0u);
    TEST_ASSERT_EQUAL_UINT8(VD_SOURCE_HOTSPOT, out[0].source);
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_NONE, out[0].state);
    // Candidate region: 30 x 20 expanded 1.5 x / 2 x about the centre.
    TEST_ASSERT_EQUAL_INT32(13, out[0].candidate.x);
    TEST_ASSERT_EQUAL_INT32(20, out[0].candidate.y);
    TEST_ASSERT_EQUAL_INT32(45, out[0].candidate.w);
    TEST_ASSERT_EQUAL_INT32(40, out[0].candidate.h);
    TEST_ASSERT_TRUE(out[0].complexity_q15 > 0u);
}

static void test_two_cars_and_nothing(void)
{
    vd_detector_cfg_t c = small_cfg();
    init_or_fail(&c);
    vd_frame_t f = frame8();
    vd_detection_t out[8];
    size_t n = 99u;
    fill(40u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 8, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    car8(10, 10, 170u);
    car8(100, 70, 190u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 8, &n));
    TEST_ASSERT_EQUAL_size_t(2u, n);
    TEST_ASSERT_EQUAL_INT32(10, out[0].box.x);   // equal scores keep raster order
    TEST_ASSERT_EQUAL_INT32(100, out[1].box.x);
}

static void test_u16_radiometric(void)
{
    // 20 C background, 40 C car, TLinear (raw = centi-kelvin).
    for (uint32_t y = 0; y < FH; y++) {
        for (uint32_t x = 0; x < FW; x++) {
            g_px16[y][x] = (uint16_t)(VD_CK_PER_0C + 2000);
        }
    }
    for (uint32_t y = 50; y < 70; y++) {
        for (uint32_t x = 60; x < 90; x++) {
            g_px16[y][x] = (uint16_t)(VD_CK_PER_0C + 4000);
        }
    }
    g_px16[5][5] = (uint16_t)(VD_CK_PER_0C + 9000);   // a lamp pixel
    vd_detector_cfg_t c = small_cfg();
    init_or_fail(&c);
    vd_frame_t f = {g_px16, FW, FH, FW * 2u, VD_PIX_U16, 0, 0};
    vd_detection_t out[4];
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_UINT32(30315u, g_det.stats.hot_thr_raw);
    TEST_ASSERT_EQUAL_UINT32(601u, g_det.stats.hot_pixels);
    TEST_ASSERT_EQUAL_INT32(60, out[0].box.x);
    TEST_ASSERT_EQUAL_INT32(50, out[0].box.y);
    TEST_ASSERT_EQUAL_INT32(30, out[0].box.w);
    TEST_ASSERT_EQUAL_INT32(20, out[0].box.h);
    // A threshold above the calibrated range: nothing is hot.
    c.hot_thr_ck = 900000;
    c.grey_lo_ck = 1000;
    c.grey_hi_ck = 900000;
    init_or_fail(&c);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
}

static void test_adaptive_threshold_for_dark_agc_frames(void)
{
    fill(20u);
    car8(40, 40, 90u);    // 90..120: below the paper's 150
    vd_detector_cfg_t c = small_cfg();
    init_or_fail(&c);
    vd_frame_t f = frame8();
    vd_detection_t out[4];
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    c.thr_mode = VD_DETECTOR_THR_ADAPTIVE;
    c.adaptive_floor_u8 = 50u;
    init_or_fail(&c);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    // 600 of 19200 px (3.1 %) are >= 90, so p99 = 90.
    TEST_ASSERT_EQUAL_UINT32(90u, g_det.stats.hot_thr_u8);
    TEST_ASSERT_EQUAL_UINT8(90u, out[0].hot_thr);
    // A frame with nothing hot: the floor keeps the background out.
    fill(20u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_UINT32(50u, g_det.stats.hot_thr_u8);
    TEST_ASSERT_EQUAL_size_t(0u, n);
}

static vd_status_t ws_run(void *ws, size_t bytes, void *ctx)
{
    (void)ctx;
    vd_detector_cfg_t c = small_cfg();
    c.temporal = true;
    vd_detector_t det;
    vd_status_t st = vd_detector_init(&det, &c, NULL, ws, bytes);
    if (st != VD_OK) {
        return st;
    }
    vd_frame_t f = frame8();
    vd_detection_t out[8];
    size_t n = 0u;
    for (int i = 0; i < 4; i++) {
        st = vd_detector_run(&det, &f, out, 8, &n);
        if (st != VD_OK) {
            return st;
        }
    }
    return (n == 1u) ? VD_OK : VD_ERR_STATE;
}

static void test_workspace_contract(void)
{
    fill(40u);
    car8(60, 50, 200u);
    vd_detector_cfg_t c = small_cfg();
    c.temporal = true;
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &bytes));
    tu_check_workspace_contract(bytes, ws_run, NULL);
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_detector_init(&g_det, &c, NULL, NULL, bytes));
}

static void test_workspace_size_640x512(void)
{
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(NULL, NULL, &bytes));
    // Issue 5 goal: <= 256 KiB at 640 x 512 with the defaults; value documented in detector.h.
    TEST_ASSERT_TRUE(bytes <= 256u * 1024u);
    // 228 400 on 64-bit hosts; 32-bit targets have smaller pointers in the per-candidate state.
    TEST_ASSERT_TRUE(bytes >= 228096u && bytes <= 228400u);
    // Bounded by the region buffers (7 B per pixel of 176 x 176), which the
    // labelling workspace (24 576 runs) fits under; nothing is 1 B per frame pixel.
    size_t cc = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_components_workspace_size_runs(640u, 512u, 24576u, &cc));
    TEST_ASSERT_TRUE(bytes >= 7u * 176u * 176u && cc < 7u * 176u * 176u);
    TEST_ASSERT_TRUE(bytes <= 7u * 176u * 176u + 16u * 1024u);
    // A larger run budget grows the workspace only once it exceeds the region buffers.
    vd_detector_cfg_t c;
    vd_detector_cfg_default(&c);
    c.max_runs = 20000u;
    size_t b2 = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b2));
    TEST_ASSERT_EQUAL_size_t(bytes, b2);
    c.max_runs = 100000u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b2));
    TEST_ASSERT_TRUE(b2 > bytes + 8u * 70000u);
    // The frame size only enters through the labeller's row buffers.
    c = small_cfg();
    c.max_width = 1280u;
    c.max_height = 1024u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b2));
    TEST_ASSERT_TRUE(b2 <= bytes + 24u * 1024u);
}

static void test_run_budget_overflow(void)
{
    // A noisy top band (1 px hot every other column: 80 runs per row) above a car.
    fill(40u);
    for (uint32_t y = 0; y < 20u; y++) {
        for (uint32_t x = 0; x < FW; x += 2u) {
            g_px[y][x] = 220u;
        }
    }
    car8(60, 70, 200u);
    vd_detector_cfg_t c = small_cfg();
    init_or_fail(&c);
    vd_frame_t f = frame8();
    vd_detection_t out[4];
    size_t n = 0u;
    // Default budget: everything is labelled.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_UINT32(20u * 80u + 20u, g_det.stats.runs);
    TEST_ASSERT_EQUAL_UINT32(0u, g_det.stats.overflow_runs);
    TEST_ASSERT_EQUAL_UINT32(20u * 80u + 600u, g_det.stats.hot_pixels);
    // A budget below the band: nothing below row 18 is labelled, reported, never silent.
    c.max_runs = 1500u;
    init_or_fail(&c);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    TEST_ASSERT_EQUAL_UINT32(FH - 18u, g_det.stats.overflow_runs);
    TEST_ASSERT_EQUAL_UINT32(18u * 80u, g_det.stats.runs);
    TEST_ASSERT_EQUAL_UINT32(0u, g_det.stats.components);   // all touch the last labelled row
    // The car above the noise: labelled rows end below it, it is still found.
    fill(40u);
    car8(60, 5, 200u);
    for (uint32_t y = 60; y < FH; y++) {
        for (uint32_t x = 0; x < FW; x += 2u) {
            g_px[y][x] = 220u;
        }
    }
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_INT32(60, out[0].box.x);
    TEST_ASSERT_TRUE(g_det.stats.overflow_runs > 0u);
    TEST_ASSERT_EQUAL_UINT32(0u, g_det.stats.overflow_components);
}

static void test_bad_configs(void)
{
    size_t bytes;
    vd_detector_cfg_t c;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(NULL, NULL, NULL));
    c = small_cfg(); c.max_width = VD_MAX_DIM + 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.rules.aspect_min_q8 = 400u; c.rules.aspect_max_q8 = 300u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.rules.min_area = 500u; c.rules.max_area = 100u; c.rules.aspect_max_q8 = 384u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.window = 4u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.median_ksize = 4u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.nms_iou_q15 = 40000u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.max_candidates = 8u; c.max_detections = 9u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.grey_lo_ck = 30000; c.grey_hi_ck = 29000;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.calib.gain_q16 = -5;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.hot_thr_ck = -1;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.thr_mode = 7u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.adaptive_permille = 1001u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.expand_w_q8 = 100u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.max_region_w = (uint16_t)(FW + 1u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.temporal_cfg.sigma_x = 5000u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    c = small_cfg(); c.max_tracks = 2000u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
    vd_model_t unloaded;
    memset(&unloaded, 0, sizeof(unloaded));
    c = small_cfg();
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_detector_workspace_size(&c, &unloaded, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_init(NULL, &c, NULL, g_ws, sizeof(g_ws)));
}

static void test_bad_run_arguments(void)
{
    vd_detector_t fresh;
    memset(&fresh, 0, sizeof(fresh));
    vd_frame_t f = frame8();
    vd_detection_t out[2];
    size_t n = 5u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_detector_run(&fresh, &f, out, 2, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    vd_detector_cfg_t c = small_cfg();
    c.max_width = 100u;   // smaller than the frame
    init_or_fail(&c);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_run(&g_det, &f, out, 2, &n));
    c = small_cfg();
    init_or_fail(&c);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_run(&g_det, &f, out, 2, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_run(&g_det, NULL, out, 2, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_run(&g_det, &f, NULL, 2, &n));
    f.format = (vd_pixfmt_t)9;
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_detector_run(&g_det, &f, out, 2, &n));
    f = frame8();
    f.stride = FW - 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_run(&g_det, &f, out, 2, &n));
    // Odd-stride 8-bit frames are fine (a view into a wider buffer).
    f = frame8();
    f.width = FW - 1u;
    fill(40u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 2, &n));
}

static void test_capacity_overflow_reported(void)
{
    fill(40u);
    car8(5, 5, 200u);
    car8(60, 5, 200u);
    car8(110, 5, 200u);
    vd_detector_cfg_t c = small_cfg();
    init_or_fail(&c);
    vd_frame_t f = frame8();
    vd_detection_t out[2];
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_detector_run(&g_det, &f, out, 2, &n));
    TEST_ASSERT_EQUAL_size_t(2u, n);
    TEST_ASSERT_EQUAL_UINT32(1u, g_det.stats.overflow_detections);
    TEST_ASSERT_EQUAL_INT32(5, out[0].box.x);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_detector_run(&g_det, &f, NULL, 0, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    // Component budget.
    c.max_components = 2u;
    init_or_fail(&c);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_detector_run(&g_det, &f, out, 2, &n));
    TEST_ASSERT_EQUAL_UINT32(1u, g_det.stats.overflow_components);
    TEST_ASSERT_EQUAL_size_t(2u, n);
    // Candidate budget.
    c = small_cfg();
    c.max_candidates = 1u;
    init_or_fail(&c);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_detector_run(&g_det, &f, out, 2, &n));
    TEST_ASSERT_EQUAL_UINT32(2u, g_det.stats.overflow_candidates);
    TEST_ASSERT_EQUAL_size_t(1u, n);
}

static void test_overlapping_candidates_suppressed(void)
{
    // Two hot parts of one vehicle (cabin and a hot engine block below,
    // separated by a 1-px cold gap): refined in overlapping regions they give
    // the same outline once the gap is bridged by the median... here we only
    // check that identical boxes are suppressed.
    fill(40u);
    rect8(40, 40, 30, 12, 200u);
    rect8(40, 53, 30, 12, 200u);
    vd_detector_cfg_t c = small_cfg();
    c.rules.min_area = 100u;
    c.rules.aspect_min_q8 = 77u;
    c.rules.aspect_max_q8 = 384u;
    init_or_fail(&c);
    vd_frame_t f = frame8();
    vd_detection_t out[4];
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_UINT32(2u, g_det.stats.kept);
    TEST_ASSERT_EQUAL_UINT32(n + g_det.stats.suppressed, g_det.stats.verified);
    for (size_t i = 0; i < n; i++) {
        for (size_t j = i + 1u; j < n; j++) {
            TEST_ASSERT_TRUE(vd_rect_iou_q15(&out[i].box, &out[j].box) <= 16384u);
        }
    }
}

static void test_decimated_region(void)
{
    fill(30u);
    rect8(20, 30, 100, 60, 200u);   // 100 x 60 car -> 150 x 120 region
    vd_detector_cfg_t c = small_cfg();
    c.max_region_w = 50u;
    c.max_region_h = 40u;
    init_or_fail(&c);
    vd_frame_t f = frame8();
    vd_detection_t out[4];
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_TRUE((out[0].flags & VD_DET_FLAG_DECIMATED) != 0u);
    TEST_ASSERT_EQUAL_UINT32(1u, g_det.stats.decimated);
    TEST_ASSERT_INT_WITHIN(3, 20, out[0].box.x);
    TEST_ASSERT_INT_WITHIN(3, 30, out[0].box.y);
    TEST_ASSERT_INT_WITHIN(6, 100, out[0].box.w);
    TEST_ASSERT_INT_WITHIN(6, 60, out[0].box.h);
}

static uint32_t g_clock;
static uint32_t fake_clock(void *user)
{
    (void)user;
    g_clock += 7u;
    return g_clock;
}

static void test_clock_callback_times_stages(void)
{
    fill(40u);
    car8(20, 30, 180u);
    vd_detector_cfg_t c = small_cfg();
    c.clock_us = fake_clock;
    g_clock = UINT32_MAX - 20u;   // wraps during the run
    init_or_fail(&c);
    vd_frame_t f = frame8();
    vd_detection_t out[4];
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    const vd_detector_stats_t *s = vd_detector_last_stats(&g_det);
    TEST_ASSERT_EQUAL_UINT32(7u, s->time_us[VD_DET_STAGE_THRESHOLD]);
    TEST_ASSERT_EQUAL_UINT32(7u, s->time_us[VD_DET_STAGE_REFINE]);
    TEST_ASSERT_EQUAL_UINT32(7u, s->time_us[VD_DET_STAGE_CONTOUR]);
    uint32_t sum = 0u;
    for (int i = 0; i < VD_DET_STAGE_TOTAL; i++) {
        sum += s->time_us[i];
    }
    TEST_ASSERT_TRUE(s->time_us[VD_DET_STAGE_TOTAL] >= sum);
}

static void test_temporal_confirm_and_recover(void)
{
    vd_detector_cfg_t c = small_cfg();
    c.temporal = true;
    init_or_fail(&c);
    vd_frame_t f = frame8();
    vd_detection_t out[4];
    size_t n = 0u;
    uint32_t id = 0u;
    for (int t = 0; t < 3; t++) {
        fill(40u);
        car8(20 + 2 * t, 30, 180u);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
        TEST_ASSERT_EQUAL_size_t(1u, n);
        TEST_ASSERT_EQUAL_UINT8(t < 2 ? VD_TRACK_NEW : VD_TRACK_CONFIRMED, out[0].state);
        if (t == 0) {
            id = out[0].track_id;
        }
        TEST_ASSERT_EQUAL_UINT32(id, out[0].track_id);
    }
    // t = 3: the car cools below the hot threshold (body 120, tyres 150 -> the
    // tyres alone are 2 x 30 px < 120): missed by the detector, found again by
    // the recovery search in the grey frame.
    fill(40u);
    car8(26, 30, 119u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_UINT32(0u, g_det.stats.verified);
    TEST_ASSERT_EQUAL_size_t(1u, n);
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_RECOVERED, out[0].state);
    TEST_ASSERT_TRUE((out[0].flags & VD_DET_FLAG_RECOVERED) != 0u);
    TEST_ASSERT_EQUAL_UINT32(id, out[0].track_id);
    TEST_ASSERT_EQUAL_UINT32(1u, g_det.stats.recovered);
    // S_C is equal at every offset that contains the whole car, so S_S keeps
    // the last box (x = 24): the paper's similarity has no motion model.
    TEST_ASSERT_INT_WITHIN(4, 26, out[0].box.x);
    // The car is gone: no recovery (background has no edges).
    fill(40u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, &f, out, 4, &n));
    TEST_ASSERT_EQUAL_size_t(0u, n);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_defaults_zeroed_equals_explicit);
    RUN_TEST(test_car_kept_lamp_and_pole_rejected);
    RUN_TEST(test_two_cars_and_nothing);
    RUN_TEST(test_u16_radiometric);
    RUN_TEST(test_adaptive_threshold_for_dark_agc_frames);
    RUN_TEST(test_workspace_contract);
    RUN_TEST(test_workspace_size_640x512);
    RUN_TEST(test_run_budget_overflow);
    RUN_TEST(test_bad_configs);
    RUN_TEST(test_bad_run_arguments);
    RUN_TEST(test_capacity_overflow_reported);
    RUN_TEST(test_overlapping_candidates_suppressed);
    RUN_TEST(test_decimated_region);
    RUN_TEST(test_clock_callback_times_stages);
    RUN_TEST(test_temporal_confirm_and_recover);
    return UNITY_END();
}
