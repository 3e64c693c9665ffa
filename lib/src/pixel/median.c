// SPDX-License-Identifier: MIT
// 3x3 and 5x5 median filters on 8-bit regions with replicated borders (cv2.medianBlur semantics).
//
// Algorithm: min/max selection networks evaluated for a block of adjacent
// output pixels at once. Each block loop has a constant trip count and
// straight-line min/max code over restrict-qualified rows, so gcc -O2 and
// clang turn it into SIMD (pminub/pmaxub, umin/umax) without intrinsics;
// scalar targets run the same code one pixel at a time.
//  3x3 ("sorted rows", Paeth/Smith): median of 9 = med3(max of the 3 row
//       minima, med3 of the 3 row medians, min of the 3 row maxima), each
//       input row triple sorted horizontally (6 min/max). Eight output rows
//       are done together from 10 input rows, the pairs of rows that two
//       outputs share combined once: 17.5 min/max per pixel, in registers
//       (spills of carried values go to the load/store ports).
//  5x5: output rows in pairs: per input column the four rows both outputs
//       share are sorted once (5 exchanges) and the top / bottom row is
//       inserted for each (4+4 min/max: 13 per pixel against 18 for a
//       9-exchange column sort). Outputs are then taken in pairs (x, x+1),
//       x even, which share the columns x+1 .. x+4: the sorted columns are
//       split into even and odd ones (so a pair is one SIMD lane), the
//       column pairs (x+1, x+2) are merged into sorted 10-lists once
//       (Batcher odd-even merge, 26 min/max per output pair), the union of
//       the pairs (x+1, x+2) and (x+3, x+4) is merged once, pruned to the
//       ranks 8..13 used, and each output takes the 13th smallest of that
//       and its own column, kth(A u B) = min over i+j=k of max(A_i, B_j)
//       (56 min/max per output pair). 13 + 13 + 28 = 54 min/max per pixel
//       against 134 when each output merged its own two pairs, and 198 for
//       a 99-exchange full median-of-25 network. The networks are generated
//       and checked exhaustively by the 0-1 principle in
//       tools/vdtools/generators/median_network.py (the pair merge) and
//       tools/vdtools/generators/median5_net.py (select_pair);
//       tests/python/test_median.py keeps this file equal to the
//       generators' output.
// Borders: row indices and column indices are clamped to the image
// (BORDER_REPLICATE, what cv2.medianBlur uses); pixels outside the ROI but
// inside the image are used. Blocks are always placed inside the image (the
// last block of a row overlaps the previous one: identical values); the
// 3x3 computes the image's first and last columns by a scalar path, the 5x5
// replicates the sorted edge column (a replicated column sorts the same).
// Images narrower than a block (+ border) take the scalar paths.
// Reference: cv2.medianBlur (OpenCV imgproc median_blur), bit-exact.
// Bounds: time O(roi.w * roi.h) (about 17.5 / 54 min-max per pixel); no
// workspace; stack (stack budget of vd_detector_run, docs/embedded.md): 3x3
// a 2 x 64-byte buffer for ROIs narrower than a block; 5x5 two rows' sorted
// columns, their even/odd split, a pair table and an output strip (S5
// below: ~3 KiB on SIMD hosts, ~200 bytes on scalar targets); both under
// 512 bytes on Cortex-M7
// (worst case with callees, -Os: docs/embedded.md).
#include <string.h>

#include "vd/median.h"
#include "internal/vd_internal.h"

#define VD_MIN8(a, b) ((uint8_t)((a) < (b) ? (a) : (b)))
#define VD_MAX8(a, b) ((uint8_t)((a) < (b) ? (b) : (a)))

// Common checks: valid views, ROI inside src, dst exactly ROI-sized.
static vd_status_t median_args(const vd_view_u8_t *src, const vd_rect_t *roi, const vd_image_u8_t *dst, vd_rect_t *r)
{
    VD_TRY(vd_view_u8_check(src));
    VD_TRY(vd_rect_roi_resolve(roi, src->width, src->height, r));
    VD_TRY(vd_image_u8_check(dst));
    VD_VERIFY(dst->width == (uint32_t)r->w && dst->height == (uint32_t)r->h, VD_ERR_ARG);
    return VD_OK;
}

static const uint8_t *row_at(const vd_view_u8_t *src, int32_t y)
{
    const int32_t h = (int32_t)src->height;
    y = y < 0 ? 0 : (y >= h ? h - 1 : y);
    return src->data + (size_t)y * src->stride;
}

// ---- 3x3 ------------------------------------------------------------------
// Outputs per block of the 3x3 kernels: a multiple of every SIMD width in use
// (16 / 32 bytes) so gcc -O2 (very-cheap cost model: no scalar epilogue) and
// clang both turn the constant-count loops into whole vectors.
#define BLK3 64

// Sorts the horizontal triple r[i], r[i+1], r[i+2] (r points one column left
// of the output; constant offsets from one base let gcc address all three
// with one register) into lo <= mid <= hi.
// Loaded highest index first: in the other order clang 14 forwards r[i+2] of
// one iteration as r[i+1] of the next (a loop-carried value) and then does
// not vectorise the loop at all (16x slower); gcc does not care.
#define HSORT3(r, i, lo, mid, hi)                                                  \
    do {                                                                           \
        const uint8_t c_ = (r)[(i) + 2], b_ = (r)[(i) + 1], a_ = (r)[i];           \
        const uint8_t n_ = VD_MIN8(a_, b_), x_ = VD_MAX8(a_, b_);                  \
        lo = VD_MIN8(n_, c_);                                                      \
        hi = VD_MAX8(x_, c_);                                                      \
        mid = VD_MAX8(n_, VD_MIN8(x_, c_));                                        \
    } while (0)

