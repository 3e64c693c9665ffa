// SPDX-License-Identifier: MIT
// Unit tests of the detector's CNN source (VD_DETECTOR_SRC_CNN) with a hand-made network whose output is known.
//
// The network, written here as a version-3 .vdm (docs/model-format.md; the
// same layout as tests/unit/test_cnn.c's writer, reduced to what this needs):
// two 2x2 max-pools (alignment 4, out_stride 4), then a 1x1 convolution to the
// five head channels with identity requantisation:
//   heatmap = pixel - 128 of the brightest half-resolution pixel of the 4x4 cell,
//   width, height, offset x, offset y = constants (the bias; weight 0).
// With the decode table score = (v + 128) * 128, size = (v + 128) * 128 Q8
// and offset = clamp(4 (v + 128) - 256, -256, 512) Q8, a box's score_q8 is
// exactly that half-resolution pixel, and with the default constants (size 8
// network px, offset 0.5 cell) the box of cell (cx, cy) is the 16 x 16 frame
// square at (8 cx - 4, 8 cy - 4), clipped to the frame.
#include "unity.h"
#include "testutil.h"

#include <stdbool.h>
#include <string.h>

#include "vd/detector.h"
#include "vd/resample.h"
#include "core/crc32.h"
#include "models/cnn/cnn_internal.h"   // the run record (vd_cnn_plan_t) a pair parks
#include "../data/dbn_golden.h"

void setUp(void) {}
void tearDown(void) {}

#define MW 96u
#define MH 80u

static uint8_t g_px[MH][MW];
static uint16_t g_px16[MH][MW];
static vd_detector_t g_det;
static uint64_t g_ws[2u * 1024u * 1024u / 8u];   // 2 MiB, aligned
static vd_detection_t g_out[64];

// ------------------------------------------------------------ the network

// Head constants (int8 logits; see the file comment for what they decode to).
typedef struct net {
    int8_t size_w, size_h, off_x, off_y;
    int8_t thr;            // header threshold
    uint16_t max_peaks;
    bool score_one;        // top score (logit 127) 32768 instead of 32640
    bool score_half;       // scores (v + 128) * 128 + 64: exactly half a Q8 step above
} net_t;

#define SIZE_8PX (-112)    // (v + 128) * 128 Q8 = 2048 = 8 network px
#define OFF_HALF (-32)     // 4 (v + 128) - 256 = 128 Q8 = half a cell (the centre)
#define OFF_2CELLS 64      // 512 Q8 = two cells

static net_t net_default(void)
{
    net_t n = {SIZE_8PX, SIZE_8PX, OFF_HALF, OFF_HALF, 0, 100u, false, false};
    return n;
}

static union {
    uint64_t align;
    uint8_t b[8192];
} g_blob;
static vd_cnn_model_t g_cnn;

// One layer-table entry; arrays at w/bias/mult/shift (0 = none).
static void entry(uint8_t *e, uint8_t op, uint8_t in, uint16_t cout, int8_t zp, uint32_t w, uint32_t bias,
                  uint32_t mult, uint32_t shift)
{
    e[0] = op;
    e[1] = 1u;
    e[2] = in;
    tu_wr16(e + 4, 1u);
    tu_wr16(e + 6, cout);
    e[8] = (uint8_t)zp;
    e[9] = 0x80u;   // act_min -128
    e[10] = 0x7Fu;  // act_max 127
    tu_wr32(e + 12, w);
    tu_wr32(e + 16, bias);
    tu_wr32(e + 20, mult);
    tu_wr32(e + 24, shift);
}

static union {
    uint64_t align;
    uint8_t b[8192];
} g_blob2;
static vd_cnn_model_t g_cnn2;   // cfg.cnn_model2 of the pair tests

// Writes the network into blob b and loads it into *m.
static void net_load_into(const net_t *n, uint8_t *b, vd_cnn_model_t *m)
{
    const uint32_t w = 224u, bias = 232u, mult = 252u, shift = 272u, dec = 280u;
    const uint32_t total = dec + 5u * 256u * 4u;
    memset(b, 0, total);
    memcpy(b, "VDMF", 4);
    tu_wr16(b + 4, 3u);
    tu_wr16(b + 6, 128u);
    tu_wr32(b + 8, total);
    b[16] = 2u;        // kind: CNN
    b[17] = 0u;        // input_norm: pixel - 128
    b[18] = 3u;        // layers
    b[19] = 5u;        // head channels
    tu_wr16(b + 20, 16u); // nominal input 16 x 16
    tu_wr16(b + 22, 16u);
    b[30] = 0x80u;     // input zero point -128
    b[31] = 4u;        // out_stride
    tu_wr32(b + 32, 128u);
    tu_wr32(b + 36, dec);
    b[40] = (uint8_t)n->thr;
    tu_wr16(b + 42, n->max_peaks);
    memcpy(b + 48, "det_test", 8);
    entry(b + 128, 4u, 0u, 1u, -128, 0u, 0u, 0u, 0u);   // MAXPOOL2
    entry(b + 160, 4u, 1u, 1u, -128, 0u, 0u, 0u, 0u);   // MAXPOOL2
    entry(b + 192, 3u, 2u, 5u, 0, w, bias, mult, shift); // PW1X1 1 -> 5
    b[w] = 1u;   // heatmap weight; the other four are 0
    const int32_t bs[5] = {-128, n->size_w, n->size_h, n->off_x, n->off_y};
    for (uint32_t o = 0u; o < 5u; o++) {
        tu_wr32(b + bias + 4u * o, (uint32_t)bs[o]);
        tu_wr32(b + mult + 4u * o, 1u << 30);   // identity requantisation: mult 2^30, shift 1
        b[shift + o] = 1u;
    }
    for (uint32_t i = 0u; i < 256u; i++) {
        const int32_t off = 4 * (int32_t)i - 256;
        tu_wr32(b + dec + 4u * i, i * 128u + (n->score_half ? 64u : 0u));
        tu_wr32(b + dec + 4u * (256u + i), i * 128u);
        tu_wr32(b + dec + 4u * (512u + i), i * 128u);
        tu_wr32(b + dec + 4u * (768u + i), (uint32_t)(off > 512 ? 512 : off));
        tu_wr32(b + dec + 4u * (1024u + i), (uint32_t)(off > 512 ? 512 : off));
    }
    if (n->score_one) {
        tu_wr32(b + dec + 4u * 255u, 32768u);
    }
    tu_wr32(b + 12, vd__crc32(0u, b + 16, total - 16u));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_load(m, b, total));
    TEST_ASSERT_EQUAL_UINT32(4u, m->align);
}

// Writes the network into g_blob and loads it into g_cnn.
static void net_load(const net_t *n)
{
    net_load_into(n, g_blob.b, &g_cnn);
}

// ------------------------------------------------------------ frames

static void fill(uint8_t v)
{
    memset(g_px, v, sizeof(g_px));
}

static void rect8(uint32_t x, uint32_t y, uint32_t w, uint32_t h, uint8_t v)
{
    for (uint32_t j = y; j < y + h; j++) {
        for (uint32_t i = x; i < x + w; i++) {
            g_px[j][i] = v;
        }
    }
}

// A frame view of the top-left w x h of g_px (row stride MW).
static vd_frame_t frame8(uint32_t w, uint32_t h)
{
    vd_frame_t f = {g_px, w, h, MW, VD_PIX_U8, 0, 0};
    return f;
}

static vd_detector_cfg_t cnn_cfg(void)
{
    vd_detector_cfg_t c;
    memset(&c, 0, sizeof(c));
    c.max_width = MW;
    c.max_height = MH;
    c.sources = VD_DETECTOR_SRC_CNN;
    c.cnn_model = &g_cnn;
    return c;
}

static void init_or_fail(const vd_detector_cfg_t *c, const vd_dbn_model_t *dbn)
{
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(c, dbn, &bytes));
    TEST_ASSERT_TRUE(bytes <= sizeof(g_ws));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_init(&g_det, c, dbn, g_ws, bytes));
}

static size_t run_ok(const vd_frame_t *f)
{
    size_t n = 99u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det, f, g_out, 64u, &n));
    return n;
}

static void expect_box(const vd_detection_t *d, int32_t x, int32_t y, int32_t w, int32_t h, uint8_t score)
{
    TEST_ASSERT_EQUAL_INT32(x, d->box.x);
    TEST_ASSERT_EQUAL_INT32(y, d->box.y);
    TEST_ASSERT_EQUAL_INT32(w, d->box.w);
    TEST_ASSERT_EQUAL_INT32(h, d->box.h);
    TEST_ASSERT_EQUAL_UINT8(score, d->score_q8);
}

// ------------------------------------------------------------ tests

// One bright 2x2 block: half-resolution pixel (200 + 200 + 201 + 201 + 2) >> 2
// = 201 (200.5 rounded half up) in cell (3, 2).
// The default network and the block: 200 over 201 at frame (26, 18)-(27, 19) on 20.
// The default network loaded and a flat frame of 20 (every logit below the threshold).
static net_t flat_scene(void)
{
    net_t n = net_default();
    net_load(&n);
    fill(20u);
    return n;
}

static net_t block_scene(void)
{
    net_t n = flat_scene();
    rect8(26u, 18u, 2u, 1u, 200u);
    rect8(26u, 19u, 2u, 1u, 201u);
    return n;
}

