// SPDX-License-Identifier: MIT
// vd_fir_demo's detector settings: one table row per setting (name, value in --help, help text,
// how its value is read and where it is stored) and the small interpreter that applies a row.
//
// Each setting has a flag "--name VALUE" and the same key in the --config file ("name" or
// "name_with_underscores"); args.c applies the config file first and the flags after it, so flags
// win. Most rows are one of a few kinds (an integer or a decimal in a range stored as a fixed-point
// integer, a name out of a list, a switch, a model path); the rest name their own parser. A value
// is checked whole before anything is stored: a rejected value leaves the run unstarted (the
// caller stops at the first error), so no partly applied setting is ever used.
#include "settings.h"

#include "json.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

// --- values --------------------------------------------------------------------------------------

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

bool demo_parse_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *out)
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

bool demo_parse_size(const char *s, uint32_t *w, uint32_t *h)
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

bool demo_parse_switch(const char *v, bool *on)
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

// --- settings with a parser of their own ----------------------------------------------------------

static bool set_hot_thr_c(demo_opts_t *o, const char *v)
{
    double d;
    if (!parse_double(v, -273.0, 380.0, &d) || c_to_ck(d) <= 0) {
        return false;
    }
    o->cfg.hot_thr_ck = c_to_ck(d);
    return true;
}

static bool set_calib(demo_opts_t *o, const char *v)
{
    double d, d2;
    if (!(parse_pair(v, ',', &d, &d2) && d > 0 && d < 32768.0 && fabs(d2) < 2e9) || lround(d * 65536.0) <= 0) {
        return false;
    }
    o->cfg.calib.gain_q16 = (int32_t)lround(d * 65536.0);
    o->cfg.calib.offset_ck = (int32_t)lround(d2);
    return true;
}

static bool set_grey_range_c(demo_opts_t *o, const char *v)
{
    double d, d2;
    if (!(parse_pair(v, ',', &d, &d2) && d < d2 && d > -273.0 && d2 < 380.0)) {
        return false;
    }
    o->cfg.grey_lo_ck = c_to_ck(d);
    o->cfg.grey_hi_ck = c_to_ck(d2);
    return true;
}

static bool set_grey_window(demo_opts_t *o, const char *v)
{
    const bool frame = strcmp(v, "frame") == 0;
    if (!frame && strcmp(v, "fixed") != 0 && strcmp(v, "auto") != 0) {
        return false;
    }
    o->grey_window_auto = strcmp(v, "auto") == 0;
    o->cfg.grey_mode = frame ? VD_DETECTOR_GREY_PERCENTILE : VD_DETECTOR_GREY_FIXED;   // auto: fixed until chosen
    return true;
}

static bool set_median(demo_opts_t *o, const char *v)
{
    uint32_t u = 0;
    if (!(demo_parse_u32(v, 0, 5, &u) && (u == 0 || u == 3 || u == 5))) {
        return false;
    }
    o->cfg.median_ksize = (uint8_t)(u == 0 ? 1u : u);   // the detector's 1 = none
    return true;
}

static bool set_window(demo_opts_t *o, const char *v)
{
    uint32_t u = 0;
    if (!(demo_parse_u32(v, 3, 255, &u) && (u % 2u) == 1u)) {
        return false;
    }
    o->cfg.window = (uint8_t)u;
    return true;
}

static bool set_max_region(demo_opts_t *o, const char *v)
{
    uint32_t w = 0, h = 0;
    if (!(demo_parse_size(v, &w, &h) && w >= 16 && h >= 16 && w <= 65535 && h <= 65535)) {
        return false;
    }
    o->cfg.max_region_w = (uint16_t)w;
    o->cfg.max_region_h = (uint16_t)h;
    return true;
}

static bool set_track_sigma_rel(demo_opts_t *o, const char *v)
{
    vd_temporal_cfg_t *t = &o->cfg.temporal_cfg;
    if (strcmp(v, "off") == 0) {
        t->flags |= VD_TEMPORAL_FIXED_SIGMA;
        return true;
    }
    double d;
    if (!parse_double(v, 1.0 / 256.0, 4.0, &d)) {
        return false;
    }
    t->sigma_rel_q8 = (uint16_t)lround(d * 256.0);
    t->flags &= (uint8_t)~VD_TEMPORAL_FIXED_SIGMA;
    return true;
}

