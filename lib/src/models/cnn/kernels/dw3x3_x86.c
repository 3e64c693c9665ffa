// SPDX-License-Identifier: MIT
// CNN kernel DW3X3 on x86-64 (AVX-512 VNNI, AVX-VNNI, AVX2): the depthwise 3x3 of dw3x3.c on vector registers,
// with its scratch (only the zero-point row) and its bytes.
//
// Algorithm: the taps are x itself (padding taps read a row of zp_in) and bias - zp_in sum w is folded
// into the constants. AVX-512: int16 products, vpdpwssd on tap pairs interleaved per channel
// (unpacklo/hi), 2 products + int32 per lane, exact; packs_epi32 of the lo/hi results restores the
// channel order; 32 channels per pass; interior pixels (no padding tap) pair the taps by column instead
// (rows 0 and 1, row 2 with 0) so that a column loaded for one pixel serves the next (dwv_run). AVX2: the
// same with vpmaddwd, 16 channels per pass, the last pass's tail read without touching bytes past the
// pixel's channels (tail_of); the pixels whose taps are all inside the input step three row pointers
// (dw_row), and the shipped networks' case (whole passes, output range all of int8, ReLU) is a
// specialised copy. AVX-VNNI: AVX2's passes, the interior pixels of whole passes paired by column with
// vpdpwssd as on AVX-512 (dwa_run).
// Reference: dw3x3.c (tests/unit/test_cnn.c compares every tensor with it).
// Bounds: as dw3x3.c; stack: the weights and constants of one pass.
#include "models/cnn/kernels/x86.h"

#include <string.h>

// A depthwise layer's input and output as rings of full rows (row y at slot
// y % slots; a whole plane has slots = height) and its geometry.
typedef struct vd_cnn_x86_dw {
    const int8_t *in;
    size_t in_row;        // bytes per input row (wi * c_n)
    uint32_t in_slots, wi, hi;
    int8_t *out;
    size_t out_row;
    uint32_t out_slots, wo;
    uint32_t stride;
    size_t c_n;
    int32_t zp_in;
    const int8_t *zrow;   // c_n bytes of zp_in (padding taps)
} vd_cnn_x86_dw_t;

// Depthwise (both kernel sets): the 3 input rows of output row oy (NULL: padding row) ...
static inline void dw_rows(const vd_cnn_x86_dw_t *d, uint32_t oy, const int8_t *rows[3])
{
    for (uint32_t ky = 0u; ky < 3u; ky++) {
        const int32_t iy = (int32_t)oy * (int32_t)d->stride - 1 + (int32_t)ky;
        rows[ky] = (iy >= 0 && iy < (int32_t)d->hi) ? d->in + (size_t)((uint32_t)iy % d->in_slots) * d->in_row
                                                     : NULL;
    }
}

// ... and the 9 tap pointers of output pixel ox; padding taps read the zero row.
static inline void dw_taps(const vd_cnn_x86_dw_t *d, const int8_t *const rows[3], uint32_t ox, const int8_t *t[9])
{
    const size_t c_n = d->c_n;
    const int32_t ix0 = (int32_t)ox * (int32_t)d->stride - 1;
    const bool left = ix0 >= 0, right = ix0 + 2 < (int32_t)d->wi;
    for (size_t ky = 0u; ky < 3u; ky++) {
        const int8_t *r = rows[ky];
        if (r == NULL) {
            t[ky * 3u] = d->zrow;
            t[ky * 3u + 1u] = d->zrow;
            t[ky * 3u + 2u] = d->zrow;
            continue;
        }
        const int8_t *c1 = r + (size_t)ox * (size_t)d->stride * c_n;
        t[ky * 3u] = left ? c1 - c_n : d->zrow;
        t[ky * 3u + 1u] = c1;
        t[ky * 3u + 2u] = right ? c1 + c_n : d->zrow;
    }
}

// The channels and bias corrections of the lanes of a pass from channel c0:
// after unpacklo/hi of tap pairs, lane j (< n) of the lo sums holds channel
// c0 + 8 (j / 4) + j % 4 and of the hi sums that + 4 (a lane past c_n takes
// channel c0; its result is not stored; c_n: the layer's channels). corr = zp_in sum w of the lane's
// channel, modulo 2^32 (ws: the pass's int16 weight sums): the taps are x,
// padding taps zp_in, so bias - zp_in sum w replaces x - zp_in.
static void dw_lanes(size_t c_n, int32_t zp_in, size_t c0, const int16_t *ws, uint32_t n, uint32_t *map_lo,
                     int32_t *corr_lo, uint32_t *map_hi, int32_t *corr_hi)
{
    for (uint32_t j = 0u; j < n; j++) {
        const size_t cl = 8u * (j / 4u) + (j % 4u);
        map_lo[j] = (uint32_t)((c0 + cl < c_n) ? c0 + cl : c0);
        map_hi[j] = (uint32_t)((c0 + cl + 4u < c_n) ? c0 + cl + 4u : c0);
        corr_lo[j] = vd_rq_u32_to_i32((uint32_t)zp_in * (uint32_t)(int32_t)ws[cl]);
        corr_hi[j] = vd_rq_u32_to_i32((uint32_t)zp_in * (uint32_t)(int32_t)ws[cl + 4u]);
    }
}

