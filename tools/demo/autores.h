// SPDX-License-Identifier: MIT
// --cnn-full-res auto (vd_fir_demo's default): half or full resolution for the networks' input, measured
// on 64 frames spread over a recording (autores.c over common/flipagree.c, docs/demo.md "Choosing the networks'
// resolution").
#ifndef VD_DEMO_AUTORES_H
#define VD_DEMO_AUTORES_H

#include "flipagree.h"
#include "settings.h"
#include "vd_port/capture.h"

// Opens `input` a second time (recorded input only) and measures, on DEMO_AUTORES_SPREAD_FRAMES frames spread over
// it (demo_autores_sample; all of a shorter one; of the first --frames N with that option), the networks' boxes at
// half and at full resolution: each frame and its mirror image through the CNN source alone (the options' networks
// and threshold, one pass each, temporal analysis off); the boxes' mean score and the agreement of the mirror's
// boxes, mirrored back and matched one to one at IoU >= 0.5 (vdtools.adapt.measure.rating, the rule vd-adapt
// --resolution auto takes without labels; vdtools.evaluation.fleet auto_resolution does the same per recording).
// Full resolution when its rating, mean score + agreement / 4, is the higher one and at least
// DEMO_AUTORES_MIN_FRAMES frames were measured. o->cfg must point at the loaded networks (demo_models_load). The
// first frame read decides the grey window of 16-bit frames (demo_grey_decide) for the whole run. A
// capture or detector error: its status, err says what.
vd_status_t demo_autores_measure(demo_opts_t *o, const char *input, const vd_capture_opts_t *copts,
                                 demo_autores_t *out, char *err, size_t err_len);

#endif
