// SPDX-License-Identifier: MIT
// vd_fir_demo --report (report.c): one self-contained HTML page of a run, with the frames that
// have misses and false positives drawn on the port's RGB canvas.
#ifndef VD_DEMO_REPORT_H
#define VD_DEMO_REPORT_H

#include "eval.h"
#include "vd_port/writer.h"

// --report DIR (report.c): DIR/index.html, self-contained (inline CSS and SVG,
// thumbnails as PNG data URIs). Calls: open, frame (per evaluated frame),
// write at the end of a successful run; abort on any failure (and after write).
#define DEMO_REPORT_MAX_THUMBS 48u
#define DEMO_REPORT_THUMB_W 320u

typedef struct demo_report_thumb {
    char name[256];       // frame name (cut)
    uint32_t tp, fp, fn;  // this frame's true positives, false positives, misses
    uint64_t index;       // frame number in the run
    uint64_t file_id;     // staged PNG "t<file_id>.png"
} demo_report_thumb_t;

typedef struct demo_report {
    char dir[4096];
    char stage[4200];     // hidden staging directory inside dir
    bool staging;
    bool created_dir;     // dir did not exist before: removed again on failure if empty
    demo_report_thumb_t thumb[DEMO_REPORT_MAX_THUMBS];
    size_t n_thumbs;
    uint64_t frames_with_errors;
    uint64_t next_file_id;
    vd_rgb_t full, small; // canvases (frame size, thumbnail size)
} demo_report_t;

// What the page shows besides the evaluation. Stage arrays have n_stages entries,
// the last one being the total.
typedef struct demo_report_info {
    const char *input, *sources, *models, *annotations;
    uint64_t frames, detections;
    uint32_t width, height;
    bool u16;
    double fps_detector, fps_wall;
    size_t n_stages;
    const char *const *stage_names;
    const double *stage_median_ms, *stage_mean_ms;
    const demo_gt_t *gt;  // NULL without ground truth (no evaluation, no gallery)
} demo_report_info_t;

// Creates dir (and parents) and the staging directory. VD_OK, VD_ERR_ARG, VD_ERR_IO.
vd_status_t demo_report_open(demo_report_t *rp, const char *dir, char *err, size_t err_len);
// One evaluated frame: its annotations (may be NULL), which boxes were found
// (demo_gt_frame_ex), the detections and their matched flags. A frame with a miss or
// a false positive may enter the gallery (a thumbnail is drawn with lo/hi the 16-bit
// grey mapping of vd_rgb_from_frame). VD_OK, or the PNG writer's status.
vd_status_t demo_report_frame(demo_report_t *rp, uint64_t index, const char *name, const vd_frame_t *f, uint32_t lo,
                              uint32_t hi, const demo_gt_image_t *im, const bool *gt_used, const demo_det_t *det,
                              const int8_t *matched, size_t n, char *err, size_t err_len);
// Writes dir/index.html (atomically) and removes the staging directory.
vd_status_t demo_report_write(demo_report_t *rp, const demo_report_info_t *info, char *err, size_t err_len);
// Removes staged thumbnails and, if this run created it and it is empty, dir; frees the canvases.
void demo_report_abort(demo_report_t *rp);

#endif