X86_INLINE __m512i dw_tap(const int8_t *t, __mmask32 m)
{
    return _mm512_cvtepi8_epi16(_mm256_maskz_loadu_epi8(m, t));
}

// A tap column (rows 0..2 of one input column, 32 channels as int16) in the
// pairing of the interior path: rows 0 and 1 interleaved per channel
// (unpacklo/hi), row 2 with 0. Weights take the same form, so one pixel is
// 6 vpdpwssd per half, and a column loaded for pixel ox serves the next
// pixel too (its left or centre column).
typedef struct dwv_col {
    __m512i pl, ph, el, eh;
} dwv_col_t;

X86_INLINE dwv_col_t dwv_col(const int8_t *p0, const int8_t *p1, const int8_t *p2, __mmask32 m)
{
    const __m512i a = dw_tap(p0, m), b = dw_tap(p1, m), e = dw_tap(p2, m), z = _mm512_setzero_si512();
    const dwv_col_t c = {_mm512_unpacklo_epi16(a, b), _mm512_unpackhi_epi16(a, b), _mm512_unpacklo_epi16(e, z),
                         _mm512_unpackhi_epi16(e, z)};
    return c;
}

X86_INLINE void dwv_acc(const dwv_col_t *c, const dwv_col_t *w, __m512i *al, __m512i *ah)
{
    *al = _mm512_dpwssd_epi32(_mm512_dpwssd_epi32(*al, c->pl, w->pl), c->el, w->el);
    *ah = _mm512_dpwssd_epi32(_mm512_dpwssd_epi32(*ah, c->ph, w->ph), c->eh, w->eh);
}

// The constants of one pass of 32 channels from c0 (m: its lanes).
typedef struct dwv_pass {
    __m512i wl[5], wh[5];   // tap pairs (0,1) (2,3) (4,5) (6,7) (8,-), the border pixels' pairing
    dwv_col_t wc[3];        // per column kx: taps (0,kx) (1,kx) paired, (2,kx) with 0
    const vd_cnn_x86_rqv_t *cl, *ch;   // the prepared constants in place, or own's
    vd_cnn_x86_rqv_t own[2];
    __mmask32 m;
    size_t c0;
} dwv_pass_t;

X86_INLINE void dwv_out(__m512i al, __m512i ah, const dwv_pass_t *ps, const vd_cnn_x86_rq_t *q, int8_t *o)
{
    if (q->sat8) {   // the clamp as saturation (rq16_store)
        const __m512i z = _mm512_packs_epi32(rq16_z(al, ps->cl, q), rq16_z(ah, ps->ch, q));
        _mm512_mask_cvtsepi16_storeu_epi8(o, ps->m, _mm512_adds_epi16(z, _mm512_set1_epi16((int16_t)q->zp)));
    } else {
        const __m512i z = _mm512_packs_epi32(rq16(al, ps->cl, q), rq16(ah, ps->ch, q));
        _mm512_mask_cvtepi16_storeu_epi8(o, ps->m, z);
    }
}

// Output pixels [xa, xb) of a row whose 9 taps are all inside the input (the
// 3 rows present, columns ox s - 1 .. ox s + 1 inside): 2 new columns per
// pixel at stride 2, 1 at stride 1 (the loader's strides). Every pixel through
// dw_taps and its 9 loads made the kernel ~20 % slower (perf, the demo).
X86_INLINE void dwv_run(const vd_cnn_x86_dw_t *d, const int8_t *const rows[3], uint32_t xa, uint32_t xb,
                        const dwv_pass_t *ps, const vd_cnn_x86_rq_t *q, int8_t *orow)
{
    // Locals: the int8 stores below may alias *d and *q, which the compiler would otherwise read per pixel.
    const bool s1 = d->stride == 1u;
    const vd_cnn_x86_rq_t qv = *q;
    const size_t c_n = d->c_n, adv = (size_t)d->stride * c_n;
    const size_t at = ((size_t)xa * d->stride - 1u) * c_n + ps->c0;
    const int8_t *p0 = rows[0] + at, *p1 = rows[1] + at, *p2 = rows[2] + at;
    dwv_col_t cl = dwv_col(p0, p1, p2, ps->m), cc = dwv_col(p0 + c_n, p1 + c_n, p2 + c_n, ps->m);
    for (uint32_t ox = xa; ox < xb; ox++) {
        if (!s1) {   // 2: the left column is the last pixel's right one, the centre is new
            cc = dwv_col(p0 + c_n, p1 + c_n, p2 + c_n, ps->m);
        }
        const dwv_col_t cr = dwv_col(p0 + 2u * c_n, p1 + 2u * c_n, p2 + 2u * c_n, ps->m);
        __m512i al = _mm512_setzero_si512(), ah = _mm512_setzero_si512();
        dwv_acc(&cl, &ps->wc[0], &al, &ah);
        dwv_acc(&cc, &ps->wc[1], &al, &ah);
        dwv_acc(&cr, &ps->wc[2], &al, &ah);
        dwv_out(al, ah, ps, &qv, orow + (size_t)ox * c_n + ps->c0);
        if (s1) {
            cl = cc;
            cc = cr;
        } else {
            cl = cr;
        }
        p0 += adv;
        p1 += adv;
        p2 += adv;
    }
}

