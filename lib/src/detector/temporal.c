// SPDX-License-Identifier: MIT
// Temporal analysis: a fixed-capacity track table that confirms and recovers detections.
//
// Algorithm (paper 000, "Multistep vehicle detection", section 4): the
// similarity of two targets is S = 0.3*S_C + 0.7*S_S (eq. 9) with the
// complexity similarity S_C = min(C_a, C_b) / max(C_a, C_b) (eq. 11; C =
// edge pixels / pixels, eq. 10) and the spatial similarity
// S_S = exp(-(dx^2/sx^2 + dy^2/sy^2 + dW^2/sW^2 + dH^2/sH^2)) (eq. 12) on box
// centres and sizes. A target is a true positive when it was also matched in
// t-1 and t-2 (confirm_frames = 3 consecutive matches); a confirmed target
// with no match at t is searched for at the best-similarity region around its
// last box, which the caller measures through a probe callback (so this module
// needs no image: the detector's probe refines the region exactly as it
// refines candidates, which keeps the complexities comparable).
//
// Beyond the paper (it assumes a fixed camera and fixed sigmas of 16 px): on
// drone video the camera moves 10-60 px between frames while cars are 15-100
// px, so (a) sigmas grow with the box (sigma_rel_q8) and (b) each detection
// is compared with the track's predicted box: last box + this frame's global
// motion (the displacement most tracks agree on, voted without scratch
// memory among <= 16 tracks x 16 observations) + the track's own velocity
// (Q4 px/frame, first measurement whole, then halfway to each new one).
// Unmatched tracks coast to their prediction, so a missed target is searched
// for, and later re-associated, where it should be. Flags restore the paper.
//
// Fixed point: S, S_C, S_S and C in Q15. The exponent is accumulated in Q16
// from squared differences times reciprocals inv = round(2^32 / sigma^2)
// computed once at init (relative error <= 0.5 / inv <= 2^-9 for sigma <=
// 4096); it saturates at 16.0 where exp() is below 1 LSB. exp(-x) =
// exp(-n) * exp(-f) from two Q30 tables (n integer, f in [0,1) by linear
// interpolation over steps of 1/128: error <= h^2/8 = 7.6e-6, i.e. <= 0.25
// LSB of Q15, plus 0.5 LSB final rounding => |error| <= 1 LSB, tested).
//
// Relative sigmas: term = d^2 * 2^32 / sigma_q8^2 with one 64-bit division
// per term, only when the relative sigma exceeds the fixed one (else the
// reciprocal above, bit-identical to the paper's mode).
//
// Bounds: update is O(T * D * min(T, D)) similarity evaluations for T tracks
// and D observations (greedy best-first association without scratch memory),
// plus 16^4 comparisons for the global motion vote, plus at most 289 probe
// calls per missed confirmed track; no recursion, own stack frame < 300
// bytes (264 on Cortex-M7 -Os), no workspace (the caller owns the tracks).
#include "vd/temporal.h"

#include <string.h>

#include "detector/temporal_internal.h"
#include "internal/vd_internal.h"

#define VD_TEMPORAL_MAX_CAP 65535u
#define VD_TEMPORAL_EXP_MAX_Q16 (16u << 16)
#define VD_TEMPORAL_MAX_SEARCH_STEPS 8u
#define VD_TEMPORAL_FLAGS_ALL \
    (VD_TEMPORAL_FIXED_SIGMA | VD_TEMPORAL_NO_MOTION | VD_TEMPORAL_NO_GLOBAL | VD_TEMPORAL_RECOVER_NO_C | \
     VD_TEMPORAL_SCORES)
#define VD_TEMPORAL_MAX_SIDE (1 << 20)   // mean box side clamp: rel * side stays < 2^31 in Q8

