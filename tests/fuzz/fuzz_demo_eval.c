// SPDX-License-Identifier: MIT
// Fuzz harness: vd_fir_demo's --eval annotation readers (demo_gt_load, tools/demo/eval.c) and the
// matching that uses what they read.
//
// Input (text): an optional first line "#classes LIST" (the --classes value),
// then either a COCO-like JSON document (first non-blank byte '{' or '['),
// written to a temporary .json file, or a YOLO label folder: sections that
// start with a line "--- NAME" become files NAME in a temporary labels/
// folder ("../classes.txt" goes to its parent; names are [A-Za-z0-9_.-],
// at most 40 bytes, not starting with '.'; at most 8 files); text before the
// first such line goes to labels/frame.txt. Checks after a successful load:
// images sorted by name, box counts within capacity, 1..64 classes; then
// every image is evaluated (demo_gt_frame with detections made from its own
// boxes, demo_gt_candidates on a small frame) and the totals must add up
// (det = tp + fp, tp <= vehicles); the report is printed (to /dev/null) and
// written as JSON. A failed load must leave an error message and no images.
#include "eval.h"
#include "fuzz_common.h"

#include <math.h>
#include <sys/stat.h>
#include <unistd.h>

#define MAX_FILES 8
#define FRAME_W 160u
#define FRAME_H 128u

static FILE *g_null;
static char g_root[256];
static uint8_t g_frame[FRAME_W * FRAME_H];

// The temporary folders (empty between inputs) go at exit.
static void cleanup(void)
{
    char p[320];
    snprintf(p, sizeof p, "%s/labels", g_root);
    (void)rmdir(p);
    (void)rmdir(g_root);
}

static void setup(void)
{
    if (g_null != NULL) {
        return;
    }
    g_null = fopen("/dev/null", "w");
    FZ_CHECK(g_null != NULL);
    const char *dir = getenv("TMPDIR");
    snprintf(g_root, sizeof g_root, "%s/vd_fuzz_demo_eval_%ld", dir ? dir : "/tmp", (long)getpid());
    char p[320];
    (void)mkdir(g_root, 0700);
    snprintf(p, sizeof p, "%s/labels", g_root);
    (void)mkdir(p, 0700);
    (void)atexit(cleanup);
    for (uint32_t i = 0u; i < FRAME_W * FRAME_H; i++) {
        g_frame[i] = (uint8_t)((i * 37u) ^ (i >> 5));
    }
}

static bool name_ok(const char *n, size_t l)
{
    if (l == 14u && memcmp(n, "../classes.txt", 14u) == 0) {
        return true;
    }
    if (l == 0u || l > 40u || n[0] == '.') {
        return false;
    }
    for (size_t i = 0u; i < l; i++) {
        const char c = n[i];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '.' ||
              c == '-')) {
            return false;
        }
    }
    return true;
}

typedef struct files {
    char path[MAX_FILES][400];
    size_t n;
    // YOLO label files (labels/<stem>.txt, not classes.txt): stem and the lines a reader must see
    char stem[MAX_FILES][48];
    size_t lines[MAX_FILES];
    bool label[MAX_FILES];
} files_t;

// Label lines of a text: lines with a character other than ' ', '\t', '\r'
// before their first NUL, within their first 511 bytes (the reader's line
// buffer; it skips blank lines and ignores what a longer line holds past it).
static size_t count_lines(const char *p, size_t n)
{
    size_t count = 0u, col = 0u;
    bool seen = false, nul = false;
    for (size_t i = 0u; i < n; i++, col++) {
        const char c = p[i];
        if (c == '\n') {
            count += seen;
            seen = nul = false;
            col = (size_t)-1;
        } else if (c == '\0') {
            nul = true;
        } else if (!nul && col < 511u && c != ' ' && c != '\t' && c != '\r') {
            seen = true;
        }
    }
    return count + seen;
}

