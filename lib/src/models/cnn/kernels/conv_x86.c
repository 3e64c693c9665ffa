// SPDX-License-Identifier: MIT
// CNN kernel CONV3X3 / CONV5X5 / PW1X1 on x86-64: conv.c's GEMM on vector registers, with conv.c's scratch
// and bytes. This file is the driver (rows, tiles, constants); the GEMM of each instruction set is a file
// of its own: gemm_x86_avx512.c (AVX-512 VNNI), gemm_x86_avxvnni.c (AVX-VNNI), gemm_x86_avx2.c (AVX2).
//
// Algorithm: per tile of <= 64 output channels the layer's weights are packed for the set and the
// requantisation constants made (tile_consts), then per output row and block of VD_CNN_NPIX pixels the
// rows are gathered and multiplied. The VNNI sets (AVX-512, AVX-VNNI) take unsigned rows x + 128, k4 apart
// (16 k4 <= the int16 rows' bytes; the one-channel first layer per row span, gather_c1k3_u8; pointwise
// layers whose input channels are a multiple of 4 read their input row in place) and subtract
// (zp_in + 128) sum w from the bias; AVX2 takes conv.c's int16 rows x - zp_in (pointwise 16 channels per
// vector op, gather_pw; the first layer per row span, gather_c1k3; others conv.c's gather).
// Streamed runs repack a layer's weights per call as conv.c re-copies its own, unless the model was
// prepared (vd_cnn_prepare, prepared.c): then every call reads the layer's tiles from the area
// vd__cnn_x86_prep_layer made once (tile_get), the same bytes as a pack.
// Reference: conv.c (tests/unit/test_cnn.c compares every tensor with it on random and shipped models).
// Bounds: as conv.c; stack ~4 KiB (the constants of one tile of 64 channels).
#include "models/cnn/kernels/x86.h"

#include <string.h>

// The per-lane requantisation constants of output channels o0 .. o0 + n_o - 1
// (one tile), corr[j] subtracted from channel o0 + j's bias (corr may be NULL).
static void tile_consts(const vd_cnn_layer_t *L, size_t o0, size_t n_o, const int32_t *corr, vd_cnn_x86_rqv_t *cv)
{
    for (size_t v = 0u; v * VD_CNN_X86_LANES < n_o; v++) {
        uint32_t ch_of[VD_CNN_X86_LANES];
        const size_t n_l = (n_o - v * 16u < 16u) ? n_o - v * 16u : 16u;
        for (size_t j = 0u; j < n_l; j++) {
            ch_of[j] = (uint32_t)(o0 + v * 16u + j);
        }
        vd__cnn_x86_rqv_fill(&cv[v], L, ch_of, (corr != NULL) ? corr + v * 16u : NULL, (uint32_t)n_l);
    }
}

// The packed weights (wp) and constants (cv) of output channels o0 .. o0 + n_o - 1 on set `level`: AVX2 int16
// pairs [k2 / 2][n][2]; the VNNI sets int8 [k4 / 4][n][4] and the bias less (zp_in + 128) sum w.
static void tile_make(const vd_cnn_layer_t *L, uint32_t level, int32_t zp_in, size_t o0, size_t n_o, void *wp,
                      vd_cnn_x86_rqv_t *cv)
{
    const size_t k = vd_cnn_k_of(L);
    if (level == VD_CNN_X86_AVX2) {
        vd__cnn_pack_avx2(L->w + o0 * k, k, n_o, (int16_t *)wp);
        tile_consts(L, o0, n_o, NULL, cv);
        return;
    }
    int32_t corr[VD_CNN_X86_TILE];
    uint32_t wsum[VD_CNN_X86_TILE];
    if (level == VD_CNN_X86_AVX512) {
        vd__cnn_pack_vnni(L->w + o0 * k, k, n_o, (int8_t *)wp, wsum);
    } else {
        vd__cnn_pack_avxvnni(L->w + o0 * k, k, n_o, (int8_t *)wp, wsum);
    }
    for (size_t o = 0u; o < n_o; o++) {
        corr[o] = vd_rq_u32_to_i32(wsum[o] * (uint32_t)(zp_in + 128));   // modulo 2^32, as the sums
    }
    tile_consts(L, o0, n_o, corr, cv);
}

// Constant sets (vectors of 16 channels) of a tile of n_o channels.
static size_t tile_vectors(size_t n_o)
{
    return (n_o + VD_CNN_X86_LANES - 1u) / VD_CNN_X86_LANES;
}

