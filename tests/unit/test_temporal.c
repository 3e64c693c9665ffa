// SPDX-License-Identifier: MIT
// Unit tests of the temporal analysis: exp table, similarity, confirm/recover/delete sequences, capacity.
#include "unity.h"
#include "testutil.h"

#include <stdlib.h>
#include <string.h>

#include "vd/temporal.h"

void setUp(void) {}
void tearDown(void) {}

// exp() in double without libm (the test runner links no -lm): e^-x =
// (e^(-x/64))^64 with a 14-term Taylor series, relative error < 1e-14.
static double exp_neg(double x)
{
    double y = -x / 64.0;
    double term = 1.0;
    double sum = 1.0;
    for (int k = 1; k < 14; k++) {
        term *= y / k;
        sum += term;
    }
    for (int k = 0; k < 6; k++) {
        sum *= sum;
    }
    return sum;
}

static long round_pos(double v)
{
    return (long)(v + 0.5);
}

static vd_temporal_obs_t mk_obs(int32_t x, int32_t y, int32_t w, int32_t h, uint16_t c)
{
    vd_temporal_obs_t o;
    memset(&o, 0, sizeof(o));
    o.box.x = x;
    o.box.y = y;
    o.box.w = w;
    o.box.h = h;
    o.complexity_q15 = c;
    return o;
}

// Paper 000 exactly: fixed sigmas, no motion model. The hand-worked values
// of the paper's formula below are checked in this mode.
static void paper_init(vd_temporal_t *t, vd_track_t *tracks, size_t cap)
{
    vd_temporal_cfg_t cfg;
    memset(&cfg, 0, sizeof(cfg));
    cfg.flags = VD_TEMPORAL_FIXED_SIGMA | VD_TEMPORAL_NO_MOTION;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(t, &cfg, tracks, cap));
}

static void test_exp_table_accuracy(void)
{
    uint32_t worst = 0u;
    for (uint32_t x = 0; x < (16u << 16); x += 7u) {
        double e = exp_neg((double)x / 65536.0) * 32768.0;
        long ref = round_pos(e);
        long got = (long)vd_temporal_exp_neg_q15(x);
        uint32_t d = (uint32_t)labs(got - ref);
        if (d > worst) {
            worst = d;
        }
    }
    TEST_ASSERT_LESS_OR_EQUAL_UINT32(1u, worst);
    // Exact table points (every k/128 and every integer) round the same way.
    for (uint32_t k = 0; k <= 128u * 16u; k++) {
        uint32_t x = k * 512u;
        long ref = round_pos(exp_neg((double)x / 65536.0) * 32768.0);
        TEST_ASSERT_INT_WITHIN(1, ref, (long)vd_temporal_exp_neg_q15(x));
    }
    TEST_ASSERT_EQUAL_UINT32(32768u, vd_temporal_exp_neg_q15(0u));
    TEST_ASSERT_EQUAL_UINT32(12055u, vd_temporal_exp_neg_q15(65536u));  // 32768 / e = 12054.8
    TEST_ASSERT_EQUAL_UINT32(0u, vd_temporal_exp_neg_q15(16u << 16));
    TEST_ASSERT_EQUAL_UINT32(0u, vd_temporal_exp_neg_q15(UINT32_MAX));
}

static void test_complexity(void)
{
    TEST_ASSERT_EQUAL_UINT16(0u, vd_temporal_complexity_q15(5u, 0u));
    TEST_ASSERT_EQUAL_UINT16(8192u, vd_temporal_complexity_q15(25u, 100u));
    TEST_ASSERT_EQUAL_UINT16(32768u, vd_temporal_complexity_q15(100u, 100u));
    TEST_ASSERT_EQUAL_UINT16(32768u, vd_temporal_complexity_q15(200u, 100u));
    TEST_ASSERT_EQUAL_UINT16(10923u, vd_temporal_complexity_q15(1u, 3u)); // 10922.67 rounds up
}

static double ref_similarity(const vd_rect_t *a, double ca, const vd_rect_t *b, double cb, double s)
{
    double dx = (a->x + a->w / 2.0) - (b->x + b->w / 2.0);
    double dy = (a->y + a->h / 2.0) - (b->y + b->h / 2.0);
    double dw = a->w - b->w;
    double dh = a->h - b->h;
    double ss = exp_neg((dx * dx + dy * dy + dw * dw + dh * dh) / (s * s));
    double lo = ca < cb ? ca : cb;
    double hi = ca < cb ? cb : ca;
    double sc = hi == 0.0 ? 1.0 : lo / hi;
    return 0.3 * sc + 0.7 * ss;
}

static void test_similarity_hand_worked(void)
{
    static vd_track_t tracks[4];
    vd_temporal_t t;
    paper_init(&t, tracks, 4);
    vd_rect_t a = {100, 100, 40, 30};
    vd_rect_t b = {116, 100, 40, 30};   // dx = sigma = 16: S_S = exp(-1)
    TEST_ASSERT_EQUAL_UINT32(32768u, vd_temporal_similarity_q15(&t, &a, 1000u, &a, 1000u));
    // 0.3 * 1 + 0.7 * 0.36788 = 0.55752 -> 18268.8; Q15 arithmetic: (9830*32768 + 22938*12055) >> 15 = 18268
    TEST_ASSERT_INT_WITHIN(1, 18269, (long)vd_temporal_similarity_q15(&t, &a, 1000u, &b, 1000u));
    // Complexity ratio 1/2, same box: 0.3 * 0.5 + 0.7 = 0.85
    TEST_ASSERT_INT_WITHIN(2, 27853, (long)vd_temporal_similarity_q15(&t, &a, 1000u, &a, 2000u));
    // Both complexities zero count as equal; one zero gives S_C = 0.
    TEST_ASSERT_EQUAL_UINT32(32768u, vd_temporal_similarity_q15(&t, &a, 0u, &a, 0u));
    TEST_ASSERT_INT_WITHIN(1, 22938, (long)vd_temporal_similarity_q15(&t, &a, 0u, &a, 500u));
    // Far apart: only the complexity part is left.
    vd_rect_t far = {5000, 5000, 40, 30};
    TEST_ASSERT_EQUAL_UINT32(9830u, vd_temporal_similarity_q15(&t, &a, 1000u, &far, 1000u));
}

