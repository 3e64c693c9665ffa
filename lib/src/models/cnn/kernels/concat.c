// SPDX-License-Identifier: MIT
// CNN kernel CONCAT: channel concatenation of two tensors (a copy op).
//
// Algorithm: output pixel = the a tensor's channels, then the b tensor's; same scale and zero point.
// An operand may be a fused upsample (ua / ub = 1): its source is read at row y >> 1, column
// x >> 1, so the upsampled tensor is never stored (schedule.c).
// Bounds: two copies per output pixel; no scratch.
#include "models/cnn/cnn_internal.h"

#include <string.h>

// Copies one operand's n channels of a pixel. The shipped networks' counts as fixed-size copies, which
// compilers inline as a few word loads and stores: a memcpy call per pixel and operand cost ~25
// instructions of set-up for 8..32 bytes (Cortex-M7, newlib-nano; 0.47 M per frame of vd_cnn_compact).
static inline void chan_copy(int8_t *d, const int8_t *s, uint32_t n)
{
    switch (n) {
    case 8u:
        memcpy(d, s, 8u);
        break;
    case 16u:
        memcpy(d, s, 16u);
        break;
    case 32u:
        memcpy(d, s, 32u);
        break;
    default:
        memcpy(d, s, n);
        break;
    }
}

void vd__cnn_concat_rows(const vd_cnn_layer_t *L, const geom_t *g, const ring_t *a, uint32_t ua, const ring_t *b,
                        uint32_t ub, const ring_t *out, uint32_t y0, uint32_t y1)
{
    // Locals: the byte stores may alias *L and *g, which the compiler would reload per pixel.
    const uint32_t ca = L->cin;
    const uint32_t cb = (uint32_t)L->cout - L->cin;
    const size_t co = L->cout;
    const uint32_t wo = g->wo;
    for (uint32_t y = y0; y < y1; y++) {
        const int8_t *ra = vd_cnn_ring_row(a, y >> ua);
        const int8_t *rb = vd_cnn_ring_row(b, y >> ub);
        int8_t *o = vd_cnn_ring_row(out, y);
        for (uint32_t x = 0u; x < wo; x++, o += co) {
            chan_copy(o, ra + (size_t)(x >> ua) * ca, ca);
            chan_copy(o + ca, rb + (size_t)(x >> ub) * cb, cb);
        }
    }
}
