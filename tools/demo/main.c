// SPDX-License-Identifier: MIT
// vd_fir_demo: runs the vd detector on recorded frames or a V4L2 camera; writes annotated PNGs, JSON Lines, evaluation.
//
// Flow: options -> models (in place: vd_cnn_load for the cnn source, vd_dbn_load
// when a source needs the DBN; the default sources follow the models at hand)
// -> ground truth (--eval) ->
// capture (port/) -> per frame: vd_detector_run -> JSON line, drawing,
// matching -> summary. Every output is written under a temporary name
// (PNGs into a hidden staging directory inside --out) and renamed into place
// only after the whole run succeeded, so an error leaves no partial output.
// Any capture error on recorded input (missing/truncated/undecodable file,
// mixed sizes) ends the run with one line on stderr and exit status 1; usage
// errors exit with 2. See docs/demo.md.
#include "demo.h"

#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "vd/vd.h"
#include "vd_port/capture.h"
#include "vd_port/writer.h"

#ifndef VD_DEMO_MODELS_DIR
#define VD_DEMO_MODELS_DIR "models"
#endif
#define MODEL_MAX_BYTES (64u * 1024u * 1024u)
#define MAX_DEVICE_RETRIES 5

static const char *const k_stage_names[VD_DET_STAGE_COUNT] = {
    "threshold", "components", "refine", "contour", "sample", "dbn", "nms", "temporal", "contrast", "windows",
    "cnn", "total"};

typedef struct run {
    demo_opts_t o;
    bool device;
    vd_capture_t cap;
    uint8_t *model_blob;
    vd_model_t model;
    bool have_model;
    char model_path[4096];
    uint8_t *cnn_blob;
    vd_cnn_model_t cnn;
    bool have_cnn;
    char cnn_path[4096];
    uint8_t *boost_blob;     // --verifier boost
    vd_boost_model_t boost;
    vd_detector_t det;
    void *ws;
    bool det_ready;
    vd_detection_t *dets;
    size_t dets_cap;
    demo_det_t *eval_dets;
    vd_rect_t *cands;        // --eval: this frame's candidates before verification (max_candidates)
    size_t n_cands, cap_cands;
    demo_gt_t gt;
    bool have_gt;
    char eval_path[4096];
    demo_atomic_t json;
    bool json_open;
    char stage_dir[4200];
    bool staging;
    char created[2][4096];   // output directories this run created (removed again on failure if empty)
    char **staged;
    size_t n_staged, cap_staged;
    vd_rgb_t canvas;
    uint32_t *times[VD_DET_STAGE_COUNT + 1];   // + wall time per frame (I/O included)
    size_t n_times, cap_times;
    uint64_t frames, detections, capacity_warnings;
    uint32_t width, height;
    vd_pixfmt_t format;
    uint32_t grey_lo_raw, grey_hi_raw;
    char err[1024];
} run_t;

// Ctrl-C / SIGTERM end the run after the current frame; outputs are then
// committed as after the last frame of a recording.
static volatile sig_atomic_t g_stop = 0;

static void on_signal(int sig)
{
    (void)sig;
    g_stop = 1;
}

static uint32_t clock_us(void *user)
{
    (void)user;
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u);
}

// One error line: "vd_fir_demo: error: <detail> (<status text>)".
static int fail(run_t *r, vd_status_t st, const char *detail)
{
    (void)r;
    fprintf(stderr, "vd_fir_demo: error: %s (%s)\n", detail, vd_status_str(st));
    return 1;
}

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
// models/README.md), else the first DBN *.vdm (by name) of the source tree's models/.
static bool find_default_model(char *out, size_t cap)
{
    snprintf(out, cap, "%s/vd_dbn_grey.vdm", VD_DEMO_MODELS_DIR);
    if (file_exists(out)) {
        return true;
    }
    DIR *dp = opendir(VD_DEMO_MODELS_DIR);
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
            snprintf(p, sizeof p, "%s/%s", VD_DEMO_MODELS_DIR, de->d_name);
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
    snprintf(out, cap, "%s/%s", VD_DEMO_MODELS_DIR, best);
    return true;
}

