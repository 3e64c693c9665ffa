// SPDX-License-Identifier: MIT
// Exact fixed-point resampler: area average when shrinking, bilinear when growing, per axis.
//
// Algorithm: separable weights per axis; the taps of up to 16 output columns
// (32 on the narrow path) are tabled once per call (stack), those of an
// output row once per row.
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
// Reference: paper 001 section 4 (32x32 samples); tools/vdtools/data/samples.py
// holds the numpy reference used by tests/python.
// Bounds: Tx, Ty <= 8192 (VD_MAX_DIM, 2*VD_RESAMPLE_MAX_DST), so a row sum is
// < 8192*255 < 2^21 (uint32) and the total < 2^34 (uint64: the one place 64
// bits are needed). Time: each source pixel of the ROI is read at most
// ceil(D/S)+1 <= 2 times per shrinking axis; growing axes read 2 taps.
// Stack: the x-tap table (16 entries, 128 bytes; narrow path: 32 entries
// + row sums of two row pairs, accumulators and column sums, 640 bytes;
// the narrow path below) + a few words. The rounded
// quotient by the constant total T is a reciprocal multiply, exact for
// T <= 2^23 (internal/recip_internal.h); larger totals divide.
//
// Box average (vd_resample_box_*): per output pixel the uint64 sum of its
// kx x ky block, then one rounded division by kx*ky (<= 2^26, so the sum of
// 16-bit pixels stays < 2^42); a 16-bit mean goes through the calibration's
// grey map. Time O(cw*kx * ch*ky) <= O(roi area).
#include "vd/resample.h"

#include <string.h>

#include "internal/calib_internal.h"
#include "internal/recip_internal.h"
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

// Taps of one output index in a compact form: source pixels first..last with
// weight wf for `first`, wl for `last` (if last > first) and the axis' whole
// weight (D on a shrinking axis) for the pixels strictly between.
typedef struct tap {
    uint16_t first;
    uint16_t last;
    uint16_t wf;
    uint16_t wl;
} tap_t;

// Output columns whose taps are tabled at once (stack: 8 bytes each); the
// detector's 32-wide samples take two chunks.
#define XCHUNK 16u

static void tap_at(uint32_t i, uint32_t s, uint32_t d, tap_t *t)
{
    axis_taps_t a;
    axis_taps_at(i, s, d, &a);
    // Indices < 8192 and weights <= 8192 (VD_MAX_DIM, 2 * VD_RESAMPLE_MAX_DST): uint16.
    t->first = (uint16_t)a.first;
    t->last = (uint16_t)a.last;
    t->wf = (uint16_t)axis_weight(&a, i, a.first, s, d);
    t->wl = a.last == a.first ? 0u : (uint16_t)axis_weight(&a, i, a.last, s, d);
}

// sum_k w(k) * row[k] over the taps t; wm = weight of the inner taps.
// < 8192 * 255 < 2^21. wl = 0 when first == last (one tap): no branch.
static inline uint32_t tap_sum(const uint8_t *row, const tap_t *t, uint32_t wm)
{
    const uint32_t f = t->first, l = t->last;
    uint32_t mid = 0u;
    for (uint32_t k = f + 1u; k < l; k++) {
        mid += row[k];
    }
    return (uint32_t)t->wf * row[f] + wm * mid + (uint32_t)t->wl * row[l];
}

// The taps of consecutive outputs i, i+1, ... along one axis without a
// division per output (tap_at divides two or three times): the same values
// as tap_at, stepped. Shrinking: lo = i*S, k = floor(lo / D) found by
// stepping (k only grows: O(S/D + 1) steps per output). Growing: p = (2i+1)*S
// - D = 2D*k + frac with floor semantics (k = -1 while p < 0); p grows by
// 2S < 2D per output, so frac wraps at most once.
typedef struct tap_iter {
    uint32_t s, d;
    uint32_t lo;    // shrinking: i*S
    int32_t k;      // shrinking: floor(lo / D); growing: floor(p / 2D)
    uint32_t frac;  // growing: p - 2D*k, in [0, 2D)
} tap_iter_t;

