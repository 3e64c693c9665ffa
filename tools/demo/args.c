// SPDX-License-Identifier: MIT
// Command-line options and the --config file (a flat JSON object of the same settings) of vd_fir_demo.
//
// Detector settings are one table: each has a flag "--name VALUE" and the
// same key in the --config file ("name" or "name_with_underscores"). The
// config file is applied first, flags after it, so flags win. A switch
// setting (--cnn-rescore, --cnn-flip) may be given without a value on the command line
// (= on); in the config file it takes true/false or "on"/"off".
#include "demo.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

// The bundled clips (tools/CMakeLists.txt sets both to absolute paths of the build):
// the real HIT-UAV excerpt committed under tools/demo/hit-uav-clip (CC BY 4.0, the default),
// and the synthetic radiometric clip generated at build time (--clip synthetic | synthetic-u8).
#ifndef VD_DEMO_HIT_CLIP_DIR
#define VD_DEMO_HIT_CLIP_DIR "tools/demo/hit-uav-clip"
#endif
#ifndef VD_DEMO_CLIP_DIR
#define VD_DEMO_CLIP_DIR "build/clip"
#endif
#define VD_DEMO_DEFAULT_INPUT VD_DEMO_HIT_CLIP_DIR "/images"

typedef enum setting_id {
    SET_THR_MODE,
    SET_HOT_THR,
    SET_HOT_THR_C,
    SET_ADAPT_PCT,
    SET_ADAPT_FLOOR,
    SET_CALIB,
    SET_GREY_RANGE_C,
    SET_MIN_AREA,
    SET_MAX_AREA,
    SET_ASPECT_MIN,
    SET_ASPECT_MAX,
    SET_EXPAND_W,
    SET_EXPAND_H,
    SET_MEDIAN,
    SET_EDGE_STEP,
    SET_WINDOW,
    SET_SCORE_THR,
    SET_NMS_IOU,
    SET_MAX_COMPONENTS,
    SET_MAX_CANDIDATES,
    SET_MAX_DETECTIONS,
    SET_MAX_REGION,
    SET_TEMPORAL,
    SET_MAX_TRACKS,
    SET_TRACK_SIGMA_REL,
    SET_TRACK_MOTION,
    SET_TRACK_RECOVER_NO_C,
    SET_SOURCES,
    SET_DEDUP_IOU,
    SET_WIN_PRESET,
    SET_WIN_BANDS,
    SET_WIN_HORIZON,
    SET_WIN_GROUND,
    SET_WIN_ASPECTS,
    SET_WIN_STRIDE,
    SET_WIN_STEP,
    SET_WIN_MIN_STD,
    SET_CONTRAST_RADIUS,
    SET_CONTRAST_THR,
    SET_CONTRAST_POLARITY,
    SET_CNN_MODEL,
    SET_CNN_THR,
    SET_CNN_RESCORE,
    SET_CNN_FLIP,
    SET_CNN_MODEL2,
    SET_VERIFIER,
    SET_BOOST_MODEL,
    SET_BOOST_OFFSET,
    SET_COUNT
} setting_id_t;

typedef struct setting {
    const char *name;
    const char *arg;
    const char *help;
} setting_t;

// A model path setting: copied into buf (a --config file's text is freed
// after parsing) and *out pointed at it; false for an empty or too long path.
static bool keep_path(const char *v, char *buf, size_t size, const char **out)
{
    if (v[0] == '\0' || strlen(v) >= size) {
        return false;
    }
    snprintf(buf, size, "%s", v);
    *out = buf;
    return true;
}

// Switch settings: the value may be left out on the command line (= on).
static bool is_switch(int id)
{
    return id == SET_CNN_RESCORE || id == SET_CNN_FLIP;
}

