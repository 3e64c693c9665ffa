// SPDX-License-Identifier: MIT
// vd_fir_demo --report DIR: one self-contained index.html (summary, stage times, evaluation, PR curve, gallery).
//
// The page needs nothing beside it: CSS and the precision-recall curve (SVG) are
// inline and the gallery's thumbnails are PNG data URIs, so index.html can be
// mailed, attached to a CI run or opened from any directory. The gallery holds
// the DEMO_REPORT_MAX_THUMBS frames with the most misses + false positives (ties:
// the earlier frame); while the run goes on, each such frame is drawn as a
// thumbnail (at most DEMO_REPORT_THUMB_W pixels wide) into a hidden staging
// directory inside DIR, and one that falls out of the top set is deleted again,
// so memory is one frame canvas and disk at most DEMO_REPORT_MAX_THUMBS small
// PNGs. At the end the page is written under a temporary name and renamed
// (out.c), the thumbnails are embedded and the staging directory removed.
// Colours: ground truth cyan (matched) / orange (missed); detections green (true
// positive), red (false positive), grey (in an ignore region).
#include "report.h"

#include "json.h"
#include "out.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>


static void html_text(FILE *f, const char *s)
{
    for (; *s != '\0'; s++) {
        switch (*s) {
        case '&': fputs("&amp;", f); break;
        case '<': fputs("&lt;", f); break;
        case '>': fputs("&gt;", f); break;
        case '"': fputs("&quot;", f); break;
        default: fputc(*s, f); break;
        }
    }
}

static void base64_file(FILE *out, const uint8_t *b, size_t n)
{
    static const char k[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)b[i] << 16;
        if (i + 1 < n) {
            v |= (uint32_t)b[i + 1] << 8;
        }
        if (i + 2 < n) {
            v |= b[i + 2];
        }
        fputc(k[(v >> 18) & 63u], out);
        fputc(k[(v >> 12) & 63u], out);
        fputc(i + 1 < n ? k[(v >> 6) & 63u] : '=', out);
        fputc(i + 2 < n ? k[v & 63u] : '=', out);
    }
}

vd_status_t demo_report_open(demo_report_t *rp, const char *dir, char *err, size_t err_len)
{
    memset(rp, 0, sizeof *rp);
    if (strlen(dir) >= sizeof rp->dir) {
        snprintf(err, err_len, "--report: path too long");
        return VD_ERR_ARG;
    }
    snprintf(rp->dir, sizeof rp->dir, "%s", dir);
    struct stat sb;
    rp->created_dir = stat(dir, &sb) != 0;
    vd_status_t st = demo_mkdirs(dir, err, err_len);
    if (st != VD_OK) {
        return st;
    }
    snprintf(rp->stage, sizeof rp->stage, "%s/.vd_report.tmp.%ld", dir, (long)getpid());
    if (mkdir(rp->stage, 0777) != 0 && errno != EEXIST) {
        snprintf(err, err_len, "cannot create directory %s: %s", rp->stage, strerror(errno));
        demo_report_abort(rp);
        return VD_ERR_IO;
    }
    rp->staging = true;
    return VD_OK;
}

static void thumb_path(const demo_report_t *rp, const demo_report_thumb_t *t, char *out, size_t cap)
{
    snprintf(out, cap, "%s/t%llu.png", rp->stage, (unsigned long long)t->file_id);
}

void demo_report_abort(demo_report_t *rp)
{
    if (rp->staging) {
        char p[4400];
        for (size_t i = 0; i < rp->n_thumbs; i++) {
            thumb_path(rp, &rp->thumb[i], p, sizeof p);
            remove(p);
        }
        rmdir(rp->stage);
        rp->staging = false;
    }
    if (rp->created_dir) {
        rmdir(rp->dir);   // only if empty: never removes what is not ours
        rp->created_dir = false;
    }
    vd_rgb_free(&rp->full);
    vd_rgb_free(&rp->small);
}

// Box in thumbnail pixels (scale s), at least 1 x 1.
static vd_rect_t scaled(double x, double y, double w, double h, uint32_t s)
{
    vd_rect_t r;
    r.x = (int32_t)lround(x / s);
    r.y = (int32_t)lround(y / s);
    long ww = lround(w / s), hh = lround(h / s);
    r.w = (int32_t)(ww < 1 ? 1 : ww);
    r.h = (int32_t)(hh < 1 ? 1 : hh);
    return r;
}