// One border pixel (some tap padding) from its 9 tap pointers.
X86_INLINE void dwv_px(const int8_t *const t[9], const dwv_pass_t *ps, const vd_cnn_x86_rq_t *q, int8_t *o)
{
    const size_t c0 = ps->c0;
    __m512i al = _mm512_setzero_si512(), ah = _mm512_setzero_si512();
    for (size_t i = 0u; i < 4u; i++) {
        const __m512i xa = dw_tap(t[2u * i] + c0, ps->m), xb = dw_tap(t[2u * i + 1u] + c0, ps->m);
        al = _mm512_dpwssd_epi32(al, _mm512_unpacklo_epi16(xa, xb), ps->wl[i]);
        ah = _mm512_dpwssd_epi32(ah, _mm512_unpackhi_epi16(xa, xb), ps->wh[i]);
    }
    const __m512i x8 = dw_tap(t[8] + c0, ps->m), zero = _mm512_setzero_si512();
    al = _mm512_dpwssd_epi32(al, _mm512_unpacklo_epi16(x8, zero), ps->wl[4]);
    ah = _mm512_dpwssd_epi32(ah, _mm512_unpackhi_epi16(x8, zero), ps->wh[4]);
    dwv_out(al, ah, ps, q, o + c0);
}

// The interior [*xa, *xb) of output row with input rows `rows` (empty when a row is padding).
static inline void dw_interior(const vd_cnn_x86_dw_t *d, const int8_t *const rows[3], uint32_t *xa, uint32_t *xb)
{
    *xa = 0u;
    *xb = 0u;
    if (rows[0] != NULL && rows[1] != NULL && rows[2] != NULL && d->wi >= 2u) {
        *xa = 1u;
        const uint32_t b = (d->wi - 2u) / d->stride + 1u;
        *xb = (b < d->wo) ? b : d->wo;
        *xb = (*xb > *xa) ? *xb : *xa;
    }
}

// The AVX-512 pass from channel c0 (mask m): its constants, lo and hi sums (bias - zp_in sum w, modulo 2^32).
static X86_TARGET void vnni_pass_consts(const vd_cnn_layer_t *L, size_t c_n, int32_t zp_in, size_t c0, __mmask32 m,
                                        vd_cnn_x86_rqv_t *cl, vd_cnn_x86_rqv_t *ch)
{
    __m512i wsum = _mm512_setzero_si512();
    for (size_t i = 0u; i < 9u; i++) {
        wsum = _mm512_add_epi16(wsum, dw_tap(L->w + i * c_n + c0, m));   // |sum| <= 9 * 128: int16
    }
    int16_t ws[32];
    _mm512_storeu_si512(ws, wsum);
    uint32_t map_lo[16], map_hi[16];
    int32_t corr_lo[16], corr_hi[16];
    dw_lanes(c_n, zp_in, c0, ws, 16u, map_lo, corr_lo, map_hi, corr_hi);
    vd__cnn_x86_rqv_fill(cl, L, map_lo, corr_lo, 16u);
    vd__cnn_x86_rqv_fill(ch, L, map_hi, corr_hi, 16u);
}

