// SPDX-License-Identifier: MIT
// Unit tests of the boosted-stump verifier (vd/boost.h): a tiny version-4
// model written here (no Python), scores and features worked out by hand,
// the threshold side of a stump, the int32 sum at its extremes, the
// workspace contract and every documented error path.
//
// The model (docs/model-format.md "Boosted kind" around a "CNN kind" blob):
//   input 4x4, input_norm 0 (int8 x = pixel - 128, zero point -128, so
//   x - zp = pixel);
//   L0 CONV5X5 1 -> 2 (padding 2), out zp 0, clamp [0, 127]:
//     c0 = requant(pixel(y,x) + pixel(y-1,x-1) + 15, x0.5)   (mult 2^30, shift 0)
//     c1 = requant(3 * pixel(y,x) - 30, x1)                    (mult 2^30, shift 1)
//   L1, L2 MAXPOOL2; L3 PW1X1 2 -> 3 head (never read by the verifier).
//   Tensors: t1 = L0 (4x4x2), t2 = L1 (2x2x2), t3 = L2, t4 = the head.
//   Maps: m0 = (t1, c0) 16 values, m1 = (t2, c0) 4 values, m2 = (t1, c1)
//   16 values: 36 features.
#include "unity.h"
#include "testutil.h"

#include <string.h>

#include "vd/boost.h"
#include "vd/detector.h"
#include "core/crc32.h"

void setUp(void) {}
void tearDown(void) {}

// ------------------------------------------------------------ blob writer

#define CNN_LEN 3436u   // 128 + 4 * 32 layer entries + 72 (L0 arrays) + 36 (L3 arrays) + 3 * 1024 decode table
#define BLOB_CAP (64u + 4u * 17u + 8u * 4097u + CNN_LEN + 64u)

static union {
    uint32_t align;
    uint8_t b[BLOB_CAP + 8u];
} g_blob;

typedef struct stump {
    uint16_t pos;
    uint8_t map;
    int8_t thr;
    int16_t left, right;
} stump_t;

typedef struct map {
    uint8_t tensor;
    uint16_t channel;
} map_t;

// The version-3 CNN of the file comment at b; returns its length (CNN_LEN).
static uint32_t write_cnn(uint8_t *b)
{
    memset(b, 0, CNN_LEN);
    memcpy(b, "VDMF", 4);
    tu_wr16(b + 4, 3u);
    tu_wr16(b + 6, 128u);
    tu_wr32(b + 8, CNN_LEN);
    b[16] = 2u;     // kind CNN
    b[17] = 0u;     // input_norm none
    b[18] = 4u;     // n_layers
    b[19] = 3u;     // out_channels
    tu_wr16(b + 20, 4u);
    tu_wr16(b + 22, 4u);
    b[30] = 0x80u;  // input zp -128
    b[31] = 4u;     // out_stride = f of the head (two max-pools)
    tu_wr32(b + 32, 128u);
    b[42] = 16u;    // max_peaks
    memcpy(b + 48, "t", 1);
    // Layer table at 128, arrays from 256.
    uint8_t *e = b + 128;
    e[0] = 7u;   // L0 CONV5X5
    e[1] = 1u;
    tu_wr16(e + 4, 1u);
    tu_wr16(e + 6, 2u);
    e[8] = 0u;   // out zp 0
    e[9] = 0u;   // act_min 0 (ReLU)
    e[10] = 127u;
    tu_wr32(e + 12, 256u);   // weights [2][5][5][1] = 50 bytes, padded to 52
    tu_wr32(e + 16, 308u);   // bias [2]
    tu_wr32(e + 20, 316u);   // mult [2]
    tu_wr32(e + 24, 324u);   // shift [2], padded to 4
    int8_t *w = (int8_t *)(b + 256);
    w[2 * 5 + 2] = 1;          // c0: centre tap (ky 2, kx 2)
    w[1 * 5 + 1] = 1;          // c0: tap (ky 1, kx 1) = pixel (y-1, x-1)
    w[25 + 2 * 5 + 2] = 3;     // c1: 3 x centre
    tu_wr32(b + 308, 15u);
    tu_wr32(b + 312, (uint32_t)-30);
    tu_wr32(b + 316, 1u << 30);
    tu_wr32(b + 320, 1u << 30);
    b[324] = 0u;   // c0: x * 2^30 / 2^31 = x / 2, rounded
    b[325] = 1u;   // c1: x * 2 * 2^30 / 2^31 = x
    for (uint32_t l = 1u; l <= 2u; l++) {   // L1, L2 MAXPOOL2 of the previous tensor
        e = b + 128u + 32u * l;
        e[0] = 4u;
        e[1] = 1u;
        e[2] = (uint8_t)l;
        tu_wr16(e + 4, 2u);
        tu_wr16(e + 6, 2u);
        e[9] = 0x80u;
        e[10] = 127u;
    }
    e = b + 128u + 96u;   // L3 PW1X1 2 -> 3 head
    e[0] = 3u;
    e[1] = 1u;
    e[2] = 3u;
    tu_wr16(e + 4, 2u);
    tu_wr16(e + 6, 3u);
    e[9] = 0x80u;
    e[10] = 127u;
    tu_wr32(e + 12, 328u);   // weights [3][2] = 6 bytes, padded to 8
    tu_wr32(e + 16, 336u);   // bias [3]
    tu_wr32(e + 20, 348u);   // mult [3]
    tu_wr32(e + 24, 360u);   // shift [3], padded to 4
    b[328] = 1u;
    b[331] = 1u;
    for (uint32_t o = 0u; o < 3u; o++) {
        tu_wr32(b + 348u + 4u * o, 1u << 30);
        b[360u + o] = 1u;
    }
    tu_wr32(b + 36, 364u);   // decode table [3][256] at 364: i * 128 (non-decreasing, in range)
    for (uint32_t c = 0u; c < 3u; c++) {
        for (uint32_t i = 0u; i < 256u; i++) {
            tu_wr32(b + 364u + 4u * (256u * c + i), i * 128u);
        }
    }
    tu_vdm_fix_crc(b);
    return CNN_LEN;
}