// Reads a model file whole (malloc'd; NUL-terminated, so 8-byte aligned).
static vd_status_t read_model(run_t *r, const char *opt, const char *path, uint8_t **blob, size_t *len)
{
    char *b = NULL;
    char e[600];
    vd_status_t st = demo_read_file(path, MODEL_MAX_BYTES, &b, len, e, sizeof e);
    if (st != VD_OK) {
        snprintf(r->err, sizeof r->err, "%s: %s", opt, e);
        return st == VD_ERR_RANGE ? VD_ERR_MODEL : st;
    }
    *blob = (uint8_t *)b;
    return VD_OK;
}

// The sources' models. --model is read first (a version-3 file is the CNN);
// without --sources the sources follow the models at hand (demo.h); the CNN
// is --cnn-model, else a CNN --model, else models/vd_cnn.vdm; the DBN is
// loaded when a paper-pipeline source or --cnn-rescore needs it (and an
// explicit DBN --model is always checked).
static vd_status_t load_models(run_t *r)
{
    demo_opts_t *o = &r->o;
    const char *mp = o->model;
    const bool none = mp != NULL && strcmp(mp, "none") == 0;
    uint8_t *mblob = NULL;
    size_t mlen = 0;
    bool model_is_cnn = false;
    vd_status_t st;
    if (mp != NULL && !none) {
        st = read_model(r, "--model", mp, &mblob, &mlen);
        if (st != VD_OK) {
            return st;
        }
        model_is_cnn = vdm_version(mblob, mlen) == VD_CNN_FORMAT_VERSION;
    }
    char def_cnn[4096];
    snprintf(def_cnn, sizeof def_cnn, "%s/vd_cnn.vdm", VD_DEMO_MODELS_DIR);
    if (!o->sources_set) {
        const bool cnn = o->cnn_model != NULL || model_is_cnn || (mp == NULL && file_exists(def_cnn));
        o->cfg.sources = cnn ? VD_DETECTOR_SRC_CNN : VD_DETECTOR_SRC_HOTSPOT;
    }
    const bool want_cnn = (o->cfg.sources & VD_DETECTOR_SRC_CNN) != 0u;
    const bool boost = o->cfg.verifier == VD_DETECTOR_VERIFIER_BOOST;
    const bool want_dbn =
        !boost && ((o->cfg.sources & VD_DETECTOR_SRC_ALL) != 0u || (want_cnn && o->cfg.cnn_rescore != 0u));
    if (boost) {
        char path[4096];
        size_t blen = 0;
        if (o->boost_model != NULL) {
            snprintf(path, sizeof path, "%s", o->boost_model);
        } else {
            snprintf(path, sizeof path, "%s/vd_boost.vdm", VD_DEMO_MODELS_DIR);
        }
        st = read_model(r, "--boost-model", path, &r->boost_blob, &blen);
        if (st == VD_OK) {
            st = vd_boost_load(&r->boost, r->boost_blob, blen);
            if (st != VD_OK) {
                snprintf(r->err, sizeof r->err, "--boost-model %s: not a valid boosted .vdm model (version 4)", path);
            }
        }
        if (st != VD_OK) {
            free(mblob);
            return st;
        }
        o->cfg.boost_model = &r->boost;
    }
    if (want_cnn) {
        size_t clen = 0;
        const char *opt = "--cnn-model";
        if (o->cnn_model != NULL) {
            snprintf(r->cnn_path, sizeof r->cnn_path, "%s", o->cnn_model);
            st = read_model(r, opt, r->cnn_path, &r->cnn_blob, &clen);
        } else if (model_is_cnn) {
            opt = "--model";
            snprintf(r->cnn_path, sizeof r->cnn_path, "%s", mp);
            r->cnn_blob = mblob;
            clen = mlen;
            mblob = NULL;
            st = VD_OK;
        } else if (file_exists(def_cnn)) {
            snprintf(r->cnn_path, sizeof r->cnn_path, "%s", def_cnn);
            st = read_model(r, opt, r->cnn_path, &r->cnn_blob, &clen);
        } else {
            snprintf(r->err, sizeof r->err, "the cnn source needs a CNN model: --cnn-model FILE (%s not found)",
                     def_cnn);
            st = VD_ERR_ARG;
        }
        if (st == VD_OK) {
            st = vd_cnn_load(&r->cnn, r->cnn_blob, clen);
            if (st != VD_OK) {
                snprintf(r->err, sizeof r->err, "%s %s: not a valid CNN .vdm model (version 3)", opt, r->cnn_path);
            }
        }
        if (st != VD_OK) {
            free(mblob);
            return st;
        }
        r->have_cnn = true;
        o->cfg.cnn_model = &r->cnn;
        // Room for the model's top-K (and the paper sources' 64) unless set.
        if (!o->max_candidates_set) {
            uint32_t mc = r->cnn.max_peaks + (((o->cfg.sources & VD_DETECTOR_SRC_ALL) != 0u) ? 64u : 0u);
            o->cfg.max_candidates = (uint16_t)(mc > 4096u ? 4096u : mc);
        }
        if (!o->max_detections_set) {
            o->cfg.max_detections = (uint16_t)(r->cnn.max_peaks < o->cfg.max_candidates ? r->cnn.max_peaks
                                                                                      : o->cfg.max_candidates);
        }
    }
    // An explicit DBN --model is checked even when no source needs it.
    if (mblob != NULL && !model_is_cnn) {
        snprintf(r->model_path, sizeof r->model_path, "%s", mp);
        r->model_blob = mblob;
        mblob = NULL;
        st = vd_dbn_load(&r->model, r->model_blob, mlen);
        if (st != VD_OK) {
            snprintf(r->err, sizeof r->err, "--model %s: not a valid .vdm model", r->model_path);
            return st;
        }
        r->have_model = want_dbn;
    } else if (want_dbn && !none && find_default_model(r->model_path, sizeof r->model_path)) {
        size_t len = 0;
        st = read_model(r, "--model", r->model_path, &r->model_blob, &len);
        if (st != VD_OK) {
            free(mblob);
            return st;
        }
        st = vd_dbn_load(&r->model, r->model_blob, len);
        if (st != VD_OK) {
            snprintf(r->err, sizeof r->err, "--model %s: not a valid .vdm model", r->model_path);
            free(mblob);
            return st;
        }
        r->have_model = true;
    }
    free(mblob);   // a CNN --model that no source uses
    if (want_cnn && o->cfg.cnn_rescore != 0u && !r->have_model && !boost) {
        snprintf(r->err, sizeof r->err, "--cnn-rescore needs a DBN model (--model FILE)");
        return VD_ERR_ARG;
    }
    return VD_OK;
}