// on/off (and the rest of a switch's words) or auto: vd_fir_demo measures at which resolution the networks'
// boxes on 64 frames spread over a recording rate higher (common/flipagree.c; tools/demo/autores.c).
static bool set_cnn_full_res(demo_opts_t *o, const char *v)
{
    bool on = false;
    if (strcmp(v, "auto") == 0) {
        o->cnn_res_auto = true;
        o->cfg.cnn_res = VD_DETECTOR_CNN_RES_HALF;   // until the choice is made
        return true;
    }
    if (!demo_parse_switch(v, &on)) {
        return false;
    }
    o->cnn_res_auto = false;
    o->cfg.cnn_res = on ? VD_DETECTOR_CNN_RES_FULL : VD_DETECTOR_CNN_RES_HALF;
    return true;
}

const char *demo_cnn_res_name(unsigned res)
{
    static const char *const names[] = {"half", "full", "quarter"};   // VD_DETECTOR_CNN_RES_* in order
    return res <= VD_DETECTOR_CNN_RES_QUARTER ? names[res] : "?";
}

const char *demo_polarity_name(unsigned invert)
{
    return invert != 0u ? "black-hot" : "white-hot";
}

// half/full/quarter (cfg.cnn_res) or auto (the measurement of --cnn-full-res auto, which chooses among them).
static bool set_cnn_res(demo_opts_t *o, const char *v)
{
    if (strcmp(v, "auto") == 0) {
        return set_cnn_full_res(o, v);
    }
    for (uint8_t i = 0u; i <= VD_DETECTOR_CNN_RES_QUARTER; i++) {
        if (strcmp(v, demo_cnn_res_name(i)) == 0) {
            o->cnn_res_auto = false;
            o->cfg.cnn_res = i;
            return true;
        }
    }
    return false;
}

// white-hot, black-hot (cfg.cnn_invert) or auto: vd_fir_demo rates the networks' boxes on the frames as they are
// and inverted, in the measurement of --cnn-full-res auto (common/flipagree.c).
static bool set_cnn_polarity(demo_opts_t *o, const char *v)
{
    if (strcmp(v, "auto") == 0) {
        o->cnn_polarity_auto = true;
        o->cfg.cnn_invert = 0u;   // white-hot until the choice is made
        return true;
    }
    for (uint8_t i = 0u; i < 2u; i++) {
        if (strcmp(v, demo_polarity_name(i)) == 0) {
            o->cnn_polarity_auto = false;
            o->cfg.cnn_invert = i;
            return true;
        }
    }
    return false;
}

// "HI" or "HI,LO": the track-score hysteresis of confirmation, 0 < LO <= HI <= 1 (Q15). LO left out keeps
// the default's gap (0.42 / 0.35) below HI, so one number moves the whole band.
static bool set_track_confirm(demo_opts_t *o, const char *v)
{
    double hi, lo;
    if (!parse_pair(v, ',', &hi, &lo)) {
        if (!parse_double(v, 1.0 / 32768.0, 1.0, &hi)) {
            return false;
        }
        lo = hi - 0.07;
        lo = (lo < 1.0 / 32768.0) ? 1.0 / 32768.0 : lo;
    }
    if (hi < 1.0 / 32768.0 || hi > 1.0 || lo < 1.0 / 32768.0 || lo > hi) {
        return false;
    }
    o->cfg.temporal_cfg.confirm_hi_q15 = (uint16_t)lround(hi * 32768.0);
    o->cfg.temporal_cfg.confirm_lo_q15 = (uint16_t)lround(lo * 32768.0);
    return true;
}

// "hotspot,cnn" (or with '+'): the union of the named sources, at least one.
static bool set_sources(demo_opts_t *o, const char *v)
{
    char buf[128];
    uint32_t bits = 0;
    if (strlen(v) >= sizeof buf) {
        return false;
    }
    snprintf(buf, sizeof buf, "%s", v);
    char *save = NULL;
    for (char *t = strtok_r(buf, ",+", &save); t != NULL; t = strtok_r(NULL, ",+", &save)) {
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
            return false;
        }
    }
    if (bits == 0) {
        return false;
    }
    o->cfg.sources = (uint8_t)bits;
    return true;
}

