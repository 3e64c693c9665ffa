// SPDX-License-Identifier: MIT
// Outer-contour tracing: raster scan + Suzuki-Abe border following, RETR_EXTERNAL.
//
// Algorithm: S. Suzuki, K. Abe, "Topological structural analysis of digitized
// binary images by border following", CVGIP 30(1), 1985, in the variant of
// OpenCV's findContours (RETR_EXTERNAL, CHAIN_APPROX_NONE), whose output this
// reproduces point for point:
//   1. The mask is copied into a mark plane with a one-pixel zero border,
//      nonzero -> 1.
//   2. Rows are scanned left to right (32 zero pixels or 8 pixels equal to
//      the previous one skipped per step: nothing happens inside a run). A
//      0 -> 1 step starts an outer border
//      unless the last border pixel met on this row (`lnbd`) is marked as a
//      left/inner side (value 2, "> 0"), which means the step lies inside an
//      already traced region (its hole or a region inside the hole).
//   3. The border is followed with the 8-neighbour search (clockwise first
//      neighbour, then counter-clockwise around each pixel). Each visited
//      pixel is marked 2, or 0x82 ("right side") when the search passed its
//      right neighbour (a background pixel). Every step emits one point and
//      its Freeman code. It stops when it is back on the start pixel about to
//      move to the first neighbour again.
//   4. Contours are found in raster order of their first pixel; cv2 lists them
//      in the reverse order, so the arrays are reversed at the end (in place).
// Marks: 0 background, 1 unvisited foreground, 2 visited, 0x82 visited and
// right side. (OpenCV keeps the same values in a signed char plane.)
//
// Bounds: time O(w*h) for the scan plus O(points) for the traces; a pixel is
// entered at most 4 times by one trace (it has at most 4 background gaps
// among its 8 neighbours), so a trace is guarded at 4*(w+2)*(h+2) steps and
// all points of all contours are fewer than 4*w*h. Stack: a few dozen bytes,
// no recursion. Workspace: (w+2)*(h+2) bytes (the mark plane).
#include "vd/contour.h"

#include <string.h>

#include "internal/vd_internal.h"

#define MARK_FG 1u
#define MARK_NEW 2u
#define MARK_RIGHT 0x80u

// Freeman code -> (dx, dy) in image coordinates.
static const int8_t k_dx[8] = {1, 1, 0, -1, -1, -1, 0, 1};
static const int8_t k_dy[8] = {0, -1, -1, -1, 0, 1, 1, 1};

static bool plane_size(uint32_t w, uint32_t h, size_t *bytes)
{
    return vd_mul_size((size_t)w + 2u, (size_t)h + 2u, bytes);
}

vd_status_t vd_contour_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes)
{
    VD_VERIFY(bytes != NULL, VD_ERR_ARG);
    VD_VERIFY(max_width >= 1u && max_height >= 1u && max_width <= VD_MAX_DIM && max_height <= VD_MAX_DIM, VD_ERR_ARG);
    VD_VERIFY(plane_size(max_width, max_height, bytes), VD_ERR_OVERFLOW);
    return VD_OK;
}

// Value of a mark read as OpenCV's signed char: positive means 1 or 2.
static bool mark_positive(uint8_t v)
{
    return v != 0u && (v & MARK_RIGHT) == 0u;
}

// d[x] = s[x] != 0 ? MARK_FG : 0 (restrict: a straight loop the compiler
// turns into SIMD compares without a run-time overlap check).
static void mark_row(const uint8_t *restrict s, uint8_t *restrict d, size_t n)
{
    for (size_t x = 0; x < n; x++) {
        d[x] = (uint8_t)(s[x] != 0u ? MARK_FG : 0u);
    }
}

typedef struct tracer {
    uint8_t *plane;
    ptrdiff_t delta[8];    // pointer offsets of the 8 Freeman directions
    size_t max_steps;
    vd_point_t *points;
    uint8_t *chain;
    size_t cap;
    size_t used;           // points written so far (all contours)
} tracer_t;