static void tap_iter_init(tap_iter_t *it, uint32_t i0, uint32_t s, uint32_t d)
{
    it->s = s;
    it->d = d;
    it->lo = i0 * s;   // < 2^13 * 2^12
    if (s >= d) {
        it->k = (int32_t)(it->lo / d);
        it->frac = 0u;
        return;
    }
    const uint32_t pp = (2u * i0 + 1u) * s;   // p + D >= S > 0
    if (pp >= d) {
        it->k = (int32_t)((pp - d) / (2u * d));
        it->frac = (pp - d) % (2u * d);
    } else {
        it->k = -1;   // -D < p < 0
        it->frac = pp + d;
    }
}

static void tap_next(tap_iter_t *it, tap_t *t)
{
    const uint32_t s = it->s, d = it->d;
    if (s >= d) {
        const uint32_t lo = it->lo, hi = lo + s;
        uint32_t k = (uint32_t)it->k;
        // Both indices stay below S (lo < hi <= S*D): explicit bounds.
        while (k + 1u < s && (k + 1u) * d <= lo) {   // < S/D + 1 steps
            k++;
        }
        uint32_t l = k;
        while (l + 1u < s && (l + 1u) * d < hi) {    // last = floor((hi - 1) / D)
            l++;
        }
        const uint32_t b = (k + 1u) * d;
        t->first = (uint16_t)k;
        t->last = (uint16_t)l;
        t->wf = (uint16_t)((b < hi ? b : hi) - lo);
        t->wl = (uint16_t)(l > k ? hi - l * d : 0u);
        it->lo = hi;
        it->k = (int32_t)l;
        return;
    }
    const uint32_t two_d = 2u * d;
    const int32_t k = it->k;
    const uint32_t frac = it->frac;
    if (k < 0 || (k == 0 && frac == 0u)) {             // p <= 0: pixel 0
        t->first = t->last = 0u;
        t->wf = (uint16_t)two_d;
        t->wl = 0u;
    } else if ((uint32_t)k >= s - 1u) {                // past the last pixel
        t->first = t->last = (uint16_t)(s - 1u);
        t->wf = (uint16_t)two_d;
        t->wl = 0u;
    } else {
        t->first = (uint16_t)k;
        t->last = (uint16_t)(frac == 0u ? (uint32_t)k : (uint32_t)k + 1u);
        t->wf = (uint16_t)(two_d - frac);
        t->wl = (uint16_t)(frac == 0u ? 0u : frac);
    }
    it->frac = frac + 2u * s;
    if (it->frac >= two_d) {
        it->frac -= two_d;
        it->k = k + 1;
    }
}

// tap_sum over a row of column sums (the vertical-first order below).
static inline uint32_t tap_sum32(const uint32_t *v, const tap_t *t, uint32_t wm)
{
    const uint32_t f = t->first, l = t->last;
    uint32_t mid = 0u;
    for (uint32_t k = f + 1u; k < l; k++) {
        mid += v[k];
    }
    return (uint32_t)t->wf * v[f] + wm * mid + (uint32_t)t->wl * v[l];
}

// The divisor of the narrow path's quotients: total's half, and either its
// log2 (pow2: total a power of two) or its reciprocal.
typedef struct quot {
    uint32_t half;
    bool pow2;
    uint32_t sh_pow2;
    vd_recip256_t rc;
} quot_t;

// out[i] = rounded acc[i] / total for i < n (acc[i] + half < 2^32).
static void narrow_quot(const uint32_t *restrict acc, uint8_t *restrict out, uint32_t n, const quot_t *q)
{
    const uint32_t half = q->half;
    if (q->pow2) {
        const uint32_t sh_pow2 = q->sh_pow2;
        for (uint32_t i = 0u; i < n; i++) {
            out[i] = (uint8_t)((acc[i] + half) >> sh_pow2);
        }
    } else {
        const uint32_t m = q->rc.m, k = q->rc.k;
        for (uint32_t i = 0u; i < n; i++) {
            out[i] = (uint8_t)vd_recip256_div32(m, k, acc[i] + half);
        }
    }
}