static void test_box_position_score_source(void)
{
    net_t n = block_scene();
    vd_detector_cfg_t c = cnn_cfg();
    init_or_fail(&c, NULL);
    vd_frame_t f = frame8(64u, 48u);
    TEST_ASSERT_EQUAL_size_t(1u, run_ok(&f));
    const vd_detection_t *d = &g_out[0];
    expect_box(d, 20, 12, 16, 16, 201u);
    TEST_ASSERT_EQUAL_INT32(d->box.x, d->candidate.x);
    TEST_ASSERT_EQUAL_INT32(d->box.w, d->candidate.w);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_CNN, d->source);
    TEST_ASSERT_EQUAL_UINT8(0u, d->flags);   // not UNVERIFIED: the network scored it
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_NONE, d->state);
    const vd_detector_stats_t *s = vd_detector_last_stats(&g_det);
    TEST_ASSERT_EQUAL_UINT32(1u, s->cnn_boxes);
    TEST_ASSERT_EQUAL_UINT32(1u, s->cand_cnn);
    TEST_ASSERT_EQUAL_UINT32(1u, s->verified);
    TEST_ASSERT_EQUAL_UINT32(0u, s->components);   // the hot-spot source is off
    TEST_ASSERT_EQUAL_UINT32(1u, s->detections);
    // A flat frame: every logit -108 is below the header threshold 0.
    fill(20u);
    TEST_ASSERT_EQUAL_size_t(0u, run_ok(&f));
    TEST_ASSERT_EQUAL_UINT32(0u, vd_detector_last_stats(&g_det)->cnn_boxes);
    // Q15 -> Q8 rounds half up and saturates: with the top score 1.0 (32768,
    // which would be 256 in Q8), pixel 255 scores 255; 254 * 128 = 32512 is 254.
    n.score_one = true;
    net_load(&n);
    init_or_fail(&c, NULL);
    rect8(26u, 18u, 2u, 2u, 255u);
    rect8(50u, 34u, 2u, 2u, 254u);
    TEST_ASSERT_EQUAL_size_t(2u, run_ok(&f));
    expect_box(&g_out[0], 20, 12, 16, 16, 255u);
    expect_box(&g_out[1], 44, 28, 16, 16, 254u);
    // Half a step rounds up: 201 * 128 + 64 is 201.5 in Q8 -> 202.
    n.score_one = false;
    n.score_half = true;
    net_load(&n);
    init_or_fail(&c, NULL);
    fill(20u);
    rect8(26u, 18u, 2u, 2u, 201u);
    TEST_ASSERT_EQUAL_size_t(1u, run_ok(&f));
    expect_box(&g_out[0], 20, 12, 16, 16, 202u);
}

// Spots 150 (cell (2, 2)) and 220 (cell (9, 7)) for cnn_score_thr_q15.
static void two_spots(void)
{
    fill(20u);
    rect8(18u, 18u, 2u, 2u, 150u);
    rect8(74u, 58u, 2u, 2u, 220u);
}

static void test_score_threshold(void)
{
    net_t n = net_default();
    net_load(&n);
    two_spots();
    vd_frame_t f = frame8(MW, MH);
    static const uint16_t thr[4] = {0u, 150u * 128u, 150u * 128u + 1u, 32768u};
    static const size_t want[4] = {2u, 2u, 1u, 0u};
    for (uint32_t k = 0u; k < 4u; k++) {
        vd_detector_cfg_t c = cnn_cfg();
        c.cnn_score_thr_q15 = thr[k];
        init_or_fail(&c, NULL);
        TEST_ASSERT_EQUAL_size_t(want[k], run_ok(&f));
        if (want[k] >= 1u) {
            expect_box(&g_out[0], 68, 52, 16, 16, 220u);   // best first
        }
        if (want[k] == 2u) {
            expect_box(&g_out[1], 12, 12, 16, 16, 150u);
        }
    }
    // A threshold below the header's lets more peaks through: 1/32768 is
    // logit -127, so the background plateau's first cell (0, 0) (score 20; no
    // spot next to it) is a peak too, its box clamped at the frame's corner.
    vd_detector_cfg_t c = cnn_cfg();
    c.cnn_score_thr_q15 = 1u;
    init_or_fail(&c, NULL);
    TEST_ASSERT_EQUAL_size_t(3u, run_ok(&f));
    expect_box(&g_out[2], 0, 0, 12, 12, 20u);
    // The header's threshold itself: 100 (pixel 228) keeps neither spot.
    n.thr = 100;
    net_load(&n);
    c = cnn_cfg();
    init_or_fail(&c, NULL);
    TEST_ASSERT_EQUAL_size_t(0u, run_ok(&f));
}

// Odd frame 61 x 45: the plane is 30 x 22 (the last odd column and row are
// not read), padded to 32 x 24 by repeating column 29 and row 21; the box of
// the corner spot is clipped to the frame.
static void test_odd_frame_padding_and_clipping(void)
{
    net_t n = net_default();
    net_load(&n);
    fill(20u);
    rect8(58u, 42u, 2u, 2u, 230u);
    rect8(60u, 0u, 1u, 45u, 255u);   // column 60 and row 44: outside the 2x2 grid
    rect8(0u, 44u, 61u, 1u, 255u);
    vd_detector_cfg_t c = cnn_cfg();
    init_or_fail(&c, NULL);
    vd_frame_t f = frame8(61u, 45u);
    TEST_ASSERT_EQUAL_size_t(1u, run_ok(&f));
    expect_box(&g_out[0], 52, 36, 9, 9, 230u);   // 16 x 16 at (52, 36), clipped to 61 x 45
    // The network input itself: exact 2x2 means rounded half up, then the
    // last real column and row repeated, on a pseudo-random frame. The
    // detector makes these rows on demand (no plane is stored), so the head
    // it leaves in its workspace (white box: the overlay after a CNN-only
    // run) is compared with a whole-plane run on the expected plane. The head
    // is a ring (VD_CNN_HEAD_RING): its last rows are there, at row y % ring
    // height; the bottom rows are where the padding is.
    uint32_t seed = 12345u;
    for (uint32_t y = 0u; y < 45u; y++) {
        for (uint32_t x = 0u; x < 61u; x++) {
            g_px[y][x] = (uint8_t)(tu_rand(&seed) & 0xFFu);
        }
    }
    (void)run_ok(&f);
    static uint8_t plane[24u * 32u];
    for (uint32_t y = 0u; y < 24u; y++) {
        for (uint32_t x = 0u; x < 32u; x++) {
            const uint32_t sx = (x < 30u ? x : 29u) * 2u;
            const uint32_t sy = (y < 22u ? y : 21u) * 2u;
            const uint32_t sum = (uint32_t)g_px[sy][sx] + g_px[sy][sx + 1u] + g_px[sy + 1u][sx] +
                                 g_px[sy + 1u][sx + 1u];
            plane[y * 32u + x] = (uint8_t)((sum + 2u) >> 2);
        }
    }
    vd_cnn_output_t got, want;
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_tensor(&g_cnn, g_det.cnn_ws, g_det.cnn_ws_bytes, 32u, 24u, 3u, &got));
    static uint64_t ws2[4096];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run(&g_cnn, plane, 32u, 24u, 32u, ws2, sizeof ws2, &want));
    const vd_cnn_plan_t *p = (const vd_cnn_plan_t *)g_det.cnn_ws;
    const uint32_t rr = p->rows[3];
    TEST_ASSERT_TRUE(rr >= 3u && rr < want.h);
    const size_t rb = (size_t)want.w * want.c;
    const int8_t *ring = (const int8_t *)g_det.cnn_ws + p->off[vd_cnn_item_of_tensor(3u)];
    for (uint32_t y = want.h - rr; y < want.h; y++) {
        TEST_ASSERT_EQUAL_INT8_ARRAY(want.data + y * rb, ring + (y % rr) * rb, rb);
    }
    // A box wholly in the padding is dropped: with offsets of two cells the
    // box of cell (6, 2) (half-resolution columns 24..27: real column 24 and
    // its copies) lies right of a 50-pixel frame.
    n.off_x = OFF_2CELLS;
    net_load(&n);
    fill(20u);
    rect8(48u, 20u, 2u, 2u, 230u);
    init_or_fail(&c, NULL);
    f = frame8(50u, 40u);
    TEST_ASSERT_EQUAL_size_t(0u, run_ok(&f));
    TEST_ASSERT_EQUAL_UINT32(1u, vd_detector_last_stats(&g_det)->cnn_boxes);
    TEST_ASSERT_EQUAL_UINT32(0u, vd_detector_last_stats(&g_det)->cand_cnn);
    // Frames under 2 x 2 pixels have no half-resolution plane: nothing, VD_OK.
    n.off_x = OFF_HALF;
    net_load(&n);
    init_or_fail(&c, NULL);
    f = frame8(1u, 40u);
    TEST_ASSERT_EQUAL_size_t(0u, run_ok(&f));
    f = frame8(40u, 1u);
    TEST_ASSERT_EQUAL_size_t(0u, run_ok(&f));
    // A detector sized for 1-pixel-wide frames never runs the network.
    c.max_width = 1u;
    c.max_region_w = 1u;
    init_or_fail(&c, NULL);
    f = frame8(1u, 40u);
    TEST_ASSERT_EQUAL_size_t(0u, run_ok(&f));
}

// 16-bit frames: the rounded raw 2x2 mean through the grey map. With the
// default calibration and grey range (27315..32415 ck), raw 27315 + 20 k is grey k.
static void test_u16_frame(void)
{
    net_t n = net_default();
    net_load(&n);
    vd_calib_grey_t map;
    const vd_calib_t cal = {65536, 0};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&map, &cal, 27315, 32415));
    TEST_ASSERT_EQUAL_UINT8(20u, vd_calib_grey_u8(&map, 27315u + 20u * 20u));
    TEST_ASSERT_EQUAL_UINT8(201u, vd_calib_grey_u8(&map, 27315u + 20u * 201u));
    for (uint32_t y = 0u; y < MH; y++) {
        for (uint32_t x = 0u; x < MW; x++) {
            g_px16[y][x] = (uint16_t)(27315u + 20u * 20u);
        }
    }
    for (uint32_t y = 18u; y < 20u; y++) {
        for (uint32_t x = 26u; x < 28u; x++) {
            g_px16[y][x] = (uint16_t)(27315u + 20u * 201u);
        }
    }
    vd_detector_cfg_t c = cnn_cfg();
    init_or_fail(&c, NULL);
    vd_frame_t f = {g_px16, 64u, 48u, MW * 2u, VD_PIX_U16, 0, 0};
    TEST_ASSERT_EQUAL_size_t(1u, run_ok(&f));
    expect_box(&g_out[0], 20, 12, 16, 16, 201u);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_CNN, g_out[0].source);
}