// Follows the outer border whose first pixel (raster order) is plane index
// `start`, at image coordinates (x, y). Appends its points; on return *len is
// the number of points and *box their bounding box.
static vd_status_t trace_outer(tracer_t *t, size_t start, int32_t x, int32_t y, size_t *len, vd_rect_t *box)
{
    uint8_t *const p = t->plane;
    const size_t first = t->used;
    int32_t x0 = x, x1 = x, y0 = y, y1 = y;

    // First neighbour: search clockwise from the left (the pixel left of an
    // outer start is background, so at most the 7 others are looked at).
    unsigned s = 4u;
    size_t i1;
    do {
        s = (s - 1u) & 7u;
        i1 = (size_t)((ptrdiff_t)start + t->delta[s]);
    } while (p[i1] == 0u && s != 4u);

    if (s == 4u) {   // isolated pixel
        p[start] = (uint8_t)(MARK_NEW | MARK_RIGHT);
        VD_VERIFY(t->used < t->cap, VD_ERR_CAPACITY);
        t->points[t->used].x = (int16_t)x;
        t->points[t->used].y = (int16_t)y;
        if (t->chain != NULL) {
            t->chain[t->used] = (uint8_t)VD_CONTOUR_CHAIN_NONE;
        }
        t->used++;
    } else {
        size_t i3 = start;
        size_t i4 = start;
        size_t steps;
        bool closed = false;
        for (steps = 0u; steps < t->max_steps; steps++) {
            const unsigned s_end = s;
            // Counter-clockwise from the direction we came from; the pixel we
            // came from is nonzero, so at most 8 directions are tried.
            unsigned k;
            for (k = 1u; k <= 8u; k++) {
                i4 = (size_t)((ptrdiff_t)i3 + t->delta[(s + k) & 7u]);
                if (p[i4] != 0u) {
                    break;
                }
            }
            VD_ASSERT(k <= 8u);
            s = (s + k) & 7u;
            // The search wrapped past direction 0: the right neighbour is
            // background, so this pixel is a right side of the region.
            if (s >= 1u && s <= s_end) {
                p[i3] = (uint8_t)(MARK_NEW | MARK_RIGHT);
            } else if (p[i3] == MARK_FG) {
                p[i3] = (uint8_t)MARK_NEW;
            }
            VD_VERIFY(t->used < t->cap, VD_ERR_CAPACITY);
            t->points[t->used].x = (int16_t)x;
            t->points[t->used].y = (int16_t)y;
            if (t->chain != NULL) {
                t->chain[t->used] = (uint8_t)s;
            }
            t->used++;
            x0 = x < x0 ? x : x0;
            x1 = x > x1 ? x : x1;
            y0 = y < y0 ? y : y0;
            y1 = y > y1 ? y : y1;
            x += k_dx[s];
            y += k_dy[s];
            if (i4 == start && i3 == i1) {
                closed = true;
                break;
            }
            i3 = i4;
            s = (s + 4u) & 7u;
        }
        VD_VERIFY(closed, VD_ERR_STATE);
    }
    *len = t->used - first;
    box->x = x0;
    box->y = y0;
    box->w = x1 - x0 + 1;
    box->h = y1 - y0 + 1;
    return VD_OK;
}

static void reverse_points(vd_point_t *a, uint8_t *c, size_t lo, size_t hi)
{
    // Reverses [lo, hi); the loop runs (hi - lo) / 2 times.
    while (hi > lo + 1u) {
        hi--;
        vd_point_t tp = a[lo];
        a[lo] = a[hi];
        a[hi] = tp;
        if (c != NULL) {
            uint8_t tc = c[lo];
            c[lo] = c[hi];
            c[hi] = tc;
        }
        lo++;
    }
}

// Puts the contours found in raster order into cv2's order (reversed) while
// keeping each contour's own point order: reverse all points, then each
// contour's run, then the contour list. O(points + contours).
static void to_cv_order(vd_point_t *pts, uint8_t *chain, size_t n_pts, vd_contour_t *cs, size_t n_cs)
{
    reverse_points(pts, chain, 0u, n_pts);
    for (size_t i = 0; i < n_cs; i++) {
        size_t first = n_pts - (size_t)cs[i].first - (size_t)cs[i].length;
        cs[i].first = (uint32_t)first;
        reverse_points(pts, chain, first, first + cs[i].length);
    }
    for (size_t i = 0, j = n_cs; j > i + 1u; i++) {
        j--;
        vd_contour_t tmp = cs[i];
        cs[i] = cs[j];
        cs[j] = tmp;
    }
}

// The mark plane p ((w + 2) x (h + 2), stride w + 2): the mask's nonzero
// pixels as MARK_FG inside a zero border.
static void mark_plane(const vd_view_u8_t *mask, uint8_t *p)
{
    const size_t w = mask->width;
    const size_t h = mask->height;
    const size_t pw = w + 2u;
    memset(p, 0, pw);
    memset(p + (h + 1u) * pw, 0, pw);
    for (size_t y = 0; y < h; y++) {
        const uint8_t *src = mask->data + y * mask->stride;
        uint8_t *row = p + (y + 1u) * pw;
        row[0] = 0u;
        row[w + 1u] = 0u;
        mark_row(src, row + 1u, w);
    }
}