// Output columns of the narrow path (below) whose taps are tabled at once:
// the detector's 32-wide samples are one chunk (stack: 8 + 4 + 4 bytes each).
#define NCHUNK 32u
// Largest horizontal weight total of the narrow path: a row sum
// sum_k wx(k) * row[k] <= tot_x * 255 then fits 16 bits.
#define NARROW_TOT_X 257u

// The narrow path: tot_x <= NARROW_TOT_X (row sums fit uint16) and
// total <= 2^23 (sums fit uint32, reciprocal exact), i.e. the candidate
// regions the detector samples. The same sums and quotients as the wide
// path below, in 16/32-bit lanes: the row sums' multiply-add by the y weight
// is a 16x16->32 multiply and the quotient one 32x32->64 multiply (a shift
// when the total is a power of two, as for two growing axes of power-of-two
// sizes: tot = 2D each), so the compiler vectorises both loops.
// The narrow path, vertical first: more source rows than output rows
// (shrinking y) and a narrow ROI (sw, dst_w <= NCHUNK).
static void narrow_vfirst(const uint8_t *base, size_t stride, uint32_t sw, uint32_t sh, uint8_t *dst, uint32_t dst_w,
                          uint32_t dst_h, const quot_t *qt)
{
    tap_t tx[NCHUNK];
    uint32_t acc[NCHUNK];
    // Each output row sums its y taps per source column (vectorised), then
    // takes its x taps of those column sums: dst_w x-tap sums per output row
    // instead of per source row. Column sums <= tot_y * 255, x-tap sums <=
    // total * 255 < 2^31. Output rows in pairs: the x taps' loads and loop
    // are shared by the pair's two gathers (the costliest part here).
    uint32_t vs[2][NCHUNK];
    uint32_t acc1[NCHUNK];
    tap_iter_t it;
    tap_iter_init(&it, 0u, sw, dst_w);
    for (uint32_t i = 0u; i < dst_w; i++) {
        tap_next(&it, &tx[i]);
    }
    tap_iter_init(&it, 0u, sh, dst_h);
    for (uint32_t oy = 0u; oy < dst_h; oy += 2u) {
        const uint32_t nr = dst_h - oy >= 2u ? 2u : 1u;
        for (uint32_t k = 0u; k < nr; k++) {
            tap_t ty;
            tap_next(&it, &ty);
            uint32_t *v = vs[k];
            const uint8_t *row = base + (size_t)ty.first * stride;
            const uint32_t wf = ty.wf;
            for (uint32_t x = 0u; x < sw; x++) {
                v[x] = wf * row[x];
            }
            for (uint32_t ky = ty.first + 1u; ky <= ty.last; ky++) {
                const uint32_t wy = ky == ty.last ? ty.wl : dst_h;
                row = base + (size_t)ky * stride;
                for (uint32_t x = 0u; x < sw; x++) {
                    v[x] += wy * row[x];
                }
            }
        }
        if (nr == 2u) {
            const uint32_t *v0 = vs[0], *v1 = vs[1];
            for (uint32_t i = 0u; i < dst_w; i++) {
                const uint32_t f = tx[i].first, l = tx[i].last;
                const uint32_t wf = tx[i].wf, wl = tx[i].wl;
                uint32_t mid0 = 0u, mid1 = 0u;
                for (uint32_t k = f + 1u; k < l; k++) {
                    mid0 += v0[k];
                    mid1 += v1[k];
                }
                acc[i] = wf * v0[f] + dst_w * mid0 + wl * v0[l];
                acc1[i] = wf * v1[f] + dst_w * mid1 + wl * v1[l];
            }
            narrow_quot(acc, dst + (size_t)oy * dst_w, dst_w, qt);
            narrow_quot(acc1, dst + (size_t)(oy + 1u) * dst_w, dst_w, qt);
        } else {
            for (uint32_t i = 0u; i < dst_w; i++) {
                acc[i] = tap_sum32(vs[0], &tx[i], dst_w);
            }
            narrow_quot(acc, dst + (size_t)oy * dst_w, dst_w, qt);
        }
    }
}