// Bytes of one tile's prepared part: its constants (768 bytes per 16 channels), then its weights, to 64 bytes.
static size_t tile_prep_bytes(uint32_t level, size_t k, size_t n_o)
{
    const size_t nv = tile_vectors(n_o);
    const size_t wb = (level == VD_CNN_X86_AVX2) ? (k + 1u) / 2u * 2u * n_o * sizeof(int16_t)   // [k2 / 2][n][2]
                                                 : (k + 3u) / 4u * 4u * n_o;                     // [k4 / 4][n][4]
    return nv * sizeof(vd_cnn_x86_rqv_t) + (wb + 63u) / 64u * 64u;
}

size_t vd__cnn_x86_prep_conv(const vd_cnn_layer_t *L, int32_t zp_in, uint32_t level, uint8_t *dst)
{
    const size_t k = vd_cnn_k_of(L);
    size_t at = 0u;
    for (size_t o0 = 0u; o0 < L->cout; o0 += VD_CNN_X86_TILE) {
        const size_t n_o = (L->cout - o0 < VD_CNN_X86_TILE) ? L->cout - o0 : VD_CNN_X86_TILE;
        if (dst != NULL) {
            vd_cnn_x86_rqv_t *cv = (vd_cnn_x86_rqv_t *)(void *)(dst + at);
            tile_make(L, level, zp_in, o0, n_o, cv + tile_vectors(n_o), cv);
        }
        at += tile_prep_bytes(level, k, n_o);
    }
    return at;
}

// The tile's constants and weights: from the prepared area at *prep (then past it), or made in cv and wp.
static void tile_get(const vd_cnn_layer_t *L, uint32_t level, int32_t zp_in, size_t o0, size_t n_o,
                     const uint8_t **prep, void *wp, vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rqv_t **cv_out,
                     const void **wp_out)
{
    if (*prep != NULL) {
        const vd_cnn_x86_rqv_t *pc = (const vd_cnn_x86_rqv_t *)(const void *)*prep;
        *cv_out = pc;
        *wp_out = pc + tile_vectors(n_o);
        *prep += tile_prep_bytes(level, vd_cnn_k_of(L), n_o);
        return;
    }
    tile_make(L, level, zp_in, o0, n_o, wp, cv);
    *cv_out = cv;
    *wp_out = wp;
}

// The unsigned rows (x + 128, padding taps zp_in + 128) of npix output pixels
// from x0, k4 bytes apart, in the weight order [ky][kx][c] (the k..k4 tails
// stay as the caller zeroed them). rowp: the ks input rows (NULL: padding row).
static void gather_u8(const geom_t *g, const int8_t *const rowp[5], int32_t ks, int32_t step, uint32_t x0,
                      uint32_t npix, size_t k4, uint8_t *rows)
{
    const size_t ci = g->ci;
    const uint8_t upad = (uint8_t)(g->zp_in + 128);
    const int32_t pad = ks / 2;
    for (uint32_t i = 0u; i < npix; i++) {
        uint8_t *r = rows + (size_t)i * k4;
        const int32_t ox = (int32_t)(x0 + i);
        if (ks == 1) {   // pointwise: one tap, never padding
            const int8_t *x = rowp[0] + (size_t)ox * ci;
            for (size_t c = 0u; c < ci; c++) {
                r[c] = (uint8_t)((uint8_t)x[c] ^ 0x80u);
            }
            continue;
        }
        const int32_t ix0 = ox * step - pad;
        const bool inside = ix0 >= 0 && ix0 + ks <= (int32_t)g->wi;
        for (int32_t ky = 0; ky < ks; ky++) {
            uint8_t *d = r + (size_t)(ky * ks) * ci;
            if (inside && rowp[ky] != NULL) {
                // ks taps of ci channels, contiguous in the input row.
                const int8_t *x = rowp[ky] + (size_t)ix0 * ci;
                for (size_t c = 0u; c < (size_t)ks * ci; c++) {
                    d[c] = (uint8_t)((uint8_t)x[c] ^ 0x80u);
                }
                continue;
            }
            for (int32_t kx = 0; kx < ks; kx++) {
                const int32_t ix = ix0 + kx;
                uint8_t *dk = d + (size_t)kx * ci;
                if (rowp[ky] == NULL || ix < 0 || ix >= (int32_t)g->wi) {
                    memset(dk, upad, ci);
                } else {
                    const int8_t *x = rowp[ky] + (size_t)ix * ci;
                    for (size_t c = 0u; c < ci; c++) {
                        dk[c] = (uint8_t)((uint8_t)x[c] ^ 0x80u);
                    }
                }
            }
        }
    }
}