// med3(a, b, c) in 4 min/max.
#define MED3(a, b, c) VD_MAX8(VD_MIN8(a, b), VD_MIN8(VD_MAX8(a, b), c))

// Two output rows (o0: rows r0 r1 r2, o1: rows r1 r2 r3) for BLK3 columns.
// r_k point one column left of the block's first output; BLK3 + 2 columns are read.
// Each row is sorted horizontally once (6 min/max), the pair r1/r2 that
// both outputs share is combined once (4), each output adds its own row (4)
// and takes med3(max of lows, med3 of mids, min of highs) (4): 16 min/max
// per pixel, all in registers (no stack buffers: stack budget, and no
// store-to-load forwarding stalls on shifted reloads).
static void med3_rows2(const uint8_t *restrict r0, const uint8_t *restrict r1, const uint8_t *restrict r2,
                       const uint8_t *restrict r3, uint8_t *restrict o0, uint8_t *restrict o1)
{
    for (size_t i = 0; i < BLK3; i++) {
        uint8_t l0, m0, h0, l1, m1, h1, l2, m2, h2, l3, m3, h3;
        HSORT3(r0, i, l0, m0, h0);
        HSORT3(r1, i, l1, m1, h1);
        HSORT3(r2, i, l2, m2, h2);
        HSORT3(r3, i, l3, m3, h3);
        const uint8_t l12 = VD_MAX8(l1, l2), h12 = VD_MIN8(h1, h2);
        const uint8_t mn12 = VD_MIN8(m1, m2), mx12 = VD_MAX8(m1, m2);
        const uint8_t la = VD_MAX8(l12, l0), ha = VD_MIN8(h12, h0), ma = VD_MAX8(mn12, VD_MIN8(mx12, m0));
        const uint8_t lb = VD_MAX8(l12, l3), hb = VD_MIN8(h12, h3), mb = VD_MAX8(mn12, VD_MIN8(mx12, m3));
        o0[i] = MED3(la, ma, ha);
        o1[i] = MED3(lb, mb, hb);
    }
}

// Four output rows (o_k: rows r_k .. r_k+2) for BLK3 columns: 6 row sorts for
// 4 outputs (9 per output in the 2-row kernel's terms: 19 min/max per pixel
// -> 14.5 with the pairs r1/r2 and r3/r4 shared).
static void med3_rows4(const uint8_t *restrict r0, const uint8_t *restrict r1, const uint8_t *restrict r2,
                       const uint8_t *restrict r3, const uint8_t *restrict r4, const uint8_t *restrict r5,
                       uint8_t *restrict o0, uint8_t *restrict o1, uint8_t *restrict o2, uint8_t *restrict o3)
{
    for (size_t i = 0; i < BLK3; i++) {
        // Source order keeps few values live at once (gcc -O2 allocates
        // registers in this order: 16 xmm registers on x86-64, else spills).
        uint8_t l0, m0, h0, l1, m1, h1, l2, m2, h2, l3, m3, h3, l4, m4, h4, l5, m5, h5;
        HSORT3(r1, i, l1, m1, h1);
        HSORT3(r2, i, l2, m2, h2);
        const uint8_t l12 = VD_MAX8(l1, l2), h12 = VD_MIN8(h1, h2);
        const uint8_t mn12 = VD_MIN8(m1, m2), mx12 = VD_MAX8(m1, m2);
        HSORT3(r0, i, l0, m0, h0);
        const uint8_t la = VD_MAX8(l12, l0), ha = VD_MIN8(h12, h0), ma = VD_MAX8(mn12, VD_MIN8(mx12, m0));
        o0[i] = MED3(la, ma, ha);
        HSORT3(r3, i, l3, m3, h3);
        const uint8_t lb = VD_MAX8(l12, l3), hb = VD_MIN8(h12, h3), mb = VD_MAX8(mn12, VD_MIN8(mx12, m3));
        o1[i] = MED3(lb, mb, hb);
        HSORT3(r4, i, l4, m4, h4);
        const uint8_t l34 = VD_MAX8(l3, l4), h34 = VD_MIN8(h3, h4);
        const uint8_t mn34 = VD_MIN8(m3, m4), mx34 = VD_MAX8(m3, m4);
        const uint8_t lc = VD_MAX8(l34, l2), hc = VD_MIN8(h34, h2), mc = VD_MAX8(mn34, VD_MIN8(mx34, m2));
        o2[i] = MED3(lc, mc, hc);
        HSORT3(r5, i, l5, m5, h5);
        const uint8_t ld = VD_MAX8(l34, l5), hd = VD_MIN8(h34, h5), md = VD_MAX8(mn34, VD_MIN8(mx34, m5));
        o3[i] = MED3(ld, md, hd);
    }
}

