// SPDX-License-Identifier: MIT
// Local-contrast map and contrast candidates (warm or cold regions that differ from their surroundings).
//
// Algorithm: box mean over a (2r+1)^2 window clipped to the frame, computed
// with running sums: per column, the sum of the rows [y-r, y+r] (updated by
// one added and one removed row per output row), then per row a running sum
// of 2r+1 column sums. Contrast = |I - mean| (or one signed half), threshold
// (fixed, or a percentile of the map's histogram with a floor), then
// vd_components_label and vd_components_filter (components.h), the same
// labelling and shape rules as the hot-spot candidates of paper 001.
// Not in the papers: the issue-7 answer to cold parked vehicles, which a
// hot-spot threshold cannot see.
//
// Bounds: time O(W*H) (independent of r) for the map, O(W*H) for threshold and
// labelling; sums < (2*127+1)^2 * 255 < 2^25 fit uint32. The rounded mean
// is a reciprocal multiply (exact: internal/recip_internal.h), the
// reciprocals made once per box height (which changes only in the first and
// last r rows): the interior's and those of the border widths r+1 .. r+32;
// wider borders (r > 32) and frames narrower than 2r+2 divide. The interior
// works in chunks of 64 pixels (box sums, means, contrasts in straight
// loops that vectorise). Stack < 700 bytes (chunk buffers 320, reciprocal
// table 168). Workspace as vd_contrast_workspace_size; capacity `cap`
// components.
#include "vd/contrast.h"
#include "vd/threshold.h"

#include <string.h>

#include "internal/recip_internal.h"
#include "internal/vd_internal.h"

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

// Interior pixels per chunk (stack: CHUNK box sums + CHUNK means).
#define CHUNK 64u
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
    for (uint32_t j = 0; j < nc; j++) {
        mean[j] = (uint8_t)vd_recip256_div32(m, k, box[j]);
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
    (void)vd_recip256_init((2u * r + 1u) * ny, &t->in);
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

    const uint32_t w = src->width;
    const uint32_t h = src->height;
    const uint32_t r = radius;
    // Column sums of at most 2r+1 <= 255 rows: <= 255 * 255 < 2^16 (the
    // workspace keeps its 4 bytes per column; half is used).
    uint16_t *col = (uint16_t *)ws;
    memset(col, 0, (size_t)w * sizeof(uint16_t));
    // Rows [0, min(r, h-1)] in the column sums for y = 0.
    const uint32_t first_hi = (r < h - 1u) ? r : h - 1u;
    for (uint32_t yy = 0; yy <= first_hi; yy++) {
        const uint8_t *row = src->data + (size_t)yy * src->stride;
        for (uint32_t x = 0; x < w; x++) {
            col[x] = (uint16_t)(col[x] + row[x]);
        }
    }
    // Interior columns [xa, xb): full 2r+1 box and both slides (x >= r and
    // x + r + 1 < w); the others are the border.
    const uint32_t xa = r < w ? r : w;
    const uint32_t xb = w > 2u * r + 1u ? w - r - 1u : xa;
    area_recips_t rt;
    uint32_t rt_ny = first_hi + 1u;   // box height rt is made for (row 0's)
    area_recips_init(&rt, r, rt_ny);
    for (uint32_t y = 0; y < h; y++) {
        const uint32_t y0 = (y > r) ? y - r : 0u;
        const uint32_t y1 = (y + r < h - 1u) ? y + r : h - 1u;
        const uint32_t ny = y1 - y0 + 1u;
        if (ny != rt_ny) {   // changes only in the first and last r rows
            area_recips_init(&rt, r, ny);
            rt_ny = ny;
        }
        const uint8_t *srow = src->data + (size_t)y * src->stride;
        uint8_t *drow = dst->data + (size_t)y * dst->stride;
        // Running sum over columns [x - r, x + r] clipped.
        uint32_t sum = 0u;
        const uint32_t xr = (r < w - 1u) ? r : w - 1u;
        for (uint32_t x = 0; x <= xr; x++) {
            sum += col[x];
        }
        uint32_t x = 0u;
        for (; x < xa; x++) {
            drow[x] = contrast_of(srow[x], border_mean(&rt, sum, x, r, w, ny), polarity);
            if (x + r + 1u < w) {   // slide: column x + r + 1 enters (x < r: none leaves)
                sum += col[x + r + 1u];
            }
        }
        const uint32_t half = (2u * r + 1u) * ny / 2u;
        while (x < xb) {
            // Chunk: the column differences (vectorised), their running sum
            // (the one sequential chain, one add per pixel), then the means
            // and contrasts (vectorised).
            const uint32_t nc = xb - x < CHUNK ? xb - x : CHUNK;
            uint32_t box[CHUNK];
            const uint16_t *in = col + x + r + 1u;
            const uint16_t *out = col + (x - r);
            for (uint32_t j = 0; j < nc; j++) {
                box[j] = (uint32_t)in[j] - out[j];   // wraps when negative; the sum is exact mod 2^32
            }
            // Four at a time: the partial sums do not wait for `acc`, so
            // the chain is one add per four pixels.
            uint32_t acc = sum + half;
            uint32_t j = 0;
            for (; j + 4u <= nc; j += 4u) {
                const uint32_t p1 = box[j], p2 = p1 + box[j + 1u], p3 = p2 + box[j + 2u], p4 = p3 + box[j + 3u];
                box[j] = acc;
                box[j + 1u] = acc + p1;
                box[j + 2u] = acc + p2;
                box[j + 3u] = acc + p3;
                acc += p4;
            }
            for (; j < nc; j++) {
                const uint32_t dj = box[j];
                box[j] = acc;
                acc += dj;
            }
            sum = acc - half;
            contrast_chunk(box, srow + x, drow + x, nc, rt.in.m, rt.in.k, polarity);
            x += nc;
        }
        for (; x < w; x++) {
            drow[x] = contrast_of(srow[x], border_mean(&rt, sum, x, r, w, ny), polarity);
            if (x + r + 1u < w) {
                sum += col[x + r + 1u];
            }
            if (x >= r) {
                sum -= col[x - r];
            }
        }
        // Slide the column sums down: row y + r + 1 enters, row y - r leaves.
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
    }
    return VD_OK;
}