// round(2^30 * exp(-k / 128)), k = 0..128. Values computed by
// tools/vdtools/bindings/detector.py:exp_tables() (math.exp, round half even);
// test_temporal.c re-checks every entry against exp().
static const uint32_t k_exp_frac_q30[129] = {
    1073741824u, 1065385899u, 1057095000u, 1048868621u, 1040706261u, 1032607421u,
    1024571606u, 1016598326u, 1008687096u, 1000837430u, 993048852u, 985320884u,
    977653056u, 970044900u, 962495950u, 955005748u, 947573834u, 940199756u,
    932883063u, 925623310u, 918420052u, 911272850u, 904181269u, 897144874u,
    890163238u, 883235932u, 876362536u, 869542628u, 862775794u, 856061619u,
    849399695u, 842789614u, 836230973u, 829723372u, 823266414u, 816859704u,
    810502851u, 804195468u, 797937169u, 791727573u, 785566300u, 779452974u,
    773387223u, 767368676u, 761396966u, 755471728u, 749592600u, 743759224u,
    737971244u, 732228306u, 726530060u, 720876158u, 715266256u, 709700009u,
    704177080u, 698697131u, 693259826u, 687864836u, 682511829u, 677200480u,
    671930464u, 666701460u, 661513148u, 656365211u, 651257337u, 646189212u,
    641160528u, 636170977u, 631220255u, 626308060u, 621434092u, 616598054u,
    611799650u, 607038587u, 602314575u, 597627326u, 592976553u, 588361973u,
    583783304u, 579240266u, 574732583u, 570259978u, 565822180u, 561418917u,
    557049920u, 552714923u, 548413661u, 544145872u, 539911296u, 535709673u,
    531540747u, 527404264u, 523299971u, 519227619u, 515186957u, 511177741u,
    507199724u, 503252664u, 499336321u, 495450455u, 491594829u, 487769208u,
    483973358u, 480207047u, 476470046u, 472762127u, 469083063u, 465432629u,
    461810604u, 458216765u, 454650894u, 451112773u, 447602185u, 444118918u,
    440662757u, 437233492u, 433830914u, 430454815u, 427104989u, 423781232u,
    420483340u, 417211113u, 413964350u, 410742854u, 407546428u, 404374876u,
    401228006u, 398105625u, 395007542u,
};

// round(2^30 * exp(-n)), n = 0..16 (same generator).
static const uint32_t k_exp_int_q30[17] = {
    1073741824u, 395007542u, 145315154u, 53458458u, 19666268u, 7234816u,
    2661540u, 979126u, 360200u, 132510u, 48748u, 17933u,
    6597u, 2427u, 893u, 328u, 121u,
};

uint32_t vd_temporal_exp_neg_q15(uint32_t x_q16)
{
    if (x_q16 >= VD_TEMPORAL_EXP_MAX_Q16) {
        return 0u;
    }
    uint32_t n = x_q16 >> 16;
    uint32_t f = x_q16 & 0xFFFFu;
    uint32_t k = f >> 9;        // table step 1/128 = 512 in Q16
    uint32_t r = f & 511u;      // position inside the step, Q9
    uint64_t drop = (uint64_t)(k_exp_frac_q30[k] - k_exp_frac_q30[k + 1u]) * r;
    uint64_t v_q30 = (uint64_t)k_exp_frac_q30[k] - ((drop + 256u) >> 9);
    uint64_t p_q60 = v_q30 * k_exp_int_q30[n];
    return (uint32_t)((p_q60 + ((uint64_t)1 << 44)) >> 45);
}

uint16_t vd_temporal_complexity_q15(uint32_t edge_pixels, uint32_t pixels)
{
    if (pixels == 0u) {
        return 0u;
    }
    if (edge_pixels >= pixels) {
        return 32768u;
    }
    // One division per detection (not per pixel): no reciprocal needed.
    return (uint16_t)((((uint64_t)edge_pixels << 15) + (pixels >> 1)) / pixels);
}

void vd_temporal_cfg_default(vd_temporal_cfg_t *cfg)
{
    if (cfg == NULL) {
        return;
    }
    cfg->sigma_x = 16u;
    cfg->sigma_y = 16u;
    cfg->sigma_w = 16u;
    cfg->sigma_h = 16u;
    cfg->weight_c_q15 = 9830u;   // 0.3 * 32768 = 9830.4
    cfg->match_thr_q15 = 16384u;
    cfg->recover_thr_q15 = 26214u;
    cfg->confirm_frames = 3u;
    cfg->max_misses = 3u;
    cfg->search_radius = 4u;
    cfg->search_step = 2u;
    cfg->sigma_rel_q8 = 384u;   // 1.5: fewest id switches on the HIT-UAV flight (vdtools.evaluation.temporal_eval)
    cfg->max_motion = 128u;
    cfg->flags = 0u;
    cfg->coast_frames = 0u;
    // Track scores: chosen on the train/val sequences of HIT-UAV (docs/results/temporal.md).
    cfg->score_alpha_q15 = 16384u;   // 0.5
    cfg->score_weight_q15 = 16384u;  // 0.5
    cfg->score_gain_q15 = 3277u;     // 0.1
    cfg->new_penalty_q15 = 3277u;    // 0.1
    cfg->confirm_hi_q15 = 13763u;    // 0.42
    cfg->confirm_lo_q15 = 11469u;    // 0.35
    cfg->miss_decay_q15 = 22938u;    // 0.7
    cfg->reserved2 = 0u;
}

static uint64_t inv_square_q32(uint32_t s)
{
    uint64_t s2 = (uint64_t)s * s;
    return (((uint64_t)1 << 32) + (s2 >> 1)) / s2;
}