// Eight output rows (o_k: rows r_k .. r_k+2) for BLK3 columns: med3_rows4's
// sequence continued for two more row pairs, 10 row sorts for 8 outputs
// (17.5 min/max per pixel against 19). The min/max units are the limit of
// this kernel (SSE2: 16 lanes; ~9.5 cycles per 16 pixels at 19), so fewer
// operations is directly fewer cycles; the sorted rows carried from one pair
// to the next may spill, but loads and stores use other ports.
static void med3_rows8(const uint8_t *restrict r0, const uint8_t *restrict r1, const uint8_t *restrict r2,
                       const uint8_t *restrict r3, const uint8_t *restrict r4, const uint8_t *restrict r5,
                       const uint8_t *restrict r6, const uint8_t *restrict r7, const uint8_t *restrict r8,
                       const uint8_t *restrict r9, uint8_t *restrict o0, uint8_t *restrict o1,
                       uint8_t *restrict o2, uint8_t *restrict o3, uint8_t *restrict o4, uint8_t *restrict o5,
                       uint8_t *restrict o6, uint8_t *restrict o7)
{
    for (size_t i = 0; i < BLK3; i++) {
        uint8_t l0, m0, h0, l1, m1, h1, l2, m2, h2, l3, m3, h3, l4, m4, h4, l5, m5, h5;
        uint8_t l6, m6, h6, l7, m7, h7, l8, m8, h8, l9, m9, h9;
        HSORT3(r1, i, l1, m1, h1);
        HSORT3(r2, i, l2, m2, h2);
        const uint8_t l12 = VD_MAX8(l1, l2), h12 = VD_MIN8(h1, h2);
        const uint8_t mn12 = VD_MIN8(m1, m2), mx12 = VD_MAX8(m1, m2);
        HSORT3(r0, i, l0, m0, h0);
        const uint8_t la = VD_MAX8(l12, l0), ha = VD_MIN8(h12, h0), ma = VD_MAX8(mn12, VD_MIN8(mx12, m0));
        o0[i] = MED3(la, ma, ha);
        HSORT3(r3, i, l3, m3, h3);
        const uint8_t lb = VD_MAX8(l12, l3), hb = VD_MIN8(h12, h3), mb = VD_MAX8(mn12, VD_MIN8(mx12, m3));
        o1[i] = MED3(lb, mb, hb);
        HSORT3(r4, i, l4, m4, h4);
        const uint8_t l34 = VD_MAX8(l3, l4), h34 = VD_MIN8(h3, h4);
        const uint8_t mn34 = VD_MIN8(m3, m4), mx34 = VD_MAX8(m3, m4);
        const uint8_t lc = VD_MAX8(l34, l2), hc = VD_MIN8(h34, h2), mc = VD_MAX8(mn34, VD_MIN8(mx34, m2));
        o2[i] = MED3(lc, mc, hc);
        HSORT3(r5, i, l5, m5, h5);
        const uint8_t ld = VD_MAX8(l34, l5), hd = VD_MIN8(h34, h5), md = VD_MAX8(mn34, VD_MIN8(mx34, m5));
        o3[i] = MED3(ld, md, hd);
        HSORT3(r6, i, l6, m6, h6);
        const uint8_t l56 = VD_MAX8(l5, l6), h56 = VD_MIN8(h5, h6);
        const uint8_t mn56 = VD_MIN8(m5, m6), mx56 = VD_MAX8(m5, m6);
        const uint8_t le = VD_MAX8(l56, l4), he = VD_MIN8(h56, h4), me = VD_MAX8(mn56, VD_MIN8(mx56, m4));
        o4[i] = MED3(le, me, he);
        HSORT3(r7, i, l7, m7, h7);
        const uint8_t lf = VD_MAX8(l56, l7), hf = VD_MIN8(h56, h7), mf = VD_MAX8(mn56, VD_MIN8(mx56, m7));
        o5[i] = MED3(lf, mf, hf);
        HSORT3(r8, i, l8, m8, h8);
        const uint8_t l78 = VD_MAX8(l7, l8), h78 = VD_MIN8(h7, h8);
        const uint8_t mn78 = VD_MIN8(m7, m8), mx78 = VD_MAX8(m7, m8);
        const uint8_t lg = VD_MAX8(l78, l6), hg = VD_MIN8(h78, h6), mg = VD_MAX8(mn78, VD_MIN8(mx78, m6));
        o6[i] = MED3(lg, mg, hg);
        HSORT3(r9, i, l9, m9, h9);
        const uint8_t lh = VD_MAX8(l78, l9), hh = VD_MIN8(h78, h9), mh = VD_MAX8(mn78, VD_MIN8(mx78, m9));
        o7[i] = MED3(lh, mh, hh);
    }
}

// One output row (rows r0 r1 r2) for BLK3 columns (an odd last row).
static void med3_rows1(const uint8_t *restrict r0, const uint8_t *restrict r1, const uint8_t *restrict r2,
                       uint8_t *restrict o0)
{
    for (size_t i = 0; i < BLK3; i++) {
        uint8_t l0, m0, h0, l1, m1, h1, l2, m2, h2;
        HSORT3(r0, i, l0, m0, h0);
        HSORT3(r1, i, l1, m1, h1);
        HSORT3(r2, i, l2, m2, h2);
        const uint8_t l = VD_MAX8(VD_MAX8(l0, l1), l2), h = VD_MIN8(VD_MIN8(h0, h1), h2);
        const uint8_t m = MED3(m0, m1, m2);
        o0[i] = MED3(l, m, h);
    }
}

// Scalar 3x3 median at image column x of rows r0 r1 r2 (columns clamped):
// the image's first and last columns, and images narrower than a block.
static uint8_t med3_px(const uint8_t *r0, const uint8_t *r1, const uint8_t *r2, int32_t x, int32_t width)
{
    const int32_t xl = x > 0 ? x - 1 : 0, xr = x + 1 < width ? x + 1 : width - 1;
    const uint8_t *rows[3] = {r0, r1, r2};
    uint8_t l = 0u, m[3], h = 255u;
    for (int32_t k = 0; k < 3; k++) {
        const uint8_t a = rows[k][xl], b = rows[k][x], c = rows[k][xr];
        const uint8_t n = VD_MIN8(a, b), xx = VD_MAX8(a, b);
        l = VD_MAX8(l, VD_MIN8(n, c));
        h = VD_MIN8(h, VD_MAX8(xx, c));
        m[k] = VD_MAX8(n, VD_MIN8(xx, c));
    }
    const uint8_t md = MED3(m[0], m[1], m[2]);
    return MED3(l, md, h);
}

