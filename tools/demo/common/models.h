// SPDX-License-Identifier: MIT
// Models of a vd_fir_demo run (models.c), shared with the GStreamer element vdfir: which files
// the options ask for (docs/demo.md "Which sources by default"), loaded in place, and the
// detector settings both derive from the options for a frame size.
#ifndef VD_DEMO_MODELS_H
#define VD_DEMO_MODELS_H

#include <stdbool.h>
#include <stdint.h>

#include "settings.h"
#include "vd/boost.h"
#include "vd/cnn.h"
#include "vd/dbn.h"

typedef struct demo_models {
    uint8_t *model_blob;        // DBN file (malloc'd); model points into it
    vd_dbn_model_t model;
    bool have_model;            // a source (or --cnn-rescore) uses the DBN
    char model_path[4096];
    uint8_t *cnn_blob;          // CNN file (malloc'd); cnn points into it
    vd_cnn_model_t cnn;
    bool have_cnn;
    char cnn_path[4096];
    uint8_t *cnn2_blob;         // --cnn-model2 (malloc'd); cnn2 points into it
    vd_cnn_model_t cnn2;
    bool have_cnn2;
    char cnn2_path[4096];
    void *cnn_prep, *cnn2_prep;  // vd_cnn_prepare's buffers (posix_memalign'd; NULL: none, e.g. not x86)
    uint8_t *boost_blob;        // --verifier boost: the boosted verifier's file (malloc'd); boost points into it
    vd_boost_model_t boost;
} demo_models_t;

// Resolves and loads the models the options ask for (docs/demo.md "Which
// sources by default"; defaults from models_dir): without --sources the
// sources follow the models at hand; sets o->cfg.sources, o->cfg.cnn_model
// (= &m->cnn, so m must not move while o->cfg is used) and, for the CNN, the
// candidate/detection budgets not set by the user. On failure err names the
// option and file. m must be zeroed before the first call.
vd_status_t demo_models_load(demo_models_t *m, demo_opts_t *o, const char *models_dir, char *err, size_t err_len);
void demo_models_free(demo_models_t *m);
// --grey-window auto switches to the per-frame window when at least this many per mille of the first 16-bit
// frame's samples lie outside the fixed one (the networks would see a black or white plane).
#define DEMO_GREY_AUTO_PERMILLE 900u
// The fixed grey window (cfg.grey_lo_ck..grey_hi_ck, defaults resolved) as raw values of the options'
// calibration, hi > lo.
void demo_grey_fixed_raw(const demo_opts_t *o, uint32_t *lo, uint32_t *hi);
// On the run's first 16-bit frame (later calls and 8-bit frames: nothing): the per mille of its samples outside
// the fixed window into o->grey_outside_permille and, with --grey-window auto, cfg.grey_mode = per frame when at
// least DEMO_GREY_AUTO_PERMILLE. Every detector of the run is set up after it, so all read grey alike.
void demo_grey_decide(demo_opts_t *o, const vd_frame_t *f);
// The detector settings for width x height frames (the options' cfg sized to the frame).
void demo_detector_cfg(const demo_opts_t *o, uint32_t width, uint32_t height, vd_detector_cfg_t *cfg);

#endif
