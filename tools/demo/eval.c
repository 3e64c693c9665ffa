// SPDX-License-Identifier: MIT
// Ground truth (COCO-like JSON incl. HIT-UAV quirks, YOLO folders) and the paper's Table 2 figures.
//
// Matching (per frame): detections sorted by score (descending, ties by
// input order); each takes the still unmatched vehicle box with the highest
// IoU, if that IoU >= 0.5 -> true positive. A detection left over whose IoU
// with an ignore region (DontCare, iscrowd) is >= 0.5, or that lies at least
// half inside one, is ignored (counted neither way); any other is a false
// positive. TP rate = matched vehicles / all vehicles (= recall); FP rate =
// false positives / counted detections (= 1 - precision); FPPI = false
// positives / evaluated frames. Bounds: O(detections x boxes) per frame.
#include "eval.h"

#include "json.h"
#include "out.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

// Class names that count as vehicles by default (case-insensitive).
static const char *const k_vehicle_names[] = {"car", "othervehicle", "other vehicle", "vehicle", "truck",
                                               "bus", "van"};
static const char *const k_ignore_names[] = {"dontcare", "dont care", "ignore"};

static bool name_in(const char *name, const char *const *list, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        if (strcasecmp(name, list[i]) == 0) {
            return true;
        }
    }
    return false;
}

double demo_iou(double ax, double ay, double aw, double ah, double bx, double by, double bw, double bh)
{
    if (aw <= 0 || ah <= 0 || bw <= 0 || bh <= 0) {
        return 0.0;
    }
    double ix = fmin(ax + aw, bx + bw) - fmax(ax, bx);
    double iy = fmin(ay + ah, by + bh) - fmax(ay, by);
    if (ix <= 0 || iy <= 0) {
        return 0.0;
    }
    double inter = ix * iy;
    return inter / (aw * ah + bw * bh - inter);
}

static demo_gt_image_t *add_image(demo_gt_t *gt, const char *name)
{
    if (gt->n == gt->cap) {
        size_t ncap = gt->cap == 0 ? 64 : gt->cap * 2;
        demo_gt_image_t *p = realloc(gt->img, ncap * sizeof *p);
        if (p == NULL) {
            return NULL;
        }
        gt->img = p;
        gt->cap = ncap;
    }
    demo_gt_image_t *im = &gt->img[gt->n];
    memset(im, 0, sizeof *im);
    im->name = strdup(name);
    if (im->name == NULL) {
        return NULL;
    }
    gt->n++;
    return im;
}

static bool add_box(demo_gt_image_t *im, const demo_gt_box_t *b)
{
    if (im->n == im->cap) {
        size_t ncap = im->cap == 0 ? 8 : im->cap * 2;
        demo_gt_box_t *p = realloc(im->box, ncap * sizeof *p);
        if (p == NULL) {
            return false;
        }
        im->box = p;
        im->cap = ncap;
    }
    im->box[im->n++] = *b;
    return true;
}

static int cmp_image(const void *a, const void *b)
{
    return strcmp(((const demo_gt_image_t *)a)->name, ((const demo_gt_image_t *)b)->name);
}

static demo_gt_image_t *find_image(const demo_gt_t *gt, const char *name)
{
    demo_gt_image_t key;
    key.name = (char *)(uintptr_t)name;
    return bsearch(&key, gt->img, gt->n, sizeof key, cmp_image);
}

static bool class_selected(const demo_gt_t *gt, int32_t cls)
{
    for (size_t i = 0; i < gt->n_classes; i++) {
        if (gt->classes[i] == cls) {
            return true;
        }
    }
    return false;
}

typedef struct cat_name {
    int32_t id;
    char name[64];
} cat_name_t;

