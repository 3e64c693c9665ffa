// SPDX-License-Identifier: MIT
// Local-contrast map and contrast candidates (warm or cold regions that differ from their surroundings).
//
// Algorithm: box mean over a (2r+1)^2 window clipped to the frame, computed
// with running sums: per column, the sum of the rows [y-r, y+r] (updated by
// one added and one removed row per output row), then per row a running sum
// of 2r+1 column sums. Contrast = |I - mean| (or one signed half), threshold
// (fixed, or a percentile of the map's histogram with a floor), then
// 8-connected components and vd_components_filter (components.h), the same
// labelling and shape rules as the hot-spot candidates of paper 001.
// Candidates are made in strips of one row pair (issue 11: no frame-sized
// buffer): the running sums read the frame itself, so a strip needs only its
// two map rows; components.c's streaming row-pair labeller
// (components_internal.h) gives the components and order of
// vd_components_label on the whole thresholded map.
// Not in the papers: the issue-7 answer to cold parked vehicles, which a
// hot-spot threshold cannot see.
//
// Bounds: time O(W*H) (independent of r) for the map, O(W*H) for threshold and
// labelling; sums < (2*127+1)^2 * 255 < 2^25 fit uint32. The rounded mean
// is a reciprocal multiply (exact: internal/recip_internal.h), the
// reciprocals made once per box height (which changes only in the first and
// last r rows): the interior's and those of the border widths r+1 .. r+32;
// wider borders (r > 32) and frames narrower than 2r+2 divide; interior
// boxes of <= 4096 pixels use the reciprocal's high word (k = 32). The
// interior works in chunks of 128 (SIMD hosts) or 64 pixels (box
// differences, box sums by a recurrence of distance 4, means, contrasts in
// straight loops that vectorise). Labelling: O(runs) union-find work per row pair
// plus, per complete component, an insertion into out[] sorted by key
// (O(1) when components complete in order, O(cap) at worst). Stack < 1.2 KiB
// on scalar targets (chunk buffers 576, map state with its reciprocal table
// ~200; docs/embedded.md), ~1.8 KiB on SIMD hosts (128-pixel chunks).
// Workspace as vd_contrast_workspace_size (width only); capacity `cap`
// components.
#include "vd/contrast.h"
#include "vd/threshold.h"

#include <string.h>

#include "internal/recip_internal.h"
#include "internal/vd_internal.h"
#include "regions/components_internal.h"

#if VD_MAX_DIM > 32767u
#error "contrast.c keeps x, y in uint16 and x0 in a 15-bit key field: VD_MAX_DIM must be below 32768"
#endif

#define DEF_RADIUS 16u
#define DEF_THR 24u
#define DEF_PERMILLE 950u

vd_status_t vd_contrast_map_workspace_size(uint32_t max_width, size_t *bytes)
{
    VD_VERIFY(bytes != NULL, VD_ERR_ARG);
    *bytes = 0u;
    VD_VERIFY(max_width >= 1u && max_width <= VD_MAX_DIM, VD_ERR_ARG);
    *bytes = (size_t)max_width * sizeof(uint32_t);
    return VD_OK;
}

// Interior pixels per chunk (stack: CHUNK differences + CHUNK box sums +
// CHUNK means: 9 bytes each). SIMD hosts take 128 (the vector loops then
// run long enough: 170 against 190 us per 640x480 frame for 64, gcc 12
// -O3; 256 and 512 are no faster), scalar targets 64 (Cortex-M stack
// budget).
#if defined(__SSE2__) || defined(__ARM_NEON) || defined(__ARM_NEON__) || defined(__ALTIVEC__)
#define CHUNK 128u
#else
#define CHUNK 64u
#endif
// Border box widths nx = r+1 .. r+BORDER_TAB whose reciprocals are tabled per
// box height (5 bytes each on the stack); wider borders divide.
#define BORDER_TAB 32u
#define VD_MAX_U8(a, b) ((a) > (b) ? (a) : (b))
#define VD_MIN_U8(a, b) ((a) < (b) ? (a) : (b))

