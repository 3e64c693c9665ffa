// SPDX-License-Identifier: MIT
// 8-connected component labelling over runs: whole frame, or streamed a row
// pair at a time (components_internal.h); shape rules in component_rules.c.
//
// Algorithm: rows are taken in pairs (ROI rows 2k, 2k+1). Each row is
// run-length encoded straight from its source (a 0/nonzero mask, or an 8- or
// 16-bit plane compared with a threshold, so no mask has to exist; uniform
// stretches are skipped a 64-bit word at a time); the runs of the pair
// are merged by start x into one array, so that run index order is the order
// of OpenCV's block-based labelling (first 2x2 block of each component). Runs
// of adjacent rows that overlap or touch diagonally (8-connectivity:
// a.x0 <= b.x1 + 1 and b.x0 <= a.x1 + 1) are united in a union-find forest
// whose root is always the smallest run index (link larger root under
// smaller; path halving, no recursion), so parent[i] <= i. One pass in index
// order then turns parents into consecutive labels (a root gets the next
// label, any other run its parent's label), and a second pass accumulates the
// statistics per run into out[] (labels < cap only). The run array is the
// only storage that grows with the content: its size is the run budget (the
// worst case ceil(w/2) * h for vd_components_label; whatever the workspace
// holds for the _thr_ functions, which stop at the first row pair that does
// not fit and report it).
// Reference: union-find over run-length segments as in the classic two-pass
// run-based labelling (e.g. He, Chao, Suzuki, "A run-based two-scan labeling
// algorithm", IEEE TIP 2008); order as in Bolelli et al., "Spaghetti
// labeling" (OpenCV's CCL_DEFAULT for 8-connectivity).
// Bounds: time O(w*h) for the scan plus O(runs * log runs) worst case for
// union-find (near-linear in practice); stack O(1) (frames in
// docs/embedded.md); workspace 24 * ceil(w/2) + 4 * (ceil(h/2) + 1) bytes
// plus 8 per run of budget (runs <= ceil(w/2) * h, which needs VD_MAX_DIM <
// 32768 for the 15-bit x plus row flag, and ceil(w/2)*h < 2^32).
#include "vd/components.h"

#include <string.h>

#include "internal/vd_internal.h"
#include "regions/components_internal.h"

#if VD_MAX_DIM > 32767u
#error "components.c packs x into 15 bits: VD_MAX_DIM must be below 32768"
#endif

// Flag in a stored run's x0: the run lies on the odd row of its pair.
#define CC_ODD_ROW 0x8000u
#define CC_X_MASK 0x7FFFu

// A run of a row being processed: [x0, x1] inclusive and its index in slots[].
typedef struct cc_span {
    uint16_t x0;
    uint16_t x1;
    uint32_t idx;
} cc_span_t;

// A stored run. After labelling, slot L (whose run was already consumed, as
// L <= the index of the component's first run <= current index) is reused as
// the 64-bit sum of x of component L.
typedef union cc_slot {
    struct {
        uint16_t x0f;     // x0 | CC_ODD_ROW on the second row of the pair
        uint16_t x1;      // inclusive end
        uint32_t parent;  // union-find parent, then the label
    } run;
    uint64_t sum_x;
} cc_slot_t;

// Workspace layout: three row-span buffers of ceil(w/2) runs, the pair
// offsets seg[ceil(h/2) + 1], then the run slots (the budget) at the end, so
// whatever the caller gives beyond the fixed part is run budget.
typedef struct cc_layout {
    size_t worst_runs; // ceil(w/2) * h: the most runs any w x h region has
    size_t spans_cap;  // ceil(w/2)
    size_t pairs;      // ceil(h/2)
    size_t fixed;      // bytes before the slots
} cc_layout_t;

static vd_status_t cc_layout(uint32_t w, uint32_t h, cc_layout_t *lay)
{
    VD_VERIFY(w >= 1u && h >= 1u && w <= VD_MAX_DIM && h <= VD_MAX_DIM, VD_ERR_ARG);
    size_t total = 0u;
    size_t n;
    lay->spans_cap = ((size_t)w + 1u) / 2u;
    lay->pairs = ((size_t)h + 1u) / 2u;
    VD_VERIFY(vd_mul_size(lay->spans_cap, (size_t)h, &lay->worst_runs), VD_ERR_OVERFLOW);
    VD_VERIFY(lay->worst_runs <= (size_t)UINT32_MAX, VD_ERR_OVERFLOW);
    for (int i = 0; i < 3; i++) {
        VD_VERIFY(vd_mul_size(lay->spans_cap, sizeof(cc_span_t), &n) && vd_size_add_slice(&total, n),
                  VD_ERR_OVERFLOW);
    }
    VD_VERIFY(vd_mul_size(lay->pairs + 1u, sizeof(uint32_t), &n) && vd_size_add_slice(&total, n), VD_ERR_OVERFLOW);
    lay->fixed = total;
    return VD_OK;
}

