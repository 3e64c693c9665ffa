// SPDX-License-Identifier: MIT
// --cnn-full-res auto, frame by frame: the networks' boxes on frames and their mirror images.
//
// Why: the networks trained on vehicles of a certain size. A camera whose vehicles are about half that size
// (a wider lens, a smaller sensor, a higher mount) loses most of them at half resolution and gets them back at
// full resolution, while a camera like the training ones loses 20-27 AP points at full resolution
// (docs/results/cameras.md). At the wrong resolution the networks still put boxes on vehicles (or their parts)
// but score them lower and agree less with themselves on the mirror image. The rating, mean box score + 1/4 x
// flip agreement, chose the resolution of the higher AP on 243 of 260 recordings of the train and val splits
// (each scene's first 32 frames, as they are and under four camera changes), losing 261 AP points in all,
// where the agreement alone, the rule before, was right on 219 and lost 792, and the mean score alone on 236
// (docs/results/cameras.md, "The rule of 2026-11-30"; vdtools.adapt.resolution_evidence). This is the rule of
// vdtools.adapt.measure.choose_resolution without labels, run where a user runs vd.
//
// Polarity (--cnn-polarity auto): the networks trained on white-hot frames only, and on a black-hot camera's
// frames their boxes rate lower than on the same frames inverted, as at a wrong resolution. Rated at one
// resolution only, small vehicles made white-hot frames rate higher inverted (docs/demo.md "Black-hot cameras");
// over the three resolutions the best rating of the frames as they are stays above the best inverted.
//
// Two threads: a frame and its mirror image cost the same, so one thread runs every configuration on the frame
// and another on the mirror image, each configuration with a detector per image (the library keeps no state
// outside a detector, and the networks' prepared weights are only read). The counts are integer sums made after
// both, so they, and the choice, are those of one thread; where no thread can be made the mirror image follows
// the frame in this one.
#include "flipagree.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "models.h"

typedef struct res_run {
    vd_detector_t det;
    void *ws;
} res_run_t;

// One image (a frame or its mirror image) in every measured configuration: its boxes per configuration.
typedef struct pass_job {
    const demo_flipagree_t *fa;             // the measurement it belongs to (configurations, capacity)
    res_run_t runs[DEMO_AUTORES_CONFIGS];   // [cfg.cnn_res + DEMO_AUTORES_RES x inverted]; det unset when not measured
    vd_detection_t *boxes;                  // [k x cap ...]: configuration k's boxes
    size_t n[DEMO_AUTORES_CONFIGS];
    const vd_frame_t *f;
    vd_status_t st;
} pass_job_t;

struct demo_flipagree {
    pass_job_t pass[2];   // the frame, its mirror image
    uint8_t measured;     // bit k: configuration k runs
    uint8_t fixed_res;    // the options' cfg.cnn_res when they fix it, else DEMO_AUTORES_RES
    void *mirror;         // the mirror image's pixels
    bool *used;
    size_t cap;
    uint32_t width, height;
    vd_pixfmt_t format;
};

uint8_t demo_autores_configs(const demo_opts_t *o)
{
    // the polarity is chosen over every resolution, whichever the run takes: at one resolution, that of small
    // vehicles, white-hot frames can rate higher inverted (docs/demo.md "Black-hot cameras")
    const uint8_t as_is = (uint8_t)((1u << DEMO_AUTORES_RES) - 1u);
    if (o->cnn_polarity_auto) {
        return (uint8_t)((1u << DEMO_AUTORES_CONFIGS) - 1u);
    }
    return o->cnn_res_auto ? as_is : 0u;
}

uint64_t demo_autores_sample(uint64_t total, uint32_t k)
{
    if (total <= DEMO_AUTORES_SPREAD_FRAMES) {
        return k;
    }
    const uint64_t parts = 2u * DEMO_AUTORES_SPREAD_FRAMES, odd = 2u * (uint64_t)k + 1u;
    return (total / parts) * odd + ((total % parts) * odd) / parts;   // floor(odd total / parts), no overflow
}

double demo_autores_agreement(const demo_autores_t *a, unsigned k)
{
    return k >= DEMO_AUTORES_CONFIGS || a->boxes[k] == 0u ? -1.0
                                                         : 2.0 * (double)a->matched[k] / (double)a->boxes[k];
}

double demo_autores_mean_score(const demo_autores_t *a, unsigned k)
{
    return k >= DEMO_AUTORES_CONFIGS || a->boxes[k] == 0u ? -1.0
                                                         : (double)a->score_q8[k] / (255.0 * (double)a->boxes[k]);
}