static void test_similarity_vs_reference_random(void)
{
    static vd_track_t tracks[1];
    vd_temporal_t t;
    paper_init(&t, tracks, 1);
    uint32_t rng = 12345u;
    for (int i = 0; i < 5000; i++) {
        vd_rect_t a = {(int32_t)(tu_rand(&rng) % 600u), (int32_t)(tu_rand(&rng) % 400u),
                       (int32_t)(1u + tu_rand(&rng) % 120u), (int32_t)(1u + tu_rand(&rng) % 90u)};
        vd_rect_t b = a;
        b.x += (int32_t)(tu_rand(&rng) % 41u) - 20;
        b.y += (int32_t)(tu_rand(&rng) % 41u) - 20;
        b.w += (int32_t)(tu_rand(&rng) % 21u) - 10;
        b.h += (int32_t)(tu_rand(&rng) % 21u) - 10;
        if (b.w < 1) { b.w = 1; }
        if (b.h < 1) { b.h = 1; }
        uint16_t ca = (uint16_t)(tu_rand(&rng) % 32769u);
        uint16_t cb = (uint16_t)(tu_rand(&rng) % 32769u);
        double ref = ref_similarity(&a, ca, &b, cb, 16.0) * 32768.0;
        // Q15 weights 9830/22938 vs 0.3/0.7 (<= 0.4 LSB) + exp (1) + S_C rounding (0.5) + final rounding
        TEST_ASSERT_INT_WITHIN(3, round_pos(ref), (long)vd_temporal_similarity_q15(&t, &a, ca, &b, cb));
    }
}

static void test_moving_box_confirmed_at_t2(void)
{
    static vd_track_t tracks[8];
    vd_temporal_t t;
    paper_init(&t, tracks, 8);
    const uint8_t expect[5] = {VD_TRACK_NEW, VD_TRACK_NEW, VD_TRACK_CONFIRMED, VD_TRACK_CONFIRMED, VD_TRACK_CONFIRMED};
    uint32_t id = 0u;
    for (int f = 0; f < 5; f++) {
        vd_temporal_obs_t o[2];
        o[0] = mk_obs(100 + 2 * f, 80, 40, 30, 3000u);
        size_t count = 99u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 2, &count, NULL, NULL));
        TEST_ASSERT_EQUAL_size_t(1u, count);
        TEST_ASSERT_EQUAL_UINT8(expect[f], o[0].state);
        if (f == 0) {
            id = o[0].track_id;
            TEST_ASSERT_NOT_EQUAL(0u, id);
            TEST_ASSERT_EQUAL_UINT32(1u, t.stats.created);
        } else {
            TEST_ASSERT_EQUAL_UINT32(id, o[0].track_id);
            TEST_ASSERT_EQUAL_UINT32(1u, t.stats.matched);
            // dx = 2 px with sigma 16: S_S = exp(-1/64), S_C = 1 -> S = 0.98916
            TEST_ASSERT_INT_WITHIN(2, 32413, (long)o[0].similarity_q15);
        }
    }
}

// Defaults (relative sigma 1.5, motion model): a 40 x 30 target moving 20 px
// per frame. Frame 1: no velocity yet, dx = 20 with sigma_x = max(16, 1.5 *
// 40) = 60: S = 0.3 + 0.7 exp(-1/9) = 0.92639 (the paper's sigma 16 would
// give 0.3 + 0.7 exp(-1.5625) = 0.447 < 0.5: a new track). Frame 2: the
// velocity (20 px = 320 in Q4) predicts the box exactly: S = 1, confirmed.
// vd_temporal_reset forgets the tracks but not the id counter: a target
// confirmed as track 1 over three frames (paper mode: NEW, NEW, CONFIRMED)
// comes back after the reset as a NEW track with id 2, and the stats of the
// last update are cleared.
static void test_reset_forgets_tracks_keeps_ids(void)
{
    static vd_track_t tracks[4];
    vd_temporal_t t;
    paper_init(&t, tracks, 4);
    vd_temporal_obs_t o[2];
    size_t count = 0u;
    for (int f = 0; f < 3; f++) {
        o[0] = mk_obs(100, 80, 40, 30, 3000u);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 2, &count, NULL, NULL));
    }
    TEST_ASSERT_EQUAL_UINT32(1u, o[0].track_id);
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_CONFIRMED, o[0].state);
    TEST_ASSERT_EQUAL_UINT32(1u, t.stats.matched);

    vd_temporal_reset(&t);
    TEST_ASSERT_EQUAL_UINT32(0u, t.stats.matched);
    TEST_ASSERT_EQUAL_UINT32(0u, t.stats.created);
    for (size_t i = 0; i < 4u; i++) {
        TEST_ASSERT_EQUAL_UINT32(0u, tracks[i].id);
    }
    o[0] = mk_obs(100, 80, 40, 30, 3000u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 2, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_size_t(1u, count);
    TEST_ASSERT_EQUAL_UINT32(2u, o[0].track_id);
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_NEW, o[0].state);
    TEST_ASSERT_EQUAL_UINT32(1u, t.stats.created);
    TEST_ASSERT_EQUAL_UINT32(0u, t.stats.matched);
    vd_temporal_reset(NULL);   // documented no-op
}