// Fixed part plus `runs` slots.
static vd_status_t cc_bytes(const cc_layout_t *lay, size_t runs, size_t *bytes)
{
    size_t n;
    size_t total = lay->fixed;
    VD_VERIFY(vd_mul_size(runs, sizeof(cc_slot_t), &n) && vd_size_add_slice(&total, n), VD_ERR_OVERFLOW);
    *bytes = total;
    return VD_OK;
}

vd_status_t vd_components_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes)
{
    VD_VERIFY(bytes != NULL, VD_ERR_ARG);
    cc_layout_t lay;
    VD_TRY(cc_layout(max_width, max_height, &lay));
    return cc_bytes(&lay, lay.worst_runs, bytes);
}

vd_status_t vd_components_workspace_size_runs(uint32_t max_width, uint32_t max_height, uint32_t max_runs,
                                              size_t *bytes)
{
    VD_VERIFY(bytes != NULL && max_runs >= 1u, VD_ERR_ARG);
    cc_layout_t lay;
    VD_TRY(cc_layout(max_width, max_height, &lay));
    return cc_bytes(&lay, (size_t)max_runs < lay.worst_runs ? (size_t)max_runs : lay.worst_runs, bytes);
}

// True if any byte of v is zero (exact: no false positives).
static inline bool cc_has_zero_byte(uint64_t v)
{
    return ((v - UINT64_C(0x0101010101010101)) & ~v & UINT64_C(0x8080808080808080)) != 0u;
}

// Lane masks for 8 x u8 and 4 x u16 lanes of a uint64. A 16-bit lane loaded
// by memcpy holds the native uint16 on either endianness, so lane tests are
// exact on big- and little-endian targets alike.
#define CC_H8 UINT64_C(0x8080808080808080)
#define CC_L8 UINT64_C(0x7F7F7F7F7F7F7F7F)
#define CC_B8 UINT64_C(0x0101010101010101)
#define CC_H16 UINT64_C(0x8000800080008000)
#define CC_L16 UINT64_C(0x7FFF7FFF7FFF7FFF)
#define CC_B16 UINT64_C(0x0001000100010001)

// Per lane: top bit set iff lane(v) >= lane(tb) (unsigned), for lanes with top
// bit H and low bits L. (v | H) - (tb & L) cannot borrow across lanes (each
// lane is >= H - L = 1), so its top bit is "low bits of v >= low bits of t";
// the top bits of v and t decide when they differ.
static inline uint64_t cc_lanes_ge(uint64_t v, uint64_t tb, uint64_t hi, uint64_t lo)
{
    const uint64_t ge_low = ((v | hi) - (tb & lo)) & hi;
    return ((v & ~tb) | (~(v ^ tb) & ge_low)) & hi;
}

// Run-length encoders of one row of w pixels into spans[] (x only); each
// returns the number of runs, at most ceil(w/2). Every loop advances x, so
// <= w steps. Background and foreground are skipped a 64-bit word at a time.
static size_t cc_runs_mask(const uint8_t *p, uint32_t w, cc_span_t *spans)
{
    size_t n = 0u;
    uint32_t x = 0u;
    while (x < w) {
        uint64_t v;
        while (x + 8u <= w) { // background: 8 zero bytes at a time
            memcpy(&v, p + x, sizeof v);
            if (v != 0u) {
                break;
            }
            x += 8u;
        }
        while (x < w && p[x] == 0u) {
            x++;
        }
        if (x >= w) {
            break;
        }
        uint32_t start = x;
        while (x + 8u <= w) { // foreground: 8 nonzero bytes at a time
            memcpy(&v, p + x, sizeof v);
            if (cc_has_zero_byte(v)) {
                break;
            }
            x += 8u;
        }
        while (x < w && p[x] != 0u) {
            x++;
        }
        spans[n].x0 = (uint16_t)start;
        spans[n].x1 = (uint16_t)(x - 1u);
        n++;
    }
    return n;
}