double demo_autores_rating(const demo_autores_t *a, unsigned k)
{
    const double m = demo_autores_mean_score(a, k);
    return m < 0.0 ? -1.0 : m + DEMO_AUTORES_AGREE_WEIGHT * demo_autores_agreement(a, k);
}

// The measured configuration of one polarity with the highest rating (ties to the lower cfg.cnn_res; no box
// rates 0), *best its rating; with too few frames only configuration 0 (half resolution as the options set the
// polarity, measured whenever anything is). DEMO_AUTORES_CONFIGS when none of that polarity counts.
static unsigned best_of(const demo_autores_t *a, unsigned inverted, double *best)
{
    unsigned pick = DEMO_AUTORES_CONFIGS;
    *best = 0.0;
    for (unsigned r = 0u; r < DEMO_AUTORES_RES; r++) {
        const unsigned k = r + DEMO_AUTORES_RES * inverted;
        if ((a->measured & (1u << k)) == 0u || (k != 0u && a->frames < DEMO_AUTORES_MIN_FRAMES)) {
            continue;
        }
        const double r_k = demo_autores_rating(a, k);
        const double v = r_k > 0.0 ? r_k : 0.0;
        if (pick == DEMO_AUTORES_CONFIGS || v > *best) {   // strictly higher: ties keep the lower cfg.cnn_res
            pick = k;
            *best = v;
        }
    }
    return pick;
}

uint8_t demo_autores_decide(demo_autores_t *a)
{
    double as_is = 0.0, other = 0.0;
    unsigned k = best_of(a, 0u, &as_is);
    const unsigned inv = best_of(a, 1u, &other);
    if (k == DEMO_AUTORES_CONFIGS || (inv != DEMO_AUTORES_CONFIGS && other > as_is + DEMO_AUTORES_INVERT_MARGIN)) {
        k = inv;
    }
    if (k == DEMO_AUTORES_CONFIGS) {   // nothing measured: half resolution as the options set the polarity
        k = 0u;
    }
    a->res = a->fixed_res < DEMO_AUTORES_RES ? a->fixed_res : (uint8_t)(k % DEMO_AUTORES_RES);
    a->inverted = (uint8_t)(k / DEMO_AUTORES_RES);
    return a->res;
}

double demo_autores_figure(const demo_autores_t *a, unsigned k, unsigned kind)
{
    return kind == 0u ? demo_autores_rating(a, k) : kind == 1u ? demo_autores_mean_score(a, k)
                                                               : demo_autores_agreement(a, k);
}

bool demo_autores_apply(const demo_autores_t *a, vd_detector_cfg_t *cfg)
{
    const bool same = a->res == cfg->cnn_res && a->inverted == 0u;
    cfg->cnn_res = a->res;
    cfg->cnn_invert = (uint8_t)(cfg->cnn_invert ^ a->inverted);
    return !same;
}

// "name value, name value" over the measured configurations; kind 0 rating, 1 mean score, 2 agreement (%).
static size_t describe_part(const demo_autores_t *a, bool both, bool black, unsigned kind, char *buf, size_t len)
{
    size_t n = 0u;
    for (unsigned k = 0u; k < DEMO_AUTORES_CONFIGS; k++) {
        if ((a->measured & (1u << k)) == 0u) {
            continue;
        }
        const double v = demo_autores_figure(a, k, kind);
        char val[32];
        if (v < 0.0) {
            snprintf(val, sizeof val, "none (no box)");
        } else if (kind == 2u) {
            snprintf(val, sizeof val, "%.1f %%", 100.0 * v);
        } else {
            snprintf(val, sizeof val, "%.3f", v);
        }
        const bool inv_black = (k >= DEMO_AUTORES_RES) != black;
        const int w = snprintf(buf + n, len - n, "%s%s%s%s %s", n ? ", " : "", demo_cnn_res_name(k % DEMO_AUTORES_RES),
                               both ? " " : "", both ? demo_polarity_name(inv_black) : "", val);
        if (w < 0 || (size_t)w >= len - n) {
            return len - 1u;
        }
        n += (size_t)w;
    }
    return n;
}