static const setting_t k_settings[SET_COUNT] = {
    [SET_THR_MODE] = {"thr-mode", "constant|adaptive",
                      "hot-spot threshold: constant (paper, default; radiometric or fixed-gain cameras and "
                      "bright drone video) or adaptive (8-bit dark road video: a frame percentile, never below "
                      "--adaptive-floor)"},
    [SET_HOT_THR] = {"hot-thr", "U8", "8-bit constant threshold, hot = pixel >= U8 (default 150, paper)"},
    [SET_HOT_THR_C] = {"hot-thr-c", "DEGC", "16-bit frames: threshold in degrees Celsius (default 30.00)"},
    [SET_ADAPT_PCT] = {"adaptive-percentile", "P", "adaptive mode: frame percentile 0.1..100 (default 99)"},
    [SET_ADAPT_FLOOR] = {"adaptive-floor", "U8", "adaptive mode: lowest threshold (default 96)"},
    [SET_CALIB] = {"calib", "GAIN,OFFSET_CK",
                   "16-bit frames: centi-kelvin = OFFSET_CK + raw * GAIN (default 1,0: TLinear 0.01 K)"},
    [SET_GREY_RANGE_C] = {"grey-range-c", "LO,HI",
                          "16-bit frames: degC mapped to grey 0 and 255 for refinement and drawing "
                          "(default threshold-30, threshold+21)"},
    [SET_MIN_AREA] = {"min-area", "PX", "rule: smallest hot region in pixels (default 120, paper)"},
    [SET_MAX_AREA] = {"max-area", "PX", "rule: largest hot region, 0 = no limit (default 0)"},
    [SET_ASPECT_MIN] = {"aspect-min", "R", "rule: smallest height/width of a hot region (default 0.3, paper)"},
    [SET_ASPECT_MAX] = {"aspect-max", "R", "rule: largest height/width of a hot region (default 1.5, paper)"},
    [SET_EXPAND_W] = {"expand-w", "F", "candidate expansion horizontally, 1..8 (default 1.5, paper)"},
    [SET_EXPAND_H] = {"expand-h", "F", "candidate expansion vertically, 1..8 (default 2, paper)"},
    [SET_MEDIAN] = {"median", "0|3|5", "refinement median filter size, 0 = none (default 3)"},
    [SET_EDGE_STEP] = {"edge-step", "N", "refinement: local threshold at every N-th edge point (default 5)"},
    [SET_WINDOW] = {"window", "N", "refinement: local window size, odd (default 5)"},
    [SET_SCORE_THR] = {"score-thr", "S", "DBN: keep candidates with p(vehicle) >= S, 0..1 (default 0.5)"},
    [SET_NMS_IOU] = {"nms-iou", "F", "suppress a box overlapping a better one by IoU > F (default 0.5)"},
    [SET_MAX_COMPONENTS] = {"max-components", "N", "components labelled per frame (default 256)"},
    [SET_MAX_CANDIDATES] = {"max-candidates", "N", "candidates verified per frame (default 64)"},
    [SET_MAX_DETECTIONS] = {"max-detections", "N", "detections kept per frame (default 32)"},
    [SET_MAX_REGION] = {"max-region", "WxH", "refinement region bound; larger regions are decimated (default: the detector's, 176x176)"},
    [SET_TEMPORAL] = {"temporal", "on|off",
                      "temporal analysis: track ids, confirmed / recovered states (default on)"},
    [SET_MAX_TRACKS] = {"max-tracks", "N", "temporal track table size (default 32)"},
    [SET_TRACK_SIGMA_REL] = {"track-sigma-rel", "F|off",
                             "temporal: association sigmas = max(16 px, F x box side), 0.004..4 (default 1.5); "
                             "off = the paper's fixed 16 px"},
    [SET_TRACK_MOTION] = {"track-motion", "on|velocity|off",
                          "temporal: predict tracks by the frame's global motion and their velocity (on, "
                          "default), velocity only, or not at all (off, the paper's)"},
    [SET_TRACK_RECOVER_NO_C] = {"track-recover-unmeasured", "on|off",
                                "temporal: also run recovery for tracks without a complexity (CNN "
                                "detections; default off: it finds edge-free background)"},
    [SET_SOURCES] = {"sources", "LIST",
                     "candidate sources, comma separated: hotspot, contrast, window, all (= the three of the "
                     "paper pipeline) and cnn (the int8 network), e.g. hotspot,cnn; all sources share "
                     "--max-candidates. Default: cnn when a CNN model is at hand (--cnn-model, a version-3 "
                     "--model, or models/vd_cnn.vdm when no --model is given), else hotspot (the paper's)"},
    [SET_DEDUP_IOU] = {"dedup-iou", "F",
                       "merge: drop a hot-spot/contrast/window candidate overlapping an earlier one (CNN boxes "
                       "come first) by IoU > F (default 0.7)"},
    [SET_WIN_PRESET] = {"window-preset", "msrs|hit|table1",
                        "window bands for a mounting: msrs = road level 640x480 (horizon 230, ground slope 1.6, "
                        "x2 tolerance, Table 1 bands), hit = drone (heights 12..120 everywhere, half stride), "
                        "table1 = Table 1 sizes everywhere; give it before other --window-* flags"},
    [SET_WIN_BANDS] = {"window-bands", "Y0:Y1:H0:H1[,...]",
                       "up to 4 bands: windows whose bottom row is in Y0..Y1 have heights H0..H1 px "
                       "(default one band, every row, 10..200)"},
    [SET_WIN_HORIZON] = {"window-horizon", "ROW", "ground model: horizon row (with --window-ground)"},
    [SET_WIN_GROUND] = {"window-ground", "K[,TOL]",
                        "ground model: expected height K px per row below the horizon, tolerance factor TOL "
                        "(default 2); 0 = off (default)"},
    [SET_WIN_ASPECTS] = {"window-aspects", "R[,R...]", "window height/width ratios, up to 4 (default 1)"},
    [SET_WIN_STRIDE] = {"window-stride", "F", "window step as a fraction of its size, 0.0625..2 (default 0.25)"},
    [SET_WIN_STEP] = {"window-step", "F", "ratio of successive window heights, 1.125..4 (default 1.25)"},
    [SET_WIN_MIN_STD] = {"window-min-std", "U8",
                         "window pre-filter: keep windows whose 4x4-cell means vary by a standard deviation "
                         ">= U8 grey levels (default 4); the highest ones fill the candidate budget"},
    [SET_CONTRAST_RADIUS] = {"contrast-radius", "N", "contrast source: box half-size 1..127 (default 16)"},
    [SET_CONTRAST_THR] = {"contrast-thr", "U8", "contrast source: |I - local mean| threshold (default 24)"},
    [SET_CONTRAST_POLARITY] = {"contrast-polarity", "both|warm|cold",
                               "contrast source: which direction counts (default both)"},
    [SET_CNN_MODEL] = {"cnn-model", "FILE",
                       "cnn source: version-3 .vdm network (default: --model if it is one, else "
                       "models/vd_cnn.vdm)"},
    [SET_CNN_THR] = {"cnn-thr", "P",
                     "cnn source: keep boxes with network score >= P, 0..1 (default: the model's own threshold; "
                     "with --cnn-model2, the second network's)"},
    [SET_CNN_RESCORE] = {"cnn-rescore", "[on|off]",
                         "cnn source: the DBN also scores each network box (whole box, as windows) and keeps it "
                         "at >= --score-thr; the score is then the DBN's (needs a DBN model; default off)"},
    [SET_CNN_FLIP] = {"cnn-flip", "[on|off]",
                      "cnn source: run the network a second time on the mirrored half-resolution frame and "
                      "fuse its boxes, mirrored back, with the first pass's (pairs averaged, the rest at half "
                      "score, fused scores below the score threshold dropped) before overlap suppression (test-time "
                      "augmentation: about twice the network's time; default on, chosen on the val split)"},
    [SET_CNN_MODEL2] = {"cnn-model2", "FILE|none",
                        "cnn source: a second version-3 .vdm network run on the same frame, its boxes fused with "
                        "the first network's as the flip pass fuses (an ensemble: about the second network's time "
                        "again; default models/vd_cnn2.vdm with the default --cnn-model, none otherwise; 'none' "
                        "= one network)"},
    [SET_VERIFIER] = {"verifier", "dbn|boost",
                      "verifier of hot-spot/contrast/window (and re-scored cnn) candidates: dbn (default, --model) "
                      "or boost (paper 003's boosted CNN-feature stumps, --boost-model)"},
    [SET_BOOST_MODEL] = {"boost-model", "FILE",
                         "--verifier boost: version-4 .vdm (default models/vd_boost.vdm)"},
    [SET_BOOST_OFFSET] = {"boost-offset", "N",
                          "--verifier boost: keep candidates with score >= the model's threshold + N "
                          "(integer, -16777216..16777216; default 0; negative values for PR curves)"},
};

