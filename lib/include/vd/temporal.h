// SPDX-License-Identifier: MIT
// Temporal analysis of detections (paper 000 §4): a fixed-capacity track table
// that confirms targets seen in three consecutive frames and recovers confirmed
// targets the detector missed.
#ifndef VD_TEMPORAL_H
#define VD_TEMPORAL_H

#include <stddef.h>
#include <stdint.h>
#include <stdbool.h>

#include "vd/image.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// State of an observation / track after vd_temporal_update().
typedef enum vd_track_state {
    VD_TRACK_NONE = 0,       // not tracked (temporal analysis off, or no free track slot)
    VD_TRACK_NEW = 1,        // seen, not yet in t-1 and t-2: a possible false detection (paper 000 §4)
    VD_TRACK_CONFIRMED = 2,  // matched in t, t-1 and t-2 (or confirmed before and matched again)
    VD_TRACK_RECOVERED = 3   // confirmed target missed by the detector at t, found by the recovery search
} vd_track_state_t;

// Similarity of two boxes and complexities, paper 000 eq. (9)-(12):
//   S = w_c * S_C + (1 - w_c) * S_S,  S_C = min(C_a, C_b) / max(C_a, C_b),
//   S_S = exp(-(dx^2/sx^2 + dy^2/sy^2 + dW^2/sW^2 + dH^2/sH^2)),
// dx, dy between box centres, dW, dH between sizes. S_C = 1 when both
// complexities are 0 (no measure, e.g. CNN detections: no evidence either
// way), 0 when only one is 0.
// Sigmas scale with the targets (unless VD_TEMPORAL_FIXED_SIGMA): sx = sW =
// max(sigma_x / sigma_w, sigma_rel * mean width of a and b), sy = sH likewise
// with heights, so a 60 px car may move further than a 15 px one.
// Association compares each detection with the track's PREDICTED box (unless
// VD_TEMPORAL_NO_MOTION): last box + global motion of this frame + the
// track's own velocity. The global motion is the displacement most tracks
// agree on (the camera's); the velocity is the smoothed remainder.
// All fields: 0 = default.
#define VD_TEMPORAL_FIXED_SIGMA   0x01u  // flags: paper 000's fixed sigmas (sigma_rel_q8 unused)
#define VD_TEMPORAL_NO_MOTION     0x02u  // flags: no global motion, no velocities (paper 000)
#define VD_TEMPORAL_NO_GLOBAL     0x04u  // flags: velocities only, no global motion estimate
#define VD_TEMPORAL_RECOVER_NO_C  0x08u  // flags: also search for tracks whose complexity is 0 (see recovery)
#define VD_TEMPORAL_SCORES        0x10u  // flags: track-aware scores (below): obs score_q8 in, fused score out;
                                         //   confirmed by the track score with hysteresis (not by hits alone)
// Global motion: at most this many matched-last-frame tracks and leading
// observations vote (bounds the O(N^4) vote to 16^4 comparisons).
#define VD_TEMPORAL_MOTION_VOTERS 16u

typedef struct vd_temporal_cfg {
    uint16_t sigma_x;          // px, 1..4096, default 16 (the minimum sigma with relative sigmas)
    uint16_t sigma_y;          // px, 1..4096, default 16
    uint16_t sigma_w;          // px, 1..4096, default 16
    uint16_t sigma_h;          // px, 1..4096, default 16
    uint16_t weight_c_q15;     // weight of S_C, 1..32768, default 9830 (0.3); S_S gets 32768 - weight_c_q15
    uint16_t match_thr_q15;    // min S to associate a detection with a track, 1..32768, default 16384 (0.5)
    uint16_t recover_thr_q15;  // min S of a recovered region, 1..32768, default 26214 (0.8; > 0.7 needs S_C > 1/3)
    uint8_t confirm_frames;    // consecutive matched frames to confirm, 1..255, default 3 (t, t-1, t-2)
    uint8_t max_misses;        // track deleted after more consecutive unmatched frames than this, 1..255, default 3
    uint8_t search_radius;     // recovery search: offsets -r..r px around the predicted box, 1..64, default 4
    uint8_t search_step;       // recovery search step in px, 1..64, default 2; radius/step <= 8, so at most
                               // (2*8 + 1)^2 = 289 probes per missed confirmed track
    uint16_t sigma_rel_q8;     // relative sigma, Q8 of the mean box side, 1..1024 (4.0), default 384 (1.5)
    uint16_t max_motion;       // px per frame, 1..4096, default 128: larger displacements never vote for
                               // the global motion, and velocities are clamped to it
    uint8_t flags;             // VD_TEMPORAL_*, default 0 (relative sigmas, global motion, velocities,
                               // no recovery of tracks without complexity, no track scores)
    uint8_t coast_frames;      // VD_TEMPORAL_SCORES: a confirmed track missed for up to this many frames (and not
                               //   recovered by the probe search) is output at its predicted box as RECOVERED
                               //   with its decayed track score, 0..255, default 0 (none; measured in
                               //   docs/results/temporal.md: predicted boxes added false positives, no vehicle)
    // Track-aware scores (VD_TEMPORAL_SCORES; unused otherwise), all Q15 of 1.0, 1..32768 (0 = default):
    uint16_t score_alpha_q15;  // EWMA weight of a new observation in the track score, default 16384 (0.5)
    uint16_t score_weight_q15; // weight of the track score in the output score, default 16384 (0.5)
    uint16_t score_gain_q15;   // persistence gain: a matched observation pulls the track score towards
                               //   min(1, score + gain), default 3277 (0.1)
    uint16_t new_penalty_q15;  // a new track starts at score * (1 - penalty), default 3277 (0.1)
    uint16_t confirm_hi_q15;   // confirmed when the track score reaches this, default 13763 (0.42)
    uint16_t confirm_lo_q15;   // ... and stays confirmed until it falls below this (<= hi), default 11469 (0.35)
    uint16_t miss_decay_q15;   // track score factor per missed frame, default 22938 (0.7)
    uint16_t reserved2;
} vd_temporal_cfg_t;