static void test_constant_velocity_confirmed_at_frame3(void)
{
    static vd_track_t tracks[4];
    vd_temporal_t t;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tracks, 4));
    const uint8_t expect[4] = {VD_TRACK_NEW, VD_TRACK_NEW, VD_TRACK_CONFIRMED, VD_TRACK_CONFIRMED};
    uint32_t id = 0u;
    for (int f = 0; f < 4; f++) {
        vd_temporal_obs_t o[1];
        o[0] = mk_obs(100 + 20 * f, 80, 40, 30, 0u);
        size_t count;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
        TEST_ASSERT_EQUAL_UINT8(expect[f], o[0].state);
        TEST_ASSERT_EQUAL_UINT32(0u, t.stats.motion_votes);   // one track: no global motion
        if (f == 0) {
            id = o[0].track_id;
            continue;
        }
        TEST_ASSERT_EQUAL_UINT32(id, o[0].track_id);
        TEST_ASSERT_INT_WITHIN(2, f == 1 ? 30356 : 32768, (long)o[0].similarity_q15);
        TEST_ASSERT_EQUAL_INT16(320, tracks[0].vx_q4);
        TEST_ASSERT_EQUAL_INT16(0, tracks[0].vy_q4);
    }
    // The same sequence in the paper's mode never associates: 4 new tracks.
    paper_init(&t, tracks, 4);
    for (int f = 0; f < 4; f++) {
        vd_temporal_obs_t o[1];
        o[0] = mk_obs(100 + 20 * f, 80, 40, 30, 0u);
        size_t count;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
        TEST_ASSERT_EQUAL_UINT8(VD_TRACK_NEW, o[0].state);
        TEST_ASSERT_EQUAL_UINT32((uint32_t)f + 1u, o[0].track_id);
    }
}

// Relative sigma: for a 40 x 30 box sigma_x = 60, sigma_y = 45, so dx = 60 or
// dy = 45 gives S_S = exp(-1), S = 0.3 + 0.7 / e = 0.55752 (18269, as the
// paper's dx = 16 above); an 8 x 8 box keeps the 16 px floor (1.5 * 8 = 12).
static void test_relative_sigma(void)
{
    static vd_track_t tracks[1];
    vd_temporal_t t;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tracks, 1));
    vd_rect_t a = {100, 100, 40, 30};
    vd_rect_t bx = {160, 100, 40, 30};
    vd_rect_t by = {100, 145, 40, 30};
    TEST_ASSERT_INT_WITHIN(1, 18269, (long)vd_temporal_similarity_q15(&t, &a, 1000u, &bx, 1000u));
    TEST_ASSERT_INT_WITHIN(1, 18269, (long)vd_temporal_similarity_q15(&t, &a, 1000u, &by, 1000u));
    // Size term: 40 -> 100 wide (mean 70, sigma 105): dW = 60 -> exp(-(60/105)^2) and the centre moves 30
    // px (sigma 105 too): S_S = exp(-(3600 + 900) / 11025) = exp(-0.40816) = 0.66491 -> S = 0.76544
    vd_rect_t big = {100, 100, 100, 30};
    TEST_ASSERT_INT_WITHIN(2, 25082, (long)vd_temporal_similarity_q15(&t, &a, 0u, &big, 0u));
    vd_temporal_t p;
    static vd_track_t tp[1];
    paper_init(&p, tp, 1);
    vd_rect_t s0 = {10, 10, 8, 8};
    vd_rect_t s1 = {22, 15, 8, 8};
    TEST_ASSERT_EQUAL_UINT32(vd_temporal_similarity_q15(&p, &s0, 0u, &s1, 0u),
                             vd_temporal_similarity_q15(&t, &s0, 0u, &s1, 0u));
}

// Four parked 20 x 20 cars 50 px apart; the camera pans 45 px left. The
// nearest box of each track is then its right neighbour (5 px away): without
// the global motion 3 of 4 ids switch. The vote: displacement -45 has 4
// agreeing tracks, +5 only 3 -> motion -45, ids kept, exact predictions.
static void test_global_motion_keeps_ids(void)
{
    for (int mode = 0; mode < 2; mode++) {
        static vd_track_t tracks[8];
        vd_temporal_t t;
        vd_temporal_cfg_t cfg;
        memset(&cfg, 0, sizeof(cfg));
        cfg.flags = mode ? VD_TEMPORAL_NO_GLOBAL : 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, &cfg, tracks, 8));
        vd_temporal_obs_t o[4];
        size_t count;
        uint32_t ids[4];
        for (int i = 0; i < 4; i++) {
            o[i] = mk_obs(100 + 50 * i, 80, 20, 20, 0u);
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 4, 4, &count, NULL, NULL));
        for (int i = 0; i < 4; i++) {
            ids[i] = o[i].track_id;
            o[i] = mk_obs(55 + 50 * i, 80, 20, 20, 0u);
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 4, 4, &count, NULL, NULL));
        if (mode == 0) {
            TEST_ASSERT_EQUAL_UINT32(4u, t.stats.motion_votes);
            TEST_ASSERT_EQUAL_INT32(-45, t.stats.motion_x);
            TEST_ASSERT_EQUAL_INT32(0, t.stats.motion_y);
            for (int i = 0; i < 4; i++) {
                TEST_ASSERT_EQUAL_UINT32(ids[i], o[i].track_id);
                TEST_ASSERT_EQUAL_UINT32(32768u, o[i].similarity_q15);
            }
        } else {
            TEST_ASSERT_EQUAL_UINT32(0u, t.stats.motion_votes);
            TEST_ASSERT_EQUAL_UINT32(ids[0], o[1].track_id);   // 105 taken by the track at 100
            TEST_ASSERT_EQUAL_UINT32(ids[1], o[2].track_id);
            TEST_ASSERT_EQUAL_UINT32(ids[2], o[3].track_id);
        }
    }
}

