// SPDX-License-Identifier: MIT
// Unit tests of the .vdm loader (every corruption, versions 1 and 2), requantisation, sigmoid table, input stretch, hand-worked layers and golden vectors.
#include "unity.h"
#include "testutil.h"

#include <stdio.h>
#include <string.h>

#include "core/crc32.h"
#include "../data/dbn_golden.h"

void setUp(void) {}
void tearDown(void) {}

// ------------------------------------------------------------ blob builder

#define HAND_TOTAL 172u

static union {
    uint64_t align;
    uint8_t b[512];
} g_blob;

static void wr_u16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)((v >> 8) & 0xFFu);
}

static void wr_u32(uint8_t *p, uint32_t v)
{
    wr_u16(p, v & 0xFFFFu);
    wr_u16(p + 2, v >> 16);
}

static void wr_i32(uint8_t *p, int32_t v)
{
    wr_u32(p, (uint32_t)v);
}

static void fix_crc(uint8_t *b)
{
    uint32_t total = (uint32_t)b[8] | ((uint32_t)b[9] << 8) | ((uint32_t)b[10] << 16) | ((uint32_t)b[11] << 24);
    wr_u32(b + 12, vd__crc32(0u, b + 16, total - 16u));
}

// The hand-worked model: 2x2 grey input, 4 -> 2 -> 1.
//  layer 0 unit 0: w = {1, 2, -1, 0},     bias 10,  mult 2^30, shift 0  (x0.5)
//          unit 1: w = {-127, 127, 0, 5}, bias -100, mult 2^30, shift -2 (x0.125)
//  layer 1 unit 0: w = {2, -3},           bias 50,  mult 2^30, shift 1  (x1.0)
// Layout: header 0..63, layer table 64..127, layer 0 arrays at 128 (w), 136
// (bias), 144 (mult), 152 (shift), layer 1 at 156, 160, 164, 168; total 172.
static void build_hand(uint8_t *b)
{
    memset(b, 0, sizeof g_blob.b);
    memcpy(b, "VDMF", 4);
    wr_u16(b + 4, 1u);          // version
    wr_u16(b + 6, 64u);         // header size
    wr_u32(b + 8, HAND_TOTAL);  // total size
    wr_u16(b + 16, 2u);         // input w
    wr_u16(b + 18, 2u);         // input h
    b[20] = 1u;                 // grey
    b[21] = 1u;                 // sigmoid Q8
    wr_u16(b + 22, 2u);         // layers
    wr_u16(b + 24, 255u);       // norm divisor
    wr_u32(b + 28, 64u);        // layer table
    memcpy(b + 40, "hand", 4);
    uint8_t *e = b + 64;
    wr_u32(e + 0, 4u);
    wr_u32(e + 4, 2u);
    wr_u32(e + 8, 128u);
    wr_u32(e + 12, 136u);
    wr_u32(e + 16, 144u);
    wr_u32(e + 20, 152u);
    e = b + 96;
    wr_u32(e + 0, 2u);
    wr_u32(e + 4, 1u);
    wr_u32(e + 8, 156u);
    wr_u32(e + 12, 160u);
    wr_u32(e + 16, 164u);
    wr_u32(e + 20, 168u);
    const int8_t w0[8] = {1, 2, -1, 0, -127, 127, 0, 5};
    memcpy(b + 128, w0, 8);
    wr_i32(b + 136, 10);
    wr_i32(b + 140, -100);
    wr_i32(b + 144, 1 << 30);
    wr_i32(b + 148, 1 << 30);
    b[152] = 0u;
    b[153] = (uint8_t)0xFEu; // -2
    const int8_t w1[2] = {2, -3};
    memcpy(b + 156, w1, 2);
    wr_i32(b + 160, 50);
    wr_i32(b + 164, 1 << 30);
    b[168] = 1u;
    fix_crc(b);
}

static vd_status_t load_hand(vd_dbn_model_t *m)
{
    return vd_dbn_load(m, g_blob.b, HAND_TOTAL);
}

// ------------------------------------------------------------------ tests

