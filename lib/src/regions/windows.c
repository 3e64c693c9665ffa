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
//
// Pre-filter (windows.h): the 4x4-cell means come from vd_resample_box_*
// over strips of CHUNK cells (a stack row buffer), and are accumulated into
// the uint32 integrals of g and g^2 (wrap-around is harmless, see
// VD_WINDOWS_MAX_CELLS); a window's level is one difference of four corners
// per integral, a 64-bit variance and a 16-step integer square root. Ranking
// (vd_windows_rank): a 256-bin histogram of levels in a first walk, the cut
// level from the top of it, and a second walk that hands out the windows
// above the cut and the first ones at it, so nothing is stored and ties keep
// the generator's order. Time O(W*H) for the pre-filter, O(windows) per walk.
#include "vd/windows.h"

#include <string.h>

#include "vd/resample.h"
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

// The one enumeration of windows of a resolved config (vd_windows_generate,
// vd_windows_count and vd_windows_rank all use it): height ladder, aspect,
// row, column; visit (NULL = only count) gets each window. Returns the number
// of windows. Bounded: VD_WINDOWS_MAX_SCALES heights x n_aspects x rows x columns.
static uint64_t walk(const vd_windows_cfg_t *c, vd_windows_visit_fn visit, void *ctx)
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
    const uint64_t all = walk(&c, collect, &col);
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
    const uint64_t all = walk(&c, NULL, NULL);
    *total = (all > UINT32_MAX) ? UINT32_MAX : (uint32_t)all;
    return VD_OK;
}

// Cells whose means are made per vd_resample_box_* call (a stack row buffer).
#define CHUNK 64u

vd_status_t vd_windows_prefilter_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes)
{
    VD_VERIFY(bytes != NULL, VD_ERR_ARG);
    *bytes = 0u;
    VD_VERIFY(max_width >= 1u && max_width <= VD_MAX_DIM && max_height >= 1u && max_height <= VD_MAX_DIM, VD_ERR_ARG);
    VD_VERIFY((max_width / VD_WINDOWS_CELL) * (max_height / VD_WINDOWS_CELL) <= VD_WINDOWS_MAX_CELLS, VD_ERR_ARG);
    // <= 2 * 2049 * 2049 * 4 bytes < 2^32: no overflow in a 32-bit size_t.
    *bytes = 2u * ((size_t)max_width / VD_WINDOWS_CELL + 1u) * ((size_t)max_height / VD_WINDOWS_CELL + 1u) *
             sizeof(uint32_t);
    return VD_OK;
}

// Means of the cells [gx, gx + nc) of cell row gy into g.
static vd_status_t cell_means(const vd_frame_t *f, const vd_calib_grey_t *grey, uint32_t gx, uint32_t gy,
                              uint32_t nc, uint8_t *g)
{
    const vd_rect_t strip = {(int32_t)(gx * VD_WINDOWS_CELL), (int32_t)(gy * VD_WINDOWS_CELL),
                             (int32_t)(nc * VD_WINDOWS_CELL), (int32_t)VD_WINDOWS_CELL};
    vd_image_u8_t row = {g, nc, 1u, nc};
    if (f->format == VD_PIX_U8) {
        vd_view_u8_t v;
        VD_TRY(vd_frame_view_u8(f, &v));
        return vd_resample_box_u8(&v, &strip, VD_WINDOWS_CELL, VD_WINDOWS_CELL, &row);
    }
    vd_view_u16_t v;
    VD_TRY(vd_frame_view_u16(f, &v));
    return vd_resample_box_u16(&v, &strip, VD_WINDOWS_CELL, VD_WINDOWS_CELL, grey, &row);
}

vd_status_t vd_windows_prefilter_init(vd_windows_prefilter_t *pf, const vd_frame_t *frame,
                                      const vd_calib_grey_t *grey, void *ws, size_t bytes)
{
    VD_VERIFY(pf != NULL, VD_ERR_ARG);
    VD_TRY(vd_frame_check(frame));
    VD_VERIFY(frame->format == VD_PIX_U8 || grey != NULL, VD_ERR_ARG);
    size_t need = 0u;
    VD_TRY(vd_windows_prefilter_workspace_size(frame->width, frame->height, &need));
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % VD_WORKSPACE_ALIGN) == 0u && bytes >= need, VD_ERR_WORKSPACE);
    const uint32_t gw = frame->width / VD_WINDOWS_CELL;
    const uint32_t gh = frame->height / VD_WINDOWS_CELL;
    const size_t stride = (size_t)gw + 1u;
    uint32_t *s1 = (uint32_t *)ws;
    uint32_t *s2 = s1 + stride * ((size_t)gh + 1u);
    memset(s1, 0, stride * sizeof(uint32_t));
    memset(s2, 0, stride * sizeof(uint32_t));
    uint8_t g[CHUNK];
    for (uint32_t gy = 0; gy < gh; gy++) {
        uint32_t r1 = 0u;
        uint32_t r2 = 0u;
        const size_t at = ((size_t)gy + 1u) * stride;
        s1[at] = 0u;
        s2[at] = 0u;
        for (uint32_t gx0 = 0; gx0 < gw; gx0 += CHUNK) {
            const uint32_t nc = (gw - gx0 < CHUNK) ? gw - gx0 : CHUNK;
            VD_TRY(cell_means(frame, grey, gx0, gy, nc, g));
            for (uint32_t i = 0; i < nc; i++) {
                const size_t gx = (size_t)gx0 + i;
                r1 += g[i];
                r2 += (uint32_t)g[i] * g[i];
                s1[at + gx + 1u] = s1[at - stride + gx + 1u] + r1;
                s2[at + gx + 1u] = s2[at - stride + gx + 1u] + r2;
            }
        }
    }
    pf->sum = s1;
    pf->gw = (uint16_t)gw;   // <= VD_MAX_DIM / 4
    pf->gh = (uint16_t)gh;
    return VD_OK;
}