// Contrast of pixel value v against mean m (both < 256) for the polarity.
static inline uint8_t contrast_of(uint32_t v, uint32_t m, uint8_t polarity)
{
    if (polarity == VD_CONTRAST_BOTH) {
        return (uint8_t)(v > m ? v - m : m - v);
    }
    if (polarity == VD_CONTRAST_WARM) {
        return (uint8_t)(v > m ? v - m : 0u);
    }
    return (uint8_t)(m > v ? m - v : 0u);
}

// d[j] = contrast of s[j] against the rounded mean box[j] / n (box[j] holds
// sum + n/2), for j < nc; (m, k) the reciprocal of n. Straight loops the
// compiler vectorises: the means as bytes (< 256), then the byte differences.
static void contrast_chunk(const uint32_t *restrict box, const uint8_t *restrict s, uint8_t *restrict d, uint32_t nc,
                           uint32_t m, uint32_t k, uint8_t polarity)
{
    uint8_t mean[CHUNK];
    if (k == 32u) {   // the high word of the product: no shift of the 64-bit lanes
        for (uint32_t j = 0; j < nc; j++) {
            mean[j] = (uint8_t)(((uint64_t)box[j] * m) >> 32);
        }
    } else {
        for (uint32_t j = 0; j < nc; j++) {
            mean[j] = (uint8_t)vd_recip256_div32(m, k, box[j]);
        }
    }
    if (polarity == VD_CONTRAST_BOTH) {
        for (uint32_t j = 0; j < nc; j++) {
            d[j] = (uint8_t)(VD_MAX_U8(s[j], mean[j]) - VD_MIN_U8(s[j], mean[j]));
        }
    } else if (polarity == VD_CONTRAST_WARM) {
        for (uint32_t j = 0; j < nc; j++) {
            d[j] = (uint8_t)(s[j] > mean[j] ? s[j] - mean[j] : 0);
        }
    } else {
        for (uint32_t j = 0; j < nc; j++) {
            d[j] = (uint8_t)(mean[j] > s[j] ? mean[j] - s[j] : 0);
        }
    }
}

// Reciprocals of the box areas of one box height ny: interior (nx = 2r+1)
// and the border widths r+1 .. r+BORDER_TAB.
typedef struct area_recips {
    vd_recip256_t in;
    uint32_t bm[BORDER_TAB];
    uint8_t bk[BORDER_TAB];
    uint32_t nb;   // tabled border widths
} area_recips_t;

static void area_recips_init(area_recips_t *t, uint32_t r, uint32_t ny)
{
    // Areas <= 255^2 < 2^23: init never fails.
    const uint32_t n_in = (2u * r + 1u) * ny;
    (void)vd_recip256_init(n_in, &t->in);
    if (n_in <= 4096u) {
        // k = 32 is exact too: m = ceil(2^32 / n), e = m*n - 2^32 < n and
        // x*e < 256n * n <= 2^32 for every x < 256n (recip_internal.h's
        // argument with 2^k = 2^32); n >= 3 keeps m below 2^32.
        t->in.k = 32u;
        t->in.m = (uint32_t)((0x100000000ull + n_in - 1u) / n_in);
    }
    t->nb = r < BORDER_TAB ? r : BORDER_TAB;
    for (uint32_t i = 0; i < t->nb; i++) {
        vd_recip256_t q;
        (void)vd_recip256_init((r + 1u + i) * ny, &q);
        t->bm[i] = q.m;
        t->bk[i] = (uint8_t)q.k;
    }
}

// Rounded mean of the box at column x (clipped to [0, w)) of height ny.
static inline uint32_t border_mean(const area_recips_t *t, uint32_t sum, uint32_t x, uint32_t r, uint32_t w,
                                   uint32_t ny)
{
    const uint32_t x0 = (x > r) ? x - r : 0u;
    const uint32_t x1 = (x + r < w - 1u) ? x + r : w - 1u;
    const uint32_t nx = x1 - x0 + 1u;
    const uint32_t n = nx * ny;
    const uint32_t num = sum + n / 2u;
    if (nx == 2u * r + 1u) {
        return vd_recip256_div32(t->in.m, t->in.k, num);
    }
    if (nx > r && nx - r - 1u < t->nb) {
        return vd_recip256_div32(t->bm[nx - r - 1u], t->bk[nx - r - 1u], num);
    }
    return num / n;   // narrow frames (w <= 2r) or r > BORDER_TAB
}