vd_status_t vd_temporal_cfg_resolve(vd_temporal_cfg_t *c)
{
    VD_VERIFY(c != NULL, VD_ERR_ARG);
    vd_temporal_cfg_t d;
    vd_temporal_cfg_default(&d);
    if (c->sigma_x == 0u) { c->sigma_x = d.sigma_x; }
    if (c->sigma_y == 0u) { c->sigma_y = d.sigma_y; }
    if (c->sigma_w == 0u) { c->sigma_w = d.sigma_w; }
    if (c->sigma_h == 0u) { c->sigma_h = d.sigma_h; }
    if (c->weight_c_q15 == 0u) { c->weight_c_q15 = d.weight_c_q15; }
    if (c->match_thr_q15 == 0u) { c->match_thr_q15 = d.match_thr_q15; }
    if (c->recover_thr_q15 == 0u) { c->recover_thr_q15 = d.recover_thr_q15; }
    if (c->confirm_frames == 0u) { c->confirm_frames = d.confirm_frames; }
    if (c->max_misses == 0u) { c->max_misses = d.max_misses; }
    if (c->search_radius == 0u) { c->search_radius = d.search_radius; }
    if (c->search_step == 0u) { c->search_step = d.search_step; }
    if (c->sigma_rel_q8 == 0u) { c->sigma_rel_q8 = d.sigma_rel_q8; }
    if (c->max_motion == 0u) { c->max_motion = d.max_motion; }
    if (c->score_alpha_q15 == 0u) { c->score_alpha_q15 = d.score_alpha_q15; }
    if (c->score_weight_q15 == 0u) { c->score_weight_q15 = d.score_weight_q15; }
    if (c->score_gain_q15 == 0u) { c->score_gain_q15 = d.score_gain_q15; }
    if (c->new_penalty_q15 == 0u) { c->new_penalty_q15 = d.new_penalty_q15; }
    if (c->confirm_hi_q15 == 0u) { c->confirm_hi_q15 = d.confirm_hi_q15; }
    if (c->confirm_lo_q15 == 0u) { c->confirm_lo_q15 = (d.confirm_lo_q15 <= c->confirm_hi_q15) ? d.confirm_lo_q15 : c->confirm_hi_q15; }
    if (c->miss_decay_q15 == 0u) { c->miss_decay_q15 = d.miss_decay_q15; }
    VD_VERIFY(c->sigma_x <= 4096u && c->sigma_y <= 4096u && c->sigma_w <= 4096u && c->sigma_h <= 4096u, VD_ERR_ARG);
    VD_VERIFY(c->weight_c_q15 <= 32768u && c->match_thr_q15 <= 32768u && c->recover_thr_q15 <= 32768u, VD_ERR_ARG);
    VD_VERIFY(c->search_radius <= 64u && c->search_step <= 64u, VD_ERR_ARG);
    VD_VERIFY(c->search_radius / c->search_step <= VD_TEMPORAL_MAX_SEARCH_STEPS, VD_ERR_ARG);
    VD_VERIFY(c->sigma_rel_q8 <= 1024u && c->max_motion <= 4096u, VD_ERR_ARG);
    VD_VERIFY((c->flags & ~VD_TEMPORAL_FLAGS_ALL) == 0u && c->reserved2 == 0u, VD_ERR_ARG);
    VD_VERIFY(c->score_alpha_q15 <= 32768u && c->score_weight_q15 <= 32768u && c->score_gain_q15 <= 32768u &&
                  c->new_penalty_q15 <= 32768u && c->confirm_hi_q15 <= 32768u && c->miss_decay_q15 <= 32768u,
              VD_ERR_ARG);
    VD_VERIFY(c->confirm_lo_q15 <= c->confirm_hi_q15, VD_ERR_ARG);
    return VD_OK;
}

vd_status_t vd_temporal_init(vd_temporal_t *t, const vd_temporal_cfg_t *cfg, vd_track_t *tracks, size_t cap)
{
    VD_VERIFY(t != NULL && tracks != NULL, VD_ERR_ARG);
    VD_VERIFY(cap >= 1u && cap <= VD_TEMPORAL_MAX_CAP, VD_ERR_ARG);
    vd_temporal_cfg_t c;
    if (cfg == NULL) {
        memset(&c, 0, sizeof(c));
    } else {
        c = *cfg;
    }
    VD_TRY(vd_temporal_cfg_resolve(&c));

    memset(t, 0, sizeof(*t));
    t->cfg = c;
    t->tracks = tracks;
    t->cap = cap;
    t->next_id = 1u;
    t->inv_sx2_q32 = inv_square_q32(c.sigma_x);
    t->inv_sy2_q32 = inv_square_q32(c.sigma_y);
    t->inv_sw2_q32 = inv_square_q32(c.sigma_w);
    t->inv_sh2_q32 = inv_square_q32(c.sigma_h);
    memset(tracks, 0, cap * sizeof(*tracks));
    return VD_OK;
}

