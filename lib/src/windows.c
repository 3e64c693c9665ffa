// SPDX-License-Identifier: MIT
// Sliding-window candidate generator: a scale ladder of window heights, a stride grid per height, kept when a
// distance band and the optional ground model accept the window.
//
// Algorithm: paper 003 ("vehicle hypothesis ... using a sliding window
// method"), restricted by the per-distance size ranges of paper 000 Table 1
// and the flat-ground constraint documented in windows.h. Heights are walked
// once from the smallest band minimum to the largest band maximum (so a window
// allowed by two overlapping bands is produced once); rows and columns are an
// integer grid per (height, aspect). All arithmetic is integer (Q8 factors,
// 64-bit products for the ground test).
//
// Bounds: heights <= VD_WINDOWS_MAX_SCALES, aspects <= VD_WINDOWS_MAX_ASPECTS,
// rows <= frame_h, columns <= frame_w per (height, aspect): every loop is
// bounded by a constant or a frame dimension. Time O(windows written +
// heights * aspects * (frame_h + frame_w)); the per-row band/ground test is
// O(VD_WINDOWS_MAX_BANDS). Stack: a resolved copy of the config (~110 bytes)
// plus a few scalars. Capacity: min(cap, max_windows), overflow reported as
// VD_ERR_CAPACITY.
#include "vd/windows.h"
#include "internal/windows_internal.h"

#include <string.h>

#include "internal/vd_internal.h"

#define DEF_MIN_H 10u
#define DEF_MAX_H 200u
#define DEF_STEP_Q8 320u
#define DEF_STRIDE_Q8 64u
#define DEF_ASPECT_Q8 256u
#define DEF_TOL_Q8 512u
#define DEF_MAX_WINDOWS 2048u
#define MAX_WINDOWS_LIMIT 1048576u

// Next height of the ladder: round(h * step), at least h + 1.
static uint32_t next_height(uint32_t h, uint32_t step_q8)
{
    uint32_t n = (h * step_q8 + 128u) >> 8;
    return (n > h) ? n : h + 1u;
}

vd_status_t vd_windows_resolve(vd_windows_cfg_t *cfg)
{
    VD_VERIFY(cfg != NULL, VD_ERR_ARG);
    VD_VERIFY(cfg->frame_w >= 1u && cfg->frame_w <= VD_MAX_DIM, VD_ERR_ARG);
    VD_VERIFY(cfg->frame_h >= 1u && cfg->frame_h <= VD_MAX_DIM, VD_ERR_ARG);
    VD_VERIFY(cfg->n_bands <= VD_WINDOWS_MAX_BANDS && cfg->n_aspects <= VD_WINDOWS_MAX_ASPECTS, VD_ERR_ARG);
    if (cfg->n_bands == 0u) {
        cfg->n_bands = 1u;
        cfg->bands[0].y_min = 0;
        cfg->bands[0].y_max = (int32_t)cfg->frame_h - 1;
        cfg->bands[0].min_h = (uint16_t)DEF_MIN_H;
        cfg->bands[0].max_h = (uint16_t)DEF_MAX_H;
    }
    if (cfg->n_aspects == 0u) {
        cfg->n_aspects = 1u;
        cfg->aspect_q8[0] = (uint16_t)DEF_ASPECT_Q8;
    }
    if (cfg->scale_step_q8 == 0u) { cfg->scale_step_q8 = (uint16_t)DEF_STEP_Q8; }
    if (cfg->stride_q8 == 0u) { cfg->stride_q8 = (uint16_t)DEF_STRIDE_Q8; }
    if (cfg->ground_tol_q8 == 0u) { cfg->ground_tol_q8 = (uint16_t)DEF_TOL_Q8; }
    if (cfg->max_windows == 0u) { cfg->max_windows = DEF_MAX_WINDOWS; }
    VD_VERIFY(cfg->scale_step_q8 >= 288u && cfg->scale_step_q8 <= 1024u, VD_ERR_ARG);
    VD_VERIFY(cfg->stride_q8 >= 16u && cfg->stride_q8 <= 512u, VD_ERR_ARG);
    VD_VERIFY(cfg->ground_tol_q8 >= 256u && cfg->ground_tol_q8 <= 4096u, VD_ERR_ARG);
    VD_VERIFY(cfg->max_windows <= MAX_WINDOWS_LIMIT, VD_ERR_ARG);
    VD_VERIFY(cfg->horizon_y >= -(int32_t)VD_MAX_DIM && cfg->horizon_y <= (int32_t)VD_MAX_DIM, VD_ERR_ARG);
    for (uint32_t a = 0; a < cfg->n_aspects; a++) {
        VD_VERIFY(cfg->aspect_q8[a] >= 64u && cfg->aspect_q8[a] <= 1024u, VD_ERR_ARG);
    }
    uint32_t lo = VD_MAX_DIM;
    uint32_t hi = 0u;
    for (uint32_t b = 0; b < cfg->n_bands; b++) {
        const vd_window_band_t *bd = &cfg->bands[b];
        VD_VERIFY(bd->min_h >= 1u && bd->min_h <= bd->max_h && bd->max_h <= VD_MAX_DIM, VD_ERR_ARG);
        VD_VERIFY(bd->y_min <= bd->y_max, VD_ERR_ARG);
        VD_VERIFY(bd->y_min >= -(int32_t)VD_MAX_DIM && bd->y_max <= 2 * (int32_t)VD_MAX_DIM, VD_ERR_ARG);
        lo = (bd->min_h < lo) ? bd->min_h : lo;
        hi = (bd->max_h > hi) ? bd->max_h : hi;
    }
    // The ladder from lo to hi must fit VD_WINDOWS_MAX_SCALES heights.
    uint32_t h = lo;
    uint32_t n = 1u;
    while (n <= VD_WINDOWS_MAX_SCALES) {   // bounded: exits after at most MAX_SCALES + 1 steps
        h = next_height(h, cfg->scale_step_q8);
        if (h > hi) {
            break;
        }
        n++;
    }
    VD_VERIFY(n <= VD_WINDOWS_MAX_SCALES, VD_ERR_ARG);
    return VD_OK;
}

