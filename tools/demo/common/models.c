// SPDX-License-Identifier: MIT
// Model resolution and loading shared by vd_fir_demo and the GStreamer element vdfir
// (one set of rules, docs/demo.md "Which sources by default"), and the detector
// settings both derive for a frame size.
#include "models.h"

#include "json.h"

#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define MODEL_MAX_BYTES (64u * 1024u * 1024u)

// Format version of a .vdm file (little-endian u16 at offset 4; 0 if unreadable):
// 1-2 DBN, 3 CNN (VD_CNN_FORMAT_VERSION).
static uint32_t vdm_version_of_file(const char *path)
{
    uint8_t h[6];
    FILE *fp = fopen(path, "rb");
    if (fp == NULL) {
        return 0u;
    }
    size_t n = fread(h, 1, sizeof h, fp);
    fclose(fp);
    return n == sizeof h ? (uint32_t)h[4] | ((uint32_t)h[5] << 8) : 0u;
}

static uint32_t vdm_version(const uint8_t *b, size_t len)
{
    return len >= 6u ? (uint32_t)b[4] | ((uint32_t)b[5] << 8) : 0u;
}

static bool file_exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 && S_ISREG(sb.st_mode);
}

// DBN with --model omitted: models/vd_dbn_grey.vdm (the best full model,
// models/README.md), else the first DBN *.vdm (by name) of models_dir.
static bool find_default_model(const char *models_dir, char *out, size_t cap)
{
    snprintf(out, cap, "%s/vd_dbn_grey.vdm", models_dir);
    if (file_exists(out)) {
        return true;
    }
    DIR *dp = opendir(models_dir);
    if (dp == NULL) {
        return false;
    }
    char best[1024] = "";
    struct dirent *de;
    while ((de = readdir(dp)) != NULL) {
        size_t l = strlen(de->d_name);
        if (l > 4 && strcmp(de->d_name + l - 4, ".vdm") == 0 && de->d_name[0] != '.' &&
            (best[0] == '\0' || strcmp(de->d_name, best) < 0) && l < sizeof best) {
            char p[4096];
            snprintf(p, sizeof p, "%s/%s", models_dir, de->d_name);
            const uint32_t v = vdm_version_of_file(p);
            if (v == 1u || v == 2u) {
                memcpy(best, de->d_name, l + 1);
            }
        }
    }
    closedir(dp);
    if (best[0] == '\0') {
        return false;
    }
    snprintf(out, cap, "%s/%s", models_dir, best);
    return true;
}

// Reads a model file whole (malloc'd; NUL-terminated, so 8-byte aligned).
static vd_status_t read_model(const char *opt, const char *path, uint8_t **blob, size_t *len, char *err,
                              size_t err_len)
{
    char *b = NULL;
    char e[600];
    vd_status_t st = demo_read_file(path, MODEL_MAX_BYTES, &b, len, e, sizeof e);
    if (st != VD_OK) {
        snprintf(err, err_len, "%s: %s", opt, e);
        return st == VD_ERR_RANGE ? VD_ERR_MODEL : st;
    }
    *blob = (uint8_t *)b;
    return VD_OK;
}

// --model as given: its file, read first (malloc'd until a source takes it), and its kind.
typedef struct model_arg {
    const char *path;   // NULL when not given
    bool none;          // --model none
    uint8_t *blob;
    size_t len;
    bool is_cnn;        // a version-3 file: taken as the CNN
} model_arg_t;

// --verifier boost: the boosted CNN-feature verifier (paper 003) instead of the DBN.
static vd_status_t load_boost(demo_models_t *m, demo_opts_t *o, const char *models_dir, char *err, size_t err_len)
{
    char path[4096];
    size_t blen = 0;
    if (o->boost_model != NULL) {
        snprintf(path, sizeof path, "%s", o->boost_model);
    } else {
        snprintf(path, sizeof path, "%s/vd_boost.vdm", models_dir);
    }
    vd_status_t st = read_model("--boost-model", path, &m->boost_blob, &blen, err, err_len);
    if (st == VD_OK) {
        st = vd_boost_load(&m->boost, m->boost_blob, blen);
        if (st != VD_OK) {
            snprintf(err, err_len, "--boost-model %s: not a valid boosted .vdm model (version 4)", path);
        }
    }
    if (st == VD_OK) {
        o->cfg.boost_model = &m->boost;
    }
    return st;
}