// "hotspot,cnn" etc. for the progress line.
static void sources_text(uint8_t bits, char *out, size_t cap)
{
    static const char *const names[4] = {"hotspot", "contrast", "window", "cnn"};
    out[0] = '\0';
    for (unsigned k = 0; k < 4u; k++) {
        if ((bits & (1u << k)) != 0u) {
            size_t l = strlen(out);
            snprintf(out + l, cap - l, "%s%s", l ? "," : "", names[k]);
        }
    }
}

static vd_status_t open_outputs(run_t *r)
{
    struct stat sb;
    if (r->o.out_dir != NULL) {
        if (stat(r->o.out_dir, &sb) != 0) {
            snprintf(r->created[0], sizeof r->created[0], "%s", r->o.out_dir);
        }
        vd_status_t st = demo_mkdirs(r->o.out_dir, r->err, sizeof r->err);
        if (st != VD_OK) {
            return st;
        }
        snprintf(r->stage_dir, sizeof r->stage_dir, "%s/.vd_fir_demo.tmp.%ld", r->o.out_dir, (long)getpid());
        if (mkdir(r->stage_dir, 0777) != 0) {
            snprintf(r->err, sizeof r->err, "cannot create %s: %s", r->stage_dir, strerror(errno));
            return VD_ERR_IO;
        }
        r->staging = true;
    }
    if (r->o.json != NULL) {
        char dir[4096];
        snprintf(dir, sizeof dir, "%s", r->o.json);
        char *slash = strrchr(dir, '/');
        if (slash != NULL && slash != dir) {
            *slash = '\0';
            if (stat(dir, &sb) != 0) {
                snprintf(r->created[1], sizeof r->created[1], "%s", dir);
            }
            vd_status_t st = demo_mkdirs(dir, r->err, sizeof r->err);
            if (st != VD_OK) {
                return st;
            }
        }
        vd_status_t st = demo_atomic_open(&r->json, r->o.json, r->err, sizeof r->err);
        if (st != VD_OK) {
            return st;
        }
        r->json_open = true;
    }
    return VD_OK;
}