static bool set_window_preset(demo_opts_t *o, const char *v)
{
    return apply_window_preset(&o->cfg.windows, v);
}

static bool set_window_bands(demo_opts_t *o, const char *v)
{
    return parse_bands(v, &o->cfg.windows);
}

static bool set_window_horizon(demo_opts_t *o, const char *v)
{
    double d;
    if (!(parse_double(v, -(double)VD_MAX_DIM, (double)VD_MAX_DIM, &d) && d == floor(d))) {
        return false;
    }
    o->cfg.windows.horizon_y = (int32_t)d;
    return true;
}

// "K" or "K,TOL" (TOL 2 when left out).
static bool set_window_ground(demo_opts_t *o, const char *v)
{
    double d = 0.0, d2 = 2.0;
    bool ok = parse_pair(v, ',', &d, &d2) || parse_double(v, 0.0, 255.0, &d);
    if (!(ok && d >= 0.0 && d <= 255.0 && d2 >= 1.0 && d2 <= 16.0)) {
        return false;
    }
    o->cfg.windows.ground_k_q8 = (uint16_t)lround(d * 256.0);
    o->cfg.windows.ground_tol_q8 = (uint16_t)lround(d2 * 256.0);
    return true;
}

// "R[,R...]": up to VD_WINDOWS_MAX_ASPECTS ratios 0.25..4.
static bool set_window_aspects(demo_opts_t *o, const char *v)
{
    vd_windows_cfg_t t = o->cfg.windows;
    t.n_aspects = 0;
    const char *p = v;
    while (*p != '\0') {
        char *end = NULL;
        double d = strtod(p, &end);
        if (!(end != p && t.n_aspects < VD_WINDOWS_MAX_ASPECTS && d >= 0.25 && d <= 4.0)) {
            return false;
        }
        t.aspect_q8[t.n_aspects++] = (uint16_t)lround(d * 256.0);
        p = (*end == ',') ? end + 1 : end;
        if (*end != ',' && *end != '\0') {
            return false;
        }
    }
    if (t.n_aspects == 0) {
        return false;
    }
    o->cfg.windows = t;
    return true;
}

// --- the table -------------------------------------------------------------------------------------

typedef enum kind {
    K_INT,      // an integer in [lo, hi] (signed for an I32 field), stored as it is
    K_FIXED,    // a decimal in [lo, hi], stored as lround(value * scale) clamped to [qlo, qhi]
    K_ENUM,     // one name of `names`, stored as its value (into the bits of `mask` when it is not 0)
    K_SWITCH,   // on/off, true/false, 1/0, stored as 1/0 (or the bits of `mask` set/cleared)
    K_PATH,     // a model file: copied into the buffer at `aux` (a config file's text is freed)
    K_CUSTOM    // its own parser
} kind_t;

typedef enum field_type { U8, U16, U32, I32, BOOL } field_type_t;

typedef struct named_value {
    const char *name;
    uint32_t value;
} named_value_t;

typedef struct setting {
    const char *name;   // flag --name; config key name or name_with_underscores
    const char *arg;    // the value as --help and the error text show it
    const char *help;
    kind_t kind;
    field_type_t type;  // of the field at `field`
    size_t field;       // offsetof(demo_opts_t, ...) of the value set
    size_t aux;         // K_PATH: offsetof the path's buffer (DEMO_PATH_MAX bytes)
    double lo, hi;      // K_INT, K_FIXED: accepted values
    double scale;       // K_FIXED
    long qlo, qhi;      // K_FIXED: bounds of the stored integer
    uint32_t mask;      // K_ENUM, K_SWITCH: the bits of a flags field this setting owns (0 = all)
    const named_value_t *names;                    // K_ENUM, ended by a NULL name
    bool (*parse)(demo_opts_t *o, const char *v);  // K_CUSTOM
    size_t mark;        // offsetof a bool set when a value is taken; 0 (= .input, no bool) for none
    bool optional;      // a switch whose value may be left out on the command line (= on)
    const char *word;   // an optional setting's value besides a switch's words (cnn-full-res: "auto"), or NULL
} setting_t;

