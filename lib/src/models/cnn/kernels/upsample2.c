// SPDX-License-Identifier: MIT
// CNN kernel UPSAMPLE2: x2 nearest-neighbour upsample (a copy op).
//
// Algorithm: output (x, y) is input (x / 2, y / 2); same scale and zero point, so a byte copy per
// pixel. Streamed, an upsample read only by concats is not run at all: the concat reads its
// source (concat.c, VD_CNN_LIVE_FUSED).
// Bounds: one memcpy of c bytes per output pixel; no scratch.
#include "models/cnn/cnn_internal.h"

#include <string.h>

void vd__cnn_upsample2_rows(const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0, uint32_t y1)
{
    const uint32_t c_n = g->co;
    for (uint32_t y = y0; y < y1; y++) {
        const int8_t *src = vd_cnn_ring_row(in, y / 2u);
        int8_t *o = vd_cnn_ring_row(out, y);
        for (uint32_t x = 0u; x < g->wo; x++) {
            memcpy(o + (size_t)x * c_n, src + (size_t)(x / 2u) * c_n, c_n);
        }
    }
}