// ctx: the configuration, or NULL for the network + hot spots with temporal analysis.
static vd_status_t ws_run(void *ws, size_t bytes, void *ctx)
{
    vd_detector_cfg_t c = cnn_cfg();
    c.sources |= VD_DETECTOR_SRC_HOTSPOT;
    c.temporal = true;
    if (ctx != NULL) {
        c = *(const vd_detector_cfg_t *)ctx;
    }
    vd_detector_t det;
    vd_status_t st = vd_detector_init(&det, &c, NULL, ws, bytes);
    if (st != VD_OK) {
        return st;
    }
    vd_frame_t f = frame8(MW, MH);
    size_t n = 0u;
    for (int i = 0; i < 3; i++) {
        st = vd_detector_run(&det, &f, g_out, 64u, &n);
        if (st != VD_OK) {
            return st;
        }
    }
    return (n == 2u) ? VD_OK : VD_ERR_STATE;
}

static void test_workspace_contract(void)
{
    net_t n = net_default();
    net_load(&n);
    two_spots();
    vd_detector_cfg_t c = cnn_cfg();
    c.sources |= VD_DETECTOR_SRC_HOTSPOT;
    c.temporal = true;
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &bytes));
    tu_check_workspace_contract(bytes, ws_run, NULL);
    // The network's share: its streamed workspace (input rows made on
    // demand, no plane) + 100 boxes, inside the overlay (which it extends
    // only when larger than the other stages' needs).
    size_t cnn = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&g_cnn, 48u, 40u, VD_CNN_STREAM, &cnn));
    TEST_ASSERT_TRUE(bytes >= cnn + 100u * sizeof(vd_cnn_box_t));
    size_t base = 0u;
    c.sources = VD_DETECTOR_SRC_HOTSPOT;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &base));
    TEST_ASSERT_TRUE(bytes >= base);
    // The network alone needs no components table (28 B x 256, the default
    // max_components) and no histogram (256 x 4 B): hand-worked 7168 + 1024,
    // both multiples of 8, so the slices' alignment adds nothing.
    size_t alone = 0u;
    c.sources = VD_DETECTOR_SRC_CNN;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &alone));
    TEST_ASSERT_EQUAL_size_t(bytes - 8192u, alone);
    tu_check_workspace_contract(alone, ws_run, &c);   // and it runs in exactly that
    // A larger frame: the network input and workspace grow with it.
    c = cnn_cfg();
    c.max_width = 640u;
    c.max_height = 512u;
    size_t big = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &big));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&g_cnn, 320u, 256u, VD_CNN_STREAM, &cnn));
    TEST_ASSERT_TRUE(big >= cnn);
}

static void test_bad_configs(void)
{
    net_t n = net_default();
    net_load(&n);
    size_t b = 0u;
    vd_detector_cfg_t c = cnn_cfg();
    c.cnn_model = NULL;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_init(&g_det, &c, NULL, g_ws, sizeof(g_ws)));
    vd_detector_cfg_t r = c;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_cfg_resolve(&r));
    // Without the source the model pointer is ignored.
    c.sources = VD_DETECTOR_SRC_HOTSPOT;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b));
    c = cnn_cfg();
    c.cnn_score_thr_q15 = 32769u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &b));
    c = cnn_cfg();
    c.cnn_rescore = 2u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &b));
    c.cnn_rescore = 1u;   // re-scoring needs a DBN model
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_init(&g_det, &c, NULL, g_ws, sizeof(g_ws)));
    c = cnn_cfg();
    c.cnn_flip = 2u;   // 0 or 1, checked even without the CNN source
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_init(&g_det, &c, NULL, g_ws, sizeof(g_ws)));
    r = c;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_cfg_resolve(&r));
    c.sources = VD_DETECTOR_SRC_HOTSPOT;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &b));
    c.cnn_flip = 1u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b));
    c = cnn_cfg();
    c.sources = 0x10u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &b));
    // A model struct that vd_cnn_load did not fill.
    vd_cnn_model_t zero;
    memset(&zero, 0, sizeof zero);
    c = cnn_cfg();
    c.cnn_model = &zero;
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_detector_workspace_size(&c, NULL, &b));
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_detector_init(&g_det, &c, NULL, g_ws, sizeof(g_ws)));
    // "all" stays the paper pipeline's three sources.
    TEST_ASSERT_EQUAL_UINT32(0x07u, VD_DETECTOR_SRC_ALL);
    TEST_ASSERT_EQUAL_UINT32(0u, VD_DETECTOR_SRC_ALL & VD_DETECTOR_SRC_CNN);
}

// CNN boxes lead the merged list; a hot spot that duplicates one is dropped
// (dedup_iou), others follow; the budget is shared.
typedef struct cand_log {
    uint8_t source[16];
    size_t n;
} cand_log_t;

static cand_log_t g_log;

static void log_candidate(void *user, const vd_detection_t *cand)
{
    cand_log_t *l = (cand_log_t *)user;
    if (l->n < 16u) {
        l->source[l->n++] = cand->source;
    }
}

// A hot car (30 x 20, body 200, tyres 230) at (20, 30) and a 2x2 spot of
// 250 at (sx, sy); the network keeps only cells >= 240 (the spot).
static void car_and_spot(uint32_t sx, uint32_t sy)
{
    fill(40u);
    rect8(20u, 30u, 30u, 20u, 200u);
    rect8(22u, 45u, 6u, 5u, 230u);
    rect8(42u, 45u, 6u, 5u, 230u);
    rect8(sx, sy, 2u, 2u, 250u);
}

static void test_merge_with_hotspots(void)
{
    net_t n = net_default();
    net_load(&n);
    vd_detector_cfg_t c = cnn_cfg();
    c.sources = VD_DETECTOR_SRC_CNN | VD_DETECTOR_SRC_HOTSPOT;
    c.cnn_score_thr_q15 = 240u * 128u;
    c.on_candidate = log_candidate;
    c.candidate_user = &g_log;
    vd_frame_t f = frame8(MW, MH);
    // Spot away from the car: both kept; the CNN box is first in the list.
    car_and_spot(80u, 8u);
    init_or_fail(&c, NULL);
    memset(&g_log, 0, sizeof g_log);
    TEST_ASSERT_EQUAL_size_t(2u, run_ok(&f));
    TEST_ASSERT_EQUAL_size_t(2u, g_log.n);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_CNN, g_log.source[0]);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_HOTSPOT, g_log.source[1]);
    // After suppression: the unverified hot spot (255) first, the CNN box (250).
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_HOTSPOT, g_out[0].source);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_FLAG_UNVERIFIED, g_out[0].flags);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_CNN, g_out[1].source);
    expect_box(&g_out[1], 76, 4, 16, 16, 250u);
    const vd_detector_stats_t *s = vd_detector_last_stats(&g_det);
    TEST_ASSERT_EQUAL_UINT32(1u, s->cand_cnn);
    TEST_ASSERT_EQUAL_UINT32(1u, s->cand_hotspot);
    TEST_ASSERT_EQUAL_UINT32(0u, s->deduplicated);
    // Spot inside the car and any overlap a duplicate: the hot spot is dropped.
    car_and_spot(34u, 38u);
    c.dedup_iou_q15 = 1u;
    init_or_fail(&c, NULL);
    TEST_ASSERT_EQUAL_size_t(1u, run_ok(&f));
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_CNN, g_out[0].source);
    s = vd_detector_last_stats(&g_det);
    TEST_ASSERT_EQUAL_UINT32(1u, s->refined);
    TEST_ASSERT_EQUAL_UINT32(0u, s->cand_hotspot);
    TEST_ASSERT_EQUAL_UINT32(1u, s->deduplicated);
    // One candidate in all: the CNN box takes it, the hot spot overflows.
    car_and_spot(80u, 8u);
    c.dedup_iou_q15 = 0u;
    c.max_candidates = 1u;
    c.max_detections = 1u;
    init_or_fail(&c, NULL);
    size_t nd = 0u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_detector_run(&g_det, &f, g_out, 64u, &nd));
    TEST_ASSERT_EQUAL_size_t(1u, nd);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_CNN, g_out[0].source);
    TEST_ASSERT_EQUAL_UINT32(1u, vd_detector_last_stats(&g_det)->overflow_candidates);
    // CNN boxes beyond the budget: the best is kept, the other counted.
    two_spots();
    c = cnn_cfg();
    c.max_candidates = 1u;
    c.max_detections = 1u;
    init_or_fail(&c, NULL);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_detector_run(&g_det, &f, g_out, 64u, &nd));
    TEST_ASSERT_EQUAL_size_t(1u, nd);
    expect_box(&g_out[0], 68, 52, 16, 16, 220u);
    TEST_ASSERT_EQUAL_UINT32(2u, vd_detector_last_stats(&g_det)->cnn_boxes);
    TEST_ASSERT_EQUAL_UINT32(1u, vd_detector_last_stats(&g_det)->overflow_candidates);
}