static void test_crc32_check_value(void)
{
    TEST_ASSERT_EQUAL_HEX32(0xCBF43926u, vd__crc32(0u, "123456789", 9));
    // In pieces gives the same result.
    uint32_t c = vd__crc32(0u, "1234", 4);
    TEST_ASSERT_EQUAL_HEX32(0xCBF43926u, vd__crc32(c, "56789", 5));
    TEST_ASSERT_EQUAL_HEX32(0u, vd__crc32(0u, "", 0));
    // The table-driven CRC against testutil's bit-by-bit one on every byte value and length 0..512.
    uint8_t buf[512];
    uint32_t s = 12345u;
    for (size_t i = 0u; i < sizeof buf; i++) {
        s = s * 1103515245u + 12345u;
        buf[i] = (uint8_t)(i < 256u ? i : (s >> 16));
    }
    TEST_ASSERT_EQUAL_HEX32(0xCBF43926u, tu_crc32((const uint8_t *)"123456789", 9));
    for (size_t n = 0u; n <= sizeof buf; n += 7u) {
        TEST_ASSERT_EQUAL_HEX32(tu_crc32(buf, n), vd__crc32(0u, buf, n));
    }
}

static void test_sigmoid_table_ends(void)
{
    TEST_ASSERT_EQUAL_UINT8(0u, vd_dbn_sigmoid_q8(-2048));
    TEST_ASSERT_EQUAL_UINT8(0u, vd_dbn_sigmoid_q8(INT32_MIN));
    TEST_ASSERT_EQUAL_UINT8(0u, vd_dbn_sigmoid_q8(-100000));
    TEST_ASSERT_EQUAL_UINT8(128u, vd_dbn_sigmoid_q8(0));
    TEST_ASSERT_EQUAL_UINT8(255u, vd_dbn_sigmoid_q8(2048));
    TEST_ASSERT_EQUAL_UINT8(255u, vd_dbn_sigmoid_q8(INT32_MAX));
    // 256*sigmoid(1/256) = 128.25 -> 128; sigmoid(1.0) = 0.731059 -> 187.15 -> 187
    TEST_ASSERT_EQUAL_UINT8(128u, vd_dbn_sigmoid_q8(1));
    TEST_ASSERT_EQUAL_UINT8(187u, vd_dbn_sigmoid_q8(256));
    TEST_ASSERT_EQUAL_UINT8(69u, vd_dbn_sigmoid_q8(-256)); // 68.85
    // On both sides of the stored steps (first, second, last): 256*sigmoid(z/256) =
    // 0.4990 | 0.5010 at -1597 | -1596, 1.4957 | 1.5015 at -1315 | -1314, 127.25 | 127.50000254 at -3 | -2;
    // z > 0 by the mirror: 128.49999746 at 2, 128.75 at 3.
    TEST_ASSERT_EQUAL_UINT8(0u, vd_dbn_sigmoid_q8(-1597));
    TEST_ASSERT_EQUAL_UINT8(1u, vd_dbn_sigmoid_q8(-1596));
    TEST_ASSERT_EQUAL_UINT8(1u, vd_dbn_sigmoid_q8(-1315));
    TEST_ASSERT_EQUAL_UINT8(2u, vd_dbn_sigmoid_q8(-1314));
    TEST_ASSERT_EQUAL_UINT8(127u, vd_dbn_sigmoid_q8(-3));
    TEST_ASSERT_EQUAL_UINT8(128u, vd_dbn_sigmoid_q8(-2));
    TEST_ASSERT_EQUAL_UINT8(128u, vd_dbn_sigmoid_q8(2));
    TEST_ASSERT_EQUAL_UINT8(129u, vd_dbn_sigmoid_q8(3));
    // Monotonic, and symmetric up to the 255 clamp: t(z) + t(-z) in {255, 256}.
    for (int32_t z = -2048; z < 2048; z++) {
        TEST_ASSERT_TRUE(vd_dbn_sigmoid_q8(z) <= vd_dbn_sigmoid_q8(z + 1));
        const uint32_t s = (uint32_t)vd_dbn_sigmoid_q8(z) + vd_dbn_sigmoid_q8(-z);
        TEST_ASSERT_TRUE(s == 255u || s == 256u);
    }
}