// The 4- and 8-row kernels are built (not in -Os builds: see vd_median3_u8).
#if defined(__OPTIMIZE_SIZE__)
#define VD_MED3_WIDE 0
#else
#define VD_MED3_WIDE 1
#endif

// BLK3 outputs of n (1, 2 or 4) consecutive rows: p[0 .. n+1] are the input
// rows and o[0 .. n-1] the output rows, at image column x / output offset off.
// A macro, used at two sites, so that every kernel has two callers: gcc -O2
// then keeps the kernels out of line, where it addresses the three shifted
// reads of a row from one register; inlined into a caller it kept 18
// pointers and spilled them (15% slower).
#define MED3_BLOCK(n, p, x, o, off)                                                                             \
    do {                                                                                                      \
        if ((n) == 8 && VD_MED3_WIDE) {                                                                       \
            med3_rows8((p)[0] + (x) - 1, (p)[1] + (x) - 1, (p)[2] + (x) - 1, (p)[3] + (x) - 1, (p)[4] + (x) - 1, \
                       (p)[5] + (x) - 1, (p)[6] + (x) - 1, (p)[7] + (x) - 1, (p)[8] + (x) - 1, (p)[9] + (x) - 1, \
                       (o)[0] + (off), (o)[1] + (off), (o)[2] + (off), (o)[3] + (off), (o)[4] + (off),        \
                       (o)[5] + (off), (o)[6] + (off), (o)[7] + (off));                                       \
        } else if ((n) == 4 && VD_MED3_WIDE) {                                                                \
            med3_rows4((p)[0] + (x) - 1, (p)[1] + (x) - 1, (p)[2] + (x) - 1, (p)[3] + (x) - 1, (p)[4] + (x) - 1, \
                       (p)[5] + (x) - 1, (o)[0] + (off), (o)[1] + (off), (o)[2] + (off), (o)[3] + (off));     \
        } else if ((n) == 2) {                                                                                \
            med3_rows2((p)[0] + (x) - 1, (p)[1] + (x) - 1, (p)[2] + (x) - 1, (p)[3] + (x) - 1, (o)[0] + (off),   \
                       (o)[1] + (off));                                                                       \
        } else {                                                                                              \
            med3_rows1((p)[0] + (x) - 1, (p)[1] + (x) - 1, (p)[2] + (x) - 1, (o)[0] + (off));                   \
        }                                                                                                     \
    } while (0)

// Output rows y .. y + n - 1 (n = 1, 2, 4 or 8) of the ROI r into d[0 .. n-1].
// Interior outputs (image columns 1 .. width - 2) go through the block
// kernels; the last block of a span overlaps the previous one (identical
// values, so no scalar tail); a span shorter than a block is computed by a
// block placed inside the image into tmp and copied; columns 0 and width - 1
// (replicated border) and images narrower than a block + 2 are scalar.
static void med3_span(const vd_view_u8_t *src, const vd_rect_t *r, int32_t y, int32_t n, uint8_t *const d[8])
{
    const int32_t width = (int32_t)src->width;
    const uint8_t *p[10];
    for (int32_t k = 0; k < 10; k++) {
        p[k] = row_at(src, r->y + y - 1 + (k <= n + 1 ? k : n + 1));
    }
    const int32_t x_end = r->x + r->w;
    const int32_t xa = r->x > 1 ? r->x : 1;                      // first interior output
    const int32_t xb = x_end < width - 1 ? x_end : width - 1;   // end of interior outputs
    int32_t sb = xa;                                             // [xa, sb): done by blocks
    if (xb - xa >= BLK3) {
        for (int32_t x = xa;; x += BLK3) {
            x = x > xb - BLK3 ? xb - BLK3 : x;
            MED3_BLOCK(n, p, x, d, (size_t)(x - r->x));
            if (x == xb - BLK3) {
                break;
            }
        }
        sb = xb;
    } else if (xb > xa && width - 2 >= BLK3) {
        // Two rows at a time through 2 x BLK3 = 128 bytes, the only buffer of
        // vd_median3_u8 (stack budget: its worst case stays under 512 bytes
        // on Cortex-M7; four rows at once would need 256).
        uint8_t tmp[2][BLK3];
        uint8_t *const t[8] = {tmp[0], tmp[1], tmp[0], tmp[1], tmp[0], tmp[1], tmp[0], tmp[1]};   // [2..]: never used (m <= 2)
        const int32_t xs = xa + BLK3 <= width - 1 ? xa : width - 1 - BLK3;
        for (int32_t k0 = 0; k0 < n; k0 += 2) {
            const int32_t m = n - k0 >= 2 ? 2 : 1;
            MED3_BLOCK(m, p + k0, xs, t, 0u);
            for (int32_t k = 0; k < m; k++) {
                memcpy(d[k0 + k] + (xa - r->x), tmp[k] + (xa - xs), (size_t)(xb - xa));
            }
        }
        sb = xb;
    }
    // Scalar: the ROI's columns outside [xa, sb).
    for (int32_t x = r->x; x < x_end; x++) {
        if (x >= xa && x < sb) {
            x = sb - 1;
            continue;
        }
        for (int32_t k = 0; k < n; k++) {
            d[k][x - r->x] = med3_px(p[k], p[k + 1], p[k + 2], x, width);
        }
    }
}