// Resolves --classes (ids or names, comma separated) or the defaults into gt->classes.
static vd_status_t pick_classes(demo_gt_t *gt, const char *opt, const cat_name_t *cats, size_t n_cats,
                                int32_t fallback, char *err, size_t err_len)
{
    gt->n_classes = 0;
    if (opt != NULL) {
        char buf[1024];
        snprintf(buf, sizeof buf, "%s", opt);
        char *save = NULL;
        for (char *tok = strtok_r(buf, ",", &save); tok != NULL; tok = strtok_r(NULL, ",", &save)) {
            while (isspace((unsigned char)*tok)) {
                tok++;
            }
            char *end = NULL;
            long v = strtol(tok, &end, 10);
            int32_t id = -1;
            if (end != tok && *end == '\0' && v >= 0 && v <= 1000000) {
                id = (int32_t)v;
            } else {
                for (size_t i = 0; i < n_cats; i++) {
                    if (strcasecmp(cats[i].name, tok) == 0) {
                        id = cats[i].id;
                    }
                }
                if (id < 0) {
                    snprintf(err, err_len, "--classes: no class named '%s' in the annotations", tok);
                    return VD_ERR_ARG;
                }
            }
            if (gt->n_classes == DEMO_MAX_CLASSES) {
                snprintf(err, err_len, "--classes: more than %d classes", DEMO_MAX_CLASSES);
                return VD_ERR_ARG;
            }
            gt->classes[gt->n_classes++] = id;
        }
        if (gt->n_classes == 0) {
            snprintf(err, err_len, "--classes: empty list");
            return VD_ERR_ARG;
        }
    } else {
        for (size_t i = 0; i < n_cats && gt->n_classes < DEMO_MAX_CLASSES; i++) {
            if (name_in(cats[i].name, k_vehicle_names, sizeof k_vehicle_names / sizeof k_vehicle_names[0])) {
                gt->classes[gt->n_classes++] = cats[i].id;
            }
        }
        if (gt->n_classes == 0) {
            gt->classes[gt->n_classes++] = fallback;
        }
    }
    size_t o = 0;
    gt->class_desc[0] = '\0';
    for (size_t i = 0; i < gt->n_classes; i++) {
        const char *nm = "";
        for (size_t k = 0; k < n_cats; k++) {
            if (cats[k].id == gt->classes[i]) {
                nm = cats[k].name;
            }
        }
        int w = snprintf(gt->class_desc + o, sizeof gt->class_desc - o, "%s%d%s%s", i ? ", " : "",
                         (int)gt->classes[i], nm[0] ? " " : "", nm);
        if (w < 0 || (size_t)w >= sizeof gt->class_desc - o) {
            break;
        }
        o += (size_t)w;
    }
    return VD_OK;
}

static bool json_int(const demo_json_t *d, int64_t idx, int64_t *out)
{
    double v;
    if (!demo_json_number(d, idx, &v) || !(v >= -1e15 && v <= 1e15)) {
        return false;
    }
    *out = (int64_t)llround(v);
    return true;
}

// A class id: an integer that fits int32_t (demo_gt_box_t.cls, --classes).
static bool json_class(const demo_json_t *d, int64_t idx, int64_t *out)
{
    return json_int(d, idx, out) && *out >= INT32_MIN && *out <= INT32_MAX;
}

typedef struct img_id {
    int64_t id;
    size_t index;   // into gt->img (before sorting)
} img_id_t;

static int cmp_img_id(const void *a, const void *b)
{
    int64_t x = ((const img_id_t *)a)->id, y = ((const img_id_t *)b)->id;
    return x < y ? -1 : x > y;
}

// The "categories" of a COCO document (up to 256 with an id and a name) and the ids of those whose name
// marks ignore regions (up to 16).
static void coco_categories(const demo_json_t *d, cat_name_t cats[256], size_t *n_cats, int32_t ignore_ids[16],
                            size_t *n_ignore)
{
    int64_t cs = demo_json_get(d, 0, "categories");
    if (cs < 0 || d->tok[cs].type != DEMO_JSON_ARRAY) {
        return;
    }
    int64_t c = demo_json_first(d, (uint32_t)cs);
    for (uint32_t k = 0; k < d->tok[cs].size && c >= 0; k++, c = demo_json_sibling(d, (uint32_t)c)) {
        int64_t id;
        if (*n_cats < 256 && json_class(d, demo_json_get(d, (uint32_t)c, "id"), &id) &&
            demo_json_string(d, demo_json_get(d, (uint32_t)c, "name"), cats[*n_cats].name,
                             sizeof cats[*n_cats].name)) {
            cats[*n_cats].id = (int32_t)id;
            if (name_in(cats[*n_cats].name, k_ignore_names, 3) && *n_ignore < 16) {
                ignore_ids[(*n_ignore)++] = (int32_t)id;
            }
            (*n_cats)++;
        }
    }
}