// cnn_rescore: the DBN (the golden 8x8 model) scores the whole box.
static void test_rescore_with_dbn(void)
{
    net_t n = net_default();
    net_load(&n);
    vd_dbn_model_t dbn;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_load(&dbn, golden_model.bytes, sizeof golden_model.bytes));
    fill(20u);
    rect8(26u, 18u, 2u, 2u, 201u);
    rect8(22u, 14u, 3u, 9u, 90u);   // some texture under the box
    vd_frame_t f = frame8(64u, 48u);
    // The expected DBN score of the box (20, 12, 16, 16) sampled at 8 x 8.
    vd_view_u8_t v = {&g_px[0][0], 64u, 48u, MW};
    const vd_rect_t box = {20, 12, 16, 16};
    uint8_t sample[64];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_resample_u8(&v, &box, sample, 8u, 8u));
    size_t dbn_bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_workspace_size(&dbn, &dbn_bytes));
    void *dws = tu_guarded_alloc(1, dbn_bytes);
    uint8_t want = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_classify(&dbn, sample, dws, dbn_bytes, &want));
    tu_guard_check(1);
    tu_guarded_free(1);
    vd_detector_cfg_t c = cnn_cfg();
    c.cnn_rescore = 1u;
    c.score_thr_q8 = 1u;
    init_or_fail(&c, &dbn);
    TEST_ASSERT_EQUAL_size_t(1u, run_ok(&f));
    expect_box(&g_out[0], 20, 12, 16, 16, want);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_CNN, g_out[0].source);
    TEST_ASSERT_EQUAL_UINT8(0u, g_out[0].flags);
    // The DBN must accept it.
    if (want < 255u) {
        c.score_thr_q8 = (uint8_t)(want + 1u);
        init_or_fail(&c, &dbn);
        TEST_ASSERT_EQUAL_size_t(0u, run_ok(&f));
        TEST_ASSERT_EQUAL_UINT32(1u, vd_detector_last_stats(&g_det)->cand_cnn);
    }
    // Without re-scoring the DBN model is not used for CNN boxes.
    c.cnn_rescore = 0u;
    init_or_fail(&c, &dbn);
    TEST_ASSERT_EQUAL_size_t(1u, run_ok(&f));
    expect_box(&g_out[0], 20, 12, 16, 16, 201u);
}

// ------------------------------------------------------------ cnn_flip

// Every merged candidate of a run, in list order (the observer sees them
// before verification; a CNN-only list is exactly the CNN source's output).
typedef struct cand_rec {
    vd_detection_t c[256];
    size_t n;
} cand_rec_t;

static cand_rec_t g_rec_a, g_rec_b, g_rec_c;

static void rec_candidate(void *user, const vd_detection_t *cand)
{
    cand_rec_t *l = (cand_rec_t *)user;
    TEST_ASSERT_TRUE(l->n < 256u);
    l->c[l->n++] = *cand;
}

// Runs f with cnn_flip = flip and records its candidates in *rec; returns the
// run's status (detections in g_out).
static vd_status_t run_recorded(vd_detector_cfg_t c, uint8_t flip, const vd_frame_t *f, cand_rec_t *rec,
                                vd_detector_stats_t *stats)
{
    c.cnn_flip = flip;
    c.on_candidate = rec_candidate;
    c.candidate_user = rec;
    rec->n = 0u;
    init_or_fail(&c, NULL);
    size_t nd = 0u;
    const vd_status_t st = vd_detector_run(&g_det, f, g_out, 64u, &nd);
    *stats = *vd_detector_last_stats(&g_det);
    return st;
}

static void expect_cand(const vd_detection_t *d, int32_t x, int32_t y, int32_t w, int32_t h, uint8_t score)
{
    expect_box(d, x, y, w, h, score);
    TEST_ASSERT_EQUAL_MEMORY(&d->box, &d->candidate, sizeof d->box);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_CNN, d->source);
    TEST_ASSERT_EQUAL_UINT8(0u, d->flags);
}

// Hand-worked geometry of the fusion tests. The network's width channel
// decodes to wb frame pixels (size logit wb - 128) and its x offset to d
// frame pixels right of the cell's left edge (offset logit 8 d - 64; the
// default -32 is d = 4, the centre), so decoding (rounding half up) gives
// cell c the box [8c + d - wb/2, 8c + d + wb/2) in the 2 nw wide network
// frame; rows stay as in the file comment ([8 cy - 4, 8 cy + 12)). A spot
// of value v at half-resolution (p, 9) (frame columns 2p, 2p + 1, rows 18,
// 19) is in cell (p >> 2, 2) of pass A and, the mirrored plane mapping x to
// hw - 1 - x, in cell ((hw - 1 - p) >> 2, 2) of pass B, whose box [x0, x1)
// goes back to [2 hw - x1, 2 hw - x0). Both rows are [12, 28). Scores:
// v * 128 in Q15 (score_q8 v). A flat background of 20 makes one more peak
// per pass (the plateau's first cell, (0, 0), score 2560), decoded only when
// the decode threshold is that low.
#define SPOT_ROW 18u
static void spot(uint32_t p, uint8_t v)
{
    rect8(2u * p, SPOT_ROW, 2u, 2u, v);
}

static uint16_t thr_q15_of_pixel(uint32_t v)
{
    return (uint16_t)(v * 128u);
}

// The scene of test_flip_fusion_hand_worked: network d = 5 (offset logit
// -24), spots O0 (p = 8) and O1 (p = 16) of 200 on a background of 20 in a
// 50 x 48 frame.
static vd_frame_t two_spot_scene(void)
{
    net_t n = net_default();
    n.off_x = -24;   // d = 5
    net_load(&n);
    fill(20u);
    spot(8u, 200u);
    spot(16u, 200u);
    return frame8(50u, 48u);
}

// Matched, unmatched A, leftover B, a tie on IoU, the threshold T on the
// fused score. Frame 50 x 48: hw = 25 (plane padded to 28, 7 cells), pass B
// cell of p: (24 - p) >> 2. Width 16, d = 5: A(c) = [8c - 3, 8c + 13), B(c')
// = [8c' - 3, 8c' + 13) mirrored back to [37 - 8c', 53 - 8c'). Spots O0 at p
// = 8 and O1 at p = 16, both 200 (score 25600):
//   A: O0 cell 2 [13, 29), O1 cell 4 [29, 45)  (equal logits: raster order)
//   B: O1 cell 2 [21, 37), O0 cell 4 [5, 21)   (the mirrored raster: O1 first)
// A0 = [13, 29) overlaps B0 = [21, 37) and B1 = [5, 21) by 8 columns each:
// IoU 128 / 384 = 10922 both, a tie >= 9830 -> the first in B's order, B0
// (O1's box, not O0's own): x0 = (13 + 21) >> 1 = 17, x1 = (29 + 37 + 1) >> 1
// = 33, rows (12 + 12) >> 1 = 12 and (28 + 28 + 1) >> 1 = 28: [17, 33) x [12,
// 28), score (25600 + 25600 + 1) >> 1 = 25600 (Q8 200). A1 = [29, 45) and the
// leftover B1 = [5, 21) do not overlap: A1 alone scores (25600 + 1) >> 1 =
// 12800 (Q8 100), then B1 likewise.
//   T = 19200 (150): decode at 2 T - 32768 = 5632 (pixel 44: no background
//     peaks); A1 and B1 (12800) fall below T although A1's own score 25600 is
//     above it: one candidate.
//   T = 12800 (100): decode at max(1, 25600 - 32768) = 1: the background
//     peaks join, A [0, 13) x [0, 12) and B [0, 13) -> [37, 50) x [0, 12),
//     unmatched, score 1280 < T: dropped. Candidates: the pair, A1, B1.
static void test_flip_fusion_hand_worked(void)
{
    vd_frame_t f = two_spot_scene();
    vd_detector_cfg_t c = cnn_cfg();
    vd_detector_stats_t s;
    c.cnn_score_thr_q15 = thr_q15_of_pixel(150u);
    TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 0u, &f, &g_rec_b, &s));   // one pass: A as it is
    TEST_ASSERT_EQUAL_size_t(2u, g_rec_b.n);
    expect_cand(&g_rec_b.c[0], 13, 12, 16, 16, 200u);
    expect_cand(&g_rec_b.c[1], 29, 12, 16, 16, 200u);
    TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 1u, &f, &g_rec_a, &s));
    TEST_ASSERT_EQUAL_size_t(1u, g_rec_a.n);
    expect_cand(&g_rec_a.c[0], 17, 12, 16, 16, 200u);
    TEST_ASSERT_EQUAL_UINT32(4u, s.cnn_boxes);
    TEST_ASSERT_EQUAL_UINT32(1u, s.cand_cnn);
    TEST_ASSERT_EQUAL_UINT32(1u, s.detections);
    c.cnn_score_thr_q15 = thr_q15_of_pixel(100u);
    TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 1u, &f, &g_rec_a, &s));
    TEST_ASSERT_EQUAL_size_t(3u, g_rec_a.n);
    expect_cand(&g_rec_a.c[0], 17, 12, 16, 16, 200u);   // A0 + B0
    expect_cand(&g_rec_a.c[1], 29, 12, 16, 16, 100u);   // A1 alone
    expect_cand(&g_rec_a.c[2], 5, 12, 16, 16, 100u);    // B1 left over
    TEST_ASSERT_EQUAL_UINT32(6u, s.cnn_boxes);          // 3 + 3 decoded, background included
    TEST_ASSERT_EQUAL_UINT32(3u, s.cand_cnn);
    TEST_ASSERT_EQUAL_UINT32(0u, s.overflow_candidates);
    // Suppression (IoU 0.5) as for any candidates: the overlaps are 4 columns.
    TEST_ASSERT_EQUAL_UINT32(0u, s.suppressed);
    TEST_ASSERT_EQUAL_UINT32(3u, s.detections);
    expect_box(&g_out[0], 17, 12, 16, 16, 200u);
    expect_box(&g_out[1], 29, 12, 16, 16, 100u);
    expect_box(&g_out[2], 5, 12, 16, 16, 100u);
}