vd_status_t vd_median3_u8(const vd_view_u8_t *src, const vd_rect_t *roi, vd_image_u8_t *dst)
{
    vd_rect_t r;
    VD_TRY(median_args(src, roi, dst, &r));
    // Output rows in groups of 8 (rows shared inside a group, see
    // med3_rows8); the last group overlaps the previous one (identical
    // values); ROIs under 8 rows high take groups of 4, 2 and 1.
    int32_t y = 0;
    while (y < r.h) {
        int32_t n = r.h >= 8 ? 8 : (r.h >= 4 ? 4 : (r.h - y >= 2 ? 2 : 1));
#if defined(__OPTIMIZE_SIZE__)
        // -Os: groups of 2 and 1 only, so the 4- and 8-row kernels are never referenced and not built
        // (~2 KiB of Cortex-M0+ code: the whole library's 64 KiB budget; same values, fewer rows shared).
        n = (r.h - y >= 2) ? 2 : 1;
#endif
        if (n >= 4 && y > r.h - n) {
            y = r.h - n;
        }
        uint8_t *d[8];
        for (int32_t k = 0; k < 8; k++) {
            d[k] = dst->data + (size_t)(y + (k < n ? k : 0)) * dst->stride;
        }
        med3_span(src, &r, y, n, d);
        y += n;
    }
    return VD_OK;
}

// ---- 5x5 ------------------------------------------------------------------
// Outputs per 5x5 strip and T5, the columns of the overlapping tail loops (a
// loop over S5 + k items runs over S5 and then over the last T5, recomputing
// some, so every loop is whole vectors on SIMD targets). Stack: two rows'
// sorted columns (2 x 5 x (S5 + 8)), one row's even/odd split (2 x 5 x
// (S5/2 + 2)), the pair table (10 x (S5/2 + 1)) and 2 x S5 outputs: ~3 KiB
// on SIMD hosts (128-pixel strips: each stage's loads then rarely wait for
// the previous stage's just-stored vectors; 64 is 5-8% slower on frames, but
// a candidate ROI narrower than a strip costs a whole strip: ~2x slower
// there, still 5-10x faster than cv2.medianBlur), ~200 bytes on scalar
// targets (Cortex-M: stack budget, vd_median5_u8 <= 500 bytes with callees),
// which take 4-pixel strips at no cost to them.
#if defined(__SSE2__) || defined(__ARM_NEON) || defined(__ARM_NEON__) || defined(__ALTIVEC__)
#define S5 128
#define T5 16
#else
#define S5 4
#define T5 4
#endif
// Outputs are taken in pairs (x, x+1), x even, sharing columns x+1 .. x+4:
// H5 pairs per strip; TH5 = the overlapping tail of loops over H5 + k items.
#define H5 (S5 / 2)
#if S5 >= 32
#define TH5 16
#else
#define TH5 2
#endif

#define CX(a, b) t = VD_MIN8(a, b); b = VD_MAX8(a, b); a = t

// Sorts columns j0 .. j0 + N - 1 of two output rows' windows: rows p1..p4
// are shared (sorted once, 5 exchanges), then p0 is inserted for the upper
// row (ca) and p5 for the lower (cb) (4 + 4 min/max each: element k of the
// union is max(s[k-1], min(s[k], v))). 26 min/max per column for two rows
// against 36 for two 9-exchange sorts. restrict: gcc -O2 does not vectorise
// when it would need a run-time alias check.
#define SORT5_COLS2(name, N)                                                                                     \
    static void name(const uint8_t *restrict p0, const uint8_t *restrict p1, const uint8_t *restrict p2,        \
                     const uint8_t *restrict p3, const uint8_t *restrict p4, const uint8_t *restrict p5,        \
                     uint8_t *restrict ca0, uint8_t *restrict ca1, uint8_t *restrict ca2, uint8_t *restrict ca3, \
                     uint8_t *restrict ca4, uint8_t *restrict cb0, uint8_t *restrict cb1, uint8_t *restrict cb2, \
                     uint8_t *restrict cb3, uint8_t *restrict cb4)                                              \
    {                                                                                                           \
        for (size_t j = 0; j < (N); j++) {                                                                      \
            uint8_t s0 = p1[j], s1 = p2[j], s2 = p3[j], s3 = p4[j], t;                                          \
            const uint8_t a = p0[j], b = p5[j];                                                                 \
            CX(s0, s1); CX(s2, s3); CX(s0, s2); CX(s1, s3); CX(s1, s2);                                         \
            ca0[j] = VD_MIN8(s0, a);                                                                            \
            ca1[j] = VD_MAX8(s0, VD_MIN8(s1, a));                                                               \
            ca2[j] = VD_MAX8(s1, VD_MIN8(s2, a));                                                               \
            ca3[j] = VD_MAX8(s2, VD_MIN8(s3, a));                                                               \
            ca4[j] = VD_MAX8(s3, a);                                                                            \
            cb0[j] = VD_MIN8(s0, b);                                                                            \
            cb1[j] = VD_MAX8(s0, VD_MIN8(s1, b));                                                               \
            cb2[j] = VD_MAX8(s1, VD_MIN8(s2, b));                                                               \
            cb3[j] = VD_MAX8(s2, VD_MIN8(s3, b));                                                               \
            cb4[j] = VD_MAX8(s3, b);                                                                            \
        }                                                                                                       \
    }
SORT5_COLS2(sort5x2_strip, S5)
SORT5_COLS2(sort5x2_tail, T5)

// One output row (the last of an odd count): sorts the five rows' columns
// (optimal 9-exchange network).
#define SORT5_COLS(name, N)                                                                                    \
    static void name(const uint8_t *restrict p0, const uint8_t *restrict p1, const uint8_t *restrict p2,      \
                     const uint8_t *restrict p3, const uint8_t *restrict p4, uint8_t *restrict c0,           \
                     uint8_t *restrict c1, uint8_t *restrict c2, uint8_t *restrict c3, uint8_t *restrict c4) \
    {                                                                                                         \
        for (size_t j = 0; j < (N); j++) {                                                                    \
            uint8_t v0 = p0[j], v1 = p1[j], v2 = p2[j], v3 = p3[j], v4 = p4[j], t;                            \
            CX(v0, v1); CX(v3, v4); CX(v2, v4); CX(v2, v3); CX(v0, v3);                                       \
            CX(v0, v2); CX(v1, v4); CX(v1, v3); CX(v1, v2);                                                   \
            c0[j] = v0; c1[j] = v1; c2[j] = v2; c3[j] = v3; c4[j] = v4;                                       \
        }                                                                                                     \
    }
