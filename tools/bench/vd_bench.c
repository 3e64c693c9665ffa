// SPDX-License-Identifier: MIT
// Benchmark of each vd stage and the whole detector on image files, without Python: median times and callgrind runs.
//
// Usage: vd_bench [--iters N] [--model m.vdm] [--thr-mode constant|adaptive] [--max-cands K] [--worst]
//                 [--quiet] file-or-list...
//   file: PGM (P5, 8/16-bit, own reader), PNG or JPEG (stb_image); a *.txt/*.lst argument is a list of paths, one a line.
// For each frame every stage runs N times (after one warm-up run when N > 1) timed with
// clock_gettime(CLOCK_MONOTONIC); the frame's figure is the median; the printed figure is the median over
// frames (ROI stages: over candidates). Each stage is a call of the public vd function itself, so under
//   valgrind --tool=callgrind --callgrind-out-file=cg.out vd_bench --iters 1 ...
// `callgrind_annotate --inclusive=yes cg.out` gives the instructions of each stage as the inclusive count of
// its wrapper cg_<stage> (divide by the call counts this program prints).
// Docs: docs/performance.md; the Python driver with OpenCV in the same run: python3 -m vdtools.evaluation.bench.
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <stb/stb_image.h>

#include "vd/vd.h"

enum {
    S_DETECTOR, S_THRESHOLD, S_COMPONENTS, S_MEDIAN3, S_MEDIAN5, S_OTSU, S_CONTOURS_FRAME,
    S_CONTRAST, S_MEDIAN3_ROI, S_MEDIAN5_ROI, S_OTSU_ROI, S_REFINE, S_CONTOURS_ROI, S_RESAMPLE, S_DBN, S_COUNT
};
static const char *const k_stage_name[S_COUNT] = {
    "detector (whole frame)", "threshold (frame)", "components (frame)", "median3 (frame)", "median5 (frame)",
    "otsu (frame)", "contours (hot mask, frame)", "contrast map r16 (frame)", "median3 (candidate ROI)", "median5 (candidate ROI)",
    "otsu (candidate ROI)", "refine (candidate ROI)", "contours (refined ROI)", "resample 32x32 (cand.)",
    "DBN (per sample)"};

typedef struct {
    double *v;
    size_t n, cap;
} series_t;

static series_t g_series[S_COUNT];
static int g_iters = 15;

static void die(const char *msg, const char *arg)
{
    fprintf(stderr, "vd_bench: %s%s%s\n", msg, arg ? ": " : "", arg ? arg : "");
    exit(2);
}

static void *xmalloc(size_t n)
{
    void *p = NULL;
    if (n == 0u) {
        n = 8u;
    }
    if (posix_memalign(&p, 64, n) != 0) {
        die("out of memory", NULL);
    }
    memset(p, 0, n);
    return p;
}

static void push(int s, double us)
{
    series_t *se = &g_series[s];
    if (se->n == se->cap) {
        se->cap = se->cap ? se->cap * 2u : 64u;
        se->v = realloc(se->v, se->cap * sizeof(double));
        if (se->v == NULL) {
            die("out of memory", NULL);
        }
    }
    se->v[se->n++] = us;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, size_t n)
{
    if (n == 0u) {
        return 0.0;
    }
    qsort(v, n, sizeof(double), cmp_double);
    return (n % 2u) ? v[n / 2u] : 0.5 * (v[n / 2u - 1u] + v[n / 2u]);
}

static double now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

// Times one stage: g_iters calls (after a warm-up when g_iters > 1); records the median.
// The stage is a statement using the status variable `st_`; any status other than OK/CAPACITY aborts.
#define TIME_STAGE(idx, call)                                                                       \
    do {                                                                                            \
        double t_[256];                                                                             \
        int n_ = g_iters > 256 ? 256 : g_iters;                                                     \
        vd_status_t st_ = VD_OK;                                                                          \
        if (n_ > 1) {                                                                               \
            st_ = (call);                                                                           \
        }                                                                                           \
        for (int i_ = 0; i_ < n_; i_++) {                                                           \
            double a_ = now_us();                                                                   \
            st_ = (call);                                                                           \
            t_[i_] = now_us() - a_;                                                                 \
        }                                                                                           \
        if (st_ != VD_OK && st_ != VD_ERR_CAPACITY) {                                               \
            fprintf(stderr, "vd_bench: %s: %s\n", k_stage_name[idx], vd_status_str(st_));           \
            exit(1);                                                                                \
        }                                                                                           \
        push(idx, median(t_, (size_t)n_));                                                          \
    } while (0)