static size_t cc_runs_thr_u8(const uint8_t *p, uint32_t w, uint8_t t, cc_span_t *spans)
{
    const uint64_t tb = (uint64_t)t * CC_B8;
    size_t n = 0u;
    uint32_t x = 0u;
    while (x < w) {
        uint64_t v;
        while (x + 8u <= w) { // background: no byte >= t
            memcpy(&v, p + x, sizeof v);
            if (cc_lanes_ge(v, tb, CC_H8, CC_L8) != 0u) {
                break;
            }
            x += 8u;
        }
        while (x < w && p[x] < t) {
            x++;
        }
        if (x >= w) {
            break;
        }
        uint32_t start = x;
        while (x + 8u <= w) { // foreground: every byte >= t
            memcpy(&v, p + x, sizeof v);
            if (cc_lanes_ge(v, tb, CC_H8, CC_L8) != CC_H8) {
                break;
            }
            x += 8u;
        }
        while (x < w && p[x] >= t) {
            x++;
        }
        spans[n].x0 = (uint16_t)start;
        spans[n].x1 = (uint16_t)(x - 1u);
        n++;
    }
    return n;
}

static inline uint16_t cc_px16(const uint8_t *p, uint32_t x)
{
    uint16_t v;
    memcpy(&v, p + 2u * x, sizeof v);
    return v;
}

static size_t cc_runs_thr_u16(const uint8_t *p, uint32_t w, uint16_t t, cc_span_t *spans)
{
    const uint64_t tb = (uint64_t)t * CC_B16;
    size_t n = 0u;
    uint32_t x = 0u;
    while (x < w) {
        uint64_t v;
        while (x + 4u <= w) { // background: no pixel >= t
            memcpy(&v, p + 2u * x, sizeof v);
            if (cc_lanes_ge(v, tb, CC_H16, CC_L16) != 0u) {
                break;
            }
            x += 4u;
        }
        while (x < w && cc_px16(p, x) < t) {
            x++;
        }
        if (x >= w) {
            break;
        }
        uint32_t start = x;
        while (x + 4u <= w) { // foreground: every pixel >= t
            memcpy(&v, p + 2u * x, sizeof v);
            if (cc_lanes_ge(v, tb, CC_H16, CC_L16) != CC_H16) {
                break;
            }
            x += 4u;
        }
        while (x < w && cc_px16(p, x) >= t) {
            x++;
        }
        spans[n].x0 = (uint16_t)start;
        spans[n].x1 = (uint16_t)(x - 1u);
        n++;
    }
    return n;
}

// What the labeller reads: a mask (nonzero) or a plane compared with thr.
enum { CC_SRC_MASK, CC_SRC_THR_U8, CC_SRC_THR_U16 };

typedef struct cc_src {
    const uint8_t *row0; // first pixel of the ROI
    size_t stride;       // bytes
    uint32_t w, h;       // ROI size
    int32_t x, y;        // ROI origin in the image
    int kind;
    uint16_t thr;
} cc_src_t;

static size_t cc_row_runs(const cc_src_t *s, size_t y, cc_span_t *spans)
{
    const uint8_t *p = s->row0 + y * s->stride;
    if (s->kind == CC_SRC_THR_U8) {
        return cc_runs_thr_u8(p, s->w, (uint8_t)s->thr, spans);
    }
    if (s->kind == CC_SRC_THR_U16) {
        return cc_runs_thr_u16(p, s->w, s->thr, spans);
    }
    return cc_runs_mask(p, s->w, spans);
}

// Root of run i with path halving. parent[j] < j for every non-root j, so
// each step lowers i: at most i steps.
static inline uint32_t cc_find(cc_slot_t *s, uint32_t i)
{
    while (s[i].run.parent != i) {
        uint32_t gp = s[s[i].run.parent].run.parent;
        s[i].run.parent = gp;
        i = gp;
    }
    return i;
}

// Unites each run of row `dn` with the runs of the row above (`up`) that it
// touches in 8-connectivity. Two-pointer sweep: O(nu + nd) pairs. The root
// of the current down run is kept in `r` across its unions (it stays a root:
// it only ever gains children or is replaced by the smaller root).
static void cc_unite_rows(cc_slot_t *s, const cc_span_t *up, size_t nu, const cc_span_t *dn, size_t nd)
{
    size_t j = 0u;
    for (size_t i = 0u; i < nd; i++) {
        uint32_t lo = dn[i].x0;
        uint32_t hi = (uint32_t)dn[i].x1 + 1u;
        while (j < nu && (uint32_t)up[j].x1 + 1u < lo) {
            j++;
        }
        if (j >= nu || up[j].x0 > hi) {
            continue;
        }
        uint32_t r = cc_find(s, dn[i].idx);
        for (size_t k = j; k < nu && up[k].x0 <= hi; k++) {
            uint32_t ru = cc_find(s, up[k].idx);
            if (ru < r) {
                s[r].run.parent = ru;
                r = ru;
            } else if (r < ru) {
                s[ru].run.parent = r;
            }
        }
    }
}

