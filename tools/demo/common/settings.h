// SPDX-License-Identifier: MIT
// What a vd_fir_demo run is asked to do (demo_opts_t) and its detector settings (settings.c):
// one table row per setting, applied from a command-line flag (args.c), a --config file or the
// GStreamer element's properties (which pass through args.c).
#ifndef VD_DEMO_SETTINGS_H
#define VD_DEMO_SETTINGS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "vd/detector.h"
#include "vd/image.h"

#define DEMO_PATH_MAX 4096   // a model path copied out of a --config file's text

typedef struct demo_opts {
    const char *input;          // --input (default: the bundled clip chosen by --clip)
    bool input_default;         // --input not given
    const char *clip_eval;      // annotations of the bundled clip in use (NULL with --input)
    const char *model;          // --model FILE | none; NULL = auto (first models/*.vdm)
    const char *out_dir;        // --out
    const char *json;           // --json
    const char *eval;           // --eval
    const char *classes;        // --classes
    const char *eval_out;       // --eval-out
    const char *report;         // --report DIR
    uint32_t raw_w, raw_h;      // --raw-size
    vd_pixfmt_t raw_format;     // --raw-format u16 (default) | u8
    bool raw_big_endian;        // --raw-format u16be
    uint32_t dev_w, dev_h, fps; // --device-size, --fps
    vd_pixfmt_t dev_format;     // --pixfmt grey | y16
    uint64_t max_frames;        // --frames (0 = all)
    int32_t timeout_ms;         // --timeout-ms (devices)
    bool quiet;                 // --quiet
    bool scores;                // draw score text (--no-scores turns off)
    vd_detector_cfg_t cfg;      // detector settings (--config FILE, then flags)
    const char *cnn_model;      // --cnn-model FILE (flag or config); NULL = a CNN --model, else models/vd_cnn.vdm
    char cnn_model_buf[DEMO_PATH_MAX];   // its copy (a config file's text is freed after parsing)
    const char *cnn_model2;     // --cnn-model2 FILE|none; NULL = models/vd_cnn2.vdm with the default --cnn-model
    char cnn_model2_buf[DEMO_PATH_MAX];
    const char *boost_model;    // --boost-model FILE; NULL = models/vd_boost.vdm (with --verifier boost)
    char boost_model_buf[DEMO_PATH_MAX];
    bool sources_set;           // --sources given (flag or config): no default source choice
    bool max_candidates_set;    // --max-candidates / --max-detections given: not raised for the CNN
    bool max_detections_set;
    bool cnn_res_auto;          // --cnn-full-res auto (the default): vd_fir_demo and the element choose
                                // cfg.cnn_res on a recording's frames (common/flipagree.c); the fleet too
    bool cnn_polarity_auto;     // --cnn-polarity auto: cfg.cnn_invert chosen by the same measurement
    bool grey_window_auto;      // --grey-window auto (the default): cfg.grey_mode chosen on the first 16-bit frame
    bool grey_decided;          //   (demo_grey_decide, models.c): made once per run
    uint32_t grey_outside_permille;  // that frame's samples outside the fixed window, per mille
} demo_opts_t;

// The detector setting called `name` ("cnn-flip" or "cnn_flip"); -1 if there is none.
int demo_setting_find(const char *name);
// True for a switch (--cnn-rescore, --cnn-flip) whose value may be left out on the command line.
bool demo_setting_is_switch(int id);
// True when v is a value setting id takes after its flag: a switch's on/off etc., or the setting's own
// extra word (--cnn-full-res auto); a switch's value may be left out, so anything else is the next argument.
bool demo_setting_value_ok(int id, const char *v);
// Applies value v of setting id to o; false with msg "bad value 'v' for NAME (expected ARG)".
bool demo_setting_apply(demo_opts_t *o, int id, const char *v, char *msg, size_t msg_len);
// --help lines of every setting in table order ("  --name ARG   help", wrapped at 100 columns).
void demo_settings_usage(FILE *f);
// --config FILE: a flat JSON object of settings, applied in its order; false with msg (the
// option, the file and what is wrong).
bool demo_settings_load(demo_opts_t *o, const char *path, char *msg, size_t msg_len);

// Value parsers, shared with the command line's own options: false (and *out untouched) unless
// the whole text is one value in range.
bool demo_parse_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *out);
bool demo_parse_size(const char *s, uint32_t *w, uint32_t *h);   // "WxH", 1..VD_MAX_DIM each
bool demo_parse_switch(const char *v, bool *on);                 // on/off, true/false, 1/0
const char *demo_cnn_res_name(unsigned res);   // cfg.cnn_res's name: "half", "full", "quarter" ("?" beyond)
const char *demo_polarity_name(unsigned invert);   // cfg.cnn_invert's name: "white-hot" (0), "black-hot"

#endif