static vd_status_t load_coco(demo_gt_t *gt, const char *path, const char *classes_opt, char *err, size_t err_len)
{
    char *text = NULL;
    size_t len = 0;
    vd_status_t st = demo_read_file(path, DEMO_JSON_MAX_BYTES, &text, &len, err, err_len);
    if (st != VD_OK) {
        return st;
    }
    demo_json_t d;
    char jerr[256];
    st = demo_json_parse(&d, text, len, jerr, sizeof jerr);
    if (st != VD_OK) {
        snprintf(err, err_len, "%s: %s", path, jerr);
        free(text);
        return st == VD_ERR_RANGE ? VD_ERR_FORMAT : st;
    }
    img_id_t *ids = NULL;
    st = VD_ERR_FORMAT;
    if (d.n == 0 || d.tok[0].type != DEMO_JSON_OBJECT) {
        snprintf(err, err_len, "%s: not a JSON object (expected COCO-like annotations)", path);
        goto out;
    }
    int64_t images = demo_json_get(&d, 0, "images");
    // "annotations" (COCO) wins when both are present; HIT-UAV only has "annotation".
    int64_t anns = demo_json_get(&d, 0, "annotations");
    if (anns < 0) {
        anns = demo_json_get(&d, 0, "annotation");
    }
    if (images < 0 || d.tok[images].type != DEMO_JSON_ARRAY || anns < 0 || d.tok[anns].type != DEMO_JSON_ARRAY) {
        snprintf(err, err_len, "%s: expected arrays \"images\" and \"annotations\" (or \"annotation\")", path);
        goto out;
    }
    cat_name_t cats[256];
    size_t n_cats = 0;
    int32_t ignore_ids[16];
    size_t n_ignore = 0;
    coco_categories(&d, cats, &n_cats, ignore_ids, &n_ignore);
    st = pick_classes(gt, classes_opt, cats, n_cats, 1, err, err_len);
    if (st != VD_OK) {
        goto out;
    }
    st = VD_ERR_FORMAT;
    size_t n_img = d.tok[images].size;
    ids = calloc(n_img + 1, sizeof *ids);
    if (ids == NULL) {
        st = VD_ERR_IO;
        snprintf(err, err_len, "out of memory");
        goto out;
    }
    int64_t im = demo_json_first(&d, (uint32_t)images);
    for (size_t k = 0; k < n_img && im >= 0; k++, im = demo_json_sibling(&d, (uint32_t)im)) {
        char name[1024];
        int64_t id;
        int64_t fn = demo_json_get(&d, (uint32_t)im, "filename");
        if (fn < 0) {
            fn = demo_json_get(&d, (uint32_t)im, "file_name");
        }
        if (!demo_json_string(&d, fn, name, sizeof name) || !json_int(&d, demo_json_get(&d, (uint32_t)im, "id"), &id)) {
            snprintf(err, err_len, "%s: image %zu has no \"filename\"/\"file_name\" or \"id\"", path, k);
            goto out;
        }
        if (add_image(gt, demo_basename(name)) == NULL) {
            st = VD_ERR_IO;
            snprintf(err, err_len, "out of memory");
            goto out;
        }
        ids[k].id = id;
        ids[k].index = gt->n - 1;
    }
    qsort(ids, n_img, sizeof *ids, cmp_img_id);
    int64_t a = demo_json_first(&d, (uint32_t)anns);
    for (size_t k = 0; k < d.tok[anns].size && a >= 0; k++, a = demo_json_sibling(&d, (uint32_t)a)) {
        int64_t image_id, cat, crowd = 0;
        int64_t bb = demo_json_get(&d, (uint32_t)a, "bbox");
        double v[4];
        bool ok = json_int(&d, demo_json_get(&d, (uint32_t)a, "image_id"), &image_id) &&
                  json_class(&d, demo_json_get(&d, (uint32_t)a, "category_id"), &cat) && bb >= 0 &&
                  d.tok[bb].type == DEMO_JSON_ARRAY && d.tok[bb].size == 4;
        if (ok) {
            int64_t e = demo_json_first(&d, (uint32_t)bb);
            for (int q = 0; q < 4 && ok; q++, e = demo_json_sibling(&d, (uint32_t)e)) {
                ok = demo_json_number(&d, e, &v[q]) && isfinite(v[q]);
            }
        }
        if (!ok) {
            snprintf(err, err_len, "%s: annotation %zu needs \"image_id\", \"category_id\" and \"bbox\": [x, y, w, h]",
                     path, k);
            goto out;
        }
        (void)json_int(&d, demo_json_get(&d, (uint32_t)a, "iscrowd"), &crowd);
        img_id_t key = {image_id, 0};
        img_id_t *hit = bsearch(&key, ids, n_img, sizeof key, cmp_img_id);
        if (hit == NULL) {
            continue;   // a box for an image that is not listed: nothing to match it with
        }
        demo_gt_box_t b = {v[0], v[1], v[2], v[3], (int32_t)cat, false, crowd != 0};
        for (size_t q = 0; q < n_ignore; q++) {
            b.ignore = b.ignore || ignore_ids[q] == b.cls;
        }
        b.vehicle = !b.ignore && class_selected(gt, b.cls);
        if (!add_box(&gt->img[hit->index], &b)) {
            st = VD_ERR_IO;
            snprintf(err, err_len, "out of memory");
            goto out;
        }
    }
    qsort(gt->img, gt->n, sizeof *gt->img, cmp_image);
    st = VD_OK;
out:
    free(ids);
    demo_json_free(&d);
    free(text);
    return st;
}