// A missed target coasts: the track box moves by its velocity, so the next
// detection two frames on is predicted exactly (S = 1, same id); the velocity
// is clamped to max_motion.
static void test_velocity_prediction_and_bounds(void)
{
    static vd_track_t tracks[2];
    vd_temporal_t t;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tracks, 2));
    vd_temporal_obs_t o[1];
    size_t count;
    for (int f = 0; f < 3; f++) {
        o[0] = mk_obs(200, 100 - 10 * f, 40, 30, 0u);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
    }
    uint32_t id = o[0].track_id;
    TEST_ASSERT_EQUAL_INT16(-160, tracks[0].vy_q4);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 1, &count, NULL, NULL));   // missed
    TEST_ASSERT_EQUAL_INT32(70, tracks[0].box.y);                                          // coasted
    o[0] = mk_obs(200, 60, 40, 30, 0u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_UINT32(id, o[0].track_id);
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_CONFIRMED, o[0].state);
    TEST_ASSERT_EQUAL_UINT32(32768u, o[0].similarity_q15);
    TEST_ASSERT_EQUAL_INT16(-160, tracks[0].vy_q4);
    // max_motion 16 px: a 100 px jump (matched thanks to sigma 4 * 40 = 160) is clamped to 16 px/frame.
    vd_temporal_cfg_t cfg;
    memset(&cfg, 0, sizeof(cfg));
    cfg.max_motion = 16u;
    cfg.sigma_rel_q8 = 1024u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, &cfg, tracks, 2));
    o[0] = mk_obs(100, 100, 40, 30, 0u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
    id = o[0].track_id;
    o[0] = mk_obs(200, 100, 40, 30, 0u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_UINT32(id, o[0].track_id);
    TEST_ASSERT_EQUAL_INT16(256, tracks[0].vx_q4);
    // Hostile coordinates saturate instead of wrapping when coasting.
    o[0] = mk_obs(INT32_MAX - 56, 0, 40, 30, 0u);   // 16 px/frame: 3 coasts pass INT32_MAX
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, &cfg, tracks, 2));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
    o[0] = mk_obs(INT32_MAX - 40, 0, 40, 30, 0u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
    for (int f = 0; f < 3; f++) {
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 1, &count, NULL, NULL));
    }
    TEST_ASSERT_EQUAL_INT32(INT32_MAX, tracks[0].box.x);
}

static vd_status_t flat_probe(void *user, const vd_rect_t *box, uint16_t *c)
{
    (void)box;
    (*(int *)user)++;
    *c = 0u;
    return VD_OK;
}

// A confirmed track without complexity (a CNN detection) is not searched
// for: on an edge-free probe S_C = 1 and S_S = 1 at the predicted box, so it
// would "recover" background. VD_TEMPORAL_RECOVER_NO_C re-enables it.
static void test_no_complexity_not_recovered(void)
{
    for (int mode = 0; mode < 2; mode++) {
        static vd_track_t tracks[2];
        vd_temporal_t t;
        vd_temporal_cfg_t cfg;
        memset(&cfg, 0, sizeof(cfg));
        cfg.flags = mode ? VD_TEMPORAL_RECOVER_NO_C : 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, &cfg, tracks, 2));
        vd_temporal_obs_t o[2];
        size_t count;
        for (int f = 0; f < 3; f++) {
            o[0] = mk_obs(100, 80, 40, 30, 0u);
            TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 2, &count, NULL, NULL));
        }
        TEST_ASSERT_EQUAL_UINT8(VD_TRACK_CONFIRMED, o[0].state);
        int calls = 0;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 2, &count, flat_probe, &calls));
        TEST_ASSERT_EQUAL_size_t(mode ? 1u : 0u, count);
        TEST_ASSERT_EQUAL_INT(mode ? 25 : 0, calls);
    }
}

static void test_two_targets_keep_their_ids(void)
{
    static vd_track_t tracks[8];
    vd_temporal_t t;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tracks, 8));
    vd_temporal_obs_t o[2];
    size_t count;
    o[0] = mk_obs(100, 80, 40, 30, 3000u);
    o[1] = mk_obs(130, 80, 40, 30, 3000u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 2, 2, &count, NULL, NULL));
    uint32_t ida = o[0].track_id;
    uint32_t idb = o[1].track_id;
    TEST_ASSERT_NOT_EQUAL(ida, idb);
    // Next frame, listed in the other order and moved apart by 3 px each.
    o[0] = mk_obs(133, 80, 40, 30, 3000u);
    o[1] = mk_obs(97, 80, 40, 30, 3000u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 2, 2, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_UINT32(idb, o[0].track_id);
    TEST_ASSERT_EQUAL_UINT32(ida, o[1].track_id);
}

