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
#include "args.h"
#include "autores.h"
#include "eval.h"
#include "json.h"
#include "models.h"
#include "out.h"
#include "progress.h"
#include "report.h"

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
#include "vd_port/file.h"
#include "vd_port/writer.h"

#ifndef VD_DEMO_MODELS_DIR
#define VD_DEMO_MODELS_DIR "models"
#endif
#define MAX_DEVICE_RETRIES 5

static const char *const k_stage_names[VD_DETECTOR_STAGE_COUNT] = {
    "threshold", "components", "refine", "contour", "sample", "dbn", "nms", "temporal", "contrast", "windows",
    "cnn", "total"};

typedef struct run {
    demo_opts_t o;
    bool device;
    vd_capture_t cap;
    demo_models_t m;
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
    uint32_t *times[VD_DETECTOR_STAGE_COUNT + 1];   // + wall time per frame (I/O included)
    size_t n_times, cap_times;
    uint64_t frames, detections, capacity_warnings;
    uint32_t width, height;
    vd_pixfmt_t format;
    uint32_t grey_lo_raw, grey_hi_raw;   // 16-bit: the fixed grey window in raw values
    demo_report_t report;    // --report
    bool have_report;
    demo_progress_t prog;    // zeroed (off) until the frame loop starts
    demo_autores_t autores;  // --cnn-full-res auto's measurement
    bool autores_ran;
    demo_autores_live_t live;   // ... on a camera: its first frames as they come
    int8_t *matched;         // --eval: per detection of this frame (dets_cap)
    bool *gt_used;           // --eval: per box of this frame's annotations
    size_t cap_gt_used;
    char err[1600];   // holds a frame's name (name[1100]) and a sentence
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
    demo_progress_end(&r->prog, stderr);   // a progress line on a terminal is ended first
    fprintf(stderr, "vd_fir_demo: error: %s (%s)\n", detail, vd_status_str(st));
    return 1;
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
        fprintf(jf, ", \"source\": \"%s\", \"state\": \"%s\"}", vd_detection_source_name(d->source),
                vd_detection_state_name(d->state));
    }
    fputs("]}\n", jf);
}

// The grey window a 16-bit frame is drawn with: the detector's own for this frame with --grey-window frame
// (stats), else the fixed one.
static void grey_window_raw(const run_t *r, uint32_t *lo, uint32_t *hi)
{
    *lo = r->grey_lo_raw;
    *hi = r->grey_hi_raw;
    if (r->det.cfg.grey_mode == VD_DETECTOR_GREY_PERCENTILE) {
        const vd_detector_stats_t *s = vd_detector_last_stats(&r->det);
        *lo = s->grey_lo_raw;
        *hi = s->grey_hi_raw > s->grey_lo_raw ? s->grey_hi_raw : s->grey_lo_raw + 1u;
    }
}