// fgets that keeps a physical line one line: when it does not fit in line[cap]
// (cap >= 2), the rest of it is read and dropped. A NUL byte in the line does
// not hide its newline (the check looks at the buffer's last bytes).
static bool read_line(char *line, size_t cap, FILE *f)
{
    line[cap - 1u] = '\1';
    if (fgets(line, (int)cap, f) == NULL) {
        return false;
    }
    if (line[cap - 1u] == '\0' && line[cap - 2u] != '\n') {
        int c;
        while ((c = fgetc(f)) != EOF && c != '\n') {
        }
    }
    return true;
}

// Reads "classes.txt" (one name per line, line k = class k) from dir or its parent.
static size_t yolo_class_names(const char *dir, cat_name_t *cats, size_t cap)
{
    char p[4200];
    FILE *f = NULL;
    snprintf(p, sizeof p, "%s/classes.txt", dir);
    f = fopen(p, "r");
    if (f == NULL) {
        snprintf(p, sizeof p, "%s/../classes.txt", dir);
        f = fopen(p, "r");
    }
    if (f == NULL) {
        return 0;
    }
    size_t n = 0;
    char line[256];
    while (n < cap && read_line(line, sizeof line, f)) {   // a longer name is cut, still one class
        size_t l = strcspn(line, "\r\n");
        line[l] = '\0';
        // "2 car" (MSRS) or "car"
        char *s = line;
        char *end = NULL;
        long id = strtol(s, &end, 10);
        if (end != s && (*end == ' ' || *end == '\t') && id >= INT32_MIN && id <= INT32_MAX) {
            s = end;
            while (*s == ' ' || *s == '\t') {
                s++;
            }
        } else {
            id = (long)n;
        }
        cats[n].id = (int32_t)id;
        snprintf(cats[n].name, sizeof cats[n].name, "%s", s);
        n++;
    }
    fclose(f);
    return n;
}

