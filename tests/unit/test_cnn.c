// SPDX-License-Identifier: MIT
// Unit tests of the int8 CNN (vd/cnn.h): hand-worked ops, requantisation, stretch, planner, decoding,
// random models against a naive reference, the streamed executor against the whole-plane one, hostile blobs.
//
// Test models are written by a small C writer (tm_write) in the layout of
// docs/model-format.md, so the test needs no Python. The naive reference
// (ref_forward) is the spec's formula evaluated directly: int64 sums over
// in-range taps of w * (x - zp), vd_rq_requantize, clamp.
#include "unity.h"
#include "testutil.h"

#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "models/cnn/cnn_internal.h"
#include "core/crc32.h"
#include "models/requant.h"

void setUp(void) {}
void tearDown(void) {}

// ------------------------------------------------------------ model writer

#define BLOB_CAP (1u << 20)

static union {
    uint64_t align;
    uint8_t b[BLOB_CAP + 16u];
} g_blob;

// One layer of a test model; arrays are NULL for ops 4-6.
typedef struct tl {
    uint8_t op, stride, in, in2;
    uint16_t cin, cout;
    int8_t zp, amin, amax;
    const int8_t *w;
    const int32_t *bias;
    const int32_t *mult;
    const int8_t *shift;
} tl_t;

typedef struct tm {
    uint8_t norm;
    uint16_t in_w, in_h, lo, hi, min_range;
    uint8_t out_stride, n_ch;
    int8_t thr;
    uint16_t max_peaks;
    const char *name;
    uint32_t n;
    tl_t L[VD_CNN_MAX_LAYERS];
    const int32_t *table;   // [n_ch][256]
} tm_t;

static uint32_t al4(uint32_t x)
{
    return (x + 3u) & ~3u;
}

static uint32_t w_len(const tl_t *L)
{
    switch (L->op) {
    case VD_CNN_OP_CONV3X3:
        return 9u * L->cin * L->cout;
    case VD_CNN_OP_CONV5X5:
        return 25u * L->cin * L->cout;
    case VD_CNN_OP_DW3X3:
        return 9u * L->cout;
    case VD_CNN_OP_PW1X1:
        return (uint32_t)L->cin * L->cout;
    default:
        return 0u;
    }
}

// Writes the .vdm blob of d into b (layout of the exporter: header, layer
// table, per layer weights/bias/mult/shift each 4-aligned, decode table);
// returns total_size.
static uint32_t tm_write(const tm_t *d, uint8_t *b)
{
    uint32_t pos = VD_CNN_HEADER_SIZE + VD_CNN_LAYER_ENTRY_SIZE * d->n;
    for (uint32_t l = 0u; l < d->n; l++) {
        const tl_t *L = &d->L[l];
        if (L->w != NULL) {
            pos = al4(pos) + w_len(L);
            pos = al4(pos) + 8u * L->cout;
            pos = al4(pos) + 4u * L->cout;
            pos += L->cout;
        }
    }
    const uint32_t dec = al4(pos);
    const uint32_t total = al4(dec + 4u * 256u * d->n_ch);
    TEST_ASSERT_TRUE(total <= BLOB_CAP);
    memset(b, 0, total);
    memcpy(b, "VDMF", 4);
    tu_wr16(b + 4, 3u);
    tu_wr16(b + 6, 128u);
    tu_wr32(b + 8, total);
    b[16] = 2u;
    b[17] = d->norm;
    b[18] = (uint8_t)d->n;
    b[19] = d->n_ch;
    tu_wr16(b + 20, d->in_w);
    tu_wr16(b + 22, d->in_h);
    tu_wr16(b + 24, d->lo);
    tu_wr16(b + 26, d->hi);
    tu_wr16(b + 28, d->min_range);
    b[30] = 0x80u;   // -128
    b[31] = d->out_stride;
    tu_wr32(b + 32, 128u);
    tu_wr32(b + 36, dec);
    b[40] = (uint8_t)d->thr;
    tu_wr16(b + 42, d->max_peaks);
    if (d->name != NULL) {
        memcpy(b + 48, d->name, strlen(d->name));
    }
    pos = VD_CNN_HEADER_SIZE + VD_CNN_LAYER_ENTRY_SIZE * d->n;
    for (uint32_t l = 0u; l < d->n; l++) {
        const tl_t *L = &d->L[l];
        uint8_t *e = b + 128u + 32u * l;
        e[0] = L->op;
        e[1] = L->stride;
        e[2] = L->in;
        e[3] = L->in2;
        tu_wr16(e + 4, L->cin);
        tu_wr16(e + 6, L->cout);
        e[8] = (uint8_t)L->zp;
        e[9] = (uint8_t)L->amin;
        e[10] = (uint8_t)L->amax;
        if (L->w == NULL) {
            continue;
        }
        pos = al4(pos);
        tu_wr32(e + 12, pos);
        memcpy(b + pos, L->w, w_len(L));
        pos = al4(pos + w_len(L));
        tu_wr32(e + 16, pos);
        for (uint32_t o = 0u; o < L->cout; o++) {
            tu_wr32(b + pos + 4u * o, (uint32_t)L->bias[o]);
        }
        pos += 4u * L->cout;
        tu_wr32(e + 20, pos);
        for (uint32_t o = 0u; o < L->cout; o++) {
            tu_wr32(b + pos + 4u * o, (uint32_t)L->mult[o]);
        }
        pos += 4u * L->cout;
        tu_wr32(e + 24, pos);
        memcpy(b + pos, L->shift, L->cout);
        pos += L->cout;
    }
    for (uint32_t i = 0u; i < 256u * d->n_ch; i++) {
        tu_wr32(b + dec + 4u * i, (uint32_t)d->table[i]);
    }
    tu_vdm_fix_crc(b);
    return total;
}

// Default decode table: score i * 128, sizes i * 128 (i / 2 px), offsets
// clamp(4 i - 256, -256, 512).
static int32_t g_table[5 * 256];

static void table_default(void)
{
    for (int32_t i = 0; i < 256; i++) {
        g_table[i] = i * 128;
        g_table[256 + i] = i * 128;
        g_table[512 + i] = i * 128;
        const int32_t off = 4 * i - 256;
        g_table[768 + i] = off > 512 ? 512 : off;
        g_table[1024 + i] = off > 512 ? 512 : off;
    }
}

static tl_t layer_weighted(uint8_t op, uint8_t stride, uint8_t in, uint16_t cin, uint16_t cout, int8_t zp,
                           const int8_t *w, const int32_t *bias, const int32_t *mult, const int8_t *shift)
{
    tl_t L;
    memset(&L, 0, sizeof L);
    L.op = op;
    L.stride = stride;
    L.in = in;
    L.cin = cin;
    L.cout = cout;
    L.zp = zp;
    L.amin = -128;
    L.amax = 127;
    L.w = w;
    L.bias = bias;
    L.mult = mult;
    L.shift = shift;
    return L;
}

static tl_t layer_copy(uint8_t op, uint8_t in, uint8_t in2, uint16_t cin, uint16_t cout, int8_t zp)
{
    tl_t L;
    memset(&L, 0, sizeof L);
    L.op = op;
    L.stride = 1u;
    L.in = in;
    L.in2 = in2;
    L.cin = cin;
    L.cout = cout;
    L.zp = zp;
    L.amin = -128;
    L.amax = 127;
    return L;
}

static void tm_init(tm_t *d, uint16_t w, uint16_t h, uint8_t n_ch, uint8_t out_stride)
{
    memset(d, 0, sizeof *d);
    table_default();
    d->in_w = w;
    d->in_h = h;
    d->n_ch = n_ch;
    d->out_stride = out_stride;
    d->thr = 0;
    d->max_peaks = 100u;
    d->name = "test";
    d->table = g_table;
}

static vd_status_t tm_load(const tm_t *d, vd_cnn_model_t *m)
{
    const uint32_t total = tm_write(d, g_blob.b);
    return vd_cnn_load(m, g_blob.b, total);
}

// Identity requantisation (mult 2^30, shift 1: x * 2 * 2^30 / 2^31 = x).
static const int32_t k_mult1[8] = {1 << 30, 1 << 30, 1 << 30, 1 << 30, 1 << 30, 1 << 30, 1 << 30, 1 << 30};
static const int8_t k_shift1[8] = {1, 1, 1, 1, 1, 1, 1, 1};
static const int32_t k_zero[8] = {0, 0, 0, 0, 0, 0, 0, 0};
// Weights of a head pw cin -> 3 (w[o][c] = k_head_w[o * cin + c]): with
// 2 input channels the head is (c0, 0, c0), with 1 (c0, 0, 0).
static const int8_t k_head_w[3 * 4] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};

// Runs d on img (w x h, contiguous) keeping every tensor; the workspace stays
// allocated in guarded slot 0 until run_free().
static vd_cnn_model_t g_m;
static void *g_ws;
static size_t g_ws_bytes;

static void run_keep(const tm_t *d, const uint8_t *img, uint32_t w, uint32_t h, vd_cnn_output_t *head)
{
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(d, &g_m));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&g_m, w, h, VD_CNN_KEEP_TENSORS, &g_ws_bytes));
    g_ws = tu_guarded_alloc(0, g_ws_bytes);
    memset(g_ws, 0x5A, g_ws_bytes);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run_ex(&g_m, img, w, h, w, VD_CNN_KEEP_TENSORS, g_ws, g_ws_bytes, head));
    tu_guard_check(0);
}

static void run_free(void)
{
    tu_guarded_free(0);
    g_ws = NULL;
}

static void expect_tensor(uint32_t w, uint32_t h, uint32_t index, const int8_t *want, uint32_t tw, uint32_t th,
                          uint32_t tc)
{
    vd_cnn_output_t t;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_tensor(&g_m, g_ws, g_ws_bytes, w, h, index, &t));
    TEST_ASSERT_EQUAL_UINT32(tw, t.w);
    TEST_ASSERT_EQUAL_UINT32(th, t.h);
    TEST_ASSERT_EQUAL_UINT32(tc, t.c);
    TEST_ASSERT_EQUAL_INT8_ARRAY(want, t.data, tw * th * tc);
}

// ------------------------------------------------------------ naive reference

typedef struct ref_shape {
    uint32_t c[VD_CNN_MAX_TENSORS], f[VD_CNN_MAX_TENSORS];
    int32_t zp[VD_CNN_MAX_TENSORS];
} ref_shape_t;

static void ref_shapes(const tm_t *d, ref_shape_t *s)
{
    s->c[0] = 1u;
    s->f[0] = 1u;
    s->zp[0] = -128;
    for (uint32_t l = 0u; l < d->n; l++) {
        const tl_t *L = &d->L[l];
        uint32_t f = s->f[L->in];
        if (L->op == VD_CNN_OP_CONV3X3 || L->op == VD_CNN_OP_DW3X3 || L->op == VD_CNN_OP_CONV5X5) {
            f *= L->stride;
        } else if (L->op == VD_CNN_OP_MAXPOOL2) {
            f *= 2u;
        } else if (L->op == VD_CNN_OP_UPSAMPLE2) {
            f /= 2u;
        }
        s->c[l + 1u] = L->cout;
        s->f[l + 1u] = f;
        s->zp[l + 1u] = L->zp;
    }
}

static int8_t ref_out(const tl_t *L, uint32_t o, int64_t sum)
{
    const int64_t acc = (int64_t)L->bias[o] + sum;
    TEST_ASSERT_TRUE(acc >= INT32_MIN && acc <= INT32_MAX);
    // int64: near INT32_MIN (shift > 0 saturating) z + zp leaves int32.
    int64_t z = (int64_t)vd_rq_requantize((int32_t)acc, L->mult[o], L->shift[o]) + L->zp;
    z = z < L->amin ? L->amin : (z > L->amax ? L->amax : z);
    return (int8_t)z;
}

// Every tensor of d on img (w x h); t[i] are malloc'd, caller frees.
static void ref_forward(const tm_t *d, const uint8_t *img, uint32_t w, uint32_t h, int8_t *t[VD_CNN_MAX_TENSORS])
{
    ref_shape_t s;
    ref_shapes(d, &s);
    t[0] = malloc((size_t)w * h);
    TEST_ASSERT_NOT_NULL(t[0]);
    if (d->norm == 0u) {
        for (uint32_t i = 0u; i < w * h; i++) {
            t[0][i] = (int8_t)(img[i] - 128);
        }
    } else {
        uint32_t hist[256] = {0};
        for (uint32_t i = 0u; i < w * h; i++) {
            hist[img[i]]++;
        }
        const uint64_t n = (uint64_t)w * h;
        const uint64_t tl = n * d->lo / 1000u, th = n * d->hi / 1000u;
        int32_t lo = -1, hi = -1;
        uint64_t cum = 0u;
        for (int32_t v = 0; v < 256; v++) {
            cum += hist[v];
            if (lo < 0 && cum > tl) {
                lo = v;
            }
            if (hi < 0 && cum > th) {
                hi = v;
            }
        }
        hi = hi < 0 ? 255 : hi;
        const int32_t r = (hi - lo > (int32_t)d->min_range) ? hi - lo : (int32_t)d->min_range;
        for (uint32_t i = 0u; i < w * h; i++) {
            int32_t p = 0;
            if (img[i] > lo) {
                p = ((img[i] - lo) * 510 + r) / (2 * r);
                p = p > 255 ? 255 : p;
            }
            t[0][i] = (int8_t)(p - 128);
        }
    }
    for (uint32_t l = 0u; l < d->n; l++) {
        const tl_t *L = &d->L[l];
        const uint32_t wi = w / s.f[L->in], hi = h / s.f[L->in], ci = s.c[L->in];
        const uint32_t wo = w / s.f[l + 1u], ho = h / s.f[l + 1u], co = L->cout;
        const int32_t zin = s.zp[L->in];
        const int8_t *x = t[L->in];
        int8_t *y = malloc((size_t)wo * ho * co);
        TEST_ASSERT_NOT_NULL(y);
        t[l + 1u] = y;
        for (uint32_t oy = 0u; oy < ho; oy++) {
            for (uint32_t ox = 0u; ox < wo; ox++) {
                int8_t *yo = y + ((size_t)oy * wo + ox) * co;
                for (uint32_t o = 0u; o < co; o++) {
                    int64_t sum = 0;
                    switch (L->op) {
                    case VD_CNN_OP_CONV3X3:
                    case VD_CNN_OP_DW3X3:
                    case VD_CNN_OP_CONV5X5: {
                        const int32_t ks = (L->op == VD_CNN_OP_CONV5X5) ? 5 : 3;
                        for (int32_t ky = 0; ky < ks; ky++) {
                            for (int32_t kx = 0; kx < ks; kx++) {
                                const int32_t iy = (int32_t)(oy * L->stride) - ks / 2 + ky;
                                const int32_t ix = (int32_t)(ox * L->stride) - ks / 2 + kx;
                                if (iy < 0 || ix < 0 || iy >= (int32_t)hi || ix >= (int32_t)wi) {
                                    continue;
                                }
                                const int8_t *xp = x + ((size_t)iy * wi + (size_t)ix) * ci;
                                if (L->op == VD_CNN_OP_DW3X3) {
                                    sum += (int64_t)L->w[(ky * 3 + kx) * (int32_t)co + (int32_t)o] * (xp[o] - zin);
                                } else {
                                    for (uint32_t c = 0u; c < ci; c++) {
                                        const uint32_t k = (uint32_t)ks;
                                        sum += (int64_t)L->w[((o * k + (uint32_t)ky) * k + (uint32_t)kx) * ci + c] *
                                               (xp[c] - zin);
                                    }
                                }
                            }
                        }
                        yo[o] = ref_out(L, o, sum);
                        break;
                    }
                    case VD_CNN_OP_PW1X1:
                        for (uint32_t c = 0u; c < ci; c++) {
                            sum += (int64_t)L->w[o * ci + c] * (x[((size_t)oy * wi + ox) * ci + c] - zin);
                        }
                        yo[o] = ref_out(L, o, sum);
                        break;
                    case VD_CNN_OP_MAXPOOL2: {
                        int8_t m = -128;
                        for (uint32_t k = 0u; k < 4u; k++) {
                            const int8_t v = x[((size_t)(2u * oy + k / 2u) * wi + 2u * ox + k % 2u) * ci + o];
                            m = v > m ? v : m;
                        }
                        yo[o] = m;
                        break;
                    }
                    case VD_CNN_OP_UPSAMPLE2:
                        yo[o] = x[((size_t)(oy / 2u) * wi + ox / 2u) * ci + o];
                        break;
                    default: {
                        const uint32_t cb = co - ci;
                        yo[o] = (o < ci) ? x[((size_t)oy * wo + ox) * ci + o]
                                         : t[L->in2][((size_t)oy * wo + ox) * cb + (o - ci)];
                        break;
                    }
                    }
                }
            }
        }
    }
}

// ------------------------------------------------------------ requantisation

static void test_requant_reference_rounding_and_saturation(void)
{
    // srdhm rounds ties toward +inf: 3 * 0.5 -> 2, -3 * 0.5 -> -1.
    TEST_ASSERT_EQUAL_INT32(2, vd_rq_requantize(3, 1 << 30, 0));
    TEST_ASSERT_EQUAL_INT32(-1, vd_rq_requantize(-3, 1 << 30, 0));
    // RoundingDivideByPOT: half away from zero, and the two roundings compound:
    // 5 * 0.25: high = round(2.5) = 3, then 3 / 2 = 1.5 -> 2.
    TEST_ASSERT_EQUAL_INT32(2, vd_rq_requantize(5, 1 << 30, -1));
    TEST_ASSERT_EQUAL_INT32(-1, vd_rq_requantize(-5, 1 << 30, -1));   // high -2 -> -1
    TEST_ASSERT_EQUAL_INT32(-2, vd_rq_requantize(-6, 1 << 30, -1));   // high -3 -> -1.5 -> -2
    // Identity (mult 2^30, shift 1) and saturation of acc << shift.
    TEST_ASSERT_EQUAL_INT32(-77, vd_rq_requantize(-77, 1 << 30, 1));
    TEST_ASSERT_EQUAL_INT32(INT32_MAX / 2 + 1, vd_rq_requantize(INT32_MAX, 1 << 30, 1));
    TEST_ASSERT_EQUAL_INT32(INT32_MIN / 2, vd_rq_requantize(INT32_MIN, 1 << 30, 1));
    // (2^31 - 1)^2 / 2^31 = 2^31 - 2 + 2^-31 -> INT32_MAX - 1.
    TEST_ASSERT_EQUAL_INT32(INT32_MAX - 1, vd_rq_requantize(1 << 30, INT32_MAX, 7));
    TEST_ASSERT_EQUAL_INT32(INT32_MIN + 1, vd_rq_requantize(-(1 << 30), INT32_MAX, 7));
    // Largest right shifts: high 2^30, / 2^31 = 0.5 -> 1 (half away from zero);
    // high 2^31 - 2, / 2^30 -> 2.
    TEST_ASSERT_EQUAL_INT32(1, vd_rq_requantize(INT32_MAX, 1 << 30, -31));
    TEST_ASSERT_EQUAL_INT32(0, vd_rq_requantize(INT32_MAX / 2, 1 << 30, -31));
    TEST_ASSERT_EQUAL_INT32(-1, vd_rq_requantize(INT32_MIN, 1 << 30, -31));
    TEST_ASSERT_EQUAL_INT32(2, vd_rq_requantize(INT32_MAX, INT32_MAX, -30));
}

static int32_t rq_fast_ref(int32_t acc, int32_t mult, int32_t shift)
{
    vd_rq_ch_t c;
    vd_rq_prepare(mult, shift, 0, &c);
    return vd_rq_apply(acc, &c);
}