// True when a window of height h with bottom row yb is allowed by a band and the ground model.
static bool row_ok(const vd_windows_cfg_t *c, uint32_t h, int32_t yb)
{
    bool band = false;
    for (uint32_t b = 0; b < c->n_bands; b++) {
        const vd_window_band_t *bd = &c->bands[b];
        if (yb >= bd->y_min && yb <= bd->y_max && h >= bd->min_h && h <= bd->max_h) {
            band = true;
            break;
        }
    }
    if (!band) {
        return false;
    }
    if (c->ground_k_q8 == 0u) {
        return true;
    }
    int64_t below = (int64_t)yb - c->horizon_y;
    if (below <= 0) {
        return false;   // at or above the horizon a road vehicle has no height
    }
    // expected height in Q8: e = k * below; keep e / t <= h <= e * t (t in Q8):
    //   h * 256 * t >= e * 256  and  h * 256 * 256 <= e * t.
    int64_t e_q8 = (int64_t)c->ground_k_q8 * below;
    int64_t h_q8 = (int64_t)h << 8;
    int64_t t = (int64_t)c->ground_tol_q8;
    return (h_q8 * t >= e_q8 * 256) && (h_q8 * 256 <= e_q8 * t);
}

// The one enumeration of windows (vd_windows_generate, vd_windows_count and the
// detector's streamed windows all use it): height ladder, aspect, row, column.
uint64_t vd_windows_walk(const vd_windows_cfg_t *c, vd_windows_visit_fn visit, void *ctx)
{
    uint32_t lo = VD_MAX_DIM;
    uint32_t hi = 0u;
    for (uint32_t b = 0; b < c->n_bands; b++) {
        lo = (c->bands[b].min_h < lo) ? c->bands[b].min_h : lo;
        hi = (c->bands[b].max_h > hi) ? c->bands[b].max_h : hi;
    }
    uint64_t all = 0u;
    uint32_t h = lo;
    for (uint32_t s = 0; s < VD_WINDOWS_MAX_SCALES && h <= hi; s++) {
        if (h <= c->frame_h) {
            for (uint32_t a = 0; a < c->n_aspects; a++) {
                uint32_t w = (h * 256u + c->aspect_q8[a] / 2u) / c->aspect_q8[a];
                w = (w < 1u) ? 1u : w;
                if (w > c->frame_w) {
                    continue;
                }
                uint32_t sx = (w * c->stride_q8) >> 8;
                uint32_t sy = (h * c->stride_q8) >> 8;
                sx = (sx < 1u) ? 1u : sx;
                sy = (sy < 1u) ? 1u : sy;
                uint32_t ox = ((c->frame_w - w) % sx) / 2u;
                uint32_t oy = ((c->frame_h - h) % sy) / 2u;
                uint32_t ncols = (c->frame_w - w - ox) / sx + 1u;
                for (uint32_t y = oy; y + h <= c->frame_h; y += sy) {
                    if (!row_ok(c, h, (int32_t)(y + h - 1u))) {
                        continue;
                    }
                    all += ncols;
                    if (visit == NULL) {
                        continue;
                    }
                    for (uint32_t i = 0; i < ncols; i++) {
                        const vd_rect_t win = {(int32_t)(ox + i * sx), (int32_t)y, (int32_t)w, (int32_t)h};
                        visit(ctx, &win);
                    }
                }
            }
        }
        h = next_height(h, c->scale_step_q8);
    }
    return all;
}

typedef struct collect {
    vd_rect_t *out;
    size_t cap;
    size_t n;
} collect_t;

// Visitor of vd_windows_generate: keeps the first `cap` windows.
static void collect(void *ctx, const vd_rect_t *win)
{
    collect_t *c = (collect_t *)ctx;
    if (c->n < c->cap) {
        c->out[c->n++] = *win;
    }
}

vd_status_t vd_windows_generate(const vd_windows_cfg_t *cfg, vd_rect_t *out, size_t cap, size_t *count)
{
    VD_VERIFY(count != NULL, VD_ERR_ARG);
    *count = 0u;
    VD_VERIFY(cfg != NULL, VD_ERR_ARG);
    VD_VERIFY(out != NULL || cap == 0u, VD_ERR_ARG);
    vd_windows_cfg_t c = *cfg;
    VD_TRY(vd_windows_resolve(&c));
    size_t lim = (cap < (size_t)c.max_windows) ? cap : (size_t)c.max_windows;
    collect_t col = {out, lim, 0u};
    const uint64_t all = vd_windows_walk(&c, collect, &col);
    *count = col.n;
    return (all > (uint64_t)col.n) ? VD_ERR_CAPACITY : VD_OK;
}

vd_status_t vd_windows_count(const vd_windows_cfg_t *cfg, uint32_t *total)
{
    VD_VERIFY(total != NULL, VD_ERR_ARG);
    *total = 0u;
    VD_VERIFY(cfg != NULL, VD_ERR_ARG);
    vd_windows_cfg_t c = *cfg;
    VD_TRY(vd_windows_resolve(&c));
    const uint64_t all = vd_windows_walk(&c, NULL, NULL);
    *total = (all > UINT32_MAX) ? UINT32_MAX : (uint32_t)all;
    return VD_OK;
}