static vd_status_t load_yolo(demo_gt_t *gt, const char *dir, const char *classes_opt, char *err, size_t err_len)
{
    cat_name_t cats[256];
    size_t n_cats = yolo_class_names(dir, cats, 256);
    vd_status_t st = pick_classes(gt, classes_opt, cats, n_cats, 2, err, err_len);
    if (st != VD_OK) {
        return st;
    }
    gt->yolo = true;
    snprintf(gt->label_dir, sizeof gt->label_dir, "%s", dir);
    DIR *dp = opendir(dir);
    if (dp == NULL) {
        snprintf(err, err_len, "cannot open %s: %s", dir, strerror(errno));
        return VD_ERR_IO;
    }
    struct dirent *de;
    size_t files = 0;
    while ((de = readdir(dp)) != NULL) {
        size_t l = strlen(de->d_name);
        if (l < 5 || strcmp(de->d_name + l - 4, ".txt") != 0 || strcmp(de->d_name, "classes.txt") == 0) {
            continue;
        }
        char path[8400];
        snprintf(path, sizeof path, "%s/%s", dir, de->d_name);
        FILE *f = fopen(path, "r");
        if (f == NULL) {
            snprintf(err, err_len, "cannot open %s: %s", path, strerror(errno));
            closedir(dp);
            return VD_ERR_IO;
        }
        char stem[1024];
        snprintf(stem, sizeof stem, "%.*s", (int)(l - 4), de->d_name);
        demo_gt_image_t *im = add_image(gt, stem);   // matched by stem (extension-less)
        if (im == NULL) {
            fclose(f);
            closedir(dp);
            snprintf(err, err_len, "out of memory");
            return VD_ERR_IO;
        }
        im->normalised = true;
        char line[512];
        unsigned lineno = 0;
        while (read_line(line, sizeof line, f)) {   // columns past the buffer are ignored, as extra ones are
            lineno++;
            long cls;
            double xc, yc, w, h;
            char extra;
            if (line[strspn(line, " \t\r\n")] == '\0') {
                continue;
            }
            int got = sscanf(line, "%ld %lf %lf %lf %lf %c", &cls, &xc, &yc, &w, &h, &extra);
            if ((got != 5 && got != 6) || cls < INT32_MIN || cls > INT32_MAX || !isfinite(xc) || !isfinite(yc) ||
                !isfinite(w) || !isfinite(h)) {
                snprintf(err, err_len, "%s line %u: expected 'class xc yc w h' (finite numbers)", path, lineno);
                fclose(f);
                closedir(dp);
                return VD_ERR_FORMAT;
            }
            demo_gt_box_t b = {xc - w / 2, yc - h / 2, w, h, (int32_t)cls, class_selected(gt, (int32_t)cls), false};
            if (!add_box(im, &b)) {
                fclose(f);
                closedir(dp);
                snprintf(err, err_len, "out of memory");
                return VD_ERR_IO;
            }
        }
        fclose(f);
        files++;
    }
    closedir(dp);
    if (files == 0) {
        snprintf(err, err_len, "%s: no YOLO label files (*.txt)", dir);
        return VD_ERR_FORMAT;
    }
    qsort(gt->img, gt->n, sizeof *gt->img, cmp_image);
    return VD_OK;
}

vd_status_t demo_gt_load(demo_gt_t *gt, const char *path, const char *classes_opt, char *err, size_t err_len)
{
    memset(gt, 0, sizeof *gt);
    struct stat sb;
    if (stat(path, &sb) != 0) {
        snprintf(err, err_len, "cannot open %s: %s", path, strerror(errno));
        return VD_ERR_IO;
    }
    vd_status_t st = S_ISDIR(sb.st_mode) ? load_yolo(gt, path, classes_opt, err, err_len)
                                         : load_coco(gt, path, classes_opt, err, err_len);
    if (st != VD_OK) {
        demo_gt_free(gt);
    }
    return st;
}

void demo_gt_free(demo_gt_t *gt)
{
    free(gt->scored);
    gt->scored = NULL;
    gt->n_scored = gt->cap_scored = 0;
    for (size_t i = 0; i < gt->n; i++) {
        free(gt->img[i].name);
        free(gt->img[i].box);
    }
    free(gt->img);
    gt->img = NULL;
    gt->n = gt->cap = 0;
}

typedef struct order {
    double score;
    size_t index;
} order_t;

static int cmp_order(const void *a, const void *b)
{
    const order_t *x = a, *y = b;
    if (x->score != y->score) {
        return x->score > y->score ? -1 : 1;
    }
    return x->index < y->index ? -1 : (x->index > y->index);
}

// The annotations of a frame (NULL: none; YOLO matches the file name's stem).
static const demo_gt_image_t *frame_image(const demo_gt_t *gt, const char *frame_name)
{
    const char *base = demo_basename(frame_name);
    if (!gt->yolo) {
        return find_image(gt, base);
    }
    char stem[1024];
    snprintf(stem, sizeof stem, "%s", base);
    char *dot = strrchr(stem, '.');
    if (dot != NULL) {
        *dot = '\0';
    }
    return find_image(gt, stem);
}

const demo_gt_image_t *demo_gt_image_of(const demo_gt_t *gt, const char *frame_name)
{
    return frame_image(gt, frame_name);
}

// True when the box (clipped to the frame, whole pixels it touches) holds a pixel >= thr.
static bool box_hot(const vd_frame_t *f, double x, double y, double w, double h, uint32_t thr)
{
    double x1 = fmax(floor(x), 0.0), y1 = fmax(floor(y), 0.0);
    double x2 = fmin(ceil(x + w), (double)f->width), y2 = fmin(ceil(y + h), (double)f->height);
    if (!(x2 > x1 && y2 > y1)) {
        return false;
    }
    size_t c0 = (size_t)x1, c1 = (size_t)x2, r0 = (size_t)y1, r1 = (size_t)y2;
    const uint8_t *base = f->data;
    for (size_t r = r0; r < r1; r++) {
        const uint8_t *row = base + r * f->stride;
        for (size_t c = c0; c < c1; c++) {
            uint32_t v = f->format == VD_PIX_U16 ? ((const uint16_t *)(const void *)row)[c] : row[c];
            if (v >= thr) {
                return true;
            }
        }
    }
    return false;
}

