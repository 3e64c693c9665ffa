// SPDX-License-Identifier: MIT
// --cnn-full-res auto, frame by frame: how confident the networks are in their boxes at half, full and quarter
// resolution and how far they agree with themselves on mirrored frames (flipagree.c), shared by vd_fir_demo
// (64 frames spread over a recording, before the run: autores.c) and the GStreamer element vdfir (the first
// frames as they pass). docs/demo.md "Choosing the networks' resolution".
#ifndef VD_DEMO_FLIPAGREE_H
#define VD_DEMO_FLIPAGREE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "settings.h"
#include "vd/detector.h"

#define DEMO_AUTORES_MAX_FRAMES 32u      // a live source: its first frames, measured as they come
#define DEMO_AUTORES_SPREAD_FRAMES 64u   // a recording: frames measured at most, spread over it (demo_autores_sample)
#define DEMO_AUTORES_MIN_FRAMES 16u   // fewer frames are too little evidence: half resolution
#define DEMO_AUTORES_RES 3u           // the resolutions measured: cfg.cnn_res HALF, FULL, QUARTER (the index)

typedef struct demo_autores {
    uint8_t res;            // the choice: cfg.cnn_res (VD_DETECTOR_CNN_RES_HALF, _FULL, _QUARTER)
    uint32_t frames;        // frames measured
    uint64_t total;         // frames of the recording they were drawn from (0: a live source, its first ones)
    uint64_t matched[DEMO_AUTORES_RES];    // [cnn_res]: boxes matched between a frame and its mirror image (pairs)
    uint64_t boxes[DEMO_AUTORES_RES];      // ... and all boxes of both, pooled over the frames
    uint64_t score_q8[DEMO_AUTORES_RES];   // ... and the sum of those boxes' scores (vd_detection_t score_q8)
    double seconds;         // time the measurement took
} demo_autores_t;

// The frame (0-based) a measurement of a recording of `total` frames reads as its k-th (k <
// DEMO_AUTORES_SPREAD_FRAMES, ascending in k): every frame of a recording of at most DEMO_AUTORES_SPREAD_FRAMES,
// else the middle frame of each of DEMO_AUTORES_SPREAD_FRAMES equal parts, (2k + 1) total / (2
// DEMO_AUTORES_SPREAD_FRAMES). Why spread, and why 64: a folder of frames from many scenes, sorted by name, starts
// with one or two of them, and the rule's two ratings can be close. On 1 894 multi-scene sets of the train and val
// splits (2-8 scene groups each, as they are and under camera changes) the resolution chosen on the first 32 frames
// lost 790 AP points in all, on 32 spread frames 626, on 64 spread frames 385 and on every frame 156; averaged over
// where in each part the sample falls, the loss falls with every size from 16 to 96 (docs/results/cameras.md,
// "Which frames the rule measures"; vdtools.adapt.window_evidence). 64 frames: twice the measurement time of before
// (64 frames of 640x512: a median of 1.9 s with the AVX-512 VNNI kernels), a fixed cost however long the recording.
// vdtools.evaluation.fleet.auto_sample is the same.
uint64_t demo_autores_sample(uint64_t total, uint32_t k);

// Flip agreement of a measurement at resolution res (cfg.cnn_res): 2 matched / boxes, or -1 when there was no
// box at that resolution.
double demo_autores_agreement(const demo_autores_t *a, unsigned res);

// Mean score of the boxes (score_q8 / 255, frames and mirror images pooled), or -1 when there was no box at
// that resolution.
double demo_autores_mean_score(const demo_autores_t *a, unsigned res);

// What the choice compares: mean box score + DEMO_AUTORES_AGREE_WEIGHT x flip agreement, or -1 when there was no
// box at that resolution.
#define DEMO_AUTORES_AGREE_WEIGHT 0.25
double demo_autores_rating(const demo_autores_t *a, unsigned res);

// Sets a->res from the counts (the resolution of the highest rating, ties to the lower cfg.cnn_res; full or
// quarter only when at least DEMO_AUTORES_MIN_FRAMES frames were measured; no box at a resolution is no
// evidence for it) and returns it.
uint8_t demo_autores_decide(demo_autores_t *a);

// The three detectors (the CNN source alone as the options set it, one pass per network, temporal analysis
// off; at half, full and quarter resolution) and buffers of a measurement on frames of `first`'s size and format.
typedef struct demo_flipagree demo_flipagree_t;

// o->cfg must point at the loaded networks (demo_models_load). A detector that cannot run such frames: its
// status, err says which; out of memory: VD_ERR_IO. *out NULL on failure.
vd_status_t demo_flipagree_new(demo_flipagree_t **out, const demo_opts_t *o, const vd_frame_t *first, char *err,
                               size_t err_len);

// Frame f (first's size and format) and its mirror image at each resolution into a's counts (a->frames + 1).
// A detector error: its status (a unchanged but for the counts of the resolution measured before it).
vd_status_t demo_flipagree_add(demo_flipagree_t *fa, const vd_frame_t *f, demo_autores_t *a);

void demo_flipagree_free(demo_flipagree_t *fa);

// Seconds on the monotonic clock (the measurements' timing; the demo's progress and rates).
double demo_now_s(void);

// --cnn-full-res auto on a live source (vd_fir_demo on a camera, the GStreamer element), whose frames cannot be
// read twice: the first DEMO_AUTORES_MAX_FRAMES frames measured as they come, before each is detected on (at
// half resolution meanwhile).
typedef struct demo_autores_live {
    demo_flipagree_t *fa;
    demo_autores_t a;
    bool on;        // measuring
    bool decided;   // a.res is the choice, from frame `from` on
    uint64_t from;
} demo_autores_live_t;

// Frame f (the `frame`-th of the run, 0-based) into the measurement; *now true when it completed it (lv->a.res
// the choice, to apply from this frame on). A detector that cannot measure: its status, err says what.
vd_status_t demo_autores_live_frame(demo_autores_live_t *lv, const demo_opts_t *o, const vd_frame_t *f,
                                    uint64_t frame, bool *now, char *err, size_t err_len);

void demo_autores_live_free(demo_autores_live_t *lv);

#endif