void demo_autores_describe(const demo_autores_t *a, bool options_black_hot, char *buf, size_t len)
{
    static const char *const what[] = {"rating ", "; mean box score ", "; flip agreement "};
    const bool both = (a->measured >> DEMO_AUTORES_RES) != 0u;
    size_t n = 0u;
    if (len == 0u) {
        return;
    }
    buf[0] = '\0';
    for (unsigned kind = 0u; kind < 3u && n + 1u < len; kind++) {
        const int w = snprintf(buf + n, len - n, "%s", what[kind]);
        n = (w < 0 || (size_t)w >= len - n) ? len - 1u : n + (size_t)w;
        if (n + 1u < len) {
            n += describe_part(a, both, options_black_hot, kind, buf + n, len - n);
        }
    }
}

// The CNN source alone as the options set it, one pass per network, no tracking: the predictor of
// vdtools.adapt.measure.flip_agreement.
static vd_status_t run_init(res_run_t *r, const demo_opts_t *o, const vd_frame_t *f, unsigned k, char *err,
                            size_t err_len)
{
    const uint8_t res = (uint8_t)(k % DEMO_AUTORES_RES);
    vd_detector_cfg_t cfg;
    demo_detector_cfg(o, f->width, f->height, &cfg);
    cfg.sources = VD_DETECTOR_SRC_CNN;
    cfg.cnn_rescore = 0u;
    cfg.cnn_flip = 0u;
    cfg.cnn_res = res;
    cfg.cnn_invert = (uint8_t)(cfg.cnn_invert ^ (k / DEMO_AUTORES_RES));
    cfg.temporal = false;
    cfg.clock_us = NULL;
    cfg.on_candidate = NULL;
    size_t bytes = 0;
    vd_status_t st = vd_detector_workspace_size(&cfg, NULL, &bytes);
    if (st == VD_OK && posix_memalign(&r->ws, 64, bytes ? bytes : 1) != 0) {
        r->ws = NULL;
        st = VD_ERR_IO;
    }
    if (st == VD_OK) {
        st = vd_detector_init(&r->det, &cfg, NULL, r->ws, bytes);
    }
    if (st != VD_OK) {
        snprintf(err, err_len, "--cnn-full-res/--cnn-polarity auto: the detector at %s resolution%s cannot run "
                 "%ux%u frames", demo_cnn_res_name(res), k >= DEMO_AUTORES_RES ? ", inverted," : "",
                 (unsigned)f->width, (unsigned)f->height);
    }
    return st;
}

void demo_flipagree_free(demo_flipagree_t *fa)
{
    if (fa == NULL) {
        return;
    }
    for (unsigned p = 0u; p < 2u; p++) {
        for (unsigned k = 0u; k < DEMO_AUTORES_CONFIGS; k++) {
            free(fa->pass[p].runs[k].ws);
        }
        free(fa->pass[p].boxes);
    }
    free(fa->mirror);
    free(fa->used);
    free(fa);
}

vd_status_t demo_flipagree_new(demo_flipagree_t **out, const demo_opts_t *o, const vd_frame_t *first, char *err,
                               size_t err_len)
{
    *out = NULL;
    demo_flipagree_t *fa = calloc(1, sizeof *fa);
    vd_status_t st = VD_OK;
    if (fa != NULL) {
        fa->width = first->width;
        fa->height = first->height;
        fa->format = first->format;
        fa->mirror = malloc((size_t)first->width * first->height * (first->format == VD_PIX_U16 ? 2u : 1u) + 1u);
        fa->measured = demo_autores_configs(o);   // configuration 0 among them whenever any
        fa->fixed_res = o->cnn_res_auto ? (uint8_t)DEMO_AUTORES_RES : o->cfg.cnn_res;
        for (unsigned p = 0u; p < 2u; p++) {
            for (unsigned k = 0u; k < DEMO_AUTORES_CONFIGS && fa->mirror != NULL && st == VD_OK; k++) {
                if ((fa->measured & (1u << k)) != 0u) {
                    st = run_init(&fa->pass[p].runs[k], o, first, k, err, err_len);
                }
            }
        }
        if (st == VD_OK && fa->mirror != NULL && fa->measured != 0u) {
            fa->cap = (size_t)fa->pass[0].runs[0].det.cfg.max_detections + 1u;
            for (unsigned p = 0u; p < 2u; p++) {
                fa->pass[p].boxes = calloc(fa->cap * DEMO_AUTORES_CONFIGS, sizeof *fa->pass[p].boxes);
                fa->pass[p].fa = fa;
            }
            fa->used = calloc(fa->cap, sizeof *fa->used);
        }
    }
    if (st == VD_OK && (fa == NULL || fa->mirror == NULL || fa->pass[0].boxes == NULL || fa->pass[1].boxes == NULL ||
                        fa->used == NULL)) {
        snprintf(err, err_len, "out of memory");
        st = VD_ERR_IO;
    }
    if (st != VD_OK) {
        demo_flipagree_free(fa);
        return st;
    }
    *out = fa;
    return VD_OK;
}