void demo_gt_candidates(demo_gt_t *gt, const char *frame_name, const vd_frame_t *frame, uint32_t hot_thr,
                        const vd_rect_t *cand, size_t n)
{
    const demo_gt_image_t *im = frame_image(gt, frame_name);
    if (im == NULL) {
        return;   // not evaluated (COCO) or no objects (YOLO)
    }
    double sx = im->normalised ? frame->width : 1.0, sy = im->normalised ? frame->height : 1.0;
    for (size_t b = 0; b < im->n; b++) {
        const demo_gt_box_t *g = &im->box[b];
        if (!g->vehicle) {
            continue;
        }
        double gx = g->x * sx, gy = g->y * sy, gw = g->w * sx, gh = g->h * sy;
        bool covered = false;
        for (size_t i = 0; i < n && !covered; i++) {
            covered = demo_iou(cand[i].x, cand[i].y, cand[i].w, cand[i].h, gx, gy, gw, gh) >= 0.5;
        }
        if (box_hot(frame, gx, gy, gw, gh, hot_thr)) {
            gt->veh_hot++;
            gt->cov_hot += covered;
        } else {
            gt->veh_cold++;
            gt->cov_cold += covered;
        }
    }
}

// Appends one counted detection to gt->scored (amortised doubling).
static void add_scored(demo_gt_t *gt, double score, bool tp)
{
    if (gt->scored_incomplete) {
        return;
    }
    if (gt->n_scored == gt->cap_scored) {
        size_t nc = gt->cap_scored ? gt->cap_scored * 2 : 1024;
        demo_gt_scored_t *p = realloc(gt->scored, nc * sizeof *p);
        if (p == NULL) {
            gt->scored_incomplete = true;
            return;
        }
        gt->scored = p;
        gt->cap_scored = nc;
    }
    gt->scored[gt->n_scored].score = score;
    gt->scored[gt->n_scored].order = gt->n_scored;
    gt->scored[gt->n_scored].tp = tp;
    gt->n_scored++;
}

void demo_gt_frame(demo_gt_t *gt, const char *frame_name, uint32_t width, uint32_t height,
                   const demo_det_t *det, size_t n, int8_t *matched)
{
    demo_gt_frame_ex(gt, frame_name, width, height, det, n, matched, NULL, 0);
}