// The kernels' one-shift form equals the two-step reference everywhere.
static void test_requant_one_shift_form_matches_reference(void)
{
    static const int32_t accs[] = {INT32_MIN, INT32_MIN + 1, -(1 << 30), -65537, -65536, -4097, -3, -2, -1,
                                   0, 1, 2, 3, 4095, 65535, 1 << 30, INT32_MAX - 1, INT32_MAX};
    static const int32_t mults[] = {1 << 30, (1 << 30) + 1, 0x5A5A5A5A, 0x7FFFFFFE, INT32_MAX};
    for (size_t a = 0u; a < sizeof accs / sizeof accs[0]; a++) {
        for (size_t k = 0u; k < sizeof mults / sizeof mults[0]; k++) {
            for (int32_t s = VD_RQ_SHIFT_MIN; s <= VD_RQ_SHIFT_MAX; s++) {
                TEST_ASSERT_EQUAL_INT32(vd_rq_requantize(accs[a], mults[k], s), rq_fast_ref(accs[a], mults[k], s));
            }
        }
    }
    uint32_t st = 12345u;
    for (int i = 0; i < 300000; i++) {
        const uint32_t r = tu_rand(&st);
        // Mix of full-range and small accumulators (where ties happen).
        const int32_t acc = (i & 1) ? (int32_t)(tu_rand(&st) % 200001u) - 100000 : (int32_t)(r ^ tu_rand(&st));
        const int32_t mult = (int32_t)(0x40000000u + (tu_rand(&st) & 0x3FFFFFFFu));
        const int32_t s = (int32_t)(tu_rand(&st) % 39u) - 31;
        TEST_ASSERT_EQUAL_INT32(vd_rq_requantize(acc, mult, s), rq_fast_ref(acc, mult, s));
    }
}

// The ReLU form (vd_rq_z_nn, sign term dropped) clamped at any lo >= 0
// equals the clamped reference: exhaustively over small accumulators (where
// the sign term matters), randomly over the full range.
static int32_t rq_nn_ref(int32_t acc, int32_t mult, int32_t shift)
{
    vd_rq_ch_t c;
    vd_rq_prepare(mult, shift, 0, &c);
    return vd_rq_z_nn((uint32_t)acc, c.k, c.mult, c.rsh, c.off);
}

static int32_t max_i32(int32_t a, int32_t b)
{
    return (a > b) ? a : b;
}

static void test_requant_relu_form_matches_reference(void)
{
    static const int32_t mults[] = {1 << 30, (1 << 30) + 1, 0x5A5A5A5A, 0x7FFFFFFE, INT32_MAX};
    static const int32_t los[] = {0, 1, 255};
    for (size_t k = 0u; k < sizeof mults / sizeof mults[0]; k++) {
        for (int32_t s = VD_RQ_SHIFT_MIN; s <= 0; s++) {
            for (int32_t acc = -3000; acc <= 3000; acc++) {
                const int32_t ref = vd_rq_requantize(acc, mults[k], s);
                const int32_t nn = rq_nn_ref(acc, mults[k], s);
                for (size_t l = 0u; l < sizeof los / sizeof los[0]; l++) {
                    TEST_ASSERT_EQUAL_INT32(max_i32(ref, los[l]), max_i32(nn, los[l]));
                }
            }
        }
    }
    uint32_t st = 777u;
    for (int i = 0; i < 300000; i++) {
        const uint32_t r = tu_rand(&st);
        const int32_t acc = (i & 1) ? (int32_t)(tu_rand(&st) % 2000001u) - 1000000 : (int32_t)(r ^ tu_rand(&st));
        const int32_t mult = (int32_t)(0x40000000u + (tu_rand(&st) & 0x3FFFFFFFu));
        const int32_t s = -(int32_t)(tu_rand(&st) % 32u);
        const int32_t ref = vd_rq_requantize(acc, mult, s);
        const int32_t nn = rq_nn_ref(acc, mult, s);
        TEST_ASSERT_EQUAL_INT32(max_i32(ref, 0), max_i32(nn, 0));
        if (ref > 0) {
            TEST_ASSERT_EQUAL_INT32(ref, nn);
        }
    }
}

// ------------------------------------------------------------ hand-worked ops

// Test image: 4x4, pixel = y * 4 + x, so tensor 0 - zp = pixel (0..15).
static uint8_t g_img16[16];

static void img16(void)
{
    for (uint32_t i = 0u; i < 16u; i++) {
        g_img16[i] = (uint8_t)i;
    }
}

// 3x3 conv weights [o][ky][kx][c] for 2 -> 2 channels: o0 sums channel 0
// over the 3x3 window; o1 = 2 * channel 1 at the centre + channel 0 at the
// top-left tap.
static void conv_weights(int8_t w[36])
{
    memset(w, 0, 36);
    for (uint32_t k = 0u; k < 9u; k++) {
        w[k * 2u] = 1;
    }
    w[18 + 4 * 2 + 1] = 2;
    w[18 + 0] = 1;
}

static const int8_t k_w_pm[2] = {1, -1};   // pw 1 -> 2: (p, -p)

static void conv_model(tm_t *d, uint8_t stride, const int8_t *w)
{
    tm_init(d, 4u, 4u, 3u, 4u);
    d->L[0] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 0u, 1u, 2u, 0, k_w_pm, k_zero, k_mult1, k_shift1);
    d->L[1] = layer_weighted(VD_CNN_OP_CONV3X3, stride, 1u, 2u, 2u, 0, w, k_zero, k_mult1, k_shift1);
    uint32_t n = 2u;
    d->L[n++] = layer_copy(VD_CNN_OP_MAXPOOL2, 2u, 0u, 2u, 2u, 0);
    if (stride == 1u) {
        d->L[n] = layer_copy(VD_CNN_OP_MAXPOOL2, (uint8_t)n, 0u, 2u, 2u, 0);
        n++;
    }
    d->L[n] = layer_weighted(VD_CNN_OP_PW1X1, 1u, (uint8_t)n, 2u, 3u, 0, k_head_w, k_zero, k_mult1, k_shift1);
    d->n = n + 1u;
}

static void test_conv3x3_stride1_padding_hand_worked(void)
{
    img16();
    int8_t w[36];
    conv_weights(w);
    tm_t d;
    conv_model(&d, 1u, w);
    vd_cnn_output_t head;
    run_keep(&d, g_img16, 4u, 4u, &head);
    // o0 = sum of pixels in the 3x3 window (padding taps contribute 0):
    //   10 18 24 18 / 27 45 54 39 / 51 81 90 63 / 42 66 72 50
    // o1 = -2 p(y,x) + p(y-1,x-1) (0 outside):
    //   0 -2 -4 -6 / -8 -10 -11 -12 / -16 -14 -15 -16 / -24 -18 -19 -20
    static const int8_t t2[32] = {10, 0,   18, -2,  24, -4,  18, -6,  27, -8,  45, -10, 54, -11, 39, -12,
                                  51, -16, 81, -14, 90, -15, 63, -16, 42, -24, 66, -18, 72, -19, 50, -20};
    expect_tensor(4u, 4u, 2u, t2, 4u, 4u, 2u);
    // Max-pool 2x2 of those, then again.
    static const int8_t t3[8] = {45, 0, 54, -4, 81, -14, 90, -15};
    expect_tensor(4u, 4u, 3u, t3, 2u, 2u, 2u);
    static const int8_t t4[2] = {90, 0};
    expect_tensor(4u, 4u, 4u, t4, 1u, 1u, 2u);
    static const int8_t hd[3] = {90, 0, 90};   // k_head_w for 2 channels: (c0, 0, c0)
    TEST_ASSERT_EQUAL_UINT32(1u, head.w);
    TEST_ASSERT_EQUAL_UINT32(3u, head.c);
    TEST_ASSERT_EQUAL_UINT32(4u, head.stride);
    TEST_ASSERT_EQUAL_INT8_ARRAY(hd, head.data, 3);
    uint64_t macs = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_macs(&g_m, 4u, 4u, &macs));
    TEST_ASSERT_TRUE(macs == (uint64_t)(16u * 2u + 16u * 9u * 2u * 2u + 1u * 2u * 3u));   // no Unity 64-bit asserts on 32-bit targets
    run_free();
}

static void test_conv3x3_stride2_hand_worked(void)
{
    img16();
    int8_t w[36];
    conv_weights(w);
    tm_t d;
    conv_model(&d, 2u, w);
    vd_cnn_output_t head;
    run_keep(&d, g_img16, 4u, 4u, &head);
    // Outputs at input positions (0,0), (0,2), (2,0), (2,2) of the stride-1 map.
    static const int8_t t2[8] = {10, 0, 24, -4, 51, -16, 90, -15};
    expect_tensor(4u, 4u, 2u, t2, 2u, 2u, 2u);
    static const int8_t hd[3] = {90, 0, 90};
    TEST_ASSERT_EQUAL_INT8_ARRAY(hd, head.data, 3);
    run_free();
}

// CONV5X5 (op 7, padding 2) on the (p, -p) planes of the 4x4 ramp p = 4y + x:
// o0 = sum of p over the in-range 5x5 window; o1 = p(y, x) (weight -1 on -p
// at the centre) + p(y-2, x-2) (weight 1 at the corner tap, 0 outside).
static void conv5_weights(int8_t w[100])
{
    memset(w, 0, 100);
    for (uint32_t k = 0u; k < 25u; k++) {
        w[k * 2u] = 1;                      // [o0][ky][kx][c0]
    }
    w[50 + (2 * 5 + 2) * 2 + 1] = -1;       // [o1][2][2][c1]
    w[50 + 0] = 1;                          // [o1][0][0][c0]
}

static void conv5_model(tm_t *d, uint8_t stride, const int8_t *w)
{
    tm_init(d, 4u, 4u, 3u, 4u);
    d->L[0] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 0u, 1u, 2u, 0, k_w_pm, k_zero, k_mult1, k_shift1);
    d->L[1] = layer_weighted(VD_CNN_OP_CONV5X5, stride, 1u, 2u, 2u, 0, w, k_zero, k_mult1, k_shift1);
    uint32_t n = 2u;
    d->L[n++] = layer_copy(VD_CNN_OP_MAXPOOL2, 2u, 0u, 2u, 2u, 0);
    if (stride == 1u) {
        d->L[n] = layer_copy(VD_CNN_OP_MAXPOOL2, (uint8_t)n, 0u, 2u, 2u, 0);
        n++;
    }
    d->L[n] = layer_weighted(VD_CNN_OP_PW1X1, 1u, (uint8_t)n, 2u, 3u, 0, k_head_w, k_zero, k_mult1, k_shift1);
    d->n = n + 1u;
}

static void test_conv5x5_padding2_hand_worked(void)
{
    img16();
    int8_t w[100];
    conv5_weights(w);
    tm_t d;
    conv5_model(&d, 1u, w);
    vd_cnn_output_t head;
    run_keep(&d, g_img16, 4u, 4u, &head);
    // o0: 45 66 66 54 / 84 120 120 96 / 84 120 120 96 / 81 114 114 90 (the whole image is 120);
    // o1: 0 1 2 3 / 4 5 6 7 / 8 9 10 12 / 12 13 18 20.
    static const int8_t t2[32] = {45, 0, 66, 1, 66, 2,  54,  3,  84, 4,  120, 5,  120, 6,  96, 7,
                                  84, 8, 120, 9, 120, 10, 96, 12, 81, 12, 114, 13, 114, 18, 90, 20};
    expect_tensor(4u, 4u, 2u, t2, 4u, 4u, 2u);
    static const int8_t hd[3] = {120, 0, 120};
    TEST_ASSERT_EQUAL_INT8_ARRAY(hd, head.data, 3);
    uint64_t macs = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_macs(&g_m, 4u, 4u, &macs));
    TEST_ASSERT_TRUE(macs == (uint64_t)(16u * 2u + 16u * 25u * 2u * 2u + 1u * 2u * 3u));
    run_free();
    // Stride 2: the stride-1 map at (0,0), (0,2), (2,0), (2,2).
    conv5_model(&d, 2u, w);
    run_keep(&d, g_img16, 4u, 4u, &head);
    static const int8_t s2[8] = {45, 0, 66, 2, 84, 8, 120, 10};
    expect_tensor(4u, 4u, 2u, s2, 2u, 2u, 2u);
    TEST_ASSERT_EQUAL_INT8_ARRAY(hd, head.data, 3);
    run_free();
}

// Depthwise after a zero point of 5 (padding taps read the zero-point row),
// output zero point -3, clamp [-10, 127]; c0 x0.5 (shift 0), c1 x0.25 (shift -1).
static void dw_model(tm_t *d, uint8_t stride, int8_t w[18])
{
    static const int32_t mult[2] = {1 << 30, 1 << 30};
    static const int8_t shift[2] = {0, -1};
    memset(w, 0, 18);
    for (uint32_t k = 0u; k < 9u; k++) {
        w[k * 2u] = 1;
    }
    w[4 * 2 + 1] = 2;
    w[0 * 2 + 1] = 1;
    tm_init(d, 4u, 4u, 3u, 4u);
    d->L[0] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 0u, 1u, 2u, 5, k_w_pm, k_zero, k_mult1, k_shift1);
    d->L[1] = layer_weighted(VD_CNN_OP_DW3X3, stride, 1u, 2u, 2u, -3, w, k_zero, mult, shift);
    d->L[1].amin = -10;
    uint32_t n = 2u;
    d->L[n++] = layer_copy(VD_CNN_OP_MAXPOOL2, 2u, 0u, 2u, 2u, -3);
    if (stride == 1u) {
        d->L[n] = layer_copy(VD_CNN_OP_MAXPOOL2, (uint8_t)n, 0u, 2u, 2u, -3);
        n++;
    }
    d->L[n] = layer_weighted(VD_CNN_OP_PW1X1, 1u, (uint8_t)n, 2u, 3u, 0, k_head_w, k_zero, k_mult1, k_shift1);
    d->n = n + 1u;
}

static void test_depthwise_hand_worked(void)
{
    img16();
    int8_t w[18];
    tm_t d;
    dw_model(&d, 1u, w);
    vd_cnn_output_t head;
    run_keep(&d, g_img16, 4u, 4u, &head);
    // Tensor 1: (p + 5, 5 - p), zero point 5.
    int8_t t1[32];
    for (int32_t p = 0; p < 16; p++) {
        t1[2 * p] = (int8_t)(p + 5);
        t1[2 * p + 1] = (int8_t)(5 - p);
    }
    expect_tensor(4u, 4u, 1u, t1, 4u, 4u, 2u);
    // c0: S = 3x3 sums (see the conv test), z = high = floor((S + 1) / 2)
    // (srdhm ties up), out = z - 3:
    //   5 9 12 9 / 14 23 27 20 / 26 41 45 32 / 21 33 36 25  -> minus 3.
    // c1: a = -(2p + p(y-1,x-1)) = 0 -2 -4 -6 / -8 -10 -13 -16 / -16 -22 -25 -28 / -24 -34 -37 -40;
    //   high = floor((a + 1) / 2) = 0 -1 -2 -3 / -4 -5 -6 -8 / -8 -11 -12 -14 / -12 -17 -18 -20;
    //   z = high / 2 half away from zero = 0 -1 -1 -2 / -2 -3 -3 -4 / -4 -6 -6 -7 / -6 -9 -9 -10;
    //   out = max(z - 3, -10).
    static const int8_t t2[32] = {2,  -3, 6,  -4, 9,  -4, 6,  -5,  11, -5,  20, -6,  24, -6,  17, -7,
                                  23, -7, 38, -9, 42, -9, 29, -10, 18, -9,  30, -10, 33, -10, 22, -10};
    expect_tensor(4u, 4u, 2u, t2, 4u, 4u, 2u);
    run_free();

    dw_model(&d, 2u, w);
    run_keep(&d, g_img16, 4u, 4u, &head);
    static const int8_t s2[8] = {2, -3, 9, -4, 23, -7, 42, -9};
    expect_tensor(4u, 4u, 2u, s2, 2u, 2u, 2u);
    run_free();
}

static void test_pointwise_hand_worked(void)
{
    img16();
    static const int8_t w0[3] = {1, 2, -3};
    static const int8_t w1[6] = {3, -1, 1, 2, -1, 1};
    static const int32_t b1[2] = {7, -1};
    static const int32_t m1[2] = {1 << 30, 1 << 30};
    static const int8_t s1[2] = {1, 0};
    tm_t d;
    tm_init(&d, 4u, 4u, 3u, 4u);
    d.L[0] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 0u, 1u, 3u, 0, w0, k_zero, k_mult1, k_shift1);
    d.L[1] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 1u, 3u, 2u, 4, w1, b1, m1, s1);
    d.L[2] = layer_copy(VD_CNN_OP_MAXPOOL2, 2u, 0u, 2u, 2u, 4);
    d.L[3] = layer_copy(VD_CNN_OP_MAXPOOL2, 3u, 0u, 2u, 2u, 4);
    d.L[4] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 4u, 2u, 3u, 0, k_head_w, k_zero, k_mult1, k_shift1);
    d.n = 5u;
    vd_cnn_output_t head;
    run_keep(&d, g_img16, 4u, 4u, &head);
    // Tensor 1 = (p, 2p, -3p). o0 = 3p - 2p - 3p + 7 = 7 - 2p (x1), + zp 4;
    // o1 = 2p - 2p - 3p - 1 = -3p - 1, x0.5: floor((-3p - 1 + 1) / 2) = floor(-3p / 2), + 4.
    int8_t t2[32];
    for (int32_t p = 0; p < 16; p++) {
        t2[2 * p] = (int8_t)(11 - 2 * p);
        t2[2 * p + 1] = (int8_t)((-3 * p - (p & 1)) / 2 + 4);
    }
    expect_tensor(4u, 4u, 2u, t2, 4u, 4u, 2u);
    run_free();
}

static void test_upsample_and_concat_hand_worked(void)
{
    img16();
    static const int8_t w1[1] = {1};
    tm_t d;
    tm_init(&d, 4u, 4u, 3u, 4u);
    d.L[0] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 0u, 1u, 1u, 0, w1, k_zero, k_mult1, k_shift1);
    d.L[1] = layer_copy(VD_CNN_OP_MAXPOOL2, 1u, 0u, 1u, 1u, 0);
    d.L[2] = layer_copy(VD_CNN_OP_UPSAMPLE2, 2u, 0u, 1u, 1u, 0);
    d.L[3] = layer_copy(VD_CNN_OP_CONCAT, 3u, 1u, 1u, 2u, 0);
    d.L[4] = layer_copy(VD_CNN_OP_MAXPOOL2, 4u, 0u, 2u, 2u, 0);
    d.L[5] = layer_copy(VD_CNN_OP_MAXPOOL2, 5u, 0u, 2u, 2u, 0);
    d.L[6] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 6u, 2u, 3u, 0, k_head_w, k_zero, k_mult1, k_shift1);
    d.n = 7u;
    vd_cnn_output_t head;
    run_keep(&d, g_img16, 4u, 4u, &head);
    static const int8_t t2[4] = {5, 7, 13, 15};
    expect_tensor(4u, 4u, 2u, t2, 2u, 2u, 1u);
    static const int8_t t3[16] = {5, 5, 7, 7, 5, 5, 7, 7, 13, 13, 15, 15, 13, 13, 15, 15};
    expect_tensor(4u, 4u, 3u, t3, 4u, 4u, 1u);
    int8_t t4[32];
    for (uint32_t p = 0u; p < 16u; p++) {
        t4[2u * p] = t3[p];
        t4[2u * p + 1u] = (int8_t)p;
    }
    expect_tensor(4u, 4u, 4u, t4, 4u, 4u, 2u);
    static const int8_t t5[8] = {5, 5, 7, 7, 13, 13, 15, 15};
    expect_tensor(4u, 4u, 5u, t5, 2u, 2u, 2u);
    run_free();
}

// Tensor 0 of a 4x4 image through a model with the given normalisation.
static void stretch_model(tm_t *d, uint8_t norm, uint16_t lo, uint16_t hi, uint16_t min_range)
{
    tm_init(d, 4u, 4u, 3u, 4u);
    d->norm = norm;
    d->lo = lo;
    d->hi = hi;
    d->min_range = min_range;
    d->L[0] = layer_copy(VD_CNN_OP_MAXPOOL2, 0u, 0u, 1u, 1u, -128);
    d->L[1] = layer_copy(VD_CNN_OP_MAXPOOL2, 1u, 0u, 1u, 1u, -128);
    d->L[2] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 2u, 1u, 3u, 0, k_head_w, k_zero, k_mult1, k_shift1);
    d->n = 3u;
}