// One non-inlined wrapper per stage, so callgrind's inclusive count of cg_<stage> is exactly that stage
// (the detector and refine also call vd_threshold_u8, vd_median3_u8, ... internally).
#define CG __attribute__((noinline))
static size_t g_cg_calls[S_COUNT];  // also keeps identical-code folding from merging wrappers
CG static vd_status_t cg_detector(vd_detector_t *d, const vd_frame_t *f, vd_detection_t *o, size_t cap, size_t *n)
{ g_cg_calls[S_DETECTOR]++; return vd_detector_run(d, f, o, cap, n); }
CG static vd_status_t cg_threshold(const vd_view_u8_t *s, uint8_t t, vd_image_u8_t *d)
{ g_cg_calls[S_THRESHOLD]++; return vd_threshold_u8(s, NULL, t, d); }
CG static vd_status_t cg_components(const vd_view_u8_t *m, void *ws, size_t b, vd_component_t *o, size_t cap, size_t *n)
{ g_cg_calls[S_COMPONENTS]++; return vd_components_label(m, NULL, ws, b, o, cap, n); }
CG static vd_status_t cg_contrast(const vd_view_u8_t *s, void *ws, size_t b, vd_image_u8_t *d)
{ g_cg_calls[S_CONTRAST]++; return vd_contrast_map_u8(s, 16u, VD_CONTRAST_BOTH, ws, b, d); }
CG static vd_status_t cg_median3(const vd_view_u8_t *s, const vd_rect_t *r, vd_image_u8_t *d)
{ g_cg_calls[S_MEDIAN3]++; return vd_median3_u8(s, r, d); }
CG static vd_status_t cg_median5(const vd_view_u8_t *s, const vd_rect_t *r, vd_image_u8_t *d)
{ g_cg_calls[S_MEDIAN5]++; return vd_median5_u8(s, r, d); }
CG static vd_status_t cg_median3_roi(const vd_view_u8_t *s, const vd_rect_t *r, vd_image_u8_t *d)
{ g_cg_calls[S_MEDIAN3_ROI]++; return vd_median3_u8(s, r, d); }
CG static vd_status_t cg_median5_roi(const vd_view_u8_t *s, const vd_rect_t *r, vd_image_u8_t *d)
{ g_cg_calls[S_MEDIAN5_ROI]++; return vd_median5_u8(s, r, d); }
CG static vd_status_t cg_otsu(const vd_view_u8_t *s, const vd_rect_t *r, uint8_t *t)
{ g_cg_calls[S_OTSU]++; return vd_otsu_u8(s, r, t); }
CG static vd_status_t cg_otsu_roi(const vd_view_u8_t *s, const vd_rect_t *r, uint8_t *t)
{ g_cg_calls[S_OTSU_ROI]++; return vd_otsu_u8(s, r, t); }
CG static vd_status_t cg_contours(const vd_view_u8_t *m, void *ws, size_t b, vd_point_t *p, size_t pc, vd_contour_t *c,
                                  size_t cc, size_t *nc, size_t *np)
{ g_cg_calls[S_CONTOURS_FRAME]++; return vd_contour_find_external(m, ws, b, p, NULL, pc, c, cc, nc, np); }
CG static vd_status_t cg_contours_roi(const vd_view_u8_t *m, void *ws, size_t b, vd_point_t *p, size_t pc,
                                      vd_contour_t *c, size_t cc, size_t *nc, size_t *np)
{ g_cg_calls[S_CONTOURS_ROI]++; return vd_contour_find_external(m, ws, b, p, NULL, pc, c, cc, nc, np); }
CG static vd_status_t cg_refine(const vd_view_u8_t *s, const vd_rect_t *r, const vd_refine_cfg_t *cfg, void *ws, size_t b,
                                vd_image_u8_t *m)
{ g_cg_calls[S_REFINE]++; return vd_refine_region(s, r, cfg, ws, b, m, NULL); }
CG static vd_status_t cg_resample(const vd_view_u8_t *s, const vd_rect_t *r, uint8_t *d)
{ g_cg_calls[S_RESAMPLE]++; return vd_resample_u8(s, r, d, 32u, 32u); }
CG static vd_status_t cg_dbn(const vd_dbn_model_t *m, const uint8_t *in, void *ws, size_t b, uint8_t *score)
{ g_cg_calls[S_DBN]++; return vd_dbn_classify(m, in, ws, b, score); }