// The boosted blob: header, maps at 64, stumps after them, the CNN last
// (each 4-aligned, as the exporter writes it). Returns total_size.
static uint32_t write_boost(const map_t *maps, uint32_t n_maps, const stump_t *st, uint32_t n_st, int32_t thr)
{
    uint8_t *b = g_blob.b;
    const uint32_t maps_off = 64u;
    const uint32_t st_off = maps_off + 4u * n_maps;
    const uint32_t cnn_off = (st_off + 8u * n_st + 3u) & ~3u;
    const uint32_t total = cnn_off + CNN_LEN;
    TEST_ASSERT_TRUE(total <= BLOB_CAP);
    memset(b, 0, total + 8u);
    memcpy(b, "VDMF", 4);
    tu_wr16(b + 4, 4u);
    tu_wr16(b + 6, 64u);
    tu_wr32(b + 8, total);
    b[16] = 3u;
    b[17] = (uint8_t)n_maps;
    tu_wr16(b + 18, n_st);
    tu_wr32(b + 20, cnn_off);
    tu_wr32(b + 24, CNN_LEN);
    tu_wr32(b + 28, maps_off);
    tu_wr32(b + 32, st_off);
    tu_wr32(b + 36, (uint32_t)thr);
    memcpy(b + 40, "boost-test", 10);
    for (uint32_t i = 0u; i < n_maps; i++) {
        b[maps_off + 4u * i] = maps[i].tensor;
        tu_wr16(b + maps_off + 4u * i + 2u, maps[i].channel);
    }
    for (uint32_t k = 0u; k < n_st; k++) {
        uint8_t *s = b + st_off + 8u * k;
        tu_wr16(s, st[k].pos);
        s[2] = st[k].map;
        s[3] = (uint8_t)st[k].thr;
        tu_wr16(s + 4, (uint16_t)st[k].left);
        tu_wr16(s + 6, (uint16_t)st[k].right);
    }
    (void)write_cnn(b + cnn_off);
    tu_vdm_fix_crc(b);
    return total;
}

static const map_t k_maps[3] = {{1u, 0u}, {2u, 0u}, {1u, 1u}};

// S0..S3 of the hand-worked score (test_known_crop_score_hand_worked).
static const stump_t k_stumps[4] = {
    {5u, 0u, 20, -100, 300},    // m0[5]  = 13  <= 20  -> left  -100
    {3u, 1u, 126, -50, 250},    // m1[3]  = 127 >  126 -> right  250
    {10u, 2u, 90, 70, -700},    // m2[10] = 90  <= 90  -> left    70 (equal: left)
    {0u, 2u, -1, 1000, -5},     // m2[0]  = 0   >  -1  -> right   -5
};