void demo_args_usage(FILE *f)
{
    fprintf(f,
            "usage: vd_fir_demo [options]\n"
            "Detects vehicles in far-infrared frames with the vd library: an int8 CNN (--sources cnn,\n"
            "the default when models/vd_cnn.vdm exists) or the paper 001 pipeline (--sources hotspot).\n\n"
            "input and outputs:\n"
            "  --input PATH        directory of frames (*.pgm *.png *.jpg *.raw *.y16, sorted by name), list file\n"
            "                      (*.txt / *.lst, one path per line), one image or raw file, or /dev/videoN\n"
            "                      (default: the bundled clip, see --clip)\n"
            "  --clip NAME         bundled clip used without --input: hit-uav (default: 38 real drone frames of\n"
            "                      HIT-UAV, CC BY 4.0, %s), synthetic (generated 16-bit radiometric\n"
            "                      night road, %s/u16) or synthetic-u8 (the same clip in 8 bits)\n"
            "  --raw-size WxH      frame size of raw files (required for raw input)\n"
            "  --raw-format F      raw samples: u16 (little-endian, default), u16be or u8\n"
            "  --device-size WxH   V4L2: requested frame size (default: the driver's)\n"
            "  --fps N             V4L2: requested frame rate\n"
            "  --pixfmt F          V4L2: grey or y16 (default: y16 if offered)\n"
            "  --timeout-ms N      V4L2: wait per frame (default 2000)\n"
            "  --frames N          stop after N frames (default: all; a camera runs until Ctrl-C)\n"
            "  --model FILE        .vdm model. A DBN (versions 1-2) verifies hot-spot/contrast/window candidates\n"
            "                      (default: models/vd_dbn_grey.vdm, else the first DBN models/*.vdm; loaded only\n"
            "                      when a source or --cnn-rescore needs it; 'none' = no DBN: every candidate is\n"
            "                      kept with score 1.0 and the default sources are hotspot). A CNN (version 3) is\n"
            "                      taken as --cnn-model. Without --sources, a DBN --model keeps the paper pipeline\n"
            "                      and a CNN model (--cnn-model, a CNN --model, or models/vd_cnn.vdm when no\n"
            "                      --model is given) makes the sources cnn; with the cnn source and no\n"
            "                      --max-candidates/--max-detections, both become the model's top-K (twice\n"
            "                      that for candidates with --cnn-flip; +64 for the other sources); with a\n"
            "                      second network (--cnn-model2, default models/vd_cnn2.vdm beside the default\n"
            "                      models/vd_cnn.vdm) the larger top-K and 32 detections\n"
            "  --out DIR           annotated PNG frames: boxes yellow = new, green = confirmed,\n"
            "                      magenta = recovered; track id and score above each box\n"
            "  --no-scores         do not draw the id/score text\n"
            "  --json FILE         detections as JSON Lines, one object per frame (docs/demo.md)\n"
            "  --eval ANNOTATIONS  compare with ground truth: COCO-like JSON (HIT-UAV layout too) or a YOLO\n"
            "                      label folder; prints TP rate, FP rate, precision, recall, FPPI\n"
            "                      (default with a bundled clip: its annotations.json)\n"
            "  --classes LIST      vehicle classes for --eval, ids or names, comma separated (default: classes\n"
            "                      named car/othervehicle/vehicle/truck/bus/van; YOLO without names: 2 = MSRS car)\n"
            "  --eval-out FILE     write the evaluation figures as JSON\n"
            "  --report DIR        DIR/index.html, one self-contained page: summary, stage times and, with\n"
            "                      ground truth, TP/FP/AP, the precision-recall curve and a gallery of the\n"
            "                      frames with misses and false positives\n"
            "  --quiet             no progress lines\n"
            "  --help              this text\n\n"
            "detector settings (also keys of --config FILE, a JSON object such as {\"hot-thr\": 150}; flags win):\n"
            "  --config FILE       read settings from FILE\n",
            VD_DEMO_HIT_CLIP_DIR, VD_DEMO_CLIP_DIR);
    for (size_t i = 0; i < SET_COUNT; i++) {
        char head[64];
        snprintf(head, sizeof head, "--%s %s", k_settings[i].name, k_settings[i].arg);
        fprintf(f, "  %-28s", head);
        if (strlen(head) > 28) {
            fprintf(f, "\n  %-28s", "");
        }
        // word-wrap the help at 100 columns, continuation lines indented to 31
        const char *h = k_settings[i].help;
        size_t col = 31;
        while (*h != '\0') {
            size_t w = strcspn(h, " ");
            if (col + 1 + w > 100 && col > 31) {
                fprintf(f, "\n  %-28s", "");
                col = 31;
            }
            fprintf(f, " %.*s", (int)w, h);
            col += 1 + w;
            h += w;
            while (*h == ' ') {
                h++;
            }
        }
        fputc('\n', f);
    }
    fprintf(f, "\nErrors print one line on stderr and exit non-zero; outputs are written to temporary names\n"
               "and renamed only when the whole run succeeded.\n");
}

static bool parse_double(const char *s, double lo, double hi, double *out)
{
    char *end = NULL;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end != '\0' || errno != 0 || !isfinite(v) || v < lo || v > hi) {
        return false;
    }
    *out = v;
    return true;
}

static bool parse_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *out)
{
    char *end = NULL;
    errno = 0;
    if (*s == '-' || *s == '+') {
        return false;
    }
    unsigned long long v = strtoull(s, &end, 10);
    if (end == s || *end != '\0' || errno != 0 || v < lo || v > hi) {
        return false;
    }
    *out = (uint32_t)v;
    return true;
}