static void test_input_stretch_hand_worked(void)
{
    tm_t d;
    vd_cnn_output_t head;
    // No normalisation: q = pixel - 128.
    static const uint8_t raw[16] = {0, 1, 127, 128, 129, 254, 255, 7, 0, 0, 0, 0, 0, 0, 0, 0};
    stretch_model(&d, 0u, 0u, 0u, 0u);
    run_keep(&d, raw, 4u, 4u, &head);
    static const int8_t q0[16] = {-128, -127, -1, 0, 1, 126, 127, -121, -128, -128, -128, -128, -128, -128, -128, -128};
    expect_tensor(4u, 4u, 0u, q0, 4u, 4u, 1u);
    run_free();

    // Four levels, 4 pixels each; n = 16, lo 250 permille -> count 4, hi 750 -> 12.
    // lo = smallest v with cum(v) > 4 = 20, hi = smallest with cum > 12 = 40, r = 20:
    // 10, 20 -> 0; 30 -> (10 * 510 + 20) / 40 = 128; 40 -> (20 * 510 + 20) / 40 = 255.
    static const uint8_t lv[16] = {10, 20, 30, 40, 40, 30, 20, 10, 10, 20, 30, 40, 40, 30, 20, 10};
    stretch_model(&d, 1u, 250u, 750u, 4u);
    run_keep(&d, lv, 4u, 4u, &head);
    int8_t q1[16];
    for (uint32_t i = 0u; i < 16u; i++) {
        q1[i] = (int8_t)(lv[i] <= 20u ? -128 : (lv[i] == 30u ? 0 : 127));
    }
    expect_tensor(4u, 4u, 0u, q1, 4u, 4u, 1u);
    run_free();

    // Nearly flat: lo = hi = 100, r = min_range 4: 101 -> (510 + 4) / 8 = 64.
    uint8_t flat[16];
    memset(flat, 100, sizeof flat);
    flat[5] = 101;
    stretch_model(&d, 1u, 250u, 750u, 4u);
    run_keep(&d, flat, 4u, 4u, &head);
    int8_t q2[16];
    memset(q2, 0x80, sizeof q2);
    q2[5] = 64 - 128;
    expect_tensor(4u, 4u, 0u, q2, 4u, 4u, 1u);
    run_free();

    // hi 1000 permille: no level has cum > n, so hi = 255. lo 0 -> the minimum (50).
    // r = 205: 65 -> (15 * 510 + 205) / 410 = 19; 50 -> 0.
    uint8_t ramp[16];
    for (uint32_t i = 0u; i < 16u; i++) {
        ramp[i] = (uint8_t)(50u + i);
    }
    stretch_model(&d, 1u, 0u, 1000u, 1u);
    run_keep(&d, ramp, 4u, 4u, &head);
    int8_t q3[16];
    for (uint32_t i = 0u; i < 16u; i++) {
        q3[i] = (int8_t)((int32_t)((i * 510u + 205u) / 410u) - 128);
    }
    TEST_ASSERT_EQUAL_INT8(-128, q3[0]);
    TEST_ASSERT_EQUAL_INT8(19 - 128, q3[15]);
    expect_tensor(4u, 4u, 0u, q3, 4u, 4u, 1u);
    run_free();
}

// ------------------------------------------------------------ planner

// Chain on 8x8: pw 1->2 (T1 128 B), maxpool (T2 32), maxpool (T3 8 -> 16),
// pw 2->3 (T4 12 -> 16). K = cin is padded to Kp = 8 (VD_CNN_KCHUNK).
// Scratch of pw 1->2: int16 weights 2 * 2 * 8 = 32, int16 rows of 16 pixels
// 2 * 16 * 8 = 256, constants 2 * sizeof(vd_rq_ch_t) = 64: 352. Of pw 2->3:
// 48 + 256 + 96 = 400.
static void chain_model(tm_t *d)
{
    static const int8_t w0[2] = {1, 2};
    tm_init(d, 8u, 8u, 3u, 4u);
    d->L[0] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 0u, 1u, 2u, 0, w0, k_zero, k_mult1, k_shift1);
    d->L[1] = layer_copy(VD_CNN_OP_MAXPOOL2, 1u, 0u, 2u, 2u, 0);
    d->L[2] = layer_copy(VD_CNN_OP_MAXPOOL2, 2u, 0u, 2u, 2u, 0);
    d->L[3] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 3u, 2u, 3u, 0, k_head_w, k_zero, k_mult1, k_shift1);
    d->n = 4u;
}

static void test_planner_chain_and_skip(void)
{
    tm_t d;
    vd_cnn_model_t m;
    size_t bytes = 0u;
    chain_model(&d);
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    // First fit, items in order (lifetime in steps):
    //   T0 64 [0,1] @0; T1 128 [1,2] @64; S0 352 [1,1] @192;
    //   T2 32 [2,3] @0 (T0 dead); T3 16 [3,4] @32; T4 16 [4,4] @0; S3 400 [4,4] @48.
    // End = 544 (S0).
    TEST_ASSERT_EQUAL_UINT32(8u, VD_CNN_KCHUNK);
    TEST_ASSERT_EQUAL_UINT32(16u, VD_CNN_NPIX);
    TEST_ASSERT_EQUAL_UINT32(32u, (uint32_t)sizeof(vd_rq_ch_t));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&m, 8u, 8u, &bytes));
    TEST_ASSERT_EQUAL_UINT32(VD_CNN_REC_BYTES + 544u, bytes);
    // Keeping every tensor: T0 @0, T1 @64, S0 @192..544, T2 @192 (S0 is
    // dead at step 2), T3 @224, T4 @240, S3 @256..656.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&m, 8u, 8u, VD_CNN_KEEP_TENSORS, &bytes));
    TEST_ASSERT_EQUAL_UINT32(VD_CNN_REC_BYTES + 656u, bytes);

    // Skip: pw 1->2 (T1, read again by the concat), maxpool (T2 32),
    // upsample (T3 128), concat(T3, T1) (T4 8x8x4 = 256), maxpool (T5 64),
    // maxpool (T6 16), pw 4->3 (T7 16, scratch 400):
    //   T0 @0 [0,1]; T1 @64 [1,4]; S0 @192..544 [1,1]; T2 @0 [2,3]; T3 @192 [3,4];
    //   T4 @320..576 [4,5]; T5 @0 [5,6]; T6 @64 [6,7]; T7 @0 [7,7]; S6 @80..480 [7,7].
    // End = 576 (T4).
    static const int8_t w0[2] = {1, 2};
    tm_init(&d, 8u, 8u, 3u, 4u);
    d.L[0] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 0u, 1u, 2u, 0, w0, k_zero, k_mult1, k_shift1);
    d.L[1] = layer_copy(VD_CNN_OP_MAXPOOL2, 1u, 0u, 2u, 2u, 0);
    d.L[2] = layer_copy(VD_CNN_OP_UPSAMPLE2, 2u, 0u, 2u, 2u, 0);
    d.L[3] = layer_copy(VD_CNN_OP_CONCAT, 3u, 1u, 2u, 4u, 0);
    d.L[4] = layer_copy(VD_CNN_OP_MAXPOOL2, 4u, 0u, 4u, 4u, 0);
    d.L[5] = layer_copy(VD_CNN_OP_MAXPOOL2, 5u, 0u, 4u, 4u, 0);
    d.L[6] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 6u, 4u, 3u, 0, k_head_w, k_zero, k_mult1, k_shift1);
    d.n = 7u;
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&m, 8u, 8u, &bytes));
    TEST_ASSERT_EQUAL_UINT32(VD_CNN_REC_BYTES + 576u, bytes);
    // With the stretch, the histogram (1280 B, live at step 0 only) meets
    // only T0's lifetime: @64..1344; every other item keeps its place
    // (nothing after step 0 conflicts with it); end = 1344.
    d.norm = 1u;
    d.lo = 10u;
    d.hi = 990u;
    d.min_range = 8u;
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&m, 8u, 8u, &bytes));
    TEST_ASSERT_EQUAL_UINT32(VD_CNN_REC_BYTES + 1344u, bytes);
    // Pure function: the same query twice, and a larger input scales tensors.
    size_t again = 0u, big = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&m, 8u, 8u, &again));
    TEST_ASSERT_EQUAL_UINT32(bytes, again);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&m, 16u, 8u, &big));
    TEST_ASSERT_TRUE(big > bytes);
}

typedef struct run_ctx {
    const vd_cnn_model_t *m;
    const uint8_t *img;
    uint32_t w, h;
} run_ctx_t;

static vd_status_t run_fn(void *ws, size_t bytes, void *ctx)
{
    const run_ctx_t *c = (const run_ctx_t *)ctx;
    vd_cnn_output_t out;
    return vd_cnn_run(c->m, c->img, c->w, c->h, c->w, ws, bytes, &out);
}

// Every size query with guard bytes: size - 1 fails, exact size works, guards intact.
static void test_workspace_contract(void)
{
    tm_t d;
    vd_cnn_model_t m;
    chain_model(&d);
    d.norm = 1u;
    d.lo = 5u;
    d.hi = 995u;
    d.min_range = 16u;
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    uint8_t img[64];
    for (uint32_t i = 0u; i < 64u; i++) {
        img[i] = (uint8_t)(i * 5u);
    }
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&m, 8u, 8u, &bytes));
    run_ctx_t ctx = {&m, img, 8u, 8u};
    tu_check_workspace_contract(bytes, run_fn, &ctx);
    // A too-small buffer for even the record.
    uint64_t tiny[4];
    vd_cnn_output_t out;
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_cnn_run(&m, img, 8u, 8u, 8u, tiny, sizeof tiny, &out));
}

static void test_tensor_liveness_and_state(void)
{
    tm_t d;
    chain_model(&d);
    uint8_t img[64];
    memset(img, 200, sizeof img);
    vd_cnn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&m, 8u, 8u, &bytes));
    uint8_t *ws = tu_guarded_alloc(1, bytes);
    memset(ws, 0, bytes);
    vd_cnn_output_t t, out;
    // No run yet.
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_tensor(&m, ws, bytes, 8u, 8u, 4u, &t));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run(&m, img, 8u, 8u, 8u, ws, bytes, &out));
    // Head: alive, same view as run's. T3 @32 is never overwritten (T4 @0,
    // S3 @48). T0 and T1 are (T2 @0, S3 over T1's bytes).
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_tensor(&m, ws, bytes, 8u, 8u, 4u, &t));
    TEST_ASSERT_EQUAL_PTR(out.data, t.data);
    TEST_ASSERT_EQUAL_UINT32(3u, t.c);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_tensor(&m, ws, bytes, 8u, 8u, 3u, &t));
    TEST_ASSERT_EQUAL_UINT32(2u, t.w);
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_tensor(&m, ws, bytes, 8u, 8u, 0u, &t));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_tensor(&m, ws, bytes, 8u, 8u, 1u, &t));
    // Other size or index: refused.
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_tensor(&m, ws, bytes, 16u, 8u, 4u, &t));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_tensor(&m, ws, bytes, 8u, 8u, 5u, &t));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_tensor(&m, ws, bytes, 8u, 6u, 4u, &t));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_tensor(&m, ws, bytes, 8u, 8u, 4u, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_cnn_tensor(&m, ws, 16u, 8u, 8u, 4u, &t));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_cnn_tensor(&m, NULL, bytes, 8u, 8u, 4u, &t));
    // A failed run invalidates the record.
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_cnn_run(&m, img, 8u, 8u, 8u, ws, bytes - 1u, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_tensor(&m, ws, bytes, 8u, 8u, 4u, &t));
    tu_guard_check(1);
    tu_guarded_free(1);
}

static void test_run_arguments(void)
{
    tm_t d;
    chain_model(&d);
    vd_cnn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    TEST_ASSERT_EQUAL_UINT32(4u, m.align);
    uint8_t img[16 * 8];
    memset(img, 9, sizeof img);
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&m, 16u, 8u, &bytes));
    uint8_t *ws = tu_guarded_alloc(1, bytes);
    vd_cnn_output_t out;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run(&m, img, 16u, 8u, 16u, ws, bytes, &out));
    TEST_ASSERT_EQUAL_UINT32(4u, out.w);
    TEST_ASSERT_EQUAL_UINT32(2u, out.h);
    // Strided input: 8x8 view of the 16-wide plane.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run(&m, img, 8u, 8u, 16u, ws, bytes, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run(&m, img, 8u, 8u, 7u, ws, bytes, &out));
    // Sizes: not a multiple of A = 4, zero, too large.
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run(&m, img, 6u, 8u, 16u, ws, bytes, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run(&m, img, 8u, 2u, 16u, ws, bytes, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run(&m, img, 0u, 8u, 16u, ws, bytes, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_workspace_size(&m, 4100u, 8u, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_workspace_size(&m, 8u, 0u, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_workspace_size(&m, 8u, 8u, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_workspace_size_ex(&m, 8u, 8u, 32u, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run(NULL, img, 8u, 8u, 16u, ws, bytes, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run(&m, NULL, 8u, 8u, 16u, ws, bytes, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run(&m, img, 8u, 8u, 16u, ws, bytes, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_ex(&m, img, 8u, 8u, 16u, 32u, ws, bytes, &out));
    uint64_t macs;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_macs(&m, 8u, 8u, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_macs(&m, 9u, 8u, &macs));
    // A model that was not loaded.
    vd_cnn_model_t zero;
    memset(&zero, 0, sizeof zero);
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_run(&zero, img, 8u, 8u, 16u, ws, bytes, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_workspace_size(&zero, 8u, 8u, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_macs(&zero, 8u, 8u, &macs));
    // A model struct edited after loading (layer chain broken) is refused, not run.
    vd_cnn_model_t bad = m;
    bad.layers[3].in = 3u;
    bad.layers[3].cin = 7u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_run(&bad, img, 8u, 8u, 16u, ws, bytes, &out));
    tu_guard_check(1);
    tu_guarded_free(1);
}

// ------------------------------------------------------------ decode

// A head tensor filled by hand: heatmap values hm (w x h), other channels
// from `rest` (c - 1 values for every cell) unless set per cell later.
static int8_t g_head[8 * 8 * 5];

static void head_fill(vd_cnn_output_t *o, const int8_t *hm, uint32_t w, uint32_t h, uint32_t c, uint32_t stride)
{
    for (uint32_t i = 0u; i < w * h; i++) {
        g_head[i * c] = hm[i];
        for (uint32_t k = 1u; k < c; k++) {
            g_head[i * c + k] = -128;
        }
    }
    o->data = g_head;
    o->w = w;
    o->h = h;
    o->c = c;
    o->stride = stride;
    o->zp = 0;
}

static void test_decode_peaks_plateaus_ties_topk(void)
{
    tm_t d;
    chain_model(&d);
    vd_cnn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    // 5 x 4 grid (network 20 x 16). (1,0) ties (0,0) but comes after it:
    // not a peak. (3,1) < (2,2) after it; (4,1) ties (3,1) before it.
    // (0,3) ties (0,2) before it. Peaks: (0,0) 10, (2,2) 9, (4,3) 9, (0,2) 3.
    static const int8_t hm[20] = {10, 10, 0, 0, 5, 0, 0, 0, 7, 7, 3, 0, 9, 0, 0, 3, 0, 0, 0, 9};
    vd_cnn_output_t o;
    head_fill(&o, hm, 5u, 4u, 3u, 4u);
    vd_cnn_box_t b[10];
    size_t n = 99u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 1, 0u, 20u, 16u, b, 10u, &n));
    TEST_ASSERT_EQUAL_UINT32(4u, (uint32_t)n);
    // Sizes 0 (table[1][0] = 0): one-pixel boxes at the cell centres
    // (x * 4 + 2 px), equal ties ordered by raster index.
    static const int32_t want[4][4] = {{2, 2, 1, 1}, {10, 10, 1, 1}, {18, 14, 1, 1}, {2, 10, 1, 1}};
    static const int8_t logit[4] = {10, 9, 9, 3};
    for (uint32_t i = 0u; i < 4u; i++) {
        TEST_ASSERT_EQUAL_INT8(logit[i], b[i].logit);
        TEST_ASSERT_EQUAL_UINT16((uint16_t)((logit[i] + 128) * 128), b[i].score_q15);
        TEST_ASSERT_EQUAL_INT32(want[i][0], b[i].rect.x);
        TEST_ASSERT_EQUAL_INT32(want[i][1], b[i].rect.y);
        TEST_ASSERT_EQUAL_INT32(want[i][2], b[i].rect.w);
        TEST_ASSERT_EQUAL_INT32(want[i][3], b[i].rect.h);
    }
    // Header threshold 0 gives the same peaks (no zero cell is a peak).
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, VD_CNN_THR_DEFAULT, 0u, 20u, 16u, b, 10u, &n));
    TEST_ASSERT_EQUAL_UINT32(4u, (uint32_t)n);
    // Top-K by capacity and by max_peaks; the tie keeps raster order.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 1, 0u, 20u, 16u, b, 2u, &n));
    TEST_ASSERT_EQUAL_UINT32(2u, (uint32_t)n);
    TEST_ASSERT_EQUAL_INT32(2, b[0].rect.x);
    TEST_ASSERT_EQUAL_INT32(10, b[1].rect.x);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 1, 3u, 20u, 16u, b, 10u, &n));
    TEST_ASSERT_EQUAL_UINT32(3u, (uint32_t)n);
    TEST_ASSERT_EQUAL_INT32(18, b[2].rect.x);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 1, 1u, 20u, 16u, b, 10u, &n));
    TEST_ASSERT_EQUAL_UINT32(1u, (uint32_t)n);
    TEST_ASSERT_EQUAL_INT8(10, b[0].logit);
    // Threshold 4 drops the 3; threshold 11 drops everything.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 4, 0u, 20u, 16u, b, 10u, &n));
    TEST_ASSERT_EQUAL_UINT32(3u, (uint32_t)n);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 11, 0u, 20u, 16u, b, 10u, &n));
    TEST_ASSERT_EQUAL_UINT32(0u, (uint32_t)n);
    // Capacity 0 with no array.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 1, 0u, 20u, 16u, NULL, 0u, &n));
    TEST_ASSERT_EQUAL_UINT32(0u, (uint32_t)n);

    // A flat map is one plateau: one peak, its first cell. A 2x2 plateau
    // inside a lower map: its top-left cell.
    int8_t flat[20];
    memset(flat, 0x80, sizeof flat);
    head_fill(&o, flat, 5u, 4u, 3u, 4u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, -128, 0u, 20u, 16u, b, 10u, &n));
    TEST_ASSERT_EQUAL_UINT32(1u, (uint32_t)n);
    TEST_ASSERT_EQUAL_INT32(2, b[0].rect.x);
    TEST_ASSERT_EQUAL_INT32(2, b[0].rect.y);
    memset(flat, 0, sizeof flat);
    flat[6] = flat[7] = flat[11] = flat[12] = 5;
    head_fill(&o, flat, 5u, 4u, 3u, 4u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 1, 0u, 20u, 16u, b, 10u, &n));
    TEST_ASSERT_EQUAL_UINT32(1u, (uint32_t)n);
    TEST_ASSERT_EQUAL_INT32(1 * 4 + 2, b[0].rect.x);
    TEST_ASSERT_EQUAL_INT32(1 * 4 + 2, b[0].rect.y);
}