// A match across objects with two different scores. Frame 50 x 48 again,
// width 16, d = 8: A(c) = [8c, 8c + 16), B(c') mirrored back to [34 - 8c',
// 50 - 8c'). Spot X at p = 12 (220, score 28160) and Y at p = 19 (180,
// 23040): in pass A they are in the adjacent cells 3 and 4, so only X is a
// peak, A0 = [24, 40); in pass B they are in cells 3 and 1, both peaks:
// B0 = X [10, 26), B1 = Y [26, 42). IoU(A0, B0) = 32 / 480 = 2184, IoU(A0, B1)
// = 224 / 288 = 25486: A0 takes B1. Fused: x0 = (24 + 26) >> 1 = 25, x1 = (40
// + 42 + 1) >> 1 = 41, score (28160 + 23040 + 1) >> 1 = 25600 (Q8 200). B0
// is left over: (28160 + 1) >> 1 = 14080, Q8 (14080 + 64) >> 7 = 110. T =
// 12800: the background boxes decode (1280 after fusion: dropped).
static void test_flip_fusion_two_scores(void)
{
    net_t n = net_default();
    n.off_x = 0;   // d = 8
    net_load(&n);
    fill(20u);
    spot(12u, 220u);
    spot(19u, 180u);
    vd_frame_t f = frame8(50u, 48u);
    vd_detector_cfg_t c = cnn_cfg();
    c.cnn_score_thr_q15 = thr_q15_of_pixel(100u);
    vd_detector_stats_t s;
    TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 1u, &f, &g_rec_a, &s));
    TEST_ASSERT_EQUAL_size_t(2u, g_rec_a.n);
    expect_cand(&g_rec_a.c[0], 25, 12, 16, 16, 200u);
    expect_cand(&g_rec_a.c[1], 10, 12, 16, 16, 110u);
    TEST_ASSERT_EQUAL_UINT32(5u, s.cnn_boxes);   // A: X, background; B: X, Y, background
    TEST_ASSERT_EQUAL_UINT32(2u, s.cand_cnn);
}

// The IoU bound VD_DETECTOR_CNN_FLIP_IOU_Q15 = 9830 is inclusive.
//   At it: frame 50 x 48, width 13 (logit -115), d = 1 (logit -56): cell c is
//   [8c + 1 - 6.5, 8c + 1 + 6.5) rounded half up = [8c - 5, 8c + 8). A spot
//   (200) at p = 9: A cell 2 [11, 24); B cell (24 - 9) >> 2 = 3 [19, 32) ->
//   [18, 31). Overlap 6 columns: IoU 96 / 320 = 0.3 exactly, Q15 9830.4 ->
//   9830: matched, [(11 + 18) >> 1, (24 + 31 + 1) >> 1) = [14, 28), score 200.
//   Just below: frame 64 x 48 (hw = 32), width 22 (logit -106), offset logit
//   19 (332 Q8, d = 10.375): cell c is [8c - 0.625, 8c + 21.375) rounded half
//   up = [8c - 1, 8c + 21). A spot (200) at p = 18: A cell 4 [31, 53); B cell
//   (31 - 18) >> 2 = 3 [23, 45) -> [19, 41). Overlap 10 columns: IoU 10 / 34 =
//   0.294, Q15 9637 < 9830: not matched, both at half score (Q8 100; T = 12800).
static void test_flip_iou_bound(void)
{
    net_t n = net_default();
    n.size_w = 13 - 128;
    n.off_x = -56;
    net_load(&n);
    fill(20u);
    spot(9u, 200u);
    vd_frame_t f = frame8(50u, 48u);
    vd_detector_cfg_t c = cnn_cfg();
    c.cnn_score_thr_q15 = thr_q15_of_pixel(100u);
    vd_detector_stats_t s;
    TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 1u, &f, &g_rec_a, &s));
    TEST_ASSERT_EQUAL_size_t(1u, g_rec_a.n);
    expect_cand(&g_rec_a.c[0], 14, 12, 14, 16, 200u);
    const vd_rect_t a = {11, 12, 13, 16}, b = {18, 12, 13, 16};
    TEST_ASSERT_EQUAL_UINT32(VD_DETECTOR_CNN_FLIP_IOU_Q15, vd_rect_iou_q15(&a, &b));
    n.size_w = 22 - 128;
    n.off_x = 19;
    net_load(&n);
    fill(20u);
    spot(18u, 200u);
    f = frame8(64u, 48u);
    TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 1u, &f, &g_rec_a, &s));
    TEST_ASSERT_EQUAL_size_t(2u, g_rec_a.n);
    expect_cand(&g_rec_a.c[0], 31, 12, 22, 16, 100u);
    expect_cand(&g_rec_a.c[1], 19, 12, 22, 16, 100u);
    const vd_rect_t a2 = {31, 12, 22, 16}, b2 = {19, 12, 22, 16};
    TEST_ASSERT_EQUAL_UINT32(9637u, vd_rect_iou_q15(&a2, &b2));
}

// The budget holds the fused boxes in their order (test_flip_fusion_hand_worked
// at T = 12800: the pair, A1, B1); those beyond it are counted as overflow
// (VD_ERR_CAPACITY), the ones below T are not.
static void test_flip_capacity(void)
{
    vd_frame_t f = two_spot_scene();
    for (uint16_t cap = 1u; cap <= 3u; cap++) {
        vd_detector_cfg_t c = cnn_cfg();
        c.cnn_score_thr_q15 = thr_q15_of_pixel(100u);
        c.max_candidates = cap;
        c.max_detections = cap;
        vd_detector_stats_t s;
        TEST_ASSERT_EQUAL_INT(cap < 3u ? VD_ERR_CAPACITY : VD_OK, run_recorded(c, 1u, &f, &g_rec_a, &s));
        TEST_ASSERT_EQUAL_size_t(cap, g_rec_a.n);
        TEST_ASSERT_EQUAL_UINT32(6u, s.cnn_boxes);
        TEST_ASSERT_EQUAL_UINT32(cap, s.cand_cnn);
        TEST_ASSERT_EQUAL_UINT32(3u - cap, s.overflow_candidates);
        expect_cand(&g_rec_a.c[0], 17, 12, 16, 16, 200u);
        if (cap >= 2u) {
            expect_cand(&g_rec_a.c[1], 29, 12, 16, 16, 100u);
        }
    }
}

// cnn_flip keeps both passes' boxes: max_peaks more in the CNN's part D of the
// overlay. Where D is the overlay's largest part (1 x 1 regions, one run,
// top-K 1024) the workspace grows by exactly that; elsewhere by at most that.
static vd_status_t ws_run_flip(void *ws, size_t bytes, void *ctx)
{
    vd_detector_t det;
    vd_status_t st = vd_detector_init(&det, (const vd_detector_cfg_t *)ctx, NULL, ws, bytes);
    if (st != VD_OK) {
        return st;
    }
    vd_frame_t f = frame8(50u, 48u);
    size_t n = 0u;
    st = vd_detector_run(&det, &f, g_out, 64u, &n);
    return (st == VD_OK && n == 3u) ? VD_OK : VD_ERR_STATE;
}

static void test_flip_workspace(void)
{
    net_t n = net_default();
    n.off_x = -24;
    n.max_peaks = 1024u;
    net_load(&n);
    fill(20u);
    spot(8u, 200u);
    spot(16u, 200u);
    vd_detector_cfg_t c = cnn_cfg();
    c.max_region_w = 1u;
    c.max_region_h = 1u;
    c.max_runs = 1u;
    c.cnn_score_thr_q15 = thr_q15_of_pixel(100u);
    size_t b0 = 0u, b1 = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b0));
    c.cnn_flip = 1u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b1));
    TEST_ASSERT_EQUAL_size_t(b0 + 1024u * sizeof(vd_cnn_box_t), b1);
    tu_check_workspace_contract(b1, ws_run_flip, &c);   // b1 - 1 fails, guards intact
    // The default plan at 96 x 80: the region buffers are the larger part.
    n.max_peaks = 100u;
    net_load(&n);
    c = cnn_cfg();
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b0));
    c.cnn_flip = 1u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b1));
    TEST_ASSERT_TRUE(b1 >= b0 && b1 - b0 <= 100u * sizeof(vd_cnn_box_t));
}

// ------------------------------------------------------------ cnn_model2

// Two networks fused (cfg.cnn_model2), hand-worked. Frame 50 x 48 (hw = 25,
// plane padded to 28), width 16. Network 1 d = 5: cell c is [8c - 3, 8c +
// 13); network 2 d = 16 (offset logit 64): [8c + 8, 8c + 24). Spots O0 (p =
// 8, cell 2) and O1 (p = 16, cell 4), both 200 (score 25600); rows [12, 28).
//   Network 1: A0 = O0 [13, 29), A1 = O1 [29, 45) (equal logits: raster).
//   Network 2: B0 = O0 [24, 40), B1 = O1 [40, 56) clipped to [40, 50).
//   A0: IoU with B0 5 / 27 (Q15 6068), with B1 0: unmatched, score (25600 +
//   1) >> 1 = 12800 (Q8 100). A1: IoU with B0 11 / 21 (17164), with B1 5 / 21
//   (7801): takes B0 (another object's box: the rule is geometric), x0 = (29
//   + 24) >> 1 = 26, x1 = (45 + 40 + 1) >> 1 = 43, score 25600 (Q8 200). B1
//   left over: 12800 (Q8 100).
//   T = 19200 (150): P = 2, both decode at 2 T - 32768 = 5632 (no background
//     peak): only the fused box reaches T.
//   T = 12800 (100): decode at max(1, 25600 - 32768) = 1: the background
//     peaks join (network 1 [0, 13), network 2 [8, 24), rows [0, 12): IoU
//     60 / 288, unmatched, 1280 < T: dropped). Candidates in order: A0, the
//     pair, B1.
static void test_pair_fusion_hand_worked(void)
{
    net_t n = net_default();
    n.off_x = -24;   // d = 5
    net_load(&n);
    net_t n2 = net_default();
    n2.off_x = 64;   // d = 16
    net_load_into(&n2, g_blob2.b, &g_cnn2);
    fill(20u);
    spot(8u, 200u);
    spot(16u, 200u);
    vd_frame_t f = frame8(50u, 48u);
    vd_detector_cfg_t c = cnn_cfg();
    c.cnn_model2 = &g_cnn2;
    vd_detector_stats_t s;
    c.cnn_score_thr_q15 = thr_q15_of_pixel(150u);
    TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 0u, &f, &g_rec_a, &s));
    TEST_ASSERT_EQUAL_size_t(1u, g_rec_a.n);
    expect_cand(&g_rec_a.c[0], 26, 12, 17, 16, 200u);
    TEST_ASSERT_EQUAL_UINT32(4u, s.cnn_boxes);
    c.cnn_score_thr_q15 = thr_q15_of_pixel(100u);
    TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 0u, &f, &g_rec_a, &s));
    TEST_ASSERT_EQUAL_size_t(3u, g_rec_a.n);
    expect_cand(&g_rec_a.c[0], 13, 12, 16, 16, 100u);   // A0 alone
    expect_cand(&g_rec_a.c[1], 26, 12, 17, 16, 200u);   // A1 + B0
    expect_cand(&g_rec_a.c[2], 40, 12, 10, 16, 100u);   // B1 left over
    TEST_ASSERT_EQUAL_UINT32(6u, s.cnn_boxes);          // 3 + 3 decoded, background included
    TEST_ASSERT_EQUAL_UINT32(3u, s.cand_cnn);
    // A threshold above both networks' top score (32640): nothing runs.
    c.cnn_score_thr_q15 = 32700u;
    TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 1u, &f, &g_rec_a, &s));
    TEST_ASSERT_EQUAL_size_t(0u, g_rec_a.n);
    TEST_ASSERT_EQUAL_UINT32(0u, s.cnn_boxes);
}