static vd_status_t draw_frame(run_t *r, const char *name, const vd_frame_t *f, size_t n)
{
    uint32_t lo = 0u, hi = 0u;
    if (f->format == VD_PIX_U16) {
        grey_window_raw(r, &lo, &hi);
    }
    vd_status_t st = vd_rgb_from_frame(&r->canvas, f, lo, hi);
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

// Candidate observer (--eval): keeps the boxes the verifier will see.
static void on_candidate(void *user, const vd_detection_t *cand)
{
    run_t *r = user;
    if (r->n_cands < r->cap_cands) {
        r->cands[r->n_cands++] = cand->box;
    }
}

// What init_detector allocates, freed (again NULL: cleanup and a new detector may follow).
static void free_detector(run_t *r)
{
    vd_rgb_free(&r->canvas);
    free(r->ws);
    free(r->dets);
    free(r->eval_dets);
    free(r->matched);
    free(r->cands);
    r->ws = NULL;
    r->dets = NULL;
    r->eval_dets = NULL;
    r->matched = NULL;
    r->cands = NULL;
    r->det_ready = false;
}

static vd_status_t init_detector(run_t *r, const vd_frame_t *f)
{
    demo_grey_decide(&r->o, f);   // before the cfg: per-frame grey window or the fixed one
    vd_detector_cfg_t cfg;
    demo_detector_cfg(&r->o, f->width, f->height, &cfg);
    cfg.clock_us = clock_us;
    cfg.clock_user = NULL;
    if (r->have_gt) {
        cfg.on_candidate = on_candidate;
        cfg.candidate_user = r;
    }
    size_t bytes = 0;
    const vd_dbn_model_t *m = r->m.have_model ? &r->m.model : NULL;
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
    r->matched = calloc(r->dets_cap, sizeof *r->matched);
    r->cap_cands = r->det.cfg.max_candidates;
    r->cands = calloc(r->cap_cands + 1u, sizeof *r->cands);
    if (r->dets == NULL || r->eval_dets == NULL || r->matched == NULL || r->cands == NULL) {
        snprintf(r->err, sizeof r->err, "out of memory");
        return VD_ERR_IO;
    }
    r->width = f->width;
    r->height = f->height;
    r->format = f->format;
    demo_grey_fixed_raw(&r->o, &r->grey_lo_raw, &r->grey_hi_raw);
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

// --cnn-full-res / --cnn-polarity auto on a camera: frame f (not yet detected on) into the measurement; when it
// completes it with another resolution or polarity, a new detector from this frame on (tracks start over).
static vd_status_t autores_live(run_t *r, const vd_frame_t *f)
{
    bool now = false;
    vd_status_t st = demo_autores_live_frame(&r->live, &r->o, f, r->frames, &now, r->err, sizeof r->err);
    char note[160];
    if (st == VD_OK && !r->o.quiet && demo_autores_live_wait_began(&r->live, note, sizeof note)) {
        fprintf(stderr, "vd_fir_demo: --cnn-full-res/--cnn-polarity auto: %s\n", note);
    }
    if (st != VD_OK || !now) {
        return st;
    }
    r->autores = r->live.a;
    r->autores_ran = true;
    if (!demo_autores_apply(&r->autores, &r->o.cfg)) {
        return VD_OK;
    }
    free_detector(r);
    return init_detector(r, f);
}

// The threshold --eval's hot / cold split counts by: the hot-spot threshold the detector used on this frame
// (stats; the resolved setting when the hot-spot source is off; 65536 = nothing can be hot). A 16-bit frame mapped
// to grey by its own window (--grey-window frame or auto on raw counts) is not radiometric, so there the threshold
// is the raw value at the 8-bit threshold's grey level in that window, as the library's hot-spot source takes it.
static uint32_t hot_threshold(const run_t *r, const vd_frame_t *f)
{
    const vd_detector_stats_t *s = vd_detector_last_stats(&r->det);
    if (f->format == VD_PIX_U16 && r->det.cfg.grey_mode == VD_DETECTOR_GREY_PERCENTILE) {
        if (s->hot_thr_raw != 0u) {
            return s->hot_thr_raw;   // the hot-spot source ran on this frame
        }
        uint16_t raw = 0u;
        return vd_calib_grey_raw_at(&r->det.grey, r->det.cfg.hot_thr_u8, &raw) == VD_OK ? raw : 65536u;
    }
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
        for (int k = 0; k <= VD_DETECTOR_STAGE_COUNT; k++) {
            uint32_t *p = realloc(r->times[k], nc * sizeof *p);
            if (p == NULL) {
                snprintf(r->err, sizeof r->err, "out of memory");
                return VD_ERR_IO;
            }
            r->times[k] = p;
        }
        r->cap_times = nc;
    }
    for (int k = 0; k < VD_DETECTOR_STAGE_COUNT; k++) {
        r->times[k][r->n_times] = s->time_us[k];
    }
    r->times[VD_DETECTOR_STAGE_COUNT][r->n_times] = wall_us;
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

// Matching of one frame (--eval) and its gallery entry (--report).
static vd_status_t evaluate_frame(run_t *r, const char *name, const vd_frame_t *f, size_t n)
{
    const demo_gt_image_t *im = demo_gt_image_of(&r->gt, name);
    const size_t nb = im != NULL ? im->n : 0;
    if (nb > r->cap_gt_used) {
        bool *p = realloc(r->gt_used, nb * sizeof *p);
        if (p == NULL) {
            snprintf(r->err, sizeof r->err, "out of memory");
            return VD_ERR_IO;
        }
        r->gt_used = p;
        r->cap_gt_used = nb;
    }
    if (nb > 0) {
        memset(r->gt_used, 0, nb * sizeof *r->gt_used);
    }
    const uint64_t evaluated = r->gt.frames;
    demo_gt_frame_ex(&r->gt, name, f->width, f->height, r->eval_dets, n, r->matched, r->gt_used, nb);
    if (!r->have_report || r->gt.frames == evaluated) {
        return VD_OK;   // no report, or a frame the annotations do not list
    }
    uint32_t lo = 0u, hi = 0u;
    if (f->format == VD_PIX_U16) {
        grey_window_raw(r, &lo, &hi);
    }
    return demo_report_frame(&r->report, r->frames, name, f, lo, hi, im, r->gt_used, r->eval_dets, r->matched, n,
                             r->err, sizeof r->err);
}

static void summary(run_t *r)
{
    double det_total = sum_us(r->times[VD_DETECTOR_STAGE_TOTAL], r->n_times);
    double wall_total = sum_us(r->times[VD_DETECTOR_STAGE_COUNT], r->n_times);
    printf("vd_fir_demo: %llu frames, %llu detections; %.1f fps (detector), %.1f fps (with I/O and outputs)\n",
           (unsigned long long)r->frames, (unsigned long long)r->detections,
           det_total > 0 ? (double)r->frames * 1e6 / det_total : 0.0,
           wall_total > 0 ? (double)r->frames * 1e6 / wall_total : 0.0);
    if (r->n_times > 0) {
        printf("median time per frame (ms):");
        for (int k = 0; k < VD_DETECTOR_STAGE_COUNT; k++) {
            printf(" %s %.2f%s", k_stage_names[k], median_us(r->times[k], r->n_times) / 1000.0,
                   k + 1 < VD_DETECTOR_STAGE_COUNT ? "," : "\n");
        }
    }
    if (r->m.have_cnn && (r->o.cfg.sources & VD_DETECTOR_SRC_CNN) != 0u) {
        printf("cnn kernels: %s\n", vd_cnn_kernel_set());   // which set the times above ran on
        if (!r->autores_ran && r->live.on) {   // a camera's measurement that had not decided when the run ended
            printf("cnn input: %s resolution, %s (a camera's frames measured as they came: %u of %llu, %s; no "
                   "choice yet)\n", demo_cnn_res_name(r->o.cfg.cnn_res), demo_polarity_name(r->o.cfg.cnn_invert),
                   (unsigned)r->live.a.frames, (unsigned long long)r->live.seen,
                   r->live.first_box == UINT64_MAX ? "none with a box" : "too few from the first with a box");
        } else if (!r->autores_ran && r->o.cfg.cnn_res != VD_DETECTOR_CNN_RES_HALF) {
            printf("cnn input: %s resolution (set by --cnn-res or --cnn-full-res)\n",
                   demo_cnn_res_name(r->o.cfg.cnn_res));
        }
    }
    if (r->autores_ran) {
        const demo_autores_t *a = &r->autores;
        const demo_opts_t *o = &r->o;
        char figures[DEMO_AUTORES_DESCRIBE_MAX], from[64] = "", of[48] = "", pol[32] = "";
        // the polarity the options asked for: the one in effect, unless the measurement turned it
        demo_autores_describe(a, (o->cfg.cnn_invert ^ a->inverted) != 0u, figures, sizeof figures);
        if (r->live.decided) {
            snprintf(from, sizeof from, ", as they came; from frame %llu on", (unsigned long long)r->live.from + 1u);
        }
        if (a->total > a->frames) {   // a sample spread over a longer recording says of how many frames
            snprintf(of, sizeof of, " spread over %llu", (unsigned long long)a->total);
        }
        if (o->cnn_polarity_auto) {
            snprintf(pol, sizeof pol, ", %s", demo_polarity_name(o->cfg.cnn_invert));
        }
        printf("cnn input: %s resolution%s (%s%s%s: %s over %u frames%s%s%s; %.2f s)\n", demo_cnn_res_name(a->res), pol,
               o->cnn_res_auto ? "--cnn-full-res auto" : "", o->cnn_res_auto && o->cnn_polarity_auto ? ", " : "",
               o->cnn_polarity_auto ? "--cnn-polarity auto" : "", figures, (unsigned)a->frames, of,
               a->frames < DEMO_AUTORES_MIN_FRAMES ? ", too few to choose" : "", from, a->seconds);
    }
    const demo_opts_t *o = &r->o;
    if (r->format == VD_PIX_U16 && o->grey_outside_permille >= DEMO_GREY_AUTO_PERMILLE) {
        const bool frame = r->det.cfg.grey_mode == VD_DETECTOR_GREY_PERCENTILE;
        printf("note: %.1f %% of the first 16-bit frame's samples lie outside the fixed grey window (raw %u..%u)",
               o->grey_outside_permille / 10.0, (unsigned)r->grey_lo_raw, (unsigned)r->grey_hi_raw);
        if (frame) {
            printf(": not radiometric, so each frame was mapped to grey by its own %.1f..%.1f %% percentiles "
                   "(--grey-window %s; a radiometric camera: --grey-window fixed with --calib GAIN,OFFSET_CK or "
                   "--grey-range-c LO,HI; docs/demo.md, \"16-bit frames\")\n", r->det.cfg.grey_tail_permille / 10.0,
                   100.0 - r->det.cfg.grey_tail_permille / 10.0, o->grey_window_auto ? "auto" : "frame");
        } else {
            printf(": the networks see them as black or white. A camera that is not radiometric (TLinear 0.01 K) "
                   "needs --grey-window frame (or auto), --calib GAIN,OFFSET_CK or --grey-range-c LO,HI "
                   "(docs/demo.md, \"16-bit frames\")\n");
        }
    }
    if (r->capacity_warnings > 0) {
        printf("note: %llu frames hit a detector budget (VD_ERR_CAPACITY; see --max-candidates, --max-detections)\n",
               (unsigned long long)r->capacity_warnings);
    }
}

// --report: index.html from the run's figures (the same as summary() prints).
static vd_status_t write_report(run_t *r)
{
    double med[VD_DETECTOR_STAGE_COUNT], mean[VD_DETECTOR_STAGE_COUNT];
    const char *names[VD_DETECTOR_STAGE_COUNT];
    for (int k = 0; k < VD_DETECTOR_STAGE_COUNT; k++) {
        names[k] = k_stage_names[k];
        mean[k] = r->n_times ? sum_us(r->times[k], r->n_times) / (double)r->n_times / 1000.0 : 0.0;
        med[k] = median_us(r->times[k], r->n_times) / 1000.0;
    }
    const double det_total = sum_us(r->times[VD_DETECTOR_STAGE_TOTAL], r->n_times);
    const double wall_total = sum_us(r->times[VD_DETECTOR_STAGE_COUNT], r->n_times);
    char src[64], models[13000];
    sources_text(r->o.cfg.sources, src, sizeof src);
    snprintf(models, sizeof models, "%s%s%s%s%s%s%s", r->m.have_cnn ? "CNN " : "", r->m.have_cnn ? r->m.cnn_path : "",
             r->m.have_cnn2 ? " + " : "", r->m.have_cnn2 ? r->m.cnn2_path : "",
             r->m.have_cnn && r->m.have_model ? ", " : "", r->m.have_model ? "DBN " : "",
             r->m.have_model ? r->m.model_path : "");
    if (!r->m.have_cnn && !r->m.have_model) {
        snprintf(models, sizeof models, "none");
    }
    demo_report_info_t in;
    memset(&in, 0, sizeof in);
    in.input = r->o.input;
    in.sources = src;
    in.models = models;
    in.annotations = r->o.eval != NULL ? r->o.eval : "";
    in.frames = r->frames;
    in.detections = r->detections;
    in.width = r->width;
    in.height = r->height;
    in.u16 = r->format == VD_PIX_U16;
    in.fps_detector = det_total > 0 ? (double)r->frames * 1e6 / det_total : 0.0;
    in.fps_wall = wall_total > 0 ? (double)r->frames * 1e6 / wall_total : 0.0;
    in.n_stages = VD_DETECTOR_STAGE_COUNT;
    in.stage_names = names;
    in.stage_median_ms = med;
    in.stage_mean_ms = mean;
    in.gt = r->have_gt ? &r->gt : NULL;
    return demo_report_write(&r->report, &in, r->err, sizeof r->err);
}

static void cleanup(run_t *r)
{
    discard_outputs(r);
    demo_report_abort(&r->report);
    free(r->gt_used);
    vd_capture_close(&r->cap);
    free_detector(r);
    demo_autores_live_free(&r->live);
    demo_models_free(&r->m);
    if (r->have_gt) {
        demo_gt_free(&r->gt);
    }
    for (size_t i = 0; i < r->n_staged; i++) {
        free(r->staged[i]);
    }
    free(r->staged);
    for (int k = 0; k <= VD_DETECTOR_STAGE_COUNT; k++) {
        free(r->times[k]);
    }
}

// The bundled clip's presence, the models and the ground truth (--eval); returns an exit status.
static int load_inputs(run_t *r)
{
    demo_opts_t *o = &r->o;
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
    vd_status_t st = demo_models_load(&r->m, &r->o, VD_DEMO_MODELS_DIR, r->err, sizeof r->err);
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
    return 0;
}

static void capture_opts(const demo_opts_t *o, vd_capture_opts_t *copts)
{
    vd_capture_opts_default(copts);
    copts->raw_width = o->raw_w;
    copts->raw_height = o->raw_h;
    copts->raw_format = o->raw_format;
    copts->raw_big_endian = o->raw_big_endian;
    copts->width = o->dev_w;
    copts->height = o->dev_h;
    copts->fps = o->fps;
    copts->format = o->dev_format;
    copts->same_size = true;
}

// --cnn-full-res auto: a recording is measured before the run (64 frames spread over it, read twice); a camera's
// frames cannot be read twice, so they are measured as they come (autores_live) at half resolution.
static int choose_resolution(run_t *r, const vd_capture_opts_t *copts)
{
    demo_opts_t *o = &r->o;
    if (!(o->cnn_res_auto || o->cnn_polarity_auto) || !r->m.have_cnn || (o->cfg.sources & VD_DETECTOR_SRC_CNN) == 0u) {
        return 0;
    }
    if (r->device) {
        demo_autores_live_start(&r->live);
        o->cfg.cnn_res = o->cnn_res_auto ? VD_DETECTOR_CNN_RES_HALF : o->cfg.cnn_res;
        if (!o->quiet) {
            fprintf(stderr, "vd_fir_demo: --cnn-full-res/--cnn-polarity auto: a camera's frames are measured as they "
                            "come, %u from the first with a box (every %uth while none has one, up to frame %u; %s "
                            "resolution, %s meanwhile)\n", (unsigned)DEMO_AUTORES_MAX_FRAMES,
                    (unsigned)DEMO_AUTORES_LIVE_STRIDE, (unsigned)DEMO_AUTORES_LIVE_WAIT,
                    demo_cnn_res_name(o->cfg.cnn_res), demo_polarity_name(o->cfg.cnn_invert));
        }
        return 0;
    }
    vd_status_t st = demo_autores_measure(o, o->input, copts, &r->autores, r->err, sizeof r->err);
    if (st != VD_OK) {
        return fail(r, st, r->err);
    }
    r->autores_ran = true;
    demo_autores_apply(&r->autores, &o->cfg);
    return 0;
}

// Capture started, the banner, the outputs and the report opened; returns an exit status.
static int open_run(run_t *r, const vd_capture_opts_t *copts)
{
    demo_opts_t *o = &r->o;
    vd_status_t st = vd_capture_open(&r->cap, o->input, copts);
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
        fprintf(stderr, "vd_fir_demo: input %s; sources %s%s%s%s%s%s; DBN model %s\n", o->input, src,
                r->m.have_cnn ? "; CNN model " : "", r->m.have_cnn ? r->m.cnn_path : "",
                r->m.have_cnn2 ? " + " : "", r->m.have_cnn2 ? r->m.cnn2_path : "",
                (r->m.have_cnn && o->cfg.cnn_flip != 0u) ? " (+ flip pass)" : "",
                r->m.have_model ? r->m.model_path
                              : (paper ? "none (candidates are not verified; score 1.0)" : "none (not needed)"));
    }
    st = open_outputs(r);
    if (st != VD_OK) {
        return fail(r, st, r->err);
    }
    if (o->report != NULL) {
        st = demo_report_open(&r->report, o->report, r->err, sizeof r->err);
        if (st != VD_OK) {
            return fail(r, st, r->err);
        }
        r->have_report = true;
    }
    return 0;
}

// One captured frame through the detector and into every output; *n: its detections. On failure r->err
// says why (the caller releases the frame either way).
static vd_status_t process_frame(run_t *r, const vd_frame_t *f, const char *name, size_t *n)
{
    vd_status_t st;
    *n = 0;
    if (!r->det_ready) {
        st = init_detector(r, f);
        if (st != VD_OK) {
            return st;
        }
    } else if (f->width != r->width || f->height != r->height || f->format != r->format) {
        snprintf(r->err, sizeof r->err, "%s: %ux%u %s-bit, but the sequence started with %ux%u %s-bit frames",
                 name, (unsigned)f->width, (unsigned)f->height, f->format == VD_PIX_U16 ? "16" : "8",
                 (unsigned)r->width, (unsigned)r->height, r->format == VD_PIX_U16 ? "16" : "8");
        return VD_ERR_FORMAT;
    }
    st = autores_live(r, f);
    if (st != VD_OK) {
        return st;
    }
    r->n_cands = 0;
    st = vd_detector_run(&r->det, f, r->dets, r->dets_cap, n);
    if (st == VD_ERR_CAPACITY) {
        r->capacity_warnings++;
    } else if (st != VD_OK) {
        snprintf(r->err, sizeof r->err, "%s: detector failed", name);
        return st;
    }
    if (r->json_open) {
        write_json_line(r, name, f, *n);
    }
    if (r->have_gt) {
        for (size_t i = 0; i < *n; i++) {
            r->eval_dets[i].box = r->dets[i].box;
            r->eval_dets[i].score = score_of(&r->dets[i]);
        }
        st = evaluate_frame(r, name, f, *n);
        if (st != VD_OK) {
            return st;
        }
        demo_gt_candidates(&r->gt, name, f, hot_threshold(r, f), r->cands, r->n_cands);
    }
    return r->staging ? draw_frame(r, name, f, *n) : VD_OK;
}

// After the last frame: the written JSON checked, evaluation and report written, outputs committed, the
// summary printed; returns the exit status.
static int finish(run_t *r)
{
    demo_opts_t *o = &r->o;
    vd_status_t st;
    demo_progress_end(&r->prog, stderr);
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
    if (r->have_report) {
        st = write_report(r);
        if (st != VD_OK) {
            return fail(r, st, r->err);
        }
    }
    st = commit_outputs(r);
    if (st != VD_OK) {
        return fail(r, st, r->err);
    }
    r->created[0][0] = r->created[1][0] = '\0';
    if (r->have_report && !o->quiet) {
        fprintf(stderr, "vd_fir_demo: report %s/index.html\n", r->report.dir);
    }
    summary(r);
    if (r->have_gt) {
        demo_gt_report(&r->gt, stdout);
    }
    return 0;
}

// The run proper; returns the exit status. cleanup() is the caller's.
static int run(run_t *r)
{
    demo_opts_t *o = &r->o;
    r->device = strncmp(o->input, "/dev/", 5) == 0;
    vd_capture_opts_t copts;
    capture_opts(o, &copts);
    int rc = load_inputs(r);
    rc = (rc == 0) ? choose_resolution(r, &copts) : rc;
    rc = (rc == 0) ? open_run(r, &copts) : rc;
    if (rc != 0) {
        return rc;
    }
    int retries = 0;
    uint64_t total = 0;
    if (!r->device && vd_file_frame_total(&r->cap, &total) != VD_OK) {
        total = 0;
    }
    if (o->max_frames != 0 && (total == 0 ? r->device : total > o->max_frames)) {
        total = o->max_frames;
    }
    demo_progress_start(&r->prog, !o->quiet, isatty(STDERR_FILENO) != 0, total, demo_now_s());
    // Recorded input ends at VD_ERR_RANGE + at_end; a device runs until --frames or an error.
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    while (!((o->max_frames != 0 && r->frames >= o->max_frames) || g_stop)) {
        vd_frame_t f;
        uint32_t t0 = clock_us(NULL);
        vd_status_t st = vd_capture_next(&r->cap, o->timeout_ms, &f);
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
        size_t n = 0;
        st = process_frame(r, &f, name, &n);
        vd_capture_release(&r->cap, &f);
        if (st != VD_OK) {
            return fail(r, st, r->err);
        }
        r->frames++;
        r->detections += n;
        st = record_times(r, vd_detector_last_stats(&r->det), clock_us(NULL) - t0);
        if (st != VD_OK) {
            return fail(r, st, r->err);
        }
        demo_progress_frame(&r->prog, stderr, r->frames, name, n, demo_now_s());
    }
    return finish(r);
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