void vd_temporal_reset(vd_temporal_t *t)
{
    if (t == NULL || t->tracks == NULL) {
        return;
    }
    memset(t->tracks, 0, t->cap * sizeof(*t->tracks));
    memset(&t->stats, 0, sizeof(t->stats));
}

const vd_temporal_stats_t *vd_temporal_last_stats(const vd_temporal_t *t)
{
    return (t == NULL) ? NULL : &t->stats;
}

// d^2 * inv_q32 >> shift, with |d| clamped so the product fits 64 bits
// (|d| < 2^15 => d^2 < 2^30, inv <= 2^32); the clamp only happens where the
// term is already >= 16 for every sigma <= 4096 (saturated anyway).
static uint32_t exp_term_q16(int64_t d, uint64_t inv_q32, unsigned shift)
{
    uint64_t a = (uint64_t)(d < 0 ? -d : d);
    if (a > 32767u) {
        a = 32767u;
    }
    uint64_t v = (a * a * inv_q32) >> shift;
    return (v > VD_TEMPORAL_EXP_MAX_Q16) ? VD_TEMPORAL_EXP_MAX_Q16 : (uint32_t)v;
}

// Term d^2 / s^2 in Q16 for a relative sigma s_q8 (Q8 px); d in units of
// 2^-(half) px: half = 1 for doubled centre coordinates. |d| < 2^15, so
// d^2 << (32 - 2 half) < 2^62; s_q8 < 2^31 so s_q8^2 < 2^62. Larger |d|
// (>= 16 k px: outside any frame) saturates, however large the boxes.
static uint32_t rel_term_q16(int64_t d, uint64_t s_q8, unsigned half)
{
    uint64_t a = (uint64_t)(d < 0 ? -d : d);
    if (a > 32767u) {
        return VD_TEMPORAL_EXP_MAX_Q16;
    }
    uint64_t s2 = s_q8 * s_q8;
    uint64_t v = ((a * a << (32u - 2u * half)) + (s2 >> 1)) / s2;
    return (v > VD_TEMPORAL_EXP_MAX_Q16) ? VD_TEMPORAL_EXP_MAX_Q16 : (uint32_t)v;
}

// One axis: the fixed sigma's reciprocal unless rel * mean side is larger.
static uint32_t axis_term_q16(const vd_temporal_t *t, int64_t d, uint64_t inv_q32, uint32_t sigma,
                              int64_t side_sum, unsigned half)
{
    if ((t->cfg.flags & VD_TEMPORAL_FIXED_SIGMA) == 0u) {
        int64_t side2 = side_sum < 0 ? 0 : side_sum;   // (w_a + w_b): twice the mean side
        if (side2 > 2 * (int64_t)VD_TEMPORAL_MAX_SIDE) {
            side2 = 2 * (int64_t)VD_TEMPORAL_MAX_SIDE;
        }
        uint64_t rel_q8 = ((uint64_t)t->cfg.sigma_rel_q8 * (uint64_t)side2) >> 1;
        if (rel_q8 > ((uint64_t)sigma << 8)) {
            return rel_term_q16(d, rel_q8, half);
        }
    }
    return exp_term_q16(d, inv_q32, half ? 18u : 16u);
}

uint32_t vd_temporal_similarity_q15(const vd_temporal_t *t, const vd_rect_t *a, uint16_t ca_q15,
                                    const vd_rect_t *b, uint16_t cb_q15)
{
    if (t == NULL || a == NULL || b == NULL) {
        return 0u;
    }
    // Centres in doubled coordinates (2x + w) keep halves exact: the squared
    // difference is 4 dx^2, hence the extra shift by 2.
    int64_t dcx2 = ((int64_t)2 * a->x + a->w) - ((int64_t)2 * b->x + b->w);
    int64_t dcy2 = ((int64_t)2 * a->y + a->h) - ((int64_t)2 * b->y + b->h);
    int64_t dw = (int64_t)a->w - b->w;
    int64_t dh = (int64_t)a->h - b->h;
    int64_t sw = (int64_t)a->w + b->w;
    int64_t sh = (int64_t)a->h + b->h;
    const vd_temporal_cfg_t *c = &t->cfg;
    uint32_t x_q16 = axis_term_q16(t, dcx2, t->inv_sx2_q32, c->sigma_x, sw, 1u);
    x_q16 += axis_term_q16(t, dcy2, t->inv_sy2_q32, c->sigma_y, sh, 1u);
    x_q16 += axis_term_q16(t, dw, t->inv_sw2_q32, c->sigma_w, sw, 0u);
    x_q16 += axis_term_q16(t, dh, t->inv_sh2_q32, c->sigma_h, sh, 0u);   // each <= 2^20: no wrap
    uint32_t ss_q15 = vd_temporal_exp_neg_q15(x_q16);

    uint32_t lo = ca_q15 < cb_q15 ? ca_q15 : cb_q15;
    uint32_t hi = ca_q15 < cb_q15 ? cb_q15 : ca_q15;
    uint32_t sc_q15;
    if (hi == 0u) {
        sc_q15 = 32768u;            // two edge-free / unmeasured (CNN) regions: no evidence against
    } else {
        sc_q15 = (uint32_t)((((uint64_t)lo << 15) + (hi >> 1)) / hi);
    }
    uint32_t wc = t->cfg.weight_c_q15;
    uint64_t s = (uint64_t)wc * sc_q15 + (uint64_t)(32768u - wc) * ss_q15;
    return (uint32_t)((s + 16384u) >> 15);
}

