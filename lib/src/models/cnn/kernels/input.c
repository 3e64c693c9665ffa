// SPDX-License-Identifier: MIT
// CNN input op: tensor 0 from the grey frame (pixel - 128, or the model's per-frame percentile stretch or
// histogram equalisation), read from a plane or a caller's row function.
//
// Algorithm: without normalisation q = pixel - 128. Otherwise a histogram of the whole plane gives a
// 256-entry table pixel -> int8 (256 divisions per frame, none per pixel): VD_CNN_NORM_PERCENTILE maps the
// lo / hi permille grey levels to 0 / 255, the range floored at the model's norm_min_range;
// VD_CNN_NORM_EQUALISE maps each level to the mid-rank of its pixels, (255 (2 below + count) + n) / (2 n),
// which any strictly increasing tone curve of the camera leaves unchanged.
// Reference: tools/vdtools/formats/cnn_ref.py (the same table, bit-exact).
// Bounds: one pass over the plane for the histogram, one per row of tensor 0; scratch: the histogram
// and table (VD_CNN_HIST_BYTES, plan item 1).
#include "models/cnn/cnn_internal.h"

#include <string.h>

static const uint8_t *src_row(const in_src_t *s, uint32_t y)
{
    if (s->img != NULL) {
        return s->img + (size_t)y * s->stride;
    }
    s->rows->row(s->rows->ctx, y, s->buf);
    return s->buf;
}

const int8_t *vd__cnn_norm_table(const vd_cnn_model_t *m, const in_src_t *src, uint32_t w, uint32_t h,
                                uint8_t *hist_area, bool kept)
{
    if (m->input_norm != VD_CNN_NORM_PERCENTILE && m->input_norm != VD_CNN_NORM_EQUALISE) {
        return NULL;
    }
    uint32_t *hist = (uint32_t *)(void *)hist_area;
    int8_t *lut = (int8_t *)(void *)(hist_area + 256u * 4u);
    if (kept) {
        return lut;
    }
    memset(hist, 0, 256u * sizeof(uint32_t));
    for (uint32_t y = 0u; y < h; y++) {
        const uint8_t *row = src_row(src, y);
        uint32_t x = 0u;
#if !defined(__OPTIMIZE_SIZE__)
        // Four pixels per word load, in any byte order (5.5 instructions per pixel against 6.2, Cortex-M7;
        // not in -Os builds, which keep the smaller byte loop).
        for (; x + 4u <= w; x += 4u) {
            uint32_t v;
            memcpy(&v, row + x, 4u);
            hist[v & 255u]++;
            hist[(v >> 8) & 255u]++;
            hist[(v >> 16) & 255u]++;
            hist[v >> 24]++;
        }
#endif
        for (; x < w; x++) {
            hist[row[x]]++;
        }
    }
    const uint64_t n = (uint64_t)w * h;
    if (m->input_norm == VD_CNN_NORM_EQUALISE) {
        // (2 below + count) <= 2 n <= 2^25 (sides <= 4096), times 255: 64-bit; the quotient is <= 255.
        uint64_t below = 0u;
        for (uint32_t v = 0u; v < 256u; v++) {
            const uint64_t p = ((2u * below + hist[v]) * 255u + n) / (2u * n);
            lut[v] = (int8_t)((int32_t)p - 128);
            below += hist[v];
        }
        return lut;
    }
    const uint64_t t_lo = n * m->norm_lo_permille / 1000u;
    const uint64_t t_hi = n * m->norm_hi_permille / 1000u;
    uint64_t cum = 0u;
    uint32_t lo = 255u, hi = 255u;
    bool have_lo = false, have_hi = false;
    for (uint32_t v = 0u; v < 256u; v++) {
        cum += hist[v];
        if (!have_lo && cum > t_lo) {
            lo = v;
            have_lo = true;
        }
        if (!have_hi && cum > t_hi) {
            hi = v;
            have_hi = true;
        }
    }
    // t_hi >= t_lo, so hi >= lo.
    const uint32_t r = (hi - lo > m->norm_min_range) ? hi - lo : m->norm_min_range;
    for (uint32_t v = 0u; v < 256u; v++) {
        uint32_t p = 0u;
        if (v > lo) {
            p = ((v - lo) * 510u + r) / (2u * r);
            p = (p > 255u) ? 255u : p;
        }
        lut[v] = (int8_t)((int32_t)p - 128);
    }
    return lut;
}

void vd__cnn_input_rows(const in_src_t *src, uint32_t w, const int8_t *lut, const ring_t *t0, uint32_t y0, uint32_t y1)
{
    for (uint32_t y = y0; y < y1; y++) {
        const uint8_t *row = src_row(src, y);
        int8_t *d = vd_cnn_ring_row(t0, y);
        if (lut == NULL) {
            for (uint32_t x = 0u; x < w; x++) {
                d[x] = (int8_t)((int32_t)row[x] - 128);
            }
        } else {
            uint32_t x = 0u;
#if !defined(__OPTIMIZE_SIZE__)
            // Four pixels per word load and store (~4 instructions per pixel against ~5, Cortex-M7; not in
            // -Os builds); byte lane k of the word read maps to byte lane k of the word written, in either
            // byte order.
            const uint8_t *u = (const uint8_t *)(const void *)lut;
            for (; x + 4u <= w; x += 4u) {
                uint32_t v;
                memcpy(&v, row + x, 4u);
                const uint32_t q = (uint32_t)u[v & 255u] | ((uint32_t)u[(v >> 8) & 255u] << 8) |
                                   ((uint32_t)u[(v >> 16) & 255u] << 16) | ((uint32_t)u[v >> 24] << 24);
                memcpy(d + x, &q, 4u);
            }
#endif
            for (; x < w; x++) {
                d[x] = lut[row[x]];
            }
        }
    }
}