// The narrow path, horizontal first (every other narrow ROI).
static void narrow_hfirst(const uint8_t *base, size_t stride, uint32_t sw, uint32_t sh, uint8_t *dst, uint32_t dst_w,
                          uint32_t dst_h, const quot_t *qt)
{
    tap_t tx[NCHUNK];
    uint32_t acc[NCHUNK];
    // Row sums cached by source row pairs (2q, 2q+1) in two slots (q & 1):
    // an output row reads at most two consecutive pairs when its taps span
    // <= 3 rows, and rows are visited in increasing order, so every pair is
    // computed once per chunk. A pair shares the x taps' loads and loop
    // between its two rows (the gather is the costliest part here).
    uint16_t hs[2][2][NCHUNK];
    uint32_t hs_pair[2];
    for (uint32_t cx = 0u; cx < dst_w; cx += NCHUNK) {
        const uint32_t nx = dst_w - cx < NCHUNK ? dst_w - cx : NCHUNK;
        tap_iter_t it;
        tap_iter_init(&it, cx, sw, dst_w);
        for (uint32_t i = 0u; i < nx; i++) {
            tap_next(&it, &tx[i]);
        }
        hs_pair[0] = hs_pair[1] = UINT32_MAX;
        tap_iter_init(&it, 0u, sh, dst_h);
        for (uint32_t oy = 0u; oy < dst_h; oy++) {
            tap_t ty;
            tap_next(&it, &ty);
            for (uint32_t ky = ty.first; ky <= ty.last; ky++) {
                // wy <= tot_y <= 8192: uint16.
                const uint16_t wy = ky == ty.first ? ty.wf : (ky == ty.last ? ty.wl : (uint16_t)dst_h);
                const uint32_t q = ky >> 1, slot = q & 1u;
                if (hs_pair[slot] != q) {
                    const uint8_t *r0 = base + (size_t)(2u * q) * stride;
                    uint16_t *o0 = hs[slot][0], *o1 = hs[slot][1];
                    if (2u * q + 1u < sh) {
                        const uint8_t *r1 = r0 + stride;
                        for (uint32_t i = 0u; i < nx; i++) {
                            const uint32_t f = tx[i].first, l = tx[i].last;
                            const uint32_t wf = tx[i].wf, wl = tx[i].wl;
                            uint32_t mid0 = 0u, mid1 = 0u;
                            for (uint32_t k = f + 1u; k < l; k++) {
                                mid0 += r0[k];
                                mid1 += r1[k];
                            }
                            // <= tot_x * 255 < 2^16
                            o0[i] = (uint16_t)(wf * r0[f] + dst_w * mid0 + wl * r0[l]);
                            o1[i] = (uint16_t)(wf * r1[f] + dst_w * mid1 + wl * r1[l]);
                        }
                    } else {
                        for (uint32_t i = 0u; i < nx; i++) {
                            o0[i] = (uint16_t)tap_sum(r0, &tx[i], dst_w);
                        }
                    }
                    hs_pair[slot] = q;
                }
                const uint16_t *h = hs[slot][ky & 1u];
                // acc <= total * 255 < 2^31.
                if (ky == ty.first) {
                    for (uint32_t i = 0u; i < nx; i++) {
                        acc[i] = (uint32_t)wy * h[i];
                    }
                } else {
                    for (uint32_t i = 0u; i < nx; i++) {
                        acc[i] += (uint32_t)wy * h[i];
                    }
                }
            }
            narrow_quot(acc, dst + (size_t)oy * dst_w + cx, nx, qt);
        }
    }
}

static void resample_narrow(const uint8_t *base, size_t stride, uint32_t sw, uint32_t sh, uint8_t *dst,
                            uint32_t dst_w, uint32_t dst_h, uint32_t total)
{
    quot_t q;
    q.half = total / 2u;
    (void)vd_recip256_init(total, &q.rc);   // total <= 2^23: never fails
    q.sh_pow2 = 0u;                         // log2(total) when total is a power of two
    while (q.sh_pow2 < 23u && (1u << q.sh_pow2) < total) {
        q.sh_pow2++;
    }
    q.pow2 = (1u << q.sh_pow2) == total;
    if (sh > dst_h && sw <= NCHUNK && dst_w <= NCHUNK) {
        narrow_vfirst(base, stride, sw, sh, dst, dst_w, dst_h, &q);
    } else {
        narrow_hfirst(base, stride, sw, sh, dst, dst_w, dst_h, &q);
    }
}