// prep: the layer's pass constants made by vd__cnn_x86_prep_dw (NULL: made here, per call).
X86_KERNEL X86_TARGET void dw_vnni(const vd_cnn_x86_dw_t *d, const vd_cnn_layer_t *L, const vd_cnn_x86_rq_t *q,
                                   uint32_t y0, uint32_t y1, const vd_cnn_x86_rqv_t *prep)
{
    const size_t c_n = d->c_n;
    for (size_t c0 = 0u; c0 < c_n; c0 += 32u) {
        dwv_pass_t ps;
        const size_t nc = (c_n - c0 < 32u) ? c_n - c0 : 32u;
        ps.m = (nc == 32u) ? (__mmask32)0xFFFFFFFFu : (__mmask32)(((uint32_t)1 << nc) - 1u);
        ps.c0 = c0;
        // Weights [9][c_n] straight from the model, in both pairings.
        __m512i wt[9];
        for (size_t i = 0u; i < 9u; i++) {
            wt[i] = dw_tap(L->w + i * c_n + c0, ps.m);
        }
        const __m512i zero = _mm512_setzero_si512();
        for (size_t i = 0u; i < 5u; i++) {
            const __m512i wb = (i < 4u) ? wt[2u * i + 1u] : zero;
            ps.wl[i] = _mm512_unpacklo_epi16(wt[2u * i], wb);
            ps.wh[i] = _mm512_unpackhi_epi16(wt[2u * i], wb);
        }
        for (size_t kx = 0u; kx < 3u; kx++) {
            ps.wc[kx].pl = _mm512_unpacklo_epi16(wt[kx], wt[3u + kx]);
            ps.wc[kx].ph = _mm512_unpackhi_epi16(wt[kx], wt[3u + kx]);
            ps.wc[kx].el = _mm512_unpacklo_epi16(wt[6u + kx], zero);
            ps.wc[kx].eh = _mm512_unpackhi_epi16(wt[6u + kx], zero);
        }
        if (prep != NULL) {
            // Read in place: a band of rows per call, so a copy per pass was a cost per call.
            ps.cl = prep + (c0 / 32u) * 2u;
            ps.ch = ps.cl + 1;
        } else {
            vnni_pass_consts(L, c_n, d->zp_in, c0, ps.m, &ps.own[0], &ps.own[1]);
            ps.cl = &ps.own[0];
            ps.ch = &ps.own[1];
        }
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rows[3];
            dw_rows(d, oy, rows);
            int8_t *orow = d->out + (size_t)(oy % d->out_slots) * d->out_row;
            uint32_t xa, xb;
            dw_interior(d, rows, &xa, &xb);
            for (uint32_t ox = 0u; ox < d->wo; ox++) {
                if (ox == xa && xa < xb && !q->general && !q->sign) {
                    // The shipped networks' case: the requantisation flags as constants.
                    const vd_cnn_x86_rq_t qc = {q->zp, q->lo, q->hi, false, false, q->sat8};
                    dwv_run(d, rows, xa, xb, &ps, &qc, orow);
                    ox = xb - 1u;
                    continue;
                }
                if (ox == xa && xa < xb) {
                    dwv_run(d, rows, xa, xb, &ps, q, orow);
                    ox = xb - 1u;
                    continue;
                }
                const int8_t *t[9];
                dw_taps(d, rows, ox, t);
                dwv_px(t, &ps, q, orow + (size_t)ox * c_n);
            }
        }
    }
}

// 16 int8 at p (n of them, 1..16; the rest 0) as int16, reading only
// p[0..n) (a copy through the stack: weights, once per group).
AVX2_INLINE __m256i tap16(const int8_t *p, size_t n)
{
    if (n >= 16u) {
        return _mm256_cvtepi8_epi16(_mm_loadu_si128((const __m128i *)(const void *)p));
    }
    int8_t tmp[16] = {0};
    memcpy(tmp, p, n);
    return _mm256_cvtepi8_epi16(_mm_loadu_si128((const __m128i *)(const void *)tmp));
}

// How tap_act reads the n channels of a pass: 0 all 16 bytes; 1 the 16
// bytes ending at p + n, moved down by shuf (the pixel has >= 16 channels,
// so they are its own); 2 (8 <= n < 16) 8 bytes at p and the 8 ending at
// p + n, shifted by sh bits; 3 (n < 8) through the stack. Never reads
// outside the pixel's channels, without a store-forwarding stall.
typedef struct tail {
    uint32_t mode;
    size_t n;
    __m128i shuf, sh;
} tail_t;

AVX2_INLINE tail_t tail_of(size_t n, size_t c_n)
{
    tail_t t;
    t.n = n;
    t.mode = (n >= 16u) ? 0u : (c_n >= 16u) ? 1u : (n >= 8u) ? 2u : 3u;
    t.shuf = _mm_setzero_si128();
    t.sh = _mm_setzero_si128();
    if (t.mode == 1u) {   // made only where read: a whole pass (mode 0) is the common case, once per call
        int8_t idx[16];
        for (size_t i = 0u; i < 16u; i++) {
            idx[i] = (int8_t)((i < n) ? (int32_t)(i + 16u - n) : -128);   // -128: pshufb writes 0
        }
        t.shuf = _mm_loadu_si128((const __m128i *)(const void *)idx);
    } else if (t.mode == 2u) {
        t.sh = _mm_cvtsi32_si128((int)(8u * (16u - n)));
    }
    return t;
}