// Renders the frame at 1/s of its size (box average) and draws boxes on it.
static vd_status_t render_thumb(demo_report_t *rp, const vd_frame_t *f, uint32_t lo, uint32_t hi,
                                const demo_gt_image_t *im, const bool *gt_used, const demo_det_t *det,
                                const int8_t *matched, size_t n, const char *path, char *err, size_t err_len)
{
    const uint32_t s = f->width > DEMO_REPORT_THUMB_W ? (f->width + DEMO_REPORT_THUMB_W - 1u) / DEMO_REPORT_THUMB_W : 1u;
    const uint32_t tw = f->width / s > 0 ? f->width / s : 1u, th = f->height / s > 0 ? f->height / s : 1u;
    vd_status_t st = VD_OK;
    if (rp->full.width != f->width || rp->full.height != f->height) {
        vd_rgb_free(&rp->full);
        vd_rgb_free(&rp->small);
        st = vd_rgb_alloc(&rp->full, f->width, f->height);
        if (st == VD_OK) {
            st = vd_rgb_alloc(&rp->small, tw, th);
        }
        if (st != VD_OK) {
            snprintf(err, err_len, "out of memory");
            return st;
        }
    }
    st = vd_rgb_from_frame(&rp->full, f, lo, hi);
    if (st != VD_OK) {
        snprintf(err, err_len, "--report: cannot render a frame");
        return st;
    }
    for (uint32_t y = 0; y < th; y++) {
        for (uint32_t x = 0; x < tw; x++) {
            for (uint32_t c = 0; c < 3u; c++) {
                uint32_t sum = 0;
                for (uint32_t dy = 0; dy < s; dy++) {
                    const uint8_t *row = rp->full.data + (size_t)(y * s + dy) * rp->full.stride;
                    for (uint32_t dx = 0; dx < s; dx++) {
                        sum += row[(size_t)(x * s + dx) * 3u + c];
                    }
                }
                rp->small.data[(size_t)y * rp->small.stride + (size_t)x * 3u + c] = (uint8_t)(sum / (s * s));
            }
        }
    }
    if (im != NULL) {
        const double sx = im->normalised ? f->width : 1.0, sy = im->normalised ? f->height : 1.0;
        for (size_t b = 0; b < im->n; b++) {
            const demo_gt_box_t *g = &im->box[b];
            if (!g->vehicle) {
                continue;
            }
            vd_rect_t r = scaled(g->x * sx, g->y * sy, g->w * sx, g->h * sy, s);
            if (gt_used[b]) {
                vd_rgb_draw_rect(&rp->small, &r, 0, 200, 255, 1);
            } else {
                vd_rgb_draw_rect(&rp->small, &r, 255, 150, 0, 2);
            }
        }
    }
    for (size_t i = 0; i < n; i++) {
        vd_rect_t r = scaled(det[i].box.x, det[i].box.y, det[i].box.w, det[i].box.h, s);
        // grow by one pixel so a detection never hides the ground-truth outline it matches
        r.x -= 1;
        r.y -= 1;
        r.w += 2;
        r.h += 2;
        if (matched[i] == 1) {
            vd_rgb_draw_rect(&rp->small, &r, 0, 230, 0, 1);
        } else if (matched[i] == 0) {
            vd_rgb_draw_rect(&rp->small, &r, 255, 40, 40, 2);
        } else {
            vd_rgb_draw_rect(&rp->small, &r, 150, 150, 150, 1);
        }
    }
    return vd_write_png_rgb(path, &rp->small, err, err_len);
}