SORT5_COLS(sort5_strip, S5)
SORT5_COLS(sort5_tail, T5)
#undef CX

// Even and odd columns of a strip's sorted columns c[.][0 .. S5+3]:
// e[.][j] = column 2j, o[.][j] = column 2j + 1 (so that the output pairs
// below are whole SIMD lanes).
static void deinterleave(const uint8_t *const c[5], uint8_t e[5][H5 + 2], uint8_t o[5][H5 + 2])
{
    for (size_t q = 0; q < 5u; q++) {
        const uint8_t *restrict s = c[q];
        uint8_t *restrict eq = e[q];
        uint8_t *restrict oq = o[q];
        for (size_t j = 0; j < H5; j++) {
            eq[j] = s[2u * j];
            oq[j] = s[2u * j + 1u];
        }
        for (size_t j = H5 + 2u - TH5; j < H5 + 2u; j++) {
            eq[j] = s[2u * j];
            oq[j] = s[2u * j + 1u];
        }
    }
}

// pr[.][i] = sorted union of the sorted columns 2i + 1 = o[.][i] and
// 2i + 2 = e[.][i+1] (Batcher merge). Column 2i + 2 is read first: in the
// other order clang 14 forwards values between iterations and then does not
// vectorise.
static inline void merge_pair(const uint8_t o[5][H5 + 2], const uint8_t e[5][H5 + 2], size_t i, uint8_t pr[10][H5 + 1])
{
    const uint8_t b0 = e[0][i + 1u], b1 = e[1][i + 1u], b2 = e[2][i + 1u], b3 = e[3][i + 1u], b4 = e[4][i + 1u];
    const uint8_t a0 = o[0][i], a1 = o[1][i], a2 = o[2][i], a3 = o[3][i], a4 = o[4][i];
    // BEGIN GENERATED pair (tools/vdtools/generators/median_network.py; do not edit)
    const uint8_t t0 = VD_MIN8(a0, b0);
    const uint8_t t1 = VD_MAX8(a0, b0);
    const uint8_t t2 = VD_MIN8(a4, b4);
    const uint8_t t3 = VD_MAX8(a4, b4);
    const uint8_t t4 = VD_MIN8(t1, t2);
    const uint8_t t5 = VD_MAX8(t1, t2);
    const uint8_t t6 = VD_MIN8(a2, b2);
    const uint8_t t7 = VD_MAX8(a2, b2);
    const uint8_t t8 = VD_MIN8(t4, t6);
    const uint8_t t9 = VD_MAX8(t4, t6);
    const uint8_t t10 = VD_MIN8(t5, t7);
    const uint8_t t11 = VD_MAX8(t5, t7);
    const uint8_t t12 = VD_MIN8(a1, b1);
    const uint8_t t13 = VD_MAX8(a1, b1);
    const uint8_t t14 = VD_MIN8(a3, b3);
    const uint8_t t15 = VD_MAX8(a3, b3);
    const uint8_t t16 = VD_MIN8(t13, t14);
    const uint8_t t17 = VD_MAX8(t13, t14);
    const uint8_t t18 = VD_MIN8(t12, t8);
    const uint8_t t19 = VD_MAX8(t12, t8);
    const uint8_t t20 = VD_MIN8(t16, t9);
    const uint8_t t21 = VD_MAX8(t16, t9);
    const uint8_t t22 = VD_MIN8(t10, t17);
    const uint8_t t23 = VD_MAX8(t10, t17);
    const uint8_t t24 = VD_MIN8(t11, t15);
    const uint8_t t25 = VD_MAX8(t11, t15);
    pr[0][i] = t0;
    pr[1][i] = t18;
    pr[2][i] = t19;
    pr[3][i] = t20;
    pr[4][i] = t21;
    pr[5][i] = t22;
    pr[6][i] = t23;
    pr[7][i] = t24;
    pr[8][i] = t25;
    pr[9][i] = t3;
    // END GENERATED pair
}

// The pair table of a strip, entries 0 .. H5 (H5, then the last TH5).
static void pair_table(const uint8_t o[5][H5 + 2], const uint8_t e[5][H5 + 2], uint8_t pr[10][H5 + 1])
{
    for (size_t i = 0; i < H5; i++) {
        merge_pair(o, e, i, pr);
    }
    for (size_t i = H5 + 1u - TH5; i < H5 + 1u; i++) {
        merge_pair(o, e, i, pr);
    }
}