#define K_THR 200

static uint32_t write_default(void)
{
    return write_boost(k_maps, 3u, k_stumps, 4u, K_THR);
}

// The test crop, 4x4 inside rows of 6 bytes (stride 6; the 2 extra bytes
// per row are 0xEE and must not be read):
//    0  0  0   0
//    0 10  0   0
//    0  0 40   0
//    0  0  0 200
#define CROP_STRIDE 6u
static uint8_t g_crop[4u * CROP_STRIDE];

static void make_crop(void)
{
    memset(g_crop, 0xEE, sizeof g_crop);
    for (uint32_t y = 0u; y < 4u; y++) {
        memset(g_crop + y * CROP_STRIDE, 0, 4u);
    }
    g_crop[1u * CROP_STRIDE + 1u] = 10u;
    g_crop[2u * CROP_STRIDE + 2u] = 40u;
    g_crop[3u * CROP_STRIDE + 3u] = 200u;
}

static vd_boost_model_t g_m;

static void load_ok(uint32_t total)
{
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_load(&g_m, g_blob.b, total));
}

static int32_t score_of(const vd_boost_model_t *m, const uint8_t *crop, uint32_t stride)
{
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_workspace_size(m, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    memset(ws, 0x5A, bytes);
    int32_t s = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_score(m, crop, stride, ws, bytes, &s));
    tu_guard_check(0);
    tu_guarded_free(0);
    return s;
}

// ------------------------------------------------------------ hand-worked scores

static void test_known_crop_score_hand_worked(void)
{
    make_crop();
    load_ok(write_default());
    TEST_ASSERT_EQUAL_UINT32(3u, g_m.n_maps);
    TEST_ASSERT_EQUAL_UINT32(4u, g_m.n_stumps);
    TEST_ASSERT_EQUAL_UINT32(4u, g_m.crop_w);
    TEST_ASSERT_EQUAL_UINT32(4u, g_m.crop_h);
    TEST_ASSERT_EQUAL_UINT32(16u, g_m.map_len[0]);   // t1: 4x4
    TEST_ASSERT_EQUAL_UINT32(4u, g_m.map_len[1]);    // t2: 2x2 after one max-pool
    TEST_ASSERT_EQUAL_UINT32(16u, g_m.map_len[2]);
    TEST_ASSERT_EQUAL_STRING("boost-test", g_m.name);
    // score_span = sum of max(|left|, |right|) = 300 + 250 + 700 + 1000.
    TEST_ASSERT_EQUAL_INT32(2250, g_m.score_span);

    // Conv sums S = pixel(y,x) + pixel(y-1,x-1) (taps outside the crop read
    // the zero point, i.e. pixel 0): S = 0 everywhere except on the diagonal,
    // (1,1): 10 + 0 = 10, (2,2): 40 + 10 = 50, (3,3): 200 + 40 = 240.
    // c0 = round((S + 15) / 2), ties up (gemmlowp, positive values), clamp 127:
    //   S 0 -> 15 / 2 = 7.5 -> 8;  10 -> 12.5 -> 13;  50 -> 32.5 -> 33;
    //   240 -> 127.5 -> 128 -> clamped to 127.
    // c1 = clamp(3 * pixel - 30, 0, 127): pixel 0 -> -30 -> 0; 10 -> 0;
    //   40 -> 90; 200 -> 570 -> 127. (pixel(0,0) = 0 on the diagonal too.)
    // m1 = max-pool 2x2 of c0: [max(8,8,8,13), 8, 8, max(33,8,8,127)].
    static const int8_t feat[36] = {
        8, 8, 8,  8, 8, 13, 8,  8, 8, 8, 33, 8, 8, 8, 8, 127,    // m0 = (t1, c0)
        13, 8, 8, 127,                                          // m1 = (t2, c0)
        0, 0, 0,  0, 0, 0,  0,  0, 0, 0, 90, 0, 0, 0, 0, 127,   // m2 = (t1, c1)
    };
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_workspace_size(&g_m, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    int8_t got[37];
    memset(got, 0x77, sizeof got);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_features(&g_m, g_crop, CROP_STRIDE, ws, bytes, got, 36u));
    TEST_ASSERT_EQUAL_INT8_ARRAY(feat, got, 36);
    TEST_ASSERT_EQUAL_INT8(0x77, got[36]);   // capacity respected
    tu_guard_check(0);
    tu_guarded_free(0);

    // S0: m0[5] = 13 <= 20 -> -100; S1: m1[3] = 127 > 126 -> +250;
    // S2: m2[10] = 90 <= 90 -> +70; S3: m2[0] = 0 > -1 -> -5.
    // score = -100 + 250 + 70 - 5 = 215 >= threshold 200: a vehicle.
    const int32_t s = score_of(&g_m, g_crop, CROP_STRIDE);
    TEST_ASSERT_EQUAL_INT32(215, s);
    int32_t thr = 0;
    uint32_t nf = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_threshold(&g_m, &thr, &nf));
    TEST_ASSERT_EQUAL_INT32(K_THR, thr);
    TEST_ASSERT_EQUAL_UINT32(36u, nf);
    TEST_ASSERT_TRUE(s >= thr);

    // An all-zero crop: c0 = 8 everywhere, c1 = 0, m1 = 8.
    // S0: 8 <= 20 -> -100; S1: 8 <= 126 -> -50; S2: 0 <= 90 -> 70; S3: 0 > -1 -> -5.
    // score = -85 < 200: not a vehicle.
    static const uint8_t zero[16] = {0};
    TEST_ASSERT_EQUAL_INT32(-85, score_of(&g_m, zero, 4u));
}

