// SPDX-License-Identifier: MIT
// --cnn-full-res auto (vd_fir_demo's default): half or full resolution for the networks' input, measured
// on the first frames of a recording (autores.c, docs/demo.md "Choosing the networks' resolution").
#ifndef VD_DEMO_AUTORES_H
#define VD_DEMO_AUTORES_H

#include <stdbool.h>
#include <stdint.h>

#include "models.h"
#include "settings.h"
#include "vd_port/capture.h"

#define DEMO_AUTORES_MAX_FRAMES 32u   // frames measured at most (the first ones of the recording)
#define DEMO_AUTORES_MIN_FRAMES 16u   // fewer frames are too little evidence: half resolution

typedef struct demo_autores {
    bool full;              // the choice
    uint32_t frames;        // frames measured
    uint64_t matched[2];    // [half, full]: boxes matched between a frame and its mirror image (pairs)
    uint64_t boxes[2];      // ... and all boxes of both, pooled over the frames
    double seconds;         // time the measurement took
} demo_autores_t;

// Flip agreement of a measurement: 2 matched / boxes, or -1 when there was no box at that resolution.
double demo_autores_agreement(const demo_autores_t *a, int full);

// Opens `input` a second time (recorded input only) and measures, on its first DEMO_AUTORES_MAX_FRAMES
// frames, how far the networks agree with themselves at half and at full resolution: each frame and its
// mirror image through the CNN source alone (the options' networks and threshold, one pass each, temporal
// analysis off), the mirror's boxes mirrored back and matched one to one at IoU >= 0.5 (vdtools.adapt.
// measure.flip_agreement, the rule vd-adapt --resolution auto takes without labels; vdtools.evaluation.fleet
// auto_resolution does the same per recording). Full resolution when
// its agreement is the higher one and at least DEMO_AUTORES_MIN_FRAMES frames were measured.
// o->cfg must point at the loaded networks (demo_models_load). A capture or detector error: its status,
// err says what.
vd_status_t demo_autores_measure(const demo_opts_t *o, const char *input, const vd_capture_opts_t *copts,
                                 demo_autores_t *out, char *err, size_t err_len);

#endif