// a / b rounded half away from zero (b > 0); C99 division truncates toward 0.
static int64_t div_round(int64_t a, int64_t b)
{
    return (a >= 0) ? (a + b / 2) / b : -((-a + b / 2) / b);
}

static int32_t sat_i32(int64_t v)
{
    return (v > INT32_MAX) ? INT32_MAX : (v < INT32_MIN) ? INT32_MIN : (int32_t)v;
}

static int16_t clamp_v_q4(int64_t v, int64_t lim)
{
    if (lim > 32767) {
        lim = 32767;
    }
    return (int16_t)(v > lim ? lim : (v < -lim ? -lim : v));
}

// Offset of a track's prediction in Q4 px: global motion + own velocity.
static int64_t pred_dx_q4(const vd_temporal_t *t, const vd_track_t *tr)
{
    return (int64_t)t->gx2 * 8 + tr->vx_q4;
}

static int64_t pred_dy_q4(const vd_temporal_t *t, const vd_track_t *tr)
{
    return (int64_t)t->gy2 * 8 + tr->vy_q4;
}

static vd_rect_t shifted(const vd_rect_t *b, int64_t dx_q4, int64_t dy_q4)
{
    vd_rect_t r = *b;
    r.x = sat_i32((int64_t)r.x + div_round(dx_q4, 16));
    r.y = sat_i32((int64_t)r.y + div_round(dy_q4, 16));
    return r;
}

static vd_rect_t predicted(const vd_temporal_t *t, const vd_track_t *tr)
{
    return shifted(&tr->box, pred_dx_q4(t, tr), pred_dy_q4(t, tr));
}

// Sizes within a factor 2 of each other: the same object at about the same range.
static bool size_compatible(const vd_rect_t *a, const vd_rect_t *b)
{
    return (int64_t)2 * a->w >= b->w && (int64_t)2 * b->w >= a->w && (int64_t)2 * a->h >= b->h &&
           (int64_t)2 * b->h >= a->h;
}

// Doubled-coordinate displacement from a track (moved by its own velocity) to an observation.
static void displacement2(const vd_track_t *tr, const vd_rect_t *o, int64_t *dx2, int64_t *dy2)
{
    *dx2 = ((int64_t)2 * o->x + o->w) - ((int64_t)2 * tr->box.x + tr->box.w) - div_round(tr->vx_q4, 8);
    *dy2 = ((int64_t)2 * o->y + o->h) - ((int64_t)2 * tr->box.y + tr->box.h) - div_round(tr->vy_q4, 8);
}

static int64_t abs64(int64_t v)
{
    return v < 0 ? -v : v;
}

// Best agreeing observation of voter tr for displacement (dx2, dy2): within
// half the track's box on each axis; returns the L1 distance or -1.
static int64_t agrees(const vd_temporal_t *t, const vd_track_t *tr, const vd_temporal_obs_t *obs, size_t no,
                      int64_t dx2, int64_t dy2, int64_t *bx2, int64_t *by2)
{
    int64_t best = -1;
    int64_t lim = (int64_t)2 * t->cfg.max_motion;
    for (size_t i = 0; i < no; i++) {
        if (!size_compatible(&tr->box, &obs[i].box)) {
            continue;
        }
        int64_t ex;
        int64_t ey;
        displacement2(tr, &obs[i].box, &ex, &ey);
        if (abs64(ex) > lim || abs64(ey) > lim) {
            continue;
        }
        int64_t ax = abs64(ex - dx2);
        int64_t ay = abs64(ey - dy2);
        if (ax <= tr->box.w && ay <= tr->box.h && (best < 0 || ax + ay < best)) {
            best = ax + ay;
            *bx2 = ex;
            *by2 = ey;
        }
    }
    return best;
}