static void test_requantize_rounding_and_saturation(void)
{
    // mult 2^30 = 0.5: SRDHM rounds 1.5 -> 2 but -1.5 -> -1 (gemmlowp nudge + truncation).
    TEST_ASSERT_EQUAL_INT32(2, vd_dbn_requantize(3, 1 << 30, 0));
    TEST_ASSERT_EQUAL_INT32(-1, vd_dbn_requantize(-3, 1 << 30, 0));
    TEST_ASSERT_EQUAL_INT32(0, vd_dbn_requantize(0, 1 << 30, 0));
    // Double rounding (TFLite default path): 5*0.25 = 1.25: SRDHM 2.5 -> 3, then 3/2 -> 2.
    TEST_ASSERT_EQUAL_INT32(2, vd_dbn_requantize(5, 1 << 30, -1));
    TEST_ASSERT_EQUAL_INT32(-1, vd_dbn_requantize(-5, 1 << 30, -1));
    // RoundingDivideByPOT ties away from zero: +-3 / 2 -> +-2 (mult ~ 1.0 keeps x).
    TEST_ASSERT_EQUAL_INT32(2, vd_dbn_requantize(3, INT32_MAX, -1));
    TEST_ASSERT_EQUAL_INT32(-2, vd_dbn_requantize(-3, INT32_MAX, -1));
    TEST_ASSERT_EQUAL_INT32(1, vd_dbn_requantize(INT32_MAX, INT32_MAX, -31));
    TEST_ASSERT_EQUAL_INT32(-1, vd_dbn_requantize(INT32_MIN, INT32_MAX, -31));
    TEST_ASSERT_EQUAL_INT32(0, vd_dbn_requantize(1, 1 << 30, -31));
    // Left shift saturates to int32 before the multiply.
    TEST_ASSERT_EQUAL_INT32(1 << 30, vd_dbn_requantize(INT32_MAX, 1 << 30, 7));
    TEST_ASSERT_EQUAL_INT32(-(1 << 30), vd_dbn_requantize(INT32_MIN, 1 << 30, 7));
    // 2^24 << 7 = 2^31 saturates to 2^31-1; (2^31-1)^2 / 2^31 = 2^31 - 2 + 2^-31 -> 2^31 - 2.
    TEST_ASSERT_EQUAL_INT32(INT32_MAX - 1, vd_dbn_requantize(1 << 24, INT32_MAX, 7));
    // Exact case: 100 * 0.75 * 2 = 150.
    TEST_ASSERT_EQUAL_INT32(150, vd_dbn_requantize(100, 0x60000000, 1));
}

static void test_requantize_golden(void)
{
    for (uint32_t i = 0u; i < GOLDEN_N_REQUANT; i++) {
        TEST_ASSERT_EQUAL_INT32_MESSAGE(golden_rq_out[i],
                                        vd_dbn_requantize(golden_rq_acc[i], golden_rq_mult[i], golden_rq_shift[i]),
                                        "golden requantise vector");
    }
}

static void test_hand_worked_model(void)
{
    build_hand(g_blob.b);
    vd_dbn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, load_hand(&m));
    TEST_ASSERT_EQUAL_UINT32(2u, m.n_layers);
    TEST_ASSERT_EQUAL_UINT32(2u, m.input_w);
    TEST_ASSERT_EQUAL_UINT32(2u, m.input_h);
    TEST_ASSERT_EQUAL_INT(VD_DBN_INPUT_GREY, m.input_mode);
    TEST_ASSERT_EQUAL_UINT32(2u, m.max_units);
    TEST_ASSERT_EQUAL_UINT32(HAND_TOTAL, m.size);
    TEST_ASSERT_EQUAL_STRING("hand", m.name);
    TEST_ASSERT_TRUE(m.layers[0].weights == (const int8_t *)(const void *)(g_blob.b + 128)); // in place
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_workspace_size(&m, &bytes));
    TEST_ASSERT_EQUAL_UINT32(16u, (uint32_t)bytes); // 2 buffers of 2 bytes, each aligned to 8
    static uint64_t ws[4];
    const uint8_t x[4] = {10, 20, 30, 40};
    uint8_t score = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_classify(&m, x, ws, bytes, &score));
    // Unit 0: acc = 10 + 40 - 30 + 0 + 10 = 30, x0.5 -> z 15 (Q8) -> 256*sig(0.0586) = 131.75 -> 132.
    // Unit 1: acc = -1270 + 2540 + 0 + 200 - 100 = 1370, x0.125 -> 171.25 -> 171 -> 169.23 -> 169.
    // Output: acc = 2*132 - 3*169 + 50 = -193, x1 -> -193 -> 256*sig(-0.754) = 81.9 -> 82.
    const uint8_t *h = (const uint8_t *)ws; // second layer wrote buffer 1, first buffer 0
    TEST_ASSERT_EQUAL_UINT8(132u, h[0]);
    TEST_ASSERT_EQUAL_UINT8(169u, h[1]);
    TEST_ASSERT_EQUAL_UINT8(82u, score);
}