vd_status_t demo_report_frame(demo_report_t *rp, uint64_t index, const char *name, const vd_frame_t *f, uint32_t lo,
                              uint32_t hi, const demo_gt_image_t *im, const bool *gt_used, const demo_det_t *det,
                              const int8_t *matched, size_t n, char *err, size_t err_len)
{
    uint32_t tp = 0, fp = 0, fn = 0;
    for (size_t i = 0; i < n; i++) {
        tp += matched[i] == 1;
        fp += matched[i] == 0;
    }
    for (size_t b = 0; im != NULL && b < im->n; b++) {
        fn += im->box[b].vehicle && !gt_used[b];
    }
    if (fp + fn == 0) {
        return VD_OK;
    }
    rp->frames_with_errors++;
    const uint32_t errors = fp + fn;
    size_t slot = rp->n_thumbs;
    if (rp->n_thumbs == DEMO_REPORT_MAX_THUMBS) {
        // the weakest entry: fewest errors, then the latest frame
        slot = 0;
        for (size_t i = 1; i < rp->n_thumbs; i++) {
            const demo_report_thumb_t *a = &rp->thumb[i], *w = &rp->thumb[slot];
            if (a->fp + a->fn < w->fp + w->fn || (a->fp + a->fn == w->fp + w->fn && a->index > w->index)) {
                slot = i;
            }
        }
        if (errors <= rp->thumb[slot].fp + rp->thumb[slot].fn) {
            return VD_OK;
        }
        char old[4400];
        thumb_path(rp, &rp->thumb[slot], old, sizeof old);
        remove(old);
    } else {
        rp->n_thumbs++;
    }
    demo_report_thumb_t *t = &rp->thumb[slot];
    memset(t, 0, sizeof *t);
    snprintf(t->name, sizeof t->name, "%s", name);
    t->tp = tp;
    t->fp = fp;
    t->fn = fn;
    t->index = index;
    t->file_id = rp->next_file_id++;
    char path[4400];
    thumb_path(rp, t, path, sizeof path);
    vd_status_t st = render_thumb(rp, f, lo, hi, im, gt_used, det, matched, n, path, err, err_len);
    if (st != VD_OK) {
        remove(path);
        rp->thumb[slot] = rp->thumb[--rp->n_thumbs];   // keep the table consistent for abort
    }
    return st;
}

// ---------------------------------------------------------------------------
// The page.

#define SVG_W 460
#define SVG_H 340
#define PL 56   // plot margins
#define PR 16
#define PT 16
#define PB 48

static double px(double r)
{
    return PL + r * (SVG_W - PL - PR);
}

static double py(double p)
{
    return SVG_H - PB - p * (SVG_H - PT - PB);
}