#define CFG(f) offsetof(demo_opts_t, cfg.f)
#define INT(t, f, l, h) .kind = K_INT, .type = t, .field = CFG(f), .lo = (l), .hi = (h)
#define FIXED(t, f, l, h, s, ql, qh) \
    .kind = K_FIXED, .type = t, .field = CFG(f), .lo = (l), .hi = (h), .scale = (s), .qlo = (ql), .qhi = (qh)
#define ENUM(t, f, n) .kind = K_ENUM, .type = t, .field = CFG(f), .names = (n)
#define ENUM_BITS(f, m, n) .kind = K_ENUM, .type = U8, .field = CFG(f), .mask = (m), .names = (n)
#define SWITCH(t, f, m) .kind = K_SWITCH, .type = t, .field = CFG(f), .mask = (m)
#define PATH(f) .kind = K_PATH, .field = offsetof(demo_opts_t, f), .aux = offsetof(demo_opts_t, f##_buf)
#define CUSTOM(fn) .kind = K_CUSTOM, .parse = (fn)
#define MARK(f) .mark = offsetof(demo_opts_t, f)
#define OPTIONAL_VALUE .optional = true
#define OPTIONAL_OR(w) .optional = true, .word = (w)

static const named_value_t k_thr_modes[] = {
    {"constant", VD_DETECTOR_THR_CONSTANT}, {"adaptive", VD_DETECTOR_THR_ADAPTIVE}, {NULL, 0}};
static const named_value_t k_track_motions[] = {
    {"on", 0u}, {"velocity", VD_TEMPORAL_NO_GLOBAL}, {"off", VD_TEMPORAL_NO_MOTION}, {NULL, 0}};
static const named_value_t k_polarities[] = {
    {"both", VD_CONTRAST_BOTH}, {"warm", VD_CONTRAST_WARM}, {"cold", VD_CONTRAST_COLD}, {NULL, 0}};
static const named_value_t k_verifiers[] = {
    {"dbn", VD_DETECTOR_VERIFIER_DBN}, {"boost", VD_DETECTOR_VERIFIER_BOOST}, {NULL, 0}};