typedef struct {
    uint32_t w, h;
    int u16;
    uint8_t *p8;
    uint16_t *p16;
} img_t;

// Reads the next whitespace/comment-separated decimal field of a PNM header.
static int pnm_field(FILE *f, unsigned long *v)
{
    int ch = fgetc(f);
    while (ch == '#' || ch == ' ' || ch == '\t' || ch == '\r' || ch == '\n') {
        if (ch == '#') {
            while (ch != '\n' && ch != EOF) {
                ch = fgetc(f);
            }
        }
        ch = fgetc(f);
    }
    if (ch < '0' || ch > '9') {
        return -1;
    }
    *v = 0;
    while (ch >= '0' && ch <= '9') {
        *v = *v * 10u + (unsigned long)(ch - '0');
        ch = fgetc(f);
    }
    return 0;   // the single whitespace after the field is consumed
}

// Binary PGM (P5), 8-bit or 16-bit big-endian: stb_image reads 16-bit PNM with the wrong byte order.
static int load_pgm(const char *path, img_t *im)
{
    FILE *f = fopen(path, "rb");
    unsigned long w, h, maxv;
    if (f == NULL) {
        return -1;
    }
    if (fgetc(f) != 'P' || fgetc(f) != '5' || pnm_field(f, &w) || pnm_field(f, &h) || pnm_field(f, &maxv) ||
        w == 0u || h == 0u || w > 65535u || h > 65535u || maxv == 0u || maxv > 65535u) {
        fclose(f);
        return -1;
    }
    size_t n = (size_t)w * h;
    int ok;
    if (maxv < 256u) {
        im->p8 = malloc(n);
        ok = im->p8 != NULL && fread(im->p8, 1, n, f) == n;
    } else {
        im->u16 = 1;
        im->p16 = malloc(n * 2u);
        ok = im->p16 != NULL && fread(im->p16, 2, n, f) == n;
        for (size_t i = 0; ok && i < n; i++) {
            const uint8_t *b = (const uint8_t *)&im->p16[i];
            im->p16[i] = (uint16_t)((unsigned)b[0] << 8 | b[1]);
        }
    }
    fclose(f);
    im->w = (uint32_t)w;
    im->h = (uint32_t)h;
    return ok ? 0 : -1;
}

static int has_suffix(const char *s, const char *suf);

static int load_image(const char *path, img_t *im)
{
    int w, h, c;
    memset(im, 0, sizeof(*im));
    if (has_suffix(path, ".pgm")) {
        return load_pgm(path, im);
    }
    if (stbi_is_16_bit(path)) {
        stbi_us *d = stbi_load_16(path, &w, &h, &c, 1);
        if (d == NULL) {
            return -1;
        }
        im->u16 = 1;
        im->p16 = d;
    } else {
        stbi_uc *d = stbi_load(path, &w, &h, &c, 1);
        if (d == NULL) {
            return -1;
        }
        im->p8 = d;
    }
    im->w = (uint32_t)w;
    im->h = (uint32_t)h;
    return 0;
}

// Synthetic worst cases (8-bit, w x h): 0 all-hot, 1 1-px checkerboard, 2 isolated dots, 3 salt-and-pepper 50 %.
static const char *const k_worst_name[] = {"all-hot", "checkerboard-1px", "dots-every-2nd", "salt-pepper-50%"};
static void make_worst(int kind, img_t *im, uint32_t w, uint32_t h)
{
    memset(im, 0, sizeof(*im));
    im->w = w;
    im->h = h;
    im->p8 = xmalloc((size_t)w * h);
    uint32_t rng = 12345u;
    for (uint32_t y = 0; y < h; y++) {
        for (uint32_t x = 0; x < w; x++) {
            uint8_t v = 0;
            switch (kind) {
            case 0: v = 255; break;
            case 1: v = ((x + y) & 1u) ? 0 : 255; break;
            case 2: v = ((x | y) & 1u) ? 0 : 255; break;
            default:
                rng = rng * 1664525u + 1013904223u;
                v = (rng >> 31) ? 255 : 0;
                break;
            }
            im->p8[(size_t)y * w + x] = v;
        }
    }
}