static bool parse_i32(const char *s, int32_t lo, int32_t hi, int32_t *out)
{
    char *end = NULL;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (end == s || *end != '\0' || errno != 0 || v < lo || v > hi) {
        return false;
    }
    *out = (int32_t)v;
    return true;
}

static bool parse_pair(const char *s, char sep, double *a, double *b)
{
    const char *p = strchr(s, sep);
    if (p == NULL) {
        return false;
    }
    char first[64];
    size_t l = (size_t)(p - s);
    if (l == 0 || l >= sizeof first) {
        return false;
    }
    memcpy(first, s, l);
    first[l] = '\0';
    return parse_double(first, -1e12, 1e12, a) && parse_double(p + 1, -1e12, 1e12, b);
}

static bool parse_size(const char *s, uint32_t *w, uint32_t *h)
{
    double a, b;
    if (!parse_pair(s, 'x', &a, &b) && !parse_pair(s, 'X', &a, &b)) {
        return false;
    }
    if (a < 1 || b < 1 || a > VD_MAX_DIM || b > VD_MAX_DIM || a != floor(a) || b != floor(b)) {
        return false;
    }
    *w = (uint32_t)a;
    *h = (uint32_t)b;
    return true;
}

static int32_t c_to_ck(double c)
{
    return (int32_t)lround(27315.0 + 100.0 * c);
}

static bool q_of(double v, double scale, double lo, double hi, uint32_t *out)
{
    if (!(v >= lo && v <= hi)) {
        return false;
    }
    *out = (uint32_t)lround(v * scale);
    return true;
}

// "Y0:Y1:H0:H1,..." -> up to VD_WINDOWS_MAX_BANDS bands.
static bool parse_bands(const char *v, vd_windows_cfg_t *w)
{
    vd_windows_cfg_t t = *w;
    t.n_bands = 0;
    const char *p = v;
    while (*p != '\0') {
        long y0, y1, h0, h1;
        int used = 0;
        if (t.n_bands >= VD_WINDOWS_MAX_BANDS || sscanf(p, "%ld:%ld:%ld:%ld%n", &y0, &y1, &h0, &h1, &used) != 4) {
            return false;
        }
        if (y0 < -(long)VD_MAX_DIM || y1 > 2L * (long)VD_MAX_DIM || y0 > y1 || h0 < 1 || h0 > h1 || h1 > (long)VD_MAX_DIM) {
            return false;
        }
        vd_window_band_t *b = &t.bands[t.n_bands++];
        b->y_min = (int32_t)y0;
        b->y_max = (int32_t)y1;
        b->min_h = (uint16_t)h0;
        b->max_h = (uint16_t)h1;
        p += used;
        if (*p == ',') {
            p++;
        } else if (*p != '\0') {
            return false;
        }
    }
    if (t.n_bands == 0) {
        return false;
    }
    *w = t;
    return true;
}

// The mounting presets of tools/vdtools/bindings/sources.py (MSRS: for 480-row frames).
static bool apply_window_preset(vd_windows_cfg_t *w, const char *name)
{
    vd_windows_cfg_t t;
    memset(&t, 0, sizeof t);
    t.n_aspects = 1;
    t.aspect_q8[0] = 256;
    if (strcmp(name, "msrs") == 0) {
        t.n_bands = 3;
        t.bands[0] = (vd_window_band_t){230, 270, 10, 30};
        t.bands[1] = (vd_window_band_t){245, 310, 25, 70};
        t.bands[2] = (vd_window_band_t){270, (int32_t)VD_MAX_DIM, 50, 300};
        t.horizon_y = 230;
        t.ground_k_q8 = 410;      // 1.6
        t.ground_tol_q8 = 512;    // x2
        t.stride_q8 = 64;         // 0.25
        t.scale_step_q8 = 320;    // 1.25
    } else if (strcmp(name, "hit") == 0) {
        t.n_bands = 1;
        t.bands[0] = (vd_window_band_t){0, (int32_t)VD_MAX_DIM, 12, 120};
        t.stride_q8 = 128;        // 0.5
        t.scale_step_q8 = 361;    // 1.41
    } else if (strcmp(name, "table1") == 0) {
        t.n_bands = 3;
        t.bands[0] = (vd_window_band_t){0, (int32_t)VD_MAX_DIM, 10, 30};
        t.bands[1] = (vd_window_band_t){0, (int32_t)VD_MAX_DIM, 25, 70};
        t.bands[2] = (vd_window_band_t){0, (int32_t)VD_MAX_DIM, 50, 200};
        t.stride_q8 = 64;
        t.scale_step_q8 = 320;
    } else {
        return false;
    }
    *w = t;
    return true;
}

static bool parse_switch(const char *v, bool *on)
{
    if (strcmp(v, "on") == 0 || strcmp(v, "true") == 0 || strcmp(v, "1") == 0) {
        *on = true;
    } else if (strcmp(v, "off") == 0 || strcmp(v, "false") == 0 || strcmp(v, "0") == 0) {
        *on = false;
    } else {
        return false;
    }
    return true;
}