// In --help order.
static const setting_t k_settings[] = {
    {"thr-mode", "constant|adaptive",
     "hot-spot threshold: constant (paper, default; radiometric or fixed-gain cameras and "
     "bright drone video) or adaptive (8-bit dark road video: a frame percentile, never below "
     "--adaptive-floor)",
     ENUM(U8, thr_mode, k_thr_modes)},
    {"hot-thr", "U8", "8-bit constant threshold, hot = pixel >= U8 (default 150, paper)",
     INT(U8, hot_thr_u8, 1, 255)},
    {"hot-thr-c", "DEGC", "16-bit frames: threshold in degrees Celsius (default 30.00)",
     CUSTOM(set_hot_thr_c)},
    {"adaptive-percentile", "P", "adaptive mode: frame percentile 0.1..100 (default 99)",
     FIXED(U16, adaptive_permille, 0.1, 100.0, 10.0, 0, 65535)},
    {"adaptive-floor", "U8", "adaptive mode: lowest threshold (default 96)",
     INT(U8, adaptive_floor_u8, 1, 255)},
    {"calib", "GAIN,OFFSET_CK",
     "16-bit frames: centi-kelvin = OFFSET_CK + raw * GAIN (default 1,0: TLinear 0.01 K)",
     CUSTOM(set_calib)},
    {"grey-range-c", "LO,HI",
     "16-bit frames: degC mapped to grey 0 and 255 for refinement and drawing "
     "(default threshold-30, threshold+21)",
     CUSTOM(set_grey_range_c)},
    {"grey-window", "auto|fixed|frame",
     "16-bit frames: fixed maps the --grey-range-c temperatures to grey (a radiometric camera); "
     "frame maps each frame's own --grey-tail percentiles (raw counts of a camera that is not "
     "radiometric); auto (default): fixed unless 90 % of the first 16-bit frame's samples lie "
     "outside its window, then frame (docs/demo.md, \"16-bit frames\")",
     CUSTOM(set_grey_window)},
    {"grey-tail", "PCT",
     "--grey-window frame: percent of each frame's samples at grey 0 and at 255, each end, "
     "0.1..49.9 (default 0.1)",
     FIXED(U16, grey_tail_permille, 0.1, 49.9, 10.0, 1, 499)},
    {"min-area", "PX", "rule: smallest hot region in pixels (default 120, paper)",
     INT(U32, rules.min_area, 1, 67108864)},
    {"max-area", "PX", "rule: largest hot region, 0 = no limit (default 0)",
     INT(U32, rules.max_area, 0, 67108864)},
    {"aspect-min", "R", "rule: smallest height/width of a hot region (default 0.3, paper)",
     FIXED(U16, rules.aspect_min_q8, 0.004, 255.0, 256.0, 0, 65535)},
    {"aspect-max", "R", "rule: largest height/width of a hot region (default 1.5, paper)",
     FIXED(U16, rules.aspect_max_q8, 0.004, 255.0, 256.0, 0, 65535)},
    {"expand-w", "F", "candidate expansion horizontally, 1..8 (default 1.5, paper)",
     FIXED(U16, expand_w_q8, 1.0, 8.0, 256.0, 0, 65535)},
    {"expand-h", "F", "candidate expansion vertically, 1..8 (default 2, paper)",
     FIXED(U16, expand_h_q8, 1.0, 8.0, 256.0, 0, 65535)},
    {"median", "0|3|5", "refinement median filter size, 0 = none (default 3)",
     CUSTOM(set_median)},
    {"edge-step", "N", "refinement: local threshold at every N-th edge point (default 5)",
     INT(U8, edge_step, 1, 255)},
    {"window", "N", "refinement: local window size, odd (default 5)",
     CUSTOM(set_window)},
    {"score-thr", "S", "DBN: keep candidates with p(vehicle) >= S, 0..1 (default 0.5)",
     FIXED(U8, score_thr_q8, 0.0, 1.0, 256.0, 1, 255)},
    {"nms-iou", "F", "suppress a box overlapping a better one by IoU > F (default 0.5)",
     FIXED(U16, nms_iou_q15, 0.0, 1.0, 32768.0, 1, 32768)},
    {"max-components", "N", "components labelled per frame (default 256)",
     INT(U16, max_components, 1, 65535)},
    {"max-candidates", "N", "candidates verified per frame (default 64)",
     INT(U16, max_candidates, 1, 4096), MARK(max_candidates_set)},
    {"max-detections", "N", "detections kept per frame (default 32)",
     INT(U16, max_detections, 1, 4096), MARK(max_detections_set)},
    {"max-region", "WxH", "refinement region bound; larger regions are decimated (default: the detector's, 176x176)",
     CUSTOM(set_max_region)},
    {"temporal", "on|off",
     "temporal analysis: track ids, confirmed / recovered states (default on)",
     SWITCH(BOOL, temporal, 0)},
    {"max-tracks", "N", "temporal track table size (default 32)",
     INT(U16, max_tracks, 1, 1024)},
    {"track-sigma-rel", "F|off",
     "temporal: association sigmas = max(16 px, F x box side), 0.004..4 (default 1.5); "
     "off = the paper's fixed 16 px",
     CUSTOM(set_track_sigma_rel)},
    {"track-motion", "on|velocity|off",
     "temporal: predict tracks by the frame's global motion and their velocity (on, "
     "default), velocity only, or not at all (off, the paper's)",
     ENUM_BITS(temporal_cfg.flags, VD_TEMPORAL_NO_MOTION | VD_TEMPORAL_NO_GLOBAL, k_track_motions)},
    {"track-scores", "on|off",
     "temporal: track-aware scores (each box's score fused with its track's, confirmed by the track score "
     "with hysteresis; default on, off = paper 000's confirmation after 3 frames)",
     SWITCH(U8, temporal_cfg.flags, VD_TEMPORAL_SCORES)},
    {"track-confirm", "HI[,LO]",
     "temporal, track scores: a track is confirmed when its score reaches HI and stays so until it falls "
     "below LO, 0 < LO <= HI <= 1 (default 0.42,0.35; LO left out: HI - 0.07)",
     CUSTOM(set_track_confirm)},
    {"track-coast", "N",
     "temporal, track scores: output a confirmed track missed for up to N frames at its predicted box as "
     "recovered, with its decaying score, 0..255 (default 0)",
     INT(U8, temporal_cfg.coast_frames, 0, 255)},
    {"track-recover-unmeasured", "on|off",
     "temporal: also run recovery for tracks without a complexity (CNN "
     "detections; default off: it finds edge-free background)",
     SWITCH(U8, temporal_cfg.flags, VD_TEMPORAL_RECOVER_NO_C)},
    {"sources", "LIST",
     "candidate sources, comma separated: hotspot, contrast, window, all (= the three of the "
     "paper pipeline) and cnn (the int8 network), e.g. hotspot,cnn; all sources share "
     "--max-candidates. Default: cnn when a CNN model is at hand (--cnn-model, a version-3 "
     "--model, or models/vd_cnn.vdm when no --model is given), else hotspot (the paper's)",
     CUSTOM(set_sources), MARK(sources_set)},
    {"dedup-iou", "F",
     "merge: drop a hot-spot/contrast/window candidate overlapping an earlier one (CNN boxes "
     "come first) by IoU > F (default 0.7)",
     FIXED(U16, dedup_iou_q15, 0.0, 1.0, 32768.0, 1, 32768)},
    {"window-preset", "msrs|hit|table1",
     "window bands for a mounting: msrs = road level 640x480 (horizon 230, ground slope 1.6, "
     "x2 tolerance, Table 1 bands), hit = drone (heights 12..120 everywhere, half stride), "
     "table1 = Table 1 sizes everywhere; give it before other --window-* flags",
     CUSTOM(set_window_preset)},
    {"window-bands", "Y0:Y1:H0:H1[,...]",
     "up to 4 bands: windows whose bottom row is in Y0..Y1 have heights H0..H1 px "
     "(default one band, every row, 10..200)",
     CUSTOM(set_window_bands)},
    {"window-horizon", "ROW", "ground model: horizon row (with --window-ground)",
     CUSTOM(set_window_horizon)},
    {"window-ground", "K[,TOL]",
     "ground model: expected height K px per row below the horizon, tolerance factor TOL "
     "(default 2); 0 = off (default)",
     CUSTOM(set_window_ground)},
    {"window-aspects", "R[,R...]", "window height/width ratios, up to 4 (default 1)",
     CUSTOM(set_window_aspects)},
    {"window-stride", "F", "window step as a fraction of its size, 0.0625..2 (default 0.25)",
     FIXED(U16, windows.stride_q8, 0.0625, 2.0, 256.0, 0, 65535)},
    {"window-step", "F", "ratio of successive window heights, 1.125..4 (default 1.25)",
     FIXED(U16, windows.scale_step_q8, 1.125, 4.0, 256.0, 0, 65535)},
    {"window-min-std", "U8",
     "window pre-filter: keep windows whose 4x4-cell means vary by a standard deviation "
     ">= U8 grey levels (default 4); the highest ones fill the candidate budget",
     INT(U8, win_min_std_u8, 1, 255)},
    {"contrast-radius", "N", "contrast source: box half-size 1..127 (default 16)",
     INT(U16, contrast.radius, 1, VD_CONTRAST_MAX_RADIUS)},
    {"contrast-thr", "U8", "contrast source: |I - local mean| threshold (default 24)",
     INT(U8, contrast.thr_u8, 1, 255)},
    {"contrast-polarity", "both|warm|cold",
     "contrast source: which direction counts (default both)",
     ENUM(U8, contrast.polarity, k_polarities)},
    {"cnn-model", "FILE",
     "cnn source: version-3 .vdm network (default: --model if it is one, else "
     "models/vd_cnn.vdm)",
     PATH(cnn_model)},
    {"cnn-thr", "P",
     "cnn source: keep boxes with network score >= P, 0..1 (default: the model's own threshold; "
     "with --cnn-model2, the second network's)",
     FIXED(U16, cnn_score_thr_q15, 0.0, 1.0, 32768.0, 1, 32768)},
    {"cnn-rescore", "[on|off]",
     "cnn source: the DBN also scores each network box (whole box, as windows) and keeps it "
     "at >= --score-thr; the score is then the DBN's (needs a DBN model; default off)",
     SWITCH(U8, cnn_rescore, 0), OPTIONAL_VALUE},
    {"cnn-flip", "[on|off]",
     "cnn source: run the network a second time on the mirrored half-resolution frame and "
     "fuse its boxes, mirrored back, with the first pass's (pairs averaged, the rest at half "
     "score, fused scores below the score threshold dropped) before overlap suppression (test-time "
     "augmentation: about twice the network's time; default on, chosen on the val split)",
     SWITCH(U8, cnn_flip, 0), OPTIONAL_VALUE},
    {"cnn-full-res", "[on|off|auto]",
     "cnn source: the networks read the frame at full resolution instead of half (for a camera "
     "whose vehicles are about half the size of the training data's, e.g. a wider lens: 4x the "
     "networks' time and a larger workspace). auto (default): half, full or quarter (--cnn-res), "
     "whichever the networks' boxes rate highest at (mean score + flip agreement / 4) on 64 frames "
     "spread over the recording (docs/demo.md; a camera's first 32 as they come); half under 16 frames",
     CUSTOM(set_cnn_full_res), OPTIONAL_OR("auto")},
    {"cnn-res", "half|full|quarter|auto",
     "cnn source: the networks' input resolution: half (the frame's 2x2 box averages, the scale they trained "
     "at), full (= --cnn-full-res on), quarter (4x4 box averages, for a camera whose vehicles are about twice "
     "the training data's size, e.g. a 1280x1024 sensor or a narrower lens: a quarter of the networks' time) "
     "or auto (= --cnn-full-res auto, which chooses among the three)",
     CUSTOM(set_cnn_res)},
    {"cnn-polarity", "white-hot|black-hot|auto",
     "cnn source: white-hot (warm is bright, as the networks trained), black-hot (a camera set to show warm as "
     "dark: the networks read each input value v as 255 - v; as they are, such frames cost the networks most of "
     "their AP) or auto (default): the polarity whose boxes rate higher on the frames --cnn-full-res "
     "auto measures, black-hot only by a margin (docs/demo.md \"Black-hot cameras\")",
     CUSTOM(set_cnn_polarity)},
    {"cnn-model2", "FILE|none",
     "cnn source: a second version-3 .vdm network run on the same frame, its boxes fused with "
     "the first network's as the flip pass fuses (an ensemble: about the second network's time "
     "again; default models/vd_cnn2.vdm with the default --cnn-model, none otherwise; 'none' "
     "= one network)",
     PATH(cnn_model2)},
    {"verifier", "dbn|boost",
     "verifier of hot-spot/contrast/window (and re-scored cnn) candidates: dbn (default, --model) "
     "or boost (paper 003's boosted CNN-feature stumps, --boost-model)",
     ENUM(U8, verifier, k_verifiers)},
    {"boost-model", "FILE",
     "--verifier boost: version-4 .vdm (default models/vd_boost.vdm)",
     PATH(boost_model)},
    {"boost-offset", "N",
     "--verifier boost: keep candidates with score >= the model's threshold + N "
     "(integer, -16777216..16777216; default 0; negative values for PR curves)",
     INT(I32, boost_thr_offset, -16777216, 16777216)},
};
#define SET_COUNT (sizeof k_settings / sizeof k_settings[0])