static void test_decode_box_rounding_and_clamping(void)
{
    static const int8_t w5[10] = {1, 0, 0, 1, 0, 0, 0, 0, 0, 0};
    tm_t d;
    chain_model(&d);
    d.n_ch = 5u;
    d.L[3].cout = 5u;
    d.L[3].w = w5;
    vd_cnn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    // 4 x 3 grid, stride 4: network 16 x 12. Default table: size i * 128
    // (i = value + 128), offset 4 i - 256.
    int8_t hm[12];
    memset(hm, -100, sizeof hm);
    hm[1 * 4 + 1] = 50;
    hm[2 * 4 + 3] = 40;
    hm[0 * 4 + 3] = 30;
    vd_cnn_output_t o;
    head_fill(&o, hm, 4u, 3u, 5u, 4u);
    int8_t *a = g_head + (1 * 4 + 1) * 5;   // (1,1): w 8 px, h 4 px, offsets 0.5 cell
    a[1] = -112;
    a[2] = -120;
    a[3] = -32;
    a[4] = -32;
    int8_t *bb = g_head + (2 * 4 + 3) * 5;  // (3,2): w 127.5 px, h 5 px, offsets -1, 0
    bb[1] = 127;
    bb[2] = -118;
    bb[3] = -128;
    bb[4] = -64;
    int8_t *c = g_head + (0 * 4 + 3) * 5;   // (3,0): size 0, offsets +2, -1 cells
    c[1] = -128;
    c[2] = -128;
    c[3] = 64;
    c[4] = -128;
    vd_cnn_box_t b[4];
    size_t n = 0u;
    // Frame = network size.
    // (1,1): cx = (256 + 128) * 4 = 1536 (6 px), x 2..10; cy 6 px, y 4..8.
    // (3,2): cx = (768 - 256) * 4 = 2048, x0n = 2048 - 16320 -> -56 -> 0,
    //   x1n = 18368 = 71.75 px -> 72 -> 16 (frame); cy = 2048, y0n = 1408
    //   = 5.5 px -> 6 (half up), y1n = 2688 = 10.5 px -> 11.
    // (3,0): cx = (768 + 512) * 4 = 20 px -> x0 15 (frame - 1), x1 16;
    //   cy = -4 px -> y0 0, y1 = max(-4, y0 + 1) = 1.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 0, 0u, 16u, 12u, b, 4u, &n));
    TEST_ASSERT_EQUAL_UINT32(3u, (uint32_t)n);
    static const int32_t want[3][4] = {{2, 4, 8, 4}, {0, 6, 16, 5}, {15, 0, 1, 1}};
    for (uint32_t i = 0u; i < 3u; i++) {
        TEST_ASSERT_EQUAL_INT32(want[i][0], b[i].rect.x);
        TEST_ASSERT_EQUAL_INT32(want[i][1], b[i].rect.y);
        TEST_ASSERT_EQUAL_INT32(want[i][2], b[i].rect.w);
        TEST_ASSERT_EQUAL_INT32(want[i][3], b[i].rect.h);
    }
    TEST_ASSERT_EQUAL_UINT16(178u * 128u, b[0].score_q15);
    // Frame twice the network: exact doubling.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 0, 0u, 32u, 24u, b, 4u, &n));
    TEST_ASSERT_EQUAL_INT32(4, b[0].rect.x);
    TEST_ASSERT_EQUAL_INT32(8, b[0].rect.y);
    TEST_ASSERT_EQUAL_INT32(16, b[0].rect.w);
    TEST_ASSERT_EQUAL_INT32(8, b[0].rect.h);
    // 30 x 20: X(512) = floor((512 * 30 + 2048) / 4096) = 4, X(2560) = 19;
    // Y(1024) = floor((1024 * 20 + 1536) / 3072) = 7, Y(2048) = 13.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &o, 0, 0u, 30u, 20u, b, 4u, &n));
    TEST_ASSERT_EQUAL_INT32(4, b[0].rect.x);
    TEST_ASSERT_EQUAL_INT32(7, b[0].rect.y);
    TEST_ASSERT_EQUAL_INT32(15, b[0].rect.w);
    TEST_ASSERT_EQUAL_INT32(6, b[0].rect.h);

    // Arguments.
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, &o, 128, 0u, 16u, 12u, b, 4u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, &o, -129, 0u, 16u, 12u, b, 4u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, &o, 0, 0u, 0u, 12u, b, 4u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, &o, 0, 0u, 16u, VD_MAX_DIM + 1u, b, 4u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, &o, 0, 0u, 16u, 12u, NULL, 4u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, &o, 0, 0u, 16u, 12u, b, 4u, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, NULL, 0, 0u, 16u, 12u, b, 4u, &n));
    vd_cnn_output_t bad = o;
    bad.c = 3u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, &bad, 0, 0u, 16u, 12u, b, 4u, &n));
    bad = o;
    bad.stride = 8u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, &bad, 0, 0u, 16u, 12u, b, 4u, &n));
    bad = o;
    bad.data = NULL;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, &bad, 0, 0u, 16u, 12u, b, 4u, &n));
    bad = o;
    bad.w = 0u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_decode(&m, &bad, 0, 0u, 16u, 12u, b, 4u, &n));
    vd_cnn_model_t zero;
    memset(&zero, 0, sizeof zero);
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_decode(&zero, &o, 0, 0u, 16u, 12u, b, 4u, &n));
}

// ------------------------------------------------------------ random models vs the naive reference

static int8_t g_wpool[1u << 17];
static int32_t g_ipool[1u << 14];
static int8_t g_spool[1u << 13];
static uint32_t g_wn, g_in, g_sn;

static void pools_reset(void)
{
    g_wn = g_in = g_sn = 0u;
}

// Random weights (full int8 range, -128 included), small biases, Q31
// multipliers, shifts mostly -12..-8 (outputs spread over int8) with some
// anywhere in -31..7 (saturation and deep right shifts), random zero point and clamp.
// Weights in -128..127, or -127..127 (what symmetric quantisation gives; the
// depthwise kernel then adds products in pairs) when g_wsym is set.
static bool g_wsym;

static tl_t rnd_weighted(uint32_t *st, uint8_t op, uint8_t stride, uint8_t in, uint16_t cin, uint16_t cout)
{
    tl_t L;
    memset(&L, 0, sizeof L);
    L.op = op;
    L.stride = stride;
    L.in = in;
    L.cin = cin;
    L.cout = cout;
    L.zp = (int8_t)((int32_t)(tu_rand(st) % 41u) - 20);
    const uint32_t act = tu_rand(st) % 10u;
    L.amin = -128;
    L.amax = 127;
    if (act < 3u) {
        L.amin = L.zp;   // ReLU
    } else if (act < 5u) {
        L.amin = (int8_t)((int32_t)(tu_rand(st) % 100u) - 100);
        L.amax = (int8_t)(L.amin + (int32_t)(tu_rand(st) % (uint32_t)(128 - L.amin)));
    }
    const uint32_t wl = w_len(&L);
    TEST_ASSERT_TRUE(g_wn + wl <= sizeof g_wpool && g_in + 2u * cout <= 1u << 14 && g_sn + cout <= sizeof g_spool);
    int8_t *w = g_wpool + g_wn;
    int32_t *bias = g_ipool + g_in;
    int32_t *mult = bias + cout;
    int8_t *shift = g_spool + g_sn;
    g_wn += wl;
    g_in += 2u * cout;
    g_sn += cout;
    for (uint32_t i = 0u; i < wl; i++) {
        w[i] = (int8_t)(g_wsym ? (int32_t)(tu_rand(st) % 255u) - 127 : (int32_t)(tu_rand(st) & 0xFFu) - 128);
    }
    for (uint32_t o = 0u; o < cout; o++) {
        bias[o] = (int32_t)(tu_rand(st) % 8001u) - 4000;
        mult[o] = (int32_t)(0x40000000u + (tu_rand(st) & 0x3FFFFFFFu));
        const uint32_t r = tu_rand(st) % 20u;
        shift[o] = (int8_t)(r < 16u ? -8 - (int32_t)(r % 5u) : (int32_t)(tu_rand(st) % 39u) - 31);
    }
    L.w = w;
    L.bias = bias;
    L.mult = mult;
    L.shift = shift;
    return L;
}

// A random percentile stretch for a test model (the input normalisation of
// the .vdm header).
static void rnd_norm(tm_t *d, uint32_t *st)
{
    d->norm = 1u;
    d->lo = (uint16_t)(tu_rand(st) % 100u);
    d->hi = (uint16_t)(900u + tu_rand(st) % 101u);
    d->min_range = (uint16_t)(1u + tu_rand(st) % 64u);
}

// Architecture 0: stride-2 stem, depthwise-separable blocks (odd channel
// counts: 17 and 33 exercise the 16-channel tails, cin 17 the K padding),
// upsample + concat skip, head 5 channels at stride 4. Architecture 1: full
// 3x3 convolutions (stride 1 and 2, cin 3 and 6), max-pools, head 3 at stride 8.
static void rnd_model(tm_t *d, uint32_t arch, uint32_t seed)
{
    uint32_t st = seed * 2654435761u + 1u;
    pools_reset();
    g_wsym = (seed / 2u) % 2u == 1u;
    if (arch == 0u) {
        tm_init(d, 8u, 8u, 5u, 4u);
        d->L[0] = rnd_weighted(&st, VD_CNN_OP_CONV3X3, 2u, 0u, 1u, 8u);
        d->L[1] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 2u, 1u, 8u, 8u);
        d->L[2] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 2u, 8u, 12u);
        d->L[3] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 3u, 12u, 12u);
        d->L[4] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 4u, 12u, 17u);
        d->L[5] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 2u, 5u, 17u, 17u);
        d->L[6] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 6u, 17u, 33u);
        d->L[7] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 7u, 33u, 33u);
        d->L[2].zp = d->L[7].zp;   // the concat below needs equal zero points
        d->L[8] = layer_copy(VD_CNN_OP_UPSAMPLE2, 8u, 0u, 33u, 33u, d->L[7].zp);
        d->L[9] = layer_copy(VD_CNN_OP_CONCAT, 9u, 3u, 33u, 45u, d->L[7].zp);
        d->L[10] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 10u, 45u, 45u);
        d->L[11] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 11u, 45u, 5u);
        d->n = 12u;
    } else {
        tm_init(d, 8u, 8u, 3u, 8u);
        d->L[0] = rnd_weighted(&st, VD_CNN_OP_CONV3X3, 1u, 0u, 1u, 3u);
        d->L[1] = layer_copy(VD_CNN_OP_MAXPOOL2, 1u, 0u, 3u, 3u, d->L[0].zp);
        d->L[2] = rnd_weighted(&st, VD_CNN_OP_CONV3X3, 2u, 2u, 3u, 6u);
        d->L[3] = rnd_weighted(&st, VD_CNN_OP_CONV3X3, 1u, 3u, 6u, 7u);
        d->L[4] = layer_copy(VD_CNN_OP_MAXPOOL2, 4u, 0u, 7u, 7u, d->L[3].zp);
        d->L[5] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 5u, 7u, 3u);
        d->n = 6u;
    }
    if (seed % 2u == 1u) {
        rnd_norm(d, &st);
    }
}

static void rnd_image(uint8_t *img, uint32_t w, uint32_t h, uint32_t seed)
{
    uint32_t st = seed + 77u;
    for (uint32_t y = 0u; y < h; y++) {
        for (uint32_t x = 0u; x < w; x++) {
            const uint32_t noise = tu_rand(&st) % 64u;
            img[y * w + x] = (uint8_t)((seed % 3u == 0u) ? tu_rand(&st) & 0xFFu : (x * 7u + y * 3u + noise) & 0xFFu);
        }
    }
}

// Runs d on img keeping every tensor and compares each with the naive
// reference (ref: the reference tensors, freed by the caller); returns the
// bytes compared. head: the run's head (workspace g_ws).
static uint32_t every_tensor_checked(const tm_t *d, const uint8_t *img, uint32_t w, uint32_t h, const char *tag,
                                     int8_t *ref[VD_CNN_MAX_TENSORS], vd_cnn_output_t *head)
{
    ref_forward(d, img, w, h, ref);
    run_keep(d, img, w, h, head);
    uint32_t n = 0u;
    for (uint32_t t = 0u; t <= d->n; t++) {
        vd_cnn_output_t x;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_tensor(&g_m, g_ws, g_ws_bytes, w, h, t, &x));
        char msg[96];
        snprintf(msg, sizeof msg, "%s size %ux%u tensor %u", tag, (unsigned)w, (unsigned)h, (unsigned)t);
        TEST_ASSERT_EQUAL_INT8_ARRAY_MESSAGE(ref[t], x.data, x.w * x.h * x.c, msg);
        n += x.w * x.h * x.c;
    }
    return n;
}

static void test_random_models_match_naive_reference(void)
{
    static const uint32_t sizes[5][2] = {{8, 8}, {16, 8}, {24, 16}, {40, 24}, {56, 40}};
    static uint8_t img[56 * 40];
    uint32_t checked = 0u;
    for (uint32_t arch = 0u; arch < 2u; arch++) {
        for (uint32_t seed = 0u; seed < 4u; seed++) {
            tm_t d;
            rnd_model(&d, arch, seed);
            for (uint32_t si = 0u; si < 5u; si++) {
                const uint32_t w = sizes[si][0], h = sizes[si][1];
                rnd_image(img, w, h, seed * 5u + si);
                char tag[48];
                snprintf(tag, sizeof tag, "arch %u seed %u", (unsigned)arch, (unsigned)seed);
                int8_t *ref[VD_CNN_MAX_TENSORS];
                vd_cnn_output_t head;
                checked += every_tensor_checked(&d, img, w, h, tag, ref, &head);
                // The shared-memory plan gives the same head, whatever the
                // workspace held before.
                const size_t keep_bytes = g_ws_bytes;
                int8_t head_copy[1024];
                TEST_ASSERT_TRUE(head.w * head.h * head.c <= sizeof head_copy);
                memcpy(head_copy, head.data, head.w * head.h * head.c);
                run_free();
                size_t bytes = 0u;
                TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&g_m, w, h, &bytes));
                TEST_ASSERT_TRUE(bytes <= keep_bytes);
                uint8_t *ws = tu_guarded_alloc(1, bytes);
                memset(ws, 0xA5, bytes);
                vd_cnn_output_t h2;
                TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run(&g_m, img, w, h, w, ws, bytes, &h2));
                TEST_ASSERT_EQUAL_INT8_ARRAY(head_copy, h2.data, h2.w * h2.h * h2.c);
                tu_guard_check(1);
                tu_guarded_free(1);
                for (uint32_t t = 0u; t <= d.n; t++) {
                    free(ref[t]);
                }
            }
        }
    }
    TEST_ASSERT_TRUE(checked > 100000u);
}

// Depthwise at the int16 limits: weights +-127 (pairs path) or -128 (single
// products) on inputs -128 / 127, i.e. products of 16256 / 16384 and pair
// sums of 32512 / 32258, against the naive reference.
static void test_depthwise_extremes_match_reference(void)
{
    static int8_t w[9 * 17];
    static const int32_t bias[17] = {0};
    static int32_t mult[17], m_id[17];
    static int8_t shift[17], s_id[17];
    static const int8_t wh[3 * 17] = {1, 1, 1};
    static const int32_t zero3[3] = {0, 0, 0};
    for (uint32_t c = 0u; c < 17u; c++) {
        mult[c] = 0x40000000 + (int32_t)c * 12345;
        shift[c] = (int8_t)(-10 - (int32_t)(c % 3u));
        m_id[c] = 1 << 30;
        s_id[c] = 1;
    }
    uint8_t img[16 * 8];
    for (uint32_t i = 0u; i < sizeof img; i++) {
        img[i] = (i % 5u < 3u) ? 0u : 255u;
    }
    for (int variant = 0; variant < 3; variant++) {
        for (uint32_t i = 0u; i < sizeof w; i++) {
            w[i] = (int8_t)(variant == 0 ? -127 : variant == 1 ? ((i & 1u) ? 127 : -127) : -128);
        }
        static const int8_t w17[17] = {1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1};
        tm_t d;
        tm_init(&d, 16u, 8u, 3u, 4u);
        // Tensor 1 = pixel - 128 on 17 channels: -128 or 127.
        d.L[0] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 0u, 1u, 17u, -128, w17, bias, m_id, s_id);
        d.L[1] = layer_weighted(VD_CNN_OP_DW3X3, 1u, 1u, 17u, 17u, 3, w, bias, mult, shift);
        d.L[2] = layer_copy(VD_CNN_OP_MAXPOOL2, 2u, 0u, 17u, 17u, 3);
        d.L[3] = layer_copy(VD_CNN_OP_MAXPOOL2, 3u, 0u, 17u, 17u, 3);
        d.L[4] = layer_weighted(VD_CNN_OP_PW1X1, 1u, 4u, 17u, 3u, 0, wh, zero3, k_mult1, k_shift1);
        d.n = 5u;
        int8_t *ref[VD_CNN_MAX_TENSORS];
        ref_forward(&d, img, 16u, 8u, ref);
        vd_cnn_output_t head;
        run_keep(&d, img, 16u, 8u, &head);
        TEST_ASSERT_EQUAL_INT8(-128, ref[1][0]);
        TEST_ASSERT_EQUAL_INT8(127, ref[1][17 * 3]);
        for (uint32_t t = 0u; t <= d.n; t++) {
            vd_cnn_output_t x;
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_tensor(&g_m, g_ws, g_ws_bytes, 16u, 8u, t, &x));
            TEST_ASSERT_EQUAL_INT8_ARRAY(ref[t], x.data, x.w * x.h * x.c);
            free(ref[t]);
        }
        run_free();
    }
}

// ------------------------------------------------------------ hostile blobs

// Every op, a skip and the stretch: conv s2 1->4 (zp 2), dw 4 (zp -1),
// pw 4->6 (zp 2), maxpool, upsample, concat(t5, t1) -> 10 (zp 2), dw s2 10,
// pw 10->n_ch. 8x8 input, A = 4, head at stride 4.
static uint32_t hostile_model(uint8_t n_ch, uint8_t *b)
{
    tm_t d;
    uint32_t st = 99u;
    pools_reset();
    tm_init(&d, 8u, 8u, n_ch, 4u);
    d.norm = 1u;
    d.lo = 20u;
    d.hi = 980u;
    d.min_range = 10u;
    d.max_peaks = 50u;
    d.thr = -7;
    d.name = "hostile";
    d.L[0] = rnd_weighted(&st, VD_CNN_OP_CONV3X3, 2u, 0u, 1u, 4u);
    d.L[0].zp = 2;
    d.L[1] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 1u, 4u, 4u);
    d.L[1].zp = -1;
    d.L[2] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 2u, 4u, 6u);
    d.L[2].zp = 2;
    d.L[3] = layer_copy(VD_CNN_OP_MAXPOOL2, 3u, 0u, 6u, 6u, 2);
    d.L[4] = layer_copy(VD_CNN_OP_UPSAMPLE2, 4u, 0u, 6u, 6u, 2);
    d.L[5] = layer_copy(VD_CNN_OP_CONCAT, 5u, 1u, 6u, 10u, 2);
    d.L[6] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 2u, 6u, 10u, 10u);
    d.L[7] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 7u, 10u, n_ch);
    d.n = 8u;
    return tm_write(&d, b);
}

static uint8_t *entry(uint8_t *b, uint32_t l)
{
    return b + 128u + 32u * l;
}

// Structural corruption k of the hostile model (n_ch 3; cases from
// N_CORRUPT3 on use the n_ch 5 model). Returns false past the last case.
// *total may be changed (cases on total_size); *fix tells whether to
// recompute the CRC.
#define N_CORRUPT3 84
#define N_CORRUPT 86