// Applies one detector setting; false (with msg) when the value is invalid.
static bool apply_setting(demo_opts_t *o, setting_id_t id, const char *v, char *msg, size_t msg_len)
{
    vd_detector_cfg_t *cfg = &o->cfg;
    bool on = false;
    double d, d2;
    uint32_t u = 0, u2 = 0;
    bool ok = true;
    switch (id) {
    case SET_THR_MODE:
        if (strcmp(v, "constant") == 0) {
            cfg->thr_mode = VD_DETECTOR_THR_CONSTANT;
        } else if (strcmp(v, "adaptive") == 0) {
            cfg->thr_mode = VD_DETECTOR_THR_ADAPTIVE;
        } else {
            ok = false;
        }
        break;
    case SET_HOT_THR:
        ok = parse_u32(v, 1, 255, &u);
        cfg->hot_thr_u8 = (uint8_t)u;
        break;
    case SET_HOT_THR_C:
        ok = parse_double(v, -273.0, 380.0, &d);
        if (ok) {
            cfg->hot_thr_ck = c_to_ck(d);
            ok = cfg->hot_thr_ck > 0;
        }
        break;
    case SET_ADAPT_PCT:
        ok = parse_double(v, 0.1, 100.0, &d) && q_of(d, 10.0, 0.1, 100.0, &u);
        cfg->adaptive_permille = (uint16_t)u;
        break;
    case SET_ADAPT_FLOOR:
        ok = parse_u32(v, 1, 255, &u);
        cfg->adaptive_floor_u8 = (uint8_t)u;
        break;
    case SET_CALIB:
        ok = parse_pair(v, ',', &d, &d2) && d > 0 && d < 32768.0 && fabs(d2) < 2e9;
        if (ok) {
            cfg->calib.gain_q16 = (int32_t)lround(d * 65536.0);
            cfg->calib.offset_ck = (int32_t)lround(d2);
            ok = cfg->calib.gain_q16 > 0;
        }
        break;
    case SET_GREY_RANGE_C:
        ok = parse_pair(v, ',', &d, &d2) && d < d2 && d > -273.0 && d2 < 380.0;
        if (ok) {
            cfg->grey_lo_ck = c_to_ck(d);
            cfg->grey_hi_ck = c_to_ck(d2);
        }
        break;
    case SET_MIN_AREA:
        ok = parse_u32(v, 1, 67108864u, &u);
        cfg->rules.min_area = u;
        break;
    case SET_MAX_AREA:
        ok = parse_u32(v, 0, 67108864u, &u);
        cfg->rules.max_area = u;
        break;
    case SET_ASPECT_MIN:
        ok = parse_double(v, 0.004, 255.0, &d) && q_of(d, 256.0, 0.004, 255.0, &u);
        cfg->rules.aspect_min_q8 = (uint16_t)u;
        break;
    case SET_ASPECT_MAX:
        ok = parse_double(v, 0.004, 255.0, &d) && q_of(d, 256.0, 0.004, 255.0, &u);
        cfg->rules.aspect_max_q8 = (uint16_t)u;
        break;
    case SET_EXPAND_W:
        ok = parse_double(v, 1.0, 8.0, &d) && q_of(d, 256.0, 1.0, 8.0, &u);
        cfg->expand_w_q8 = (uint16_t)u;
        break;
    case SET_EXPAND_H:
        ok = parse_double(v, 1.0, 8.0, &d) && q_of(d, 256.0, 1.0, 8.0, &u);
        cfg->expand_h_q8 = (uint16_t)u;
        break;
    case SET_MEDIAN:
        ok = parse_u32(v, 0, 5, &u) && (u == 0 || u == 3 || u == 5);
        cfg->median_ksize = (uint8_t)(u == 0 ? 1u : u);   // the detector's 1 = none
        break;
    case SET_EDGE_STEP:
        ok = parse_u32(v, 1, 255, &u);
        cfg->edge_step = (uint8_t)u;
        break;
    case SET_WINDOW:
        ok = parse_u32(v, 3, 255, &u) && (u % 2u) == 1u;
        cfg->window = (uint8_t)u;
        break;
    case SET_SCORE_THR:
        // score_q8 = p * 256 rounded, 1..255; p = 0 keeps everything (1/256)
        ok = parse_double(v, 0.0, 1.0, &d);
        if (ok) {
            long q = lround(d * 256.0);
            cfg->score_thr_q8 = (uint8_t)(q < 1 ? 1 : q > 255 ? 255 : q);
        }
        break;
    case SET_NMS_IOU:
        ok = parse_double(v, 0.0, 1.0, &d);
        if (ok) {
            long q = lround(d * 32768.0);
            cfg->nms_iou_q15 = (uint16_t)(q < 1 ? 1 : q);
        }
        break;
    case SET_MAX_COMPONENTS:
        ok = parse_u32(v, 1, 65535, &u);
        cfg->max_components = (uint16_t)u;
        break;
    case SET_MAX_CANDIDATES:
        ok = parse_u32(v, 1, 4096, &u);
        cfg->max_candidates = (uint16_t)u;
        o->max_candidates_set = ok;
        break;
    case SET_MAX_DETECTIONS:
        ok = parse_u32(v, 1, 4096, &u);
        cfg->max_detections = (uint16_t)u;
        o->max_detections_set = ok;
        break;
    case SET_MAX_REGION:
        ok = parse_size(v, &u, &u2) && u >= 16 && u2 >= 16 && u <= 65535 && u2 <= 65535;
        cfg->max_region_w = (uint16_t)u;
        cfg->max_region_h = (uint16_t)u2;
        break;
    case SET_TEMPORAL:
        ok = parse_switch(v, &on);
        cfg->temporal = ok ? on : cfg->temporal;
        break;
    case SET_MAX_TRACKS:
        ok = parse_u32(v, 1, 1024, &u);
        cfg->max_tracks = (uint16_t)u;
        break;
    case SET_TRACK_SIGMA_REL:
        if (strcmp(v, "off") == 0) {
            cfg->temporal_cfg.flags |= VD_TEMPORAL_FIXED_SIGMA;
            ok = true;
        } else {
            ok = parse_double(v, 1.0 / 256.0, 4.0, &d) && q_of(d, 256.0, 1.0 / 256.0, 4.0, &u);
            cfg->temporal_cfg.sigma_rel_q8 = (uint16_t)u;
            cfg->temporal_cfg.flags &= (uint8_t)~VD_TEMPORAL_FIXED_SIGMA;
        }
        break;
    case SET_TRACK_MOTION:
        ok = strcmp(v, "on") == 0 || strcmp(v, "velocity") == 0 || strcmp(v, "off") == 0;
        if (ok) {
            uint8_t fl = cfg->temporal_cfg.flags & (uint8_t)~(VD_TEMPORAL_NO_MOTION | VD_TEMPORAL_NO_GLOBAL);
            fl |= (strcmp(v, "off") == 0) ? (uint8_t)VD_TEMPORAL_NO_MOTION
                  : (strcmp(v, "velocity") == 0) ? (uint8_t)VD_TEMPORAL_NO_GLOBAL : (uint8_t)0u;
            cfg->temporal_cfg.flags = fl;
        }
        break;
    case SET_TRACK_RECOVER_NO_C:
        ok = parse_switch(v, &on);
        if (ok) {
            cfg->temporal_cfg.flags = on ? (uint8_t)(cfg->temporal_cfg.flags | VD_TEMPORAL_RECOVER_NO_C)
                                         : (uint8_t)(cfg->temporal_cfg.flags & (uint8_t)~VD_TEMPORAL_RECOVER_NO_C);
        }
        break;
    case SET_SOURCES: {
        char buf[128];
        uint32_t bits = 0;
        ok = strlen(v) < sizeof buf;
        if (ok) {
            snprintf(buf, sizeof buf, "%s", v);
            char *save = NULL;
            for (char *t = strtok_r(buf, ",+", &save); t != NULL && ok; t = strtok_r(NULL, ",+", &save)) {
                if (strcmp(t, "hotspot") == 0) {
                    bits |= VD_DETECTOR_SRC_HOTSPOT;
                } else if (strcmp(t, "contrast") == 0) {
                    bits |= VD_DETECTOR_SRC_CONTRAST;
                } else if (strcmp(t, "window") == 0 || strcmp(t, "windows") == 0) {
                    bits |= VD_DETECTOR_SRC_WINDOW;
                } else if (strcmp(t, "all") == 0) {
                    bits |= VD_DETECTOR_SRC_ALL;
                } else if (strcmp(t, "cnn") == 0) {
                    bits |= VD_DETECTOR_SRC_CNN;
                } else {
                    ok = false;
                }
            }
        }
        ok = ok && bits != 0;
        cfg->sources = (uint8_t)bits;
        o->sources_set = ok;
        break;
    }
    case SET_DEDUP_IOU:
        ok = parse_double(v, 0.0, 1.0, &d);
        if (ok) {
            long q = lround(d * 32768.0);
            cfg->dedup_iou_q15 = (uint16_t)(q < 1 ? 1 : q);
        }
        break;
    case SET_WIN_PRESET:
        ok = apply_window_preset(&cfg->windows, v);
        break;
    case SET_WIN_BANDS:
        ok = parse_bands(v, &cfg->windows);
        break;
    case SET_WIN_HORIZON:
        ok = parse_double(v, -(double)VD_MAX_DIM, (double)VD_MAX_DIM, &d) && d == floor(d);
        cfg->windows.horizon_y = ok ? (int32_t)d : cfg->windows.horizon_y;
        break;
    case SET_WIN_GROUND:
        d2 = 2.0;
        ok = parse_pair(v, ',', &d, &d2) || parse_double(v, 0.0, 255.0, &d);
        ok = ok && d >= 0.0 && d <= 255.0 && d2 >= 1.0 && d2 <= 16.0;
        if (ok) {
            cfg->windows.ground_k_q8 = (uint16_t)lround(d * 256.0);
            cfg->windows.ground_tol_q8 = (uint16_t)lround(d2 * 256.0);
        }
        break;
    case SET_WIN_ASPECTS: {
        vd_windows_cfg_t t = cfg->windows;
        t.n_aspects = 0;
        const char *p = v;
        while (ok && *p != '\0') {
            char *end = NULL;
            d = strtod(p, &end);
            ok = end != p && t.n_aspects < VD_WINDOWS_MAX_ASPECTS && d >= 0.25 && d <= 4.0;
            if (ok) {
                t.aspect_q8[t.n_aspects++] = (uint16_t)lround(d * 256.0);
                p = (*end == ',') ? end + 1 : end;
                ok = (*end == ',' || *end == '\0');
            }
        }
        ok = ok && t.n_aspects > 0;
        if (ok) {
            cfg->windows = t;
        }
        break;
    }
    case SET_WIN_STRIDE:
        ok = parse_double(v, 0.0625, 2.0, &d) && q_of(d, 256.0, 0.0625, 2.0, &u);
        cfg->windows.stride_q8 = ok ? (uint16_t)u : cfg->windows.stride_q8;
        break;
    case SET_WIN_STEP:
        ok = parse_double(v, 1.125, 4.0, &d) && q_of(d, 256.0, 1.125, 4.0, &u);
        cfg->windows.scale_step_q8 = ok ? (uint16_t)u : cfg->windows.scale_step_q8;
        break;
    case SET_WIN_MIN_STD:
        ok = parse_u32(v, 1, 255, &u);
        cfg->win_min_std_u8 = ok ? (uint8_t)u : cfg->win_min_std_u8;
        break;
    case SET_CONTRAST_RADIUS:
        ok = parse_u32(v, 1, VD_CONTRAST_MAX_RADIUS, &u);
        cfg->contrast.radius = ok ? (uint16_t)u : cfg->contrast.radius;
        break;
    case SET_CONTRAST_THR:
        ok = parse_u32(v, 1, 255, &u);
        cfg->contrast.thr_u8 = ok ? (uint8_t)u : cfg->contrast.thr_u8;
        break;
    case SET_CONTRAST_POLARITY:
        if (strcmp(v, "both") == 0) {
            cfg->contrast.polarity = VD_CONTRAST_BOTH;
        } else if (strcmp(v, "warm") == 0) {
            cfg->contrast.polarity = VD_CONTRAST_WARM;
        } else if (strcmp(v, "cold") == 0) {
            cfg->contrast.polarity = VD_CONTRAST_COLD;
        } else {
            ok = false;
        }
        break;
    case SET_CNN_MODEL:
        ok = keep_path(v, o->cnn_model_buf, sizeof o->cnn_model_buf, &o->cnn_model);
        break;
    case SET_CNN_MODEL2:
        ok = keep_path(v, o->cnn_model2_buf, sizeof o->cnn_model2_buf, &o->cnn_model2);
        break;
    case SET_CNN_THR:
        // Q15; p = 0 keeps every box (1/32768: 0 would mean the model's threshold)
        ok = parse_double(v, 0.0, 1.0, &d);
        if (ok) {
            long q = lround(d * 32768.0);
            cfg->cnn_score_thr_q15 = (uint16_t)(q < 1 ? 1 : q);
        }
        break;
    case SET_CNN_RESCORE:
        ok = parse_switch(v, &on);
        cfg->cnn_rescore = ok ? (uint8_t)on : cfg->cnn_rescore;
        break;
    case SET_CNN_FLIP:
        ok = parse_switch(v, &on);
        cfg->cnn_flip = ok ? (uint8_t)on : cfg->cnn_flip;
        break;
    case SET_VERIFIER:
        ok = strcmp(v, "dbn") == 0 || strcmp(v, "boost") == 0;
        cfg->verifier = (ok && v[0] == 'b') ? (uint8_t)VD_DETECTOR_VERIFIER_BOOST : cfg->verifier;
        cfg->verifier = (ok && v[0] == 'd') ? (uint8_t)VD_DETECTOR_VERIFIER_DBN : cfg->verifier;
        break;
    case SET_BOOST_OFFSET: {
        int32_t off = 0;
        ok = parse_i32(v, -16777216, 16777216, &off);
        cfg->boost_thr_offset = ok ? off : cfg->boost_thr_offset;
        break;
    }
    case SET_BOOST_MODEL:
        ok = keep_path(v, o->boost_model_buf, sizeof o->boost_model_buf, &o->boost_model);
        break;
    default:
        ok = false;
        break;
    }
    if (!ok) {
        snprintf(msg, msg_len, "bad value '%s' for %s (expected %s)", v, k_settings[id].name, k_settings[id].arg);
    }
    return ok;
}