// A feature exactly at a stump's threshold votes left (x <= thr); one below
// the threshold's value it votes right.
static void test_feature_at_threshold_goes_left(void)
{
    make_crop();
    stump_t st[4];
    memcpy(st, k_stumps, sizeof st);
    // S2 has x = 90 = thr: left (+70), as in the hand-worked score (215).
    // With thr 89: 90 > 89 -> right (-700): -100 + 250 - 700 - 5 = -555.
    st[2].thr = 89;
    load_ok(write_boost(k_maps, 3u, st, 4u, K_THR));
    TEST_ASSERT_EQUAL_INT32(-555, score_of(&g_m, g_crop, CROP_STRIDE));
    // S1 at x = 127 = thr 127: left (-50) instead of +250: -100 - 50 + 70 - 5 = -85.
    memcpy(st, k_stumps, sizeof st);
    st[1].thr = 127;
    load_ok(write_boost(k_maps, 3u, st, 4u, K_THR));
    TEST_ASSERT_EQUAL_INT32(-85, score_of(&g_m, g_crop, CROP_STRIDE));
    // S3 at x = 0 = thr 0: left (+1000): -100 + 250 + 70 + 1000 = 1220.
    // Threshold -128 (the int8 minimum): only x = -128 votes left; m2 >= 0, so right.
    memcpy(st, k_stumps, sizeof st);
    st[3].thr = 0;
    load_ok(write_boost(k_maps, 3u, st, 4u, K_THR));
    TEST_ASSERT_EQUAL_INT32(1220, score_of(&g_m, g_crop, CROP_STRIDE));
    st[3].thr = -128;
    load_ok(write_boost(k_maps, 3u, st, 4u, K_THR));
    TEST_ASSERT_EQUAL_INT32(215, score_of(&g_m, g_crop, CROP_STRIDE));
}

// The sum has no saturation and no rounding: the votes are int16 already in
// the exporter's Q-format, and 4096 * 32767 < 2^31 fits an int32. The
// extremes: 4096 stumps voting +32767 (or -32767) on either side.
static stump_t g_many[VD_BOOST_MAX_STUMPS + 1u];