// A tracer on the mark plane p (stride pw, need bytes) writing into the
// caller's point and chain arrays (cap points).
static void tracer_init(tracer_t *t, uint8_t *p, size_t pw, size_t need, vd_point_t *points, uint8_t *chain,
                        size_t cap)
{
    const ptrdiff_t st = (ptrdiff_t)pw;
    t->plane = p;
    t->delta[0] = 1;
    t->delta[1] = 1 - st;
    t->delta[2] = -st;
    t->delta[3] = -st - 1;
    t->delta[4] = -1;
    t->delta[5] = st - 1;
    t->delta[6] = st;
    t->delta[7] = st + 1;
    t->max_steps = 4u * need;   // need = (w+2)(h+2) < 2^27: no overflow
    t->points = points;
    t->chain = chain;
    t->cap = cap;
    t->used = 0u;
}

vd_status_t vd_contour_find_external(const vd_view_u8_t *mask, void *ws, size_t bytes,
                                      vd_point_t *points, uint8_t *chain, size_t points_cap,
                                      vd_contour_t *contours, size_t contours_cap,
                                      size_t *n_contours, size_t *n_points)
{
    if (n_contours != NULL) {
        *n_contours = 0u;
    }
    if (n_points != NULL) {
        *n_points = 0u;
    }
    VD_VERIFY(n_contours != NULL && n_points != NULL && points != NULL && contours != NULL, VD_ERR_ARG);
    VD_TRY(vd_view_u8_check(mask));
    const size_t w = mask->width;
    const size_t h = mask->height;
    const size_t pw = w + 2u;   // padded width = stride of the mark plane
    size_t need;
    VD_VERIFY(plane_size(mask->width, mask->height, &need), VD_ERR_OVERFLOW);
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % (uintptr_t)VD_WORKSPACE_ALIGN) == 0u && bytes >= need,
              VD_ERR_WORKSPACE);

    // 1. Mark plane with a zero border, nonzero -> 1.
    uint8_t *p = (uint8_t *)ws;
    mark_plane(mask, p);
    tracer_t t;
    tracer_init(&t, p, pw, need, points, chain, points_cap);

    vd_status_t st = VD_OK;
    size_t nc = 0u;
    // 2. Raster scan of the interior of the padded plane.
    for (size_t y = 1u; y <= h && st == VD_OK; y++) {
        uint8_t *row = p + y * pw;
        uint8_t prev = 0u;
        size_t lnbd = 0u;   // column of the last border pixel met on this row
        for (size_t x = 1u; x <= w; x++) {
            // Skip 32 zero pixels or 8 pixels equal to prev at once (a hot
            // mask is mostly zero runs; blob interiors are runs of 1).
            // Nothing happens at a pixel equal to prev: same result.
            if (x + 7u <= w) {
                uint64_t q[4];
                if (prev == 0u && x + 31u <= w) {
                    memcpy(q, row + x, sizeof q);
                    if ((q[0] | q[1] | q[2] | q[3]) == 0u) {
                        x += 31u;
                        continue;
                    }
                } else {
                    memcpy(q, row + x, sizeof q[0]);
                }
                if (q[0] == (uint64_t)prev * 0x0101010101010101ull) {
                    x += 7u;
                    continue;
                }
            }
            const uint8_t v = row[x];
            if (v == prev) {
                continue;
            }
            if (prev == 0u && v == MARK_FG) {
                if (!mark_positive(row[lnbd])) {
                    // New outer border starting at (x, y).
                    if (nc >= contours_cap) {
                        st = VD_ERR_CAPACITY;
                        break;
                    }
                    size_t len = 0u;
                    vd_rect_t box;
                    const size_t first = t.used;
                    st = trace_outer(&t, y * pw + x, (int32_t)x - 1, (int32_t)y - 1, &len, &box);
                    if (st != VD_OK) {
                        t.used = first;   // drop the partial contour
                        break;
                    }
                    contours[nc].first = (uint32_t)first;
                    contours[nc].length = (uint32_t)len;
                    contours[nc].box = box;
                    nc++;
                    lnbd = x;
                    prev = row[x];   // now marked
                    continue;
                }
            } else if (v == 0u && prev != 0u && (prev & MARK_RIGHT) == 0u) {
                // Start of a hole border: not traced in this mode, but OpenCV
                // moves lnbd to the marked pixel just left of it.
                if ((prev & 0xFEu) != 0u) {
                    lnbd = x - 1u;
                }
            }
            prev = v;
            if ((v & 0xFEu) != 0u) {
                lnbd = x;
            }
        }
    }

    to_cv_order(points, chain, t.used, contours, nc);
    *n_contours = nc;
    *n_points = t.used;
    return st;
}
