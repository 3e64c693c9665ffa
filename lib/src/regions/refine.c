// SPDX-License-Identifier: MIT
// Candidate-region segmentation of paper 001 §3: median, Otsu, hole filling,
// edge image, local maximum-distance thresholds at every n-th edge point.
//
// Reference: paper 001 (FIR vehicle detection with a DBN; README.md names the
// papers), section 3, steps 2-5, and eq. (1), R(T) = (sum_{i<=T} i*P_i -
// mu*P(T))^2 / (P(T) * (1 - P(T))): Otsu's between-class criterion evaluated
// on the histogram of a small window.
//
// Algorithm of vd_refine_region on a w x h ROI:
//   F = median (median.h) or a copy of the ROI; t = Otsu (otsu.h);
//   M = F > t into the output mask; holes of M filled (vd_refine_fill_holes_u8:
//   depth-first flood of the background from the ROI border over
//   4-neighbours, explicit stack, each pixel pushed at most once);
//   E = edges of M (vd_refine_edges_u8: foreground with a background 4-neighbour,
//   outside the ROI counts as background); then every edge_step-th pixel of E
//   in raster order gets its window x window neighbourhood (clipped to the
//   ROI) re-binarised: mask = F > T, T = eq. (1) on the window's histogram.
// Why raster order and not the order along the traced boundary: it needs no
// contour storage (E is scanned once), it is trivially reproducible (numpy:
// np.flatnonzero(E)[::step]), and on the blob-like candidates it still spaces
// the windows evenly: a row of a convex blob holds two edge pixels, so every
// 5th edge pixel alternates sides and each side gets a 5x5 window about every
// 5 rows, which tiles the side; the flat top and bottom runs get one every
// 5 pixels, as along the boundary.
//
// eq. (1) in integers, for counts h_i with total n and level sum S, at a
// split T with c = sum_{i<=T} h_i, s = sum_{i<=T} i*h_i:
//   R(T) = (s*n - S*c)^2 / (n^2 * c * (n - c)),
// so T maximises D^2 / (c*(n-c)) with D = s*n - S*c; candidates compare by
// cross multiplication. D = c*(n-c)*(mean_low - mean_high), so with
// n <= 255: |D| <= 16256 * 255 < 2^22, D^2 < 2^44, c*(n-c) < 2^14 and every
// product < 2^58: exact in uint64.
//
// Bounds: time O(w*h * k) with k = 25 (5x5 median) + the windows
// (edge_points / edge_step * window^2: eq. (1) visits only the window's
// occupied levels, found from a 32-byte bitmap); stack: a few words (the
// 256-entry histogram is in the workspace) + the median's (< 512 bytes);
// workspace align(w*h) + max(4*w*h, align(w*h) + 1 KiB) bytes (refine.h).
#include "vd/refine.h"

#include <string.h>

#include "vd/median.h"
#include "vd/otsu.h"
#include "internal/vd_internal.h"

void vd_refine_cfg_default(vd_refine_cfg_t *cfg)
{
    if (cfg != NULL) {
        cfg->median_ksize = 3u;
        cfg->edge_step = 5u;
        cfg->window = 5u;
    }
}

// Index of the lowest set bit of a one-bit word (de Bruijn multiply: no
// count-trailing-zeros in C99).
static uint32_t bit_index(uint32_t low)
{
    static const uint8_t k_debruijn[32] = {0u,  1u,  28u, 2u,  29u, 14u, 24u, 3u,  30u, 22u, 20u,
                                           15u, 25u, 17u, 4u,  8u,  31u, 27u, 13u, 23u, 21u, 19u,
                                           16u, 7u,  26u, 12u, 18u, 6u,  11u, 5u,  10u, 9u};
    return k_debruijn[(uint32_t)(low * 0x077CB531u) >> 27];
}