static void test_score_sum_extremes(void)
{
    make_crop();
    for (uint32_t k = 0u; k < VD_BOOST_MAX_STUMPS; k++) {
        g_many[k] = (stump_t){(uint16_t)(k % 16u), (uint8_t)(k % 3u == 1u ? 0u : k % 3u), (int8_t)(k % 7u), 32767,
                              32767};
    }
    load_ok(write_boost(k_maps, 3u, g_many, VD_BOOST_MAX_STUMPS, 0));
    // 4096 * 32767 = 134213632 (< 2^27, far from INT32_MAX).
    TEST_ASSERT_EQUAL_INT32(134213632, g_m.score_span);
    TEST_ASSERT_EQUAL_INT32(134213632, score_of(&g_m, g_crop, CROP_STRIDE));
    for (uint32_t k = 0u; k < VD_BOOST_MAX_STUMPS; k++) {
        g_many[k].left = -32767;
        g_many[k].right = -32767;
    }
    load_ok(write_boost(k_maps, 3u, g_many, VD_BOOST_MAX_STUMPS, 0));
    TEST_ASSERT_EQUAL_INT32(134213632, g_m.score_span);
    TEST_ASSERT_EQUAL_INT32(-134213632, score_of(&g_m, g_crop, CROP_STRIDE));
    // One stump past the maximum count, and a vote of -32768, are rejected.
    g_many[VD_BOOST_MAX_STUMPS] = g_many[0];
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL,
                          vd_boost_load(&g_m, g_blob.b, write_boost(k_maps, 3u, g_many, VD_BOOST_MAX_STUMPS + 1u, 0)));
    stump_t st[4];
    memcpy(st, k_stumps, sizeof st);
    st[1].left = -32768;
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_boost_load(&g_m, g_blob.b, write_boost(k_maps, 3u, st, 4u, 0)));
    memcpy(st, k_stumps, sizeof st);
    st[3].right = -32768;
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_boost_load(&g_m, g_blob.b, write_boost(k_maps, 3u, st, 4u, 0)));
    st[3].right = -32767;   // the most negative allowed vote
    load_ok(write_boost(k_maps, 3u, st, 4u, 0));
    // -100 + 250 + 70 - 32767 = -32547.
    TEST_ASSERT_EQUAL_INT32(-32547, score_of(&g_m, g_crop, CROP_STRIDE));
}

// ------------------------------------------------------------ workspace

static vd_status_t run_score(void *ws, size_t bytes, void *ctx)
{
    (void)ctx;
    int32_t s = 0;
    return vd_boost_score(&g_m, g_crop, CROP_STRIDE, ws, bytes, &s);
}

static void test_workspace_size_and_contract(void)
{
    make_crop();
    load_ok(write_default());
    size_t bytes = 0u, cnn_bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_workspace_size(&g_m, &bytes));
    // The CNN at the crop size with every tensor kept (the maps are read after the run).
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&g_m.cnn, 4u, 4u, VD_CNN_KEEP_TENSORS, &cnn_bytes));
    TEST_ASSERT_EQUAL_size_t(cnn_bytes, bytes);
    // NULL, one byte short and misaligned: VD_ERR_WORKSPACE; exact: VD_OK, guards intact.
    tu_check_workspace_contract(bytes, run_score, NULL);
    // vd_boost_features has the same contract.
    void *ws = tu_guarded_alloc(0, bytes);
    int8_t f[36];
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_boost_features(&g_m, g_crop, CROP_STRIDE, ws, bytes - 1u, f, 36u));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_features(&g_m, g_crop, CROP_STRIDE, ws, bytes, f, 36u));
    tu_guard_check(0);
    tu_guarded_free(0);
    TEST_ASSERT_EQUAL_size_t(sizeof(vd_boost_model_t), vd_boost_model_bytes());
}

// ------------------------------------------------------------ error paths

static vd_boost_model_t g_before;

static void poison(void)
{
    memset(&g_m, 0x5A, sizeof g_m);
    g_before = g_m;
}

// Rejected before the embedded CNN loads: *m untouched.
static void expect_reject_untouched(vd_status_t want, const void *blob, size_t bytes)
{
    poison();
    TEST_ASSERT_EQUAL_INT(want, vd_boost_load(&g_m, blob, bytes));
    TEST_ASSERT_EQUAL_MEMORY(&g_before, &g_m, sizeof g_m);
}

// Rejected at any point: VD_ERR_MODEL and *m either untouched or zeroed (not
// loaded), so a later score reports VD_ERR_STATE or the caller never used it.
static void expect_model_reject(uint32_t total)
{
    poison();
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_boost_load(&g_m, g_blob.b, total));
    if (memcmp(&g_before, &g_m, sizeof g_m) != 0) {
        TEST_ASSERT_NULL(g_m.blob);
        TEST_ASSERT_EQUAL_UINT32(0u, g_m.n_stumps);
    }
}