// gather_u8 for a CONV3X3 on one input channel (the first layer), as
// gather_c1k3 below does for the int16 rows: each input row's span of the
// block is flipped to unsigned bytes once (zp_in + 128 outside the row), then
// pixel i's 3 taps move from buf + step i with one 4-byte move. The 4th byte
// lands on tap 3 (ky + 1, rewritten next) or, for ky = 2, on position 9 of the
// k4 = 12, whose packed weight is 0 (pack_vnni pads k..k4 with 0). The per-tap
// loop of gather_u8 took 12 % of the demo's time on an AVX-512 machine (perf).
static AVX2_TARGET void gather_c1k3_u8(const geom_t *g, const int8_t *const rowp[5], int32_t step, uint32_t x0,
                                      uint32_t npix, size_t k4, uint8_t *rows)
{
    uint8_t buf[48];   // step (npix - 1) + 4 <= 34 values
    const int32_t ix0 = (int32_t)x0 * step - 1;
    const int32_t n = step * ((int32_t)npix - 1) + 4;
    const int32_t jlo = (ix0 < 0) ? -ix0 : 0;
    const int32_t jhi = ((int32_t)g->wi - ix0 < n) ? (int32_t)g->wi - ix0 : n;
    const uint8_t upad = (uint8_t)(g->zp_in + 128);
    const __m128i top = _mm_set1_epi8((char)0x80);
    for (int32_t ky = 0; ky < 3; ky++) {
        const int8_t *x = rowp[ky];
        int32_t j = 0;
        if (x != NULL) {
            for (; j < jlo; j++) {
                buf[j] = upad;
            }
            for (; j + 16 <= jhi; j += 16) {
                const __m128i v = _mm_loadu_si128((const __m128i *)(const void *)(x + ix0 + j));
                _mm_storeu_si128((__m128i *)(void *)(buf + j), _mm_xor_si128(v, top));
            }
            for (; j < jhi; j++) {
                buf[j] = (uint8_t)((uint8_t)x[ix0 + j] ^ 0x80u);
            }
        }
        for (; j < n; j++) {
            buf[j] = upad;
        }
        for (uint32_t i = 0u; i < npix; i++) {
            memcpy(rows + (size_t)i * k4 + (size_t)ky * 3u, buf + (size_t)step * i, 4u);
        }
    }
}

// vd__cnn_conv_gather for a CONV3X3 on one input channel (the first layer):
// the same int16 rows (x - zp_in, padding taps 0). The generic gather moves
// one tap at a time (callgrind: 18 % of the demo's instructions, almost all
// here); this converts each input row's span of the block once into buf
// (0 outside the row) and copies pixel i's 3 taps from buf + step i with one
// 8-byte move. The move's 4th value lands on tap 3 (ky + 1) or, for ky = 2,
// on position 9, whose packed weight is 0 (pack_avx2 pads k2 = 10 with 0):
// rewritten, or multiplied by 0.
static AVX2_TARGET void gather_c1k3(const geom_t *g, const int8_t *const rowp[5], int32_t step, uint32_t x0,
                                    uint32_t npix, size_t kp, int16_t *rows)
{
    int16_t buf[48];   // step (npix - 1) + 4 <= 34 values, whole 16-value chunks
    const int32_t ix0 = (int32_t)x0 * step - 1;
    const int32_t n = step * ((int32_t)npix - 1) + 4;
    const int32_t jlo = (ix0 < 0) ? -ix0 : 0;
    const int32_t jhi = ((int32_t)g->wi - ix0 < n) ? (int32_t)g->wi - ix0 : n;
    const __m256i zp = _mm256_set1_epi16((int16_t)g->zp_in);
    for (int32_t ky = 0; ky < 3; ky++) {
        const int8_t *x = rowp[ky];
        int32_t j = 0;
        if (x != NULL) {
            for (; j < jlo; j++) {
                buf[j] = 0;
            }
            for (; j + 16 <= jhi; j += 16) {
                const __m128i v = _mm_loadu_si128((const __m128i *)(const void *)(x + ix0 + j));
                _mm256_storeu_si256((__m256i *)(void *)(buf + j), _mm256_sub_epi16(_mm256_cvtepi8_epi16(v), zp));
            }
            for (; j < jhi; j++) {
                buf[j] = (int16_t)(x[ix0 + j] - g->zp_in);
            }
        }
        for (; j < n; j++) {
            buf[j] = 0;
        }
        for (uint32_t i = 0u; i < npix; i++) {
            memcpy(rows + (size_t)i * kp + (size_t)ky * 3u, buf + (size_t)step * i, 4u * sizeof(int16_t));
        }
    }
}