// Running-sum state of the map: column sums of the rows [y - r, y + r]
// (clipped) for the next output row y. Each call of cmap_row writes row y and
// slides the sums one row down, reading the frame only (rows y + r + 1 and
// y - r), so a strip of any height needs no frame-sized buffer.
typedef struct cmap {
    const vd_view_u8_t *src;
    uint16_t *col;    // w column sums of at most 2r+1 <= 255 rows: < 2^16
    uint32_t r, y;
    uint32_t xa, xb;  // interior columns [xa, xb): full 2r+1 box and both slides
    uint32_t rt_ny;   // box height rt is made for
    uint8_t polarity;
    area_recips_t rt;
} cmap_t;

static void cmap_init(cmap_t *m, const vd_view_u8_t *src, uint32_t r, uint8_t polarity, uint16_t *col)
{
    const uint32_t w = src->width;
    const uint32_t h = src->height;
    m->src = src;
    m->col = col;
    m->r = r;
    m->y = 0u;
    m->polarity = polarity;
    memset(col, 0, (size_t)w * sizeof(uint16_t));
    // Rows [0, min(r, h-1)] in the column sums for y = 0.
    const uint32_t first_hi = (r < h - 1u) ? r : h - 1u;
    for (uint32_t yy = 0; yy <= first_hi; yy++) {
        const uint8_t *row = src->data + (size_t)yy * src->stride;
        for (uint32_t x = 0; x < w; x++) {
            col[x] = (uint16_t)(col[x] + row[x]);
        }
    }
    m->xa = r < w ? r : w;
    m->xb = w > 2u * r + 1u ? w - r - 1u : m->xa;
    m->rt_ny = first_hi + 1u;   // row 0's box height
    area_recips_init(&m->rt, r, m->rt_ny);
}

// box[j] = acc + dif[0] + .. + dif[j-1] for j < nc (the running box sums of
// one chunk, modulo 2^32). Two forms of the same sums, chosen by what each
// compiler makes fast (both exact): gcc vectorises the recurrence of
// distance 4 (the box four to the left plus a window of four differences:
// 194 against 219 us per 640x480 frame for the form below, gcc 12 -O3,
// 64-pixel chunks); clang 14 does not vectorise it and then runs it as a
// store-to-load chain (366 us), while its scalar four-at-a-time running sum
// takes 209 us.
static inline void box_sums(const uint32_t *dif, uint32_t nc, uint32_t acc, uint32_t *box)
{
#if defined(__clang__)
    uint32_t j = 0;
    for (; j + 4u <= nc; j += 4u) {
        const uint32_t p1 = dif[j], p2 = p1 + dif[j + 1u], p3 = p2 + dif[j + 2u], p4 = p3 + dif[j + 3u];
        box[j] = acc;
        box[j + 1u] = acc + p1;
        box[j + 2u] = acc + p2;
        box[j + 3u] = acc + p3;
        acc += p4;
    }
    for (; j < nc; j++) {
        box[j] = acc;
        acc += dif[j];
    }
#else
    const uint32_t n4 = nc < 4u ? nc : 4u;
    for (uint32_t j = 0; j < n4; j++) {
        box[j] = acc;
        acc += dif[j];
    }
    for (uint32_t j = 4u; j < nc; j++) {
        box[j] = box[j - 4u] + ((dif[j - 4u] + dif[j - 3u]) + (dif[j - 2u] + dif[j - 1u]));
    }
#endif
}

// Slides the column sums of map row m->y down (row y + r + 1 enters, row
// y - r leaves) and moves to the next row.
static void cmap_slide(cmap_t *m)
{
    const vd_view_u8_t *src = m->src;
    const uint32_t w = src->width;
    const uint32_t h = src->height;
    const uint32_t r = m->r;
    const uint32_t y = m->y;
    uint16_t *col = m->col;
    const bool enter = y + r + 1u < h;
    const bool leave = y >= r;
    const uint8_t *add = enter ? src->data + (size_t)(y + r + 1u) * src->stride : src->data;
    const uint8_t *sub = leave ? src->data + (size_t)(y - r) * src->stride : src->data;
    if (enter && leave) {
        for (uint32_t i = 0; i < w; i++) {
            col[i] = (uint16_t)(col[i] + add[i] - sub[i]);
        }
    } else if (enter) {
        for (uint32_t i = 0; i < w; i++) {
            col[i] = (uint16_t)(col[i] + add[i]);
        }
    } else if (leave) {
        for (uint32_t i = 0; i < w; i++) {
            col[i] = (uint16_t)(col[i] - sub[i]);
        }
    }
    m->y = y + 1u;
}