static void test_golden_vectors(void)
{
    vd_dbn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_load(&m, golden_model.bytes, sizeof golden_model.bytes));
    TEST_ASSERT_EQUAL_UINT32(3u, m.n_layers);
    TEST_ASSERT_EQUAL_STRING("golden_tiny", m.name);
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_workspace_size(&m, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    for (uint32_t i = 0u; i < GOLDEN_N_INPUTS; i++) {
        uint8_t s = 0;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_classify(&m, golden_inputs + i * GOLDEN_INPUT_LEN, ws, bytes, &s));
        TEST_ASSERT_EQUAL_UINT8_MESSAGE(golden_scores[i], s, "golden score");
    }
    tu_guard_check(0);
    tu_guarded_free(0);
}

typedef struct ws_ctx {
    const vd_dbn_model_t *m;
    const uint8_t *x;
} ws_ctx_t;

static vd_status_t run_classify(void *ws, size_t bytes, void *ctx)
{
    const ws_ctx_t *c = (const ws_ctx_t *)ctx;
    uint8_t s;
    return vd_dbn_classify(c->m, c->x, ws, bytes, &s);
}

static void test_workspace_contract(void)
{
    vd_dbn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_load(&m, golden_model.bytes, sizeof golden_model.bytes));
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_workspace_size(&m, &bytes));
    ws_ctx_t ctx = {&m, golden_inputs};
    tu_check_workspace_contract(bytes, run_classify, &ctx);
    uint8_t s;
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_dbn_classify(&m, golden_inputs, NULL, bytes, &s));
}

static void test_args_and_state(void)
{
    vd_dbn_model_t m;
    build_hand(g_blob.b);
    static uint64_t ws[4];
    uint8_t s;
    size_t bytes;
    const uint8_t x[4] = {0, 0, 0, 0};
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_load(NULL, g_blob.b, HAND_TOTAL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_load(&m, NULL, HAND_TOTAL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_load(&m, g_blob.b, 0));
    memset(&m, 0, sizeof m); // never loaded
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_dbn_workspace_size(&m, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_dbn_classify(&m, x, ws, sizeof ws, &s));
    TEST_ASSERT_EQUAL_INT(VD_OK, load_hand(&m));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_workspace_size(NULL, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_workspace_size(&m, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_classify(NULL, x, ws, sizeof ws, &s));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_classify(&m, NULL, ws, sizeof ws, &s));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_classify(&m, x, ws, sizeof ws, NULL));
    // Bytes beyond total_size (flash padding) are ignored.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_load(&m, g_blob.b, sizeof g_blob.b));
}

static void test_misaligned_blob_pointer(void)
{
    static union {
        uint64_t align;
        uint8_t b[HAND_TOTAL + 8];
    } shifted;
    build_hand(g_blob.b);
    for (size_t off = 1; off < 4; off++) {
        memcpy(shifted.b + off, g_blob.b, HAND_TOTAL);
        vd_dbn_model_t m;
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_load(&m, shifted.b + off, HAND_TOTAL));
    }
    memcpy(shifted.b + 4, g_blob.b, HAND_TOTAL);
    vd_dbn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_load(&m, shifted.b + 4, HAND_TOTAL));
}

static void test_every_bit_flip_is_rejected(void)
{
    // Every single-bit corruption anywhere in the blob (header fields are
    // checked directly, everything after the CRC field is covered by the CRC).
    for (uint32_t i = 0u; i < HAND_TOTAL; i++) {
        for (uint32_t bit = 0u; bit < 8u; bit++) {
            build_hand(g_blob.b);
            g_blob.b[i] = (uint8_t)(g_blob.b[i] ^ (1u << bit));
            vd_dbn_model_t m;
            memset(&m, 0xA5, sizeof m);
            const vd_status_t st = load_hand(&m);
            if (st != VD_ERR_MODEL) {
                TEST_FAIL_MESSAGE("a flipped bit was accepted");
            }
            // *m untouched on failure.
            TEST_ASSERT_EQUAL_UINT8(0xA5u, ((const uint8_t *)&m)[0]);
        }
    }
}

