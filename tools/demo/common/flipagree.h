// SPDX-License-Identifier: MIT
// --cnn-full-res auto and --cnn-polarity auto, frame by frame: how confident the networks are in their boxes at
// half, full and quarter resolution, on frames as they are and inverted, and how far they agree with themselves
// on mirrored frames (flipagree.c), shared by vd_fir_demo (64 frames spread over a recording, before the run:
// autores.c) and the GStreamer element vdfir (the first frames as they pass). docs/demo.md "Choosing the
// networks' resolution" and "Black-hot cameras".
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
#define DEMO_AUTORES_RES 3u           // the resolutions: cfg.cnn_res HALF, FULL, QUARTER (the index)
// The configurations a measurement may rate, k = cnn_res + DEMO_AUTORES_RES x inverted: inverted 0 reads the
// frames in the options' polarity (cfg.cnn_invert), 1 in the other one (--cnn-polarity auto).
#define DEMO_AUTORES_CONFIGS (2u * DEMO_AUTORES_RES)
// --cnn-polarity auto takes the other polarity only when its best rating is above the best of the frames as they
// are by more than this. Every frame of ../shared/data is white-hot, and a black-hot camera's frames are those
// inverted, so one margin per recording (best as they are - best inverted) says both what a white-hot camera
// would lose (margin below -m: turned black-hot) and what a black-hot one would (margin below m: left as it is).
// Chosen on the train and val splits' recordings (docs/demo.md "Black-hot cameras";
// vdtools.adapt.polarity_evidence --recordings).
#define DEMO_AUTORES_INVERT_MARGIN 0.025