// Left-right mirror image of f into buf (f's size, packed rows).
static void mirror(const vd_frame_t *f, void *buf, vd_frame_t *out)
{
    const size_t bpp = f->format == VD_PIX_U16 ? 2u : 1u;
    const size_t row = (size_t)f->width * bpp;
    for (uint32_t y = 0; y < f->height; y++) {
        const unsigned char *s = (const unsigned char *)f->data + (size_t)y * f->stride;
        unsigned char *d = (unsigned char *)buf + (size_t)y * row;
        for (uint32_t x = 0; x < f->width; x++) {
            memcpy(d + (size_t)(f->width - 1u - x) * bpp, s + (size_t)x * bpp, bpp);
        }
    }
    *out = *f;
    out->data = buf;
    out->stride = row;
}

// a IoU >= b IoU, exactly: inter_a / union_a against inter_b / union_b.
static bool iou_ge(uint64_t ia, uint64_t ua, uint64_t ib, uint64_t ub)
{
    return ia * ub >= ib * ua;
}

static void overlap(const vd_rect_t *a, const vd_rect_t *b, uint64_t *inter, uint64_t *uni)
{
    const int32_t ix = (a->x + a->w < b->x + b->w ? a->x + a->w : b->x + b->w) - (a->x > b->x ? a->x : b->x);
    const int32_t iy = (a->y + a->h < b->y + b->h ? a->y + a->h : b->y + b->h) - (a->y > b->y ? a->y : b->y);
    *inter = (ix > 0 && iy > 0) ? (uint64_t)ix * (uint64_t)iy : 0u;
    *uni = (uint64_t)a->w * (uint64_t)a->h + (uint64_t)b->w * (uint64_t)b->h - *inter;
}

// Boxes of a matched one to one with b as vdtools.metrics.evaluate.one_to_one: each box of a in turn takes the
// unused box of b with the largest IoU (ties: the later one), kept when IoU >= 0.5. used: nb flags.
static uint32_t matches(const vd_detection_t *a, size_t na, const vd_detection_t *b, size_t nb, bool *used)
{
    uint32_t m = 0u;
    memset(used, 0, nb * sizeof *used);
    for (size_t i = 0; i < na; i++) {
        size_t best = nb;
        uint64_t bi = 0u, bu = 1u;
        for (size_t j = 0; j < nb; j++) {
            uint64_t in = 0u, un = 1u;
            if (used[j]) {
                continue;
            }
            overlap(&a[i].box, &b[j].box, &in, &un);
            if (un > 0u && (best == nb || iou_ge(in, un, bi, bu))) {
                best = j;
                bi = in;
                bu = un;
            }
        }
        if (best < nb && 2u * bi >= bu) {
            used[best] = true;
            m++;
        }
    }
    return m;
}

// Every measured configuration on one image: its boxes (a thread's body; the first error ends the pass).
static void *pass_run(void *arg)
{
    pass_job_t *j = arg;
    const size_t cap = j->fa->cap;
    j->st = VD_OK;
    for (unsigned k = 0u; k < DEMO_AUTORES_CONFIGS && j->st == VD_OK; k++) {
        j->n[k] = 0u;
        if ((j->fa->measured & (1u << k)) != 0u) {
            const vd_status_t st = vd_detector_run(&j->runs[k].det, j->f, j->boxes + k * cap, cap, &j->n[k]);
            j->st = st == VD_ERR_CAPACITY ? VD_OK : st;
        }
    }
    return NULL;
}

