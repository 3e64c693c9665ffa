// SPDX-License-Identifier: MIT
// Private constants of the CNN module (lib/src/cnn.c): workspace run record, kernel block sizes; and the
// decode-table lookup the detector needs for its score threshold.
#ifndef VD_CNN_INTERNAL_H
#define VD_CNN_INTERNAL_H

#include <stdint.h>

#include "vd/cnn.h"

// Workspace plan items: item 0 tensor 0, item 1 the stretch histogram, then
// per layer l its output tensor (2 + 2l) and its scratch (3 + 2l).
#define VD_CNN_MAX_ITEMS (2u + 2u * VD_CNN_MAX_LAYERS)
// Every item starts at a multiple of this (from the workspace start) and its
// length is rounded up to it.
#define VD_CNN_ITEM_ALIGN 16u
#define VD_CNN_REC_MAGIC 0x524E4E43u   // "CNNR"
// Output pixels per block of the CONV3X3 / PW1X1 kernel (a multiple of 4), and its K chunk
// (K is zero-padded to a multiple of it).
#define VD_CNN_NPIX 16u
#define VD_CNN_KCHUNK 8u
// Channels per pass of the depthwise kernel (weight copies padded to it).
#define VD_CNN_DWB 16u
// Head rows per step of the streamed executor (VD_CNN_STREAM): rings grow
// by about this many rows per tensor, per-layer set-up runs once per band.
#ifndef VD_CNN_BAND_ROWS
#define VD_CNN_BAND_ROWS 1u
#endif
// Input rows per push sub-step of the streamed schedule (>= 1): more rows
// per kernel call (set-up amortised), taller rings.
#ifndef VD_CNN_BAND_IN_ROWS
#define VD_CNN_BAND_IN_ROWS 1u
#endif
// Streamed: output channels per int16 weight copy of a CONV / PW layer
// (the one shared scratch holds 2 * this * K bytes of weights).
#ifndef VD_CNN_STREAM_COUT
#define VD_CNN_STREAM_COUT 64u
#endif
// Stretch histogram (uint32[256]) and its int8 lookup table.
#define VD_CNN_HIST_BYTES (256u * 4u + 256u)

// The run record at the start of the workspace: the plan of the run and,
// after a complete run, the key vd_cnn_tensor checks. Offsets are from the
// workspace start; item lifetimes are steps (0 = input, l + 1 = layer l).
typedef struct vd_cnn_plan {
    uint32_t magic;           // VD_CNN_REC_MAGIC after a complete run, else 0
    uint32_t flags;
    uint32_t width;
    uint32_t height;
    uint32_t crc;             // model identity
    uint32_t size;
    uint32_t n_items;
    uint32_t total;           // workspace bytes, record included
    uint32_t off[VD_CNN_MAX_ITEMS];
    uint32_t len[VD_CNN_MAX_ITEMS];
    uint8_t first[VD_CNN_MAX_ITEMS];
    uint8_t last[VD_CNN_MAX_ITEMS];
    // Per tensor: rows kept (ring height; the height for a whole plane, 0 if
    // never computed), height, and the row schedule's counters.
    uint16_t rows[VD_CNN_MAX_TENSORS];
    uint16_t h[VD_CNN_MAX_TENSORS];
    uint16_t done[VD_CNN_MAX_TENSORS];   // rows produced so far
    uint16_t need[VD_CNN_MAX_TENSORS];   // rows needed for the current head target
    uint16_t req[VD_CNN_MAX_TENSORS];    // rows made by the current sub-step
    uint8_t live[VD_CNN_MAX_TENSORS];    // 1: the head depends on it; 2: also, an upsample fused into its concats
} vd_cnn_plan_t;

// Bytes of the record (items start after it).
#define VD_CNN_REC_BYTES \
    ((uint32_t)((sizeof(vd_cnn_plan_t) + VD_CNN_ITEM_ALIGN - 1u) / VD_CNN_ITEM_ALIGN * VD_CNN_ITEM_ALIGN))

// Decoded heatmap score (Q15, 0..32768) of int8 value v (-128..127) of a
// model vd_cnn_load filled (its score table is checked there); the table
// vd_cnn_thr_from_score searches.
uint32_t vd_cnn_score_of_logit(const vd_cnn_model_t *m, int32_t v);

#endif