// --- the interpreter -------------------------------------------------------------------------------

static void store(demo_opts_t *o, const setting_t *s, int64_t v)
{
    unsigned char *p = (unsigned char *)o + s->field;
    switch (s->type) {
    case U8: {
        uint8_t x = (uint8_t)v;
        memcpy(p, &x, sizeof x);
        break;
    }
    case U16: {
        uint16_t x = (uint16_t)v;
        memcpy(p, &x, sizeof x);
        break;
    }
    case U32: {
        uint32_t x = (uint32_t)v;
        memcpy(p, &x, sizeof x);
        break;
    }
    case I32: {
        int32_t x = (int32_t)v;
        memcpy(p, &x, sizeof x);
        break;
    }
    case BOOL: {
        bool x = v != 0;
        memcpy(p, &x, sizeof x);
        break;
    }
    }
}

// Sets or clears `bits` of the U8 flags field of s, leaving its other bits.
static void store_bits(demo_opts_t *o, const setting_t *s, uint32_t bits)
{
    uint8_t *p = (uint8_t *)o + s->field;
    *p = (uint8_t)((*p & (uint8_t)~s->mask) | (bits & s->mask));
}

static bool apply_int(demo_opts_t *o, const setting_t *s, const char *v)
{
    if (s->type == I32) {
        int32_t x = 0;
        if (!parse_i32(v, (int32_t)s->lo, (int32_t)s->hi, &x)) {
            return false;
        }
        store(o, s, x);
        return true;
    }
    uint32_t x = 0;
    if (!demo_parse_u32(v, (uint32_t)s->lo, (uint32_t)s->hi, &x)) {
        return false;
    }
    store(o, s, x);
    return true;
}