// Removes everything this run wrote (error path).
static void discard_outputs(run_t *r)
{
    if (r->json_open) {
        demo_atomic_abort(&r->json);
        r->json_open = false;
    }
    if (r->staging) {
        char p[8400];
        for (size_t i = 0; i < r->n_staged; i++) {
            snprintf(p, sizeof p, "%s/%s", r->stage_dir, r->staged[i]);
            remove(p);
        }
        rmdir(r->stage_dir);
        r->staging = false;
    }
    for (int k = 1; k >= 0; k--) {
        if (r->created[k][0] != '\0') {
            rmdir(r->created[k]);   // only if still empty
        }
    }
}

static vd_status_t commit_outputs(run_t *r)
{
    if (r->json_open) {
        r->json_open = false;
        vd_status_t st = demo_atomic_commit(&r->json, r->err, sizeof r->err);
        if (st != VD_OK) {
            return st;
        }
    }
    if (r->staging) {
        char from[8400], to[8400];
        for (size_t i = 0; i < r->n_staged; i++) {
            snprintf(from, sizeof from, "%s/%s", r->stage_dir, r->staged[i]);
            snprintf(to, sizeof to, "%s/%s", r->o.out_dir, r->staged[i]);
            if (rename(from, to) != 0) {
                snprintf(r->err, sizeof r->err, "cannot rename %s to %s: %s", from, to, strerror(errno));
                return VD_ERR_IO;
            }
        }
        rmdir(r->stage_dir);
        r->staging = false;
    }
    return VD_OK;
}

static const char *state_name(uint8_t state)
{
    switch (state) {
    case VD_TRACK_CONFIRMED: return "confirmed";
    case VD_TRACK_RECOVERED: return "recovered";
    default: return "new";
    }
}

// The DESIGN.md names of vd_detection_t.source.
static const char *source_name(uint8_t source)
{
    if (source == VD_SOURCE_CNN) {
        return "cnn";
    }
    if (source == VD_SOURCE_WINDOW) {
        return "window";
    }
    if (source == VD_SOURCE_CONTRAST) {
        return "contrast";
    }
    return "hotspot";
}

static double score_of(const vd_detection_t *d)
{
    return d->score_q8 / 255.0;
}

// The frame's name in the JSON and for --eval: the file name, or "device:seq".
static void frame_name(run_t *r, const vd_frame_t *f, char *out, size_t cap)
{
    if (r->device) {
        snprintf(out, cap, "%s:%u", r->o.input, (unsigned)f->seq);
    } else {
        snprintf(out, cap, "%s", demo_basename(vd_capture_frame_name(&r->cap)));
    }
}

static void write_json_line(run_t *r, const char *name, const vd_frame_t *f, size_t n)
{
    FILE *jf = r->json.f;
    fputs("{\"frame\": ", jf);
    demo_json_write_string(jf, name);
    fprintf(jf, ", \"seq\": %u, \"width\": %u, \"height\": %u, \"detections\": [", (unsigned)f->seq,
            (unsigned)f->width, (unsigned)f->height);
    for (size_t i = 0; i < n; i++) {
        const vd_detection_t *d = &r->dets[i];
        fprintf(jf, "%s{\"box\": [%d, %d, %d, %d], \"score\": %.3f, \"track\": ", i ? ", " : "", (int)d->box.x,
                (int)d->box.y, (int)d->box.w, (int)d->box.h, score_of(d));
        if (d->track_id != 0 && d->state != VD_TRACK_NONE) {
            fprintf(jf, "%u", (unsigned)d->track_id);
        } else {
            fputs("null", jf);
        }
        fprintf(jf, ", \"source\": \"%s\", \"state\": \"%s\"}", source_name(d->source), state_name(d->state));
    }
    fputs("]}\n", jf);
}