static void test_every_truncation_is_rejected(void)
{
    build_hand(g_blob.b);
    vd_dbn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_load(&m, g_blob.b, 0));
    for (size_t n = 1; n < HAND_TOTAL; n++) {
        TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_dbn_load(&m, g_blob.b, n));
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_load(&m, g_blob.b, HAND_TOTAL));
    // The same for the golden model (several layers).
    static union {
        uint64_t align;
        uint8_t b[sizeof golden_model.bytes];
    } g;
    memcpy(g.b, golden_model.bytes, sizeof g.b);
    for (size_t n = 1; n < sizeof g.b; n++) {
        TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_dbn_load(&m, g.b, n));
    }
}

static void test_wrong_crc(void)
{
    build_hand(g_blob.b);
    vd_dbn_model_t m;
    g_blob.b[12] = (uint8_t)(g_blob.b[12] + 1u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, load_hand(&m));
    build_hand(g_blob.b);
    memset(g_blob.b + 12, 0, 4);
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, load_hand(&m));
}

// Structural corruptions with a CORRECT CRC, so the structure checks (not the
// CRC) must catch them.
typedef void (*corrupt_fn)(uint8_t *b);

static void c_version(uint8_t *b) { wr_u16(b + 4, 3u); }
static void c_version_zero(uint8_t *b) { wr_u16(b + 4, 0u); }
static void c_norm_in_v1(uint8_t *b) { b[36] = 1u; b[37] = 16u; }                      // version 1: reserved
static void c_norm_unknown(uint8_t *b) { wr_u16(b + 4, 2u); b[36] = 2u; b[37] = 16u; }
static void c_norm_range_zero(uint8_t *b) { wr_u16(b + 4, 2u); b[36] = 1u; }
static void c_norm_none_range(uint8_t *b) { wr_u16(b + 4, 2u); b[37] = 5u; }
static void c_reserved0_hi(uint8_t *b) { wr_u16(b + 4, 2u); b[36] = 1u; b[37] = 16u; b[39] = 0x80u; }
static void c_header_size(uint8_t *b) { wr_u16(b + 6, 72u); }
static void c_total_unaligned(uint8_t *b) { wr_u32(b + 8, HAND_TOTAL - 2u); }
static void c_total_small(uint8_t *b) { wr_u32(b + 8, 60u); }
static void c_input_w(uint8_t *b) { wr_u16(b + 16, 4u); }
static void c_input_zero(uint8_t *b) { wr_u16(b + 18, 0u); }
static void c_input_huge(uint8_t *b) { wr_u16(b + 16, 300u); }
static void c_mode(uint8_t *b) { b[20] = 3u; }
static void c_activation(uint8_t *b) { b[21] = 2u; }
static void c_layers_zero(uint8_t *b) { wr_u16(b + 22, 0u); }
static void c_layers_many(uint8_t *b) { wr_u16(b + 22, 9u); }
static void c_layers_one(uint8_t *b) { wr_u16(b + 22, 1u); } // last out would be 2
static void c_norm_zero(uint8_t *b) { wr_u16(b + 24, 0u); }
static void c_table_low(uint8_t *b) { wr_u32(b + 28, 32u); }
static void c_table_unaligned(uint8_t *b) { wr_u32(b + 28, 66u); }
static void c_table_beyond(uint8_t *b) { wr_u32(b + 28, 0xFFFFFFF0u); }
static void c_flags(uint8_t *b) { b[32] = 1u; }
static void c_reserved0(uint8_t *b) { b[37] = 1u; }
static void c_reserved1(uint8_t *b) { b[63] = 1u; }
static void c_name(uint8_t *b) { b[41] = 0x07u; }
static void c_name_gap(uint8_t *b) { b[50] = 'x'; }
static void c_in_mismatch(uint8_t *b) { wr_u32(b + 96, 3u); }
static void c_first_in(uint8_t *b) { wr_u32(b + 64, 5u); }
static void c_out_zero(uint8_t *b) { wr_u32(b + 68, 0u); }
static void c_last_out(uint8_t *b) { wr_u32(b + 100, 2u); }
static void c_out_huge(uint8_t *b) { wr_u32(b + 68, 0x40000001u); wr_u32(b + 96, 0x40000001u); }
static void c_w_unaligned(uint8_t *b) { wr_u32(b + 72, 129u); }
static void c_w_overlap(uint8_t *b) { wr_u32(b + 76, 132u); }    // bias overlaps weights
static void c_w_in_table(uint8_t *b) { wr_u32(b + 72, 96u); }    // weights inside the layer table
static void c_shift_overlap(uint8_t *b) { wr_u32(b + 116, 152u); } // layer 1 shift = layer 0 shift
static void c_mult_beyond(uint8_t *b) { wr_u32(b + 112, 168u); }  // layer 1 mult overlaps its shift
static void c_bias_end(uint8_t *b) { wr_u32(b + 108, HAND_TOTAL); } // 4 bytes past the end
static void c_off_wrap(uint8_t *b) { wr_u32(b + 104, 0xFFFFFFFCu); } // offset + len wraps 32 bits
static void c_layer_flags(uint8_t *b) { b[64 + 24] = 1u; }
static void c_layer_reserved(uint8_t *b) { b[96 + 31] = 1u; }
static void c_mult_small(uint8_t *b) { wr_i32(b + 144, (1 << 30) - 1); }
static void c_mult_negative(uint8_t *b) { wr_i32(b + 148, INT32_MIN); }
static void c_shift_big(uint8_t *b) { b[152] = 8u; }
static void c_shift_small(uint8_t *b) { b[153] = (uint8_t)0xE0u; } // -32
static void c_bias_big(uint8_t *b) { wr_i32(b + 136, INT32_MAX - 4 * 127 * 255 + 1); }
static void c_bias_small(uint8_t *b) { wr_i32(b + 160, -(INT32_MAX - 2 * 127 * 255 + 1)); }