static bool corrupt(int k, uint8_t *b, uint32_t *total, bool *fix)
{
    *fix = true;
    uint8_t *e2 = entry(b, 2u);
    const uint32_t dec = tu_rd32(b + 36);
    switch (k) {
    case 0: tu_wr16(b + 4, 2u); break;                     // version 2 (a DBN version)
    case 1: tu_wr16(b + 4, 4u); break;
    case 2: tu_wr16(b + 4, 1u); break;
    case 3: tu_wr16(b + 6, 64u); break;                    // header size
    case 4: b[16] = 1u; break;                          // kind
    case 5: b[16] = 0u; break;
    case 6: b[17] = 2u; break;                          // input_norm
    case 7: tu_wr16(b + 24, 980u); break;                  // lo == hi
    case 8: tu_wr16(b + 26, 1001u); break;                 // hi > 1000
    case 9: tu_wr16(b + 28, 0u); break;                    // min_range 0
    case 10: tu_wr16(b + 28, 256u); break;
    case 11: b[17] = 0u; break;                         // no stretch but parameters set
    case 12: b[18] = 0u; break;                         // n_layers
    case 13: b[18] = 33u; break;
    case 14: b[18] = 7u; break;                         // head would be 10 channels at stride 4
    case 15: b[19] = 4u; break;                         // out_channels
    case 16: b[19] = 5u; break;                         // != head channels
    case 17: tu_wr16(b + 20, 0u); break;                   // input_w
    case 18: tu_wr16(b + 20, 4100u); break;
    case 19: tu_wr16(b + 20, 10u); break;                  // not a multiple of A = 4
    case 20: tu_wr16(b + 22, 6u); break;
    case 21: b[30] = 0x81u; break;                      // input_zp -127
    case 22: b[31] = 8u; break;                         // out_stride != head factor 4
    case 23: b[31] = 2u; break;
    case 24: tu_wr32(b + 32, 124u); break;                 // layer table inside the header
    case 25: tu_wr32(b + 32, 130u); break;                 // misaligned
    case 26: tu_wr32(b + 32, *total - 16u); break;         // past the end
    case 27: tu_wr32(b + 36, dec + 2u); break;             // decode table misaligned
    case 28: tu_wr32(b + 36, dec + 4u); break;             // past the end
    case 29: tu_wr32(b + 36, 128u); break;                 // over the layer table
    case 30: tu_wr32(b + 36, tu_rd32(entry(b, 0u) + 12)); break;   // over layer 0's weights
    case 31: b[41] = 1u; break;                         // reserved
    case 32: tu_wr16(b + 42, 0u); break;                   // max_peaks
    case 33: tu_wr16(b + 42, 1025u); break;
    case 34: tu_wr32(b + 44, 1u); break;                   // flags
    case 35: b[49] = 0x7Fu; break;                      // name not printable
    case 36: b[48 + 8] = 'x'; break;                    // text after the NUL
    case 37: b[64] = 1u; break;                         // reserved tail
    case 38: b[127] = 0x80u; break;
    case 39: e2[0] = 0u; break;                         // op
    case 40: e2[0] = 7u; break;
    case 41: e2[1] = 2u; break;                         // pw stride 2
    case 42: entry(b, 0u)[1] = 3u; break;               // conv stride 3
    case 43: entry(b, 0u)[1] = 0u; break;
    case 44: entry(b, 3u)[1] = 2u; break;               // maxpool stride field 2
    case 45: e2[2] = 3u; break;                         // in from the future
    case 46: e2[3] = 1u; break;                         // in2 on a non-concat
    case 47: entry(b, 5u)[3] = 6u; break;               // concat in2 from the future
    case 48: entry(b, 5u)[2] = 6u; break;
    case 49: tu_wr16(e2 + 4, 5u); break;                   // cin != channels of tensor 2
    case 50: tu_wr16(e2 + 6, 0u); break;                   // cout
    case 51: tu_wr16(e2 + 6, 1025u); break;
    case 52: tu_wr16(entry(b, 1u) + 6, 5u); break;         // depthwise cout != cin
    case 53: tu_wr16(entry(b, 3u) + 6, 5u); break;         // maxpool cout != cin
    case 54: e2[9] = 10u; e2[10] = 5u; break;           // act_min > act_max
    case 55: entry(b, 3u)[8] = 3u; break;               // maxpool zero point changes
    case 56: entry(b, 3u)[9] = 0x81u; break;            // maxpool act_min -127
    case 57: entry(b, 4u)[10] = 126u; break;            // upsample act_max 126
    case 58: entry(b, 4u)[2] = 0u; tu_wr16(entry(b, 4u) + 4, 1u); tu_wr16(entry(b, 4u) + 6, 1u); break;  // upsample at f 1
    case 59: entry(b, 5u)[3] = 4u; tu_wr16(entry(b, 5u) + 6, 12u); break;  // concat of f 2 and f 4
    case 60: entry(b, 5u)[3] = 2u; break;               // concat zero points 2 and -1
    case 61: tu_wr16(entry(b, 5u) + 6, 11u); break;        // concat cout != 6 + 4
    case 62: entry(b, 5u)[8] = 3u; break;               // concat out_zp
    case 63: e2[11] = 1u; break;                        // layer reserved byte
    case 64: tu_wr32(e2 + 28, 4u); break;                  // layer reserved word
    case 65: tu_wr32(e2 + 12, 0u); break;                  // pw without weights
    case 66: tu_wr32(entry(b, 3u) + 12, tu_rd32(e2 + 12)); break;   // maxpool with an array
    case 67: tu_wr32(e2 + 16, tu_rd32(e2 + 16) + 1u); break;  // bias misaligned
    case 68: tu_wr32(e2 + 20, tu_rd32(e2 + 16)); break;       // mult over bias
    case 69: tu_wr32(e2 + 24, *total - 4u); break;         // shift past the end
    case 70: tu_wr32(e2 + 12, 128u); break;                // weights over the layer table
    case 71: tu_wr32(b + tu_rd32(e2 + 20), 0x3FFFFFFFu); break;     // mult < 2^30
    case 72: tu_wr32(b + tu_rd32(e2 + 20) + 4u, 0x80000000u); break; // mult negative
    case 73: b[tu_rd32(e2 + 24)] = 0xE0u; break;           // shift -32
    case 74: b[tu_rd32(e2 + 24) + 5u] = 8u; break;         // shift 8
    case 75: tu_wr32(b + tu_rd32(entry(b, 0u) + 16), (uint32_t)(INT32_MAX - 9 * 128 * 255 + 1)); break;  // bias bound
    case 76: tu_wr32(b + tu_rd32(entry(b, 0u) + 16) + 4u, (uint32_t)(-(INT32_MAX - 9 * 128 * 255) - 1)); break;
    case 77: tu_wr32(b + dec + 4u * 5u, tu_rd32(b + dec + 4u * 4u) - 1u); break;  // score decreasing
    case 78: tu_wr32(b + dec + 4u * 255u, 32769u); break;  // score > 1.0
    case 79: tu_wr32(b + dec, 0xFFFFFFFFu); break;         // score -1
    case 80: tu_wr32(b + dec + 4u * (256u + 3u), 0xFFFFFFFFu); break;     // width -1
    case 81: tu_wr32(b + dec + 4u * (512u + 7u), 4096u * 256u + 1u); break;  // height too large
    case 82: entry(b, 6u)[1] = 1u; break;               // head at stride 2 (dw s1)
    case 83: tu_wr32(b + 8, *total + 2u); *total += 2u; break;   // total not a multiple of 4
    case 84: tu_wr32(b + dec + 4u * (768u + 9u), (uint32_t)-257); break;  // (n_ch 5) x offset
    case 85: tu_wr32(b + dec + 4u * (1024u + 9u), 513u); break;           // y offset
    default: return false;
    }
    return true;
}

static uint8_t g_work[BLOB_CAP + 16u];

static void test_structural_corruptions_rejected(void)
{
    static union {
        uint64_t align;
        uint8_t b[16384];
    } base;
    int n_cases = 0;
    for (int k = 0; k < N_CORRUPT; k++) {
        const uint8_t n_ch = (k < N_CORRUPT3) ? 3u : 5u;
        uint32_t total = hostile_model(n_ch, base.b);
        vd_cnn_model_t m;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_load(&m, base.b, total));
        // A fresh, aligned copy with 8 spare bytes after it.
        uint8_t *b = g_blob.b;
        memcpy(b, base.b, total);
        memset(b + total, 0, 8u);
        bool fix = true;
        TEST_ASSERT_TRUE(corrupt(k, b, &total, &fix));
        if (fix) {
            const uint32_t t = tu_rd32(b + 8);
            if (t >= 16u && t <= total + 8u) {
                tu_vdm_fix_crc(b);
            }
        }
        memset(&m, 0x5A, sizeof m);
        vd_cnn_model_t before = m;
        char msg[40];
        snprintf(msg, sizeof msg, "corruption %d", k);
        TEST_ASSERT_EQUAL_INT_MESSAGE(VD_ERR_MODEL, vd_cnn_load(&m, b, total + 8u), msg);
        TEST_ASSERT_EQUAL_MEMORY_MESSAGE(&before, &m, sizeof m, msg);   // *m untouched
        n_cases++;
    }
    TEST_ASSERT_EQUAL_INT(N_CORRUPT, n_cases);
    uint32_t total = 0u;
    bool fix;
    TEST_ASSERT_FALSE(corrupt(N_CORRUPT, base.b, &total, &fix));

    // Boundary values that are valid: bias exactly at the bound, offsets -256
    // and 512, score 32768, sizes 0 and 4096 * 256.
    total = hostile_model(5u, g_blob.b);
    uint8_t *b = g_blob.b;
    const uint32_t dec = tu_rd32(b + 36);
    tu_wr32(b + tu_rd32(entry(b, 0u) + 16), (uint32_t)(INT32_MAX - 9 * 128 * 255));
    tu_wr32(b + tu_rd32(entry(b, 0u) + 16) + 4u, (uint32_t)(-(INT32_MAX - 9 * 128 * 255)));
    tu_wr32(b + dec + 4u * 255u, 32768u);
    tu_wr32(b + dec + 4u * 256u, 0u);
    tu_wr32(b + dec + 4u * 511u, 4096u * 256u);
    tu_wr32(b + dec + 4u * 768u, (uint32_t)-256);
    tu_wr32(b + dec + 4u * 1279u, 512u);
    tu_vdm_fix_crc(b);
    vd_cnn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_load(&m, b, total));
    TEST_ASSERT_EQUAL_STRING("hostile", m.name);
    TEST_ASSERT_EQUAL_INT8(-7, m.score_threshold_i8);
    TEST_ASSERT_EQUAL_UINT16(50u, m.max_peaks);
    TEST_ASSERT_EQUAL_UINT32(4u, m.align);
    TEST_ASSERT_EQUAL_UINT32(8u, m.n_layers);
    // A DBN reader refuses the CNN kind.
    vd_dbn_model_t dbn;
    TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_dbn_load(&dbn, b, total));
}

static void test_every_bit_flip_and_truncation_rejected(void)
{
    const uint32_t total = hostile_model(3u, g_blob.b);
    uint8_t *b = g_blob.b;
    vd_cnn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_load(&m, b, total));
    // Flash padding after total_size is ignored.
    memset(b + total, 0xFF, 8u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_load(&m, b, total + 8u));
    uint32_t flips = 0u;
    for (uint32_t i = 0u; i < total; i++) {
        for (uint32_t bit = 0u; bit < 8u; bit++) {
            b[i] ^= (uint8_t)(1u << bit);
            memset(&m, 0x33, sizeof m);
            if (vd_cnn_load(&m, b, total + 8u) != VD_ERR_MODEL) {
                char msg[48];
                snprintf(msg, sizeof msg, "flip byte %u bit %u accepted", (unsigned)i, (unsigned)bit);
                TEST_FAIL_MESSAGE(msg);
            }
            b[i] ^= (uint8_t)(1u << bit);
            flips++;
        }
    }
    TEST_ASSERT_EQUAL_UINT32(8u * total, flips);
    for (uint32_t len = 1u; len < total; len++) {
        TEST_ASSERT_EQUAL_INT(VD_ERR_MODEL, vd_cnn_load(&m, b, len));
    }
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_load(&m, b, 0u));
    // Misaligned pointers and NULLs.
    for (uint32_t k = 1u; k < 4u; k++) {
        memcpy(g_work + k, b, total);
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_load(&m, g_work + k, total));
    }
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_load(NULL, b, total));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_load(&m, NULL, total));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_load(&m, b, total));
    // The hostile model runs and decodes (the loaded pointers are usable).
    uint8_t img[64];
    for (uint32_t i = 0u; i < 64u; i++) {
        img[i] = (uint8_t)(i * 37u);
    }
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&m, 8u, 8u, &bytes));
    void *ws = tu_guarded_alloc(1, bytes);
    vd_cnn_output_t out;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run(&m, img, 8u, 8u, 8u, ws, bytes, &out));
    vd_cnn_box_t boxes[8];
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(&m, &out, -128, 0u, 64u, 48u, boxes, 8u, &n));
    TEST_ASSERT_TRUE(n >= 1u);
    for (size_t i = 0u; i < n; i++) {
        TEST_ASSERT_TRUE(boxes[i].rect.x >= 0 && boxes[i].rect.w >= 1 && boxes[i].rect.x + boxes[i].rect.w <= 64);
        TEST_ASSERT_TRUE(boxes[i].rect.y >= 0 && boxes[i].rect.h >= 1 && boxes[i].rect.y + boxes[i].rect.h <= 48);
    }
    tu_guard_check(1);
    tu_guarded_free(1);
}

// vd_cnn_thr_from_score: the smallest logit whose table score reaches a Q15
// threshold (the detector's cnn_score_thr_q15), on plateaus and at the ends.
static void test_thr_from_score(void)
{
    tm_t d;
    chain_model(&d);
    for (int32_t i = 0; i < 256; i++) {
        g_table[i] = (i / 16) * 2048;   // plateaus of 16 logits; top score 30720
    }
    vd_cnn_model_t m;
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    static const uint32_t score[6] = {0u, 1u, 2048u, 2049u, 30719u, 30720u};
    static const int32_t want[6] = {-128, -112, -112, -96, 112, 112};
    int32_t thr = 77;
    for (uint32_t k = 0u; k < 6u; k++) {
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_thr_from_score(&m, score[k], &thr));
        TEST_ASSERT_EQUAL_INT32(want[k], thr);
    }
    // Against the definition, every 97th score.
    for (uint32_t sc = 0u; sc <= 30720u; sc += 97u) {
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_thr_from_score(&m, sc, &thr));
        TEST_ASSERT_TRUE((uint32_t)g_table[thr + 128] >= sc);
        TEST_ASSERT_TRUE(thr == -128 || (uint32_t)g_table[thr + 127] < sc);
    }
    thr = 77;
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_cnn_thr_from_score(&m, 30721u, &thr));
    TEST_ASSERT_EQUAL_INT32(77, thr);   // unchanged
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_thr_from_score(&m, 32769u, &thr));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_thr_from_score(NULL, 0u, &thr));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_thr_from_score(&m, 0u, NULL));
    vd_cnn_model_t zero;
    memset(&zero, 0, sizeof zero);
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_thr_from_score(&zero, 0u, &thr));
    // Default table (score = (v + 128) * 128): 1.0 is out of reach, 32640 is logit 127.
    chain_model(&d);
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_thr_from_score(&m, 32640u, &thr));
    TEST_ASSERT_EQUAL_INT32(127, thr);
    TEST_ASSERT_EQUAL_INT(VD_ERR_RANGE, vd_cnn_thr_from_score(&m, 32768u, &thr));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_thr_from_score(&m, 129u, &thr));
    TEST_ASSERT_EQUAL_INT32(-126, thr);
}

// ------------------------------------------------------------ streamed executor

#ifndef VD_SOURCE_DIR
#define VD_SOURCE_DIR "."
#endif

typedef struct stream_ctx {
    const vd_cnn_model_t *m;
    const uint8_t *img;
    uint32_t w, h;
} stream_ctx_t;

static vd_status_t stream_fn(void *ws, size_t bytes, void *ctx)
{
    const stream_ctx_t *c = (const stream_ctx_t *)ctx;
    vd_cnn_output_t out;
    return vd_cnn_run_ex(c->m, c->img, c->w, c->h, c->w, VD_CNN_STREAM, ws, bytes, &out);
}

typedef struct plane_rows {
    const uint8_t *img;
    uint32_t w, h;
    uint32_t calls;
    uint32_t next;    // next row expected by the in-order check
    bool in_order;
} plane_rows_t;

static void plane_row(void *ctx, uint32_t y, uint8_t *dst)
{
    plane_rows_t *r = (plane_rows_t *)ctx;
    TEST_ASSERT_TRUE(y < r->h);
    if (y == 0u) {
        r->next = 0u;   // a new pass (histogram, then the network)
    }
    r->in_order = r->in_order && y == r->next;
    r->next = y + 1u;
    memcpy(dst, r->img + (size_t)y * r->w, r->w);
    r->calls++;
}

// vd_cnn_run_rows_decode (streamed, with and without VD_CNN_HEAD_RING) against vd_cnn_decode of the
// whole-plane head `a`: every peak (top-K the header's, capacity 200: eviction once a head has more
// peaks), threshold 0 with top-3 in 5 (eviction at once), the header's threshold with capacity 0. The
// same boxes, field by field, in workspaces of exactly the queried size, guarded and prefilled with garbage.
// Three settings, not a grid: each is a whole network run, and this runs for every streamed test size.
static void decode_stream_check(const vd_cnn_model_t *m, const uint8_t *img, uint32_t w, uint32_t h,
                                const vd_cnn_output_t *a, const char *what)
{
    static vd_cnn_box_t want[200], got[200];
    static const int32_t thrs[3] = {-128, 0, VD_CNN_THR_DEFAULT};
    static const uint32_t peaks[3] = {0u, 3u, 0u};
    static const size_t caps[3] = {200u, 5u, 0u};
    for (uint32_t ring = 0u; ring < 2u; ring++) {
        const uint32_t flags = VD_CNN_STREAM | ((ring != 0u) ? VD_CNN_HEAD_RING : 0u);
        size_t bytes = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(m, w, h, flags, &bytes));
        void *ws = tu_guarded_alloc(3, bytes);
        for (uint32_t ci = 0u; ci < 3u; ci++) {
            const vd_cnn_decode_opts_t o = {thrs[ci], peaks[ci], 2u * w + 1u, 2u * h};
            size_t nw = 99u, ng = 99u;
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_decode(m, a, o.thr_i8, o.max_peaks, o.frame_w, o.frame_h, want,
                                                       caps[ci], &nw));
            TEST_ASSERT_TRUE(ci != 0u || nw > 0u);   // every head has a peak: its first maximum
            memset(ws, 0xC3, bytes);
            plane_rows_t pr = {img, w, h, 0u, 0u, true};
            const vd_cnn_rows_t rows = {plane_row, &pr};
            TEST_ASSERT_EQUAL_INT_MESSAGE(
                VD_OK, vd_cnn_run_rows_decode(m, &rows, w, h, flags, ws, bytes, &o, got, caps[ci], &ng), what);
            TEST_ASSERT_EQUAL_size_t_MESSAGE(nw, ng, what);
            for (size_t i = 0u; i < nw; i++) {
                tu_assert_rect_equal(&want[i].rect, &got[i].rect, what);
                TEST_ASSERT_EQUAL_UINT16_MESSAGE(want[i].score_q15, got[i].score_q15, what);
                TEST_ASSERT_EQUAL_INT8_MESSAGE(want[i].logit, got[i].logit, what);
            }
        }
        // A ring head is not whole (unless the ring is the head): vd_cnn_tensor refuses it.
        const vd_cnn_plan_t *p = (const vd_cnn_plan_t *)ws;
        vd_cnn_output_t t;
        const vd_status_t st = vd_cnn_tensor(m, ws, bytes, w, h, m->n_layers, &t);
        TEST_ASSERT_EQUAL_INT(p->rows[m->n_layers] == a->h ? VD_OK : VD_ERR_STATE, st);
        TEST_ASSERT_TRUE(ring != 0u || st == VD_OK);
        tu_guard_check(3);
        tu_guarded_free(3);
    }
}

// Whole-plane head of m on img (w x h) against the streamed run from the
// plane and from a row source, in guarded workspaces of exactly the queried
// sizes (the streamed one prefilled with garbage); the streamed decode; then the streamed
// workspace contract (size - 1 fails, guards intact).
static void stream_check(const vd_cnn_model_t *m, const uint8_t *img, uint32_t w, uint32_t h, const char *what)
{
    size_t whole = 0u, streamed = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(m, w, h, &whole));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(m, w, h, VD_CNN_STREAM, &streamed));
    void *ws = tu_guarded_alloc(0, whole);
    vd_cnn_output_t a, b, c;
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_cnn_run(m, img, w, h, w, ws, whole, &a), what);
    void *ws2 = tu_guarded_alloc(1, streamed);
    memset(ws2, 0xA5, streamed);
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_cnn_run_ex(m, img, w, h, w, VD_CNN_STREAM, ws2, streamed, &b), what);
    TEST_ASSERT_EQUAL_UINT32(a.w, b.w);
    TEST_ASSERT_EQUAL_UINT32(a.h, b.h);
    TEST_ASSERT_EQUAL_UINT32(a.c, b.c);
    TEST_ASSERT_EQUAL_INT8_ARRAY_MESSAGE(a.data, b.data, a.w * a.h * a.c, what);
    // The head stays readable through vd_cnn_tensor; ring tensors do not.
    vd_cnn_output_t t;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_tensor(m, ws2, streamed, w, h, m->n_layers, &t));
    TEST_ASSERT_EQUAL_PTR(b.data, t.data);
    memset(ws2, 0x5A, streamed);
    plane_rows_t pr = {img, w, h, 0u, 0u, true};
    const vd_cnn_rows_t rows = {plane_row, &pr};
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_cnn_run_rows(m, &rows, w, h, VD_CNN_STREAM, ws2, streamed, &c), what);
    TEST_ASSERT_EQUAL_INT8_ARRAY_MESSAGE(a.data, c.data, a.w * a.h * a.c, what);
    // Every row once for the network, once more for a stretch histogram; in order.
    TEST_ASSERT_EQUAL_UINT32(h * ((m->input_norm != VD_CNN_NORM_NONE) ? 2u : 1u), pr.calls);
    TEST_ASSERT_TRUE(pr.in_order);
    decode_stream_check(m, img, w, h, &a, what);
    tu_guard_check(0);
    tu_guard_check(1);
    tu_guarded_free(1);
    tu_guarded_free(0);
    stream_ctx_t ctx = {m, img, w, h};
    tu_check_workspace_contract(streamed, stream_fn, &ctx);
}