static vd_status_t draw_frame(run_t *r, const char *name, const vd_frame_t *f, size_t n)
{
    vd_status_t st = vd_rgb_from_frame(&r->canvas, f, f->format == VD_PIX_U16 ? r->grey_lo_raw : 0,
                                       f->format == VD_PIX_U16 ? r->grey_hi_raw : 0);
    if (st != VD_OK) {
        snprintf(r->err, sizeof r->err, "%s: cannot render the frame", name);
        return st;
    }
    // Worst first so the best boxes end on top.
    for (size_t k = n; k-- > 0;) {
        const vd_detection_t *d = &r->dets[k];
        uint8_t cr = 255, cg = 255, cb = 0;   // new: yellow
        if (d->state == VD_TRACK_CONFIRMED) {
            cr = 0;
            cg = 255;
            cb = 0;
        } else if (d->state == VD_TRACK_RECOVERED) {
            cr = 255;
            cg = 0;
            cb = 255;
        }
        vd_rgb_draw_rect(&r->canvas, &d->box, cr, cg, cb, 2);
        if (r->o.scores) {
            char label[48];
            if (d->track_id != 0 && d->state != VD_TRACK_NONE) {
                snprintf(label, sizeof label, "#%u %.2f", (unsigned)d->track_id, score_of(d));
            } else {
                snprintf(label, sizeof label, "%.2f", score_of(d));
            }
            int32_t ty = d->box.y >= 13 ? d->box.y - 12 : d->box.y + d->box.h + 2;
            vd_rgb_draw_text(&r->canvas, d->box.x, ty, label, cr, cg, cb, 2);
        }
    }
    // PNG name: the frame's name with .png (device frames: frame_<seq>.png).
    char png[1100];
    if (r->device) {
        snprintf(png, sizeof png, "frame_%08u.png", (unsigned)f->seq);
    } else {
        snprintf(png, sizeof png, "%s", name);
        char *hash = strchr(png, '#');
        if (hash != NULL) {
            *hash = '_';
        } else {
            char *dot = strrchr(png, '.');
            if (dot != NULL && dot != png) {
                *dot = '\0';
            }
        }
        size_t l = strlen(png);
        snprintf(png + l, sizeof png - l, ".png");
    }
    char path[8400];
    snprintf(path, sizeof path, "%s/%s", r->stage_dir, png);
    char e[512];
    st = vd_write_png_rgb(path, &r->canvas, e, sizeof e);
    if (st != VD_OK) {
        snprintf(r->err, sizeof r->err, "%s", e);
        return st;
    }
    for (size_t i = 0; i < r->n_staged; i++) {
        if (strcmp(r->staged[i], png) == 0) {
            return VD_OK;   // same name again (e.g. a list naming a file twice): overwritten
        }
    }
    if (r->n_staged == r->cap_staged) {
        size_t nc = r->cap_staged ? r->cap_staged * 2 : 256;
        char **p = realloc(r->staged, nc * sizeof *p);
        if (p == NULL) {
            snprintf(r->err, sizeof r->err, "out of memory");
            return VD_ERR_IO;
        }
        r->staged = p;
        r->cap_staged = nc;
    }
    r->staged[r->n_staged] = strdup(png);
    if (r->staged[r->n_staged] == NULL) {
        snprintf(r->err, sizeof r->err, "out of memory");
        return VD_ERR_IO;
    }
    r->n_staged++;
    return VD_OK;
}

static uint32_t raw_of_ck(const vd_calib_t *c, int32_t ck)
{
    double raw = ((double)ck - c->offset_ck) * 65536.0 / c->gain_q16;
    return raw < 0 ? 0u : raw > 65535.0 ? 65535u : (uint32_t)lround(raw);
}

// Candidate observer (--eval): keeps the boxes the verifier will see.
static void on_candidate(void *user, const vd_detection_t *cand)
{
    run_t *r = user;
    if (r->n_cands < r->cap_cands) {
        r->cands[r->n_cands++] = cand->box;
    }
}