static bool apply_fixed(demo_opts_t *o, const setting_t *s, const char *v)
{
    double d;
    if (!parse_double(v, s->lo, s->hi, &d)) {
        return false;
    }
    long q = lround(d * s->scale);
    store(o, s, q < s->qlo ? s->qlo : q > s->qhi ? s->qhi : q);
    return true;
}

static bool apply_enum(demo_opts_t *o, const setting_t *s, const char *v)
{
    for (const named_value_t *n = s->names; n->name != NULL; n++) {
        if (strcmp(v, n->name) == 0) {
            if (s->mask != 0u) {
                store_bits(o, s, n->value);
            } else {
                store(o, s, n->value);
            }
            return true;
        }
    }
    return false;
}

static bool apply_switch(demo_opts_t *o, const setting_t *s, const char *v)
{
    bool on = false;
    if (!demo_parse_switch(v, &on)) {
        return false;
    }
    if (s->mask != 0u) {
        store_bits(o, s, on ? s->mask : 0u);
    } else {
        store(o, s, on);
    }
    return true;
}

static bool apply_path(demo_opts_t *o, const setting_t *s, const char *v)
{
    if (v[0] == '\0' || strlen(v) >= DEMO_PATH_MAX) {
        return false;
    }
    char *buf = (char *)o + s->aux;
    const char *copy = buf;
    snprintf(buf, DEMO_PATH_MAX, "%s", v);
    memcpy((unsigned char *)o + s->field, &copy, sizeof copy);
    return true;
}