// Probe of a synthetic scene: the vehicle is really at (108, 80) with
// complexity 3000; everywhere else the region has complexity 300.
typedef struct probe_ctx {
    int32_t x;
    int32_t y;
    int calls;
} probe_ctx_t;

static vd_status_t scene_probe(void *user, const vd_rect_t *box, uint16_t *c)
{
    probe_ctx_t *p = (probe_ctx_t *)user;
    p->calls++;
    int32_t dx = box->x - p->x;
    int32_t dy = box->y - p->y;
    *c = (dx == 0 && dy == 0) ? 3000u : 300u;
    return VD_OK;
}

static void test_missed_frame_recovered(void)
{
    static vd_track_t tracks[4];
    vd_temporal_t t;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tracks, 4));
    vd_temporal_obs_t o[3];
    size_t count;
    uint32_t id = 0u;
    for (int f = 0; f < 3; f++) {
        o[0] = mk_obs(100 + 2 * f, 80, 40, 30, 3000u);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 3, &count, NULL, NULL));
        id = o[0].track_id;
    }
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_CONFIRMED, o[0].state);
    // t = 3: the detector misses the car (now at x = 106).
    probe_ctx_t p = {106, 80, 0};
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 3, &count, scene_probe, &p));
    TEST_ASSERT_EQUAL_size_t(1u, count);
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_RECOVERED, o[0].state);
    TEST_ASSERT_EQUAL_UINT32(id, o[0].track_id);
    TEST_ASSERT_EQUAL_INT32(106, o[0].box.x);   // the search found the car, not the stale box at 104
    TEST_ASSERT_EQUAL_INT32(80, o[0].box.y);
    TEST_ASSERT_EQUAL_INT(25, p.calls);         // radius 4, step 2: 5 x 5 offsets
    TEST_ASSERT_EQUAL_UINT32(1u, vd_temporal_last_stats(&t)->recovered);
    // t = 4: detected again -> still the same confirmed track.
    o[0] = mk_obs(108, 80, 40, 30, 3000u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 3, &count, scene_probe, &p));
    TEST_ASSERT_EQUAL_size_t(1u, count);
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_CONFIRMED, o[0].state);
    TEST_ASSERT_EQUAL_UINT32(id, o[0].track_id);
    // The car leaves: nothing near the box resembles it (S <= 0.3*0.1 + 0.7) -> not recovered.
    p.x = 5000;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 3, &count, scene_probe, &p));
    TEST_ASSERT_EQUAL_size_t(0u, count);
}

static void test_unconfirmed_not_recovered_and_false_alarm_stays_new(void)
{
    static vd_track_t tracks[4];
    vd_temporal_t t;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tracks, 4));
    vd_temporal_obs_t o[2];
    size_t count;
    probe_ctx_t p = {100, 80, 0};
    o[0] = mk_obs(100, 80, 40, 30, 3000u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 2, &count, scene_probe, &p));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 2, &count, scene_probe, &p));
    TEST_ASSERT_EQUAL_size_t(0u, count);
    TEST_ASSERT_EQUAL_INT(0, p.calls);
    // Seen again after a gap: t-1 missing, so hits restart -> NEW, NEW, then CONFIRMED.
    o[0] = mk_obs(100, 80, 40, 30, 3000u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 2, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_NEW, o[0].state);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 2, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_NEW, o[0].state);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 2, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_CONFIRMED, o[0].state);
}

static size_t live_tracks(const vd_track_t *tr, size_t n)
{
    size_t k = 0u;
    for (size_t i = 0; i < n; i++) {
        k += tr[i].id != 0u;
    }
    return k;
}

static void test_track_dies_after_max_misses(void)
{
    static vd_track_t tracks[4];
    vd_temporal_t t;
    vd_temporal_cfg_t cfg;
    memset(&cfg, 0, sizeof(cfg));
    cfg.max_misses = 2;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, &cfg, tracks, 4));
    vd_temporal_obs_t o[1];
    size_t count;
    o[0] = mk_obs(10, 10, 20, 20, 100u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
    uint32_t first = o[0].track_id;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 1, &count, NULL, NULL)); // miss 1
    TEST_ASSERT_EQUAL_size_t(1u, live_tracks(tracks, 4));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 1, &count, NULL, NULL)); // miss 2
    TEST_ASSERT_EQUAL_size_t(1u, live_tracks(tracks, 4));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 1, &count, NULL, NULL)); // miss 3 > 2
    TEST_ASSERT_EQUAL_size_t(0u, live_tracks(tracks, 4));
    TEST_ASSERT_EQUAL_UINT32(1u, t.stats.deleted);
    o[0] = mk_obs(10, 10, 20, 20, 100u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
    TEST_ASSERT_NOT_EQUAL(first, o[0].track_id);
}

static void test_confirmed_track_recovered_at_most_max_misses_times(void)
{
    static vd_track_t tracks[2];
    vd_temporal_t t;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tracks, 2));   // max_misses 3
    vd_temporal_obs_t o[2];
    size_t count;
    for (int f = 0; f < 3; f++) {
        o[0] = mk_obs(100, 80, 40, 30, 3000u);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 2, &count, NULL, NULL));
    }
    probe_ctx_t p = {100, 80, 0};
    for (int f = 0; f < 3; f++) {
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 2, &count, scene_probe, &p));
        TEST_ASSERT_EQUAL_size_t(1u, count);
        TEST_ASSERT_EQUAL_UINT8(VD_TRACK_RECOVERED, o[0].state);
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0, 2, &count, scene_probe, &p));
    TEST_ASSERT_EQUAL_size_t(0u, count);
    TEST_ASSERT_EQUAL_size_t(0u, live_tracks(tracks, 2));
}