vd_status_t vd_resample_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint8_t *dst,
                           uint32_t dst_w, uint32_t dst_h)
{
    vd_rect_t r;
    VD_VERIFY(dst != NULL, VD_ERR_ARG);
    VD_VERIFY(dst_w >= 1u && dst_w <= VD_RESAMPLE_MAX_DST, VD_ERR_ARG);
    VD_VERIFY(dst_h >= 1u && dst_h <= VD_RESAMPLE_MAX_DST, VD_ERR_ARG);
    VD_TRY(vd_view_u8_check(src));
    VD_TRY(vd_rect_roi_resolve(roi, src->width, src->height, &r));

    const uint32_t sw = (uint32_t)r.w;
    const uint32_t sh = (uint32_t)r.h;
    const uint8_t *base = src->data + (size_t)r.y * src->stride + (size_t)r.x;
    // Weight totals and inner weights are the same for every output.
    const uint32_t tot_x = sw >= dst_w ? sw : 2u * dst_w;
    const uint32_t tot_y = sh >= dst_h ? sh : 2u * dst_h;
    const uint32_t wm_x = dst_w;   // inner taps exist only on a shrinking axis
    const uint32_t wm_y = dst_h;
    const uint64_t total = (uint64_t)tot_x * tot_y;   // <= 2^26
    if (tot_x <= NARROW_TOT_X && total <= VD_RECIP256_MAX_DIV) {
        resample_narrow(base, src->stride, sw, sh, dst, dst_w, dst_h, (uint32_t)total);
        return VD_OK;
    }
    const uint64_t half = total / 2u;
    // Rounded quotient < 256: reciprocal multiply when the total allows it
    // (regions up to 2^23 pixels), else one division per output.
    vd_recip256_t rc;
    const bool use_recip = vd_recip256_init((uint32_t)total, &rc);

    tap_t tx[XCHUNK];
    // Horizontal sums of the last two source rows computed (a source row is
    // shared by consecutive output rows: always when the y axis grows, at
    // the boundaries when it shrinks), and the output row's accumulators.
    uint32_t hs[2][XCHUNK];
    uint32_t hs_row[2];
    uint64_t acc[XCHUNK];
    for (uint32_t cx = 0u; cx < dst_w; cx += XCHUNK) {
        const uint32_t nx = dst_w - cx < XCHUNK ? dst_w - cx : XCHUNK;
        for (uint32_t i = 0u; i < nx; i++) {
            tap_at(cx + i, sw, dst_w, &tx[i]);
        }
        hs_row[0] = hs_row[1] = UINT32_MAX;   // nothing cached (rows < 8192)
        uint32_t victim = 0u;
        for (uint32_t oy = 0u; oy < dst_h; oy++) {
            tap_t ty;
            tap_at(oy, sh, dst_h, &ty);
            for (uint32_t ky = ty.first; ky <= ty.last; ky++) {
                const uint32_t wy = ky == ty.first ? ty.wf : (ky == ty.last ? ty.wl : wm_y);
                const uint32_t *h;
                if (hs_row[0] == ky) {
                    h = hs[0];
                } else if (hs_row[1] == ky) {
                    h = hs[1];
                } else {
                    // Compute into the slot not used last.
                    const uint8_t *row = base + (size_t)ky * src->stride;
                    uint32_t *o = hs[victim];
                    for (uint32_t i = 0u; i < nx; i++) {
                        o[i] = tap_sum(row, &tx[i], wm_x);
                    }
                    hs_row[victim] = ky;
                    h = o;
                    victim ^= 1u;
                }
                if (ky == ty.first) {   // (no separate clearing pass)
                    for (uint32_t i = 0u; i < nx; i++) {
                        acc[i] = (uint64_t)wy * h[i];
                    }
                } else {
                    for (uint32_t i = 0u; i < nx; i++) {
                        acc[i] += (uint64_t)wy * h[i];
                    }
                }
            }
            uint8_t *out = dst + (size_t)oy * dst_w + cx;
            if (use_recip) {
                for (uint32_t i = 0u; i < nx; i++) {
                    const uint32_t q = vd_recip256_div(&rc, acc[i] + half);
                    VD_ASSERT(q <= 255u);
                    out[i] = (uint8_t)q;
                }
            } else {
                for (uint32_t i = 0u; i < nx; i++) {
                    const uint64_t q = (acc[i] + half) / total;
                    VD_ASSERT(q <= 255u);
                    out[i] = (uint8_t)q;
                }
            }
        }
    }
    return VD_OK;
}