static void test_structural_corruptions(void)
{
    static const corrupt_fn fns[] = {
        c_version, c_header_size, c_total_unaligned, c_total_small, c_input_w, c_input_zero, c_input_huge,
        c_mode, c_activation, c_layers_zero, c_layers_many, c_layers_one, c_norm_zero, c_table_low,
        c_table_unaligned, c_table_beyond, c_flags, c_reserved0, c_reserved1, c_name, c_name_gap,
        c_in_mismatch, c_first_in, c_out_zero, c_last_out, c_out_huge, c_w_unaligned, c_w_overlap,
        c_w_in_table, c_shift_overlap, c_mult_beyond, c_bias_end, c_off_wrap, c_layer_flags,
        c_layer_reserved, c_mult_small, c_mult_negative, c_shift_big, c_shift_small, c_bias_big,
        c_bias_small, c_version_zero, c_norm_in_v1, c_norm_unknown, c_norm_range_zero, c_norm_none_range,
        c_reserved0_hi,
    };
    for (size_t i = 0; i < sizeof fns / sizeof fns[0]; i++) {
        build_hand(g_blob.b);
        fns[i](g_blob.b);
        fix_crc(g_blob.b);
        vd_dbn_model_t m;
        const vd_status_t st = vd_dbn_load(&m, g_blob.b, HAND_TOTAL);
        if (st != VD_ERR_MODEL) {
            char msg[64];
            snprintf(msg, sizeof msg, "structural corruption #%u accepted (status %d)", (unsigned)i, (int)st);
            TEST_FAIL_MESSAGE(msg);
        }
    }
    // Boundary values that must still load.
    build_hand(g_blob.b);
    wr_i32(g_blob.b + 136, INT32_MAX - 4 * 127 * 255);
    wr_i32(g_blob.b + 144, INT32_MAX);
    g_blob.b[152] = 7u;
    g_blob.b[153] = (uint8_t)0xE1u; // -31
    fix_crc(g_blob.b);
    vd_dbn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, load_hand(&m));
    static uint64_t ws[4];
    const uint8_t x[4] = {255, 0, 0, 255};
    uint8_t s;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_classify(&m, x, ws, sizeof ws, &s));
}

// ------------------------------------------------------- input normalisation