// mode: t->mode, or a constant where the caller specialises on it.
AVX2_INLINE __m256i tap_act(const int8_t *p, const tail_t *t, const uint32_t mode)
{
    __m128i v;
    if (mode == 0u) {
        v = _mm_loadu_si128((const __m128i *)(const void *)p);
    } else if (mode == 1u) {
        v = _mm_shuffle_epi8(_mm_loadu_si128((const __m128i *)(const void *)(p + t->n - 16u)), t->shuf);
    } else if (mode == 2u) {
        const __m128i lo = _mm_loadl_epi64((const __m128i *)(const void *)p);
        const __m128i hi = _mm_srl_epi64(_mm_loadl_epi64((const __m128i *)(const void *)(p + t->n - 8u)), t->sh);
        v = _mm_unpacklo_epi64(lo, hi);
    } else {
        return tap16(p, t->n);
    }
    return _mm256_cvtepi8_epi16(v);
}

// The weights of a pass as the activations' tap pairs and its constants.
typedef struct dw_pass {
    __m256i wl[5], wh[5];
    const vd_cnn_x86_rqv_t *cv;   // lanes 0..7 the lo sums', 8..15 the hi sums' (prepared, or own)
    vd_cnn_x86_rqv_t own;
    tail_t tl;
    size_t nc;
} dw_pass_t;

// The requantised bytes of one pixel's lo / hi sums to o: packs restores the channel order per 128-bit lane,
// permute joins the lanes' bytes.
AVX2_INLINE void dw_out(__m256i al, __m256i ah, const dw_pass_t *ps, const vd_cnn_x86_rq_t *q, int8_t *o,
                        const uint32_t mode)
{
    __m256i b;
    if (q->sat8) {
        b = sat8_16(_mm256_packs_epi32(rq8_z(al, ps->cv, 0u, q), rq8_z(ah, ps->cv, 1u, q)), q);
    } else {
        const __m256i z16 = _mm256_packs_epi32(rq8(al, ps->cv, 0u, q), rq8(ah, ps->cv, 1u, q));
        b = _mm256_packs_epi16(z16, z16);
    }
    const __m128i b8 = _mm256_castsi256_si128(_mm256_permute4x64_epi64(b, 0x08));
    if (mode == 0u || ps->nc == 16u) {   // mode 0: nc = 16
        _mm_storeu_si128((__m128i *)(void *)o, b8);
    } else {
        int8_t tmp[16];
        _mm_storeu_si128((__m128i *)(void *)tmp, b8);
        memcpy(o, tmp, ps->nc);
    }
}

// One output pixel of a pass from its 9 tap pointers (already at the pass's
// first channel) to o.
AVX2_INLINE void dw_px(const int8_t *const t[9], const dw_pass_t *ps, const vd_cnn_x86_rq_t *q, int8_t *o,
                       const uint32_t mode)
{
    __m256i al = _mm256_setzero_si256(), ah = _mm256_setzero_si256();
    for (size_t i = 0u; i < 4u; i++) {
        const __m256i xa = tap_act(t[2u * i], &ps->tl, mode), xb = tap_act(t[2u * i + 1u], &ps->tl, mode);
        al = _mm256_add_epi32(al, _mm256_madd_epi16(_mm256_unpacklo_epi16(xa, xb), ps->wl[i]));
        ah = _mm256_add_epi32(ah, _mm256_madd_epi16(_mm256_unpackhi_epi16(xa, xb), ps->wh[i]));
    }
    const __m256i x8 = tap_act(t[8], &ps->tl, mode), zero = _mm256_setzero_si256();
    al = _mm256_add_epi32(al, _mm256_madd_epi16(_mm256_unpacklo_epi16(x8, zero), ps->wl[4]));
    ah = _mm256_add_epi32(ah, _mm256_madd_epi16(_mm256_unpackhi_epi16(x8, zero), ps->wh[4]));
    dw_out(al, ah, ps, q, o, mode);
}