static vd_status_t init_detector(run_t *r, const vd_frame_t *f)
{
    vd_detector_cfg_t cfg = r->o.cfg;
    cfg.max_width = f->width;
    cfg.max_height = f->height;
    // The region bound may not exceed the frame (frames smaller than the default 176 x 176).
    cfg.max_region_w = (uint16_t)(cfg.max_region_w > f->width ? f->width : cfg.max_region_w);
    cfg.max_region_h = (uint16_t)(cfg.max_region_h > f->height ? f->height : cfg.max_region_h);
    cfg.clock_us = clock_us;
    cfg.clock_user = NULL;
    if (r->have_gt) {
        cfg.on_candidate = on_candidate;
        cfg.candidate_user = r;
    }
    size_t bytes = 0;
    const vd_model_t *m = r->have_model ? &r->model : NULL;
    vd_status_t st = vd_detector_workspace_size(&cfg, m, &bytes);
    if (st != VD_OK) {
        snprintf(r->err, sizeof r->err, "detector settings rejected for %ux%u frames", (unsigned)f->width,
                 (unsigned)f->height);
        return st;
    }
    if (posix_memalign(&r->ws, 64, bytes ? bytes : 1) != 0) {
        r->ws = NULL;
        snprintf(r->err, sizeof r->err, "out of memory (%zu bytes of detector workspace)", bytes);
        return VD_ERR_IO;
    }
    st = vd_detector_init(&r->det, &cfg, m, r->ws, bytes);
    if (st != VD_OK) {
        snprintf(r->err, sizeof r->err, "detector initialisation failed");
        return st;
    }
    r->dets_cap = (size_t)r->det.cfg.max_detections + r->det.cfg.max_tracks + 1u;
    r->dets = calloc(r->dets_cap, sizeof *r->dets);
    r->eval_dets = calloc(r->dets_cap, sizeof *r->eval_dets);
    r->cap_cands = r->det.cfg.max_candidates;
    r->cands = calloc(r->cap_cands + 1u, sizeof *r->cands);
    if (r->dets == NULL || r->eval_dets == NULL || r->cands == NULL) {
        snprintf(r->err, sizeof r->err, "out of memory");
        return VD_ERR_IO;
    }
    r->width = f->width;
    r->height = f->height;
    r->format = f->format;
    r->grey_lo_raw = raw_of_ck(&r->det.cfg.calib, r->det.cfg.grey_lo_ck);
    r->grey_hi_raw = raw_of_ck(&r->det.cfg.calib, r->det.cfg.grey_hi_ck);
    if (r->grey_hi_raw <= r->grey_lo_raw) {
        r->grey_hi_raw = r->grey_lo_raw + 1u;
    }
    if (r->staging) {
        st = vd_rgb_alloc(&r->canvas, f->width, f->height);
        if (st != VD_OK) {
            snprintf(r->err, sizeof r->err, "out of memory");
            return st;
        }
    }
    r->det_ready = true;
    return VD_OK;
}

// The hot-spot threshold the detector used on this frame (stats; the resolved
// setting when the hot-spot source is off; 65536 = nothing can be hot).
static uint32_t hot_threshold(const run_t *r, const vd_frame_t *f)
{
    const vd_detector_stats_t *s = vd_detector_last_stats(&r->det);
    if (f->format == VD_PIX_U16) {
        if (r->det.raw_never_hot) {
            return 65536u;
        }
        return s->hot_thr_raw != 0u ? s->hot_thr_raw : r->det.raw_thr;
    }
    return s->hot_thr_u8 != 0u ? s->hot_thr_u8 : r->det.cfg.hot_thr_u8;
}

static vd_status_t record_times(run_t *r, const vd_detector_stats_t *s, uint32_t wall_us)
{
    if (r->n_times == r->cap_times) {
        size_t nc = r->cap_times ? r->cap_times * 2 : 256;
        for (int k = 0; k <= VD_DET_STAGE_COUNT; k++) {
            uint32_t *p = realloc(r->times[k], nc * sizeof *p);
            if (p == NULL) {
                snprintf(r->err, sizeof r->err, "out of memory");
                return VD_ERR_IO;
            }
            r->times[k] = p;
        }
        r->cap_times = nc;
    }
    for (int k = 0; k < VD_DET_STAGE_COUNT; k++) {
        r->times[k][r->n_times] = s->time_us[k];
    }
    r->times[VD_DET_STAGE_COUNT][r->n_times] = wall_us;
    r->n_times++;
    return VD_OK;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

static double median_us(uint32_t *v, size_t n)
{
    if (n == 0) {
        return 0.0;
    }
    qsort(v, n, sizeof *v, cmp_u32);
    return n % 2 ? v[n / 2] : (v[n / 2 - 1] + (double)v[n / 2]) / 2.0;
}

static double sum_us(const uint32_t *v, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++) {
        s += v[i];
    }
    return s;
}

static void summary(run_t *r)
{
    double det_total = sum_us(r->times[VD_DET_STAGE_TOTAL], r->n_times);
    double wall_total = sum_us(r->times[VD_DET_STAGE_COUNT], r->n_times);
    printf("vd_fir_demo: %llu frames, %llu detections; %.1f fps (detector), %.1f fps (with I/O and outputs)\n",
           (unsigned long long)r->frames, (unsigned long long)r->detections,
           det_total > 0 ? (double)r->frames * 1e6 / det_total : 0.0,
           wall_total > 0 ? (double)r->frames * 1e6 / wall_total : 0.0);
    if (r->n_times > 0) {
        printf("median time per frame (ms):");
        for (int k = 0; k < VD_DET_STAGE_COUNT; k++) {
            printf(" %s %.2f%s", k_stage_names[k], median_us(r->times[k], r->n_times) / 1000.0,
                   k + 1 < VD_DET_STAGE_COUNT ? "," : "\n");
        }
    }
    if (r->capacity_warnings > 0) {
        printf("note: %llu frames hit a detector budget (VD_ERR_CAPACITY; see --max-candidates, --max-detections)\n",
               (unsigned long long)r->capacity_warnings);
    }
}