// vd__cnn_conv_gather for a pointwise layer: the npix pixels' ci channels
// (contiguous from x) as int16 x - zp_in, kp apart, 16 and then 8 at a time
// (the generic loop: ~1.8 instructions per value, callgrind).
static AVX2_TARGET void gather_pw(const int8_t *x, size_t ci, int32_t zp_in, uint32_t npix, size_t kp, int16_t *rows)
{
    const __m256i zp = _mm256_set1_epi16((int16_t)zp_in);
    for (uint32_t i = 0u; i < npix; i++) {
        const int8_t *xi = x + (size_t)i * ci;
        int16_t *r = rows + (size_t)i * kp;
        size_t c = 0u;
        for (; c + 16u <= ci; c += 16u) {
            const __m128i v = _mm_loadu_si128((const __m128i *)(const void *)(xi + c));
            _mm256_storeu_si256((__m256i *)(void *)(r + c), _mm256_sub_epi16(_mm256_cvtepi8_epi16(v), zp));
        }
        if (c + 8u <= ci) {
            const __m128i v = _mm_cvtepi8_epi16(_mm_loadl_epi64((const __m128i *)(const void *)(xi + c)));
            _mm_storeu_si128((__m128i *)(void *)(r + c), _mm_sub_epi16(v, _mm256_castsi256_si128(zp)));
            c += 8u;
        }
        for (; c < ci; c++) {
            r[c] = (int16_t)(xi[c] - zp_in);
        }
    }
}

// vd__cnn_conv_rows on the AVX2 GEMM: the portable int16 rows (x - zp_in, padding
// 0) and, per tile of <= 64 output channels, int16 weight pairs
// [k2 / 2][n][2] (2 n k2 <= the int16 copy's 2 chunk kp bytes).
static void conv_rows_avx2(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out,
                           uint32_t y0, uint32_t y1, uint8_t *scr, const scratch_layout_t *s, const uint8_t *prep)
{
    const size_t k = vd_cnn_k_of(L);
    const size_t kp = vd_cnn_round_up((uint32_t)k, VD_CNN_KCHUNK);
    int16_t *wp = (int16_t *)(void *)(scr + s->w16);
    int16_t *rows = (int16_t *)(void *)(scr + s->rows);
    if (k % 2u != 0u) {
        // gemm_avx2 reads k2 = k rounded up to even values per row: position k (weight 0) must be
        // defined. The gathers write positions 0..k - 1 of every row they fill; rows past npix feed
        // only results that are not stored. (Zeroing every call: ~1.4 % of the demo's instructions.)
        memset(rows, 0, (size_t)VD_CNN_NPIX * kp * sizeof(int16_t));
    }
    const vd_cnn_x86_rq_t xq = vd__cnn_x86_layer_rq(L, &prep);
    const int32_t step = L->stride;
    const bool pw = L->op == VD_CNN_OP_PW1X1;
    const int32_t ks = pw ? 1 : ((L->op == VD_CNN_OP_CONV5X5) ? 5 : 3);
    const bool c1k3 = ks == 3 && g->ci == 1u;   // gather_c1k3's case (stride 1 or 2: the loader's bound)
    for (size_t o0 = 0u; o0 < g->co; o0 += VD_CNN_X86_TILE) {
        const size_t n_o = (g->co - o0 < VD_CNN_X86_TILE) ? g->co - o0 : VD_CNN_X86_TILE;
        vd_cnn_x86_rqv_t cv_own[VD_CNN_X86_TILE / VD_CNN_X86_LANES];
        const vd_cnn_x86_rqv_t *cv;
        const void *wt;
        tile_get(L, VD_CNN_X86_AVX2, g->zp_in, o0, n_o, &prep, wp, cv_own, &cv, &wt);
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rowp[5];
            vd__cnn_conv_row_ptrs(g, in, oy, step, ks, rowp);
            int8_t *orow = vd_cnn_ring_row(out, oy) + o0;
            for (uint32_t x0 = 0u; x0 < g->wo; x0 += VD_CNN_NPIX) {
                const uint32_t npix = (g->wo - x0 < VD_CNN_NPIX) ? g->wo - x0 : VD_CNN_NPIX;
                if (pw) {
                    gather_pw(rowp[0] + (size_t)x0 * g->ci, g->ci, g->zp_in, npix, kp, rows);
                } else if (c1k3) {
                    gather_c1k3(g, rowp, step, x0, npix, kp, rows);
                } else {
                    vd__cnn_conv_gather(g, rowp, ks, step, x0, npix, kp, rows);
                }
                vd__cnn_gemm_avx2(rows, kp, k, (const int16_t *)wt, n_o, cv, &xq, g->co, orow + (size_t)x0 * g->co,
                                  npix);
            }
        }
    }
}