// The host's speed-up (vd_cnn_prepare): the network's weights packed once for this CPU's kernels instead of
// per band of rows, the same detections (docs/performance.md). Without the memory the run is only slower.
static vd_status_t prepare_cnn(vd_cnn_model_t *cnn, void **buf)
{
    size_t n = 0u;
    vd_status_t st = vd_cnn_prepared_size(cnn, &n);
    if (st != VD_OK || n == 0u) {
        return st;
    }
    if (posix_memalign(buf, 64, n) != 0) {   // 64: a multiple of VD_WORKSPACE_ALIGN, the kernels' cache lines
        *buf = NULL;
        return VD_OK;
    }
    return vd_cnn_prepare(cnn, *buf, n);
}

// The second network: --cnn-model2, or models/vd_cnn2.vdm next to the default first network
// (the shipped pair, docs/results/detector.md); 'none' keeps one.
static vd_status_t load_cnn2(demo_models_t *m, demo_opts_t *o, const model_arg_t *ma, const char *models_dir,
                             char *err, size_t err_len)
{
    char def_cnn2[4096];
    snprintf(def_cnn2, sizeof def_cnn2, "%s/vd_cnn2.vdm", models_dir);
    const bool def_pair = o->cnn_model == NULL && !ma->is_cnn && file_exists(def_cnn2);
    if (!((o->cnn_model2 != NULL && strcmp(o->cnn_model2, "none") != 0) || (o->cnn_model2 == NULL && def_pair))) {
        return VD_OK;
    }
    size_t len2 = 0;
    snprintf(m->cnn2_path, sizeof m->cnn2_path, "%s", o->cnn_model2 != NULL ? o->cnn_model2 : def_cnn2);
    vd_status_t st = read_model("--cnn-model2", m->cnn2_path, &m->cnn2_blob, &len2, err, err_len);
    if (st == VD_OK) {
        st = vd_cnn_load(&m->cnn2, m->cnn2_blob, len2);
        if (st != VD_OK) {
            snprintf(err, err_len, "--cnn-model2 %s: not a valid CNN .vdm model (version 3)", m->cnn2_path);
        } else if ((st = prepare_cnn(&m->cnn2, &m->cnn2_prep)) != VD_OK) {
            snprintf(err, err_len, "--cnn-model2 %s: vd_cnn_prepare: %s", m->cnn2_path, vd_status_str(st));
        }
    }
    if (st == VD_OK) {
        m->have_cnn2 = true;
        o->cfg.cnn_model2 = &m->cnn2;
    }
    return st;
}

// Room for every decoded box unless set: the model's top-K, twice that with --cnn-flip (its fusion
// yields up to one box per box of either pass); and the paper sources' 64. Detections after
// suppression: top-K also with --cnn-flip (the best by score; more is reported as a capacity hit),
// which keeps the demo's workspace with temporal analysis under 256 KiB at 640x512.
// With a second network (cfg.cnn_model2) the larger top-K as candidates and the library's 32
// detections: the fused boxes above the threshold are far fewer than the decoded ones (at most 26
// vehicles in a frame of ../shared/data), and room for every box of four passes (2 x (100 + 80))
// would take the workspace to 275 920 B; with these budgets it is 261 536 B, under 256 KiB
// (docs/embedded.md). More is reported as a capacity hit (results valid).
static void cnn_budgets(const demo_models_t *m, demo_opts_t *o)
{
    uint32_t topk = m->cnn.max_peaks * (o->cfg.cnn_flip != 0u ? 2u : 1u);
    uint32_t md = m->cnn.max_peaks;
    if (m->have_cnn2) {
        topk = m->cnn.max_peaks > m->cnn2.max_peaks ? m->cnn.max_peaks : m->cnn2.max_peaks;
        md = 32u;
    }
    if (!o->max_candidates_set) {
        uint32_t mc = topk + (((o->cfg.sources & VD_DETECTOR_SRC_ALL) != 0u) ? 64u : 0u);
        o->cfg.max_candidates = (uint16_t)(mc > 4096u ? 4096u : mc);
    }
    if (!o->max_detections_set) {
        o->cfg.max_detections = (uint16_t)(md < o->cfg.max_candidates ? md : o->cfg.max_candidates);
    }
}