static void test_load_argument_errors(void)
{
    const uint32_t total = write_default();
    expect_reject_untouched(VD_ERR_ARG, NULL, total);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_load(NULL, g_blob.b, total));
    expect_reject_untouched(VD_ERR_ARG, g_blob.b, 0u);
    // Misaligned: the same bytes one byte further on.
    memmove(g_blob.b + 1, g_blob.b, total);
    expect_reject_untouched(VD_ERR_ARG, g_blob.b + 1, total);
}

static void test_load_container_errors(void)
{
    uint32_t total = write_default();
    uint8_t *b = g_blob.b;
    // Truncated: fewer bytes than total_size, fewer than a header.
    expect_reject_untouched(VD_ERR_MODEL, b, total - 4u);
    expect_reject_untouched(VD_ERR_MODEL, b, total - 1u);
    expect_reject_untouched(VD_ERR_MODEL, b, 63u);
    expect_reject_untouched(VD_ERR_MODEL, b, 4u);
    // Bytes past total_size are ignored (flash padding).
    poison();
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_load(&g_m, b, total + 7u));
    // Bad CRC: one stump vote changed without the CRC.
    b[64u + 12u + 4u] ^= 0x01u;
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    tu_vdm_fix_crc(b);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_load(&g_m, b, total));   // the same change with its CRC loads
    // Magic, version (3, 5), header size, kind, total size not a multiple of 4 / past the bytes (CRC fixed).
    static const struct {
        uint32_t off, len, value;
    } k_bad[] = {{0u, 1u, 'X'}, {4u, 2u, 3u}, {4u, 2u, 5u}, {6u, 2u, 128u}, {16u, 1u, 2u}, {16u, 1u, 4u}};
    for (size_t i = 0u; i < sizeof k_bad / sizeof k_bad[0]; i++) {
        total = write_default();
        if (k_bad[i].len == 1u) {
            b[k_bad[i].off] = (uint8_t)k_bad[i].value;
        } else {
            tu_wr16(b + k_bad[i].off, k_bad[i].value);
        }
        tu_vdm_fix_crc(b);
        expect_reject_untouched(VD_ERR_MODEL, b, total);
    }
    total = write_default();
    tu_wr32(b + 8, total - 2u);
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    total = write_default();
    tu_wr32(b + 8, total + 4u);
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    // The embedded CNN blob on its own (version 3, kind 2) is not a boosted model.
    total = write_default();
    expect_reject_untouched(VD_ERR_MODEL, b + tu_rd32(b + 20), CNN_LEN);
}

static void test_load_structure_errors(void)
{
    uint8_t *b = g_blob.b;
    map_t maps[3];
    stump_t st[4];
    // Map table: tensor 0 (the input), tensor 5 (past the 4 layers), a
    // channel the tensor lacks (t1 has 2), a nonzero reserved byte.
    static const map_t k_bad_maps[3] = {{0u, 0u}, {5u, 0u}, {1u, 2u}};
    for (uint32_t i = 0u; i < 3u; i++) {
        memcpy(maps, k_maps, sizeof maps);
        maps[1] = k_bad_maps[i];
        expect_model_reject(write_boost(maps, 3u, k_stumps, 4u, K_THR));
    }
    memcpy(maps, k_maps, sizeof maps);
    maps[1] = (map_t){4u, 2u};   // the head (t4, 1x1, 3 channels) exists: accepted
    memcpy(st, k_stumps, sizeof st);
    st[1].pos = 0u;              // its only value
    load_ok(write_boost(maps, 3u, st, 4u, K_THR));
    TEST_ASSERT_EQUAL_UINT32(1u, g_m.map_len[1]);
    TEST_ASSERT_EQUAL_UINT32(33u, g_m.n_features);
    uint32_t total = write_default();
    b[64u + 4u + 1u] = 1u;
    tu_vdm_fix_crc(b);
    expect_model_reject(total);
    // n_maps 0 and 17, n_stumps 0.
    total = write_default();
    b[17] = 0u;
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    b[17] = 17u;
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    total = write_default();
    tu_wr16(b + 18, 0u);
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    // Stumps: a feature index past its map (m0 has 16 values, m1 4), a map index past n_maps.
    static const stump_t k_bad_st[3] = {{16u, 0u, 0, 1, 1}, {4u, 1u, 0, 1, 1}, {0u, 3u, 0, 1, 1}};
    for (uint32_t i = 0u; i < 3u; i++) {
        memcpy(st, k_stumps, sizeof st);
        st[2] = k_bad_st[i];
        expect_model_reject(write_boost(k_maps, 3u, st, 4u, K_THR));
    }
    memcpy(st, k_stumps, sizeof st);
    st[2] = (stump_t){15u, 0u, 0, 1, 1};   // the last value of m0: accepted
    st[3] = (stump_t){3u, 1u, 0, 1, 1};    // the last value of m1
    load_ok(write_boost(k_maps, 3u, st, 4u, K_THR));
    // Sections: stumps overlapping the map table, the CNN before the stumps,
    // a misaligned offset, cnn_len not the CNN's total_size, a CNN that
    // vd_cnn_load rejects (its CRC), a bad name, nonzero reserved header bytes.
    total = write_default();
    tu_wr32(b + 32, 64u);
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    total = write_default();
    tu_wr32(b + 20, 64u + 12u);
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    total = write_default();
    tu_wr32(b + 32, 64u + 12u + 2u);
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    total = write_default();
    tu_wr32(b + 24, CNN_LEN - 4u);   // the CNN says 3436, the header 3432
    tu_vdm_fix_crc(b);
    expect_model_reject(total);
    total = write_default();
    b[tu_rd32(b + 20) + 300u] ^= 0x10u;   // inside the CNN's arrays, its own CRC now wrong
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    total = write_default();
    b[40] = 0x01u;
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
    total = write_default();
    b[60] = 1u;
    tu_vdm_fix_crc(b);
    expect_reject_untouched(VD_ERR_MODEL, b, total);
}

