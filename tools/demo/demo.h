// SPDX-License-Identifier: MIT
// vd_fir_demo internals: bounded JSON reader/writer, ground-truth evaluation, atomic outputs.
#ifndef VD_DEMO_H
#define VD_DEMO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "vd/image.h"
#include "vd/status.h"

// ---------------------------------------------------------------------------
// JSON reader (json.c). The whole text is tokenised into a flat array (like
// jsmn) by a loop with an explicit stack: no recursion, nesting at most
// DEMO_JSON_MAX_DEPTH, at most DEMO_JSON_MAX_TOKENS tokens, text at most
// DEMO_JSON_MAX_BYTES. Strict RFC 8259 syntax (no comments, no trailing commas).
#define DEMO_JSON_MAX_DEPTH 64
#define DEMO_JSON_MAX_TOKENS 20000000u
#define DEMO_JSON_MAX_BYTES (512u * 1024u * 1024u)

typedef enum demo_json_type {
    DEMO_JSON_OBJECT = 1,
    DEMO_JSON_ARRAY,
    DEMO_JSON_STRING,
    DEMO_JSON_NUMBER,
    DEMO_JSON_TRUE,
    DEMO_JSON_FALSE,
    DEMO_JSON_NULL
} demo_json_type_t;

typedef struct demo_json_tok {
    demo_json_type_t type;
    uint32_t size;   // object: number of keys; array: number of elements
    uint32_t next;   // index of the first token after this value's subtree
    size_t start;    // byte span in the text (strings: without the quotes)
    size_t len;
} demo_json_tok_t;

typedef struct demo_json {
    const char *text;
    size_t text_len;
    demo_json_tok_t *tok;   // malloc'd
    uint32_t n;
    uint32_t cap;
} demo_json_t;

// Parses text[0..len). On failure returns VD_ERR_FORMAT (syntax, with line
// and column in err), VD_ERR_RANGE (too deep, too many tokens, too long) or
// VD_ERR_IO (out of memory); doc is then empty. text must outlive doc.
vd_status_t demo_json_parse(demo_json_t *doc, const char *text, size_t len, char *err, size_t err_len);
void demo_json_free(demo_json_t *doc);
// Value of `key` in object token `obj`; -1 if absent or obj is not an object.
int64_t demo_json_get(const demo_json_t *doc, uint32_t obj, const char *key);
// First element / next sibling of an array (or first key of an object); -1 at the end.
int64_t demo_json_first(const demo_json_t *doc, uint32_t container);
int64_t demo_json_sibling(const demo_json_t *doc, uint32_t elem);
// Number value; false if the token is not a number.
bool demo_json_number(const demo_json_t *doc, int64_t idx, double *out);
// String value decoded (escapes, \u to UTF-8) into buf (NUL-terminated); false if
// not a string, if it does not fit, or if it contains a NUL.
bool demo_json_string(const demo_json_t *doc, int64_t idx, char *buf, size_t cap);
// True if key token `idx` (a string) equals `key` after decoding.
bool demo_json_string_eq(const demo_json_t *doc, int64_t idx, const char *key);

// JSON writer helpers: a string with escapes (quotes included).
void demo_json_write_string(FILE *f, const char *s);

// Reads a whole file (at most max_bytes) into malloc'd memory plus a NUL.
vd_status_t demo_read_file(const char *path, size_t max_bytes, char **buf, size_t *len, char *err, size_t err_len);

// ---------------------------------------------------------------------------
// Ground truth and Table-2 evaluation (eval.c).
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

// ---------------------------------------------------------------------------
// Atomic outputs (out.c): a file is written as "<dir>/.<name>.tmp.<pid>" and
// renamed over its final name on commit; abort removes it.
typedef struct demo_atomic {
    char final_path[4096];
    char tmp_path[4200];
    FILE *f;
} demo_atomic_t;

vd_status_t demo_atomic_open(demo_atomic_t *a, const char *path, char *err, size_t err_len);
vd_status_t demo_atomic_commit(demo_atomic_t *a, char *err, size_t err_len);
void demo_atomic_abort(demo_atomic_t *a);
// Creates a directory and its parents (like mkdir -p).
vd_status_t demo_mkdirs(const char *path, char *err, size_t err_len);
// The file name part of a path ("a/b/c.pgm" -> "c.pgm").
const char *demo_basename(const char *path);

// ---------------------------------------------------------------------------
// Progress on stderr (progress.c): on a terminal one line redrawn in place,
// otherwise a plain line every 50 frames and at the last one.
typedef struct demo_progress {
    bool on;          // false with --quiet: nothing is written
    bool tty;         // stderr is a terminal
    uint64_t total;   // frames expected (0 = unknown: no percentage, no time left)
    double t0;        // start time, seconds (any monotonic clock)
    double last;      // last redraw (terminal), seconds; < 0 before the first
    bool drawn;       // a terminal line is on screen (ended by demo_progress_end)
} demo_progress_t;

