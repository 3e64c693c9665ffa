// SPDX-License-Identifier: MIT
// vd_fir_demo --eval (eval.c): ground truth (COCO-like JSON, YOLO folders), per-frame matching,
// candidate recall, the precision-recall curve and the paper's Table-2 figures.
#ifndef VD_DEMO_EVAL_H
#define VD_DEMO_EVAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "vd/image.h"
#include "vd/rect.h"
#include "vd/status.h"

typedef struct demo_gt_box {
    double x, y, w, h;      // pixels (normalised 0..1 while `normalised` is set on the image)
    int32_t cls;
    bool vehicle;           // one of the evaluated classes
    bool ignore;            // DontCare / iscrowd region: detections inside are not counted
} demo_gt_box_t;

typedef struct demo_gt_image {
    char *name;             // file name without directories
    demo_gt_box_t *box;
    size_t n, cap;
    bool normalised;        // YOLO: multiply by the frame size when evaluating
} demo_gt_image_t;

#define DEMO_MAX_CLASSES 64

// One counted detection (true or false positive; ignored ones are left out),
// kept for the precision-recall curve and AP.
typedef struct demo_gt_scored {
    double score;
    uint64_t order;   // evaluation order: ties in score keep it (as vdtools.metrics.evaluate.average_precision)
    bool tp;
} demo_gt_scored_t;

typedef struct demo_gt {
    demo_gt_image_t *img;   // sorted by name
    size_t n, cap;
    bool yolo;
    char label_dir[4096];   // YOLO folder
    int32_t classes[DEMO_MAX_CLASSES];
    size_t n_classes;
    char class_desc[512];   // "1 Car, 3 OtherVehicle"
    // running totals
    uint64_t frames, frames_unannotated, gt, det, det_ignored, tp, fp;
    // candidate recall (demo_gt_candidates): vehicles hot / cold, and those covered by a candidate
    uint64_t veh_hot, veh_cold, cov_hot, cov_cold;
    // every counted detection in evaluation order (malloc'd; demo_gt_pr)
    demo_gt_scored_t *scored;
    size_t n_scored, cap_scored;
    bool scored_incomplete;   // out of memory on the way: no AP
} demo_gt_t;

typedef struct demo_det {
    vd_rect_t box;
    double score;
} demo_det_t;

// Loads COCO-like JSON (HIT-UAV quirks: "annotation", "filename") or a YOLO
// label folder. classes_opt: NULL for the defaults, else a comma-separated list
// of class ids or names. Returns VD_OK, VD_ERR_IO, VD_ERR_FORMAT, VD_ERR_ARG.
vd_status_t demo_gt_load(demo_gt_t *gt, const char *path, const char *classes_opt, char *err, size_t err_len);
void demo_gt_free(demo_gt_t *gt);
// Greedy matching of one frame's detections (any order; sorted here by score)
// against its ground truth, IoU >= 0.5. frame_name: the input's file name.
// matched (may be NULL, n entries): 1 = true positive, 0 = false positive, -1 = ignored.
void demo_gt_frame(demo_gt_t *gt, const char *frame_name, uint32_t width, uint32_t height,
                   const demo_det_t *det, size_t n, int8_t *matched);
// demo_gt_frame that also reports which boxes of the frame's annotations
// (demo_gt_image_of(gt, frame_name)->box[b]) a detection matched: gt_used[b]
// (may be NULL; n_gt_used entries, boxes past it are not reported).
void demo_gt_frame_ex(demo_gt_t *gt, const char *frame_name, uint32_t width, uint32_t height,
                      const demo_det_t *det, size_t n, int8_t *matched, bool *gt_used, size_t n_gt_used);
// The annotations of a frame (YOLO: by the file name's stem); NULL if it has none.
const demo_gt_image_t *demo_gt_image_of(const demo_gt_t *gt, const char *frame_name);
// Precision-recall curve over all counted detections so far, pooled and sorted by
// score (descending; ties in evaluation order), and its AP at IoU 0.5 with all-point
// interpolation (PASCAL VOC 2010+; the same figure as vdtools.metrics.evaluate.average_precision).
// *recall and *precision are malloc'd arrays of *n points (free them; NULL when *n is 0).
// *ap is 0 when there are no vehicles. The curve ends at the detector's operating point
// (its score threshold), so the AP is that of the detections it outputs.
// Returns VD_OK; VD_ERR_STATE (a detection was lost to out-of-memory: no curve); VD_ERR_IO.
vd_status_t demo_gt_pr(const demo_gt_t *gt, double **recall, double **precision, size_t *n, double *ap);
// Candidate recall of one frame (call once per frame demo_gt_frame evaluates,
// with the same frame_name): each vehicle box is "covered" when a candidate
// (the merged list before verification, vd_detector_cfg_t.on_candidate) has
// IoU >= 0.5 with it, and "hot" when its box clipped to the frame holds a
// pixel >= hot_thr (the frame's 8-bit or raw 16-bit threshold; a value above
// the format's range means nothing is hot). O(candidates x boxes + box pixels).
void demo_gt_candidates(demo_gt_t *gt, const char *frame_name, const vd_frame_t *frame, uint32_t hot_thr,
                        const vd_rect_t *cand, size_t n);
// IoU of two boxes given as x, y, w, h.
double demo_iou(double ax, double ay, double aw, double ah, double bx, double by, double bw, double bh);
// Prints the Table-2 figures and writes them as JSON (path may be NULL).
void demo_gt_report(const demo_gt_t *gt, FILE *f);
vd_status_t demo_gt_write_json(const demo_gt_t *gt, const char *annotations, const char *path, char *err,
                               size_t err_len);

#endif