// The cnn source's network: --cnn-model, else a CNN --model (its file taken over), else
// models/vd_cnn.vdm; then the second network and the budgets.
static vd_status_t load_cnn(demo_models_t *m, demo_opts_t *o, model_arg_t *ma, const char *models_dir,
                            char *err, size_t err_len)
{
    char def_cnn[4096];
    snprintf(def_cnn, sizeof def_cnn, "%s/vd_cnn.vdm", models_dir);
    size_t clen = 0;
    const char *opt = "--cnn-model";
    vd_status_t st;
    if (o->cnn_model != NULL) {
        snprintf(m->cnn_path, sizeof m->cnn_path, "%s", o->cnn_model);
        st = read_model(opt, m->cnn_path, &m->cnn_blob, &clen, err, err_len);
    } else if (ma->is_cnn) {
        opt = "--model";
        snprintf(m->cnn_path, sizeof m->cnn_path, "%s", ma->path);
        m->cnn_blob = ma->blob;
        clen = ma->len;
        ma->blob = NULL;
        st = VD_OK;
    } else if (file_exists(def_cnn)) {
        snprintf(m->cnn_path, sizeof m->cnn_path, "%s", def_cnn);
        st = read_model(opt, m->cnn_path, &m->cnn_blob, &clen, err, err_len);
    } else {
        snprintf(err, err_len, "the cnn source needs a CNN model: --cnn-model FILE (%s not found)", def_cnn);
        st = VD_ERR_ARG;
    }
    if (st == VD_OK) {
        st = vd_cnn_load(&m->cnn, m->cnn_blob, clen);
        if (st != VD_OK) {
            snprintf(err, err_len, "%s %s: not a valid CNN .vdm model (version 3)", opt, m->cnn_path);
        } else if ((st = prepare_cnn(&m->cnn, &m->cnn_prep)) != VD_OK) {
            snprintf(err, err_len, "%s %s: vd_cnn_prepare: %s", opt, m->cnn_path, vd_status_str(st));
        }
    }
    if (st != VD_OK) {
        return st;
    }
    m->have_cnn = true;
    o->cfg.cnn_model = &m->cnn;
    st = load_cnn2(m, o, ma, models_dir, err, err_len);
    if (st == VD_OK) {
        cnn_budgets(m, o);
    }
    return st;
}

// The DBN: an explicit DBN --model is checked even when no source needs it (its file taken over);
// otherwise the default DBN when a source needs one and --model is not 'none'.
static vd_status_t load_dbn(demo_models_t *m, model_arg_t *ma, bool want_dbn, const char *models_dir, char *err,
                            size_t err_len)
{
    vd_status_t st;
    if (ma->blob != NULL && !ma->is_cnn) {
        snprintf(m->model_path, sizeof m->model_path, "%s", ma->path);
        m->model_blob = ma->blob;
        ma->blob = NULL;
        st = vd_dbn_load(&m->model, m->model_blob, ma->len);
        if (st != VD_OK) {
            snprintf(err, err_len, "--model %s: not a valid .vdm model", m->model_path);
            return st;
        }
        m->have_model = want_dbn;
    } else if (want_dbn && !ma->none && find_default_model(models_dir, m->model_path, sizeof m->model_path)) {
        size_t len = 0;
        st = read_model("--model", m->model_path, &m->model_blob, &len, err, err_len);
        if (st != VD_OK) {
            return st;
        }
        st = vd_dbn_load(&m->model, m->model_blob, len);
        if (st != VD_OK) {
            snprintf(err, err_len, "--model %s: not a valid .vdm model", m->model_path);
            return st;
        }
        m->have_model = true;
    }
    return VD_OK;
}

// The sources' models. --model is read first (a version-3 file is the CNN);
// without --sources the sources follow the models at hand; the CNN
// is --cnn-model, else a CNN --model, else models/vd_cnn.vdm; the DBN is
// loaded when a paper-pipeline source or --cnn-rescore needs it (and an
// explicit DBN --model is always checked).
vd_status_t demo_models_load(demo_models_t *m, demo_opts_t *o, const char *models_dir, char *err, size_t err_len)
{
    model_arg_t ma = {o->model, o->model != NULL && strcmp(o->model, "none") == 0, NULL, 0, false};
    vd_status_t st;
    if (ma.path != NULL && !ma.none) {
        st = read_model("--model", ma.path, &ma.blob, &ma.len, err, err_len);
        if (st != VD_OK) {
            return st;
        }
        ma.is_cnn = vdm_version(ma.blob, ma.len) == VD_CNN_FORMAT_VERSION;
    }
    if (!o->sources_set) {
        char def_cnn[4096];
        snprintf(def_cnn, sizeof def_cnn, "%s/vd_cnn.vdm", models_dir);
        const bool cnn = o->cnn_model != NULL || ma.is_cnn || (ma.path == NULL && file_exists(def_cnn));
        o->cfg.sources = cnn ? VD_DETECTOR_SRC_CNN : VD_DETECTOR_SRC_HOTSPOT;
    }
    const bool want_cnn = (o->cfg.sources & VD_DETECTOR_SRC_CNN) != 0u;
    const bool boost = o->cfg.verifier == VD_DETECTOR_VERIFIER_BOOST;
    const bool want_dbn =
        !boost && ((o->cfg.sources & VD_DETECTOR_SRC_ALL) != 0u || (want_cnn && o->cfg.cnn_rescore != 0u));
    st = boost ? load_boost(m, o, models_dir, err, err_len) : VD_OK;
    if (st == VD_OK && want_cnn) {
        st = load_cnn(m, o, &ma, models_dir, err, err_len);
    }
    if (st == VD_OK) {
        st = load_dbn(m, &ma, want_dbn, models_dir, err, err_len);
    }
    free(ma.blob);   // a CNN --model that no source uses, or the file of a failed load
    if (st == VD_OK && want_cnn && o->cfg.cnn_rescore != 0u && !m->have_model && !boost) {
        snprintf(err, err_len, "--cnn-rescore needs a DBN model (--model FILE)");
        return VD_ERR_ARG;
    }
    return st;
}