static void test_capacity_full(void)
{
    static vd_track_t tracks[2];
    vd_temporal_t t;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tracks, 2));
    vd_temporal_obs_t o[3];
    size_t count;
    o[0] = mk_obs(0, 0, 20, 20, 100u);
    o[1] = mk_obs(200, 0, 20, 20, 100u);
    o[2] = mk_obs(400, 0, 20, 20, 100u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_temporal_update(&t, o, 3, 3, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_size_t(3u, count);
    TEST_ASSERT_NOT_EQUAL(0u, o[0].track_id);
    TEST_ASSERT_NOT_EQUAL(0u, o[1].track_id);
    TEST_ASSERT_EQUAL_UINT32(0u, o[2].track_id);
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_NONE, o[2].state);
    TEST_ASSERT_EQUAL_UINT32(1u, t.stats.overflow);
    // Recovery with no room in the output: dropped and reported.
    static vd_track_t tr1[1];
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tr1, 1));
    for (int f = 0; f < 3; f++) {
        o[0] = mk_obs(100, 80, 40, 30, 3000u);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1, 1, &count, NULL, NULL));
    }
    probe_ctx_t p = {100, 80, 0};
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_temporal_update(&t, o, 0, 0, &count, scene_probe, &p));
    TEST_ASSERT_EQUAL_size_t(0u, count);
    TEST_ASSERT_EQUAL_UINT32(1u, t.stats.overflow);
}

static void test_bad_arguments(void)
{
    static vd_track_t tracks[2];
    vd_temporal_t t;
    vd_temporal_cfg_t cfg;
    size_t count;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_init(NULL, NULL, tracks, 2));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_init(&t, NULL, NULL, 2));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_init(&t, NULL, tracks, 0));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_init(&t, NULL, tracks, 70000));
    vd_temporal_cfg_default(&cfg);
    cfg.sigma_x = 5000;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_init(&t, &cfg, tracks, 2));
    vd_temporal_cfg_default(&cfg);
    cfg.match_thr_q15 = 40000;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_init(&t, &cfg, tracks, 2));
    vd_temporal_cfg_default(&cfg);
    cfg.search_radius = 20;
    cfg.search_step = 1;   // 20 steps > 8
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_init(&t, &cfg, tracks, 2));
    cfg.search_radius = 65;
    cfg.search_step = 64;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_init(&t, &cfg, tracks, 2));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, NULL, tracks, 2));
    vd_temporal_obs_t o[2];
    o[0] = mk_obs(0, 0, 0, 5, 0u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_update(&t, o, 1, 2, &count, NULL, NULL));
    o[0] = mk_obs(0, 0, 5, 5, 0u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_update(&t, o, 2, 1, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_update(&t, NULL, 1, 1, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_update(&t, o, 1, 1, NULL, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, NULL, 0, 0, &count, NULL, NULL));
    TEST_ASSERT_EQUAL_size_t(0u, count);
    // Hostile boxes far outside any frame saturate instead of overflowing.
    vd_rect_t a = {INT32_MAX - 10, INT32_MIN + 10, INT32_MAX, INT32_MAX};
    vd_rect_t b = {0, 0, 1, 1};
    TEST_ASSERT_EQUAL_UINT32(9830u, vd_temporal_similarity_q15(&t, &a, 5u, &b, 5u));
}

static void test_cfg_resolve(void)
{
    vd_temporal_cfg_t z;
    vd_temporal_cfg_t d;
    memset(&z, 0, sizeof(z));
    vd_temporal_cfg_default(&d);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_cfg_resolve(&z));
    TEST_ASSERT_EQUAL_MEMORY(&d, &z, sizeof(z));
    TEST_ASSERT_EQUAL_UINT16(16u, z.sigma_x);
    TEST_ASSERT_EQUAL_UINT16(9830u, z.weight_c_q15);
    TEST_ASSERT_EQUAL_UINT16(26214u, z.recover_thr_q15);
    TEST_ASSERT_EQUAL_UINT8(3u, z.confirm_frames);
    TEST_ASSERT_EQUAL_UINT8(2u, z.search_step);
    TEST_ASSERT_EQUAL_UINT16(384u, z.sigma_rel_q8);
    TEST_ASSERT_EQUAL_UINT16(128u, z.max_motion);
    TEST_ASSERT_EQUAL_UINT8(0u, z.flags);
    // Given fields are kept, the others filled.
    memset(&z, 0, sizeof(z));
    z.sigma_w = 4096u;
    z.search_radius = 16u;
    z.search_step = 2u;   // 16 / 2 = 8 steps: the limit
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_cfg_resolve(&z));
    TEST_ASSERT_EQUAL_UINT16(4096u, z.sigma_w);
    TEST_ASSERT_EQUAL_UINT16(16u, z.sigma_h);
    TEST_ASSERT_EQUAL_UINT8(16u, z.search_radius);
    // The init uses the same resolution: the tracker's copy equals the resolved cfg.
    static vd_track_t tracks[1];
    vd_temporal_t t;
    vd_temporal_cfg_t given;
    memset(&given, 0, sizeof(given));
    given.sigma_w = 4096u;
    given.search_radius = 16u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(&t, &given, tracks, 1));
    TEST_ASSERT_EQUAL_MEMORY(&z, &t.cfg, sizeof(z));
    // Ranges.
    memset(&z, 0, sizeof(z));
    z.search_radius = 18u;   // 9 steps of 2
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    memset(&z, 0, sizeof(z));
    z.sigma_y = 4097u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    memset(&z, 0, sizeof(z));
    z.recover_thr_q15 = 32769u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    memset(&z, 0, sizeof(z));
    z.search_step = 65u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    memset(&z, 0, sizeof(z));
    z.sigma_rel_q8 = 1025u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    memset(&z, 0, sizeof(z));
    z.max_motion = 4097u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    memset(&z, 0, sizeof(z));
    z.flags = 0x20u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    memset(&z, 0, sizeof(z));
    z.reserved2 = 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    // track scores: every Q15 field <= 32768, confirm_lo <= confirm_hi
    memset(&z, 0, sizeof(z));
    z.score_alpha_q15 = 32769u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    memset(&z, 0, sizeof(z));
    z.miss_decay_q15 = 40000u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    memset(&z, 0, sizeof(z));
    z.confirm_hi_q15 = 1000u;
    z.confirm_lo_q15 = 1001u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(&z));
    memset(&z, 0, sizeof(z));
    z.confirm_hi_q15 = 1000u;   // lo left 0: the default 11469 would exceed hi, so lo = hi
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_cfg_resolve(&z));
    TEST_ASSERT_EQUAL_UINT(1000u, z.confirm_lo_q15);
    memset(&z, 0, sizeof(z));
    z.flags = VD_TEMPORAL_SCORES;
    z.coast_frames = 255u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_cfg_resolve(&z));
    TEST_ASSERT_EQUAL_UINT(16384u, z.score_alpha_q15);
    TEST_ASSERT_EQUAL_UINT(13763u, z.confirm_hi_q15);
    TEST_ASSERT_EQUAL_UINT(11469u, z.confirm_lo_q15);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_temporal_cfg_resolve(NULL));
}