static void put_file(files_t *fs, const char *name, size_t name_len, const char *p, size_t n)
{
    if (!name_ok(name, name_len)) {
        return;
    }
    char path[400];
    if (name_len == 14u && name[0] == '.') {
        snprintf(path, sizeof path, "%s/classes.txt", g_root);
    } else {
        snprintf(path, sizeof path, "%s/labels/%.*s", g_root, (int)name_len, name);
    }
    bool seen;
    size_t slot = fs->n;
    for (size_t i = 0u; i < fs->n; i++) {
        if (strcmp(fs->path[i], path) == 0) {
            slot = i;
        }
    }
    seen = slot < fs->n;
    if (!seen) {
        if (fs->n == MAX_FILES) {
            return;
        }
        snprintf(fs->path[fs->n++], sizeof fs->path[0], "%s", path);
        fs->label[slot] = name[0] != '.' && name_len >= 5u && memcmp(name + name_len - 4u, ".txt", 4u) == 0 &&
                          !(name_len == 11u && memcmp(name, "classes.txt", 11u) == 0);
        fs->lines[slot] = 0u;
        // name is not NUL-terminated: the precision must never go negative (name_len < 4 made
        // it so, and "%.*s" with a negative precision reads up to a NUL, past the fuzz input)
        snprintf(fs->stem[slot], sizeof fs->stem[0], "%.*s", (int)(name_len >= 4u ? name_len - 4u : 0u), name);
    } else {
        fs->label[slot] = false;   // appended to: its lines may have been joined, no count
    }
    fs->lines[slot] += count_lines(p, n);
    FILE *f = fopen(path, seen ? "ab" : "wb");
    if (f == NULL) {
        return;
    }
    if (n) {
        (void)fwrite(p, 1u, n, f);
    }
    fclose(f);
}

// The first line at or after i (i is at a line start) that starts with "--- "; n if none.
static size_t find_header(const char *p, size_t n, size_t i)
{
    for (size_t e = i; e < n; e++) {
        if ((e == 0u || p[e - 1u] == '\n') && n - e >= 4u && memcmp(p + e, "--- ", 4u) == 0) {
            return e;
        }
    }
    return n;
}

static int32_t clamp_px(double v)
{
    return (v >= -100000.0 && v <= 100000.0) ? (int32_t)v : 0;
}