// Writes map row m->y to drow (w bytes) and moves to the next row; called
// once per row, m->y < height.
static void cmap_row(cmap_t *m, uint8_t *restrict drow)
{
    const vd_view_u8_t *src = m->src;
    const uint32_t w = src->width;
    const uint32_t h = src->height;
    const uint32_t r = m->r;
    const uint32_t y = m->y;
    const uint32_t xa = m->xa;
    const uint32_t xb = m->xb;
    const uint8_t polarity = m->polarity;
    uint16_t *col = m->col;
    const area_recips_t *rt = &m->rt;
    const uint32_t y0 = (y > r) ? y - r : 0u;
    const uint32_t y1 = (y + r < h - 1u) ? y + r : h - 1u;
    const uint32_t ny = y1 - y0 + 1u;
    if (ny != m->rt_ny) {   // changes only in the first and last r rows
        area_recips_init(&m->rt, r, ny);
        m->rt_ny = ny;
    }
    const uint8_t *srow = src->data + (size_t)y * src->stride;
    // Running sum over columns [x - r, x + r] clipped.
    uint32_t sum = 0u;
    const uint32_t xr = (r < w - 1u) ? r : w - 1u;
    for (uint32_t x = 0; x <= xr; x++) {
        sum += col[x];
    }
    uint32_t x = 0u;
    // Border columns with every box width tabled (frames wider than 2r+1,
    // r <= BORDER_TAB): column x < r has width r+1+x, column w-1-i width
    // r+1+i; straight loops without border_mean's clipping and branches.
    const bool fast_border = xb > xa && r <= BORDER_TAB;
    if (fast_border) {
        for (; x < xa; x++) {   // x < r: column x + r + 1 < w enters, none leaves
            const uint32_t num = sum + (((r + 1u + x) * ny) >> 1);
            drow[x] = contrast_of(srow[x], vd_recip256_div32(rt->bm[x], rt->bk[x], num), polarity);
            sum += col[x + r + 1u];
        }
    }
    for (; x < xa; x++) {
        drow[x] = contrast_of(srow[x], border_mean(rt, sum, x, r, w, ny), polarity);
        if (x + r + 1u < w) {   // slide: column x + r + 1 enters (x < r: none leaves)
            sum += col[x + r + 1u];
        }
    }
    const uint32_t half = (2u * r + 1u) * ny / 2u;
    while (x < xb) {
        // Chunk: the column differences (vectorised), their running sums
        // (below), then the means and contrasts (vectorised).
        const uint32_t nc = xb - x < CHUNK ? xb - x : CHUNK;
        uint32_t dif[CHUNK];
        uint32_t box[CHUNK];
        const uint16_t *in = col + x + r + 1u;
        const uint16_t *out = col + (x - r);
        for (uint32_t j = 0; j < nc; j++) {
            dif[j] = (uint32_t)in[j] - out[j];   // wraps when negative; the sums are exact mod 2^32
        }
        box_sums(dif, nc, sum + half, box);
        sum = box[nc - 1u] + dif[nc - 1u] - half;
        contrast_chunk(box, srow + x, drow + x, nc, rt->in.m, rt->in.k, polarity);
        x += nc;
    }
    if (fast_border) {
        // x = xb = w - r - 1 still has the full width (nothing enters after it).
        drow[x] = contrast_of(srow[x], vd_recip256_div32(rt->in.m, rt->in.k, sum + half), polarity);
        sum -= col[x - r];
        x++;
        for (; x < w; x++) {   // x > xb > r: none enters, column x - r leaves
            const uint32_t i = w - 1u - x;
            const uint32_t num = sum + (((r + 1u + i) * ny) >> 1);
            drow[x] = contrast_of(srow[x], vd_recip256_div32(rt->bm[i], rt->bk[i], num), polarity);
            sum -= col[x - r];
        }
    }
    for (; x < w; x++) {
        drow[x] = contrast_of(srow[x], border_mean(rt, sum, x, r, w, ny), polarity);
        if (x + r + 1u < w) {
            sum += col[x + r + 1u];
        }
        if (x >= r) {
            sum -= col[x - r];
        }
    }
    cmap_slide(m);
}