// vd_refine_maxdist_from_hist for a histogram whose occupied levels are the set
// bits of present[] (level v: bit v & 31 of word v >> 5), with total n and
// level sum `sum`: the same criterion, evaluated only at occupied levels. An
// empty level t leaves (c, s) and so the criterion of the level before it
// unchanged, and with the strict > (first maximum wins) it can never become
// the answer, so the result is identical. Returns false for one grey level.
static bool maxdist_levels(const uint32_t hist[256], const uint32_t present[8], uint32_t n, uint32_t sum,
                           uint8_t *thr)
{
    const int64_t n_s = (int64_t)n;
    const int64_t sum_s = (int64_t)sum;
    int64_t c = 0;
    int64_t s = 0;
    uint64_t best_num = 0u;
    uint64_t best_den = 1u;
    int32_t best_t = -1;
    for (uint32_t wi = 0u; wi < 8u; wi++) {
        uint32_t bits = present[wi];
        while (bits != 0u) {   // one pass per set bit: <= 32
            const uint32_t low = bits & (0u - bits);
            bits ^= low;
            const uint32_t t = wi * 32u + bit_index(low);
            c += (int64_t)hist[t];
            s += (int64_t)t * (int64_t)hist[t];
            if (c == n_s) {
                break;   // the last occupied level: class 2 empty
            }
            // n <= VD_REFINE_MAXDIST_MAX_COUNT (255): |d| < 255 * 255 * 255, so d^2 < 2^48 and
            // num * best_den < 2^48 * 2^14 fits uint64.
            const int64_t d = s * n_s - sum_s * c;
            const uint64_t ad = (uint64_t)(d < 0 ? -d : d);
            const uint64_t num = ad * ad;
            const uint64_t den = (uint64_t)(c * (n_s - c));
            if (best_t < 0 || num * best_den > best_num * den) {
                best_num = num;
                best_den = den;
                best_t = (int32_t)t;
            }
        }
    }
    *thr = (uint8_t)(best_t < 0 ? 0 : best_t);
    return best_t >= 0;
}

vd_status_t vd_refine_maxdist_from_hist(const uint32_t hist[256], uint8_t *thr)
{
    VD_VERIFY(hist != NULL && thr != NULL, VD_ERR_ARG);
    uint64_t n = 0u;
    uint64_t sum = 0u;
    uint32_t present[8] = {0u};
    for (uint32_t i = 0; i < 256u; i++) {
        n += hist[i];   // 256 * (2^32 - 1) fits in uint64
        sum += (uint64_t)i * hist[i];
        present[i >> 5] |= (hist[i] != 0u ? 1u : 0u) << (i & 31u);
    }
    VD_VERIFY(n >= 1u && n <= VD_REFINE_MAXDIST_MAX_COUNT, VD_ERR_RANGE);
    // n <= 255, so sum <= 255 * 255 fits the helper's uint32.
    uint8_t t = 0u;   // *thr is left alone on failure
    VD_VERIFY(maxdist_levels(hist, present, (uint32_t)n, (uint32_t)sum, &t), VD_ERR_RANGE);  // one grey level only
    *thr = t;
    return VD_OK;
}

static bool fill_ws_size(uint32_t w, uint32_t h, size_t *bytes)
{
    size_t px;
    return vd_mul_size((size_t)w, (size_t)h, &px) && vd_mul_size(px, sizeof(uint32_t), bytes);
}

vd_status_t vd_refine_fill_holes_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes)
{
    VD_VERIFY(bytes != NULL, VD_ERR_ARG);
    VD_VERIFY(max_width >= 1u && max_height >= 1u && max_width <= VD_MAX_DIM && max_height <= VD_MAX_DIM, VD_ERR_ARG);
    VD_VERIFY(fill_ws_size(max_width, max_height, bytes), VD_ERR_OVERFLOW);
    return VD_OK;
}

// Marks a background pixel as reached from the border (value 1) and pushes it.
#define FILL_REACHED 1u