// The grey map of the three loops below: inline where speed is asked for (a call into calib.c per output
// pixel was half the cost of a 16-bit frame's rows), the library's one copy under -Os (an inline copy cost a
// Cortex-M0+ 126 B of its 64 KiB).
static uint8_t grey_of(const vd_calib_grey_t *grey, uint32_t raw)
{
#if defined(__OPTIMIZE_SIZE__)
    return vd_calib_grey_u8(grey, (uint16_t)raw);
#else
    return vd__calib_grey_u8(grey, raw);
#endif
}

#ifndef __OPTIMIZE_SIZE__
// The CNN's quarter-resolution rows (cfg.cnn_res QUARTER, 8-bit), made for every pass of every frame:
// the general loop (box_any), with its 64-bit sum and division, cost ~14 instructions per frame pixel
// (callgrind, 1280 x 1024 frames: 174.1 -> 107.5 M per frame with this loop). Same rounding,
// (sum + 8) >> 4. Size-optimised builds (the Cortex-M0+ budget) take the general loop: the same bytes.
static void box4_u8(const uint8_t *data, size_t stride, const vd_rect_t *r, vd_image_u8_t *dst)
{
    const size_t out_w = dst->width;
    for (uint32_t cy = 0; cy < dst->height; cy++) {
        const uint8_t *a = data + ((size_t)r->y + 4u * (size_t)cy) * stride + (size_t)r->x;
        uint8_t *out = dst->data + (size_t)cy * dst->stride;
        for (size_t cx = 0; cx < out_w; cx++) {
            uint32_t sum = 8u;
            for (size_t j = 0; j < 4u; j++) {
                const uint8_t *q = a + j * stride + 4u * cx;
                sum += (uint32_t)q[0] + q[1] + q[2] + q[3];
            }
            out[cx] = (uint8_t)(sum >> 4);
        }
    }
}
#endif

// Any kx x ky block: a 64-bit sum and one rounded division per output (box_average takes the CNN's
// 1 x 1, 2 x 2 and 4 x 4 rows in loops of their own).
static void box_any(const uint8_t *data, size_t stride, bool wide, const vd_rect_t *r, uint32_t kx, uint32_t ky,
                    const vd_calib_grey_t *grey, vd_image_u8_t *dst)
{
    const uint32_t n = kx * ky;
    for (uint32_t cy = 0; cy < dst->height; cy++) {
        uint8_t *out = dst->data + (size_t)cy * dst->stride;
        for (uint32_t cx = 0; cx < dst->width; cx++) {
            uint64_t sum = 0u;
            const size_t x0 = (size_t)r->x + (size_t)cx * kx;
            const size_t y0 = (size_t)r->y + (size_t)cy * ky;
            for (uint32_t j = 0; j < ky; j++) {
                const uint8_t *row = data + (y0 + j) * stride;
                for (uint32_t i = 0; i < kx; i++) {
                    if (wide) {
                        uint16_t v;
                        memcpy(&v, row + 2u * (x0 + i), sizeof(v));
                        sum += v;
                    } else {
                        sum += row[x0 + i];
                    }
                }
            }
            const uint32_t avg = (uint32_t)((sum + n / 2u) / n);
            out[cx] = wide ? grey_of(grey, avg) : (uint8_t)avg;
        }
    }
}