// Architecture 2 (alignment 4, head stride 4): 5x5 stride-2 stem, a dead
// branch (tensor 2: no consumer), max-pool, 3x3 and 5x5 stride 1, a concat
// skip of the max-pool output, pointwise head 3.
static void rnd_model2(tm_t *d, uint32_t seed)
{
    uint32_t st = seed * 2246822519u + 3u;
    pools_reset();
    g_wsym = seed % 2u == 1u;
    tm_init(d, 8u, 8u, 3u, 4u);
    d->L[0] = rnd_weighted(&st, VD_CNN_OP_CONV5X5, 2u, 0u, 1u, 4u);
    d->L[1] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 1u, 4u, 4u);
    d->L[2] = layer_copy(VD_CNN_OP_MAXPOOL2, 1u, 0u, 4u, 4u, d->L[0].zp);
    d->L[3] = rnd_weighted(&st, VD_CNN_OP_CONV3X3, 1u, 3u, 4u, 6u);
    d->L[4] = rnd_weighted(&st, VD_CNN_OP_CONV5X5, 1u, 4u, 6u, 5u);
    d->L[4].zp = d->L[0].zp;   // the concat needs equal zero points
    d->L[5] = layer_copy(VD_CNN_OP_CONCAT, 5u, 3u, 5u, 9u, d->L[0].zp);
    d->L[6] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 6u, 9u, 3u);
    d->n = 7u;
    if (seed % 2u == 0u) {
        rnd_norm(d, &st);
    }
}

// Architecture 3 (alignment 16, head stride 4): upsamples the streamed plan
// fuses into their concats and ones it must keep. Tensor 6 (an upsample read
// by an upsample) and tensor 8 (an upsample read by a concat and a
// pointwise layer) are stored; tensor 7 (up of up, the second operand of a
// concat) is fused, its concat reading tensor 6 at half the row and column.
static void rnd_model3(tm_t *d, uint32_t seed)
{
    uint32_t st = seed * 3266489917u + 5u;
    pools_reset();
    g_wsym = seed % 2u == 0u;
    tm_init(d, 16u, 16u, 3u, 4u);
    d->L[0] = rnd_weighted(&st, VD_CNN_OP_CONV3X3, 2u, 0u, 1u, 6u);
    d->L[1] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 2u, 1u, 6u, 6u);
    d->L[2] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 2u, 6u, 8u);
    d->L[3] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 2u, 3u, 8u, 8u);
    d->L[4] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 2u, 4u, 8u, 8u);
    const int8_t zp = d->L[1].zp;   // every concat operand below shares it
    d->L[3].zp = zp;
    d->L[4].zp = zp;
    d->L[5] = layer_copy(VD_CNN_OP_UPSAMPLE2, 5u, 0u, 8u, 8u, zp);    // t6, stride 8
    d->L[6] = layer_copy(VD_CNN_OP_UPSAMPLE2, 6u, 0u, 8u, 8u, zp);    // t7, stride 4: fused
    d->L[7] = layer_copy(VD_CNN_OP_UPSAMPLE2, 4u, 0u, 8u, 8u, zp);    // t8, stride 4: kept (L10 reads it)
    d->L[8] = layer_copy(VD_CNN_OP_CONCAT, 2u, 7u, 6u, 14u, zp);      // t9
    d->L[9] = layer_copy(VD_CNN_OP_CONCAT, 9u, 8u, 14u, 22u, zp);     // t10
    d->L[10] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 8u, 8u, 4u);    // t11
    d->L[10].zp = zp;
    d->L[11] = layer_copy(VD_CNN_OP_CONCAT, 10u, 11u, 22u, 26u, zp);  // t12
    d->L[12] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 12u, 26u, 26u);
    d->L[13] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 13u, 26u, 3u);
    d->n = 14u;
    if (seed % 2u == 1u) {
        rnd_norm(d, &st);
    }
}

// Random models of every op (architectures 0-3: upsample/concat skips,
// stride 2 down to odd tensor sizes, max-pools, 5x5, a dead branch): the
// streamed head equals the whole-plane head; with VD_CNN_KEEP_TENSORS too,
// every computed tensor equals the naive reference and the dead one is
// reported as not available.
static void test_stream_random_models_match_whole_plane(void)
{
    static const uint32_t sizes[4][5][2] = {{{8, 8}, {16, 8}, {24, 16}, {40, 24}, {56, 40}},
                                            {{8, 8}, {16, 8}, {24, 16}, {40, 24}, {56, 40}},
                                            {{4, 4}, {12, 8}, {20, 12}, {36, 20}, {44, 28}},
                                            {{16, 16}, {32, 16}, {48, 32}, {64, 48}, {80, 48}}};
    static uint8_t img[80 * 48];
    for (uint32_t arch = 0u; arch < 4u; arch++) {
        for (uint32_t seed = 0u; seed < 4u; seed++) {
            tm_t d;
            if (arch < 2u) {
                rnd_model(&d, arch, seed);
            } else if (arch == 2u) {
                rnd_model2(&d, seed);
            } else {
                rnd_model3(&d, seed);
            }
            for (uint32_t si = 0u; si < 5u; si++) {
                const uint32_t w = sizes[arch][si][0], h = sizes[arch][si][1];
                rnd_image(img, w, h, seed * 5u + si + 100u);
                char msg[64];
                snprintf(msg, sizeof msg, "arch %u seed %u size %ux%u", (unsigned)arch, (unsigned)seed,
                         (unsigned)w, (unsigned)h);
                TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, tm_load(&d, &g_m), msg);
                stream_check(&g_m, img, w, h, msg);
                int8_t *ref[VD_CNN_MAX_TENSORS];
                ref_forward(&d, img, w, h, ref);
                size_t bytes = 0u;
                const uint32_t fl = VD_CNN_STREAM | VD_CNN_KEEP_TENSORS;
                TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&g_m, w, h, fl, &bytes));
                void *ws = tu_guarded_alloc(2, bytes);
                vd_cnn_output_t head;
                TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run_ex(&g_m, img, w, h, w, fl, ws, bytes, &head));
                for (uint32_t t = 0u; t <= d.n; t++) {
                    vd_cnn_output_t x;
                    const vd_status_t st = vd_cnn_tensor(&g_m, ws, bytes, w, h, t, &x);
                    if (arch == 2u && t == 2u) {
                        TEST_ASSERT_EQUAL_INT_MESSAGE(VD_ERR_STATE, st, msg);   // dead branch: never computed
                        continue;
                    }
                    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, st, msg);
                    TEST_ASSERT_EQUAL_INT8_ARRAY_MESSAGE(ref[t], x.data, x.w * x.h * x.c, msg);
                }
                tu_guard_check(2);
                tu_guarded_free(2);
                // Streamed alone, a ring tensor cannot be read back.
                if (d.n >= 2u) {
                    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&g_m, w, h, VD_CNN_STREAM, &bytes));
                    ws = tu_guarded_alloc(2, bytes);
                    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run_ex(&g_m, img, w, h, w, VD_CNN_STREAM, ws, bytes, &head));
                    vd_cnn_output_t x;
                    if (h / g_m.align > 2u) {
                        TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_tensor(&g_m, ws, bytes, w, h, 1u, &x));
                    }
                    tu_guarded_free(2);
                }
                for (uint32_t t = 0u; t <= d.n; t++) {
                    free(ref[t]);
                }
            }
        }
    }
}

// Which upsamples the streamed plan fuses (run record, cnn_internal.h):
// only one whose every consumer is a concat, and none with
// VD_CNN_KEEP_TENSORS or on a whole plane. A fused one has no ring and no
// bytes; the kept ones have theirs.
static void test_stream_fuses_upsample_read_only_by_concats(void)
{
    tm_t d;
    rnd_model3(&d, 1u);
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &g_m));
    static uint8_t img[64 * 32];
    rnd_image(img, 64u, 32u, 9u);
    const uint32_t flags[3] = {VD_CNN_STREAM, VD_CNN_STREAM | VD_CNN_KEEP_TENSORS, 0u};
    for (uint32_t i = 0u; i < 3u; i++) {
        size_t bytes = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&g_m, 64u, 32u, flags[i], &bytes));
        void *ws = tu_guarded_alloc(0, bytes);
        vd_cnn_output_t head;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run_ex(&g_m, img, 64u, 32u, 64u, flags[i], ws, bytes, &head));
        const vd_cnn_plan_t *p = (const vd_cnn_plan_t *)ws;
        const bool fused = i == 0u;
        TEST_ASSERT_EQUAL_UINT8(fused ? 2u : 1u, p->live[7]);
        TEST_ASSERT_EQUAL_UINT16(fused ? 0u : 8u, p->rows[7]);   // 32 / 4 rows when stored whole
        TEST_ASSERT_EQUAL_UINT32(fused ? 0u : 16u * 8u * 8u, p->len[2u * 7u]);
        TEST_ASSERT_EQUAL_UINT8(1u, p->live[6]);
        TEST_ASSERT_EQUAL_UINT8(1u, p->live[8]);
        TEST_ASSERT_TRUE(p->rows[6] > 0u && p->rows[8] > 0u);
        tu_guard_check(0);
        tu_guarded_free(0);
    }
}

// The committed networks (models/vd_cnn*.vdm): streamed == whole plane on
// thermal-like frames at the detector's input sizes for frames of 640x512,
// 640x480, 200x120, 66x34 and 16x16 (half resolution, padded to the
// alignment as the detector pads: 320x256, 320x240, 100x60 -> 112x64, 33x17
// -> 48x32, 8x8 -> 16x16 for alignment 16).
static uint32_t g_model_buf[(192u * 1024u) / 4u];   // the largest committed network, vd_cnn2: 157 KiB

static bool load_file_model(const char *path, vd_cnn_model_t *m)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        return false;
    }
    const size_t n = fread(g_model_buf, 1, sizeof g_model_buf, f);
    fclose(f);
    return vd_cnn_load(m, g_model_buf, n) == VD_OK;
}

// A test frame for the committed models: warm blobs (vehicles) on a
// sky-to-road gradient with noise; phase shifts the blob pattern.
static void warm_frame(uint8_t *img, uint32_t w, uint32_t h, uint32_t seed, uint32_t phase)
{
    uint32_t st = seed;
    for (uint32_t y = 0u; y < h; y++) {
        for (uint32_t x = 0u; x < w; x++) {
            uint32_t v = 40u + (y * 120u) / h + (tu_rand(&st) & 15u);
            if (((x / 12u) * 5u + (y / 9u) * 3u + phase) % 13u == 0u) {
                v += 90u;
            }
            img[(size_t)y * w + x] = (uint8_t)(v > 255u ? 255u : v);
        }
    }
}

static void test_stream_committed_models_match_whole_plane(void)
{
    static const char *const paths[3] = {VD_SOURCE_DIR "/models/vd_cnn.vdm", VD_SOURCE_DIR "/models/vd_cnn2.vdm",
                                         VD_SOURCE_DIR "/models/vd_cnn_compact.vdm"};
    static const uint32_t sizes[5][2] = {{320, 256}, {320, 240}, {100, 60}, {33, 17}, {8, 8}};
    static uint8_t img[320 * 256];
    static vd_cnn_model_t m;
    uint32_t loaded = 0u;
    for (uint32_t mi = 0u; mi < 3u; mi++) {
        if (!load_file_model(paths[mi], &m)) {
            continue;   // a checkout without the models: the random models above still run
        }
        loaded++;
        const uint32_t a = m.align;
        for (uint32_t si = 0u; si < 5u; si++) {
            const uint32_t w = (sizes[si][0] + a - 1u) / a * a;
            const uint32_t h = (sizes[si][1] + a - 1u) / a * a;
            warm_frame(img, w, h, 99u + si * 7u + mi, si);
            char msg[96];
            snprintf(msg, sizeof msg, "%s %ux%u", m.name, (unsigned)w, (unsigned)h);
            stream_check(&m, img, w, h, msg);
        }
    }
    TEST_ASSERT_TRUE(loaded == 3u);
}


// Head bytes of a streamed run of m on img (w x h) with flags, into ws; copied to head (>= out bytes).
static vd_status_t reuse_run(const vd_cnn_model_t *m, const uint8_t *img, uint32_t w, uint32_t h, uint32_t flags,
                             uint8_t *ws, size_t bytes, int8_t *head, size_t *n)
{
    vd_cnn_output_t out;
    const vd_status_t st = vd_cnn_run_ex(m, img, w, h, w, VD_CNN_STREAM | flags, ws, bytes, &out);
    if (st == VD_OK) {
        *n = (size_t)out.w * out.h * out.c;
        memcpy(head, out.data, *n);
    }
    return st;
}

// The streamed band rule (plan.c): vd_cnn at 320 x 256 (workspace above VD_CNN_BAND_CAP with one-row
// bands) keeps 1; vd_cnn_compact takes VD_CNN_BAND_MAX within the cap; a whole plane has no band.
static void test_stream_band_rule(void)
{
    static vd_cnn_model_t m;
    static vd_cnn_plan_t p;
    chain_t c;
    if (!load_file_model(VD_SOURCE_DIR "/models/vd_cnn.vdm", &m)) {
        TEST_IGNORE_MESSAGE("models/vd_cnn.vdm not in this checkout");
    }
    TEST_ASSERT_TRUE(vd__cnn_model_ok(&m, &c));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd__cnn_plan_make(&m, &c, 320u, 256u, VD_CNN_STREAM, &p));
    TEST_ASSERT_EQUAL_UINT8(1u, p.band);
    TEST_ASSERT_TRUE(p.total > VD_CNN_BAND_CAP);
    static vd_cnn_model_t mc;
    TEST_ASSERT_TRUE(load_file_model(VD_SOURCE_DIR "/models/vd_cnn_compact.vdm", &mc));
    TEST_ASSERT_TRUE(vd__cnn_model_ok(&mc, &c));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd__cnn_plan_make(&mc, &c, 320u, 256u, VD_CNN_STREAM, &p));
    TEST_ASSERT_EQUAL_UINT8(VD_CNN_BAND_MAX, p.band);
    TEST_ASSERT_TRUE(p.total <= VD_CNN_BAND_CAP);
}