// (0) Global motion (doubled px) into t->gx2/gy2: each (voter, observation)
// pair proposes its displacement; the one most voters agree with wins (ties:
// the smaller one), then the mean of the agreeing displacements. Voters:
// the first 16 tracks matched in the previous frame; the first 16
// observations (the detector's best). Fewer than 2 votes: no global motion.
static void estimate_motion(vd_temporal_t *t, const vd_temporal_obs_t *obs, size_t n)
{
    uint16_t v[VD_TEMPORAL_MOTION_VOTERS];
    size_t nv = 0u;
    t->gx2 = 0;
    t->gy2 = 0;
    if ((t->cfg.flags & (VD_TEMPORAL_NO_MOTION | VD_TEMPORAL_NO_GLOBAL)) != 0u) {
        return;
    }
    for (size_t k = 0; k < t->cap && nv < VD_TEMPORAL_MOTION_VOTERS; k++) {
        if (t->tracks[k].id != 0u && t->tracks[k].misses == 0u) {
            v[nv++] = (uint16_t)k;
        }
    }
    size_t no = n < VD_TEMPORAL_MOTION_VOTERS ? n : VD_TEMPORAL_MOTION_VOTERS;
    uint32_t best_votes = 0u;
    int64_t bdx = 0;
    int64_t bdy = 0;
    int64_t lim = (int64_t)2 * t->cfg.max_motion;
    for (size_t a = 0; a < nv; a++) {
        const vd_track_t *ta = &t->tracks[v[a]];
        for (size_t i = 0; i < no; i++) {
            if (!size_compatible(&ta->box, &obs[i].box)) {
                continue;
            }
            int64_t dx2;
            int64_t dy2;
            displacement2(ta, &obs[i].box, &dx2, &dy2);
            if (abs64(dx2) > lim || abs64(dy2) > lim) {
                continue;
            }
            uint32_t votes = 0u;
            for (size_t b = 0; b < nv; b++) {
                int64_t ux;
                int64_t uy;
                votes += agrees(t, &t->tracks[v[b]], obs, no, dx2, dy2, &ux, &uy) >= 0;
            }
            if (votes > best_votes ||
                (votes == best_votes && abs64(dx2) + abs64(dy2) < abs64(bdx) + abs64(bdy))) {
                best_votes = votes;
                bdx = dx2;
                bdy = dy2;
            }
        }
    }
    if (best_votes < 2u) {
        return;
    }
    int64_t sx = 0;
    int64_t sy = 0;
    int64_t cnt = 0;
    for (size_t b = 0; b < nv; b++) {
        int64_t ux = 0;
        int64_t uy = 0;
        if (agrees(t, &t->tracks[v[b]], obs, no, bdx, bdy, &ux, &uy) >= 0) {
            sx += ux;
            sy += uy;
            cnt++;
        }
    }
    t->gx2 = (int32_t)div_round(sx, cnt);   // |mean| <= 2 * max_motion + box: fits
    t->gy2 = (int32_t)div_round(sy, cnt);
    t->stats.motion_votes = (uint32_t)cnt;
    t->stats.motion_x = (int32_t)div_round(t->gx2, 2);
    t->stats.motion_y = (int32_t)div_round(t->gy2, 2);
}

// Velocity after a match: the prediction error spread over the frames since
// the last match; the first measurement is taken whole (no estimate yet),
// later ones halfway (smooths detector jitter of a few px).
static void update_velocity(const vd_temporal_t *t, vd_track_t *tr, const vd_rect_t *o)
{
    if ((t->cfg.flags & VD_TEMPORAL_NO_MOTION) != 0u) {
        return;
    }
    int64_t px = ((int64_t)2 * tr->box.x + tr->box.w) * 8 + pred_dx_q4(t, tr);
    int64_t py = ((int64_t)2 * tr->box.y + tr->box.h) * 8 + pred_dy_q4(t, tr);
    int64_t ex = ((int64_t)2 * o->x + o->w) * 8 - px;
    int64_t ey = ((int64_t)2 * o->y + o->h) * 8 - py;
    int64_t frames = (int64_t)tr->misses + 1;
    int64_t div = tr->moving ? 2 * frames : frames;
    int64_t lim = (int64_t)t->cfg.max_motion * 16;
    tr->vx_q4 = clamp_v_q4(tr->vx_q4 + div_round(ex, div), lim);
    tr->vy_q4 = clamp_v_q4(tr->vy_q4 + div_round(ey, div), lim);
    tr->moving = 1u;
}

static void track_clear(vd_track_t *tr)
{
    memset(tr, 0, sizeof(*tr));
}

static uint8_t sat_inc_u8(uint8_t v)
{
    return (uint8_t)(v < 255u ? v + 1u : 255u);
}

// Track-aware scores (VD_TEMPORAL_SCORES): temporal_score.c.
static bool scores_on(const vd_temporal_t *t)
{
    return (t->cfg.flags & VD_TEMPORAL_SCORES) != 0u;
}

