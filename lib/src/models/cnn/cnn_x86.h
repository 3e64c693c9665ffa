// SPDX-License-Identifier: MIT
// Optional x86-64 kernels of the int8 CNN (lib/src/cnn_x86.c: AVX-512 VNNI, AVX2), bit-exact with the portable ones.
//
// Built only when CMake's VD_CNN_X86 is ON (x86-64 gcc/clang hosts, never in
// cross builds); cnn.c picks the set vd_cnn_x86_level() names (runtime CPU
// check) unless the run flags have VD_CNN_PORTABLE. Private to lib/; tests include it.
#ifndef VD_CNN_X86_H
#define VD_CNN_X86_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "vd/cnn.h"
#include "internal/requant.h"

// Output channels per vector (one 512-bit register of int32) and per GEMM
// tile (four vectors).
#define VD_CNN_X86_LANES 16u
#define VD_CNN_X86_TILE 64u

// Requantisation constants of 16 int32 lanes (any lane -> channel map):
// the vd_rq_ch_t fields spread for the even/odd 64-bit halves of
// _mm512_mul_epu32. bias includes the kernel's zero-point correction.
typedef struct vd_cnn_x86_rqv {
    int32_t bias[16];
    uint32_t mult[16];   // Q31 multiplier
    int32_t thr[16];
    uint32_t dk[16];     // 0 or 2^31
    uint32_t off[16];
    uint32_t lsh[16];
    uint64_t k_e[8], k_o[8];       // k of lanes 2j, 2j + 1
    uint64_t rsh_e[8], rsh_o[8];   // s of lanes 2j, 2j + 1 (31..62)
} vd_cnn_x86_rqv_t;

// Layer-wide part of the requantisation (output clamp relative to the zero point).
typedef struct vd_cnn_x86_rq {
    int32_t zp, lo, hi;
    bool general;   // some channel has lsh > 0
    bool sign;      // the sign term is needed (not ReLU-clamped, or general)
} vd_cnn_x86_rq_t;

// Kernel sets by what the CPU (and OS) supports.
#define VD_CNN_X86_NONE 0u     // portable C
#define VD_CNN_X86_AVX2 1u     // AVX2: 256-bit, int16 vpmaddwd
#define VD_CNN_X86_AVX512 2u   // AVX-512 F, BW, VL and VNNI: vpdpbusd / vpdpwssd
uint32_t vd_cnn_x86_level(void);

// Fills v for lanes 0..15: lane j takes output channel ch_of[j] of layer L
// (its bias, mult, shift; vd_rq_prepare), n_lanes lanes valid and the
// others copying lane 0, with corr[j] subtracted from the bias modulo 2^32
// (corr may be NULL).
void vd_cnn_x86_rqv_fill(vd_cnn_x86_rqv_t *v, const vd_cnn_layer_t *L, const uint32_t *ch_of, const int32_t *corr,
                         uint32_t n_lanes);

// Pointwise / spatial GEMM of one block: npix (1..16) rows of k4 bytes
// (k4 a multiple of 4), rstride bytes apart: unsigned x + 128 or, with
// flip, the int8 x itself (the kernel flips bit 7: a pointwise layer with
// cin a multiple of 4 reads its input row in place). Dotted with the packed
// int8 weights wp[k4 / 4][n_o][4] (n_o 1..64 channels), requantised with
// cv[n_o / 16 rounded up]; writes n_o int8 channels of npix pixels at out,
// pstride bytes apart. Only the npix rows are read.
void vd_cnn_x86_gemm(const uint8_t *rows, size_t rstride, bool flip, size_t k4, const int8_t *wp, size_t n_o,
                     const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out,
                     uint32_t npix);

// Packs the int8 weights w[n_o][k] (n_o <= 64) as wp[k4 / 4][n_o][4]
// (k4 = k rounded up to 4, zeros past k) and writes sum w of each channel
// (modulo 2^32) to wsum[n_o].
void vd_cnn_x86_pack(const int8_t *w, size_t k, size_t n_o, int8_t *wp, uint32_t *wsum);

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

// Output rows [y0, y1) of a DW3X3 layer L (weights read in place [9][c_n];
// bias - zp_in sum w folded into the constants here).
void vd_cnn_x86_dw_rows(const vd_cnn_x86_dw_t *d, const vd_cnn_layer_t *L, const vd_cnn_x86_rq_t *q, uint32_t y0,
                        uint32_t y1);

// AVX2 kernels. Packs w[n_o][k] as int16 pairs wp[k2 / 2][n_o][2] (k2 = k
// rounded up to 2, zero past k).
void vd_cnn_x86_pack16(const int8_t *w, size_t k, size_t n_o, int16_t *wp);
// The GEMM on the portable kernel's int16 rows (x - zp_in, padding 0;
// rstride int16 apart, zero past k), no correction; otherwise as
// vd_cnn_x86_gemm.
void vd_cnn_x86_gemm16(const int16_t *rows, size_t rstride, size_t k, const int16_t *wp, size_t n_o,
                       const vd_cnn_x86_rqv_t *cv, const vd_cnn_x86_rq_t *q, size_t pstride, int8_t *out,
                       uint32_t npix);
// As vd_cnn_x86_dw_rows, 16 channels per pass.
void vd_cnn_x86_dw_rows_avx2(const vd_cnn_x86_dw_t *d, const vd_cnn_layer_t *L, const vd_cnn_x86_rq_t *q,
                             uint32_t y0, uint32_t y1);

#endif