void demo_models_free(demo_models_t *m)
{
    free(m->model_blob);
    free(m->cnn_blob);
    free(m->cnn2_blob);
    free(m->cnn_prep);
    free(m->cnn2_prep);
    free(m->boost_blob);
    m->model_blob = NULL;
    m->cnn_blob = NULL;
    m->cnn2_blob = NULL;
    m->have_cnn2 = false;
    m->have_model = false;
    m->have_cnn = false;
}

void demo_detector_cfg(const demo_opts_t *o, uint32_t width, uint32_t height, vd_detector_cfg_t *cfg)
{
    *cfg = o->cfg;
    cfg->max_width = width;
    cfg->max_height = height;
    // The region bound may not exceed the frame (frames smaller than the default 176 x 176).
    cfg->max_region_w = (uint16_t)(cfg->max_region_w > width ? width : cfg->max_region_w);
    cfg->max_region_h = (uint16_t)(cfg->max_region_h > height ? height : cfg->max_region_h);
}

// Raw value of a temperature under calib (the inverse of vd_calib_ck_from_raw, clamped to 0..65535).
static uint32_t raw_of_ck(const vd_calib_t *c, int32_t ck)
{
    const double raw = ((double)ck - c->offset_ck) * 65536.0 / c->gain_q16;
    return raw < 0 ? 0u : raw > 65535.0 ? 65535u : (uint32_t)lround(raw);
}

void demo_grey_fixed_raw(const demo_opts_t *o, uint32_t *lo, uint32_t *hi)
{
    vd_detector_cfg_t c = o->cfg;
    c.cnn_model = NULL;   // only the grey fields matter here: the CNN is checked when the detector is made
    c.sources = 0u;
    if (vd_detector_cfg_resolve(&c) != VD_OK) {
        *lo = 0u;   // the detector will refuse these settings with its own message
        *hi = 65535u;
        return;
    }
    *lo = raw_of_ck(&c.calib, c.grey_lo_ck);
    *hi = raw_of_ck(&c.calib, c.grey_hi_ck);
    if (*hi <= *lo) {
        *hi = *lo + 1u;
    }
}

// Why: a camera that is not radiometric (raw counts, not TLinear 0.01 K) lands outside the fixed window, and its
// frames reach the networks as a flat black or white plane: almost no CNN box, without a word (docs/demo.md).
void demo_grey_decide(demo_opts_t *o, const vd_frame_t *f)
{
    if (o->grey_decided || f->format != VD_PIX_U16) {
        return;
    }
    o->grey_decided = true;
    uint32_t lo = 0u, hi = 0u;
    demo_grey_fixed_raw(o, &lo, &hi);
    uint64_t out = 0u;
    for (uint32_t y = 0; y < f->height; y++) {
        const uint16_t *row = (const uint16_t *)(const void *)((const uint8_t *)f->data + (size_t)y * f->stride);
        for (uint32_t x = 0; x < f->width; x++) {
            out += (row[x] < lo || row[x] > hi) ? 1u : 0u;
        }
    }
    const uint64_t n = (uint64_t)f->width * f->height;
    o->grey_outside_permille = n != 0u ? (uint32_t)((out * 1000u) / n) : 0u;
    if (o->grey_window_auto && o->grey_outside_permille >= DEMO_GREY_AUTO_PERMILLE) {
        o->cfg.grey_mode = VD_DETECTOR_GREY_PERCENTILE;
    }
}