// Track-aware scores (VD_TEMPORAL_SCORES), defaults: alpha 0.5, weight 0.5, gain 3277, penalty 3277,
// hi 13763, lo 11469, decay 22938. Hand-worked, in the module's integer arithmetic:
//   s(100) = (100 * 32768 + 127) / 255 = 12850; new: T = (12850 * 29491 + 16384) >> 15 = 11565 < hi: new;
//   out = q8((16384 * 12850 + 16384 >> 15) + (16384 * 11565 + 16384 >> 15)) = q8(6425 + 5783 = 12208)
//       = (12208 * 255 + 16384) >> 15 = 95.
//   frame 2: target 12850 + 3277 = 16127, T = 11565 + (16384 * 4562 + 16384 >> 15 = 2281) = 13846 >= hi:
//   confirmed, out q8(6425 + 6923) = 104; frame 3: T = 13846 + 1141 = 14987, out 108;
//   a miss: T = (14987 * 22938 + 16384) >> 15 = 10491 < lo: no longer confirmed.
static void scores_init(vd_temporal_t *t, vd_track_t *tracks, size_t cap, uint8_t coast)
{
    vd_temporal_cfg_t cfg;
    memset(&cfg, 0, sizeof(cfg));
    cfg.flags = VD_TEMPORAL_SCORES;
    cfg.coast_frames = coast;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_init(t, &cfg, tracks, cap));
}

static void test_track_scores_hand_worked(void)
{
    vd_track_t tracks[4];
    vd_temporal_t t;
    scores_init(&t, tracks, 4u, 0u);
    static const uint8_t out_q8[3] = {95u, 104u, 108u};
    static const uint8_t state[3] = {VD_TRACK_NEW, VD_TRACK_CONFIRMED, VD_TRACK_CONFIRMED};
    static const uint16_t tr_q15[3] = {11565u, 13846u, 14987u};
    for (int f = 0; f < 3; f++) {
        vd_temporal_obs_t o[2];
        o[0] = mk_obs(100, 100, 40, 30, 0u);
        o[0].score_q8 = 100u;
        size_t n = 0u;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1u, 2u, &n, NULL, NULL));
        TEST_ASSERT_EQUAL_size_t(1u, n);
        TEST_ASSERT_EQUAL_UINT32(1u, o[0].track_id);
        TEST_ASSERT_EQUAL_UINT8(out_q8[f], o[0].score_q8);
        TEST_ASSERT_EQUAL_UINT8(state[f], o[0].state);
        TEST_ASSERT_EQUAL_UINT16(tr_q15[f], tracks[0].score_q15);
    }
    // a miss: decayed below confirm_lo, no longer confirmed, nothing output (coast_frames 0)
    vd_temporal_obs_t o[1];
    size_t n = 9u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0u, 1u, &n, NULL, NULL));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    TEST_ASSERT_EQUAL_UINT16(10491u, tracks[0].score_q15);
    TEST_ASSERT_EQUAL_UINT8(0u, tracks[0].confirmed);
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_NEW, tracks[0].state);
}