// A model rejected after its CNN loaded is zeroed, so it reports VD_ERR_STATE.
static void test_not_loaded_and_call_errors(void)
{
    make_crop();
    load_ok(write_default());
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_boost_workspace_size(&g_m, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    int32_t s = 0;
    int8_t f[36];
    int32_t thr = 0;
    uint32_t nf = 0u;
    // NULL arguments.
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_workspace_size(NULL, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_workspace_size(&g_m, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_score(NULL, g_crop, CROP_STRIDE, ws, bytes, &s));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_score(&g_m, NULL, CROP_STRIDE, ws, bytes, &s));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_score(&g_m, g_crop, CROP_STRIDE, ws, bytes, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_boost_score(&g_m, g_crop, CROP_STRIDE, NULL, bytes, &s));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_features(NULL, g_crop, CROP_STRIDE, ws, bytes, f, 36u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_features(&g_m, NULL, CROP_STRIDE, ws, bytes, f, 36u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_features(&g_m, g_crop, CROP_STRIDE, ws, bytes, NULL, 36u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_features(&g_m, g_crop, CROP_STRIDE, ws, bytes, f, 35u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_threshold(NULL, &thr, &nf));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_threshold(&g_m, NULL, &nf));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_threshold(&g_m, &thr, NULL));
    // The crop size is the model's (crop_w x crop_h): the caller only picks
    // the row stride, which must hold a crop row.
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_score(&g_m, g_crop, 3u, ws, bytes, &s));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_score(&g_m, g_crop, 0u, ws, bytes, &s));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_boost_features(&g_m, g_crop, 3u, ws, bytes, f, 36u));
    // A workspace short by one byte.
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_boost_score(&g_m, g_crop, CROP_STRIDE, ws, bytes - 1u, &s));
    tu_guard_check(0);
    // Not loaded: a zeroed struct, and one a failed load zeroed.
    vd_boost_model_t z;
    memset(&z, 0, sizeof z);
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_boost_workspace_size(&z, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_boost_score(&z, g_crop, CROP_STRIDE, ws, bytes, &s));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_boost_features(&z, g_crop, CROP_STRIDE, ws, bytes, f, 36u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_boost_threshold(&z, &thr, &nf));
    stump_t st[4];
    memcpy(st, k_stumps, sizeof st);
    st[0].pos = 16u;   // fails after the CNN loaded into g_m.cnn
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_boost_load(&g_m, g_blob.b, write_boost(k_maps, 3u, st, 4u, K_THR)));
    TEST_ASSERT_NULL(g_m.blob);
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_boost_score(&g_m, g_crop, CROP_STRIDE, ws, bytes, &s));
    tu_guarded_free(0);
}

// ------------------------------------------------------------ as the detector's verifier