vd_status_t vd_contrast_map_u8(const vd_view_u8_t *src, uint32_t radius, uint8_t polarity, void *ws, size_t bytes,
                               vd_image_u8_t *dst)
{
    VD_VERIFY(src != NULL && dst != NULL, VD_ERR_ARG);
    VD_TRY(vd_view_u8_check(src));
    VD_TRY(vd_image_u8_check(dst));
    VD_VERIFY(dst->width == src->width && dst->height == src->height, VD_ERR_ARG);
    VD_VERIFY(radius >= 1u && radius <= VD_CONTRAST_MAX_RADIUS, VD_ERR_ARG);
    VD_VERIFY(polarity <= VD_CONTRAST_COLD, VD_ERR_ARG);
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % VD_WORKSPACE_ALIGN) == 0u, VD_ERR_WORKSPACE);
    VD_VERIFY(bytes >= (size_t)src->width * sizeof(uint32_t), VD_ERR_WORKSPACE);
    // dst must not alias src (the running sums read rows below the one written).
    const uint8_t *s_lo = src->data;
    const uint8_t *s_hi = src->data + (size_t)(src->height - 1u) * src->stride + src->width;
    const uint8_t *d_lo = dst->data;
    const uint8_t *d_hi = dst->data + (size_t)(dst->height - 1u) * dst->stride + dst->width;
    VD_VERIFY(d_hi <= s_lo || s_hi <= d_lo, VD_ERR_ARG);
    // The workspace keeps its 4 bytes per column; the sums use half.
    cmap_t m;
    cmap_init(&m, src, radius, polarity, (uint16_t *)ws);
    for (uint32_t y = 0; y < src->height; y++) {
        cmap_row(&m, dst->data + (size_t)y * dst->stride);
    }
    return VD_OK;
}

// Slices of the candidate workspace for frames w wide: column sums, two map
// rows (the strip), the streaming labeller's (components_internal.h), and the
// histogram of the percentile threshold last.
typedef struct cand_layout {
    size_t col, rows, label, hist, total;
} cand_layout_t;

static vd_status_t cand_layout(uint32_t w, uint32_t h, cand_layout_t *l)
{
    VD_VERIFY(w >= 1u && w <= VD_MAX_DIM && h >= 1u && h <= VD_MAX_DIM, VD_ERR_ARG);
    l->col = (size_t)w * sizeof(uint16_t);
    l->rows = 2u * (size_t)w;
    VD_TRY(vd__components_stream_workspace_size(w, &l->label));
    l->hist = 256u * sizeof(uint32_t);
    size_t t = 0u;
    // VD_MAX_DIM < 2^15 keeps every term far below size_t's range.
    (void)vd_size_add_slice(&t, l->col);
    (void)vd_size_add_slice(&t, l->rows);
    (void)vd_size_add_slice(&t, l->label);
    (void)vd_size_add_slice(&t, l->hist);
    l->total = t;
    return VD_OK;
}

vd_status_t vd_contrast_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes)
{
    VD_VERIFY(bytes != NULL, VD_ERR_ARG);
    *bytes = 0u;
    cand_layout_t l;
    VD_TRY(cand_layout(max_width, max_height, &l));
    *bytes = l.total;
    return VD_OK;
}

vd_status_t vd_contrast_cfg_resolve(vd_contrast_cfg_t *c)
{
    VD_VERIFY(c != NULL, VD_ERR_ARG);
    if (c->radius == 0u) { c->radius = (uint16_t)DEF_RADIUS; }
    if (c->thr_u8 == 0u) { c->thr_u8 = (uint8_t)DEF_THR; }
    if (c->permille == 0u) { c->permille = (uint16_t)DEF_PERMILLE; }
    VD_VERIFY(c->radius <= VD_CONTRAST_MAX_RADIUS, VD_ERR_ARG);
    VD_VERIFY(c->polarity <= VD_CONTRAST_COLD && c->thr_mode <= VD_CONTRAST_THR_PERCENTILE, VD_ERR_ARG);
    VD_VERIFY(c->permille <= 1000u, VD_ERR_ARG);
    return vd_components_rules_resolve(&c->rules);
}