// Without cnn_score_thr_q15 a pair runs at the score of cnn_model2's header
// threshold (the pair's operating point), not cnn_model's. The scene of
// test_pair_fusion_hand_worked: second header -28 (pixel 100, T = 12800) and
// first 0 gives its three candidates at T = 100; swapped (T = 16384 from the
// second header 0), only the fused box (25600) reaches T: A0 and B1 (12800)
// and the background peaks (1280; decode at max(1, 2 T - 32768) = 1) drop.
static void test_pair_threshold_from_second_header(void)
{
    static const int8_t thr1[2] = {0, -28};
    static const int8_t thr2[2] = {-28, 0};
    static const size_t want[2] = {3u, 1u};
    fill(20u);
    spot(8u, 200u);
    spot(16u, 200u);
    vd_frame_t f = frame8(50u, 48u);
    for (size_t k = 0u; k < 2u; k++) {
        net_t n = net_default();
        n.off_x = -24;
        n.thr = thr1[k];
        net_load(&n);
        net_t n2 = net_default();
        n2.off_x = 64;
        n2.thr = thr2[k];
        net_load_into(&n2, g_blob2.b, &g_cnn2);
        vd_detector_cfg_t c = cnn_cfg();
        c.cnn_model2 = &g_cnn2;
        vd_detector_stats_t s;
        TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 0u, &f, &g_rec_a, &s));
        TEST_ASSERT_EQUAL_size_t(want[k], g_rec_a.n);
        TEST_ASSERT_EQUAL_UINT32(6u, s.cnn_boxes);
        if (k == 0u) {
            expect_cand(&g_rec_a.c[0], 13, 12, 16, 16, 100u);
            expect_cand(&g_rec_a.c[1], 26, 12, 17, 16, 200u);
            expect_cand(&g_rec_a.c[2], 40, 12, 10, 16, 100u);
        } else {
            expect_cand(&g_rec_a.c[0], 26, 12, 17, 16, 200u);
        }
    }
}

// The same network twice is one pass (every box matches itself: same box,
// score (s + s + 1) >> 1 = s), decoded at the lower score of P = 2 (4 with
// cnn_flip): the same candidates as one network, twice the decoded boxes.
static void test_pair_of_one_network(void)
{
    vd_frame_t f = two_spot_scene();
    for (uint8_t flip = 0u; flip <= 1u; flip++) {
        vd_detector_cfg_t c = cnn_cfg();
        c.cnn_score_thr_q15 = thr_q15_of_pixel(100u);
        vd_detector_stats_t s1, s2;
        TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, flip, &f, &g_rec_b, &s1));
        c.cnn_model2 = &g_cnn;
        TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, flip, &f, &g_rec_a, &s2));
        TEST_ASSERT_TRUE(g_rec_b.n > 0u);
        TEST_ASSERT_EQUAL_size_t(g_rec_b.n, g_rec_a.n);
        for (size_t i = 0u; i < g_rec_a.n; i++) {
            expect_cand(&g_rec_a.c[i], g_rec_b.c[i].box.x, g_rec_b.c[i].box.y, g_rec_b.c[i].box.w,
                        g_rec_b.c[i].box.h, g_rec_b.c[i].score_q8);
        }
        TEST_ASSERT_TRUE(s2.cnn_boxes >= 2u * s1.cnn_boxes);
    }
}

// Workspace: both networks' boxes (max_peaks each, twice with cnn_flip) where
// D is the overlay's largest part; an unloaded second network is VD_ERR_MODEL;
// without the CNN source cnn_model2 is ignored.
static void test_pair_workspace_and_bad_model(void)
{
    net_t n = net_default();
    n.max_peaks = 1024u;
    net_load(&n);
    net_t n2 = net_default();
    n2.max_peaks = 512u;
    net_load_into(&n2, g_blob2.b, &g_cnn2);
    vd_detector_cfg_t c = cnn_cfg();
    c.max_region_w = 1u;
    c.max_region_h = 1u;
    c.max_runs = 1u;
    size_t b0 = 0u, b1 = 0u, b2 = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b0));
    c.cnn_model2 = &g_cnn2;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b1));
    // + both networks' parked plan keys (2 x 96 B, a multiple of the slice alignment)
    TEST_ASSERT_EQUAL_size_t(192u, 2u * (size_t)VD_CNN_PLAN_KEY_BYTES);
    TEST_ASSERT_EQUAL_size_t(b0 + 512u * sizeof(vd_cnn_box_t) + 192u, b1);
    c.cnn_flip = 1u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b2));
    TEST_ASSERT_EQUAL_size_t(b0 + (1024u + 2u * 512u) * sizeof(vd_cnn_box_t) + 192u, b2);
    vd_cnn_model_t unloaded;
    memset(&unloaded, 0, sizeof unloaded);
    c.cnn_model2 = &unloaded;
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_detector_workspace_size(&c, NULL, &b2));
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_detector_init(&g_det, &c, NULL, g_ws, sizeof g_ws));
    c.sources = VD_DETECTOR_SRC_HOTSPOT;
    c.cnn_model = NULL;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &b2));
}

// A pair keeps each network's plan (what VD_CNN_REUSE_PLAN keeps of each record is parked, outside the
// overlay): after init and after every run the parked keys are network 1's and network 2's, both marked
// (a plan made ahead, then a complete run), and the record in the network workspace is network 2's. Over
// frames of changing size and content, and after network 2's parked key is forged (a ring height, which
// the next run must not keep, and its magic), every run's candidates equal those of a detector
// initialised for that frame alone.
static vd_detector_t g_det_keep;
static uint64_t g_ws_keep[512u * 1024u / 8u];

static void test_pair_keeps_each_plan(void)
{
    net_t n = net_default();
    n.off_x = -24;
    net_load(&n);
    net_t n2 = net_default();
    n2.off_x = 64;
    n2.max_peaks = 40u;
    net_load_into(&n2, g_blob2.b, &g_cnn2);
    TEST_ASSERT_TRUE(g_cnn.crc32 != g_cnn2.crc32);
    vd_detector_cfg_t c = cnn_cfg();
    c.cnn_model2 = &g_cnn2;
    c.cnn_flip = 1u;
    c.cnn_score_thr_q15 = thr_q15_of_pixel(40u);
    c.on_candidate = rec_candidate;
    c.candidate_user = &g_rec_c;
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &bytes));
    TEST_ASSERT_TRUE(bytes <= sizeof(g_ws_keep));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_init(&g_det_keep, &c, NULL, g_ws_keep, bytes));
    const vd_cnn_plan_t *in_ws = (const vd_cnn_plan_t *)g_det_keep.cnn_ws;
    uint8_t *park = (uint8_t *)g_det_keep.cnn_park;
    TEST_ASSERT_NOT_NULL(park);
    static vd_cnn_plan_t parked[2];   // the keys, read into whole records (the rest stays zero)
    for (uint32_t j = 0u; j < 2u; j++) {
        memcpy(&parked[j], park + j * VD_CNN_PLAN_KEY_BYTES, VD_CNN_PLAN_KEY_BYTES);
    }
    TEST_ASSERT_EQUAL_HEX32(VD_CNN_PLAN_MAGIC, parked[0].magic);
    TEST_ASSERT_EQUAL_HEX32(g_cnn.crc32, parked[0].crc);
    TEST_ASSERT_EQUAL_HEX32(VD_CNN_PLAN_MAGIC, parked[1].magic);
    TEST_ASSERT_EQUAL_HEX32(g_cnn2.crc32, parked[1].crc);
    static const uint32_t sizes[6][2] = {{50u, 48u}, {50u, 48u}, {40u, 32u}, {50u, 48u}, {50u, 48u}, {50u, 48u}};
    for (uint32_t k = 0u; k < 6u; k++) {
        fill((uint8_t)(20u + k));
        spot(8u, 200u);
        spot(4u + 2u * k, (uint8_t)(150u + 10u * k));
        const vd_frame_t f = frame8(sizes[k][0], sizes[k][1]);
        if (k == 4u) {
            parked[1].rows[1] = (uint16_t)(parked[1].rows[1] + 1u);   // forged: the CRC check refuses it
            memcpy(park + VD_CNN_PLAN_KEY_BYTES, &parked[1], VD_CNN_PLAN_KEY_BYTES);
        }
        if (k == 5u) {
            parked[1].magic = 0u;   // not a plan: network 2 plans again
            memcpy(park + VD_CNN_PLAN_KEY_BYTES, &parked[1], VD_CNN_PLAN_KEY_BYTES);
        }
        vd_detector_stats_t s;
        TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 1u, &f, &g_rec_b, &s));   // fresh detector in g_det
        g_rec_c.n = 0u;
        size_t nd = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&g_det_keep, &f, g_out, 64u, &nd));
        TEST_ASSERT_TRUE(g_rec_b.n > 0u);
        TEST_ASSERT_EQUAL_size_t(g_rec_b.n, g_rec_c.n);
        TEST_ASSERT_EQUAL_MEMORY(g_rec_b.c, g_rec_c.c, g_rec_b.n * sizeof(g_rec_b.c[0]));
        TEST_ASSERT_EQUAL_HEX32(VD_CNN_REC_MAGIC, in_ws->magic);
        TEST_ASSERT_EQUAL_HEX32(g_cnn2.crc32, in_ws->crc);
        for (uint32_t j = 0u; j < 2u; j++) {
            memcpy(&parked[j], park + j * VD_CNN_PLAN_KEY_BYTES, VD_CNN_PLAN_KEY_BYTES);
            TEST_ASSERT_EQUAL_HEX32(VD_CNN_REC_MAGIC, parked[j].magic);
            TEST_ASSERT_EQUAL_HEX32(j == 0u ? g_cnn.crc32 : g_cnn2.crc32, parked[j].crc);
            TEST_ASSERT_EQUAL_UINT32(in_ws->height, parked[j].height);   // both networks' plans of this frame
        }
    }
}