vd_status_t vd_refine_fill_holes_u8(vd_image_u8_t *mask, void *ws, size_t bytes)
{
    VD_TRY(vd_image_u8_check(mask));
    size_t need;
    VD_VERIFY(fill_ws_size(mask->width, mask->height, &need), VD_ERR_OVERFLOW);
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % (uintptr_t)VD_WORKSPACE_ALIGN) == 0u && bytes >= need,
              VD_ERR_WORKSPACE);
    uint32_t *stack = (uint32_t *)ws;
    const uint32_t w = mask->width;
    const uint32_t h = mask->height;
    const size_t stride = mask->stride;
    uint8_t *const d = mask->data;
    size_t top = 0u;

    // Normalise to 0/255 so the value 1 is free as the "reached" mark.
    for (uint32_t y = 0; y < h; y++) {
        uint8_t *row = d + (size_t)y * stride;
        for (uint32_t x = 0; x < w; x++) {
            row[x] = row[x] != 0u ? 255u : 0u;
        }
    }
    // Seeds: background pixels on the border. Index y*w + x < 2^26.
    for (uint32_t y = 0; y < h; y++) {
        uint8_t *row = d + (size_t)y * stride;
        const uint32_t step = (y == 0u || y == h - 1u) ? 1u : (w > 1u ? w - 1u : 1u);
        for (uint32_t x = 0; x < w; x += step) {
            if (row[x] == 0u) {
                row[x] = FILL_REACHED;
                stack[top++] = y * w + x;
            }
        }
    }
    // Depth-first flood; every pixel is pushed once, so the loop runs at most
    // w*h times and the stack never exceeds w*h entries.
    while (top > 0u) {
        const uint32_t i = stack[--top];
        const uint32_t y = i / w;
        const uint32_t x = i - y * w;
        uint8_t *px = d + (size_t)y * stride + x;
        if (x > 0u && px[-1] == 0u) {
            px[-1] = FILL_REACHED;
            stack[top++] = i - 1u;
        }
        if (x + 1u < w && px[1] == 0u) {
            px[1] = FILL_REACHED;
            stack[top++] = i + 1u;
        }
        if (y > 0u && *(px - stride) == 0u) {
            *(px - stride) = FILL_REACHED;
            stack[top++] = i - w;
        }
        if (y + 1u < h && px[stride] == 0u) {
            px[stride] = FILL_REACHED;
            stack[top++] = i + w;
        }
        VD_ASSERT(top <= (size_t)w * h);
    }
    // Unreached background is a hole -> foreground; reached -> background.
    for (uint32_t y = 0; y < h; y++) {
        uint8_t *row = d + (size_t)y * stride;
        for (uint32_t x = 0; x < w; x++) {
            row[x] = row[x] == FILL_REACHED ? 0u : 255u;
        }
    }
    return VD_OK;
}

vd_status_t vd_refine_edges_u8(const vd_view_u8_t *mask, const vd_rect_t *roi, vd_image_u8_t *dst)
{
    vd_rect_t r;
    VD_TRY(vd_view_u8_check(mask));
    VD_TRY(vd_image_u8_check(dst));
    VD_TRY(vd_rect_roi_resolve(roi, mask->width, mask->height, &r));
    VD_VERIFY(dst->width == (uint32_t)r.w && dst->height == (uint32_t)r.h, VD_ERR_ARG);
    const uint32_t w = (uint32_t)r.w;
    const uint32_t h = (uint32_t)r.h;
    const uint8_t *base = mask->data + (size_t)r.y * mask->stride + (size_t)r.x;
    for (uint32_t y = 0; y < h; y++) {
        const uint8_t *row = base + (size_t)y * mask->stride;
        const uint8_t *up = y > 0u ? row - mask->stride : NULL;
        const uint8_t *dn = y + 1u < h ? row + mask->stride : NULL;
        uint8_t *out = dst->data + (size_t)y * dst->stride;
        for (uint32_t x = 0; x < w; x++) {
            bool edge = false;
            if (row[x] != 0u) {
                edge = x == 0u || row[x - 1u] == 0u || x + 1u == w || row[x + 1u] == 0u ||
                       up == NULL || up[x] == 0u || dn == NULL || dn[x] == 0u;
            }
            out[x] = edge ? 255u : 0u;
        }
    }
    return VD_OK;
}

// The 256-bin histogram lives in the workspace, not on the stack (stack
// budget of vd_detector_run: it was 1 KiB of vd_refine_region's 1.2 KiB
// frame). It shares the fill-holes region: the global histogram is used
// before the fill, the local ones after it, when only the edge image (w*h
// bytes at the region's start) is live; so it sits at offset align(w*h) of
// that region, which is max(4*w*h, align(w*h) + 1 KiB) bytes. Regions of
// 342 pixels or more need nothing extra (the detector's workspace is unchanged).
#define REFINE_HIST_BYTES (256u * sizeof(uint32_t))