// Appends the runs of both rows of a pair to slots[], merged by x0 (a tie
// means the runs touch vertically, so their order does not change labels).
// Adds the runs' pixels to *pixels.
static uint32_t cc_merge_pair(cc_slot_t *s, uint32_t n, cc_span_t *a, size_t na, cc_span_t *b, size_t nb,
                              uint32_t *pixels)
{
    size_t ia = 0u;
    size_t ib = 0u;
    uint32_t px = 0u;
    while (ia < na || ib < nb) {
        if (ib == nb || (ia < na && a[ia].x0 <= b[ib].x0)) {
            s[n].run.x0f = a[ia].x0;
            s[n].run.x1 = a[ia].x1;
            a[ia].idx = n;
            ia++;
        } else {
            s[n].run.x0f = (uint16_t)(b[ib].x0 | CC_ODD_ROW);
            s[n].run.x1 = b[ib].x1;
            b[ib].idx = n;
            ib++;
        }
        px += (uint32_t)s[n].run.x1 - (s[n].run.x0f & CC_X_MASK) + 1u;
        s[n].run.parent = n;
        n++;
    }
    *pixels += px;
    return n;
}

// Pass 2 of cc_label: box, area and coordinate sums of every label < cap
// from the labelled runs (slots, pair k's runs at seg[k] .. seg[k + 1]).
static void cc_accumulate(cc_slot_t *slots, const uint32_t *seg, size_t pairs, vd_component_t *out, size_t cap)
{
    // Labels < cap, in index order. While accumulating, out[L].box holds
    // {min x, min y, max x, max y} in ROI coordinates,
    // cx_q8 | cy_q8 << 32 holds sum(y), and slots[L].sum_x sum(x). Label L
    // first appears at its root run (L <= root index), labels first appear
    // in increasing order, and slot L was read at step L <= i before reuse.
    // Sums: sum(x) < area * w <= 2^26 * 2^13 = 2^39 for VD_MAX_DIM 8192 (and
    // < 2^60 for any w, h < 2^15), so uint64 cannot overflow.
    uint32_t seen = 0u;
    for (size_t k = 0u; k < pairs; k++) {
        const uint32_t y_even = (uint32_t)(2u * k);
        for (uint32_t i = seg[k]; i < seg[k + 1u]; i++) {
            const uint32_t x0f = slots[i].run.x0f;
            const uint32_t x0 = x0f & CC_X_MASK;
            const uint32_t x1 = slots[i].run.x1;
            const uint32_t lab = slots[i].run.parent;
            if ((size_t)lab >= cap) {
                continue;
            }
            const uint32_t y = y_even + ((x0f & CC_ODD_ROW) != 0u ? 1u : 0u);
            const uint32_t len = x1 - x0 + 1u;
            // x0 + ... + x1 = (x0 + x1) * len / 2; the product is always even.
            const uint64_t sx = ((uint64_t)(x0 + x1) * len) >> 1;
            vd_component_t *c = &out[lab];
            uint64_t sy = (uint64_t)y * len;
            if (lab == seen) {
                seen++;
                c->box.x = (int32_t)x0;
                c->box.y = (int32_t)y;
                c->box.w = (int32_t)x1;
                c->box.h = (int32_t)y;
                c->area = len;
                slots[lab].sum_x = sx;
            } else {
                if ((int32_t)x0 < c->box.x) {
                    c->box.x = (int32_t)x0;
                }
                if ((int32_t)x1 > c->box.w) {
                    c->box.w = (int32_t)x1;
                }
                if ((int32_t)y < c->box.y) {
                    c->box.y = (int32_t)y;
                }
                if ((int32_t)y > c->box.h) {
                    c->box.h = (int32_t)y;
                }
                c->area += len;
                slots[lab].sum_x += sx;
                sy += (uint64_t)c->cx_q8 | ((uint64_t)c->cy_q8 << 32);
            }
            c->cx_q8 = (uint32_t)(sy & 0xFFFFFFFFu);
            c->cy_q8 = (uint32_t)(sy >> 32);
        }
    }
}