// Box average of the ROI r of a plane of 1 (wide false) or 2 (wide true)
// bytes per pixel into dst; 16-bit means are mapped through grey.
static void box_average(const uint8_t *data, size_t stride, bool wide, const vd_rect_t *r, uint32_t kx,
                        uint32_t ky, const vd_calib_grey_t *grey, vd_image_u8_t *dst)
{
    if (kx == 1u && ky == 1u) {
        // A 1 x 1 box is the pixel: the CNN's full-resolution rows (cfg.cnn_res FULL), made for every pass
        // of every frame, where the general loop (box_any) spent ~170 instructions per pixel (callgrind).
        for (uint32_t cy = 0; cy < dst->height; cy++) {
            const uint8_t *row = data + ((size_t)r->y + cy) * stride;
            uint8_t *out = dst->data + (size_t)cy * dst->stride;
            if (!wide) {
                memcpy(out, row + (size_t)r->x, dst->width);
                continue;
            }
            const uint16_t *px = (const uint16_t *)(const void *)row + r->x;   // aligned: vd_view_u16_check
            for (uint32_t cx = 0; cx < dst->width; cx++) {
                out[cx] = grey_of(grey, px[cx]);
            }
        }
        return;
    }
    if (kx == 2u && ky == 2u && wide) {
        // The CNN's half-resolution rows of a 16-bit frame (every pass of every frame): the general loop
        // (box_any) and a call per output into calib.c cost ~180 instructions per output pixel (callgrind,
        // 640 x 512 raw counts). Same sums and rounding, (sum + 2) >> 2, and the same map inline.
        const size_t out_w = dst->width;
        for (uint32_t cy = 0; cy < dst->height; cy++) {
            const uint8_t *row = data + ((size_t)r->y + 2u * (size_t)cy) * stride;
            const uint16_t *a = (const uint16_t *)(const void *)row + r->x;   // aligned: vd_view_u16_check
            const uint16_t *b = (const uint16_t *)(const void *)(row + stride) + r->x;
            uint8_t *out = dst->data + (size_t)cy * dst->stride;
            for (size_t cx = 0; cx < out_w; cx++) {
                const uint32_t sum = (uint32_t)a[2u * cx] + a[2u * cx + 1u] + b[2u * cx] + b[2u * cx + 1u];
                out[cx] = grey_of(grey, (sum + 2u) >> 2);
            }
        }
        return;
    }
    if (kx == 2u && ky == 2u && !wide) {
        // The CNN's half-resolution rows, made for every pass of every frame:
        // the general loop (box_any) cost ~160 instructions per output pixel. Same
        // rounding, (sum + n / 2) / n = (sum + 2) >> 2; a loop compilers vectorise
        // given size_t indices and the width in a local (with uint32_t 2 cx, which may
        // wrap, and dst->width reread after each byte store, gcc 12 -O3 kept it
        // scalar: 17 instructions per pixel, callgrind).
        const size_t out_w = dst->width;
        for (uint32_t cy = 0; cy < dst->height; cy++) {
            const uint8_t *a = data + ((size_t)r->y + 2u * (size_t)cy) * stride + (size_t)r->x;
            const uint8_t *b = a + stride;
            uint8_t *out = dst->data + (size_t)cy * dst->stride;
            size_t cx = 0;
#if defined(__ARM_FEATURE_SIMD32) && defined(__ARM_FEATURE_UNALIGNED) && defined(__GNUC__)
            // Armv7E-M (Cortex-M4/M7; also Armv7-A): four outputs from two words of each row. UXTB16 /
            // UXTAB16 (ROR #8) add the bytes of a pair into one 16-bit lane (a lane's sum <= 4 * 255 + 2
            // never carries into the next), then +2, >> 2 and PKHBT pack the four bytes: ~22 instructions
            // per four outputs against ~36 for the plain-C SWAR form gcc 12 made of the same arithmetic
            // (mps2-an500: these rows are made twice per frame of vd_cnn_compact, for the percentile
            // histogram and for the network). Assembly, not <arm_acle.h>: lib/'s include rule; the masks
            // and the rounding constant in registers, which ARM as well as Thumb-2 encodings take.
            const uint32_t m = 0x00FF00FFu;   // bytes 0 and 2 of a word, one per 16-bit lane
            const uint32_t k2 = 0x00020002u;  // the rounding 2 in both lanes
            for (; cx + 4u <= out_w; cx += 4u) {
                uint32_t w0, w1, w2, w3, lo, hi;
                memcpy(&w0, a + 2u * cx, 4u);
                memcpy(&w1, a + 2u * cx + 4u, 4u);
                memcpy(&w2, b + 2u * cx, 4u);
                memcpy(&w3, b + 2u * cx + 4u, 4u);
                // lo lanes: outputs 0 and 1 (bytes 0+1 and 2+3 of w0 and w2); hi: outputs 2 and 3.
                __asm__("uxtb16 %[lo], %[w0]\n\t"
                        "uxtab16 %[lo], %[lo], %[w0], ror #8\n\t"
                        "uxtab16 %[lo], %[lo], %[w2]\n\t"
                        "uxtab16 %[lo], %[lo], %[w2], ror #8\n\t"
                        "uxtb16 %[hi], %[w1]\n\t"
                        "uxtab16 %[hi], %[hi], %[w1], ror #8\n\t"
                        "uxtab16 %[hi], %[hi], %[w3]\n\t"
                        "uxtab16 %[hi], %[hi], %[w3], ror #8\n\t"
                        "add %[lo], %[lo], %[k2]\n\t"
                        "add %[hi], %[hi], %[k2]\n\t"
                        "and %[lo], %[m], %[lo], lsr #2\n\t"      // o0 | o1 << 16
                        "and %[hi], %[m], %[hi], lsr #2\n\t"      // o2 | o3 << 16
                        "orr %[lo], %[lo], %[lo], lsr #8\n\t"     // low half o0 | o1 << 8
                        "orr %[hi], %[hi], %[hi], lsr #8\n\t"
                        "pkhbt %[lo], %[lo], %[hi], lsl #16"
                        : [lo] "=&r"(lo), [hi] "=&r"(hi)
                        : [w0] "r"(w0), [w1] "r"(w1), [w2] "r"(w2), [w3] "r"(w3), [m] "r"(m), [k2] "r"(k2));
                memcpy(out + cx, &lo, 4u);
            }
#endif
            for (; cx < out_w; cx++) {
                const uint32_t sum = (uint32_t)a[2u * cx] + a[2u * cx + 1u] + b[2u * cx] + b[2u * cx + 1u];
                out[cx] = (uint8_t)((sum + 2u) >> 2);
            }
        }
        return;
    }
#ifndef __OPTIMIZE_SIZE__
    if (kx == 4u && ky == 4u && !wide) {
        box4_u8(data, stride, r, dst);
        return;
    }
#endif
    box_any(data, stride, wide, r, kx, ky, grey, dst);
}