// One output row of a pass from channel c0. Pixels whose 9 taps are all in
// the input (3 rows, columns ix0 .. ix0 + 2 inside) step three row pointers
// (dw_taps per pixel cost a quarter of the kernel's instructions, callgrind);
// the others take dw_taps.
AVX2_INLINE void dw_row(const vd_cnn_x86_dw_t *d, const int8_t *const rows[3], size_t c0, const dw_pass_t *ps,
                        const vd_cnn_x86_rq_t *q, int8_t *orow, const uint32_t mode)
{
    const size_t c_n = d->c_n;
    const size_t s = d->stride;
    uint32_t xa, xb;   // interior [xa, xb): ox >= 1 and ox s + 1 < wi
    dw_interior(d, rows, &xa, &xb);
    uint32_t ox = 0u;
    while (ox < d->wo) {
        if (ox == xa && xa < xb) {
            const size_t adv = s * c_n;
            const int8_t *p0 = rows[0] + ((size_t)xa * s - 1u) * c_n + c0;
            const int8_t *p1 = rows[1] + ((size_t)xa * s - 1u) * c_n + c0;
            const int8_t *p2 = rows[2] + ((size_t)xa * s - 1u) * c_n + c0;
            for (; ox < xb; ox++) {
                const int8_t *const t[9] = {p0, p0 + c_n, p0 + 2u * c_n, p1, p1 + c_n, p1 + 2u * c_n,
                                            p2, p2 + c_n, p2 + 2u * c_n};
                dw_px(t, ps, q, orow + (size_t)ox * c_n + c0, mode);
                p0 += adv;
                p1 += adv;
                p2 += adv;
            }
            continue;
        }
        const int8_t *t[9];
        dw_taps(d, rows, ox, t);
        for (size_t i = 0u; i < 9u; i++) {
            t[i] += c0;
        }
        dw_px(t, ps, q, orow + (size_t)ox * c_n + c0, mode);
        ox++;
    }
}

// The AVX2 pass of nc channels from c0: its constants (lanes 0..7 the lo sums', 8..15 the hi sums').
static AVX2_TARGET void avx2_pass_consts(const vd_cnn_layer_t *L, size_t c_n, int32_t zp_in, size_t c0, size_t nc,
                                         vd_cnn_x86_rqv_t *cv)
{
    __m256i wsum = _mm256_setzero_si256();
    for (size_t i = 0u; i < 9u; i++) {
        wsum = _mm256_add_epi16(wsum, tap16(L->w + i * c_n + c0, nc));   // |sum| <= 9 * 128: int16
    }
    int16_t ws[16];
    _mm256_storeu_si256((__m256i *)(void *)ws, wsum);
    uint32_t map[16];
    int32_t corr[16];
    dw_lanes(c_n, zp_in, c0, ws, 8u, map, corr, map + 8, corr + 8);
    vd__cnn_x86_rqv_fill(cv, L, map, corr, 16u);
}

// The AVX2 pass of channels c0 .. from the model's weights [9][c_n] (wt: them as int16) and its constants
// (prep: the prepared ones, else made here); prep as dw_vnni's, one constant set per pass of 16 channels.
AVX2_INLINE void dw_pass_init(const vd_cnn_x86_dw_t *d, const vd_cnn_layer_t *L, size_t c0,
                              const vd_cnn_x86_rqv_t *prep, dw_pass_t *ps, __m256i wt[9])
{
    const size_t c_n = d->c_n;
    ps->nc = (c_n - c0 < 16u) ? c_n - c0 : 16u;
    for (size_t i = 0u; i < 9u; i++) {
        wt[i] = tap16(L->w + i * c_n + c0, ps->nc);
    }
    for (size_t i = 0u; i < 5u; i++) {
        const __m256i wb = (i < 4u) ? wt[2u * i + 1u] : _mm256_setzero_si256();
        ps->wl[i] = _mm256_unpacklo_epi16(wt[2u * i], wb);
        ps->wh[i] = _mm256_unpackhi_epi16(wt[2u * i], wb);
    }
    if (prep != NULL) {
        ps->cv = prep + c0 / 16u;   // in place, as dw_vnni
    } else {
        avx2_pass_consts(L, c_n, d->zp_in, c0, ps->nc, &ps->own);
        ps->cv = &ps->own;
    }
    ps->tl = tail_of(ps->nc, c_n);
}

X86_KERNEL AVX2_TARGET void dw_avx2(const vd_cnn_x86_dw_t *d, const vd_cnn_layer_t *L, const vd_cnn_x86_rq_t *q,
                                    uint32_t y0, uint32_t y1, const vd_cnn_x86_rqv_t *prep)
{
    vd_cnn_x86_rq_t qc;
    const bool shipped = vd__cnn_x86_rq_shipped(q, &qc);
    for (size_t c0 = 0u; c0 < d->c_n; c0 += 16u) {
        dw_pass_t ps;
        __m256i wt[9];
        dw_pass_init(d, L, c0, prep, &ps, wt);
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rows[3];
            dw_rows(d, oy, rows);
            int8_t *orow = d->out + (size_t)(oy % d->out_slots) * d->out_row;
            if (shipped && ps.tl.mode == 0u) {   // specialised: a whole pass (plain loads, one store), no branch
                dw_row(d, rows, c0, &ps, &qc, orow, 0u);
            } else {
                dw_row(d, rows, c0, &ps, q, orow, ps.tl.mode);
            }
        }
    }
}