// One track slot. id 0 marks a free slot. Caller-owned storage (see init).
typedef struct vd_track {
    uint32_t id;               // 1.. (wraps past UINT32_MAX back to 1), 0 = free
    vd_rect_t box;             // last box (matched or recovered), image coordinates
    uint16_t complexity_q15;   // last complexity, Q15 edge-pixel ratio
    uint16_t similarity_q15;   // S of the last match or recovery, Q15
    uint8_t hits;              // consecutive matched frames (saturates at 255)
    uint8_t misses;            // consecutive frames without a detector match
    uint8_t confirmed;         // 1 once confirmed; stays until the track is deleted
    uint8_t state;             // vd_track_state_t at the last update
    uint8_t matched;           // internal: matched during the current update
    uint8_t moving;            // 1 once a velocity was measured (two matched boxes)
    uint16_t score_q15;        // VD_TEMPORAL_SCORES: track score (EWMA of its observations' scores), Q15
    uint32_t age;              // frames since creation (saturating)
    int16_t vx_q4;             // own velocity (beyond the global motion), Q4 px per frame
    int16_t vy_q4;
} vd_track_t;

// An observation fed to / returned by vd_temporal_update(): a detection's box
// and complexity in, its track id and state out.
typedef struct vd_temporal_obs {
    vd_rect_t box;             // in: image coordinates, w, h > 0
    uint16_t complexity_q15;   // in: edge pixels / pixels in Q15 (vd_temporal_complexity_q15)
    uint16_t similarity_q15;   // out: S to the matched track (0 for a new track)
    uint32_t track_id;         // out: 0 if no track slot was free
    uint8_t state;             // out: vd_track_state_t
    uint8_t score_q8;          // VD_TEMPORAL_SCORES: in the detection's score (Q8, 0..255), out the fused score
                               //   (recovered: the track's decayed score); unchanged without the flag
    uint8_t reserved[2];
} vd_temporal_obs_t;

// Per-update counts.
typedef struct vd_temporal_stats {
    uint32_t matched;          // observations associated with an existing track
    uint32_t created;          // new tracks
    uint32_t confirmed;        // observations in state CONFIRMED
    uint32_t recovered;        // recovered tracks appended to the output
    uint32_t deleted;          // tracks deleted after too many misses
    uint32_t probes;           // probe callback calls
    uint32_t overflow;         // observations left untracked (table full) + recoveries dropped (output full)
    uint32_t motion_votes;     // tracks agreeing on the global motion (0: none found, motion 0)
    int32_t motion_x;          // global motion of this frame, px
    int32_t motion_y;
} vd_temporal_stats_t;

// Recovery probe: measures the complexity (Q15 edge-pixel ratio, the same
// measure the detector feeds in) of the region `box` of the current frame.
// Returns VD_OK and sets *complexity_q15, or any error to skip that box.
// The detector provides one (vd_detector.h); tests provide synthetic ones.
typedef vd_status_t (*vd_temporal_probe_fn)(void *user, const vd_rect_t *box, uint16_t *complexity_q15);

// Temporal analyser. Complete so the caller can own it (static, stack);
// fields are private: read them only through the functions below.
typedef struct vd_temporal {
    vd_temporal_cfg_t cfg;     // resolved (no zero fields)
    vd_track_t *tracks;
    size_t cap;
    uint32_t next_id;
    uint64_t inv_sx2_q32;      // round(2^32 / sigma_x^2) etc.: reciprocal multiplies, see temporal.c
    uint64_t inv_sy2_q32;
    uint64_t inv_sw2_q32;
    uint64_t inv_sh2_q32;
    int32_t gx2;               // global motion of the current update, doubled px (internal)
    int32_t gy2;
    vd_temporal_stats_t stats;
} vd_temporal_t;

