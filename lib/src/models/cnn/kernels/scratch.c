// SPDX-License-Identifier: MIT
// CNN kernels' shared part: the scratch layout of a weighted layer and its per-channel requantisation
// constants.
//
// Algorithm: a weighted layer's scratch holds, each piece at a multiple of VD_CNN_ITEM_ALIGN, its
// kernel's int16 weight copy, its int16 rows (CONV / PW) or zero-point row (DW3X3), then one vd_rq_ch_t
// per output channel: the TFLite double-rounding requantisation of models/requant.h prepared once per
// layer call (vd_rq_prepare), so the kernels' inner loops read loop-invariant constants. Each kernel's
// scratch query (conv.c, dw3x3.c) gives the byte counts of its first two pieces.
// Bounds: O(cout) per layer call; cin, cout <= 1024 keep every size below 2^26.
#include "models/cnn/cnn_internal.h"

uint64_t vd__cnn_scratch_pack(const vd_cnn_layer_t *L, uint32_t w_bytes, uint32_t r_bytes, scratch_layout_t *s)
{
    // Each piece starts at a multiple of VD_CNN_ITEM_ALIGN; cin, cout <= 1024
    // keep every size below 2^26.
    s->w16 = 0u;
    s->rows = vd_cnn_round_up(w_bytes, VD_CNN_ITEM_ALIGN);
    s->ch = s->rows + vd_cnn_round_up(r_bytes, VD_CNN_ITEM_ALIGN);
    return (uint64_t)s->ch + vd_cnn_round_up((uint32_t)(L->cout * sizeof(vd_rq_ch_t)), VD_CNN_ITEM_ALIGN);
}

// Fills the scratch constants of a weighted layer; returns the view on them.
rq_t vd__cnn_rq_setup(const vd_cnn_layer_t *L, uint8_t *scr, const scratch_layout_t *s)
{
    vd_rq_ch_t *ch = (vd_rq_ch_t *)(void *)(scr + s->ch);
    for (uint32_t o = 0u; o < L->cout; o++) {
        vd_rq_prepare(vd_cnn_rd_i32(L->mult + 4u * (size_t)o), L->shift[o], vd_cnn_rd_i32(L->bias + 4u * (size_t)o),
                      &ch[o]);
    }
    rq_t q;
    q.ch = ch;
    q.general = false;
    for (uint32_t o = 0u; o < L->cout; o++) {
        q.general = q.general || ch[o].lsh != 0u;
    }
    q.zp = L->out_zp;
    q.lo = L->act_min - L->out_zp;
    q.hi = L->act_max - L->out_zp;
    q.relu = q.lo >= 0;
    return q;
}