typedef struct {
    vd_dbn_model_t model;
    int have_model;
    uint8_t thr_mode;
    int max_cands;
    int quiet;
    size_t frames, cands, samples;
    uint64_t hot_total, comps_total;  // detector counts summed over frames (cross-check with Python)
} opts_t;

static void *read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        die("cannot open", path);
    }
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    void *buf = xmalloc((size_t)n + 8u);
    if (fread(buf, 1, (size_t)n, f) != (size_t)n) {
        die("cannot read", path);
    }
    fclose(f);
    *len = (size_t)n;
    return buf;
}

static double run_detector_only(opts_t *o, const img_t *im, const char *label)
{
    vd_detector_cfg_t cfg;
    vd_detector_cfg_default(&cfg);
    cfg.max_width = im->w;
    cfg.max_height = im->h;
    cfg.thr_mode = o->thr_mode;
    size_t bytes;
    const vd_dbn_model_t *m = o->have_model ? &o->model : NULL;
    if (vd_detector_workspace_size(&cfg, m, &bytes) != VD_OK) {
        die("detector workspace size", label);
    }
    void *ws = xmalloc(bytes);
    static vd_detector_t det;
    if (vd_detector_init(&det, &cfg, m, ws, bytes) != VD_OK) {
        die("detector init", label);
    }
    vd_frame_t fr = {im->u16 ? (const void *)im->p16 : (const void *)im->p8, im->w, im->h,
                     im->u16 ? (size_t)im->w * 2u : (size_t)im->w, im->u16 ? VD_PIX_U16 : VD_PIX_U8, 0u, 0u};
    vd_detection_t out[64];
    size_t cnt = 0;
    double t[256];
    int n = g_iters > 256 ? 256 : g_iters;
    vd_status_t st = VD_OK;
    for (int i = 0; i < n; i++) {
        double a = now_us();
        st = cg_detector(&det, &fr, out, 64u, &cnt);
        t[i] = now_us() - a;
    }
    const vd_detector_stats_t *s = vd_detector_last_stats(&det);
    double med = median(t, (size_t)n);
    printf("  %-36s %5ux%-5u %10.1f us  %-16s hot=%u runs=%u comps=%u kept=%u refined=%u dets=%zu overflow "
           "runs/c/cand/cont/det=%u/%u/%u/%u/%u ws=%zu B\n",
           label, im->w, im->h, med, vd_status_str(st), s->hot_pixels, s->runs, s->components, s->kept, s->refined,
           cnt, s->overflow_runs, s->overflow_components, s->overflow_candidates, s->overflow_contours, s->overflow_detections, bytes);
    free(ws);
    return med;
}