void demo_progress_start(demo_progress_t *p, bool on, bool tty, uint64_t total, double now_s);
// After frame number `done` (1-based) named `name` with n_det detections, at time now_s.
void demo_progress_frame(demo_progress_t *p, FILE *f, uint64_t done, const char *name, size_t n_det, double now_s);
// Ends a terminal line with a newline (nothing otherwise).
void demo_progress_end(demo_progress_t *p, FILE *f);
// The progress text without line control: "[done/total pct%] R frames/s, M:SS left | name: n detections"
// ("[done] R frames/s | name: n detections" when total is 0). Returns its length (cut at cap - 1).
size_t demo_progress_text(char *buf, size_t cap, uint64_t done, uint64_t total, double elapsed_s,
                          const char *name, size_t n_det);

// ---------------------------------------------------------------------------
// Options (args.c).
#include "vd/detector.h"

typedef struct demo_opts {
    const char *input;          // --input (default: the bundled clip chosen by --clip)
    bool input_default;         // --input not given
    const char *clip_eval;      // annotations of the bundled clip in use (NULL with --input)
    const char *model;          // --model FILE | none; NULL = auto (first models/*.vdm)
    const char *out_dir;        // --out
    const char *json;           // --json
    const char *eval;           // --eval
    const char *classes;        // --classes
    const char *eval_out;       // --eval-out
    const char *report;         // --report DIR
    uint32_t raw_w, raw_h;      // --raw-size
    vd_pixfmt_t raw_format;     // --raw-format u16 (default) | u8
    bool raw_big_endian;        // --raw-format u16be
    uint32_t dev_w, dev_h, fps; // --device-size, --fps
    vd_pixfmt_t dev_format;     // --pixfmt grey | y16
    uint64_t max_frames;        // --frames (0 = all)
    int32_t timeout_ms;         // --timeout-ms (devices)
    bool quiet;                 // --quiet
    bool scores;                // draw score text (--no-scores turns off)
    vd_detector_cfg_t cfg;      // detector settings (--config FILE, then flags)
    const char *cnn_model;      // --cnn-model FILE (flag or config); NULL = a CNN --model, else models/vd_cnn.vdm
    char cnn_model_buf[4096];   // its copy (a config file's text is freed after parsing)
    const char *cnn_model2;     // --cnn-model2 FILE|none; NULL = models/vd_cnn2.vdm with the default --cnn-model
    char cnn_model2_buf[4096];
    const char *boost_model;    // --boost-model FILE; NULL = models/vd_boost.vdm (with --verifier boost)
    char boost_model_buf[4096];
    bool sources_set;           // --sources given (flag or config): no default source choice
    bool max_candidates_set;    // --max-candidates / --max-detections given: not raised for the CNN
    bool max_detections_set;
} demo_opts_t;

// Parses argv. Returns 0 to run, 1 after --help (exit 0), -1 on a usage error
// (message printed on stderr).
int demo_args_parse(demo_opts_t *o, int argc, char **argv);
// The same with the --help text written to `out` and the error line to `errf`
// (demo_args_parse: stdout, stderr); no other side effect (--config is read).
int demo_args_parse_to(demo_opts_t *o, int argc, char **argv, FILE *out, FILE *errf);
void demo_args_usage(FILE *f);

// ---------------------------------------------------------------------------
// Models (models.c), shared by vd_fir_demo and the GStreamer element vdfir.
#include "vd/cnn.h"
#include "vd/dbn.h"

typedef struct demo_models {
    uint8_t *model_blob;        // DBN file (malloc'd); model points into it
    vd_dbn_model_t model;
    bool have_model;            // a source (or --cnn-rescore) uses the DBN
    char model_path[4096];
    uint8_t *cnn_blob;          // CNN file (malloc'd); cnn points into it
    vd_cnn_model_t cnn;
    bool have_cnn;
    char cnn_path[4096];
    uint8_t *cnn2_blob;         // --cnn-model2 (malloc'd); cnn2 points into it
    vd_cnn_model_t cnn2;
    bool have_cnn2;
    char cnn2_path[4096];
    uint8_t *boost_blob;        // --verifier boost: the boosted verifier's file (malloc'd); boost points into it
    vd_boost_model_t boost;
} demo_models_t;

// Resolves and loads the models the options ask for (docs/demo.md "Which
// sources by default"; defaults from models_dir): without --sources the
// sources follow the models at hand; sets o->cfg.sources, o->cfg.cnn_model
// (= &m->cnn, so m must not move while o->cfg is used) and, for the CNN, the
// candidate/detection budgets not set by the user. On failure err names the
// option and file. m must be zeroed before the first call.
vd_status_t demo_models_load(demo_models_t *m, demo_opts_t *o, const char *models_dir, char *err, size_t err_len);
void demo_models_free(demo_models_t *m);
// The detector settings for width x height frames (the options' cfg sized to the frame).
void demo_detector_cfg(const demo_opts_t *o, uint32_t width, uint32_t height, vd_detector_cfg_t *cfg);

#endif
