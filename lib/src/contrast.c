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
// labelling; sums < (2*127+1)^2 * 255 < 2^25 fit uint32; mean by one integer
// division per pixel. Stack O(1) (< 200 bytes). Workspace as
// vd_contrast_workspace_size; capacity `cap` components.
#include "vd/contrast.h"

#include <string.h>

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

    uint32_t w = src->width;
    uint32_t h = src->height;
    uint32_t *col = (uint32_t *)ws;
    memset(col, 0, (size_t)w * sizeof(uint32_t));
    // Rows [0, min(r, h-1)] in the column sums for y = 0.
    uint32_t r = radius;
    uint32_t first_hi = (r < h - 1u) ? r : h - 1u;
    for (uint32_t yy = 0; yy <= first_hi; yy++) {
        const uint8_t *row = src->data + (size_t)yy * src->stride;
        for (uint32_t x = 0; x < w; x++) {
            col[x] += row[x];
        }
    }
    for (uint32_t y = 0; y < h; y++) {
        uint32_t y0 = (y > r) ? y - r : 0u;
        uint32_t y1 = (y + r < h - 1u) ? y + r : h - 1u;
        uint32_t ny = y1 - y0 + 1u;
        const uint8_t *srow = src->data + (size_t)y * src->stride;
        uint8_t *drow = dst->data + (size_t)y * dst->stride;
        // Running sum over columns [x - r, x + r] clipped.
        uint32_t sum = 0u;
        uint32_t xr = (r < w - 1u) ? r : w - 1u;
        for (uint32_t x = 0; x <= xr; x++) {
            sum += col[x];
        }
        for (uint32_t x = 0; x < w; x++) {
            uint32_t x0 = (x > r) ? x - r : 0u;
            uint32_t x1 = (x + r < w - 1u) ? x + r : w - 1u;
            uint32_t n = (x1 - x0 + 1u) * ny;
            uint32_t mean = (sum + n / 2u) / n;
            int32_t d = (int32_t)srow[x] - (int32_t)mean;
            if (polarity == VD_CONTRAST_COLD) {
                d = -d;
            } else if (polarity == VD_CONTRAST_BOTH && d < 0) {
                d = -d;
            }
            drow[x] = (d > 0) ? (uint8_t)d : 0u;
            // Slide: column x + r + 1 enters, column x - r leaves.
            if (x + r + 1u < w) {
                sum += col[x + r + 1u];
            }
            if (x >= r) {
                sum -= col[x - r];
            }
        }
        // Slide the column sums down: row y + r + 1 enters, row y - r leaves.
        if (y + r + 1u < h) {
            const uint8_t *add = src->data + (size_t)(y + r + 1u) * src->stride;
            for (uint32_t x = 0; x < w; x++) {
                col[x] += add[x];
            }
        }
        if (y >= r) {
            const uint8_t *sub = src->data + (size_t)(y - r) * src->stride;
            for (uint32_t x = 0; x < w; x++) {
                col[x] -= sub[x];
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

// Fills zero fields with the defaults and checks the ranges.
static vd_status_t resolve(const vd_contrast_cfg_t *in, vd_contrast_cfg_t *c)
{
    if (in == NULL) {
        memset(c, 0, sizeof(*c));
    } else {
        *c = *in;
    }
    if (c->radius == 0u) { c->radius = (uint16_t)DEF_RADIUS; }
    if (c->thr_u8 == 0u) { c->thr_u8 = (uint8_t)DEF_THR; }
    if (c->permille == 0u) { c->permille = (uint16_t)DEF_PERMILLE; }
    if (c->rules.aspect_min_q8 == 0u && c->rules.aspect_max_q8 == 0u && c->rules.min_area == 0u &&
        c->rules.max_area == 0u) {
        vd_cc_rules_default(&c->rules);
    }
    VD_VERIFY(c->radius <= VD_CONTRAST_MAX_RADIUS, VD_ERR_ARG);
    VD_VERIFY(c->polarity <= VD_CONTRAST_COLD && c->thr_mode <= VD_CONTRAST_THR_PERCENTILE, VD_ERR_ARG);
    VD_VERIFY(c->permille <= 1000u, VD_ERR_ARG);
    VD_VERIFY(c->rules.aspect_min_q8 <= c->rules.aspect_max_q8, VD_ERR_ARG);
    VD_VERIFY(c->rules.max_area == 0u || c->rules.min_area <= c->rules.max_area, VD_ERR_ARG);
    return VD_OK;
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
    VD_TRY(resolve(cfg, &c));
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
        // Smallest level t with at least ceil(N * p / 1000) pixels <= t (as the detector's adaptive threshold).
        uint64_t target = ((uint64_t)npix * c.permille + 999u) / 1000u;
        uint64_t cum = 0u;
        uint32_t t = 255u;
        for (uint32_t i = 0; i < 256u; i++) {
            cum += hist[i];
            if (cum >= target) {
                t = i;
                break;
            }
        }
        thr = (t > thr) ? t : thr;
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