// vd__cnn_conv_rows on the AVX-512 VNNI or AVX-VNNI GEMM (gemm_x86_avx512.c, gemm_x86_avxvnni.c), same scratch:
// per tile of <= 64 output channels the int8 weights packed [k4 / 4][n][4]
// (n k4 <= the int16 copy's 2 chunk kp bytes), per block of 16 pixels the
// rows as unsigned bytes x + 128, k4 apart (16 k4 <= the int16 rows' bytes);
// padding taps are zp_in + 128 and the bias loses (zp_in + 128) sum w, so
// the int32 sums equal the portable ones modulo 2^32 (above).
void vd__cnn_conv_rows_x86(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0,
                          uint32_t y1, bool stream, uint8_t *scr, uint32_t level, const uint8_t *prep)
{
    scratch_layout_t sl;
    (void)vd__cnn_conv_scratch(L, stream, &sl);
    const scratch_layout_t *s = &sl;
    if (level == VD_CNN_X86_AVX2) {
        conv_rows_avx2(L, g, in, out, y0, y1, scr, s, prep);
        return;
    }
    // AVX-512 VNNI or AVX-VNNI: the same rows, weights and constants, so the set is a function pointer.
    void (*const gemm)(const uint8_t *, size_t, bool, size_t, const int8_t *, size_t, const vd_cnn_x86_rqv_t *,
                       const vd_cnn_x86_rq_t *, size_t, int8_t *, uint32_t) =
        (level == VD_CNN_X86_AVX512) ? vd__cnn_gemm_vnni : vd__cnn_gemm_avxvnni;
    const size_t k = vd_cnn_k_of(L);
    const size_t k4 = vd_cnn_round_up((uint32_t)k, 4u);
    int8_t *wp = (int8_t *)(void *)(scr + s->w16);
    uint8_t *rows = scr + s->rows;
    memset(rows, 0, (size_t)VD_CNN_NPIX * k4);   // the k..k4 tails stay 0 (their weights are 0 too)
    const vd_cnn_x86_rq_t xq = vd__cnn_x86_layer_rq(L, &prep);
    const size_t ci = g->ci;
    const int32_t step = L->stride;
    const bool pw = L->op == VD_CNN_OP_PW1X1;
    const int32_t ks = pw ? 1 : ((L->op == VD_CNN_OP_CONV5X5) ? 5 : 3);
    const bool in_place = pw && ci % 4u == 0u;
    const bool c1k3 = ks == 3 && ci == 1u;   // gather_c1k3_u8's case (stride 1 or 2: the loader's bound)
    for (size_t o0 = 0u; o0 < g->co; o0 += VD_CNN_X86_TILE) {
        const size_t n_o = (g->co - o0 < VD_CNN_X86_TILE) ? g->co - o0 : VD_CNN_X86_TILE;
        vd_cnn_x86_rqv_t cv_own[VD_CNN_X86_TILE / VD_CNN_X86_LANES];
        const vd_cnn_x86_rqv_t *cv;
        const void *wt;
        tile_get(L, level, g->zp_in, o0, n_o, &prep, wp, cv_own, &cv, &wt);
        const int8_t *w8 = (const int8_t *)wt;
        for (uint32_t oy = y0; oy < y1; oy++) {
            const int8_t *rowp[5];
            vd__cnn_conv_row_ptrs(g, in, oy, step, ks, rowp);
            int8_t *orow = vd_cnn_ring_row(out, oy) + o0;
            for (uint32_t x0 = 0u; x0 < g->wo; x0 += VD_CNN_NPIX) {
                const uint32_t npix = (g->wo - x0 < VD_CNN_NPIX) ? g->wo - x0 : VD_CNN_NPIX;
                if (in_place) {
                    // The input pixels are the rows (x, flipped to x + 128 in the kernel).
                    const uint8_t *xr = (const uint8_t *)(const void *)(rowp[0] + (size_t)x0 * ci);
                    int8_t *o = orow + (size_t)x0 * g->co;
                    gemm(xr, ci, true, k4, w8, n_o, cv, &xq, g->co, o, npix);
                    continue;
                }
                if (c1k3) {
                    gather_c1k3_u8(g, rowp, step, x0, npix, k4, rows);
                } else {
                    gather_u8(g, rowp, ks, step, x0, npix, k4, rows);
                }
                gemm(rows, k4, false, k4, w8, n_o, cv, &xq, g->co, orow + (size_t)x0 * g->co, npix);
            }
        }
    }
}