// The fusion written again from the definition (detector.h, cfg.cnn_flip),
// on candidate lists: a[0..na) the normal pass, b[0..nb) the mirrored pass
// (mirrored back and clipped), Q15 scores score_q8 * 128 (the test network
// scores pixel * 128). Appends the fused candidates >= thr to *out.
static void ref_fuse(const cand_rec_t *a, const cand_rec_t *b, uint32_t thr, cand_rec_t *out)
{
    bool used[256] = {false};
    out->n = 0u;
    for (size_t i = 0u; i <= a->n + b->n; i++) {
        vd_detection_t d;
        uint32_t score;
        if (i < a->n) {
            d = a->c[i];
            score = 128u * d.score_q8;
            size_t best = SIZE_MAX;
            uint32_t best_iou = 0u;
            for (size_t j = 0u; j < b->n; j++) {
                const uint32_t q = used[j] ? 0u : vd_rect_iou_q15(&d.box, &b->c[j].box);
                if (q >= 9830u && (best == SIZE_MAX || q > best_iou)) {
                    best = j;
                    best_iou = q;
                }
            }
            if (best != SIZE_MAX) {
                const vd_rect_t *e = &b->c[best].box;
                const int32_t x0 = (d.box.x + e->x) / 2, y0 = (d.box.y + e->y) / 2;
                const int32_t x1 = (d.box.x + d.box.w + e->x + e->w + 1) / 2;
                const int32_t y1 = (d.box.y + d.box.h + e->y + e->h + 1) / 2;
                d.box.x = x0;
                d.box.y = y0;
                d.box.w = x1 - x0;
                d.box.h = y1 - y0;
                score += 128u * b->c[best].score_q8;
                used[best] = true;
            }
        } else if (i < a->n + b->n && !used[i - a->n]) {
            d = b->c[i - a->n];
            score = 128u * d.score_q8;
        } else {
            continue;
        }
        score = (score + 1u) / 2u;
        if (score >= thr) {
            d.candidate = d.box;
            d.score_q8 = (uint8_t)((score + 64u) / 128u > 255u ? 255u : (score + 64u) / 128u);
            out->c[out->n++] = d;
        }
    }
}

// mirror(d) of the rule: [x, x + w) -> [2 hw - x - w, 2 hw - x) within [0, fw);
// false when nothing is left.
static bool mirror_cand(vd_detection_t *d, uint32_t hw, uint32_t fw)
{
    int32_t x0 = 2 * (int32_t)hw - (d->box.x + d->box.w);
    int32_t x1 = 2 * (int32_t)hw - d->box.x;
    x0 = x0 > 0 ? x0 : 0;
    x1 = x1 < (int32_t)fw ? x1 : (int32_t)fw;
    if (x1 <= x0) {
        return false;
    }
    d->box.x = x0;
    d->box.w = x1 - x0;
    d->candidate = d->box;
    return true;
}

// On pseudo-random frames (every 4x4 cell a peak candidate, ties and the
// top-K at work) of even and odd widths, with and without padding, 8 and
// 16 bits, at the header's threshold (T = 16384, decode at score 1) and at
// T = 150 * 128 (decode at 44 * 128): candidates(F, flip 1) == ref_fuse of
// candidates(F, flip 0) and the mirrored-back candidates(M, flip 0), both
// one-pass runs at the decode threshold, where M is F with its first 2 hw
// columns reversed (so that M's half-resolution plane is F's, mirrored; an
// odd last column is not read and is set to 255 to show it).
static void test_flip_equals_fusion_of_passes(void)
{
    net_t n = net_default();
    net_load(&n);
    static const uint32_t sizes[6][2] = {{64u, 48u}, {50u, 40u}, {61u, 45u}, {63u, 33u}, {96u, 80u}, {3u, 9u}};
    static uint8_t src8[MH][MW];
    static uint16_t src16[MH][MW];
    static cand_rec_t fused;
    uint32_t seed = 777u;
    uint32_t matched = 0u, dropped = 0u;
    for (uint32_t k = 0u; k < 24u; k++) {
        const uint32_t w = sizes[k % 6u][0], h = sizes[k % 6u][1], hw = w / 2u;
        const bool wide = (k / 6u) % 2u == 1u;
        const uint32_t thr = (k < 12u) ? 16384u : 150u * 128u;
        const uint32_t dec = (k < 12u) ? 1u : 2u * thr - 32768u;
        for (uint32_t y = 0u; y < h; y++) {
            for (uint32_t x = 0u; x < w; x++) {
                const uint32_t v = tu_rand(&seed);
                g_px[y][x] = (uint8_t)(v & 0xFFu);
                g_px16[y][x] = (uint16_t)(27315u + (v >> 8) % 5200u);
            }
        }
        memcpy(src8, g_px, sizeof src8);
        memcpy(src16, g_px16, sizeof src16);
        vd_frame_t f = {wide ? (const void *)g_px16 : (const void *)g_px, w, h, wide ? MW * 2u : MW,
                        wide ? VD_PIX_U16 : VD_PIX_U8, 0, 0};
        vd_detector_cfg_t c = cnn_cfg();
        c.max_candidates = 256u;
        c.max_detections = 64u;
        c.cnn_score_thr_q15 = (k < 12u) ? 0u : (uint16_t)thr;
        vd_detector_stats_t sa, sb, sc;
        TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 1u, &f, &g_rec_a, &sa));
        c.cnn_score_thr_q15 = (uint16_t)dec;
        TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 0u, &f, &g_rec_b, &sb));
        for (uint32_t y = 0u; y < h; y++) {
            for (uint32_t x = 0u; x < w; x++) {
                g_px[y][x] = (x < 2u * hw) ? src8[y][2u * hw - 1u - x] : 255u;
                g_px16[y][x] = (x < 2u * hw) ? src16[y][2u * hw - 1u - x] : (uint16_t)65535u;
            }
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, 0u, &f, &g_rec_c, &sc));
        size_t m = 0u;
        for (size_t i = 0u; i < g_rec_c.n; i++) {
            vd_detection_t e = g_rec_c.c[i];
            if (mirror_cand(&e, hw, w)) {
                g_rec_c.c[m++] = e;
            }
        }
        g_rec_c.n = m;
        ref_fuse(&g_rec_b, &g_rec_c, thr, &fused);
        TEST_ASSERT_EQUAL_size_t(fused.n, g_rec_a.n);
        for (size_t i = 0u; i < fused.n; i++) {
            TEST_ASSERT_EQUAL_MEMORY(&fused.c[i], &g_rec_a.c[i], sizeof fused.c[i]);
        }
        TEST_ASSERT_EQUAL_UINT32(sb.cnn_boxes + sc.cnn_boxes, sa.cnn_boxes);
        TEST_ASSERT_EQUAL_UINT32((uint32_t)g_rec_a.n, sa.cand_cnn);
        TEST_ASSERT_EQUAL_UINT32(0u, sa.overflow_candidates);
        matched += (uint32_t)(g_rec_b.n + g_rec_c.n) > (uint32_t)g_rec_a.n ? 1u : 0u;
        dropped += (g_rec_b.n > 0u && g_rec_a.n < g_rec_b.n) ? 1u : 0u;
    }
    // Not vacuous: pairs were fused and boxes dropped below T.
    TEST_ASSERT_TRUE(matched >= 12u);
    TEST_ASSERT_TRUE(dropped >= 4u);
}

static uint32_t g_clock;
static uint32_t fake_clock(void *user)
{
    (void)user;
    g_clock += 3u;
    return g_clock;
}

static void test_clock_and_temporal(void)
{
    net_t n = net_default();
    net_load(&n);
    two_spots();
    vd_detector_cfg_t c = cnn_cfg();
    c.clock_us = fake_clock;
    c.temporal = true;
    init_or_fail(&c, NULL);
    vd_frame_t f = frame8(MW, MH);
    for (int i = 0; i < 4; i++) {
        TEST_ASSERT_EQUAL_size_t(2u, run_ok(&f));
    }
    const vd_detector_stats_t *s = vd_detector_last_stats(&g_det);
    TEST_ASSERT_EQUAL_UINT32(3u, s->time_us[VD_DETECTOR_STAGE_CNN]);
    TEST_ASSERT_EQUAL_UINT32(0u, s->time_us[VD_DETECTOR_STAGE_THRESHOLD]);
    TEST_ASSERT_TRUE(s->time_us[VD_DETECTOR_STAGE_TOTAL] >= s->time_us[VD_DETECTOR_STAGE_CNN]);
    // Still boxes: tracked and confirmed like any detection.
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_CONFIRMED, g_out[0].state);
    TEST_ASSERT_TRUE(g_out[0].track_id != 0u);
}