static void pr_svg(FILE *f, const double *r, const double *p, size_t n, double ap)
{
    fprintf(f, "<svg id=\"pr-curve\" xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\" "
               "viewBox=\"0 0 %d %d\" role=\"img\" aria-label=\"precision-recall curve\">\n",
            SVG_W, SVG_H, SVG_W, SVG_H);
    fprintf(f, "<rect x=\"0\" y=\"0\" width=\"%d\" height=\"%d\" fill=\"#fff\"/>\n", SVG_W, SVG_H);
    for (int k = 0; k <= 5; k++) {
        const double v = k / 5.0;
        fprintf(f, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>", px(0), py(v), px(1), py(v));
        fprintf(f, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>", px(v), py(0), px(v), py(1));
        fprintf(f, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"12\" text-anchor=\"end\">%.1f</text>", px(0) - 6,
                py(v) + 4, v);
        fprintf(f, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"12\" text-anchor=\"middle\">%.1f</text>\n", px(v),
                py(0) + 16, v);
    }
    fprintf(f, "<text x=\"%.1f\" y=\"%d\" font-size=\"13\" text-anchor=\"middle\">recall</text>", px(0.5),
            SVG_H - 10);
    fprintf(f, "<text x=\"14\" y=\"%.1f\" font-size=\"13\" text-anchor=\"middle\" transform=\"rotate(-90 14 %.1f)\">"
               "precision</text>\n",
            py(0.5), py(0.5));
    if (n > 0) {
        // interpolated precision (the envelope): its area is the AP
        double *env = malloc(n * sizeof *env);
        if (env != NULL) {
            for (size_t i = n; i-- > 0;) {
                env[i] = (i + 1 < n && env[i + 1] > p[i]) ? env[i + 1] : p[i];
            }
            fprintf(f, "<path fill=\"#cfe3ff\" stroke=\"none\" d=\"M%.1f %.1f", px(0), py(0));
            double prev_r = 0.0;
            for (size_t i = 0; i < n; i++) {
                if (i + 1 < n && env[i + 1] == env[i]) {
                    continue;   // one step per envelope level
                }
                fprintf(f, " L%.1f %.1f L%.1f %.1f", px(prev_r), py(env[i]), px(r[i]), py(env[i]));
                prev_r = r[i];
            }
            fprintf(f, " L%.1f %.1f Z\"/>\n", px(r[n - 1]), py(0));
            free(env);
        }
        // the raw curve, one point per pixel at most
        fprintf(f, "<polyline fill=\"none\" stroke=\"#1f5fbf\" stroke-width=\"2\" points=\"");
        double lx = -1e9, ly = -1e9;
        for (size_t i = 0; i < n; i++) {
            const double x = px(r[i]), y = py(p[i]);
            if (i + 1 < n && fabs(x - lx) < 0.5 && fabs(y - ly) < 0.5) {
                continue;
            }
            fprintf(f, "%.1f,%.1f ", x, y);
            lx = x;
            ly = y;
        }
        fprintf(f, "\"/>\n");
        fprintf(f, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"5\" fill=\"#d62728\"/>", px(r[n - 1]), py(p[n - 1]));
        fprintf(f, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"12\" text-anchor=\"end\">operating point</text>\n",
                px(r[n - 1]) - 8, py(p[n - 1]) + 20);
    }
    fprintf(f, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"14\" font-weight=\"bold\">AP %.2f%%</text>\n", px(0.05),
            py(0.08), 100.0 * ap);
    fprintf(f, "</svg>\n");
}

static double ratio(uint64_t a, uint64_t b)
{
    return b == 0 ? 0.0 : (double)a / (double)b;
}

static int cmp_thumb(const void *a, const void *b)
{
    const demo_report_thumb_t *x = a, *y = b;
    return x->index < y->index ? -1 : (x->index > y->index);
}

static void row(FILE *f, const char *label, const char *id, const char *value)
{
    fprintf(f, "<tr><th>%s</th><td id=\"%s\">", label, id);
    html_text(f, value);
    fprintf(f, "</td></tr>\n");
}

static void evaluation(FILE *f, const demo_gt_t *gt, const char *annotations)
{
    char v[128];
    fprintf(f, "<section><h2>Evaluation against ground truth</h2>\n<p class=\"note\">");
    html_text(f, annotations);
    fprintf(f, "; IoU &ge; 0.5; classes ");
    html_text(f, gt->class_desc);
    fprintf(f, ". Same rules and figures as <code>--eval</code> (docs/demo.md).</p>\n<div class=\"cols\">"
               "<table class=\"figs\">\n");
    snprintf(v, sizeof v, "%llu", (unsigned long long)gt->frames);
    row(f, "frames evaluated", "eval-frames", v);
    snprintf(v, sizeof v, "%llu", (unsigned long long)gt->gt);
    row(f, "vehicles", "vehicles", v);
    snprintf(v, sizeof v, "%llu", (unsigned long long)gt->det);
    row(f, "detections counted", "eval-detections", v);
    snprintf(v, sizeof v, "%llu", (unsigned long long)gt->tp);
    row(f, "true positives", "tp", v);
    snprintf(v, sizeof v, "%llu", (unsigned long long)gt->fp);
    row(f, "false positives", "fp", v);
    snprintf(v, sizeof v, "%llu", (unsigned long long)(gt->gt - gt->tp));
    row(f, "misses", "fn", v);
    snprintf(v, sizeof v, "%.2f%%", 100.0 * ratio(gt->tp, gt->gt));
    row(f, "TP rate (recall)", "tp-rate", v);
    snprintf(v, sizeof v, "%.2f%%", 100.0 * ratio(gt->fp, gt->det));
    row(f, "FP rate", "fp-rate", v);
    snprintf(v, sizeof v, "%.2f%%", 100.0 * ratio(gt->tp, gt->det));
    row(f, "precision", "precision", v);
    snprintf(v, sizeof v, "%.3f", ratio(gt->fp, gt->frames));
    row(f, "false positives per frame", "fppi", v);
    double *r = NULL, *p = NULL, ap = 0.0;
    size_t n = 0;
    const vd_status_t st = demo_gt_pr(gt, &r, &p, &n, &ap);
    snprintf(v, sizeof v, st == VD_OK ? "%.2f%%" : "n/a", 100.0 * ap);
    row(f, "AP", "ap", v);
    fprintf(f, "</table>\n<figure>");
    if (st == VD_OK) {
        pr_svg(f, r, p, n, ap);
    }
    fprintf(f, "<figcaption>Precision&ndash;recall over the %zu counted detections by score; shaded: "
               "interpolated precision (area = AP). The curve ends at the detector's score threshold.</figcaption>"
               "</figure></div></section>\n",
            n);
    free(r);
    free(p);
}

static void gallery(FILE *f, demo_report_t *rp)
{
    fprintf(f, "<section><h2>Frames with misses or false positives</h2>\n<p class=\"note\" id=\"gallery-note\">"
               "%llu frames have a miss or a false positive",
            (unsigned long long)rp->frames_with_errors);
    if (rp->frames_with_errors > rp->n_thumbs) {
        fprintf(f, "; the %zu with the most are shown", rp->n_thumbs);
    }
    fprintf(f, ".</p>\n<p class=\"note\"><span class=\"lg\"><span class=\"sw\" style=\"border-color:#00c8ff\">"
               "</span>ground truth, found</span> <span class=\"lg\"><span class=\"sw\" style=\"border-color:#ff9600\">"
               "</span>ground truth, missed</span> <span class=\"lg\"><span class=\"sw\" style=\"border-color:#00e600\">"
               "</span>detection, true positive</span> <span class=\"lg\"><span class=\"sw\" "
               "style=\"border-color:#ff2828\"></span>detection, false positive</span> <span class=\"lg\"><span "
               "class=\"sw\" style=\"border-color:#969696\"></span>detection in an ignore region</span></p>\n");
    if (rp->n_thumbs == 0) {
        fprintf(f, "<p>None.</p></section>\n");
        return;
    }
    qsort(rp->thumb, rp->n_thumbs, sizeof rp->thumb[0], cmp_thumb);
    fprintf(f, "<div class=\"gallery\">\n");
    for (size_t i = 0; i < rp->n_thumbs; i++) {
        const demo_report_thumb_t *t = &rp->thumb[i];
        char path[4400];
        thumb_path(rp, t, path, sizeof path);
        char *buf = NULL;
        size_t len = 0;
        char e[512];
        fprintf(f, "<figure class=\"thumb\">");
        if (demo_read_file(path, 64u << 20, &buf, &len, e, sizeof e) == VD_OK) {
            fprintf(f, "<img alt=\"");
            html_text(f, t->name);
            fprintf(f, "\" src=\"data:image/png;base64,");
            base64_file(f, (const uint8_t *)buf, len);
            fprintf(f, "\">");
            free(buf);
        }
        fprintf(f, "<figcaption>");
        html_text(f, t->name);
        fprintf(f, "<br>TP %u, FP %u, missed %u</figcaption></figure>\n", t->tp, t->fp, t->fn);
    }
    fprintf(f, "</div></section>\n");
}

static const char k_css[] =
    "body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,'DejaVu Sans',sans-serif;margin:24px auto;"
    "max-width:1100px;padding:0 16px;color:#222;background:#f6f7f9}"
    "h1{font-size:24px;margin:0 0 4px}h2{font-size:18px;margin:0 0 10px}"
    "section{background:#fff;border:1px solid #dde;border-radius:8px;padding:16px;margin:16px 0}"
    ".note{color:#555;font-size:13px}.cols{display:flex;flex-wrap:wrap;gap:24px;align-items:flex-start}"
    "table{border-collapse:collapse;font-size:14px}th,td{padding:4px 10px;border-bottom:1px solid #eee;"
    "text-align:left}td{text-align:right;font-variant-numeric:tabular-nums}"
    ".figs td{font-weight:600;font-size:15px}.bar{display:inline-block;height:10px;background:#1f5fbf;"
    "vertical-align:middle}figure{margin:0}figcaption{font-size:12px;color:#555;max-width:460px}"
    ".gallery{display:flex;flex-wrap:wrap;gap:12px}.thumb{background:#fafafa;border:1px solid #ddd;padding:6px}"
    ".thumb img{display:block;max-width:320px;image-rendering:pixelated}"
    ".sw{display:inline-block;width:12px;height:9px;border:2px solid;margin:0 4px 0 10px;vertical-align:middle}"
    ".lg{white-space:nowrap}";

vd_status_t demo_report_write(demo_report_t *rp, const demo_report_info_t *in, char *err, size_t err_len)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/index.html", rp->dir);
    demo_atomic_t a;
    vd_status_t st = demo_atomic_open(&a, path, err, err_len);
    if (st != VD_OK) {
        return st;
    }
    FILE *f = a.f;
    fprintf(f, "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
               "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
               "<title>vd_fir_demo report</title><style>%s</style></head><body>\n",
            k_css);
    fprintf(f, "<h1>vd_fir_demo report</h1>\n<p class=\"note\">input <code>");
    html_text(f, in->input);
    fprintf(f, "</code>; sources <code>");
    html_text(f, in->sources);
    fprintf(f, "</code>; models: ");
    html_text(f, in->models);
    fprintf(f, "</p>\n");

    // summary
    char v[160];
    fprintf(f, "<section><h2>Summary</h2><div class=\"cols\"><table class=\"figs\">\n");
    snprintf(v, sizeof v, "%llu", (unsigned long long)in->frames);
    row(f, "frames", "frames", v);
    snprintf(v, sizeof v, "%llu", (unsigned long long)in->detections);
    row(f, "detections", "detections", v);
    snprintf(v, sizeof v, "%.2f", in->frames ? (double)in->detections / (double)in->frames : 0.0);
    row(f, "detections per frame", "detections-per-frame", v);
    snprintf(v, sizeof v, "%u &times; %u, %s", (unsigned)in->width, (unsigned)in->height,
             in->u16 ? "16-bit" : "8-bit");
    fprintf(f, "<tr><th>frame size</th><td id=\"frame-size\">%s</td></tr>\n", v);
    snprintf(v, sizeof v, "%.1f", in->fps_detector);
    row(f, "frames/s, detector", "fps-detector", v);
    snprintf(v, sizeof v, "%.1f", in->fps_wall);
    row(f, "frames/s, with I/O and outputs", "fps-wall", v);
    fprintf(f, "</table>\n");

    // stage times: the stages that took time, and the total
    double max_ms = 0.0;
    for (size_t k = 0; k < in->n_stages; k++) {
        max_ms = in->stage_mean_ms[k] > max_ms ? in->stage_mean_ms[k] : max_ms;
    }
    fprintf(f, "<table id=\"stages\"><tr><th>stage</th><td>median ms</td><td>mean ms</td><td></td></tr>\n");
    for (size_t k = 0; k < in->n_stages; k++) {
        const bool total = k + 1 == in->n_stages;
        if (!total && in->stage_mean_ms[k] < 0.005 && in->stage_median_ms[k] < 0.005) {   // shows as 0.00
            continue;
        }
        fprintf(f, "<tr><th>%s%s%s</th><td>%.2f</td><td>%.2f</td><td style=\"text-align:left\">"
                   "<span class=\"bar\" style=\"width:%.0fpx\"></span></td></tr>\n",
                total ? "<b>" : "", in->stage_names[k], total ? "</b>" : "", in->stage_median_ms[k],
                in->stage_mean_ms[k], max_ms > 0 ? 160.0 * in->stage_mean_ms[k] / max_ms : 0.0);
    }
    fprintf(f, "</table></div><p class=\"note\">Stage times are the detector's own (its clock callback), per "
               "frame; wall time includes reading frames and writing outputs.</p></section>\n");

    if (in->gt != NULL) {
        evaluation(f, in->gt, in->annotations);
        gallery(f, rp);
    } else {
        fprintf(f, "<section><h2>Evaluation</h2><p>No ground truth: pass <code>--eval ANNOTATIONS</code> for "
                   "TP/FP/AP figures, the precision&ndash;recall curve and a gallery of misses and false "
                   "positives.</p></section>\n");
    }
    fprintf(f, "<p class=\"note\">Written by vd_fir_demo --report (docs/demo.md).</p>\n</body></html>\n");
    st = demo_atomic_commit(&a, err, err_len);
    if (st != VD_OK) {
        return st;
    }
    rp->created_dir = false;   // it holds the page now
    demo_report_abort(rp);     // removes the staged thumbnails
    return VD_OK;
}