bool demo_setting_value_ok(int id, const char *v)
{
    bool on = false;
    if (id < 0 || (size_t)id >= SET_COUNT || !k_settings[id].optional) {
        return false;
    }
    const char *w = k_settings[id].word;
    return (w != NULL && strcmp(v, w) == 0) || demo_parse_switch(v, &on);
}

bool demo_setting_is_switch(int id)
{
    return id >= 0 && (size_t)id < SET_COUNT && k_settings[id].optional;
}

bool demo_setting_apply(demo_opts_t *o, int id, const char *v, char *msg, size_t msg_len)
{
    if (id < 0 || (size_t)id >= SET_COUNT) {
        snprintf(msg, msg_len, "internal: no setting %d", id);
        return false;
    }
    const setting_t *s = &k_settings[id];
    bool ok = false;
    switch (s->kind) {
    case K_INT:
        ok = apply_int(o, s, v);
        break;
    case K_FIXED:
        ok = apply_fixed(o, s, v);
        break;
    case K_ENUM:
        ok = apply_enum(o, s, v);
        break;
    case K_SWITCH:
        ok = apply_switch(o, s, v);
        break;
    case K_PATH:
        ok = apply_path(o, s, v);
        break;
    case K_CUSTOM:
        ok = s->parse(o, v);
        break;
    }
    if (!ok) {
        snprintf(msg, msg_len, "bad value '%s' for %s (expected %s)", v, s->name, s->arg);
        return false;
    }
    if (s->mark != 0u) {
        const bool taken = true;
        memcpy((unsigned char *)o + s->mark, &taken, sizeof taken);
    }
    return true;
}

// Names are compared with '_' read as '-', so a config key may use either.
int demo_setting_find(const char *name)
{
    char norm[64];
    size_t l = strlen(name);
    if (l >= sizeof norm) {
        return -1;
    }
    for (size_t i = 0; i <= l; i++) {
        norm[i] = name[i] == '_' ? '-' : name[i];
    }
    for (size_t i = 0; i < SET_COUNT; i++) {
        if (strcmp(norm, k_settings[i].name) == 0) {
            return (int)i;
        }
    }
    return -1;
}

void demo_settings_usage(FILE *f)
{
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
}

bool demo_settings_load(demo_opts_t *o, const char *path, char *msg, size_t msg_len)
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
        int id = demo_setting_find(key);
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
        if (!demo_setting_apply(o, id, val, m2, sizeof m2)) {
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