// ------------------------------------------------------------ cnn_invert
// The block scene as a black-hot camera shows it: 255 - v everywhere (background 235, the block 55 over 54).
// The plane is inverted after the 2x2 mean: (55 + 55 + 54 + 54 + 2) >> 2 = 55 (54.5 rounded half up), 255 - 55
// = 200, where the white-hot block gave 201; the background 255 - 235 = 20, as before.
static void test_invert_hand_worked(void)
{
    (void)block_scene();
    vd_detector_cfg_t c = cnn_cfg();
    vd_frame_t f = frame8(64u, 48u);
    fill(235u);
    rect8(26u, 18u, 2u, 1u, 55u);
    rect8(26u, 19u, 2u, 1u, 54u);
    c.cnn_invert = 1u;
    init_or_fail(&c, NULL);
    TEST_ASSERT_EQUAL_size_t(1u, run_ok(&f));
    expect_box(&g_out[0], 20, 12, 16, 16, 200u);
    fill(235u);   // a flat frame: 20 everywhere once inverted, below the threshold
    TEST_ASSERT_EQUAL_size_t(0u, run_ok(&f));
    c.cnn_invert = 2u;
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
}

// ------------------------------------------------------------ cnn_res

// Full resolution, hand-worked: the block of test_box_position_score_source
// (frame (26, 18)-(27, 19), 200 over 201) is now read pixel for pixel: the two
// max-pools put it in cell (26 >> 2, 18 >> 2) = (6, 4) with value max = 201;
// centre (4 * 6 + 2, 4 * 4 + 2) = (26, 18) in network pixels = frame pixels,
// width 8 network pixels = 8 frame pixels: [22, 30) x [14, 22).
// The detector at cfg.cnn_res = res on the 64 x 48 frame of g_px finds one box: (x, y, w, h), score_q8 q8.
// Returns the configuration it ran.
static vd_detector_cfg_t one_box_at_res(uint8_t res, int32_t x, int32_t y, int32_t w, int32_t h, uint8_t q8)
{
    vd_detector_cfg_t c = cnn_cfg();
    c.cnn_res = res;
    init_or_fail(&c, NULL);
    vd_frame_t f = frame8(64u, 48u);
    TEST_ASSERT_EQUAL_size_t(1u, run_ok(&f));
    expect_box(&g_out[0], x, y, w, h, q8);
    return c;
}

static void test_full_res_hand_worked(void)
{
    (void)block_scene();
    vd_detector_cfg_t c = one_box_at_res(VD_DETECTOR_CNN_RES_FULL, 22, 14, 8, 8, 201u);
    // HALF, FULL or QUARTER only, checked even without the CNN source.
    size_t b = 0u;
    c.cnn_res = 3u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &b));
    c.sources = VD_DETECTOR_SRC_HOTSPOT;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &b));
    // The network's input is 4x the pixels: its workspace never shrinks (this tiny network's rows are in
    // the overlay's shadow; the shipped pair's growth is in tests/python/test_cnn_detector.py).
    size_t half = 0u;
    size_t full = 0u;
    c = cnn_cfg();
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &half));
    c.cnn_res = 1u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &full));
    TEST_ASSERT_TRUE(full >= half);
}

// Quarter resolution, hand-worked: a 4 x 4 block at frame (24, 16)-(27, 19), 200 but for one pixel of 208,
// averages (15 * 200 + 208 + 8) >> 4 = 201 (200.5 rounded half up; truncation would give 200) at quarter
// pixel (6, 4): cell (1, 1), value 201; centre (4 * 1 + 2, 4 * 1 + 2) = (6, 6) network pixels = (24, 24)
// frame pixels, width 8 network pixels = 32 frame pixels: [8, 40) x [8, 40).
static void test_quarter_res_hand_worked(void)
{
    (void)flat_scene();
    rect8(24u, 16u, 4u, 4u, 200u);
    rect8(27u, 19u, 1u, 1u, 208u);
    vd_detector_cfg_t c = one_box_at_res(VD_DETECTOR_CNN_RES_QUARTER, 8, 8, 32, 32, 201u);
    // A 16-bit frame: the rounded 4 x 4 mean of the raw values through the grey map (grey 20 + 1 raw step per
    // 1/20 grey, test_u16_frame's map): the same block at grey 201 gives the same box.
    vd_calib_grey_t map;
    const vd_calib_t cal = {65536, 0};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_calib_grey_init(&map, &cal, 27315, 32415));
    for (uint32_t y = 0u; y < MH; y++) {
        for (uint32_t x = 0u; x < MW; x++) {
            const bool in = x >= 24u && x < 28u && y >= 16u && y < 20u;
            g_px16[y][x] = (uint16_t)(27315u + 20u * (in ? 201u : 20u));
        }
    }
    TEST_ASSERT_EQUAL_UINT8(201u, vd_calib_grey_u8(&map, 27315u + 20u * 201u));
    vd_frame_t f16 = {g_px16, 64u, 48u, MW * 2u, VD_PIX_U16, 0, 0};
    TEST_ASSERT_EQUAL_size_t(1u, run_ok(&f16));
    expect_box(&g_out[0], 8, 8, 32, 32, 201u);
    // The last partial 4 x 4 block is not read: a spot in frame columns 64..66 of a 67-wide frame is not seen.
    fill(20u);
    rect8(64u, 16u, 3u, 4u, 250u);
    vd_frame_t f = frame8(67u, 48u);
    init_or_fail(&c, NULL);
    TEST_ASSERT_EQUAL_size_t(0u, run_ok(&f));
}

// res_a on a frame F is res_b on F with every pixel repeated 2 x 2 (FULL on F = HALF on F doubled: the box
// average of four equal pixels is the pixel; HALF on F = QUARTER on F doubled: (4 s + 8) >> 4 = (s + 2) >> 2):
// the same candidates in the same order with the same scores, every corner of the replicated frame's box
// twice the other's to within the decode's rounding (one pixel), with and without the flip pass. F: 40 x 32,
// spots of several values and sizes (k times as wide and tall for res_a = HALF, whose 2 x 2 means would
// drown 1-pixel-tall spots), one at the right edge (padding and mirror).
static void check_res_of_the_doubled_frame(uint8_t res_a, uint8_t res_b)
{
    net_t n = net_default();
    net_load(&n);
    static const uint8_t spots[][4] = {{5, 6, 180}, {17, 9, 220}, {30, 20, 150}, {38, 27, 240}, {11, 25, 200}};
    for (uint8_t flip = 0u; flip <= 1u; flip++) {
        fill(20u);
        for (size_t i = 0u; i < sizeof spots / sizeof spots[0]; i++) {
            const uint32_t k = (res_a == VD_DETECTOR_CNN_RES_HALF) ? 2u : 1u;
            rect8(spots[i][0], spots[i][1], 2u * k, (1u + (uint32_t)(i & 1u)) * k, spots[i][2]);
        }
        vd_detector_cfg_t c = cnn_cfg();
        c.cnn_res = res_a;
        vd_frame_t f = frame8(40u, 32u);
        vd_detector_stats_t s;
        TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, flip, &f, &g_rec_a, &s));
        TEST_ASSERT_TRUE(g_rec_a.n >= 2u);
        // F doubled in place, from the bottom-right so that no source pixel is overwritten before it is read.
        for (uint32_t y = 32u; y-- > 0u;) {
            for (uint32_t x = 40u; x-- > 0u;) {
                const uint8_t v = g_px[y][x];
                rect8(2u * x, 2u * y, 2u, 2u, v);
            }
        }
        c.cnn_res = res_b;
        f = frame8(80u, 64u);
        TEST_ASSERT_EQUAL_INT(VD_OK, run_recorded(c, flip, &f, &g_rec_b, &s));
        TEST_ASSERT_EQUAL_size_t(g_rec_a.n, g_rec_b.n);
        for (size_t i = 0u; i < g_rec_a.n; i++) {
            const vd_rect_t *a = &g_rec_a.c[i].box;
            const vd_rect_t *h = &g_rec_b.c[i].box;
            TEST_ASSERT_EQUAL_UINT8(g_rec_b.c[i].score_q8, g_rec_a.c[i].score_q8);
            TEST_ASSERT_INT32_WITHIN(1, h->x, 2 * a->x);
            TEST_ASSERT_INT32_WITHIN(1, h->y, 2 * a->y);
            TEST_ASSERT_INT32_WITHIN(1, h->x + h->w, 2 * (a->x + a->w));
            TEST_ASSERT_INT32_WITHIN(1, h->y + h->h, 2 * (a->y + a->h));
        }
    }
}

static void test_full_res_is_half_res_of_the_doubled_frame(void)
{
    check_res_of_the_doubled_frame(VD_DETECTOR_CNN_RES_FULL, VD_DETECTOR_CNN_RES_HALF);
}

static void test_half_res_is_quarter_res_of_the_doubled_frame(void)
{
    check_res_of_the_doubled_frame(VD_DETECTOR_CNN_RES_HALF, VD_DETECTOR_CNN_RES_QUARTER);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_box_position_score_source);
    RUN_TEST(test_score_threshold);
    RUN_TEST(test_odd_frame_padding_and_clipping);
    RUN_TEST(test_u16_frame);
    RUN_TEST(test_workspace_contract);
    RUN_TEST(test_bad_configs);
    RUN_TEST(test_merge_with_hotspots);
    RUN_TEST(test_rescore_with_dbn);
    RUN_TEST(test_flip_fusion_hand_worked);
    RUN_TEST(test_flip_fusion_two_scores);
    RUN_TEST(test_flip_iou_bound);
    RUN_TEST(test_flip_capacity);
    RUN_TEST(test_flip_workspace);
    RUN_TEST(test_flip_equals_fusion_of_passes);
    RUN_TEST(test_pair_fusion_hand_worked);
    RUN_TEST(test_pair_threshold_from_second_header);
    RUN_TEST(test_pair_of_one_network);
    RUN_TEST(test_pair_workspace_and_bad_model);
    RUN_TEST(test_pair_keeps_each_plan);
    RUN_TEST(test_clock_and_temporal);
    RUN_TEST(test_invert_hand_worked);
    RUN_TEST(test_full_res_hand_worked);
    RUN_TEST(test_full_res_is_half_res_of_the_doubled_frame);
    RUN_TEST(test_quarter_res_hand_worked);
    RUN_TEST(test_half_res_is_quarter_res_of_the_doubled_frame);
    return UNITY_END();
}