// Output pairs k < H5: oe[k] = median of columns 2k .. 2k+4 (column e[.][k]
// with the pairs pr[.][k], pr[.][k+1]), oo[k] = median of 2k+1 .. 2k+5 (the
// same pairs with column o[.][k+2]).
static void med5_select(const uint8_t e[5][H5 + 2], const uint8_t o[5][H5 + 2], const uint8_t pr[10][H5 + 1],
                        uint8_t *restrict oe, uint8_t *restrict oo)
{
    for (size_t k = 0; k < H5; k++) {
        const uint8_t q0 = pr[0][k + 1u], q1 = pr[1][k + 1u], q2 = pr[2][k + 1u], q3 = pr[3][k + 1u];
        const uint8_t q4 = pr[4][k + 1u], q5 = pr[5][k + 1u], q6 = pr[6][k + 1u], q7 = pr[7][k + 1u];
        const uint8_t q8 = pr[8][k + 1u], q9 = pr[9][k + 1u];
        const uint8_t p0 = pr[0][k], p1 = pr[1][k], p2 = pr[2][k], p3 = pr[3][k], p4 = pr[4][k];
        const uint8_t p5 = pr[5][k], p6 = pr[6][k], p7 = pr[7][k], p8 = pr[8][k], p9 = pr[9][k];
        const uint8_t b0 = o[0][k + 2u], b1 = o[1][k + 2u], b2 = o[2][k + 2u], b3 = o[3][k + 2u], b4 = o[4][k + 2u];
        const uint8_t a0 = e[0][k], a1 = e[1][k], a2 = e[2][k], a3 = e[3][k], a4 = e[4][k];
        // BEGIN GENERATED select_pair (tools/vdtools/generators/median5_net.py; do not edit)
        const uint8_t t0 = VD_MAX8(p0, q0);
        const uint8_t t1 = VD_MIN8(p8, q8);
        const uint8_t t2 = VD_MIN8(t0, t1);
        const uint8_t t3 = VD_MAX8(t0, t1);
        const uint8_t t4 = VD_MIN8(p4, q4);
        const uint8_t t5 = VD_MAX8(p4, q4);
        const uint8_t t6 = VD_MAX8(t2, t4);
        const uint8_t t7 = VD_MIN8(t3, t5);
        const uint8_t t8 = VD_MAX8(p2, q2);
        const uint8_t t9 = VD_MIN8(p6, q6);
        const uint8_t t10 = VD_MIN8(t8, t9);
        const uint8_t t11 = VD_MAX8(t8, t9);
        const uint8_t t12 = VD_MAX8(t10, t6);
        const uint8_t t13 = VD_MIN8(t7, t11);
        const uint8_t t14 = VD_MAX8(t7, t11);
        const uint8_t t15 = VD_MAX8(p1, q1);
        const uint8_t t16 = VD_MIN8(p9, q9);
        const uint8_t t17 = VD_MIN8(t15, t16);
        const uint8_t t18 = VD_MAX8(t15, t16);
        const uint8_t t19 = VD_MIN8(p5, q5);
        const uint8_t t20 = VD_MAX8(p5, q5);
        const uint8_t t21 = VD_MAX8(t17, t19);
        const uint8_t t22 = VD_MIN8(t18, t20);
        const uint8_t t23 = VD_MAX8(p3, q3);
        const uint8_t t24 = VD_MIN8(p7, q7);
        const uint8_t t25 = VD_MIN8(t23, t24);
        const uint8_t t26 = VD_MAX8(t23, t24);
        const uint8_t t27 = VD_MIN8(t21, t25);
        const uint8_t t28 = VD_MAX8(t21, t25);
        const uint8_t t29 = VD_MIN8(t22, t26);
        const uint8_t t30 = VD_MIN8(t12, t27);
        const uint8_t t31 = VD_MAX8(t12, t27);
        const uint8_t t32 = VD_MIN8(t13, t28);
        const uint8_t t33 = VD_MAX8(t13, t28);
        const uint8_t t34 = VD_MIN8(t14, t29);
        const uint8_t t35 = VD_MAX8(t14, t29);
        const uint8_t t36 = VD_MAX8(a0, t34);
        const uint8_t t37 = VD_MIN8(t35, t36);
        const uint8_t t38 = VD_MAX8(a1, t33);
        const uint8_t t39 = VD_MIN8(t37, t38);
        const uint8_t t40 = VD_MAX8(a2, t32);
        const uint8_t t41 = VD_MIN8(t39, t40);
        const uint8_t t42 = VD_MAX8(a3, t31);
        const uint8_t t43 = VD_MIN8(t41, t42);
        const uint8_t t44 = VD_MAX8(a4, t30);
        const uint8_t t45 = VD_MIN8(t43, t44);
        const uint8_t t46 = VD_MAX8(b0, t34);
        const uint8_t t47 = VD_MIN8(t35, t46);
        const uint8_t t48 = VD_MAX8(b1, t33);
        const uint8_t t49 = VD_MIN8(t47, t48);
        const uint8_t t50 = VD_MAX8(b2, t32);
        const uint8_t t51 = VD_MIN8(t49, t50);
        const uint8_t t52 = VD_MAX8(b3, t31);
        const uint8_t t53 = VD_MIN8(t51, t52);
        const uint8_t t54 = VD_MAX8(b4, t30);
        const uint8_t t55 = VD_MIN8(t53, t54);
        oe[k] = t45;
        oo[k] = t55;
        // END GENERATED select_pair
    }
}

// d[2k] = oe[k], d[2k+1] = oo[k]: the S5 outputs of a strip in order.
static void interleave(const uint8_t *restrict oe, const uint8_t *restrict oo, uint8_t *restrict d)
{
    for (size_t k = 0; k < H5; k++) {
        d[2u * k] = oe[k];
        d[2u * k + 1u] = oo[k];
    }
}

// Scalar 5x5 median at image column x of rows p[0..4] (columns clamped): images
// narrower than a strip.
static uint8_t med5_px(const uint8_t *const p[5], int32_t x, int32_t width)
{
    uint8_t win[25];
    int32_t n = 0;
    for (int32_t k = 0; k < 5; k++) {
        for (int32_t dx = -2; dx <= 2; dx++) {
            int32_t xx = x + dx;
            xx = xx < 0 ? 0 : (xx >= width ? width - 1 : xx);
            const uint8_t v = p[k][xx];
            int32_t j = n++;
            while (j > 0 && win[j - 1] > v) {   // insertion sort, at most 24 steps
                win[j] = win[j - 1];
                j--;
            }
            win[j] = v;
        }
    }
    return win[12];
}