static void bench_frame(opts_t *o, const img_t *im)
{
    const uint32_t w = im->w, h = im->h;
    // Detector first: it also chooses the frame's hot threshold (adaptive mode).
    vd_detector_cfg_t cfg;
    vd_detector_cfg_default(&cfg);
    cfg.max_width = w;
    cfg.max_height = h;
    cfg.thr_mode = o->thr_mode;
    size_t bytes;
    const vd_dbn_model_t *m = o->have_model ? &o->model : NULL;
    if (vd_detector_workspace_size(&cfg, m, &bytes) != VD_OK) {
        die("detector workspace size", NULL);
    }
    void *dws = xmalloc(bytes);
    static vd_detector_t det;
    if (vd_detector_init(&det, &cfg, m, dws, bytes) != VD_OK) {
        die("detector init", NULL);
    }
    vd_frame_t fr = {im->u16 ? (const void *)im->p16 : (const void *)im->p8, w, h,
                     im->u16 ? (size_t)w * 2u : (size_t)w, im->u16 ? VD_PIX_U16 : VD_PIX_U8, 0u, 0u};
    vd_detection_t out[64];
    size_t cnt = 0;
    TIME_STAGE(S_DETECTOR, cg_detector(&det, &fr, out, 64u, &cnt));
    o->frames++;
    uint8_t thr = (uint8_t)vd_detector_last_stats(&det)->hot_thr_u8;
    o->hot_total += vd_detector_last_stats(&det)->hot_pixels;
    o->comps_total += vd_detector_last_stats(&det)->components;
    free(dws);
    if (im->u16) {
        return;   // stage benchmarks are 8-bit
    }

    vd_view_u8_t src = {im->p8, w, h, w};
    uint8_t *mask = xmalloc((size_t)w * h);
    uint8_t *dst = xmalloc((size_t)w * h);
    vd_image_u8_t mimg = {mask, w, h, w};
    vd_image_u8_t dimg = {dst, w, h, w};
    vd_view_u8_t mview = {mask, w, h, w};

    TIME_STAGE(S_THRESHOLD, cg_threshold(&src, thr, &mimg));

    size_t ccb;
    vd_components_workspace_size(w, h, &ccb);
    void *ccws = xmalloc(ccb);
    size_t ccap = (size_t)((w + 1u) / 2u) * ((h + 1u) / 2u);
    vd_component_t *comps = xmalloc(ccap * sizeof(vd_component_t));
    size_t ncomp = 0;
    TIME_STAGE(S_COMPONENTS, cg_components(&mview, ccws, ccb, comps, ccap, &ncomp));

    TIME_STAGE(S_MEDIAN3, cg_median3(&src, NULL, &dimg));
    TIME_STAGE(S_MEDIAN5, cg_median5(&src, NULL, &dimg));
    uint8_t t8 = 0;
    TIME_STAGE(S_OTSU, cg_otsu(&src, NULL, &t8));

    size_t ctb;
    vd_contour_workspace_size(w, h, &ctb);
    void *ctws = xmalloc(ctb);
    size_t pcap = 4u * (size_t)w * h;
    vd_point_t *pts = xmalloc(pcap * sizeof(vd_point_t));
    vd_contour_t *conts = xmalloc(ccap * sizeof(vd_contour_t));
    size_t nc = 0, np = 0;
    TIME_STAGE(S_CONTOURS_FRAME, cg_contours(&mview, ctws, ctb, pts, pcap, conts, ccap, &nc, &np));

    size_t cmb;
    vd_contrast_map_workspace_size(w, &cmb);
    void *cmws = xmalloc(cmb);
    TIME_STAGE(S_CONTRAST, cg_contrast(&src, cmws, cmb, &dimg));
    free(cmws);

    // Candidates as the detector makes them: rules, then expansion.
    vd_components_rules_t rules;
    vd_components_rules_default(&rules);
    size_t kept = 0;
    vd_components_filter(comps, ncomp, &rules, &kept);
    size_t rfb;
    vd_refine_workspace_size(w, h, &rfb);
    void *rfws = xmalloc(rfb);
    vd_refine_cfg_t rcfg;
    vd_refine_cfg_default(&rcfg);
    uint8_t sample[32 * 32];
    size_t dbnb = 0;
    void *dbnws = NULL;
    if (o->have_model) {
        vd_dbn_workspace_size(&o->model, &dbnb);
        dbnws = xmalloc(dbnb);
    }
    for (size_t i = 0; i < kept && (int)i < o->max_cands; i++) {
        vd_rect_t r;
        if (vd_rect_expand(&comps[i].box, VD_RECT_EXPAND_W_Q8, VD_RECT_EXPAND_H_Q8, w, h, &r) != VD_OK) {
            continue;
        }
        vd_image_u8_t rimg = {dst, (uint32_t)r.w, (uint32_t)r.h, (size_t)r.w};
        vd_view_u8_t rview = {dst, (uint32_t)r.w, (uint32_t)r.h, (size_t)r.w};
        o->cands++;
        TIME_STAGE(S_MEDIAN3_ROI, cg_median3_roi(&src, &r, &rimg));
        TIME_STAGE(S_MEDIAN5_ROI, cg_median5_roi(&src, &r, &rimg));
        TIME_STAGE(S_OTSU_ROI, cg_otsu_roi(&src, &r, &t8));
        TIME_STAGE(S_REFINE, cg_refine(&src, &r, &rcfg, rfws, rfb, &rimg));
        TIME_STAGE(S_CONTOURS_ROI, cg_contours_roi(&rview, ctws, ctb, pts, pcap, conts, ccap, &nc, &np));
        TIME_STAGE(S_RESAMPLE, cg_resample(&src, &r, sample));
        if (o->have_model) {
            uint8_t score = 0;
            o->samples++;
            TIME_STAGE(S_DBN, cg_dbn(&o->model, sample, dbnws, dbnb, &score));
        }
    }
    free(dbnws);
    free(rfws);
    free(conts);
    free(pts);
    free(ctws);
    free(comps);
    free(ccws);
    free(dst);
    free(mask);
}