// A confident track coasts: s(200) = 25700, new T = 23130 (confirmed at once, out 190); matched again
// T = 23130 + (16384 * (28977 - 23130) + 16384 >> 15 = 2924) = 26054, out 201; then misses: T = 18238
// (recovered at the predicted box, score (18238 * 255 + 16384) >> 15 = 142), 12767 (99, still >= lo),
// 8937 < lo: unconfirmed, no box; with coast_frames 2 the third miss would not be output anyway.
static void test_track_scores_coast_decays(void)
{
    vd_track_t tracks[2];
    vd_temporal_t t;
    scores_init(&t, tracks, 2u, 2u);
    vd_temporal_obs_t o[3];
    size_t n = 0u;
    o[0] = mk_obs(200, 100, 40, 30, 0u);
    o[0].score_q8 = 200u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1u, 3u, &n, NULL, NULL));
    TEST_ASSERT_EQUAL_UINT8(VD_TRACK_CONFIRMED, o[0].state);
    TEST_ASSERT_EQUAL_UINT8(190u, o[0].score_q8);
    o[0] = mk_obs(200, 100, 40, 30, 0u);
    o[0].score_q8 = 200u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1u, 3u, &n, NULL, NULL));
    TEST_ASSERT_EQUAL_UINT8(201u, o[0].score_q8);
    static const uint8_t rec_q8[2] = {142u, 99u};
    for (int k = 0; k < 2; k++) {
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0u, 3u, &n, NULL, NULL));
        TEST_ASSERT_EQUAL_size_t(1u, n);
        TEST_ASSERT_EQUAL_UINT8(VD_TRACK_RECOVERED, o[0].state);
        TEST_ASSERT_EQUAL_UINT32(1u, o[0].track_id);
        TEST_ASSERT_EQUAL_UINT8(rec_q8[k], o[0].score_q8);
        TEST_ASSERT_EQUAL_INT32(200, o[0].box.x);   // no motion measured: the prediction is the last box
        TEST_ASSERT_EQUAL_INT32(40, o[0].box.w);
    }
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 0u, 3u, &n, NULL, NULL));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    TEST_ASSERT_EQUAL_UINT16(8937u, tracks[0].score_q15);
    TEST_ASSERT_EQUAL_UINT8(0u, tracks[0].confirmed);
    // a coasting box that does not fit in cap is dropped with VD_ERR_CAPACITY (the track still exists)
    vd_track_t tr2[1];
    scores_init(&t, tr2, 1u, 1u);
    o[0] = mk_obs(10, 10, 20, 20, 0u);
    o[0].score_q8 = 255u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1u, 1u, &n, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_CAPACITY, vd_temporal_update(&t, o, 0u, 0u, &n, NULL, NULL));
    TEST_ASSERT_EQUAL_size_t(0u, n);
    TEST_ASSERT_EQUAL_UINT32(1u, vd_temporal_last_stats(&t)->overflow);
}

// Scores at the extremes stay in range, and without the flag the scores pass through untouched.
static void test_track_scores_extremes_and_off(void)
{
    vd_track_t tracks[3];
    vd_temporal_t t;
    scores_init(&t, tracks, 3u, 255u);
    for (int f = 0; f < 300; f++) {
        vd_temporal_obs_t o[6];
        o[0] = mk_obs(10 + f % 3, 10, 30, 30, 0u);
        o[0].score_q8 = 255u;
        o[1] = mk_obs(300, 200 + f % 5, 30, 30, 0u);
        o[1].score_q8 = 0u;
        size_t n = 0u;
        size_t no = (f % 7 == 3) ? 0u : 2u;   // some frames miss both
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, no, 6u, &n, NULL, NULL));
        for (size_t i = 0; i < n; i++) {
            TEST_ASSERT_TRUE(o[i].state != VD_TRACK_NONE);
        }
        if (no == 2u) {
            TEST_ASSERT_EQUAL_UINT8(VD_TRACK_CONFIRMED, o[0].state);
            TEST_ASSERT_TRUE(o[0].score_q8 >= 229u);   // (1 - 0.5) * 1 + 0.5 * T, T >= 0.9 * 1 after a new start
            TEST_ASSERT_EQUAL_UINT8(VD_TRACK_NEW, o[1].state);
            TEST_ASSERT_TRUE(o[1].score_q8 <= 13u);    // 0.5 * 0 + 0.5 * min(1, 0 + 0.1) at most
        }
        for (size_t k = 0; k < 3u; k++) {
            TEST_ASSERT_TRUE(tracks[k].score_q15 <= 32768u);
        }
    }
    paper_init(&t, tracks, 3u);
    vd_temporal_obs_t o[2];
    o[0] = mk_obs(10, 10, 30, 30, 0u);
    o[0].score_q8 = 77u;
    size_t n = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_temporal_update(&t, o, 1u, 2u, &n, NULL, NULL));
    TEST_ASSERT_EQUAL_UINT8(77u, o[0].score_q8);
    TEST_ASSERT_EQUAL_UINT16(0u, tracks[0].score_q15);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_exp_table_accuracy);
    RUN_TEST(test_track_scores_hand_worked);
    RUN_TEST(test_track_scores_coast_decays);
    RUN_TEST(test_track_scores_extremes_and_off);
    RUN_TEST(test_complexity);
    RUN_TEST(test_similarity_hand_worked);
    RUN_TEST(test_similarity_vs_reference_random);
    RUN_TEST(test_moving_box_confirmed_at_t2);
    RUN_TEST(test_constant_velocity_confirmed_at_frame3);
    RUN_TEST(test_reset_forgets_tracks_keeps_ids);
    RUN_TEST(test_relative_sigma);
    RUN_TEST(test_global_motion_keeps_ids);
    RUN_TEST(test_velocity_prediction_and_bounds);
    RUN_TEST(test_no_complexity_not_recovered);
    RUN_TEST(test_two_targets_keep_their_ids);
    RUN_TEST(test_missed_frame_recovered);
    RUN_TEST(test_unconfirmed_not_recovered_and_false_alarm_stays_new);
    RUN_TEST(test_track_dies_after_max_misses);
    RUN_TEST(test_confirmed_track_recovered_at_most_max_misses_times);
    RUN_TEST(test_capacity_full);
    RUN_TEST(test_bad_arguments);
    RUN_TEST(test_cfg_resolve);
    return UNITY_END();
}