// The n_out accumulated components as results: boxes to image coordinates,
// centroids from the sums.
static void cc_finish(const cc_src_t *src, const cc_slot_t *slots, vd_component_t *out, size_t n_out)
{
    // Centroids round-half-up in Q8: floor((512 * sum + area) / (2 * area));
    // 512 * sum < 2^48.
    for (size_t l = 0u; l < n_out; l++) {
        vd_component_t *c = &out[l];
        const uint64_t sy = (uint64_t)c->cx_q8 | ((uint64_t)c->cy_q8 << 32);
        const uint64_t sx = slots[l].sum_x;
        const uint64_t a2 = 2u * (uint64_t)c->area;
        const uint64_t cx = (512u * sx + c->area) / a2;
        const uint64_t cy = (512u * sy + c->area) / a2;
        c->box.w = c->box.w - c->box.x + 1;
        c->box.h = c->box.h - c->box.y + 1;
        c->box.x += src->x;
        c->box.y += src->y;
        c->cx_q8 = (uint32_t)cx + ((uint32_t)src->x << 8);
        c->cy_q8 = (uint32_t)cy + ((uint32_t)src->y << 8);
    }
}

// The labeller shared by all entry points. `ws`/`bytes` were checked to hold
// the fixed part of `lay` plus at least one slot; the run budget is what is
// left, up to the worst case.
static vd_status_t cc_label(const cc_src_t *src, const cc_layout_t *lay, void *ws, size_t bytes,
                            vd_component_t *out, size_t cap, size_t *count, vd_components_stats_t *stats)
{
    vd_arena_t arena;
    VD_TRY(vd_arena_init(&arena, ws, bytes));
    cc_span_t *sp_a = (cc_span_t *)vd_arena_take(&arena, lay->spans_cap * sizeof(cc_span_t));
    cc_span_t *sp_b = (cc_span_t *)vd_arena_take(&arena, lay->spans_cap * sizeof(cc_span_t));
    cc_span_t *sp_up = (cc_span_t *)vd_arena_take(&arena, lay->spans_cap * sizeof(cc_span_t));
    uint32_t *seg = (uint32_t *)vd_arena_take(&arena, (lay->pairs + 1u) * sizeof(uint32_t));
    VD_ASSERT(sp_a != NULL && sp_b != NULL && sp_up != NULL && seg != NULL && arena.used == lay->fixed);
    cc_slot_t *slots = (cc_slot_t *)((uint8_t *)ws + lay->fixed);
    size_t runs_cap = (bytes - lay->fixed) / sizeof(cc_slot_t);
    if (runs_cap > lay->worst_runs) {
        runs_cap = lay->worst_runs;
    }
    const uint32_t h = src->h;

    // Pass 1: runs and unions, one row pair at a time. sp_up holds the runs
    // of the row just above the pair (the previous pair's second row). A pair
    // whose runs do not fit in the budget ends the scan: `pairs` complete
    // pairs (rows [0, rows)) are labelled.
    uint32_t n = 0u;
    uint32_t pixels = 0u;
    size_t n_up = 0u;
    size_t pairs = lay->pairs;
    uint32_t rows = h;
    for (size_t k = 0u; k < lay->pairs; k++) {
        const size_t y = 2u * k;
        size_t na = cc_row_runs(src, y, sp_a);
        size_t nb = 0u;
        if (y + 1u < h) {
            nb = cc_row_runs(src, y + 1u, sp_b);
        }
        if (na + nb > runs_cap - n) {
            pairs = k;
            rows = (uint32_t)y;
            break;
        }
        seg[k] = n;
        n = cc_merge_pair(slots, n, sp_a, na, sp_b, nb, &pixels);
        cc_unite_rows(slots, sp_up, n_up, sp_a, na);
        cc_unite_rows(slots, sp_a, na, sp_b, nb);
        cc_span_t *t = sp_up; // the pair's second row is the next pair's row above
        sp_up = sp_b;
        sp_b = t;
        n_up = nb;
    }
    seg[pairs] = n;

    // Labels: parent[i] <= i, so parent[p] already holds p's label.
    uint32_t n_labels = 0u;
    for (uint32_t i = 0u; i < n; i++) {
        uint32_t p = slots[i].run.parent;
        slots[i].run.parent = (p == i) ? n_labels++ : slots[p].run.parent;
    }

    // Pass 2: statistics of labels < cap; then image coordinates and centroids.
    cc_accumulate(slots, seg, pairs, out, cap);
    const size_t n_out = (size_t)n_labels < cap ? (size_t)n_labels : cap;
    cc_finish(src, slots, out, n_out);
    *count = n_out;
    if (stats != NULL) {
        stats->runs = n;
        stats->pixels = pixels;
        stats->rows = rows;
        stats->labels = n_labels;
    }
    return ((size_t)n_labels > cap || rows < h) ? VD_ERR_CAPACITY : VD_OK;
}