static void cleanup(run_t *r)
{
    discard_outputs(r);
    vd_capture_close(&r->cap);
    vd_rgb_free(&r->canvas);
    free(r->ws);
    free(r->dets);
    free(r->eval_dets);
    free(r->cands);
    free(r->model_blob);
    free(r->cnn_blob);
    free(r->boost_blob);
    if (r->have_gt) {
        demo_gt_free(&r->gt);
    }
    for (size_t i = 0; i < r->n_staged; i++) {
        free(r->staged[i]);
    }
    free(r->staged);
    for (int k = 0; k <= VD_DET_STAGE_COUNT; k++) {
        free(r->times[k]);
    }
}

// The run proper; returns the exit status. cleanup() is the caller's.
static int run(run_t *r)
{
    demo_opts_t *o = &r->o;
    vd_status_t st;
    r->device = strncmp(o->input, "/dev/", 5) == 0;
    struct stat sb;
    if (o->input_default) {
        if (stat(o->input, &sb) != 0) {
            char m[1200];
            snprintf(m, sizeof m, "the bundled clip is missing at %s: the HIT-UAV clip is part of the repository "
                                  "(tools/demo/hit-uav-clip), the synthetic one is built by 'cmake --build build "
                                  "--target vd_clip'; or pass --input",
                     o->input);
            return fail(r, VD_ERR_IO, m);
        }
        if (o->eval == NULL && o->clip_eval != NULL) {
            snprintf(r->eval_path, sizeof r->eval_path, "%s", o->clip_eval);
            if (stat(r->eval_path, &sb) == 0) {
                o->eval = r->eval_path;
            }
        }
    }
    st = load_models(r);
    if (st != VD_OK) {
        return fail(r, st, r->err);
    }
    if (o->eval != NULL) {
        st = demo_gt_load(&r->gt, o->eval, o->classes, r->err, sizeof r->err);
        if (st != VD_OK) {
            char m[1200];
            snprintf(m, sizeof m, "--eval: %s", r->err);
            return fail(r, st, m);
        }
        r->have_gt = true;
    }
    vd_capture_opts_t copts;
    vd_capture_opts_default(&copts);
    copts.raw_width = o->raw_w;
    copts.raw_height = o->raw_h;
    copts.raw_format = o->raw_format;
    copts.raw_big_endian = o->raw_big_endian;
    copts.width = o->dev_w;
    copts.height = o->dev_h;
    copts.fps = o->fps;
    copts.format = o->dev_format;
    copts.same_size = true;
    st = vd_capture_open(&r->cap, o->input, &copts);
    if (st == VD_OK) {
        st = vd_capture_start(&r->cap);
    }
    if (st != VD_OK) {
        const char *e = vd_capture_error(&r->cap);
        char m[1200];
        snprintf(m, sizeof m, "%s", e[0] ? e : o->input);
        return fail(r, st, m);
    }
    if (!o->quiet) {
        char src[64];
        sources_text(o->cfg.sources, src, sizeof src);
        const bool paper = (o->cfg.sources & VD_DETECTOR_SRC_ALL) != 0u;
        fprintf(stderr, "vd_fir_demo: input %s; sources %s%s%s; DBN model %s\n", o->input, src,
                r->have_cnn ? "; CNN model " : "", r->have_cnn ? r->cnn_path : "",
                r->have_model ? r->model_path
                              : (paper ? "none (candidates are not verified; score 1.0)" : "none (not needed)"));
    }
    st = open_outputs(r);
    if (st != VD_OK) {
        return fail(r, st, r->err);
    }
    int retries = 0;
    bool tty = isatty(2) != 0;
    // Recorded input ends at VD_ERR_RANGE + at_end; a device runs until --frames or an error.
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    for (;;) {
        if ((o->max_frames != 0 && r->frames >= o->max_frames) || g_stop) {
            break;
        }
        vd_frame_t f;
        uint32_t t0 = clock_us(NULL);
        st = vd_capture_next(&r->cap, o->timeout_ms, &f);
        if (st == VD_ERR_RANGE && vd_capture_at_end(&r->cap)) {
            break;
        }
        if (st != VD_OK) {
            if (r->device && (st == VD_ERR_TIMEOUT || st == VD_ERR_AGAIN) && ++retries <= MAX_DEVICE_RETRIES) {
                continue;
            }
            char m[1200];
            snprintf(m, sizeof m, "%s", vd_capture_error(&r->cap));
            return fail(r, st, m);
        }
        retries = 0;
        char name[1100];
        frame_name(r, &f, name, sizeof name);
        if (!r->det_ready) {
            st = init_detector(r, &f);
            if (st != VD_OK) {
                vd_capture_release(&r->cap, &f);
                return fail(r, st, r->err);
            }
        } else if (f.width != r->width || f.height != r->height || f.format != r->format) {
            char m[1400];
            snprintf(m, sizeof m, "%s: %ux%u %s-bit, but the sequence started with %ux%u %s-bit frames", name,
                     (unsigned)f.width, (unsigned)f.height, f.format == VD_PIX_U16 ? "16" : "8", (unsigned)r->width,
                     (unsigned)r->height, r->format == VD_PIX_U16 ? "16" : "8");
            vd_capture_release(&r->cap, &f);
            return fail(r, VD_ERR_FORMAT, m);
        }
        size_t n = 0;
        r->n_cands = 0;
        st = vd_detector_run(&r->det, &f, r->dets, r->dets_cap, &n);
        if (st == VD_ERR_CAPACITY) {
            r->capacity_warnings++;
        } else if (st != VD_OK) {
            char m[1400];
            snprintf(m, sizeof m, "%s: detector failed", name);
            vd_capture_release(&r->cap, &f);
            return fail(r, st, m);
        }
        if (r->json_open) {
            write_json_line(r, name, &f, n);
        }
        if (r->have_gt) {
            for (size_t i = 0; i < n; i++) {
                r->eval_dets[i].box = r->dets[i].box;
                r->eval_dets[i].score = score_of(&r->dets[i]);
            }
            demo_gt_frame(&r->gt, name, f.width, f.height, r->eval_dets, n, NULL);
            demo_gt_candidates(&r->gt, name, &f, hot_threshold(r, &f), r->cands, r->n_cands);
        }
        if (r->staging) {
            st = draw_frame(r, name, &f, n);
            if (st != VD_OK) {
                vd_capture_release(&r->cap, &f);
                return fail(r, st, r->err);
            }
        }
        vd_capture_release(&r->cap, &f);
        r->frames++;
        r->detections += n;
        st = record_times(r, vd_detector_last_stats(&r->det), clock_us(NULL) - t0);
        if (st != VD_OK) {
            return fail(r, st, r->err);
        }
        if (!o->quiet && (tty || r->frames % 50 == 0)) {
            fprintf(stderr, "%s[%llu] %s: %zu detections%s", tty ? "\r" : "", (unsigned long long)r->frames, name, n,
                    tty ? "\033[K" : "\n");
        }
    }
    if (!o->quiet && tty) {
        fputc('\n', stderr);
    }
    if (g_stop && !o->quiet) {
        fprintf(stderr, "vd_fir_demo: interrupted after %llu frames\n", (unsigned long long)r->frames);
    }
    if (r->frames == 0) {
        return fail(r, VD_ERR_IO, "no frames were read");
    }
    if (r->json_open && (fflush(r->json.f) != 0 || ferror(r->json.f))) {
        char m[1200];
        snprintf(m, sizeof m, "cannot write %s", o->json);
        return fail(r, VD_ERR_IO, m);
    }
    if (r->have_gt && o->eval_out != NULL) {
        st = demo_gt_write_json(&r->gt, o->eval, o->eval_out, r->err, sizeof r->err);
        if (st != VD_OK) {
            return fail(r, st, r->err);
        }
    }
    st = commit_outputs(r);
    if (st != VD_OK) {
        return fail(r, st, r->err);
    }
    r->created[0][0] = r->created[1][0] = '\0';
    summary(r);
    if (r->have_gt) {
        demo_gt_report(&r->gt, stdout);
    }
    return 0;
}

int main(int argc, char **argv)
{
    static run_t r;   // large; zero-initialised
    int a = demo_args_parse(&r.o, argc, argv);
    if (a != 0) {
        return a > 0 ? 0 : 2;
    }
    int rc = run(&r);
    cleanup(&r);
    return rc;
}