// floor(sqrt(v)), 16 iterations at most.
static uint32_t isqrt32(uint32_t v)
{
    uint32_t r = 0u;
    uint32_t bit = 1u << 30;
    for (uint32_t i = 0; i < 16u && bit > v; i++) {
        bit >>= 2;
    }
    for (uint32_t i = 0; i < 16u && bit != 0u; i++) {
        if (v >= r + bit) {
            v -= r + bit;
            r = (r >> 1) + bit;
        } else {
            r >>= 1;
        }
        bit >>= 2;
    }
    return r;
}

// Cells [*c0, *c1) of one axis under [p, p + len) on a grid of g cells (see
// vd_windows_prefilter_level).
static void cell_range(uint32_t p, uint32_t len, uint32_t g, uint32_t *c0, uint32_t *c1)
{
    uint32_t a = (p + VD_WINDOWS_CELL - 1u) / VD_WINDOWS_CELL;
    uint32_t b = (p + len) / VD_WINDOWS_CELL;
    b = (b > g) ? g : b;
    a = (a >= b) ? ((b > 0u) ? b - 1u : 0u) : a;
    b = (b <= a) ? a + 1u : b;
    *c0 = a;
    *c1 = b;
}

uint32_t vd_windows_prefilter_level(const vd_windows_prefilter_t *pf, const vd_rect_t *win)
{
    const uint32_t gw = pf->gw;
    const uint32_t gh = pf->gh;
    if (gw == 0u || gh == 0u) {
        return 0u;
    }
    const size_t stride = (size_t)gw + 1u;
    const uint32_t *s1 = pf->sum;
    const uint32_t *s2 = s1 + stride * ((size_t)gh + 1u);
    uint32_t x0, x1, y0, y1;
    cell_range((uint32_t)win->x, (uint32_t)win->w, gw, &x0, &x1);
    cell_range((uint32_t)win->y, (uint32_t)win->h, gh, &y0, &y1);
    const uint32_t a1 = s1[(size_t)y1 * stride + x1] - s1[(size_t)y0 * stride + x1] -
                        s1[(size_t)y1 * stride + x0] + s1[(size_t)y0 * stride + x0];
    const uint32_t a2 = s2[(size_t)y1 * stride + x1] - s2[(size_t)y0 * stride + x1] -
                        s2[(size_t)y1 * stride + x0] + s2[(size_t)y0 * stride + x0];
    const uint64_t n = (uint64_t)(x1 - x0) * (y1 - y0);
    const uint64_t num = n * a2 - (uint64_t)a1 * a1;   // n^2 * variance >= 0
    const uint32_t var = (uint32_t)(num / (n * n));
    const uint32_t sd = isqrt32(var);
    return (sd > 255u) ? 255u : sd;
}

// State of the two walks of vd_windows_rank: pass 0 builds the histogram of
// levels >= min_std; pass 1 hands out the windows of level > cut and the
// first `ties` of level == cut.
typedef struct rank_pass {
    const vd_windows_prefilter_t *pf;
    uint32_t *hist;
    vd_windows_visit_fn visit;
    void *ctx;
    uint32_t min_std;
    uint32_t cut;
    uint32_t ties;
    int pass;
} rank_pass_t;

static void rank_visit(void *ctx, const vd_rect_t *b)
{
    rank_pass_t *p = (rank_pass_t *)ctx;
    const uint32_t lv = vd_windows_prefilter_level(p->pf, b);
    if (lv < p->min_std) {
        return;
    }
    if (p->pass == 0) {
        p->hist[lv]++;
        return;
    }
    if (lv < p->cut || (lv == p->cut && p->ties == 0u)) {
        return;
    }
    if (lv == p->cut) {
        p->ties--;
    }
    p->visit(p->ctx, b);
}

vd_status_t vd_windows_rank(const vd_windows_cfg_t *cfg, const vd_windows_prefilter_t *pf, uint8_t min_std,
                            size_t room, uint32_t hist[256], vd_windows_visit_fn visit, void *ctx,
                            vd_windows_rank_stats_t *stats)
{
    VD_VERIFY(cfg != NULL && pf != NULL && hist != NULL, VD_ERR_ARG);
    VD_VERIFY(visit != NULL || room == 0u, VD_ERR_ARG);
    vd_windows_cfg_t c = *cfg;
    VD_TRY(vd_windows_resolve(&c));
    memset(hist, 0, 256u * sizeof(uint32_t));
    rank_pass_t p = {pf, hist, visit, ctx, min_std, 0u, 0u, 0};
    const uint64_t all = walk(&c, rank_visit, &p);
    // Highest levels first: cut = the level where the room runs out.
    uint64_t cum = 0u;
    p.cut = min_std;
    p.ties = hist[min_std];
    for (uint32_t k = 0; k < 256u; k++) {
        const uint32_t lv = 255u - k;
        if (lv < min_std) {
            break;
        }
        if (cum + hist[lv] > room) {
            p.cut = lv;
            p.ties = (uint32_t)(room - cum);
            break;
        }
        cum += hist[lv];
    }
    uint64_t passed = 0u;
    for (uint32_t k = min_std; k < 256u; k++) {
        passed += hist[k];
    }
    if (stats != NULL) {
        stats->windows = (all > UINT32_MAX) ? UINT32_MAX : (uint32_t)all;
        stats->passed = (uint32_t)passed;
    }
    if (room > 0u) {
        p.pass = 1;
        (void)walk(&c, rank_visit, &p);
    }
    return VD_OK;
}