void demo_gt_frame_ex(demo_gt_t *gt, const char *frame_name, uint32_t width, uint32_t height,
                      const demo_det_t *det, size_t n, int8_t *matched, bool *gt_used, size_t n_gt_used)
{
    const demo_gt_image_t *im = frame_image(gt, frame_name);
    gt->frames++;
    if (im == NULL && !gt->yolo) {
        // not listed in the annotations: not evaluated
        gt->frames_unannotated++;
        gt->frames--;
        if (matched != NULL) {
            for (size_t i = 0; i < n; i++) {
                matched[i] = -1;
            }
        }
        return;
    }
    // YOLO: a frame without a label file has no objects (YOLO's convention).
    size_t nb = im != NULL ? im->n : 0;
    double sx = 1.0, sy = 1.0;
    if (im != NULL && im->normalised) {
        sx = width;
        sy = height;
    }
    bool *used = calloc(nb + 1, sizeof *used);
    order_t *ord = calloc(n + 1, sizeof *ord);
    if (used == NULL || ord == NULL) {
        free(used);
        free(ord);
        return;
    }
    for (size_t b = 0; b < nb; b++) {
        if (im->box[b].vehicle) {
            gt->gt++;
        }
    }
    for (size_t i = 0; i < n; i++) {
        ord[i].score = det[i].score;
        ord[i].index = i;
    }
    qsort(ord, n, sizeof *ord, cmp_order);
    for (size_t k = 0; k < n; k++) {
        const demo_det_t *d = &det[ord[k].index];
        double dx = d->box.x, dy = d->box.y, dw = d->box.w, dh = d->box.h;
        double best = 0.0;
        size_t best_b = nb;
        for (size_t b = 0; b < nb; b++) {
            const demo_gt_box_t *g = &im->box[b];
            if (!g->vehicle || used[b]) {
                continue;
            }
            double iou = demo_iou(dx, dy, dw, dh, g->x * sx, g->y * sy, g->w * sx, g->h * sy);
            if (iou >= 0.5 && iou > best) {
                best = iou;
                best_b = b;
            }
        }
        int8_t m;
        if (best_b < nb) {
            used[best_b] = true;
            gt->tp++;
            gt->det++;
            m = 1;
        } else {
            bool ignored = false;
            for (size_t b = 0; b < nb && !ignored; b++) {
                const demo_gt_box_t *g = &im->box[b];
                if (!g->ignore) {
                    continue;
                }
                double gx = g->x * sx, gy = g->y * sy, gw = g->w * sx, gh = g->h * sy;
                double ix = fmin(dx + dw, gx + gw) - fmax(dx, gx);
                double iy = fmin(dy + dh, gy + gh) - fmax(dy, gy);
                double inside = (ix > 0 && iy > 0 && dw > 0 && dh > 0) ? ix * iy / (dw * dh) : 0.0;
                ignored = demo_iou(dx, dy, dw, dh, gx, gy, gw, gh) >= 0.5 || inside >= 0.5;
            }
            if (ignored) {
                gt->det_ignored++;
                m = -1;
            } else {
                gt->fp++;
                gt->det++;
                m = 0;
            }
        }
        if (matched != NULL) {
            matched[ord[k].index] = m;
        }
        if (m >= 0) {
            add_scored(gt, d->score, m == 1);
        }
    }
    for (size_t b = 0; gt_used != NULL && b < nb && b < n_gt_used; b++) {
        gt_used[b] = used[b];
    }
    free(used);
    free(ord);
}

static double ratio(uint64_t a, uint64_t b)
{
    return b == 0 ? 0.0 : (double)a / (double)b;
}

static int cmp_scored(const void *a, const void *b)
{
    const demo_gt_scored_t *x = a, *y = b;
    if (x->score != y->score) {
        return x->score > y->score ? -1 : 1;
    }
    return x->order < y->order ? -1 : (x->order > y->order);
}

vd_status_t demo_gt_pr(const demo_gt_t *gt, double **recall, double **precision, size_t *n, double *ap)
{
    *recall = *precision = NULL;
    *n = 0;
    *ap = 0.0;
    if (gt->scored_incomplete) {
        return VD_ERR_STATE;
    }
    const size_t m = gt->n_scored;
    demo_gt_scored_t *s = malloc((m + 1) * sizeof *s);
    double *r = malloc((m + 1) * sizeof *r);
    double *p = malloc((m + 1) * sizeof *p);
    double *env = malloc((m + 1) * sizeof *env);
    if (s == NULL || r == NULL || p == NULL || env == NULL) {
        free(s);
        free(r);
        free(p);
        free(env);
        return VD_ERR_IO;
    }
    if (m > 0) {
        memcpy(s, gt->scored, m * sizeof *s);
    }
    qsort(s, m, sizeof *s, cmp_scored);
    uint64_t tp = 0, fp = 0;
    for (size_t i = 0; i < m; i++) {
        tp += s[i].tp;
        fp += !s[i].tp;
        r[i] = ratio(tp, gt->gt);
        p[i] = ratio(tp, tp + fp);
    }
    // all-point interpolation: the precision envelope (max precision at any higher recall),
    // summed over the recall steps
    for (size_t i = m; i-- > 0;) {
        env[i] = (i + 1 < m && env[i + 1] > p[i]) ? env[i + 1] : p[i];
    }
    double last_r = 0.0, sum = 0.0;
    for (size_t i = 0; i < m && gt->gt > 0; i++) {
        sum += (r[i] - last_r) * env[i];
        last_r = r[i];
    }
    free(s);
    free(env);
    if (m == 0) {
        free(r);
        free(p);
        r = p = NULL;
    }
    *recall = r;
    *precision = p;
    *n = m;
    *ap = sum;
    return VD_OK;
}

// AP of the counted detections (demo_gt_pr); false when it is not available.
static bool gt_ap(const demo_gt_t *gt, double *ap)
{
    double *r, *p;
    size_t n;
    vd_status_t st = demo_gt_pr(gt, &r, &p, &n, ap);
    free(r);
    free(p);
    return st == VD_OK;
}