static void evaluate(demo_gt_t *gt, const files_t *fs)
{
    FZ_CHECK(gt->n <= gt->cap && gt->n_classes >= 1u && gt->n_classes <= DEMO_MAX_CLASSES);
    FZ_CHECK(strlen(gt->class_desc) < sizeof gt->class_desc);
    for (size_t i = 0u; i < gt->n; i++) {
        FZ_CHECK(gt->img[i].name != NULL && gt->img[i].n <= gt->img[i].cap);
        FZ_CHECK(gt->img[i].normalised == gt->yolo);
        if (i > 0u) {
            FZ_CHECK(strcmp(gt->img[i - 1u].name, gt->img[i].name) <= 0);
        }
        for (size_t b = 0u; b < gt->img[i].n; b++) {
            const demo_gt_box_t *g = &gt->img[i].box[b];
            FZ_CHECK(isfinite(g->x) && isfinite(g->y) && isfinite(g->w) && isfinite(g->h));
            FZ_CHECK(!(g->vehicle && g->ignore));
        }
    }
    // YOLO: one box per label line of each file
    for (size_t k = 0u; gt->yolo && k < fs->n; k++) {
        if (!fs->label[k]) {
            continue;
        }
        const demo_gt_image_t *im = NULL;
        for (size_t i = 0u; i < gt->n; i++) {
            if (strcmp(gt->img[i].name, fs->stem[k]) == 0) {
                im = &gt->img[i];
            }
        }
        FZ_CHECK(im != NULL && im->n == fs->lines[k]);
    }
    vd_frame_t fr;
    memset(&fr, 0, sizeof fr);
    fr.data = g_frame;
    fr.width = FRAME_W;
    fr.height = FRAME_H;
    fr.stride = FRAME_W;
    fr.format = VD_PIX_U8;
    demo_det_t det[64];
    vd_rect_t cand[64];
    int8_t matched[64];
    for (size_t i = 0u; i < gt->n && i < 16u; i++) {
        const demo_gt_image_t *im = &gt->img[i];
        const double sx = im->normalised ? FRAME_W : 1.0, sy = im->normalised ? FRAME_H : 1.0;
        size_t n = 0u;
        for (size_t b = 0u; b < im->n && n + 2u <= 64u; b++) {
            const demo_gt_box_t *g = &im->box[b];
            vd_rect_t r = {clamp_px(g->x * sx), clamp_px(g->y * sy), clamp_px(g->w * sx), clamp_px(g->h * sy)};
            det[n].box = r;
            det[n].score = (double)(b % 7u) / 7.0;
            n++;
            r.x += r.w / 2;   // a shifted copy: a false positive or an ignored one
            det[n].box = r;
            det[n].score = 0.5;
            n++;
        }
        for (size_t k = 0u; k < n; k++) {
            cand[k] = det[k].box;
        }
        char name[1100];
        snprintf(name, sizeof name, "dir/%s%s", im->name, gt->yolo ? ".png" : "");
        const uint64_t tp0 = gt->tp, fp0 = gt->fp, ig0 = gt->det_ignored;
        memset(matched, 0x55, sizeof matched);
        demo_gt_frame(gt, name, FRAME_W, FRAME_H, det, n, matched);
        uint64_t t = 0u, f = 0u, g = 0u;
        for (size_t k = 0u; k < n; k++) {
            FZ_CHECK(matched[k] == 1 || matched[k] == 0 || matched[k] == -1);
            t += matched[k] == 1;
            f += matched[k] == 0;
            g += matched[k] == -1;
        }
        FZ_CHECK(gt->tp - tp0 == t && gt->fp - fp0 == f && gt->det_ignored - ig0 == g);
        demo_gt_candidates(gt, name, &fr, 100u, cand, n);
    }
    demo_gt_frame(gt, "not-listed.png", FRAME_W, FRAME_H, det, 0u, NULL);
    FZ_CHECK(gt->det == gt->tp + gt->fp && gt->tp <= gt->gt);
    FZ_CHECK(gt->cov_hot <= gt->veh_hot && gt->cov_cold <= gt->veh_cold);
    demo_gt_report(gt, g_null);
    char out[400], err[512];
    snprintf(out, sizeof out, "%s/eval.json", g_root);
    FZ_CHECK(demo_gt_write_json(gt, "annotations \"fuzz\"", out, err, sizeof err) == VD_OK);
    (void)remove(out);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    setup();
    const char *p = (const char *)data;
    size_t n = size;
    char classes[256];
    const char *classes_opt = NULL;
    if (n >= 9u && memcmp(p, "#classes ", 9u) == 0) {
        const char *nl = memchr(p, '\n', n);
        const size_t l = nl != NULL ? (size_t)(nl - p) : n;
        snprintf(classes, sizeof classes, "%.*s", (int)(l - 9u), p + 9);
        classes_opt = classes;
        p += nl != NULL ? l + 1u : l;
        n -= nl != NULL ? l + 1u : l;
    }
    size_t s = 0u;
    while (s < n && (p[s] == ' ' || p[s] == '\t' || p[s] == '\r' || p[s] == '\n')) {
        s++;
    }
    files_t fs;
    memset(&fs, 0, sizeof fs);
    char path[400];
    if (s < n && (p[s] == '{' || p[s] == '[')) {
        snprintf(path, sizeof path, "%s/annotations.json", g_root);
        snprintf(fs.path[fs.n++], sizeof fs.path[0], "%s", path);
        FILE *f = fopen(path, "wb");
        if (f == NULL) {
            return 0;
        }
        (void)fwrite(p, 1u, n, f);
        fclose(f);
    } else {
        snprintf(path, sizeof path, "%s/labels", g_root);
        const char *name = "frame.txt";
        size_t name_len = 9u;
        bool named = false;
        size_t i = 0u;
        for (;;) {
            const size_t next = find_header(p, n, i);
            if (named || next > i || next == n) {
                put_file(&fs, name, name_len, p + i, next - i);
            }
            if (next == n) {
                break;
            }
            const char *nl = memchr(p + next, '\n', n - next);
            name = p + next + 4u;
            name_len = (size_t)((nl != NULL ? nl : p + n) - name);
            if (name_len > 0u && name[name_len - 1u] == '\r') {
                name_len--;
            }
            named = true;
            i = nl != NULL ? (size_t)(nl - p) + 1u : n;
        }
    }
    demo_gt_t gt;
    char err[1024];
    err[0] = '\0';
    const vd_status_t st = demo_gt_load(&gt, path, classes_opt, err, sizeof err);
    if (st == VD_OK) {
        evaluate(&gt, &fs);
    } else {
        FZ_CHECK(st == VD_ERR_IO || st == VD_ERR_FORMAT || st == VD_ERR_ARG);
        FZ_CHECK(err[0] != '\0' && gt.n == 0u && gt.img == NULL);
    }
    demo_gt_free(&gt);
    for (size_t k = 0u; k < fs.n; k++) {
        (void)remove(fs.path[k]);
    }
    return 0;
}