// Fills *cfg with the defaults listed in vd_temporal_cfg_t (same as a zeroed cfg).
VD_API void vd_temporal_cfg_default(vd_temporal_cfg_t *cfg);

// Resolves cfg in place: zero fields take the defaults above, then every
// field is checked against its documented range (and search_radius /
// search_step <= 8). Returns VD_OK; VD_ERR_ARG for NULL cfg or a field out of range.
VD_API vd_status_t vd_temporal_cfg_resolve(vd_temporal_cfg_t *cfg);

// Initialises `t` over caller storage `tracks[cap]` (cap 1..65535), which
// must outlive `t`; all slots are cleared. `cfg` may be NULL (defaults); it
// is copied and resolved (vd_temporal_cfg_resolve). Returns VD_ERR_ARG for
// NULL t/tracks, cap 0 or > 65535, or a cfg field out of its documented range.
VD_API vd_status_t vd_temporal_init(vd_temporal_t *t, const vd_temporal_cfg_t *cfg, vd_track_t *tracks, size_t cap);

// Forgets every track and the last stats (ids keep increasing). t NULL: no-op.
VD_API void vd_temporal_reset(vd_temporal_t *t);

// Processes one frame's detections.
//   obs[0..n): this frame's detections (box, complexity in; id, state,
//              similarity out). obs has room for `cap` entries (cap >= n).
//   Recovered tracks are appended as obs[n..*count) with state
//   VD_TRACK_RECOVERED, the found box and its complexity.
//   probe/user: recovery search (may be NULL = no recovery).
// Order: (0) global motion: the displacement (track box + velocity ->
// observation, both boxes of similar size, |d| <= max_motion) with which the
// most voting tracks have an observation within half their box; >= 2 votes
// needed, else 0; the mean of the agreeing displacements; (1) greedy
// association of predicted boxes, highest S first, pairs with S >= match_thr;
// (2) matched tracks take the new box, hits+1, confirmed at confirm_frames,
// velocity updated (first measurement taken whole, later ones half-way);
// (3) unmatched tracks coast to their predicted box; unmatched confirmed
// tracks with a complexity (or with VD_TEMPORAL_RECOVER_NO_C) are searched at
// offsets of search_step up to search_radius around it (same size), best S
// >= recover_thr wins; (4) other unmatched tracks age and are deleted after
// max_misses misses; (5) unmatched observations start new tracks in free slots.
// With VD_TEMPORAL_SCORES each track keeps a score T (Q15) and each output
// box's score fuses its own: (2) a match moves T by score_alpha towards
// min(1, s + score_gain); (5) a new track starts at T = s * (1 - new_penalty);
// (3) a miss multiplies T by miss_decay; the output score is (1 - w) * s + w * T
// (w = score_weight, s the detection's score in Q15 = score_q8 * 32768 / 255);
// a track is confirmed when T >= confirm_hi and loses it when T < confirm_lo
// (hysteresis); a recovered box (probe search or coasting, coast_frames)
// carries T. docs/architecture.md "Temporal analysis" has the state machine.
// Recovery needs a complexity: for a track without one (0) S_C only reaches
// 1 on an edge-free probe, i.e. it would "recover" empty background.
// Returns VD_OK; VD_ERR_ARG for NULL t/obs(with n>0)/count or n > cap or a
// box with w or h <= 0; VD_ERR_CAPACITY when the track table was full for an
// observation (its track_id = 0, state NONE) or recoveries did not fit in
// cap (dropped; the track still counts a miss) — everything else is valid.
VD_API vd_status_t vd_temporal_update(vd_temporal_t *t, vd_temporal_obs_t *obs, size_t n, size_t cap, size_t *count,
                               vd_temporal_probe_fn probe, void *user);

// Counts of the last update (valid until the next update).
VD_API const vd_temporal_stats_t *vd_temporal_last_stats(const vd_temporal_t *t);

// Similarity S of (a, ca) and (b, cb) under t's configuration, Q15 (0..32768).
VD_API uint32_t vd_temporal_similarity_q15(const vd_temporal_t *t, const vd_rect_t *a, uint16_t ca_q15,
                                    const vd_rect_t *b, uint16_t cb_q15);

// Complexity = edge_pixels / pixels in Q15, rounded, clamped to 32768;
// 0 when pixels is 0.
VD_API uint16_t vd_temporal_complexity_q15(uint32_t edge_pixels, uint32_t pixels);

// exp(-x) for x >= 0 in Q16, result in Q15 (0..32768). Table of exp(-k/128)
// with linear interpolation times a table of exp(-n): |error| <= 1 LSB
// (checked against exp() for every x step in tests/unit/test_temporal.c).
// x >= 16.0 gives 0 (exp(-16) * 32768 < 0.004).
VD_API uint32_t vd_temporal_exp_neg_q15(uint32_t x_q16);

#ifdef __cplusplus
}
#endif
#endif