// Streaming labeller (components_internal.h). Nodes are the runs of the
// current pair (m .. n, merged by x0 as above) after the open components of
// the pairs before (0 .. m, renumbered after every pair in index order). A
// node's key ((y / 2) << 15 | x0 of its first run) never decreases with its
// index, so cc_unite_rows' smallest-index root is the component's first run
// in the whole-frame run order and its key orders the components as the
// labels of cc_label. A component no run of the pair's second row reaches
// is complete: it goes to out[], kept sorted by key and truncated to cap.
typedef struct cc_rec {
    uint64_t sx, sy; // sums of x and y: < area * 2^15 < 2^45
    uint32_t area;
    uint32_t key;    // (row pair << 15) | x0 of the first run
    uint16_t x0, x1, y0, y1;
} cc_rec_t;

// Slices: three run rows of ceil(w/2) runs (the most one row has), then per
// node (<= 3 ceil(w/2): the open components, each owning a run of the row
// above, plus the pair's runs) a slot and a record.
static size_t cc_stream_slices(uint32_t w, size_t *spans, size_t *nodes)
{
    const size_t hw = ((size_t)w + 1u) / 2u;
    size_t t = 0u;
    *spans = hw * sizeof(cc_span_t);
    *nodes = 3u * hw;
    // VD_MAX_DIM < 2^15 keeps every term far below size_t's range.
    for (int i = 0; i < 3; i++) {
        (void)vd_size_add_slice(&t, *spans);
    }
    (void)vd_size_add_slice(&t, *nodes * sizeof(cc_slot_t));
    (void)vd_size_add_slice(&t, *nodes * sizeof(cc_rec_t));
    return t;
}

vd_status_t vd__components_stream_workspace_size(uint32_t max_width, size_t *bytes)
{
    VD_VERIFY(bytes != NULL && max_width >= 1u && max_width <= VD_MAX_DIM, VD_ERR_ARG);
    size_t spans, nodes;
    *bytes = cc_stream_slices(max_width, &spans, &nodes);
    return VD_OK;
}

vd_status_t vd__components_stream_init(vd__components_stream_t *s, uint32_t width, void *ws, size_t bytes, vd_component_t *out,
                              size_t cap)
{
    VD_VERIFY(s != NULL && width >= 1u && width <= VD_MAX_DIM && (out != NULL || cap == 0u), VD_ERR_ARG);
    size_t spans, nodes;
    VD_VERIFY(bytes >= cc_stream_slices(width, &spans, &nodes), VD_ERR_WORKSPACE);
    vd_arena_t a;
    VD_TRY(vd_arena_init(&a, ws, bytes));
    s->up = (cc_span_t *)vd_arena_take(&a, spans);
    s->a = (cc_span_t *)vd_arena_take(&a, spans);
    s->b = (cc_span_t *)vd_arena_take(&a, spans);
    s->node = (cc_slot_t *)vd_arena_take(&a, nodes * sizeof(cc_slot_t));
    s->rec = (cc_rec_t *)vd_arena_take(&a, nodes * sizeof(cc_rec_t));
    VD_ASSERT(s->rec != NULL);
    s->w = width;
    s->out = out;
    s->cap = cap;
    vd__components_stream_restart(s);
    return VD_OK;
}

void vd__components_stream_restart(vd__components_stream_t *s)
{
    s->nup = 0u;
    s->m = 0u;
    s->labels = 0u;
    s->n = 0u;
}

// Order of a waiting out[] entry: its key, kept in box.w's upper bits until
// the end (box.w < 2^15, x0 < 2^15) with the row pair box.y / 2.
static inline uint32_t cc_key_of(const vd_component_t *c)
{
    return (((uint32_t)c->box.y >> 1) << 15) | ((uint32_t)c->box.w >> 16);
}