static int has_suffix(const char *s, const char *suf)
{
    size_t a = strlen(s), b = strlen(suf);
    return a >= b && strcmp(s + a - b, suf) == 0;
}

static void bench_path(opts_t *o, const char *path)
{
    img_t im;
    if (load_image(path, &im) != 0) {
        fprintf(stderr, "vd_bench: skipping %s: %s\n", path, stbi_failure_reason());
        return;
    }
    bench_frame(o, &im);
    if (has_suffix(path, ".pgm")) {
        free(im.u16 ? (void *)im.p16 : (void *)im.p8);
    } else {
        stbi_image_free(im.u16 ? (void *)im.p16 : (void *)im.p8);
    }
}

int main(int argc, char **argv)
{
    opts_t o;
    memset(&o, 0, sizeof(o));
    o.max_cands = 8;
    int worst = 0;
    uint32_t worst_dim = 0;
    void *blob = NULL;
    int nfiles = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--iters") == 0 && i + 1 < argc) {
            g_iters = atoi(argv[++i]);
            if (g_iters < 1) {
                g_iters = 1;
            }
        } else if (strcmp(a, "--model") == 0 && i + 1 < argc) {
            size_t len;
            blob = read_file(argv[++i], &len);
            if (vd_dbn_load(&o.model, blob, len) != VD_OK) {
                die("bad model", argv[i]);
            }
            o.have_model = 1;
        } else if (strcmp(a, "--thr-mode") == 0 && i + 1 < argc) {
            o.thr_mode = strcmp(argv[++i], "adaptive") == 0 ? VD_DETECTOR_THR_ADAPTIVE : VD_DETECTOR_THR_CONSTANT;
        } else if (strcmp(a, "--max-cands") == 0 && i + 1 < argc) {
            o.max_cands = atoi(argv[++i]);
        } else if (strcmp(a, "--worst") == 0) {
            worst = 1;
        } else if (strcmp(a, "--worst-dim") == 0 && i + 1 < argc) {
            worst_dim = (uint32_t)atoi(argv[++i]);
        } else if (strcmp(a, "--help") == 0 || a[0] == '-') {
            printf("usage: vd_bench [--iters N] [--model m.vdm] [--thr-mode constant|adaptive] [--max-cands K]\n"
                   "                [--worst] [--worst-dim D] file|list.txt ...\n");
            return a[0] == '-' && strcmp(a, "--help") != 0 ? 2 : 0;
        } else if (has_suffix(a, ".txt") || has_suffix(a, ".lst")) {
            FILE *f = fopen(a, "r");
            if (f == NULL) {
                die("cannot open list", a);
            }
            char line[4096];
            while (fgets(line, sizeof line, f) != NULL) {
                line[strcspn(line, "\r\n")] = '\0';
                if (line[0] != '\0' && line[0] != '#') {
                    bench_path(&o, line);
                    nfiles++;
                }
            }
            fclose(f);
        } else {
            bench_path(&o, a);
            nfiles++;
        }
    }
    printf("vd_bench: %zu frames, %zu candidates, %zu DBN samples, %d iterations per stage (median); "
           "detector: %llu hot pixels, %llu components in all\n", o.frames, o.cands, o.samples, g_iters,
           (unsigned long long)o.hot_total, (unsigned long long)o.comps_total);
    printf("%-30s %8s %10s\n", "stage", "calls", "median us");
    for (int s = 0; s < S_COUNT; s++) {
        if (g_series[s].n > 0u) {
            size_t n = g_series[s].n;
            printf("%-30s %8zu %10.2f\n", k_stage_name[s], n, median(g_series[s].v, n));
        }
        free(g_series[s].v);
    }
    if (worst) {
        printf("worst cases (detector, default caps):\n");
        for (int k = 0; k < 4; k++) {
            img_t im;
            make_worst(k, &im, 640u, 512u);
            run_detector_only(&o, &im, k_worst_name[k]);
            free(im.p8);
        }
        if (worst_dim > 0u) {
            for (int k = 0; k < 4; k += 3) {
                img_t im;
                make_worst(k, &im, worst_dim, worst_dim);
                char label[64];
                snprintf(label, sizeof label, "max-size %s", k_worst_name[k]);
                run_detector_only(&o, &im, label);
                free(im.p8);
            }
        }
    }
    free(blob);
    (void)nfiles;
    (void)g_cg_calls;
    return 0;
}