void demo_gt_report(const demo_gt_t *gt, FILE *f)
{
    fprintf(f, "evaluation (IoU >= 0.5, classes %s): %llu frames", gt->class_desc, (unsigned long long)gt->frames);
    if (gt->frames_unannotated > 0) {
        fprintf(f, " (+%llu frames not in the annotations, not evaluated)", (unsigned long long)gt->frames_unannotated);
    }
    fprintf(f, ", %llu vehicles, %llu detections (%llu in ignore regions not counted)\n",
            (unsigned long long)gt->gt, (unsigned long long)gt->det, (unsigned long long)gt->det_ignored);
    fprintf(f, "  TP rate %.2f%%  FP rate %.2f%%  precision %.2f%%  recall %.2f%%  FPPI %.3f  (TP %llu, FP %llu, FN %llu)\n",
            100.0 * ratio(gt->tp, gt->gt), 100.0 * ratio(gt->fp, gt->det), 100.0 * ratio(gt->tp, gt->det),
            100.0 * ratio(gt->tp, gt->gt), ratio(gt->fp, gt->frames), (unsigned long long)gt->tp,
            (unsigned long long)gt->fp, (unsigned long long)(gt->gt - gt->tp));
    double ap = 0.0;
    if (gt_ap(gt, &ap)) {
        fprintf(f, "  AP %.2f%%  (IoU >= 0.5, all-point interpolated, over the %llu counted detections by score)\n",
                100.0 * ap, (unsigned long long)gt->det);
    }
    fprintf(f, "  candidate recall (ceiling of the TP rate): %.2f%% (hot %.2f%% of %llu, cold %.2f%% of %llu)\n",
            100.0 * ratio(gt->cov_hot + gt->cov_cold, gt->veh_hot + gt->veh_cold), 100.0 * ratio(gt->cov_hot, gt->veh_hot),
            (unsigned long long)gt->veh_hot, 100.0 * ratio(gt->cov_cold, gt->veh_cold),
            (unsigned long long)gt->veh_cold);
}

vd_status_t demo_gt_write_json(const demo_gt_t *gt, const char *annotations, const char *path, char *err,
                               size_t err_len)
{
    demo_atomic_t a;
    vd_status_t st = demo_atomic_open(&a, path, err, err_len);
    if (st != VD_OK) {
        return st;
    }
    FILE *f = a.f;
    fprintf(f, "{\"annotations\": ");
    demo_json_write_string(f, annotations);
    fprintf(f, ", \"iou_threshold\": 0.5, \"classes\": [");
    for (size_t i = 0; i < gt->n_classes; i++) {
        fprintf(f, "%s%d", i ? ", " : "", (int)gt->classes[i]);
    }
    fprintf(f, "], \"frames\": %llu, \"frames_not_annotated\": %llu, \"vehicles\": %llu, \"detections\": %llu, "
               "\"ignored_detections\": %llu, \"tp\": %llu, \"fp\": %llu, \"fn\": %llu, ",
            (unsigned long long)gt->frames, (unsigned long long)gt->frames_unannotated, (unsigned long long)gt->gt,
            (unsigned long long)gt->det, (unsigned long long)gt->det_ignored, (unsigned long long)gt->tp,
            (unsigned long long)gt->fp, (unsigned long long)(gt->gt - gt->tp));
    fprintf(f, "\"candidate_recall\": %.6f, \"candidate_recall_hot\": %.6f, \"candidate_recall_cold\": %.6f, "
               "\"vehicles_hot\": %llu, \"vehicles_cold\": %llu, ",
            ratio(gt->cov_hot + gt->cov_cold, gt->veh_hot + gt->veh_cold), ratio(gt->cov_hot, gt->veh_hot),
            ratio(gt->cov_cold, gt->veh_cold), (unsigned long long)gt->veh_hot, (unsigned long long)gt->veh_cold);
    double ap = 0.0;
    if (gt_ap(gt, &ap)) {
        fprintf(f, "\"ap\": %.6f, ", ap);
    }
    fprintf(f, "\"tp_rate\": %.6f, \"fp_rate\": %.6f, \"precision\": %.6f, \"recall\": %.6f, \"fppi\": %.6f}\n",
            ratio(gt->tp, gt->gt), ratio(gt->fp, gt->det), ratio(gt->tp, gt->det), ratio(gt->tp, gt->gt),
            ratio(gt->fp, gt->frames));
    return demo_atomic_commit(&a, err, err_len);
}