// AVX-VNNI (VEX vpdpwssd on 256 bits): the AVX2 passes and constants, with the interior pixels of whole
// passes paired by column as the AVX-512 kernel pairs them (dwv_run): rows 0 and 1 of a column interleaved
// per channel, row 2 with 0, 6 vpdpwssd per pixel and half, and a column loaded for one pixel serves the
// next. Against the AVX2 pairing (9 tap loads, 10 unpacks, 10 vpmaddwd and 10 adds per pixel) that is 3
// loads and 4 unpacks per new column and 12 vpdpwssd. The sums are the same integers modulo 2^32.
typedef struct dwa_col {
    __m256i pl, ph, el, eh;
} dwa_col_t;

AVXVNNI_INLINE dwa_col_t dwa_col(const int8_t *p0, const int8_t *p1, const int8_t *p2)
{
    const __m256i a = _mm256_cvtepi8_epi16(_mm_loadu_si128((const __m128i *)(const void *)p0));
    const __m256i b = _mm256_cvtepi8_epi16(_mm_loadu_si128((const __m128i *)(const void *)p1));
    const __m256i e = _mm256_cvtepi8_epi16(_mm_loadu_si128((const __m128i *)(const void *)p2));
    const __m256i z = _mm256_setzero_si256();
    const dwa_col_t c = {_mm256_unpacklo_epi16(a, b), _mm256_unpackhi_epi16(a, b), _mm256_unpacklo_epi16(e, z),
                         _mm256_unpackhi_epi16(e, z)};
    return c;
}

AVXVNNI_INLINE void dwa_acc(const dwa_col_t *c, const dwa_col_t *w, __m256i *al, __m256i *ah)
{
    *al = _mm256_dpwssd_avx_epi32(_mm256_dpwssd_avx_epi32(*al, c->pl, w->pl), c->el, w->el);
    *ah = _mm256_dpwssd_avx_epi32(_mm256_dpwssd_avx_epi32(*ah, c->ph, w->ph), c->eh, w->eh);
}

// Interior output pixels [xa, xb) of a whole pass from channel c0 (wc: the weights per column kx in the
// columns' pairing); strides 1 and 2, as dwv_run.
AVXVNNI_INLINE void dwa_run(const vd_cnn_x86_dw_t *d, const int8_t *const rows[3], size_t c0, uint32_t xa,
                            uint32_t xb, const dw_pass_t *ps, const dwa_col_t wc[3], const vd_cnn_x86_rq_t *q,
                            int8_t *orow)
{
    const bool s1 = d->stride == 1u;
    const vd_cnn_x86_rq_t qv = *q;   // a local: the int8 stores may alias *q
    const size_t c_n = d->c_n, adv = (size_t)d->stride * c_n;
    const size_t at = ((size_t)xa * d->stride - 1u) * c_n + c0;
    const int8_t *p0 = rows[0] + at, *p1 = rows[1] + at, *p2 = rows[2] + at;
    dwa_col_t cl = dwa_col(p0, p1, p2), cc = dwa_col(p0 + c_n, p1 + c_n, p2 + c_n);
    for (uint32_t ox = xa; ox < xb; ox++) {
        if (!s1) {   // 2: the left column is the last pixel's right one, the centre is new
            cc = dwa_col(p0 + c_n, p1 + c_n, p2 + c_n);
        }
        const dwa_col_t cr = dwa_col(p0 + 2u * c_n, p1 + 2u * c_n, p2 + 2u * c_n);
        __m256i al = _mm256_setzero_si256(), ah = _mm256_setzero_si256();
        dwa_acc(&cl, &wc[0], &al, &ah);
        dwa_acc(&cc, &wc[1], &al, &ah);
        dwa_acc(&cr, &wc[2], &al, &ah);
        dw_out(al, ah, ps, &qv, orow + (size_t)ox * c_n + c0, 0u);
        if (s1) {
            cl = cc;
            cc = cr;
        } else {
            cl = cr;
        }
        p0 += adv;
        p1 += adv;
        p2 += adv;
    }
}

// One output row of a whole pass: the interior by dwa_run, the border pixels as AVX2's.
AVXVNNI_INLINE void dwa_row(const vd_cnn_x86_dw_t *d, const int8_t *const rows[3], size_t c0, const dw_pass_t *ps,
                            const dwa_col_t wc[3], const vd_cnn_x86_rq_t *q, int8_t *orow)
{
    uint32_t xa, xb;
    dw_interior(d, rows, &xa, &xb);
    for (uint32_t ox = 0u; ox < d->wo; ox++) {
        if (ox == xa && xa < xb) {
            dwa_run(d, rows, c0, xa, xb, ps, wc, q, orow);
            ox = xb - 1u;
            continue;
        }
        const int8_t *t[9];
        dw_taps(d, rows, ox, t);
        for (size_t i = 0u; i < 9u; i++) {
            t[i] += c0;
        }
        dw_px(t, ps, q, orow + (size_t)ox * d->c_n + c0, 0u);
    }
}