vd_status_t demo_flipagree_add(demo_flipagree_t *fa, const vd_frame_t *f, demo_autores_t *a)
{
    if (f->width != fa->width || f->height != fa->height || f->format != fa->format) {
        return VD_ERR_ARG;
    }
    vd_frame_t fm;
    mirror(f, fa->mirror, &fm);
    fa->pass[0].f = f;
    fa->pass[1].f = &fm;
    pthread_t mate;
    const bool two = pthread_create(&mate, NULL, pass_run, &fa->pass[1]) == 0;
    pass_run(&fa->pass[0]);
    if (two) {
        pthread_join(mate, NULL);
    } else {
        pass_run(&fa->pass[1]);   // no thread to be had: one after the other, the same counts
    }
    if (fa->pass[0].st != VD_OK || fa->pass[1].st != VD_OK) {
        return fa->pass[0].st != VD_OK ? fa->pass[0].st : fa->pass[1].st;
    }
    a->measured = fa->measured;
    a->fixed_res = fa->fixed_res;
    for (unsigned k = 0u; k < DEMO_AUTORES_CONFIGS; k++) {
        if ((fa->measured & (1u << k)) == 0u) {
            continue;
        }
        // The frame's boxes and its mirror image's, mirrored back, into the pooled counts.
        vd_detection_t *da = fa->pass[0].boxes + k * fa->cap, *db = fa->pass[1].boxes + k * fa->cap;
        const size_t na = fa->pass[0].n[k], nb = fa->pass[1].n[k];
        for (size_t j = 0; j < nb; j++) {
            db[j].box.x = (int32_t)f->width - db[j].box.x - db[j].box.w;
            a->score_q8[k] += db[j].score_q8;
        }
        for (size_t i = 0; i < na; i++) {
            a->score_q8[k] += da[i].score_q8;
        }
        a->matched[k] += matches(da, na, db, nb, fa->used);
        a->boxes[k] += na + nb;
    }
    a->frames++;
    return VD_OK;
}

double demo_now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

void demo_autores_live_start(demo_autores_live_t *lv)
{
    lv->on = true;
    lv->decided = false;
    lv->seen = 0u;
    lv->first_box = UINT64_MAX;
}

static uint64_t autores_boxes(const demo_autores_t *a)
{
    uint64_t n = 0u;
    for (unsigned k = 0u; k < DEMO_AUTORES_CONFIGS; k++) {
        n += a->boxes[k];
    }
    return n;
}

vd_status_t demo_autores_live_frame(demo_autores_live_t *lv, const demo_opts_t *o, const vd_frame_t *f,
                                    uint64_t frame, bool *now, char *err, size_t err_len)
{
    *now = false;
    if (!lv->on) {
        return VD_OK;
    }
    const uint64_t i = lv->seen++;   // this frame's place in the measurement (demo_autores_live_start zeroes it)
    const bool waiting = lv->first_box == UINT64_MAX;
    const bool last = waiting && i + 1u >= DEMO_AUTORES_LIVE_WAIT;
    if (waiting && !last && lv->a.frames >= DEMO_AUTORES_MAX_FRAMES && i % DEMO_AUTORES_LIVE_STRIDE != 0u) {
        return VD_OK;   // no box yet in the frames measured: the sparse wait
    }
    const double t0 = demo_now_s();
    vd_status_t st = VD_OK;
    if (lv->fa == NULL) {
        st = demo_flipagree_new(&lv->fa, o, f, err, err_len);
    }
    if (st == VD_OK) {
        st = demo_flipagree_add(lv->fa, f, &lv->a);
        if (st != VD_OK) {
            snprintf(err, err_len, "--cnn-full-res/--cnn-polarity auto: frame %llu: detector failed",
                     (unsigned long long)frame);
        }
    }
    lv->a.seconds += demo_now_s() - t0;
    if (st != VD_OK) {
        demo_autores_live_free(lv);
        lv->on = false;
        return st;
    }
    if (waiting && autores_boxes(&lv->a) > 0u) {
        lv->first_box = i;
    }
    // from the first frame with a box on, every frame is measured
    const bool enough = lv->first_box != UINT64_MAX && i - lv->first_box + 1u >= DEMO_AUTORES_MAX_FRAMES;
    if (!enough && !last) {
        return VD_OK;
    }
    demo_autores_decide(&lv->a);
    demo_autores_live_free(lv);
    lv->on = false;
    lv->decided = true;
    lv->from = frame;
    *now = true;
    return VD_OK;
}

bool demo_autores_live_wait_began(const demo_autores_live_t *lv, char *buf, size_t len)
{
    if (!lv->on || lv->first_box != UINT64_MAX || lv->seen != DEMO_AUTORES_MAX_FRAMES) {
        return false;
    }
    snprintf(buf, len, "no box in the first %u frames; measuring every %uth frame until one has a box (up to frame %u)",
             (unsigned)DEMO_AUTORES_MAX_FRAMES, (unsigned)DEMO_AUTORES_LIVE_STRIDE, (unsigned)DEMO_AUTORES_LIVE_WAIT);
    return true;
}

void demo_autores_live_free(demo_autores_live_t *lv)
{
    demo_flipagree_free(lv->fa);
    lv->fa = NULL;
}