// VD_CNN_HEAD_RING, hand-worked on the committed networks at 320 x 256: the head (80 x 64 cells of 5
// channels at stride 4: 25 600 B) becomes a ring of band + 2 rows of 400 B: vd_cnn (band 1) 3 rows,
// 1 200 B; vd_cnn_compact (band 4) 6 rows, 2 400 B. The workspace shrinks by the difference (24 400 B,
// 23 200 B) where nothing else is planned into the bytes freed; with the CMSIS-NN back end the plan gives
// them to layers' prepared areas (plan.c prep_size, VD_CNN_PREP_CAP), so there it only does not grow.
// Then every argument vd_cnn_run_rows_decode refuses, before running, with *count untouched.
static void test_head_ring_workspace_and_arguments(void)
{
    static vd_cnn_model_t m, mc;
    if (!load_file_model(VD_SOURCE_DIR "/models/vd_cnn.vdm", &m) ||
        !load_file_model(VD_SOURCE_DIR "/models/vd_cnn_compact.vdm", &mc)) {
        TEST_IGNORE_MESSAGE("models/vd_cnn*.vdm not in this checkout");
    }
    static vd_cnn_plan_t p;
    chain_t c;
    const vd_cnn_model_t *ms[2] = {&m, &mc};
    const uint32_t rows_want[2] = {3u, 6u};
    for (uint32_t i = 0u; i < 2u; i++) {
        size_t whole = 0u, ring = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(ms[i], 320u, 256u, VD_CNN_STREAM, &whole));
        TEST_ASSERT_EQUAL_INT(VD_OK,
                              vd_cnn_workspace_size_ex(ms[i], 320u, 256u, VD_CNN_STREAM | VD_CNN_HEAD_RING, &ring));
        TEST_ASSERT_TRUE(ring <= whole);
#if !defined(VD_CNN_CMSIS)
        TEST_ASSERT_EQUAL_size_t(25600u - rows_want[i] * 400u, whole - ring);
#endif
        const uint32_t head = vd_cnn_item_of_tensor(ms[i]->n_layers);
        TEST_ASSERT_TRUE(vd__cnn_model_ok(ms[i], &c));
        TEST_ASSERT_EQUAL_INT(VD_OK, vd__cnn_plan_make(ms[i], &c, 320u, 256u, VD_CNN_STREAM, &p));
        TEST_ASSERT_EQUAL_UINT16(64u, p.rows[ms[i]->n_layers]);
        TEST_ASSERT_EQUAL_UINT32(25600u, p.len[head]);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd__cnn_plan_make(ms[i], &c, 320u, 256u, VD_CNN_STREAM | VD_CNN_HEAD_RING, &p));
        TEST_ASSERT_EQUAL_UINT16(rows_want[i], p.rows[ms[i]->n_layers]);
        TEST_ASSERT_EQUAL_UINT32(rows_want[i] * 400u, p.len[head]);
    }
    size_t bytes = 0u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_workspace_size_ex(&m, 320u, 256u, VD_CNN_HEAD_RING, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_workspace_size_ex(&m, 320u, 256u,
                                                               VD_CNN_STREAM | VD_CNN_KEEP_TENSORS | VD_CNN_HEAD_RING,
                                                               &bytes));
    const uint32_t fl = VD_CNN_STREAM | VD_CNN_HEAD_RING;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&mc, 64u, 32u, fl, &bytes));
    void *ws = tu_guarded_alloc(0, bytes);
    static uint8_t img[64 * 32];
    warm_frame(img, 64u, 32u, 5u, 1u);
    plane_rows_t pr = {img, 64u, 32u, 0u, 0u, true};
    const vd_cnn_rows_t rows = {plane_row, &pr};
    const vd_cnn_rows_t no_row = {NULL, &pr};
    vd_cnn_output_t out;
    // The runs that return the head cannot return a ring of it.
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_ex(&mc, img, 64u, 32u, 64u, fl, ws, bytes, &out));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows(&mc, &rows, 64u, 32u, fl, ws, bytes, &out));
    vd_cnn_box_t boxes[8];
    const vd_cnn_decode_opts_t ok = {VD_CNN_THR_DEFAULT, 0u, 128u, 64u};
    const vd_cnn_decode_opts_t bad[4] = {{200, 0u, 128u, 64u}, {-129, 0u, 128u, 64u}, {0, 0u, 0u, 64u},
                                         {0, 0u, 128u, VD_MAX_DIM + 1u}};
    size_t n = 77u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(NULL, &rows, 64u, 32u, fl, ws, bytes, &ok, boxes, 8u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(&mc, NULL, 64u, 32u, fl, ws, bytes, &ok, boxes, 8u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(&mc, &no_row, 64u, 32u, fl, ws, bytes, &ok, boxes, 8u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(&mc, &rows, 64u, 32u, fl, ws, bytes, &ok, boxes, 8u, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(&mc, &rows, 64u, 32u, fl, ws, bytes, NULL, boxes, 8u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(&mc, &rows, 64u, 32u, fl, ws, bytes, &ok, NULL, 8u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(&mc, &rows, 64u, 32u, VD_CNN_HEAD_RING, ws, bytes, &ok,
                                                             boxes, 8u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(&mc, &rows, 64u, 32u, fl | VD_CNN_KEEP_TENSORS, ws, bytes,
                                                             &ok, boxes, 8u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(&mc, &rows, 64u, 32u, fl | 64u, ws, bytes, &ok, boxes,
                                                             8u, &n));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(&mc, &rows, 60u, 32u, fl, ws, bytes, &ok, boxes, 8u, &n));
    for (uint32_t i = 0u; i < 4u; i++) {
        TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_run_rows_decode(&mc, &rows, 64u, 32u, fl, ws, bytes, &bad[i], boxes,
                                                                 8u, &n));
    }
    TEST_ASSERT_EQUAL_UINT32(0u, pr.calls);   // refused before any row was asked for
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_cnn_run_rows_decode(&mc, &rows, 64u, 32u, fl, ws, bytes - 1u, &ok,
                                                                   boxes, 8u, &n));
    static vd_cnn_model_t unloaded;
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_run_rows_decode(&unloaded, &rows, 64u, 32u, fl, ws, bytes, &ok, boxes,
                                                               8u, &n));
    TEST_ASSERT_EQUAL_size_t(77u, n);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run_rows_decode(&mc, &rows, 64u, 32u, fl, ws, bytes, &ok, boxes, 8u, &n));
    TEST_ASSERT_TRUE(n <= 8u);
    tu_guard_check(0);
    tu_guarded_free(0);
}

// The CRC a record's kept part carries (plan.c's rows_crc): rows, h, live of tensors 0..nt-1, the band.
static uint32_t forged_crc(const vd_cnn_plan_t *p, uint32_t nt)
{
    uint32_t crc = vd__crc32(0u, p->rows, nt * sizeof p->rows[0]);
    crc = vd__crc32(crc, p->h, nt * sizeof p->h[0]);
    crc = vd__crc32(crc, p->live, nt * sizeof p->live[0]);
    return vd__crc32(crc, &p->band, sizeof p->band);
}

// VD_CNN_REUSE_PLAN: a kept plan gives the same bytes as a new one; a record changed since (ring heights
// out of bounds, a CRC that does not match, another size in between) is planned anew, and forged heights
// with a matching CRC never write outside the workspace (guarded allocation), only change results or
// ask for more workspace.
static void test_reuse_plan_kept_checked_and_safe(void)
{
    static vd_cnn_model_t m;
    if (!load_file_model(VD_SOURCE_DIR "/models/vd_cnn_compact.vdm", &m)) {
        TEST_IGNORE_MESSAGE("models/vd_cnn_compact.vdm not in this checkout");
    }
    const uint32_t w = 64u, h = 32u;
    static uint8_t img[64 * 32];
    static int8_t ref[8192], got[8192];
    warm_frame(img, w, h, 5u, 1u);
    size_t bytes, small, nref = 0u, n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&m, w, h, VD_CNN_STREAM, &bytes));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&m, w, h, VD_CNN_STREAM | VD_CNN_REUSE_PLAN, &small));
    TEST_ASSERT_EQUAL_size_t(bytes, small);   // no effect on the size
    uint8_t *ws = tu_guarded_alloc(1, bytes);
    memset(ws, 0, bytes);
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, 0u, ws, bytes, ref, &nref));
    TEST_ASSERT_TRUE(nref > 0u && nref <= sizeof ref);
    vd_cnn_plan_t *p = (vd_cnn_plan_t *)(void *)ws;
    const vd_cnn_plan_t fresh = *p;
    // Kept: same bytes and the same plan, twice.
    for (int k = 0; k < 2; k++) {
        TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
        TEST_ASSERT_EQUAL_size_t(nref, n);
        TEST_ASSERT_EQUAL_MEMORY(ref, got, n);
        TEST_ASSERT_EQUAL_MEMORY(fresh.rows, p->rows, sizeof fresh.rows);
        TEST_ASSERT_EQUAL_MEMORY(fresh.off, p->off, sizeof fresh.off);
        TEST_ASSERT_EQUAL_UINT32(VD_CNN_STREAM, p->flags);   // the plan's flags do not hold the reuse bit
    }
    // Another size in between, then back.
    static int8_t other[8192];
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, 32u, 32u, VD_CNN_REUSE_PLAN, ws, bytes, other, &n));
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_MEMORY(ref, got, nref);
    const uint32_t nt = m.n_layers + 1u;
    uint32_t t1 = 1u;   // a computed tensor with a ring of more than one row
    while (t1 < m.n_layers && !(p->live[t1] == 1u && p->rows[t1] > 1u && p->rows[t1] < p->h[t1])) {
        t1++;
    }
    TEST_ASSERT_TRUE(t1 < m.n_layers);
    // A changed height without its CRC, or out of bounds with it: planned anew.
    p->rows[t1] = (uint16_t)(p->rows[t1] - 1u);
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_MEMORY(ref, got, nref);
    TEST_ASSERT_EQUAL_MEMORY(fresh.rows, p->rows, sizeof fresh.rows);
    p->rows[t1] = (uint16_t)(p->h[t1] + 1u);
    p->rows_crc = forged_crc(p, nt);
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_MEMORY(ref, got, nref);
    TEST_ASSERT_EQUAL_MEMORY(fresh.rows, p->rows, sizeof fresh.rows);
    // Forged within bounds, CRC matching: kept (the proof that a run keeps heights). A taller ring asks
    // for more workspace than there is; a one-row ring runs inside its item (wrong values, no stray write).
    p->rows[t1] = p->h[t1];
    p->rows_crc = forged_crc(p, nt);
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));   // magic 0: anew
    TEST_ASSERT_EQUAL_MEMORY(ref, got, nref);
    p->rows[t1] = 1u;
    p->rows_crc = forged_crc(p, nt);
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_UINT16(1u, p->rows[t1]);
    // A band outside 1..VD_CNN_BAND_MAX, CRC matching: planned anew.
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, 0u, ws, bytes, got, &n));
    p->band = (uint8_t)(VD_CNN_BAND_MAX + 1u);
    p->rows_crc = forged_crc(p, nt);
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_MEMORY(ref, got, nref);
    TEST_ASSERT_EQUAL_UINT8(fresh.band, p->band);
    // A plan made ahead (the detector's init): no tensor to read, kept by the first run, same bytes.
    memset(ws, 0xA5, bytes);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd__cnn_plan_ahead(&m, w, h, VD_CNN_STREAM, ws, bytes));
    TEST_ASSERT_EQUAL_UINT32(VD_CNN_PLAN_MAGIC, p->magic);
    vd_cnn_output_t t;
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_tensor(&m, ws, bytes, w, h, m.n_layers, &t));
    TEST_ASSERT_EQUAL_MEMORY(fresh.rows, p->rows, nt * sizeof p->rows[0]);   // (the rest: 0xA5)
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_MEMORY(ref, got, nref);
    TEST_ASSERT_EQUAL_UINT32(VD_CNN_REC_MAGIC, p->magic);
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd__cnn_plan_ahead(&m, w, h, VD_CNN_STREAM, ws, bytes - 16u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd__cnn_plan_ahead(&m, 6u, h, VD_CNN_STREAM, ws, bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd__cnn_plan_ahead(NULL, w, h, VD_CNN_STREAM, ws, bytes));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd__cnn_plan_ahead(&m, w, h, VD_CNN_STREAM, ws + 1, bytes - 1u));
    // Without the flag the record is never read.
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, 0u, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_MEMORY(ref, got, nref);
    TEST_ASSERT_EQUAL_MEMORY(fresh.rows, p->rows, nt * sizeof p->rows[0]);
    tu_guarded_free(1);
}

// VD_CNN_SAME_HIST: after a complete run on a frame, a kept-plan run on its mirror takes that run's input
// table and gives the bytes of a fresh run on the mirror; the table is made anew (the flag not honoured)
// without VD_CNN_REUSE_PLAN, after a plan made ahead, and after a run of another size. A broken promise
// (an inverted frame) gives other bytes than a fresh run of it, inside the guarded workspace.
static void test_same_hist_mirror(void)
{
    static vd_cnn_model_t m;
    if (!load_file_model(VD_SOURCE_DIR "/models/vd_cnn_compact.vdm", &m)) {
        TEST_IGNORE_MESSAGE("models/vd_cnn_compact.vdm not in this checkout");
    }
    TEST_ASSERT_TRUE(m.input_norm == VD_CNN_NORM_PERCENTILE || m.input_norm == VD_CNN_NORM_EQUALISE);
    const uint32_t w = 64u, h = 32u;
    static uint8_t img[64 * 32], mir[64 * 32], inv[64 * 32];
    warm_frame(img, w, h, 11u, 2u);
    for (uint32_t y = 0u; y < h; y++) {
        for (uint32_t x = 0u; x < w; x++) {
            mir[y * w + x] = img[y * w + (w - 1u - x)];
            inv[y * w + x] = (uint8_t)(255u - img[y * w + x]);
        }
    }
    static int8_t ref_m[8192], ref_i[8192], got[8192];
    size_t bytes, nref = 0u, n = 0u, ni = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&m, w, h, VD_CNN_STREAM | VD_CNN_SAME_HIST, &bytes));
    uint8_t *ws = tu_guarded_alloc(1, bytes);
    memset(ws, 0, bytes);
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, mir, w, h, 0u, ws, bytes, ref_m, &nref));
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, inv, w, h, 0u, ws, bytes, ref_i, &ni));
    TEST_ASSERT_EQUAL_size_t(nref, ni);
    const uint32_t keep = VD_CNN_REUSE_PLAN | VD_CNN_SAME_HIST;
    // Honoured: the frame, then its mirror.
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, mir, w, h, keep, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_MEMORY(ref_m, got, nref);
    // A broken promise: the frame's table on the inverted frame, not the inverted frame's own.
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, inv, w, h, keep, ws, bytes, got, &n));
    TEST_ASSERT_TRUE(memcmp(ref_i, got, ni) != 0);
    // Not honoured: without VD_CNN_REUSE_PLAN ...
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, w, h, 0u, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, inv, w, h, VD_CNN_SAME_HIST, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_MEMORY(ref_i, got, ni);
    // ... after a plan made ahead (no run left a table) ...
    memset(ws, 0x5A, bytes);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd__cnn_plan_ahead(&m, w, h, VD_CNN_STREAM, ws, bytes));
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, inv, w, h, keep, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_MEMORY(ref_i, got, ni);
    // ... and after a run of another size.
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, img, 32u, 32u, VD_CNN_REUSE_PLAN, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_INT(VD_OK, reuse_run(&m, inv, w, h, keep, ws, bytes, got, &n));
    TEST_ASSERT_EQUAL_MEMORY(ref_i, got, ni);
    tu_guarded_free(1);
}

// ------------------------------------------------------------ x86 kernels against the portable ones

// Pushes a random weighted layer to the limits (mode bits): 1 weights
// -128 / 127 only (else half of them), 2 the output zero point -128 or 127,
// 4 multipliers 2^30 / 2^31 - 1, 8 shifts -31 / -1 / 0 / 1 / 7 (else 32:
// shifts -30 / -1 / 0), 16 biases at the loader's bound +-(INT32_MAX - K * 128 * 255).
static void push_extremes(tl_t *L, uint32_t *st, uint32_t mode)
{
    int8_t *w = g_wpool + (L->w - g_wpool);
    int32_t *bias = g_ipool + (L->bias - g_ipool);
    int32_t *mult = g_ipool + (L->mult - g_ipool);
    int8_t *shift = g_spool + (L->shift - g_spool);
    const uint32_t wl = w_len(L);
    for (uint32_t i = 0u; i < wl; i++) {
        if ((mode & 1u) != 0u || (tu_rand(st) & 1u) != 0u) {
            w[i] = (int8_t)((tu_rand(st) & 1u) ? 127 : -128);
        }
    }
    if ((mode & 2u) != 0u) {
        const bool relu = L->amin == L->zp;
        L->zp = (int8_t)((tu_rand(st) & 1u) ? 127 : -128);
        L->amin = relu ? L->zp : -128;
        L->amax = 127;
    }
    const uint32_t k = (L->op == VD_CNN_OP_DW3X3) ? 9u
                       : (L->op == VD_CNN_OP_PW1X1) ? L->cin
                       : (L->op == VD_CNN_OP_CONV5X5) ? 25u * L->cin : 9u * L->cin;
    const int32_t bmax = (int32_t)(INT32_MAX - (int64_t)k * 128 * 255);
    static const int8_t shifts[5] = {-31, -1, 0, 1, 7};
    static const int8_t shifts_nonpos[3] = {-30, -1, 0};
    for (uint32_t o = 0u; o < L->cout; o++) {
        if ((mode & 4u) != 0u) {
            mult[o] = (tu_rand(st) & 1u) ? INT32_MAX : 0x40000000;
        }
        if ((mode & 8u) != 0u) {
            shift[o] = shifts[tu_rand(st) % 5u];
        } else if ((mode & 32u) != 0u) {
            shift[o] = shifts_nonpos[tu_rand(st) % 3u];
        }
        if ((mode & 16u) != 0u && (tu_rand(st) & 1u) != 0u) {
            bias[o] = (tu_rand(st) & 1u) ? bmax : -bmax;
        }
    }
}

// Awkward shapes for the x86 tiles: channel counts 1, 3, 5, 17, 33, 65, 129
// (lane and tile tails), K = 9, 25 cin, cin 65, every weighted op. arch 0
// reaches stride 4 in two layers, so inputs 4, 28, 132 wide give tensors 1,
// 7, 33 wide; arch 1 strides 2 by 3x3, dw and 5x5 (head at stride 8).
static void awkward_model(tm_t *d, uint32_t arch, uint32_t seed, uint32_t mode)
{
    uint32_t st = seed * 2246822519u + 3u;
    pools_reset();
    g_wsym = false;
    static const uint16_t c1s[3] = {1, 3, 5};
    const uint16_t c1 = c1s[seed % 3u];
    if (arch == 0u) {
        tm_init(d, 8u, 8u, 5u, 4u);
        d->L[0] = rnd_weighted(&st, VD_CNN_OP_CONV3X3, 2u, 0u, 1u, c1);
        d->L[1] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 2u, 1u, c1, c1);
        d->L[2] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 2u, c1, 17u);
        d->L[3] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 3u, 17u, 17u);
        d->L[4] = rnd_weighted(&st, VD_CNN_OP_CONV5X5, 1u, 4u, 17u, 3u);
        d->L[5] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 5u, 3u, 33u);
        d->L[6] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 6u, 33u, 33u);
        d->L[7] = rnd_weighted(&st, VD_CNN_OP_CONV3X3, 1u, 7u, 33u, 65u);
        d->L[8] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 8u, 65u, 65u);
        d->L[9] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 9u, 65u, 129u);
        d->L[10] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 10u, 129u, 129u);
        d->L[11] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 11u, 129u, 5u);
        d->n = 12u;
    } else {
        tm_init(d, 8u, 8u, 5u, 8u);
        d->L[0] = rnd_weighted(&st, VD_CNN_OP_CONV3X3, 2u, 0u, 1u, c1);
        d->L[1] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 1u, 1u, c1, c1);
        d->L[2] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 2u, c1, 17u);
        d->L[3] = rnd_weighted(&st, VD_CNN_OP_DW3X3, 2u, 3u, 17u, 17u);
        d->L[4] = rnd_weighted(&st, VD_CNN_OP_CONV5X5, 2u, 4u, 17u, 33u);
        d->L[5] = rnd_weighted(&st, VD_CNN_OP_PW1X1, 1u, 5u, 33u, 5u);
        d->n = 6u;
    }
    for (uint32_t l = 0u; l < d->n; l++) {
        push_extremes(&d->L[l], &st, mode);
    }
}

// The awkward models with extreme values against the naive reference
// (every build: the portable kernels, or the x86 or CMSIS-NN ones where they
// run; mode 32's shifts are ones CMSIS-NN takes).
static void test_awkward_models_match_naive_reference(void)
{
    static uint8_t img[132 * 36];
    static const uint32_t modes[4] = {0u, 1u | 2u | 4u | 8u | 16u, 8u | 16u, 1u | 2u | 4u | 16u | 32u};
    static const uint32_t sizes[2][2][2] = {{{4, 4}, {132, 36}}, {{8, 8}, {56, 16}}};
    uint32_t checked = 0u;
    for (uint32_t arch = 0u; arch < 2u; arch++) {
        for (uint32_t mi = 0u; mi < 4u; mi++) {
            tm_t d;
            awkward_model(&d, arch, 5u + mi, modes[mi]);
            for (uint32_t si = 0u; si < 2u; si++) {
                const uint32_t w = sizes[arch][si][0], h = sizes[arch][si][1];
                rnd_image(img, w, h, mi + si + 400u);
                char tag[48];
                snprintf(tag, sizeof tag, "awkward %u mode %u", (unsigned)arch, (unsigned)modes[mi]);
                int8_t *ref[VD_CNN_MAX_TENSORS];
                vd_cnn_output_t head;
                checked += every_tensor_checked(&d, img, w, h, tag, ref, &head);
                for (uint32_t t = 0u; t <= d.n; t++) {
                    free(ref[t]);
                }
                run_free();
            }
        }
    }
    TEST_ASSERT_TRUE(checked > 100000u);
}

#if defined(VD_CNN_X86) || defined(VD_CNN_CMSIS)
// Every tensor of two runs of m with flags f (KEEP_TENSORS) in workspaces a and b, byte for byte (tag:
// the message's prefix). Returns the bytes compared.
static uint32_t tensors_equal(const vd_cnn_model_t *m, const uint8_t *a, size_t ab, const uint8_t *b, size_t bb,
                              uint32_t w, uint32_t h, uint32_t f, const char *what, const char *tag)
{
    uint32_t compared = 0u;
    for (uint32_t t = 0u; t <= m->n_layers; t++) {
        vd_cnn_output_t xa, xb;
        const vd_status_t sa = vd_cnn_tensor(m, a, ab, w, h, t, &xa);
        TEST_ASSERT_EQUAL_INT_MESSAGE(vd_cnn_tensor(m, b, bb, w, h, t, &xb), sa, what);
        if (sa == VD_OK) {
            char msg[128];
            snprintf(msg, sizeof msg, "%s %sflags %u tensor %u", what, tag, (unsigned)f, (unsigned)t);
            TEST_ASSERT_EQUAL_INT8_ARRAY_MESSAGE(xb.data, xa.data, xa.w * xa.h * xa.c, msg);
            compared += xa.w * xa.h * xa.c;
        }
    }
    return compared;
}

#if defined(VD_CNN_X86)
// m prepared (vd_cnn_prepare, into a guarded buffer) against the portable kernels: every tensor of a run
// with flags fl | VD_CNN_KEEP_TENSORS, byte for byte. Returns the bytes compared.
static uint32_t prepared_check(const vd_cnn_model_t *m, const uint8_t *img, uint32_t w, uint32_t h, uint32_t fl,
                               const char *what)
{
    static vd_cnn_model_t pm;
    pm = *m;
    size_t pb = 0u, wb = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_prepared_size(&pm, &pb));
    TEST_ASSERT_TRUE_MESSAGE(pb > 0u, what);   // x86_skip_unless_available: this CPU has a kernel set
    uint8_t *pbuf = tu_guarded_alloc(2, pb);
    memset(pbuf, 0x3C, pb);
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_cnn_prepare(&pm, pbuf, pb), what);
    TEST_ASSERT_TRUE(pm.prepared == pbuf);
    const uint32_t f = fl | VD_CNN_KEEP_TENSORS;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(&pm, w, h, f, &wb));
    uint8_t *a = tu_guarded_alloc(0, wb);
    uint8_t *b = tu_guarded_alloc(1, wb);
    vd_cnn_output_t ha, hb;
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_cnn_run_ex(&pm, img, w, h, w, f, a, wb, &ha), what);
    TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_cnn_run_ex(&pm, img, w, h, w, f | VD_CNN_PORTABLE, b, wb, &hb), what);
    const uint32_t compared = tensors_equal(&pm, a, wb, b, wb, w, h, f, what, "prepared, ");
    tu_guard_check(0);
    tu_guard_check(1);
    tu_guard_check(2);
    tu_guarded_free(1);
    tu_guarded_free(0);
    tu_guarded_free(2);
    return compared;
}
#endif

// Every tensor of m on img (w x h): flags fl (with VD_CNN_KEEP_TENSORS)
// against fl | VD_CNN_PORTABLE, byte for byte; same workspace size; and the
// shared-memory head (fl without KEEP) likewise. Returns the bytes compared.
static uint32_t backend_check(const vd_cnn_model_t *m, const uint8_t *img, uint32_t w, uint32_t h, uint32_t fl,
                              const char *what)
{
    uint32_t compared = 0u;
    for (uint32_t keep = 0u; keep < 2u; keep++) {
        const uint32_t f = fl | (keep ? VD_CNN_KEEP_TENSORS : 0u);
        size_t fast_b = 0u, port_b = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(m, w, h, f, &fast_b));
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size_ex(m, w, h, f | VD_CNN_PORTABLE, &port_b));
        TEST_ASSERT_TRUE_MESSAGE(port_b == fast_b, what);   // (Unity has no 64-bit compare on 32-bit targets)
        uint8_t *a = tu_guarded_alloc(0, fast_b);
        uint8_t *b = tu_guarded_alloc(1, port_b);
        memset(a, 0x5A, fast_b);
        memset(b, 0xA5, port_b);
        vd_cnn_output_t ha, hb;
        TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_cnn_run_ex(m, img, w, h, w, f, a, fast_b, &ha), what);
        TEST_ASSERT_EQUAL_INT_MESSAGE(VD_OK, vd_cnn_run_ex(m, img, w, h, w, f | VD_CNN_PORTABLE, b, port_b, &hb),
                                      what);
        TEST_ASSERT_EQUAL_INT8_ARRAY_MESSAGE(hb.data, ha.data, ha.w * ha.h * ha.c, what);
        compared += ha.w * ha.h * ha.c;
        compared += keep ? tensors_equal(m, a, fast_b, b, port_b, w, h, f, what, "") : 0u;
        tu_guard_check(0);
        tu_guard_check(1);
        tu_guarded_free(1);
        tu_guarded_free(0);
    }