// Byte sizes of the candidate workspace slices.
static vd_status_t cand_layout(uint32_t w, uint32_t h, size_t *map, size_t *col, size_t *cc, size_t *total)
{
    VD_VERIFY(w >= 1u && w <= VD_MAX_DIM && h >= 1u && h <= VD_MAX_DIM, VD_ERR_ARG);
    VD_VERIFY(vd_mul_size(w, h, map), VD_ERR_OVERFLOW);
    *col = (size_t)w * sizeof(uint32_t);
    VD_TRY(vd_components_workspace_size(w, h, cc));
    size_t t = 0u;
    VD_VERIFY(vd_size_add_slice(&t, *map) && vd_size_add_slice(&t, *col) &&
              vd_size_add_slice(&t, 256u * sizeof(uint32_t)) && vd_size_add_slice(&t, *cc), VD_ERR_OVERFLOW);
    *total = t;
    return VD_OK;
}

vd_status_t vd_contrast_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes)
{
    VD_VERIFY(bytes != NULL, VD_ERR_ARG);
    *bytes = 0u;
    size_t map, col, cc;
    return cand_layout(max_width, max_height, &map, &col, &cc, bytes);
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
    return vd_cc_rules_resolve(&c->rules);
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
    size_t map_b, col_b, cc_b, need;
    VD_TRY(cand_layout(src->width, src->height, &map_b, &col_b, &cc_b, &need));
    vd_arena_t a;
    VD_TRY(vd_arena_init(&a, ws, bytes));
    VD_VERIFY(bytes >= need, VD_ERR_WORKSPACE);
    uint8_t *map = (uint8_t *)vd_arena_take(&a, map_b);
    uint32_t *col = (uint32_t *)vd_arena_take(&a, col_b);
    uint32_t *hist = (uint32_t *)vd_arena_take(&a, 256u * sizeof(uint32_t));
    void *cc_ws = vd_arena_take(&a, cc_b);
    VD_ASSERT(cc_ws != NULL);

    vd_image_u8_t m = {map, src->width, src->height, src->width};
    VD_TRY(vd_contrast_map_u8(src, c.radius, c.polarity, col, col_b, &m));
    size_t npix = map_b;
    uint32_t thr = c.thr_u8;
    if (c.thr_mode == VD_CONTRAST_THR_PERCENTILE) {
        memset(hist, 0, 256u * sizeof(uint32_t));
        for (size_t i = 0; i < npix; i++) {
            hist[map[i]]++;
        }
        // max(thr_u8, p-th percentile of the map), as the detector's adaptive threshold.
        uint8_t t = 0u;
        VD_TRY(vd_threshold_percentile_u8(hist, c.permille, (uint8_t)thr, &t));
        thr = t;
    }
    for (size_t i = 0; i < npix; i++) {
        map[i] = (map[i] >= thr) ? 255u : 0u;
    }
    if (thr_used != NULL) {
        *thr_used = (uint8_t)thr;
    }
    vd_view_u8_t mv = vd_image_u8_view(&m);
    size_t n = 0u;
    vd_status_t st = vd_components_label(&mv, NULL, cc_ws, cc_b, out, cap, &n);
    if (st != VD_OK && st != VD_ERR_CAPACITY) {
        return st;
    }
    size_t kept = 0u;
    VD_TRY(vd_components_filter(out, n, &c.rules, &kept));
    *count = kept;
    return st;
}