// A complete component: counted, and inserted into out[] by key when among
// the cap smallest keys so far (then out[] drops its last entry if full).
static void cc_emit(vd__components_stream_t *s, const cc_rec_t *q)
{
    s->labels++;
    if (s->cap == 0u) {
        return;
    }
    vd_component_t *out = s->out;
    size_t n = s->n;
    if (n == s->cap) {
        if (q->key > cc_key_of(&out[n - 1u])) {
            return;
        }
        n--; // the last entry leaves for this one
    }
    size_t j = n;
    while (j > 0u && cc_key_of(&out[j - 1u]) > q->key) { // usually 0 or 1 step: keys close in order
        out[j] = out[j - 1u];
        j--;
    }
    vd_component_t *c = &out[j];
    c->box.x = (int32_t)q->x0;
    c->box.y = (int32_t)q->y0;
    c->box.w = (int32_t)(((uint32_t)q->x1 - q->x0 + 1u) | ((q->key & 0x7FFFu) << 16));
    c->box.h = (int32_t)((uint32_t)q->y1 - q->y0 + 1u);
    c->area = q->area;
    // Round-half-up in Q8 as cc_finish.
    const uint64_t a2 = 2u * (uint64_t)q->area;
    c->cx_q8 = (uint32_t)((512u * q->sx + q->area) / a2);
    c->cy_q8 = (uint32_t)((512u * q->sy + q->area) / a2);
    s->n = n + 1u;
}

// Node i's statistics into its root's (root < i: already made); its open
// mark (slot's x1, free once the record is made) cleared.
static inline void cc_fold(vd__components_stream_t *s, uint32_t i)
{
    cc_slot_t *nd = s->node;
    nd[i].run.x1 = 0u;
    if (nd[i].run.parent != i) {
        cc_rec_t *d = &s->rec[cc_find(nd, i)];
        const cc_rec_t *q = &s->rec[i];
        d->sx += q->sx;
        d->sy += q->sy;
        d->area += q->area;
        d->x0 = q->x0 < d->x0 ? q->x0 : d->x0;
        d->x1 = q->x1 > d->x1 ? q->x1 : d->x1;
        d->y0 = q->y0 < d->y0 ? q->y0 : d->y0;
        d->y1 = q->y1 > d->y1 ? q->y1 : d->y1;
    }
}

void vd__components_stream_pair(vd__components_stream_t *s, const uint8_t *ra, const uint8_t *rb, uint32_t y, uint8_t thr)
{
    cc_slot_t *nd = s->node;
    const size_t na = cc_runs_thr_u8(ra, s->w, thr, s->a);
    const size_t nb = (rb != NULL) ? cc_runs_thr_u8(rb, s->w, thr, s->b) : 0u;
    uint32_t px = 0u;
    const uint32_t m0 = s->m;
    const uint32_t n = cc_merge_pair(nd, m0, s->a, na, s->b, nb, &px);
    cc_unite_rows(nd, s->up, s->nup, s->a, na);
    cc_unite_rows(nd, s->a, na, s->b, nb);
    // Statistics to the roots; roots of the second row's runs stay open.
    for (uint32_t i = 0u; i < m0; i++) {
        cc_fold(s, i);
    }
    const uint32_t pair_key = (y >> 1) << 15;
    for (uint32_t i = m0; i < n; i++) {
        const uint32_t x0 = nd[i].run.x0f & CC_X_MASK;
        const uint32_t x1 = nd[i].run.x1;
        const uint32_t row = y + ((nd[i].run.x0f & CC_ODD_ROW) != 0u ? 1u : 0u);
        const uint32_t len = x1 - x0 + 1u;
        cc_rec_t *q = &s->rec[i];
        q->sx = ((uint64_t)(x0 + x1) * len) >> 1; // x0 + ... + x1: the product is even
        q->sy = (uint64_t)row * len;
        q->area = len;
        q->key = pair_key | x0;
        q->x0 = (uint16_t)x0;
        q->x1 = (uint16_t)x1;
        q->y0 = (uint16_t)row;
        q->y1 = (uint16_t)row;
        cc_fold(s, i);
    }
    for (size_t j = 0u; j < nb; j++) {
        const uint32_t r = cc_find(nd, s->b[j].idx);
        s->b[j].idx = r;
        nd[r].run.x1 = 1u;
    }
    // Open roots renumbered 0.. in place (the new number never exceeds the
    // old, so no unread record is overwritten); complete ones emitted. The
    // mark of an open root becomes 1 + its new number (< 3 * 2^14).
    uint32_t m = 0u;
    for (uint32_t i = 0u; i < n; i++) {
        if (nd[i].run.parent != i) {
            continue;
        }
        if (nd[i].run.x1 == 0u) {
            cc_emit(s, &s->rec[i]);
            continue;
        }
        nd[i].run.x1 = (uint16_t)(m + 1u);
        if (m != i) {
            s->rec[m] = s->rec[i];
        }
        nd[m].run.parent = m;
        m++;
    }
    for (size_t j = 0u; j < nb; j++) {
        s->b[j].idx = nd[s->b[j].idx].run.x1 - 1u;
    }
    s->m = m;
    cc_span_t *t = s->up; // the second row is the next pair's row above
    s->up = s->b;
    s->b = t;
    s->nup = nb;
}