vd_status_t vd_median5_u8(const vd_view_u8_t *src, const vd_rect_t *roi, vd_image_u8_t *dst)
{
    vd_rect_t r;
    VD_TRY(median_args(src, roi, dst, &r));
    const int32_t width = (int32_t)src->width;
    // Sorted columns c0 - 2 .. c0 + S5 + 5 (2 replicated each side) of the
    // upper [0] and lower [1] output row of a pair of rows.
    uint8_t colbuf[2][5][S5 + 8];
    uint8_t ev[5][H5 + 2], od[5][H5 + 2];   // even / odd sorted columns of one row's strip
    uint8_t pt[10][H5 + 1];                 // its pair table
    uint8_t oe[H5], oo[H5];                 // its even / odd outputs
    uint8_t out[S5];                        // a strip's outputs when not all of them are wanted
    const int32_t x_end = r.x + r.w;
    // Output rows in pairs (rows y - 2 .. y + 3 read, the middle four shared);
    // an odd last row alone.
    for (int32_t y = 0; y < r.h; y += 2) {
        const int32_t n = r.h - y >= 2 ? 2 : 1;
        const uint8_t *rows[6];
        for (int32_t k = 0; k < 6; k++) {
            rows[k] = row_at(src, r.y + y - 2 + k);
        }
        uint8_t *d[2];
        d[0] = dst->data + (size_t)y * dst->stride;
        d[1] = n == 2 ? d[0] + dst->stride : d[0];
        if (width < S5 + 4) {
            for (int32_t k = 0; k < n; k++) {
                for (int32_t x = r.x; x < x_end; x++) {
                    d[k][x - r.x] = med5_px(rows + k, x, width);
                }
            }
            continue;
        }
        uint8_t *const ca[5] = {colbuf[0][0] + 2, colbuf[0][1] + 2, colbuf[0][2] + 2, colbuf[0][3] + 2, colbuf[0][4] + 2};
        uint8_t *const cb[5] = {colbuf[1][0] + 2, colbuf[1][1] + 2, colbuf[1][2] + 2, colbuf[1][3] + 2, colbuf[1][4] + 2};
        for (int32_t x = r.x; x < x_end; x += S5) {
            // Strip of outputs [xs, xs + S5) inside the image, covering x.
            const int32_t xs = x + S5 <= width ? x : width - S5;
            // Sorted columns c0 .. c0 + S5 + 3 (inside the image); the strip
            // needs xs - 2 .. xs + S5 + 1, which is the same with d = xs - 2 - c0
            // in -2 .. 2 and the edge column replicated beyond the image.
            const int32_t c0 = xs - 2 < 0 ? 0 : (xs + S5 + 2 > width ? width - S5 - 4 : xs - 2);
            const size_t jt = S5 + 4 - T5;   // the last T5 columns
            const uint8_t *const *p = rows;
            if (n == 2) {
                sort5x2_strip(p[0] + c0, p[1] + c0, p[2] + c0, p[3] + c0, p[4] + c0, p[5] + c0, ca[0], ca[1], ca[2], ca[3],
                              ca[4], cb[0], cb[1], cb[2], cb[3], cb[4]);
                sort5x2_tail(p[0] + c0 + jt, p[1] + c0 + jt, p[2] + c0 + jt, p[3] + c0 + jt, p[4] + c0 + jt,
                             p[5] + c0 + jt, ca[0] + jt, ca[1] + jt, ca[2] + jt, ca[3] + jt, ca[4] + jt, cb[0] + jt,
                             cb[1] + jt, cb[2] + jt, cb[3] + jt, cb[4] + jt);
            } else {
                sort5_strip(p[0] + c0, p[1] + c0, p[2] + c0, p[3] + c0, p[4] + c0, ca[0], ca[1], ca[2], ca[3], ca[4]);
                sort5_tail(p[0] + c0 + jt, p[1] + c0 + jt, p[2] + c0 + jt, p[3] + c0 + jt, p[4] + c0 + jt, ca[0] + jt,
                           ca[1] + jt, ca[2] + jt, ca[3] + jt, ca[4] + jt);
            }
            const int32_t dshift = xs - 2 - c0;
            // Wanted outputs of this strip: [max(x, xs), min(x_end, xs + S5)).
            const int32_t wa = x > xs ? x : xs;
            const int32_t wb = x_end < xs + S5 ? x_end : xs + S5;
            for (int32_t k = 0; k < n; k++) {
                uint8_t(*cb5)[S5 + 8] = colbuf[k];
                for (int32_t q = 0; q < 5; q++) {
                    cb5[q][0] = cb5[q][1] = cb5[q][2];
                    cb5[q][S5 + 6] = cb5[q][S5 + 7] = cb5[q][S5 + 5];
                }
                const uint8_t *const c[5] = {cb5[0] + 2 + dshift, cb5[1] + 2 + dshift, cb5[2] + 2 + dshift,
                                             cb5[3] + 2 + dshift, cb5[4] + 2 + dshift};
                deinterleave(c, ev, od);
                pair_table((const uint8_t(*)[H5 + 2])od, (const uint8_t(*)[H5 + 2])ev, pt);
                med5_select((const uint8_t(*)[H5 + 2])ev, (const uint8_t(*)[H5 + 2])od, (const uint8_t(*)[H5 + 1])pt,
                            oe, oo);
                if (wa == xs && wb == xs + S5) {
                    interleave(oe, oo, d[k] + (xs - r.x));
                } else {
                    interleave(oe, oo, out);
                    memcpy(d[k] + (wa - r.x), out + (wa - xs), (size_t)(wb - wa));
                }
            }
            if (wb == x_end) {
                break;
            }
            x = wb - S5;   // next strip starts at wb
        }
    }
    return VD_OK;
}