// Checks shared by both formats: factors, and dst of the decimated ROI size.
static vd_status_t box_check(const vd_rect_t *r, uint32_t kx, uint32_t ky, const vd_image_u8_t *dst)
{
    VD_VERIFY(kx >= 1u && ky >= 1u && kx <= (uint32_t)r->w && ky <= (uint32_t)r->h, VD_ERR_ARG);
    VD_TRY(vd_image_u8_check(dst));
    VD_VERIFY(dst->width == (uint32_t)r->w / kx && dst->height == (uint32_t)r->h / ky, VD_ERR_ARG);
    return VD_OK;
}

vd_status_t vd_resample_box_u8(const vd_view_u8_t *src, const vd_rect_t *roi, uint32_t kx, uint32_t ky,
                               vd_image_u8_t *dst)
{
    vd_rect_t r;
    VD_TRY(vd_view_u8_check(src));
    VD_TRY(vd_rect_roi_resolve(roi, src->width, src->height, &r));
    VD_TRY(box_check(&r, kx, ky, dst));
    box_average(src->data, src->stride, false, &r, kx, ky, NULL, dst);
    return VD_OK;
}

vd_status_t vd_resample_box_u16(const vd_view_u16_t *src, const vd_rect_t *roi, uint32_t kx, uint32_t ky,
                                const vd_calib_grey_t *grey, vd_image_u8_t *dst)
{
    vd_rect_t r;
    VD_VERIFY(grey != NULL, VD_ERR_ARG);
    VD_TRY(vd_view_u16_check(src));
    VD_TRY(vd_rect_roi_resolve(roi, src->width, src->height, &r));
    VD_TRY(box_check(&r, kx, ky, dst));
    box_average((const uint8_t *)(const void *)src->data, src->stride, true, &r, kx, ky, grey, dst);
    return VD_OK;
}