static void test_stretch_hand_worked(void)
{
    uint8_t out[4];
    // Flat sample: range 0 < min_range, every byte maps to 0.
    const uint8_t flat[3] = {7, 7, 7};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_stretch_u8(flat, 3u, 16u, out));
    TEST_ASSERT_EQUAL_UINT8(0u, out[0]);
    TEST_ASSERT_EQUAL_UINT8(0u, out[2]);
    const uint8_t flat255[2] = {255, 255};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_stretch_u8(flat255, 2u, 1u, out));
    TEST_ASSERT_EQUAL_UINT8(0u, out[1]);
    // r = 32: (0*510+32)/64 = 0, (10*510+32)/64 = 80.19, (20*510+32)/64 = 159.9, (32*510+32)/64 = 255.5.
    const uint8_t a[4] = {10, 20, 30, 42};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_stretch_u8(a, 4u, 16u, out));
    TEST_ASSERT_EQUAL_UINT8(0u, out[0]);
    TEST_ASSERT_EQUAL_UINT8(80u, out[1]);
    TEST_ASSERT_EQUAL_UINT8(159u, out[2]);
    TEST_ASSERT_EQUAL_UINT8(255u, out[3]);
    // Range 8 below min_range 16: divided by 16, the maximum does not reach 255.
    const uint8_t n[3] = {100, 104, 108};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_stretch_u8(n, 3u, 16u, out));
    TEST_ASSERT_EQUAL_UINT8(0u, out[0]);
    TEST_ASSERT_EQUAL_UINT8(64u, out[1]);  // 2056 / 32 = 64.25
    TEST_ASSERT_EQUAL_UINT8(128u, out[2]); // 4096 / 32 = 128 exactly
    // Tie: 255 * 1 / 2 = 127.5 rounds up to 128.
    const uint8_t t[2] = {0, 1};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_stretch_u8(t, 2u, 2u, out));
    TEST_ASSERT_EQUAL_UINT8(0u, out[0]);
    TEST_ASSERT_EQUAL_UINT8(128u, out[1]);
    // Full range is the identity; in place works.
    uint8_t io[3] = {0, 128, 255};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_stretch_u8(io, 3u, 255u, io));
    TEST_ASSERT_EQUAL_UINT8(0u, io[0]);
    TEST_ASSERT_EQUAL_UINT8(128u, io[1]);
    TEST_ASSERT_EQUAL_UINT8(255u, io[2]);
    // Arguments.
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_stretch_u8(NULL, 3u, 16u, out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_stretch_u8(a, 3u, 16u, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_stretch_u8(a, 0u, 16u, out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_stretch_u8(a, 3u, 0u, out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_dbn_stretch_u8(a, 3u, 256u, out));
}

// Naive reference: the largest q with q * 2r <= 510 (v - lo) + r, by counting.
static void stretch_naive(const uint8_t *in, uint32_t n, uint32_t min_range, uint8_t *out)
{
    uint32_t lo = 255u, hi = 0u;
    for (uint32_t i = 0u; i < n; i++) {
        lo = (in[i] < lo) ? in[i] : lo;
        hi = (in[i] > hi) ? in[i] : hi;
    }
    const uint32_t r = (hi - lo > min_range) ? hi - lo : min_range;
    for (uint32_t i = 0u; i < n; i++) {
        const uint32_t num = 510u * ((uint32_t)in[i] - lo) + r;
        uint32_t q = 0u;
        while (q < 255u && (q + 1u) * 2u * r <= num) {
            q++;
        }
        out[i] = (uint8_t)q;
    }
}

static void test_stretch_random_vs_naive(void)
{
    static uint8_t x[1024], a[1024], b[1024];
    uint32_t seed = 12345u;
    for (uint32_t trial = 0u; trial < 200u; trial++) {
        const uint32_t base = tu_rand(&seed) % 256u;
        const uint32_t spread = 1u + tu_rand(&seed) % 256u;
        const uint32_t n = 1u + tu_rand(&seed) % 1024u;
        const uint32_t mr = 1u + tu_rand(&seed) % 255u;
        for (uint32_t i = 0u; i < n; i++) {
            uint32_t v = base + tu_rand(&seed) % spread;
            x[i] = (uint8_t)(v > 255u ? 255u : v);
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_stretch_u8(x, n, mr, a));
        stretch_naive(x, n, mr, b);
        TEST_ASSERT_EQUAL_UINT8_ARRAY(b, a, n);
    }
}

// The hand model as version 2 with min-max normalisation (min range 16).
static void test_hand_worked_model_minmax(void)
{
    build_hand(g_blob.b);
    wr_u16(g_blob.b + 4, 2u);
    g_blob.b[36] = 1u;
    g_blob.b[37] = 16u;
    fix_crc(g_blob.b);
    vd_dbn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, load_hand(&m));
    TEST_ASSERT_EQUAL_UINT32(2u, m.format_version);
    TEST_ASSERT_EQUAL_INT(VD_DBN_NORM_MINMAX, m.input_norm);
    TEST_ASSERT_EQUAL_UINT32(16u, m.norm_min_range);
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_workspace_size(&m, &bytes));
    TEST_ASSERT_EQUAL_UINT32(24u, (uint32_t)bytes); // + the 4-byte stretched sample, aligned to 8
    static uint64_t ws[4];
    const uint8_t x[4] = {10, 20, 30, 40};
    uint8_t score = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_classify(&m, x, ws, bytes, &score));
    // Stretch, r = 30: (v - 10) * 510 + 30) / 60 -> {0, 85 (85.5), 170 (170.5), 255 (255.5)}.
    const uint8_t *st = (const uint8_t *)ws + 16;
    TEST_ASSERT_EQUAL_UINT8(0u, st[0]);
    TEST_ASSERT_EQUAL_UINT8(85u, st[1]);
    TEST_ASSERT_EQUAL_UINT8(170u, st[2]);
    TEST_ASSERT_EQUAL_UINT8(255u, st[3]);
    // Unit 0: acc = 10 + 0 + 170 - 170 + 0 = 10, x0.5 -> 5 -> 256*sig(0.0195) = 129.25 -> 129.
    // Unit 1: acc = -100 + 0 + 127*85 + 0 + 5*255 = 11970, x0.125 -> 1496.25 -> 1496 -> 255.3 -> 255.
    // Output: acc = 50 + 2*129 - 3*255 = -457, x1 -> 256*sig(-1.785) = 36.8 -> 37.
    const uint8_t *h = (const uint8_t *)ws;
    TEST_ASSERT_EQUAL_UINT8(129u, h[0]);
    TEST_ASSERT_EQUAL_UINT8(255u, h[1]);
    TEST_ASSERT_EQUAL_UINT8(37u, score);
    TEST_ASSERT_EQUAL_UINT8(10u, x[0]); // input untouched
    // A brighter copy of the same pattern scores the same (what the stretch is for).
    const uint8_t x2[4] = {110, 120, 130, 140};
    uint8_t score2 = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_classify(&m, x2, ws, bytes, &score2));
    TEST_ASSERT_EQUAL_UINT8(score, score2);
    // Flat sample: stretched to all 0; acc0 = 10 -> 5 -> 129, acc1 = -100 -> -12.5 -> -13 -> 124.9 -> 125,
    // output 50 + 258 - 375 = -67 -> 256*sig(-0.262) = 111.4 -> 111.
    const uint8_t flat[4] = {200, 200, 200, 200};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_classify(&m, flat, ws, bytes, &score));
    TEST_ASSERT_EQUAL_UINT8(129u, h[0]);
    TEST_ASSERT_EQUAL_UINT8(125u, h[1]);
    TEST_ASSERT_EQUAL_UINT8(111u, score);
    // The contract: one byte short of the larger workspace fails.
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_dbn_classify(&m, x, ws, bytes - 1u, &score));
}