// Bytes of the filtered plane slice (px aligned) and of the region after it.
static bool refine_ws_parts(uint32_t w, uint32_t h, size_t *plane, size_t *region)
{
    size_t px;
    size_t fill;
    size_t hist_end = 0u;
    if (!vd_mul_size((size_t)w, (size_t)h, &px) || !fill_ws_size(w, h, &fill) ||
        !vd_size_add_slice(&hist_end, px) || !vd_add_size(hist_end, REFINE_HIST_BYTES, &hist_end)) {
        return false;
    }
    *plane = hist_end - REFINE_HIST_BYTES;   // align(px)
    *region = fill > hist_end ? fill : hist_end;
    return true;
}

// Filtered plane + the fill-holes / edge image / histogram region, each aligned.
static bool refine_ws_size(uint32_t w, uint32_t h, size_t *bytes)
{
    size_t plane;
    size_t region;
    return refine_ws_parts(w, h, &plane, &region) && vd_add_size(plane, region, bytes);
}

vd_status_t vd_refine_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes)
{
    VD_VERIFY(bytes != NULL, VD_ERR_ARG);
    VD_VERIFY(max_width >= 1u && max_height >= 1u && max_width <= VD_MAX_DIM && max_height <= VD_MAX_DIM, VD_ERR_ARG);
    VD_VERIFY(refine_ws_size(max_width, max_height, bytes), VD_ERR_OVERFLOW);
    return VD_OK;
}

static bool cfg_ok(const vd_refine_cfg_t *c)
{
    return (c->median_ksize == 0u || c->median_ksize == 3u || c->median_ksize == 5u) && c->edge_step >= 1u &&
           c->window >= 3u && c->window <= VD_REFINE_MAX_WINDOW && (c->window & 1u) == 1u;
}

// Steps 4-5 at edge pixel (x, y) of the filtered plane fdata (w x h): the
// eq. (1) threshold of its window (side 2 half + 1, clipped to the plane)
// rewrites the mask there when the window splits into two levels (returns
// true). hist is all zero on entry and on return.
static bool local_window(const uint8_t *fdata, uint32_t w, uint32_t h, uint32_t x, uint32_t y, uint32_t half,
                         uint32_t *hist, vd_image_u8_t *mask)
{
    const uint32_t x0 = x > half ? x - half : 0u;
    const uint32_t y0 = y > half ? y - half : 0u;
    const uint32_t x1 = x + half < w ? x + half : w - 1u;
    const uint32_t y1 = y + half < h ? y + half : h - 1u;
    // Window histogram + a bitmap of its occupied levels, so that
    // eq. (1) visits only those (<= window^2), not all 256 levels.
    uint32_t present[8] = {0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u};
    uint32_t wsum = 0u;
    for (uint32_t yy = y0; yy <= y1; yy++) {
        const uint8_t *f = fdata + (size_t)yy * w;
        for (uint32_t xx = x0; xx <= x1; xx++) {
            const uint32_t v = f[xx];
            hist[v]++;
            present[v >> 5] |= 1u << (v & 31u);
            wsum += v;
        }
    }
    uint8_t tl = 0u;
    const bool split = maxdist_levels(hist, present, (x1 - x0 + 1u) * (y1 - y0 + 1u), wsum, &tl);
    for (uint32_t yy = y0; yy <= y1; yy++) {
        const uint8_t *f = fdata + (size_t)yy * w;
        uint8_t *m = mask->data + (size_t)yy * mask->stride;
        for (uint32_t xx = x0; xx <= x1; xx++) {
            hist[f[xx]] = 0u;   // clears only the bins used
            if (split) {
                m[xx] = f[xx] > tl ? 255u : 0u;
            }
        }
    }
    return split;
}