typedef struct demo_autores {
    uint8_t res;            // the choice: cfg.cnn_res (VD_DETECTOR_CNN_RES_HALF, _FULL, _QUARTER)
    uint8_t inverted;       // the choice: 1 = the other polarity than the options' (cfg.cnn_invert flipped)
    uint8_t measured;       // bit k: configuration k measured (the options' fixed resolution or polarity: fewer)
    uint8_t fixed_res;      // the options' cfg.cnn_res when they fix it (the choice keeps it), else DEMO_AUTORES_RES
    uint32_t frames;        // frames measured
    uint64_t total;         // frames of the recording they were drawn from (0: a live source, its first ones)
    uint64_t matched[DEMO_AUTORES_CONFIGS];    // [k]: boxes matched between a frame and its mirror image (pairs)
    uint64_t boxes[DEMO_AUTORES_CONFIGS];      // ... and all boxes of both, pooled over the frames
    uint64_t score_q8[DEMO_AUTORES_CONFIGS];   // ... and the sum of those boxes' scores (vd_detection_t score_q8)
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

// The configurations (bit k) a measurement rates: the three resolutions in the options' polarity with
// --cnn-full-res auto, all six with --cnn-polarity auto (the polarity is chosen over every resolution, even one
// the options fix), none when neither is auto.
uint8_t demo_autores_configs(const demo_opts_t *o);

// Flip agreement of a measurement in configuration k (cfg.cnn_res + DEMO_AUTORES_RES x inverted): 2 matched /
// boxes, or -1 when there was no box in it (or it was not measured).
double demo_autores_agreement(const demo_autores_t *a, unsigned k);

// Mean score of the boxes (score_q8 / 255, frames and mirror images pooled), or -1 when there was no box in
// configuration k.
double demo_autores_mean_score(const demo_autores_t *a, unsigned k);

// What the choice compares: mean box score + DEMO_AUTORES_AGREE_WEIGHT x flip agreement, or -1 when there was no
// box in configuration k.
#define DEMO_AUTORES_AGREE_WEIGHT 0.25
double demo_autores_rating(const demo_autores_t *a, unsigned k);

// One of the three figures of configuration k: kind 0 the rating, 1 the mean box score, 2 the flip agreement.
double demo_autores_figure(const demo_autores_t *a, unsigned k, unsigned kind);

// Sets a->res and a->inverted from the counts and returns a->res: among the configurations measured in the
// options' polarity, the highest rating (ties to the lower cfg.cnn_res); the other polarity's highest rating
// instead when it is above that by more than DEMO_AUTORES_INVERT_MARGIN. Anything but configuration 0 (half
// resolution as the options set the polarity) only with at least DEMO_AUTORES_MIN_FRAMES frames; no box is no evidence (rating 0). A resolution
// the options fix (a->fixed_res) stays.
uint8_t demo_autores_decide(demo_autores_t *a);

// Puts a decided measurement's choice into cfg (cnn_res; cnn_invert flipped when a->inverted). True when that
// changed cfg: a running detector must then be made anew.
bool demo_autores_apply(const demo_autores_t *a, vd_detector_cfg_t *cfg);

// Writes the choice's figures as "rating half 0.715, full 0.651, quarter 0.541; mean box score ...; flip
// agreement half 90.9 %, ..." (configurations not measured left out; with both polarities measured each name
// carries its polarity: "half white-hot", "half black-hot"), at most len bytes with the NUL. The summary line of
// vd_fir_demo and the element's log.
// DEMO_AUTORES_DESCRIBE_MAX bytes hold the longest (six configurations without a box: 3 x 6 x 37 + 40 bytes).
#define DEMO_AUTORES_DESCRIBE_MAX 1024u
void demo_autores_describe(const demo_autores_t *a, bool options_black_hot, char *buf, size_t len);

// The detectors (the CNN source alone as the options set it, one pass per network, temporal analysis off) of the
// configurations the options leave open (--cnn-full-res auto: the three resolutions; --cnn-polarity auto: both
// polarities) and the buffers of a measurement on frames of `first`'s size and format.
typedef struct demo_flipagree demo_flipagree_t;

// o->cfg must point at the loaded networks (demo_models_load). A detector that cannot run such frames: its
// status, err says which; out of memory: VD_ERR_IO. *out NULL on failure.
vd_status_t demo_flipagree_new(demo_flipagree_t **out, const demo_opts_t *o, const vd_frame_t *first, char *err,
                               size_t err_len);

// Frame f (first's size and format) and its mirror image in each configuration into a's counts (a->frames + 1).
// A detector error: its status (a unchanged). The frame and its mirror image run in two threads (the counts are
// those of one: integer sums made after both).
vd_status_t demo_flipagree_add(demo_flipagree_t *fa, const vd_frame_t *f, demo_autores_t *a);

void demo_flipagree_free(demo_flipagree_t *fa);

// Seconds on the monotonic clock (the measurements' timing; the demo's progress and rates).
double demo_now_s(void);

// --cnn-full-res / --cnn-polarity auto on a live source (vd_fir_demo on a camera, the GStreamer element), whose frames cannot be
// read twice: frames measured as they come, before each is detected on (at half resolution meanwhile), until
// DEMO_AUTORES_MAX_FRAMES of them counted from the first that holds a box (in any configuration). A frame without
// a box adds nothing to the counts, so a camera that starts on frames without vehicles (its shutter or warm-up
// frames, a lens cap, fog, a uniform scene) would be decided on nothing: after
// DEMO_AUTORES_MAX_FRAMES such frames only every DEMO_AUTORES_LIVE_STRIDE-th frame is measured (an eighth of the
// cost) while none holds a box, and with frame DEMO_AUTORES_LIVE_WAIT the measurement decides on what it has
// (no box: half resolution, the options' polarity), as it did on the first 32 frames before 2026-11-30.
#define DEMO_AUTORES_LIVE_STRIDE 8u
#define DEMO_AUTORES_LIVE_WAIT 2048u   // frames (68 s at 30 frames/s)
typedef struct demo_autores_live {
    demo_flipagree_t *fa;
    demo_autores_t a;
    bool on;             // measuring
    bool decided;        // a.res is the choice, from frame `from` on
    uint64_t from;
    uint64_t seen;       // frames offered since the start
    uint64_t first_box;  // of them, the first measured one that held a box (UINT64_MAX: none yet)
} demo_autores_live_t;

// Starts a live measurement (lv->fa NULL: zeroed, or after demo_autores_live_free).
void demo_autores_live_start(demo_autores_live_t *lv);

// Frame f (the `frame`-th of the run, 0-based, frames in order) into the measurement (or not: the sparse wait
// above); *now true when it completed it (lv->a.res the choice, to apply from this frame on). A detector that
// cannot measure: its status, err says what.
vd_status_t demo_autores_live_frame(demo_autores_live_t *lv, const demo_opts_t *o, const vd_frame_t *f,
                                    uint64_t frame, bool *now, char *err, size_t err_len);

// True when the frame just offered began the sparse wait (no box in the first DEMO_AUTORES_MAX_FRAMES); buf then
// holds the line that says so, for the demo's stderr and the element's log (each adds its prefix).
bool demo_autores_live_wait_began(const demo_autores_live_t *lv, char *buf, size_t len);

void demo_autores_live_free(demo_autores_live_t *lv);

#endif