static int find_setting(const char *name)
{
    char norm[64];
    size_t l = strlen(name);
    if (l >= sizeof norm) {
        return -1;
    }
    for (size_t i = 0; i <= l; i++) {
        norm[i] = name[i] == '_' ? '-' : name[i];
    }
    for (int i = 0; i < SET_COUNT; i++) {
        if (strcmp(norm, k_settings[i].name) == 0) {
            return i;
        }
    }
    return -1;
}

static bool load_config(demo_opts_t *o, const char *path, char *msg, size_t msg_len)
{
    char *text = NULL;
    size_t len = 0;
    char err[512];
    if (demo_read_file(path, 1u << 20, &text, &len, err, sizeof err) != VD_OK) {
        snprintf(msg, msg_len, "--config: %s", err);
        return false;
    }
    demo_json_t d;
    if (demo_json_parse(&d, text, len, err, sizeof err) != VD_OK) {
        snprintf(msg, msg_len, "--config %s: %s", path, err);
        free(text);
        return false;
    }
    bool ok = true;
    if (d.n == 0 || d.tok[0].type != DEMO_JSON_OBJECT) {
        snprintf(msg, msg_len, "--config %s: expected a JSON object of settings", path);
        ok = false;
    }
    uint32_t k = 1;
    for (uint32_t i = 0; ok && i < d.tok[0].size && k + 1u < d.n; i++) {
        char key[64], val[128];
        if (!demo_json_string(&d, k, key, sizeof key)) {
            snprintf(msg, msg_len, "--config %s: key too long", path);
            ok = false;
            break;
        }
        int id = find_setting(key);
        const demo_json_tok_t *t = &d.tok[k + 1u];
        if (id < 0) {
            snprintf(msg, msg_len, "--config %s: unknown setting \"%s\" (see --help)", path, key);
            ok = false;
            break;
        }
        if (t->type == DEMO_JSON_STRING) {
            ok = demo_json_string(&d, k + 1u, val, sizeof val);
        } else if (t->type == DEMO_JSON_NUMBER && t->len < sizeof val) {
            memcpy(val, text + t->start, t->len);
            val[t->len] = '\0';
        } else if (t->type == DEMO_JSON_TRUE || t->type == DEMO_JSON_FALSE) {
            snprintf(val, sizeof val, "%s", t->type == DEMO_JSON_TRUE ? "on" : "off");
        } else {
            ok = false;
        }
        if (!ok) {
            snprintf(msg, msg_len, "--config %s: \"%s\" needs a number or string", path, key);
            break;
        }
        char m2[256];
        if (!apply_setting(o, (setting_id_t)id, val, m2, sizeof m2)) {
            snprintf(msg, msg_len, "--config %s: %s", path, m2);
            ok = false;
            break;
        }
        k = t->next;
    }
    demo_json_free(&d);
    free(text);
    return ok;
}

