// SPDX-License-Identifier: MIT
// Exact fixed-point resampler: area average when shrinking, bilinear when growing, per axis.
//
// Algorithm: separable weights per axis, computed on the fly for each output
// index (no tables, no workspace).
//  - Shrinking axis (S >= D): in units of 1/D source pixel, output i covers
//    [i*S, (i+1)*S) and source pixel k covers [k*D, (k+1)*D); the weight of k
//    is the length of the overlap (an integer), the weights sum to S. This is
//    the box filter that cv2.INTER_AREA approximates with float weights.
//  - Growing axis (S < D): position of output centre i in units of 1/(2D)
//    source pixel is p = (2i+1)*S - D (i.e. (i+0.5)*S/D - 0.5); p < 0 clamps
//    to pixel 0, p >= 2D*(S-1) to pixel S-1; otherwise k0 = p / 2D and
//    frac = p % 2D give weights 2D-frac (k0) and frac (k0+1), total 2D. Same
//    geometry as cv2.INTER_LINEAR, but exact instead of 11-bit weights.
//  - Output = (sum_k,l wx(k)*wy(l)*src(l,k) + T/2) / T with T = Tx*Ty, i.e.
//    rounded half up, exact.
// Reference: paper 001 section 4 (32x32 samples); tools/vdtools/samples.py
// holds the numpy reference used by tests/python.
// Bounds: Tx, Ty <= 8192 (VD_MAX_DIM, 2*VD_RESAMPLE_MAX_DST), so a row sum is
// < 8192*255 < 2^21 (uint32) and the total < 2^34 (uint64: the one place 64
// bits are needed). Time: each source pixel of the ROI is read at most
// ceil(D/S)+1 <= 2 times per shrinking axis; growing axes read 2 taps.
// Stack: a few words. One 64-bit division per output pixel.
#include "vd/resample.h"

#include "internal/vd_internal.h"

// Taps of one output index along one axis: source indices first..last and
// the weight total.
typedef struct axis_taps {
    uint32_t first;
    uint32_t last;
    uint32_t total;
    uint32_t w_first; // growing axis: weight of `first` (and `total - w_first` of last)
    bool shrink;
} axis_taps_t;

static void axis_taps_at(uint32_t i, uint32_t s, uint32_t d, axis_taps_t *t)
{
    if (s >= d) {
        uint32_t lo = i * s;          // < 2^13 * 2^12: no overflow
        uint32_t hi = lo + s;
        t->shrink = true;
        t->first = lo / d;
        t->last = (hi - 1u) / d;
        t->total = s;
        t->w_first = 0u;
        return;
    }
    uint32_t two_d = 2u * d;
    t->shrink = false;
    t->total = two_d;
    uint32_t p_pos = (2u * i + 1u) * s; // position + D, never negative
    if (p_pos <= d) {
        t->first = 0u;
        t->last = 0u;
        t->w_first = two_d;
        return;
    }
    uint32_t p = p_pos - d;
    uint32_t k0 = p / two_d;
    uint32_t frac = p % two_d;
    if (k0 >= s - 1u) {
        t->first = s - 1u;
        t->last = s - 1u;
        t->w_first = two_d;
        return;
    }
    t->first = k0;
    t->last = (frac == 0u) ? k0 : k0 + 1u;
    t->w_first = two_d - frac;
}

// Weight of source index k (first <= k <= last) for output i.
static uint32_t axis_weight(const axis_taps_t *t, uint32_t i, uint32_t k, uint32_t s, uint32_t d)
{
    if (t->shrink) {
        uint32_t lo = i * s;
        uint32_t hi = lo + s;
        uint32_t a = k * d;
        uint32_t b = a + d;
        uint32_t from = (a > lo) ? a : lo;
        uint32_t to = (b < hi) ? b : hi;
        return to - from;
    }
    return (k == t->first) ? t->w_first : t->total - t->w_first;
}

vd_status_t vd_resample_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint8_t *dst,
                           uint32_t dst_w, uint32_t dst_h)
{
    vd_rect_t r;
    VD_VERIFY(dst != NULL, VD_ERR_ARG);
    VD_VERIFY(dst_w >= 1u && dst_w <= VD_RESAMPLE_MAX_DST, VD_ERR_ARG);
    VD_VERIFY(dst_h >= 1u && dst_h <= VD_RESAMPLE_MAX_DST, VD_ERR_ARG);
    VD_TRY(vd_view_u8_check(src));
    VD_TRY(vd_roi_resolve(roi, src->width, src->height, &r));

    const uint32_t sw = (uint32_t)r.w;
    const uint32_t sh = (uint32_t)r.h;
    const uint8_t *base = src->data + (size_t)r.y * src->stride + (size_t)r.x;

    for (uint32_t oy = 0u; oy < dst_h; oy++) {
        axis_taps_t ty;
        axis_taps_at(oy, sh, dst_h, &ty);
        for (uint32_t ox = 0u; ox < dst_w; ox++) {
            axis_taps_t tx;
            axis_taps_at(ox, sw, dst_w, &tx);
            uint64_t acc = 0u;
            for (uint32_t ky = ty.first; ky <= ty.last; ky++) {
                const uint8_t *row = base + (size_t)ky * src->stride;
                uint32_t row_sum = 0u;
                for (uint32_t kx = tx.first; kx <= tx.last; kx++) {
                    row_sum += axis_weight(&tx, ox, kx, sw, dst_w) * (uint32_t)row[kx];
                }
                acc += (uint64_t)axis_weight(&ty, oy, ky, sh, dst_h) * row_sum;
            }
            const uint64_t total = (uint64_t)tx.total * ty.total;
            const uint64_t q = (acc + total / 2u) / total;
            VD_ASSERT(q <= 255u);
            dst[(size_t)oy * dst_w + ox] = (uint8_t)q;
        }
    }
    return VD_OK;
}