static void test_golden_vectors_minmax(void)
{
    vd_dbn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_load(&m, golden_norm_model.bytes, sizeof golden_norm_model.bytes));
    TEST_ASSERT_EQUAL_INT(VD_DBN_NORM_MINMAX, m.input_norm);
    TEST_ASSERT_EQUAL_UINT32(GOLDEN_NORM_MIN_RANGE, m.norm_min_range);
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_workspace_size(&m, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    for (uint32_t i = 0u; i < GOLDEN_N_INPUTS; i++) {
        uint8_t s = 0;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_dbn_classify(&m, golden_inputs + i * GOLDEN_INPUT_LEN, ws, bytes, &s));
        TEST_ASSERT_EQUAL_UINT8_MESSAGE(golden_norm_scores[i], s, "golden score (minmax)");
    }
    tu_guard_check(0);
    tu_guarded_free(0);
    ws_ctx_t ctx = {&m, golden_inputs};
    tu_check_workspace_contract(bytes, run_classify, &ctx);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_stretch_hand_worked);
    RUN_TEST(test_stretch_random_vs_naive);
    RUN_TEST(test_hand_worked_model_minmax);
    RUN_TEST(test_golden_vectors_minmax);
    RUN_TEST(test_crc32_check_value);
    RUN_TEST(test_sigmoid_table_ends);
    RUN_TEST(test_requantize_rounding_and_saturation);
    RUN_TEST(test_requantize_golden);
    RUN_TEST(test_hand_worked_model);
    RUN_TEST(test_golden_vectors);
    RUN_TEST(test_workspace_contract);
    RUN_TEST(test_args_and_state);
    RUN_TEST(test_misaligned_blob_pointer);
    RUN_TEST(test_every_bit_flip_is_rejected);
    RUN_TEST(test_every_truncation_is_rejected);
    RUN_TEST(test_wrong_crc);
    RUN_TEST(test_structural_corruptions);
    return UNITY_END();
}