X86_KERNEL AVXVNNI_TARGET void dw_avxvnni(const vd_cnn_x86_dw_t *d, const vd_cnn_layer_t *L,
                                          const vd_cnn_x86_rq_t *q, uint32_t y0, uint32_t y1,
                                          const vd_cnn_x86_rqv_t *prep)
{
    vd_cnn_x86_rq_t qc;
    const bool shipped = vd__cnn_x86_rq_shipped(q, &qc);
    for (size_t c0 = 0u; c0 < d->c_n; c0 += 16u) {
        dw_pass_t ps;
        __m256i wt[9];
        dw_pass_init(d, L, c0, prep, &ps, wt);
        dwa_col_t wc[3];
        const __m256i z = _mm256_setzero_si256();
        for (size_t kx = 0u; kx < 3u; kx++) {
            wc[kx].pl = _mm256_unpacklo_epi16(wt[kx], wt[3u + kx]);
            wc[kx].ph = _mm256_unpackhi_epi16(wt[kx], wt[3u + kx]);
            wc[kx].el = _mm256_unpacklo_epi16(wt[6u + kx], z);
            wc[kx].eh = _mm256_unpackhi_epi16(wt[6u + kx], z);
        }
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rows[3];
            dw_rows(d, oy, rows);
            int8_t *orow = d->out + (size_t)(oy % d->out_slots) * d->out_row;
            if (shipped && ps.tl.mode == 0u) {
                dwa_row(d, rows, c0, &ps, wc, &qc, orow);
            } else if (ps.tl.mode == 0u) {
                dwa_row(d, rows, c0, &ps, wc, q, orow);
            } else {   // a pass of < 16 channels: AVX2's tail reads
                dw_row(d, rows, c0, &ps, q, orow, ps.tl.mode);
            }
        }
    }
}

// vd__cnn_dw3x3_rows on the AVX-512 VNNI, AVX-VNNI or AVX2 kernel: the scratch holds only the zero-point row.
void vd__cnn_dw3x3_rows_x86(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                           uint32_t y0, uint32_t y1, uint8_t *scr, uint32_t level, const uint8_t *prep)
{
    scratch_layout_t s;
    (void)vd__cnn_dw3x3_scratch(L, &s);
    int8_t *zr = (int8_t *)(void *)(scr + s.rows);
    memset(zr, g->zp_in, g->co);
    const vd_cnn_x86_dw_t d = {in->base, in->row, in->rows, g->wi, g->hi, out->base, out->row, out->rows,
                               g->wo, L->stride, g->co, g->zp_in, zr};
    const vd_cnn_x86_rq_t xq = vd__cnn_x86_layer_rq(L, &prep);   // prep: now at the pass constants
    const vd_cnn_x86_rqv_t *pc = (const vd_cnn_x86_rqv_t *)(const void *)prep;
    if (level == VD_CNN_X86_AVX512) {
        dw_vnni(&d, L, &xq, y0, y1, pc);
    } else if (level == VD_CNN_X86_AVXVNNI) {
        dw_avxvnni(&d, L, &xq, y0, y1, pc);
    } else {
        dw_avx2(&d, L, &xq, y0, y1, pc);
    }
}

size_t vd__cnn_x86_prep_dw(const vd_cnn_layer_t *L, int32_t zp_in, uint32_t level, uint8_t *dst)
{
    const size_t c_n = L->cout;
    const size_t step = (level == VD_CNN_X86_AVX512) ? 32u : 16u;   // channels per pass
    const size_t per = (level == VD_CNN_X86_AVX512) ? 2u : 1u;      // constant sets per pass
    vd_cnn_x86_rqv_t *cv = (dst != NULL) ? (vd_cnn_x86_rqv_t *)(void *)dst : NULL;
    size_t n = 0u;
    for (size_t c0 = 0u; c0 < c_n; c0 += step) {
        if (cv != NULL && level == VD_CNN_X86_AVX512) {
            const size_t nc = (c_n - c0 < 32u) ? c_n - c0 : 32u;
            const __mmask32 m = (nc == 32u) ? (__mmask32)0xFFFFFFFFu : (__mmask32)(((uint32_t)1 << nc) - 1u);
            vnni_pass_consts(L, c_n, zp_in, c0, m, cv + n, cv + n + 1u);
        } else if (cv != NULL) {
            avx2_pass_consts(L, c_n, zp_in, c0, (c_n - c0 < 16u) ? c_n - c0 : 16u, cv + n);
        }
        n += per;
    }
    return n * sizeof(vd_cnn_x86_rqv_t);
}