// Best-similarity region around a missed confirmed track (its box has
// already coasted to the prediction); true if one reaches recover_thr
// (box/complexity/similarity returned).
static bool recover_search(vd_temporal_t *t, const vd_track_t *tr, vd_temporal_probe_fn probe, void *user,
                           vd_rect_t *best_box, uint16_t *best_c, uint32_t *best_s)
{
    int32_t r = (int32_t)t->cfg.search_radius;
    int32_t step = (int32_t)t->cfg.search_step;
    int32_t nsteps = r / step;  // <= 8 by init
    bool found = false;
    *best_s = 0u;
    for (int32_t iy = -nsteps; iy <= nsteps; iy++) {
        for (int32_t ix = -nsteps; ix <= nsteps; ix++) {
            vd_rect_t cand = tr->box;
            cand.x += ix * step;
            cand.y += iy * step;
            uint16_t c = 0u;
            t->stats.probes++;
            if (probe(user, &cand, &c) != VD_OK) {
                continue;
            }
            uint32_t s = vd_temporal_similarity_q15(t, &tr->box, tr->complexity_q15, &cand, c);
            // Strictly greater: on ties the earlier (raster order of offsets) wins.
            if (s >= t->cfg.recover_thr_q15 && (!found || s > *best_s)) {
                found = true;
                *best_s = s;
                *best_box = cand;
                *best_c = c;
            }
        }
    }
    return found;
}

// (1)+(2) of vd_temporal_update: greedy association, best pair first; a
// matched track takes its observation.
static void associate(vd_temporal_t *t, vd_temporal_obs_t *obs, size_t n)
{
    vd_track_t *tracks = t->tracks;
    // (1) Greedy association, best pair first. Each round fixes one pair, so
    // at most min(tracks, n) rounds.
    size_t rounds = (n < t->cap) ? n : t->cap;
    for (size_t round = 0; round < rounds; round++) {
        uint32_t best = 0u;
        size_t bi = 0u;
        size_t bk = 0u;
        bool any = false;
        for (size_t k = 0; k < t->cap; k++) {
            const vd_track_t *tr = &tracks[k];
            if (tr->id == 0u || tr->matched) {
                continue;
            }
            vd_rect_t pb = predicted(t, tr);
            for (size_t i = 0; i < n; i++) {
                if (obs[i].track_id != 0u) {
                    continue;
                }
                uint32_t s = vd_temporal_similarity_q15(t, &pb, tr->complexity_q15, &obs[i].box,
                                                        obs[i].complexity_q15);
                if (s >= t->cfg.match_thr_q15 && (!any || s > best)) {
                    any = true;
                    best = s;
                    bi = i;
                    bk = k;
                }
            }
        }
        if (!any) {
            break;
        }
        // (2) The matched track takes the new observation.
        vd_track_t *tr = &tracks[bk];
        tr->matched = 1u;
        update_velocity(t, tr, &obs[bi].box);
        tr->box = obs[bi].box;
        tr->complexity_q15 = obs[bi].complexity_q15;
        tr->similarity_q15 = (uint16_t)best;
        tr->hits = sat_inc_u8(tr->hits);
        tr->misses = 0u;
        if (scores_on(t)) {
            obs[bi].score_q8 = vd__temporal_score_match(&t->cfg, tr, obs[bi].score_q8);
        } else if (tr->hits >= t->cfg.confirm_frames) {
            tr->confirmed = 1u;
        }
        tr->state = tr->confirmed ? (uint8_t)VD_TRACK_CONFIRMED : (uint8_t)VD_TRACK_NEW;
        obs[bi].track_id = tr->id;
        obs[bi].state = tr->state;
        obs[bi].similarity_q15 = (uint16_t)best;
        t->stats.matched++;
    }
}