vd_status_t vd_contrast_candidates(const vd_view_u8_t *src, const vd_contrast_cfg_t *cfg, void *ws, size_t bytes,
                                   vd_component_t *out, size_t cap, size_t *count, uint8_t *thr_used)
{
    VD_VERIFY(count != NULL, VD_ERR_ARG);
    *count = 0u;
    VD_VERIFY(src != NULL, VD_ERR_ARG);
    VD_VERIFY(out != NULL || cap == 0u, VD_ERR_ARG);
    VD_TRY(vd_view_u8_check(src));
    vd_contrast_cfg_t c;
    if (cfg == NULL) {
        memset(&c, 0, sizeof(c));
    } else {
        c = *cfg;
    }
    VD_TRY(vd_contrast_cfg_resolve(&c));
    const uint32_t w = src->width;
    const uint32_t h = src->height;
    cand_layout_t lay;
    VD_TRY(cand_layout(w, h, &lay));
    vd_arena_t a;
    VD_TRY(vd_arena_init(&a, ws, bytes));
    VD_VERIFY(bytes >= lay.total, VD_ERR_WORKSPACE);
    uint16_t *col = (uint16_t *)vd_arena_take(&a, lay.col);
    uint8_t *ra = (uint8_t *)vd_arena_take(&a, lay.rows);
    uint8_t *rb = ra + w;
    void *lws = vd_arena_take(&a, lay.label);
    uint32_t *hist = (uint32_t *)vd_arena_take(&a, lay.hist);
    VD_ASSERT(lws != NULL && hist != NULL);
    vd__components_stream_t L;
    VD_TRY(vd__components_stream_init(&L, w, lws, lay.label, out, cap));

    cmap_t m;
    uint32_t thr = c.thr_u8;
    bool labelled = false;
    if (c.thr_mode == VD_CONTRAST_THR_PERCENTILE) {
        // First pass over the map for its histogram, labelling at the floor
        // thr_u8 on the way: when the percentile does not exceed it (road
        // video, mostly), that is the result; else the map is made again
        // (the price of no frame-sized map).
        memset(hist, 0, lay.hist);
        cmap_init(&m, src, c.radius, c.polarity, col);
        for (uint32_t y = 0; y < h; y += 2u) {
            const bool two = y + 1u < h;
            cmap_row(&m, ra);
            for (uint32_t x = 0; x < w; x++) {
                hist[ra[x]]++;
            }
            if (two) {
                cmap_row(&m, rb);
                for (uint32_t x = 0; x < w; x++) {
                    hist[rb[x]]++;
                }
            }
            vd__components_stream_pair(&L, ra, two ? rb : NULL, y, (uint8_t)thr);
        }
        // max(thr_u8, p-th percentile of the map), as the detector's adaptive threshold.
        uint8_t t = 0u;
        VD_TRY(vd_threshold_percentile_u8(hist, c.permille, (uint8_t)thr, &t));
        labelled = (t == thr);
        if (!labelled) {
            vd__components_stream_restart(&L);   // start again: nothing open, nothing emitted
        }
        thr = t;
    }
    if (thr_used != NULL) {
        *thr_used = (uint8_t)thr;
    }
    // Strips of one row pair: its two map rows, then their runs labelled.
    if (!labelled) {
        cmap_init(&m, src, c.radius, c.polarity, col);
        for (uint32_t y = 0; y < h; y += 2u) {
            cmap_row(&m, ra);
            const bool two = y + 1u < h;
            if (two) {
                cmap_row(&m, rb);
            }
            vd__components_stream_pair(&L, ra, two ? rb : NULL, y, (uint8_t)thr);
        }
    }
    const size_t n = vd__components_stream_finish(&L);
    size_t kept = 0u;
    VD_TRY(vd_components_filter(out, n, &c.rules, &kept));
    *count = kept;
    // As vd_components_label: more components than cap is a capacity error.
    return ((size_t)L.labels > cap) ? VD_ERR_CAPACITY : VD_OK;
}
