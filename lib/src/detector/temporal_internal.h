// SPDX-License-Identifier: MIT
// Track-aware scores of the temporal analysis (VD_TEMPORAL_SCORES), shared by temporal.c and temporal_score.c.
#ifndef VD_TEMPORAL_INTERNAL_H
#define VD_TEMPORAL_INTERNAL_H

#include <stdint.h>

#include "vd/temporal.h"

// A new track from an observation of score s_q8: T = s (1 - new_penalty), confirmed if T >= confirm_hi.
// Returns the observation's output score (Q8).
uint8_t vd__temporal_score_new(const vd_temporal_cfg_t *c, vd_track_t *tr, uint8_t s_q8);
// A matched observation of score s_q8: T += alpha (min(1, s + gain) - T), hysteresis. Returns its output score.
uint8_t vd__temporal_score_match(const vd_temporal_cfg_t *c, vd_track_t *tr, uint8_t s_q8);
// A missed frame: T *= miss_decay; below confirm_lo the track is no longer confirmed.
void vd__temporal_score_miss(const vd_temporal_cfg_t *c, vd_track_t *tr);
// Q15 score -> Q8 (0..255), rounded.
uint8_t vd__temporal_score_q8(uint32_t s_q15);

#endif
