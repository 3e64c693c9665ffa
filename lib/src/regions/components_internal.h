// SPDX-License-Identifier: MIT
// Streaming row-pair labeller of components.c, for stages that make their
// mask a row pair at a time (contrast.c) and keep no frame-sized buffer.
//
// Rows come in pairs (y, y + 1) of 8-bit pixels compared with a threshold
// (>= thr is foreground). The result is that of vd_components_label_thr_u8 on
// the whole frame: the same components in the same order (labels 1..n of the
// whole-frame labeller), out[] holding the first `cap` of them, and `labels`
// counting all. Only the components still open (touching the pair's second
// row) are kept between pairs, so the workspace grows with the width only.
// Bounds: workspace as vd__components_stream_workspace_size (24 * ceil(w/2) for the
// run rows plus 40 per node, 3 * ceil(w/2) nodes); time O(w) per pair for
// the runs plus near-linear union-find, and per complete component an
// insertion into out[] (O(1) when components complete in order, O(cap) worst).
#ifndef VD_COMPONENTS_INTERNAL_H
#define VD_COMPONENTS_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "vd/components.h"

struct cc_span;
union cc_slot;
struct cc_rec;

typedef struct vd__components_stream {
    struct cc_span *up, *a, *b; // runs of the row above the pair and of its two rows
    union cc_slot *node;        // per node: union-find parent, then the open mark
    struct cc_rec *rec;         // per node: statistics of its part of a component
    size_t nup;                 // runs in `up`
    uint32_t w;                 // row width
    uint32_t m;                 // open components: nodes [0, m)
    uint32_t labels;            // complete components so far (all, not only those in out)
    vd_component_t *out;
    size_t cap, n;              // out[]'s capacity and entries
} vd__components_stream_t;

// Workspace bytes of the streaming labeller for rows of up to max_width pixels.
vd_status_t vd__components_stream_workspace_size(uint32_t max_width, size_t *bytes);

// Carves ws (VD_WORKSPACE_ALIGN-aligned, >= the size for width) and starts an
// empty labelling that fills out[0 .. cap).
vd_status_t vd__components_stream_init(vd__components_stream_t *s, uint32_t width, void *ws, size_t bytes, vd_component_t *out,
                              size_t cap);

// Forgets every pair labelled so far (out[] and labels start again).
void vd__components_stream_restart(vd__components_stream_t *s);

// Labels rows y (ra) and y + 1 (rb; NULL past the frame's last row) of the
// mask pixel >= thr; y is even and pairs come in order from y = 0.
void vd__components_stream_pair(vd__components_stream_t *s, const uint8_t *ra, const uint8_t *rb, uint32_t y, uint8_t thr);

// Ends the frame: the components still open are complete. Returns the number
// of entries in out[] (image coordinates of the rows given, as
// vd_components_label); s->labels then counts every component.
size_t vd__components_stream_finish(vd__components_stream_t *s);

#endif