size_t vd__components_stream_finish(vd__components_stream_t *s)
{
    for (uint32_t i = 0u; i < s->m; i++) { // the components open at the last row are complete
        cc_emit(s, &s->rec[i]);
    }
    s->m = 0u;
    for (size_t i = 0u; i < s->n; i++) {
        s->out[i].box.w = (int32_t)((uint32_t)s->out[i].box.w & 0xFFFFu); // the key bits go
    }
    return s->n;
}

// Common argument checks; fills the source geometry and the layout.
static vd_status_t cc_prepare(uint32_t img_w, uint32_t img_h, const vd_rect_t *roi, void *ws, size_t bytes,
                              size_t min_runs_worst, const vd_component_t *out, size_t cap, cc_src_t *src,
                              cc_layout_t *lay)
{
    VD_VERIFY(out != NULL || cap == 0u, VD_ERR_ARG);
    vd_rect_t r;
    VD_TRY(vd_rect_roi_resolve(roi, img_w, img_h, &r));
    src->w = (uint32_t)r.w;
    src->h = (uint32_t)r.h;
    src->x = r.x;
    src->y = r.y;
    VD_TRY(cc_layout(src->w, src->h, lay));
    size_t need;
    VD_TRY(cc_bytes(lay, min_runs_worst != 0u ? lay->worst_runs : 1u, &need));
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % (uintptr_t)VD_WORKSPACE_ALIGN) == 0u && bytes >= need,
              VD_ERR_WORKSPACE);
    return VD_OK;
}

vd_status_t vd_components_label(const vd_view_u8_t *mask, const vd_rect_t *roi, void *ws, size_t bytes,
                                vd_component_t *out, size_t cap, size_t *count)
{
    VD_VERIFY(count != NULL, VD_ERR_ARG);
    *count = 0u;
    VD_VERIFY(mask != NULL && vd_view_u8_check(mask) == VD_OK, VD_ERR_ARG);
    cc_src_t src;
    cc_layout_t lay;
    VD_TRY(cc_prepare(mask->width, mask->height, roi, ws, bytes, 1u, out, cap, &src, &lay));
    src.row0 = mask->data + (size_t)src.y * mask->stride + (size_t)src.x;
    src.stride = mask->stride;
    src.kind = CC_SRC_MASK;
    src.thr = 1u;
    return cc_label(&src, &lay, ws, bytes, out, cap, count, NULL);
}

vd_status_t vd_components_label_thr_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint8_t thr, void *ws,
                                       size_t bytes, vd_component_t *out, size_t cap, size_t *count,
                                       vd_components_stats_t *stats)
{
    VD_VERIFY(count != NULL, VD_ERR_ARG);
    *count = 0u;
    VD_VERIFY(src != NULL && vd_view_u8_check(src) == VD_OK, VD_ERR_ARG);
    cc_src_t s;
    cc_layout_t lay;
    VD_TRY(cc_prepare(src->width, src->height, roi, ws, bytes, 0u, out, cap, &s, &lay));
    s.row0 = src->data + (size_t)s.y * src->stride + (size_t)s.x;
    s.stride = src->stride;
    s.kind = CC_SRC_THR_U8;
    s.thr = thr;
    return cc_label(&s, &lay, ws, bytes, out, cap, count, stats);
}

vd_status_t vd_components_label_thr_u16(const vd_view_u16_t *src, const vd_rect_t *roi, uint16_t thr, void *ws,
                                        size_t bytes, vd_component_t *out, size_t cap, size_t *count,
                                        vd_components_stats_t *stats)
{
    VD_VERIFY(count != NULL, VD_ERR_ARG);
    *count = 0u;
    VD_VERIFY(src != NULL && vd_view_u16_check(src) == VD_OK, VD_ERR_ARG);
    cc_src_t s;
    cc_layout_t lay;
    VD_TRY(cc_prepare(src->width, src->height, roi, ws, bytes, 0u, out, cap, &s, &lay));
    s.row0 = (const uint8_t *)src->data + (size_t)s.y * src->stride + 2u * (size_t)s.x;
    s.stride = src->stride;
    s.kind = CC_SRC_THR_U16;
    s.thr = thr;
    return cc_label(&s, &lay, ws, bytes, out, cap, count, stats);
}
