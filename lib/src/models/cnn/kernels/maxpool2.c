// SPDX-License-Identifier: MIT
// CNN kernel MAXPOOL2: 2x2 max-pool, stride 2 (a copy op: no weights, no requantisation).
//
// Algorithm: output (x, y) is the largest of input (2x..2x+1, 2y..2y+1), per channel; input and
// output share scale and zero point (the loader checks it), so no requantisation.
// Bounds: 3 compares per output value; no scratch.
#include "models/cnn/cnn_internal.h"

void vd__cnn_maxpool2_rows(const geom_t *g, const ring_t *in, const ring_t *out, uint32_t y0, uint32_t y1)
{
    const uint32_t c_n = g->co;
    for (uint32_t y = y0; y < y1; y++) {
        const int8_t *r0 = vd_cnn_ring_row(in, 2u * y);
        const int8_t *r1 = vd_cnn_ring_row(in, 2u * y + 1u);
        int8_t *orow = vd_cnn_ring_row(out, y);
        for (uint32_t x = 0u; x < g->wo; x++) {
            const int8_t *a = r0 + (size_t)(2u * x) * c_n;
            const int8_t *b = a + c_n;
            const int8_t *c = r1 + (size_t)(2u * x) * c_n;
            const int8_t *d = c + c_n;
            int8_t *o = orow + (size_t)x * c_n;
            for (uint32_t k = 0u; k < c_n; k++) {
                const int8_t m1 = (a[k] > b[k]) ? a[k] : b[k];
                const int8_t m2 = (c[k] > d[k]) ? c[k] : d[k];
                o[k] = (m1 > m2) ? m1 : m2;
            }
        }
    }
}