#if defined(VD_CNN_X86)
    compared += prepared_check(m, img, w, h, fl, what);   // and with its weights prepared once
#endif
    return compared;
}

// Random models of every op (architectures 0-2 of the tests above) and the
// awkward ones with extreme values, whole plane and streamed, through
// backend_check; returns the bytes compared. Mode 32 keeps every shift <= 0
// (and >= -30), the layers the CMSIS-NN back end takes (kernels/cmsis.h),
// so its extremes run there rather than on the portable kernels.
static uint32_t backend_random_models(void)
{
    static uint8_t img[264 * 40];
    uint32_t compared = 0u;
    tm_t d;
    for (uint32_t arch = 0u; arch < 3u; arch++) {
        static const uint32_t sizes[3][3][2] = {{{8, 8}, {24, 16}, {56, 40}},
                                                {{8, 8}, {40, 24}, {56, 40}},
                                                {{4, 4}, {20, 12}, {44, 28}}};
        for (uint32_t seed = 0u; seed < 4u; seed++) {
            if (arch < 2u) {
                rnd_model(&d, arch, seed);
            } else {
                rnd_model2(&d, seed);
            }
            TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &g_m));
            for (uint32_t si = 0u; si < 3u; si++) {
                const uint32_t w = sizes[arch][si][0], h = sizes[arch][si][1];
                rnd_image(img, w, h, seed * 3u + si + 200u);
                char msg[64];
                snprintf(msg, sizeof msg, "arch %u seed %u %ux%u", (unsigned)arch, (unsigned)seed, (unsigned)w,
                         (unsigned)h);
                compared += backend_check(&g_m, img, w, h, 0u, msg);
                compared += backend_check(&g_m, img, w, h, VD_CNN_STREAM, msg);
            }
        }
    }
    static const uint32_t modes[7] = {0u, 1u, 2u | 16u, 4u | 8u, 1u | 2u | 4u | 8u | 16u, 8u | 16u,
                                      1u | 2u | 4u | 16u | 32u};
    for (uint32_t arch = 0u; arch < 2u; arch++) {
        static const uint32_t sizes[2][3][2] = {{{4, 4}, {28, 20}, {132, 36}}, {{8, 8}, {56, 16}, {264, 24}}};
        for (uint32_t mi = 0u; mi < 7u; mi++) {
            for (uint32_t seed = 0u; seed < 3u; seed++) {
                awkward_model(&d, arch, seed + 10u * mi, modes[mi]);
                TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &g_m));
                for (uint32_t si = 0u; si < 3u; si++) {
                    const uint32_t w = sizes[arch][si][0], h = sizes[arch][si][1];
                    TEST_ASSERT_TRUE(w % g_m.align == 0u && h % g_m.align == 0u);
                    rnd_image(img, w, h, seed + si + 300u);
                    char msg[64];
                    snprintf(msg, sizeof msg, "awkward %u mode %u seed %u %ux%u", (unsigned)arch,
                             (unsigned)modes[mi], (unsigned)seed, (unsigned)w, (unsigned)h);
                    compared += backend_check(&g_m, img, w, h, 0u, msg);
                    compared += backend_check(&g_m, img, w, h, VD_CNN_STREAM, msg);
                }
            }
        }
    }
    return compared;
}

// The committed networks at several input sizes, whole plane and streamed, through backend_check.
static void backend_committed_models(void)
{
    static const char *const paths[3] = {VD_SOURCE_DIR "/models/vd_cnn.vdm", VD_SOURCE_DIR "/models/vd_cnn2.vdm",
                                         VD_SOURCE_DIR "/models/vd_cnn_compact.vdm"};
    static const uint32_t sizes[4][2] = {{320, 256}, {100, 60}, {33, 17}, {8, 8}};
    static uint8_t img[320 * 256];
    static vd_cnn_model_t m;
    uint32_t loaded = 0u;
    for (uint32_t mi = 0u; mi < 3u; mi++) {
        if (!load_file_model(paths[mi], &m)) {
            continue;
        }
        loaded++;
        const uint32_t a = m.align;
        for (uint32_t si = 0u; si < 4u; si++) {
            const uint32_t w = (sizes[si][0] + a - 1u) / a * a;
            const uint32_t h = (sizes[si][1] + a - 1u) / a * a;
            warm_frame(img, w, h, 7u + si * 13u + mi, si + 1u);
            char msg[96];
            snprintf(msg, sizeof msg, "%s %ux%u", m.name, (unsigned)w, (unsigned)h);
            (void)backend_check(&m, img, w, h, 0u, msg);
            (void)backend_check(&m, img, w, h, VD_CNN_STREAM, msg);
        }
    }
    TEST_ASSERT_TRUE(loaded == 3u);
}

#if defined(VD_CNN_CMSIS)
// A random layer as the shipped networks' (and so the CMSIS-NN back end's DSP kernels', kernels/cmsis.h)
// are: clamp [-128, 127], zero point -128 (ReLU) or zp, every shift in -12..-5.
static tl_t dsp_weighted(uint32_t *st, uint8_t op, uint8_t stride, uint8_t in, uint16_t cin, uint16_t cout, int8_t zp)
{
    tl_t L = rnd_weighted(st, op, stride, in, cin, cout);
    L.zp = zp;
    L.amin = -128;
    L.amax = 127;
    int8_t *shift = g_spool + g_sn - cout;   // this layer's shifts (rnd_weighted's last take of the pool)
    for (uint32_t o = 0u; o < cout; o++) {
        shift[o] = (int8_t)(-5 - (int32_t)(tu_rand(st) % 8u));
    }
    return L;
}

// Shapes of the DSP kernels' less common paths, which the committed networks do not reach: pointwise
// layers whose input channels are an odd number of four-value steps (12, 20) or one step (4), ReLU
// layers with output channels not a multiple of 4, a one-channel 3x3 layer of 12 channels, depthwise
// layers of 8, 12, 20 channels at strides 1 and 2; whole plane and streamed at several sizes, through
// backend_check. Returns the bytes compared.
static uint32_t backend_dsp_models(void)
{
    static uint8_t img[100 * 36];
    static const uint32_t sizes[5][2] = {{4, 4}, {8, 8}, {20, 12}, {44, 28}, {100, 36}};
    uint32_t compared = 0u;
    tm_t d;
    for (uint32_t seed = 0u; seed < 4u; seed++) {
        uint32_t st = seed * 2654435761u + 7u;
        pools_reset();
        g_wsym = seed % 2u == 1u;
        tm_init(&d, 8u, 8u, 5u, 4u);
        d.L[0] = dsp_weighted(&st, VD_CNN_OP_CONV3X3, 2u, 0u, 1u, 12u, -128);
        d.L[1] = dsp_weighted(&st, VD_CNN_OP_DW3X3, 1u, 1u, 12u, 12u, -128);
        d.L[2] = dsp_weighted(&st, VD_CNN_OP_PW1X1, 1u, 2u, 12u, 8u, -128);
        d.L[3] = dsp_weighted(&st, VD_CNN_OP_DW3X3, 2u, 3u, 8u, 8u, -128);
        d.L[4] = dsp_weighted(&st, VD_CNN_OP_PW1X1, 1u, 4u, 8u, 4u, -128);
        d.L[5] = dsp_weighted(&st, VD_CNN_OP_PW1X1, 1u, 5u, 4u, 20u, -128);
        d.L[6] = dsp_weighted(&st, VD_CNN_OP_DW3X3, 1u, 6u, 20u, 20u, -128);
        d.L[7] = dsp_weighted(&st, VD_CNN_OP_PW1X1, 1u, 7u, 20u, 12u, -128);
        d.L[8] = dsp_weighted(&st, VD_CNN_OP_PW1X1, 1u, 8u, 12u, 6u, -128);
        d.L[9] = dsp_weighted(&st, VD_CNN_OP_PW1X1, 1u, 9u, 6u, 8u, -128);
        d.L[10] = dsp_weighted(&st, VD_CNN_OP_PW1X1, 1u, 10u, 8u, 5u, (int8_t)(seed * 3u));
        d.n = 11u;
        if (seed >= 2u) {
            rnd_norm(&d, &st);
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &g_m));
        for (uint32_t si = 0u; si < 5u; si++) {
            const uint32_t w = sizes[si][0], h = sizes[si][1];
            rnd_image(img, w, h, seed * 5u + si + 500u);
            char msg[64];
            snprintf(msg, sizeof msg, "dsp seed %u %ux%u", (unsigned)seed, (unsigned)w, (unsigned)h);
            compared += backend_check(&g_m, img, w, h, 0u, msg);
            compared += backend_check(&g_m, img, w, h, VD_CNN_STREAM, msg);
        }
    }
    return compared;
}
#endif
#endif

// vd_cnn_prepare's contract on chain_model (two pointwise layers, 1 -> 2 and 2 -> 3 channels): the size
// hand-worked, every refusal with the model left unprepared, the same head prepared or not, and a buffer
// that is not the model's (another model's struct, a damaged header) refused by the run.
static void test_prepare_arguments_and_mismatch(void)
{
    tm_t d;
    chain_model(&d);
    static vd_cnn_model_t m, other;
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    TEST_ASSERT_NULL(m.prepared);
    size_t pb = 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_prepared_size(NULL, &pb));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_prepared_size(&m, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_cnn_prepare(NULL, NULL, 0u));
    memset(&other, 0, sizeof other);
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_prepared_size(&other, &pb));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_prepare(&other, NULL, 0u));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_prepared_size(&m, &pb));
#if defined(VD_CNN_X86)
    if (vd__cnn_x86_level() == VD_CNN_X86_NONE) {
        TEST_ASSERT_EQUAL_UINT32(0u, (uint32_t)pb);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_prepare(&m, NULL, 0u));
        TEST_ASSERT_NULL(m.prepared);
        return;
    }
    // The 192-byte header, then per layer its flags (64 bytes) and one tile: 16 lanes of constants (768
    // bytes) and the weights (VNNI: k4 = 4 bytes per channel; AVX2: k2 = 2 int16), 8 or 12 bytes, padded to
    // 64: 192 + 2 * (64 + 768 + 64).
    TEST_ASSERT_EQUAL_UINT32(1984u, (uint32_t)pb);
    uint8_t *buf = tu_guarded_alloc(2, pb + VD_WORKSPACE_ALIGN);
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_cnn_prepare(&m, NULL, pb));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_cnn_prepare(&m, buf, pb - 1u));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, vd_cnn_prepare(&m, buf + 1, pb));
    TEST_ASSERT_NULL(m.prepared);
    static uint8_t img[16 * 8];
    rnd_image(img, 16u, 8u, 77u);
    size_t wb = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&m, 16u, 8u, &wb));
    uint8_t *ws = tu_guarded_alloc(1, wb);
    vd_cnn_output_t out;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run(&m, img, 16u, 8u, 16u, ws, wb, &out));
    int8_t head[4 * 2 * 3];
    memcpy(head, out.data, sizeof head);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_prepare(&m, buf, pb));
    TEST_ASSERT_TRUE(m.prepared == buf);
    memset(ws, 0x77, wb);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run(&m, img, 16u, 8u, 16u, ws, wb, &out));
    TEST_ASSERT_EQUAL_INT8_ARRAY(head, out.data, sizeof head);
    // Another model with this buffer: its blob and CRC are not the header's.
    TEST_ASSERT_TRUE(load_file_model(VD_SOURCE_DIR "/models/vd_cnn_compact.vdm", &other));
    TEST_ASSERT_NULL(other.prepared);
    other.prepared = buf;
    size_t ob = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_workspace_size(&other, 32u, 32u, &ob));
    uint8_t *ows = tu_guarded_alloc(0, ob);
    static uint8_t oimg[32 * 32];
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_run(&other, oimg, 32u, 32u, 32u, ows, ob, &out));
    tu_guarded_free(0);
    // A damaged header (a layer's offset moved, the level, the size): refused, even for portable runs.
    uint32_t off0;
    memcpy(&off0, buf + offsetof(vd_cnn_prep_hdr_t, off), sizeof off0);
    TEST_ASSERT_EQUAL_UINT32(192u, off0);
    uint32_t off3;
    memcpy(&off3, buf + offsetof(vd_cnn_prep_hdr_t, off) + 3u * sizeof off3, sizeof off3);
    TEST_ASSERT_EQUAL_UINT32(192u + 896u, off3);
    const uint32_t bad[3][2] = {{(uint32_t)offsetof(vd_cnn_prep_hdr_t, off), 1088u},
                                {(uint32_t)offsetof(vd_cnn_prep_hdr_t, level), 9u},
                                {(uint32_t)offsetof(vd_cnn_prep_hdr_t, bytes), 100000u}};
    for (uint32_t i = 0u; i < 3u; i++) {
        uint32_t keep;
        memcpy(&keep, buf + bad[i][0], sizeof keep);
        memcpy(buf + bad[i][0], &bad[i][1], sizeof bad[i][1]);
        TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_run(&m, img, 16u, 8u, 16u, ws, wb, &out));
        TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_cnn_run_ex(&m, img, 16u, 8u, 16u, VD_CNN_PORTABLE, ws, wb, &out));
        memcpy(buf + bad[i][0], &keep, sizeof keep);
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_run(&m, img, 16u, 8u, 16u, ws, wb, &out));
    TEST_ASSERT_EQUAL_INT8_ARRAY(head, out.data, sizeof head);
    // Loading again forgets the buffer.
    TEST_ASSERT_EQUAL_INT(VD_OK, tm_load(&d, &m));
    TEST_ASSERT_NULL(m.prepared);
    tu_guard_check(1);
    tu_guard_check(2);
    tu_guarded_free(1);
    tu_guarded_free(2);
#else
    TEST_ASSERT_EQUAL_UINT32(0u, (uint32_t)pb);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cnn_prepare(&m, NULL, 0u));
    TEST_ASSERT_NULL(m.prepared);
#endif
}

static void x86_skip_unless_available(void)
{
#if !defined(VD_CNN_X86)
    TEST_IGNORE_MESSAGE("x86 kernels not built (CMake VD_CNN_X86=OFF): nothing to compare");
#else
    const uint32_t level = vd__cnn_x86_level();
    if (level == VD_CNN_X86_NONE) {
        TEST_IGNORE_MESSAGE("x86 kernels built, but this CPU lacks AVX2: portable path only, "
                            "not compared");
    }
    // A copy capped at a level this CPU lacks (test_cnn_avxvnni on an AVX2-only CPU) compares the level below.
    printf("x86 kernels compared with the portable ones: %s\n",
           (level == VD_CNN_X86_AVX512) ? "AVX-512 VNNI" : (level == VD_CNN_X86_AVXVNNI) ? "AVX-VNNI" : "AVX2");
#endif
}

// vd_cnn_kernel_set names the set the runs take: the x86 level's name where the x86 back end is built (the
// capped copies of this test, test_cnn_avx2 and test_cnn_avxvnni, name theirs), "cmsis-nn" with CMSIS-NN.
static void test_kernel_set_named(void)
{
    const char *k = vd_cnn_kernel_set();
    TEST_ASSERT_NOT_NULL(k);
#if defined(VD_CNN_X86)
    static const char *const names[4] = {"portable", "avx2", "avx-vnni", "avx512-vnni"};   // by level 0..3
    const uint32_t level = vd__cnn_x86_level();
    TEST_ASSERT_TRUE(level < 4u);
    TEST_ASSERT_EQUAL_STRING(names[level], k);
#elif defined(VD_CNN_CMSIS)
    TEST_ASSERT_EQUAL_STRING("cmsis-nn", k);
#else
    TEST_ASSERT_EQUAL_STRING("portable", k);
#endif
}

// Random models of every op and the awkward ones with extreme values: every
// tensor of the x86 kernels equals the portable kernels' (VD_CNN_PORTABLE),
// whole plane and streamed.
static void test_x86_kernels_match_portable_random(void)
{
    x86_skip_unless_available();
#if defined(VD_CNN_X86)
    TEST_ASSERT_TRUE(backend_random_models() > 1000000u);
#endif
}

// The committed networks at several input sizes, whole plane and streamed:
// every tensor of the x86 kernels equals the portable kernels'.
static void test_x86_kernels_match_portable_committed(void)
{
    x86_skip_unless_available();
#if defined(VD_CNN_X86)
    backend_committed_models();
#endif
}

static void cmsis_skip_unless_built(void)
{
#if !defined(VD_CNN_CMSIS)
    TEST_IGNORE_MESSAGE("CMSIS-NN kernels not built (CMake VD_CNN_CMSIS=OFF, a Cortex-M build option): nothing "
                        "to compare");
#endif
}

// The same models through the CMSIS-NN back end (Cortex-M builds; tests/cross_run.sh runs this test
// compiled for a Cortex-M7 under qemu-arm): every tensor equals the portable kernels'.
static void test_cmsis_kernels_match_portable_random(void)
{
    cmsis_skip_unless_built();
#if defined(VD_CNN_CMSIS)
    TEST_ASSERT_TRUE(backend_random_models() > 1000000u);
#endif
}

static void test_cmsis_kernels_match_portable_committed(void)
{
    cmsis_skip_unless_built();
#if defined(VD_CNN_CMSIS)
    backend_committed_models();
#endif
}

// The DSP kernels' less common shapes (backend_dsp_models) through the CMSIS-NN back end: every tensor
// equals the portable kernels'.
static void test_cmsis_dsp_shapes_match_portable(void)
{
    cmsis_skip_unless_built();
#if defined(VD_CNN_CMSIS)
    TEST_ASSERT_TRUE(backend_dsp_models() > 10000u);
#endif
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_requant_reference_rounding_and_saturation);
    RUN_TEST(test_requant_relu_form_matches_reference);
    RUN_TEST(test_requant_one_shift_form_matches_reference);
    RUN_TEST(test_conv3x3_stride1_padding_hand_worked);
    RUN_TEST(test_conv3x3_stride2_hand_worked);
    RUN_TEST(test_conv5x5_padding2_hand_worked);
    RUN_TEST(test_depthwise_hand_worked);
    RUN_TEST(test_pointwise_hand_worked);
    RUN_TEST(test_upsample_and_concat_hand_worked);
    RUN_TEST(test_input_stretch_hand_worked);
    RUN_TEST(test_planner_chain_and_skip);
    RUN_TEST(test_workspace_contract);
    RUN_TEST(test_tensor_liveness_and_state);
    RUN_TEST(test_run_arguments);
    RUN_TEST(test_decode_peaks_plateaus_ties_topk);
    RUN_TEST(test_decode_box_rounding_and_clamping);
    RUN_TEST(test_thr_from_score);
    RUN_TEST(test_random_models_match_naive_reference);
    RUN_TEST(test_depthwise_extremes_match_reference);
    RUN_TEST(test_stream_random_models_match_whole_plane);
    RUN_TEST(test_stream_fuses_upsample_read_only_by_concats);
    RUN_TEST(test_stream_committed_models_match_whole_plane);
    RUN_TEST(test_reuse_plan_kept_checked_and_safe);
    RUN_TEST(test_same_hist_mirror);
    RUN_TEST(test_stream_band_rule);
    RUN_TEST(test_head_ring_workspace_and_arguments);
    RUN_TEST(test_awkward_models_match_naive_reference);
    RUN_TEST(test_kernel_set_named);
    RUN_TEST(test_prepare_arguments_and_mismatch);
    RUN_TEST(test_x86_kernels_match_portable_random);
    RUN_TEST(test_x86_kernels_match_portable_committed);
    RUN_TEST(test_cmsis_kernels_match_portable_random);
    RUN_TEST(test_cmsis_kernels_match_portable_committed);
    RUN_TEST(test_cmsis_dsp_shapes_match_portable);
    RUN_TEST(test_structural_corruptions_rejected);
    RUN_TEST(test_every_bit_flip_and_truncation_rejected);
    return UNITY_END();
}