static int usage_error(FILE *errf, const char *fmt, const char *a, const char *b)
{
    fprintf(errf, "vd_fir_demo: error: ");
    fprintf(errf, fmt, a, b);
    fprintf(errf, " (%s; see --help)\n", vd_status_str(VD_ERR_ARG));
    return -1;
}

int demo_args_parse(demo_opts_t *o, int argc, char **argv)
{
    return demo_args_parse_to(o, argc, argv, stdout, stderr);
}

int demo_args_parse_to(demo_opts_t *o, int argc, char **argv, FILE *out, FILE *errf)
{
    memset(o, 0, sizeof *o);
    o->input = VD_DEMO_DEFAULT_INPUT;
    o->input_default = true;
    o->clip_eval = VD_DEMO_HIT_CLIP_DIR "/annotations.json";
    const char *clip_input = NULL;   // --clip's frames; applied after the first pass
    o->raw_format = VD_PIX_U16;
    o->timeout_ms = 2000;
    o->scores = true;
    vd_detector_cfg_default(&o->cfg);
    o->cfg.temporal = true;
    o->cfg.cnn_flip = 1u;   // the shipped operating point (docs/results/detector.md): fused flip pass at the header's threshold
    const char *config = NULL;
    // First pass: everything but detector settings, and find --config.
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            demo_args_usage(out);
            return 1;
        }
        bool flag_only = strcmp(a, "--quiet") == 0 || strcmp(a, "--no-scores") == 0;
        if (flag_only) {
            if (a[2] == 'q') {
                o->quiet = true;
            } else {
                o->scores = false;
            }
            continue;
        }
        if (strncmp(a, "--", 2) != 0) {
            return usage_error(errf, "unexpected argument '%s'%s", a, "");
        }
        const int sid = find_setting(a + 2);
        if (is_switch(sid) && strchr(a + 2, '_') == NULL) {
            bool on;
            if (i + 1 < argc && parse_switch(argv[i + 1], &on)) {
                i++;   // its optional value; applied in the second pass
            }
            continue;
        }
        if (i + 1 >= argc) {
            return usage_error(errf, "%s needs a value%s", a, "");
        }
        const char *v = argv[++i];
        const char *n = a + 2;
        if (strcmp(n, "input") == 0) {
            o->input = v;
            o->input_default = false;
        } else if (strcmp(n, "clip") == 0) {
            if (strcmp(v, "hit-uav") == 0) {
                o->clip_eval = VD_DEMO_HIT_CLIP_DIR "/annotations.json";
            } else if (strcmp(v, "synthetic") == 0 || strcmp(v, "synthetic-u8") == 0) {
                o->clip_eval = VD_DEMO_CLIP_DIR "/annotations.json";
            } else {
                return usage_error(errf, "bad --clip '%s'%s (expected hit-uav, synthetic or synthetic-u8)", v, "");
            }
            clip_input = strcmp(v, "hit-uav") == 0 ? VD_DEMO_DEFAULT_INPUT
                            : strcmp(v, "synthetic") == 0 ? VD_DEMO_CLIP_DIR "/u16"
                                                          : VD_DEMO_CLIP_DIR "/u8";
        } else if (strcmp(n, "model") == 0) {
            o->model = v;
        } else if (strcmp(n, "out") == 0) {
            o->out_dir = v;
        } else if (strcmp(n, "json") == 0) {
            o->json = v;
        } else if (strcmp(n, "eval") == 0) {
            o->eval = v;
        } else if (strcmp(n, "classes") == 0) {
            o->classes = v;
        } else if (strcmp(n, "eval-out") == 0) {
            o->eval_out = v;
        } else if (strcmp(n, "report") == 0) {
            o->report = v;
        } else if (strcmp(n, "config") == 0) {
            config = v;
        } else if (strcmp(n, "raw-size") == 0) {
            if (!parse_size(v, &o->raw_w, &o->raw_h)) {
                return usage_error(errf, "bad --raw-size '%s'%s (expected WxH)", v, "");
            }
        } else if (strcmp(n, "raw-format") == 0) {
            if (strcmp(v, "u16") == 0) {
                o->raw_format = VD_PIX_U16;
            } else if (strcmp(v, "u16be") == 0) {
                o->raw_format = VD_PIX_U16;
                o->raw_big_endian = true;
            } else if (strcmp(v, "u8") == 0) {
                o->raw_format = VD_PIX_U8;
            } else {
                return usage_error(errf, "bad --raw-format '%s'%s (expected u16, u16be or u8)", v, "");
            }
        } else if (strcmp(n, "device-size") == 0) {
            if (!parse_size(v, &o->dev_w, &o->dev_h)) {
                return usage_error(errf, "bad --device-size '%s'%s (expected WxH)", v, "");
            }
        } else if (strcmp(n, "fps") == 0) {
            if (!parse_u32(v, 1, 1000, &o->fps)) {
                return usage_error(errf, "bad --fps '%s'%s", v, "");
            }
        } else if (strcmp(n, "pixfmt") == 0) {
            if (strcmp(v, "grey") == 0 || strcmp(v, "gray") == 0) {
                o->dev_format = VD_PIX_U8;
            } else if (strcmp(v, "y16") == 0) {
                o->dev_format = VD_PIX_U16;
            } else {
                return usage_error(errf, "bad --pixfmt '%s'%s (expected grey or y16)", v, "");
            }
        } else if (strcmp(n, "timeout-ms") == 0) {
            uint32_t t;
            if (!parse_u32(v, 1, 3600000u, &t)) {
                return usage_error(errf, "bad --timeout-ms '%s'%s", v, "");
            }
            o->timeout_ms = (int32_t)t;
        } else if (strcmp(n, "frames") == 0) {
            uint32_t t;
            if (!parse_u32(v, 1, UINT32_MAX, &t)) {
                return usage_error(errf, "bad --frames '%s'%s", v, "");
            }
            o->max_frames = t;
        } else if (strchr(n, '_') != NULL || find_setting(n) < 0) {
            return usage_error(errf, "unknown option '%s'%s", a, "");
        }
    }
    if (clip_input != NULL) {
        if (!o->input_default) {
            return usage_error(errf, "--clip chooses a bundled clip: not with --input%s%s", "", "");
        }
        o->input = clip_input;
    }
    if (!o->input_default) {
        o->clip_eval = NULL;
    }
    char msg[600];
    if (config != NULL && !load_config(o, config, msg, sizeof msg)) {
        fprintf(errf, "vd_fir_demo: error: %s (%s)\n", msg, vd_status_str(VD_ERR_FORMAT));
        return -1;
    }
    // Second pass: detector setting flags override the config file.
    for (int i = 1; i < argc; i++) {
        if (strncmp(argv[i], "--", 2) != 0) {
            continue;
        }
        if (strcmp(argv[i], "--quiet") == 0 || strcmp(argv[i], "--no-scores") == 0) {
            continue;
        }
        int id = find_setting(argv[i] + 2);
        if (is_switch(id)) {
            bool on;
            const char *v = (i + 1 < argc && parse_switch(argv[i + 1], &on)) ? argv[++i] : "on";
            if (!apply_setting(o, (setting_id_t)id, v, msg, sizeof msg)) {
                return usage_error(errf, "%s%s", msg, "");
            }
            continue;
        }
        if (i + 1 >= argc) {
            break;   // the first pass made sure every other option has its value
        }
        if (id >= 0 && !apply_setting(o, (setting_id_t)id, argv[i + 1], msg, sizeof msg)) {
            return usage_error(errf, "%s%s", msg, "");
        }
        i++;   // skip the value
    }
    if (o->eval == NULL && !o->input_default && (o->classes != NULL || o->eval_out != NULL)) {
        return usage_error(errf, "--classes and --eval-out need --eval%s%s", "", "");
    }
    return 0;
}
