// SPDX-License-Identifier: MIT
// Track-aware scores of the temporal analysis (VD_TEMPORAL_SCORES, temporal.h): a track score T per track,
// fused into each output box's score, and confirmation by T with hysteresis.
//
// Model (paper 000 confirms a target seen in t, t-1 and t-2; on short drone sequences with 10-200 px of
// camera motion between frames that loses most vehicles, docs/results/temporal.md): T is an exponentially
// weighted average of the track's scores, pulled up by a persistence gain on every match, discounted on a
// new track and decayed on every miss; the output score is (1 - w) s + w T. Confirmed at T >= confirm_hi,
// unconfirmed below confirm_lo.
//
// Fixed point: scores Q15 of 1.0 (<= 32768) in uint32; a product of two is <= 2^30, rounded half up
// (+16384 >> 15); Q8 -> Q15 is (s * 32768 + 127) / 255 (a constant divisor, once per observation). Bounds:
// O(1) per observation or track, no loops, a few words of stack.
#include <stdbool.h>

#include "detector/temporal_internal.h"

// All Q15 of 1.0 in uint32 (<= 32768); products of two
// Q15 values < 2^31, rounded half up by +16384 >> 15; no division but q8 -> q15 (a constant 255).

// Q8 score (0..255, 255 = 1.0) -> Q15 (0..32768), rounded.
static uint32_t q15_of_q8(uint8_t s)
{
    return ((uint32_t)s * 32768u + 127u) / 255u;
}

// Q15 -> Q8 (0..255), rounded, saturated.
uint8_t vd__temporal_score_q8(uint32_t s)
{
    uint32_t v = (s * 255u + 16384u) >> 15;
    return (uint8_t)(v > 255u ? 255u : v);
}

static uint32_t mul_q15(uint32_t a, uint32_t b)
{
    return (a * b + 16384u) >> 15;   // a, b <= 32768: a * b <= 2^30
}

// Hysteresis: confirmed at T >= hi, kept while T >= lo.
static void confirm_by_score(const vd_temporal_cfg_t *c, vd_track_t *tr)
{
    if (tr->score_q15 >= c->confirm_hi_q15) {
        tr->confirmed = 1u;
    } else if (tr->score_q15 < c->confirm_lo_q15) {
        tr->confirmed = 0u;
    }
}

// Output score of an observation of score s (Q15) on a track of score T: (1 - w) s + w T, in Q8.
static uint8_t fused_q8(const vd_temporal_cfg_t *c, uint32_t s_q15, uint32_t tr_q15)
{
    uint32_t w = c->score_weight_q15;
    return vd__temporal_score_q8(mul_q15(32768u - w, s_q15) + mul_q15(w, tr_q15));
}

// A matched observation of score s: T += alpha (min(1, s + gain) - T).
static void score_match(const vd_temporal_cfg_t *c, vd_track_t *tr, uint32_t s_q15)
{
    uint32_t target = s_q15 + c->score_gain_q15;
    if (target > 32768u) {
        target = 32768u;
    }
    uint32_t cur = tr->score_q15;
    uint32_t a = c->score_alpha_q15;
    uint32_t v = (target >= cur) ? cur + mul_q15(a, target - cur) : cur - mul_q15(a, cur - target);
    tr->score_q15 = (uint16_t)(v > 32768u ? 32768u : v);
}

uint8_t vd__temporal_score_new(const vd_temporal_cfg_t *c, vd_track_t *tr, uint8_t s_q8)
{
    const uint32_t s = q15_of_q8(s_q8);
    tr->score_q15 = (uint16_t)mul_q15(s, 32768u - c->new_penalty_q15);
    confirm_by_score(c, tr);
    return fused_q8(c, s, tr->score_q15);
}

uint8_t vd__temporal_score_match(const vd_temporal_cfg_t *c, vd_track_t *tr, uint8_t s_q8)
{
    const uint32_t s = q15_of_q8(s_q8);
    score_match(c, tr, s);
    confirm_by_score(c, tr);
    return fused_q8(c, s, tr->score_q15);
}

void vd__temporal_score_miss(const vd_temporal_cfg_t *c, vd_track_t *tr)
{
    tr->score_q15 = (uint16_t)mul_q15(tr->score_q15, c->miss_decay_q15);
    if (tr->score_q15 < c->confirm_lo_q15) {
        tr->confirmed = 0u;   // hysteresis: a decayed track is no longer confirmed
    }
}