// cfg.verifier = BOOST on a hot-spot candidate, with one stump voting +500 on
// both sides (score 500 whatever the crop, score_span 500), so the decision
// depends only on the threshold: kept when 500 >= threshold + offset, and
// score_q8 = clamp(128 + floor(128 (500 - threshold) / 500), 0, 255).
#define DFW 160u
#define DFH 120u
static uint8_t g_frame[DFH][DFW];
static uint64_t g_det_ws[4u * 1024u * 1024u / 8u];

static size_t detect(int32_t thr, int32_t offset, vd_detection_t *out, const vd_detector_stats_t **stats)
{
    static const stump_t k_const[1] = {{0u, 0u, 0, 500, 500}};
    load_ok(write_boost(k_maps, 3u, k_const, 1u, thr));
    vd_detector_cfg_t c;
    memset(&c, 0, sizeof c);
    c.max_width = DFW;
    c.max_height = DFH;
    c.verifier = VD_DETECTOR_VERIFIER_BOOST;
    c.boost_model = &g_m;
    c.boost_thr_offset = offset;
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_workspace_size(&c, NULL, &bytes));
    TEST_ASSERT_TRUE(bytes <= sizeof g_det_ws);
    static vd_detector_t det;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_init(&det, &c, NULL, g_det_ws, bytes));
    const vd_frame_t f = {&g_frame[0][0], DFW, DFH, DFW, VD_PIX_U8, 0, 0};
    size_t n = 99u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_detector_run(&det, &f, out, 4u, &n));
    *stats = vd_detector_last_stats(&det);
    return n;
}

static void test_detector_uses_boost_threshold_and_offset(void)
{
    // One car-like hot object (as tests/unit/test_detector.c): one hot-spot candidate.
    memset(g_frame, 40, sizeof g_frame);
    for (uint32_t y = 30u; y < 50u; y++) {
        memset(&g_frame[y][20], 180, 30u);
    }
    vd_detection_t out[4];
    const vd_detector_stats_t *s = NULL;
    // Threshold 500: 500 >= 500, kept; score_q8 = 128 + 0.
    TEST_ASSERT_EQUAL_size_t(1u, detect(500, 0, out, &s));
    TEST_ASSERT_EQUAL_UINT32(1u, s->verified);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_SOURCE_HOTSPOT, out[0].source);
    TEST_ASSERT_EQUAL_UINT8(128u, out[0].score_q8);
    TEST_ASSERT_TRUE((out[0].flags & VD_DETECTION_FLAG_UNVERIFIED) == 0u);
    // Threshold 501: 500 < 501, rejected.
    TEST_ASSERT_EQUAL_size_t(0u, detect(501, 0, out, &s));
    TEST_ASSERT_EQUAL_UINT32(0u, s->verified);
    // Offset -1 keeps it: 500 >= 501 - 1; score_q8 = 128 + floor(128 * -1 / 500) = 128 - 1 = 127.
    TEST_ASSERT_EQUAL_size_t(1u, detect(501, -1, out, &s));
    TEST_ASSERT_EQUAL_UINT8(127u, out[0].score_q8);
    // Threshold -1000: 128 + floor(128 * 1500 / 500) = 512, clamped to 255.
    TEST_ASSERT_EQUAL_size_t(1u, detect(-1000, 0, out, &s));
    TEST_ASSERT_EQUAL_UINT8(255u, out[0].score_q8);
    // VERIFIER_BOOST without a boosted model: an argument error (vd_detector_cfg_resolve).
    vd_detector_cfg_t c;
    memset(&c, 0, sizeof c);
    c.max_width = DFW;
    c.max_height = DFH;
    c.verifier = VD_DETECTOR_VERIFIER_BOOST;
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_detector_workspace_size(&c, NULL, &bytes));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_known_crop_score_hand_worked);
    RUN_TEST(test_feature_at_threshold_goes_left);
    RUN_TEST(test_score_sum_extremes);
    RUN_TEST(test_workspace_size_and_contract);
    RUN_TEST(test_load_argument_errors);
    RUN_TEST(test_load_container_errors);
    RUN_TEST(test_load_structure_errors);
    RUN_TEST(test_not_loaded_and_call_errors);
    RUN_TEST(test_detector_uses_boost_threshold_and_offset);
    return UNITY_END();
}