vd_status_t vd_refine_region(const vd_view_u8_t *src, const vd_rect_t *roi, const vd_refine_cfg_t *cfg,
                             void *ws, size_t bytes, vd_image_u8_t *mask, vd_refine_stats_t *stats)
{
    vd_refine_cfg_t def;
    vd_rect_t r;
    VD_TRY(vd_view_u8_check(src));
    VD_TRY(vd_image_u8_check(mask));
    VD_TRY(vd_rect_roi_resolve(roi, src->width, src->height, &r));
    VD_VERIFY(mask->width == (uint32_t)r.w && mask->height == (uint32_t)r.h, VD_ERR_ARG);
    if (cfg == NULL) {
        vd_refine_cfg_default(&def);
        cfg = &def;
    }
    VD_VERIFY(cfg_ok(cfg), VD_ERR_ARG);
    const uint32_t w = (uint32_t)r.w;
    const uint32_t h = (uint32_t)r.h;
    size_t plane;
    size_t region;
    size_t fill;
    VD_VERIFY(refine_ws_parts(w, h, &plane, &region) && fill_ws_size(w, h, &fill), VD_ERR_OVERFLOW);
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % (uintptr_t)VD_WORKSPACE_ALIGN) == 0u && bytes >= plane + region,
              VD_ERR_WORKSPACE);
    // Layout: F at 0; the region after F (aligned, so uint32-aligned) holds
    // the fill stack, later the edge image at its start and the histogram at
    // its offset `plane` (= align(w*h)).
    uint8_t *fdata = (uint8_t *)ws;
    void *stack = fdata + plane;
    uint32_t *hist = (uint32_t *)(void *)(fdata + plane + plane);

    // Step 2: median filter of the ROI (or a plain copy).
    vd_image_u8_t fimg = {fdata, w, h, w};
    if (cfg->median_ksize == 3u) {
        VD_TRY(vd_median3_u8(src, &r, &fimg));
    } else if (cfg->median_ksize == 5u) {
        VD_TRY(vd_median5_u8(src, &r, &fimg));
    } else {
        for (uint32_t y = 0; y < h; y++) {
            memcpy(fdata + (size_t)y * w, src->data + ((size_t)r.y + y) * src->stride + (size_t)r.x, w);
        }
    }
    const vd_view_u8_t fview = vd_image_u8_view(&fimg);

    // Step 3: Otsu, binarise, fill holes, edge image.
    uint8_t t;
    VD_TRY(vd_histogram_u8(&fview, NULL, hist));
    VD_TRY(vd_otsu_from_hist(hist, &t));
    for (uint32_t y = 0; y < h; y++) {
        const uint8_t *f = fdata + (size_t)y * w;
        uint8_t *m = mask->data + (size_t)y * mask->stride;
        for (uint32_t x = 0; x < w; x++) {
            m[x] = f[x] > t ? 255u : 0u;
        }
    }
    VD_TRY(vd_refine_fill_holes_u8(mask, stack, fill));
    vd_image_u8_t eimg = {(uint8_t *)stack, w, h, w};
    const vd_view_u8_t mview = vd_image_u8_view(mask);
    VD_TRY(vd_refine_edges_u8(&mview, NULL, &eimg));

    // Steps 4-5: every edge_step-th edge pixel, local eq. (1) threshold.
    memset(hist, 0, REFINE_HIST_BYTES);
    const uint32_t half = (uint32_t)cfg->window / 2u;
    uint32_t n_edges = 0u;
    uint32_t n_windows = 0u;
    for (uint32_t y = 0; y < h; y++) {
        const uint8_t *e = eimg.data + (size_t)y * w;
        for (uint32_t x = 0; x < w; x++) {
            if (e[x] == 0u) {
                continue;
            }
            const bool selected = (n_edges % cfg->edge_step) == 0u;
            n_edges++;
            if (!selected) {
                continue;
            }
            n_windows += local_window(fdata, w, h, x, y, half, hist, mask) ? 1u : 0u;
        }
    }

    if (stats != NULL) {
        uint32_t fg = 0u;
        for (uint32_t y = 0; y < h; y++) {
            const uint8_t *m = mask->data + (size_t)y * mask->stride;
            for (uint32_t x = 0; x < w; x++) {
                fg += m[x] != 0u ? 1u : 0u;
            }
        }
        stats->otsu_thr = t;
        stats->edge_points = n_edges;
        stats->local_windows = n_windows;
        stats->fg_pixels = fg;
    }
    return VD_OK;
}