// (3)+(4): unmatched tracks miss, are deleted, or are recovered by a probe
// search; a recovered track appends an observation at *out (< cap, else
// VD_ERR_CAPACITY and the recovery is dropped).
static vd_status_t unmatched_tracks(vd_temporal_t *t, vd_temporal_obs_t *obs, size_t cap, size_t *out_n,
                                    vd_temporal_probe_fn probe, void *user)
{
    vd_status_t st = VD_OK;
    vd_track_t *tracks = t->tracks;
    size_t out = *out_n;
    for (size_t k = 0; k < t->cap; k++) {
        vd_track_t *tr = &tracks[k];
        if (tr->id == 0u) {
            continue;
        }
        if (tr->age < UINT32_MAX) {
            tr->age++;
        }
        if (tr->matched) {
            continue;
        }
        tr->misses = sat_inc_u8(tr->misses);
        tr->box = predicted(t, tr);   // coast: where it should be now
        if (!tr->confirmed) {
            tr->hits = 0u;     // confirmation needs consecutive frames
        }
        if (tr->misses > t->cfg.max_misses) {
            track_clear(tr);
            t->stats.deleted++;
            continue;
        }
        if (scores_on(t)) {
            vd__temporal_score_miss(&t->cfg, tr);   // decays; below confirm_lo no longer confirmed
        }
        tr->state = tr->confirmed ? (uint8_t)VD_TRACK_CONFIRMED : (uint8_t)VD_TRACK_NEW;
        if (!tr->confirmed) {
            continue;
        }
        vd_rect_t box = tr->box;
        uint16_t c = tr->complexity_q15;
        uint32_t s = 0u;
        bool searchable = probe != NULL &&
                          (tr->complexity_q15 != 0u || (t->cfg.flags & VD_TEMPORAL_RECOVER_NO_C) != 0u);
        // no complexity (CNN): S_C = 1 only on an edge-free probe, i.e. background: no search
        bool found = searchable && recover_search(t, tr, probe, user, &box, &c, &s);
        if (!found && !(scores_on(t) && tr->misses <= t->cfg.coast_frames)) {
            continue;
        }
        if (!found) {
            box = tr->box;   // coasting: the predicted box, as last measured
            c = tr->complexity_q15;
            s = 0u;
        }
        if (out >= cap) {
            t->stats.overflow++;
            st = VD_ERR_CAPACITY;
            continue;
        }
        tr->box = box;
        tr->complexity_q15 = c;
        tr->similarity_q15 = (uint16_t)s;
        tr->state = VD_TRACK_RECOVERED;
        memset(&obs[out], 0, sizeof(obs[out]));
        obs[out].box = box;
        obs[out].complexity_q15 = c;
        obs[out].similarity_q15 = (uint16_t)s;
        obs[out].track_id = tr->id;
        obs[out].state = VD_TRACK_RECOVERED;
        obs[out].score_q8 = scores_on(t) ? vd__temporal_score_q8(tr->score_q15) : 0u;
        out++;
        t->stats.recovered++;
    }
    *out_n = out;
    return st;
}

// (5): new tracks for the unmatched observations, in observation order
// (VD_ERR_CAPACITY for those without a free slot).
static vd_status_t new_tracks(vd_temporal_t *t, vd_temporal_obs_t *obs, size_t n)
{
    vd_status_t st = VD_OK;
    vd_track_t *tracks = t->tracks;
    size_t slot = 0u;
    for (size_t i = 0; i < n; i++) {
        if (obs[i].track_id != 0u) {
            continue;
        }
        while (slot < t->cap && tracks[slot].id != 0u) {
            slot++;
        }
        if (slot >= t->cap) {
            obs[i].state = VD_TRACK_NONE;
            t->stats.overflow++;
            st = VD_ERR_CAPACITY;
            continue;
        }
        vd_track_t *tr = &tracks[slot];
        track_clear(tr);
        tr->id = t->next_id;
        t->next_id = (t->next_id == UINT32_MAX) ? 1u : t->next_id + 1u;
        tr->box = obs[i].box;
        tr->complexity_q15 = obs[i].complexity_q15;
        tr->hits = 1u;
        tr->matched = 1u;
        if (scores_on(t)) {
            obs[i].score_q8 = vd__temporal_score_new(&t->cfg, tr, obs[i].score_q8);
        } else if (tr->hits >= t->cfg.confirm_frames) {
            tr->confirmed = 1u;
        }
        tr->state = tr->confirmed ? (uint8_t)VD_TRACK_CONFIRMED : (uint8_t)VD_TRACK_NEW;
        obs[i].track_id = tr->id;
        obs[i].state = tr->state;
        t->stats.created++;
    }
    return st;
}

vd_status_t vd_temporal_update(vd_temporal_t *t, vd_temporal_obs_t *obs, size_t n, size_t cap, size_t *count,
                               vd_temporal_probe_fn probe, void *user)
{
    VD_VERIFY(t != NULL && t->tracks != NULL && count != NULL, VD_ERR_ARG);
    VD_VERIFY(n == 0u || obs != NULL, VD_ERR_ARG);
    VD_VERIFY(n <= cap, VD_ERR_ARG);
    *count = 0u;
    for (size_t i = 0; i < n; i++) {
        VD_VERIFY(obs[i].box.w > 0 && obs[i].box.h > 0, VD_ERR_ARG);
    }
    vd_track_t *tracks = t->tracks;
    memset(&t->stats, 0, sizeof(t->stats));
    for (size_t i = 0; i < n; i++) {
        obs[i].track_id = 0u;
        obs[i].state = VD_TRACK_NONE;
        obs[i].similarity_q15 = 0u;
    }
    for (size_t k = 0; k < t->cap; k++) {
        tracks[k].matched = 0u;
    }

    estimate_motion(t, obs, n);
    associate(t, obs, n);
    size_t out = n;
    const vd_status_t st_rec = unmatched_tracks(t, obs, cap, &out, probe, user);
    const vd_status_t st_new = new_tracks(t, obs, n);
    const vd_status_t st = (st_rec != VD_OK) ? st_rec : st_new;
    for (size_t i = 0; i < out; i++) {
        if (obs[i].state == VD_TRACK_CONFIRMED) {
            t->stats.confirmed++;
        }
    }
    *count = out;
    return st;
}
