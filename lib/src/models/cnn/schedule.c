// SPDX-License-Identifier: MIT
// CNN row schedule: which rows of which tensor the streamed executor (VD_CNN_STREAM) makes when, and the
// ring heights that follow from it.
//
// Algorithm: the streamed executor (VD_CNN_STREAM) keeps every tensor but the head as
// a ring of full-width rows. For head rows T = B, 2B, .. (B =
// p->band, plan.c) it first pulls: walking the layers backwards, the rows
// each tensor must have so that the head has T rows (p->need; rows_read of
// the consumers' last needed row, clamped). Then it pushes in sub-steps:
// tensor 0 gains B input rows, and in layer order
// every tensor makes the rows whose input rows exist, up to its need. Pull alone would make the
// whole receptive field of the first head row in one batch per tensor (an
// encoder tensor would hold tens of rows); push alone would finish every
// decoder tensor in one batch when the last input row arrives. Together a
// tensor holds its consumers' kernel rows plus what a skip must bridge.
// The plan runs the same walk without computing (vd__cnn_sched_next) and keeps per
// tensor the largest span from the oldest row a live consumer will still
// read to the newest row written: that is the ring height.
// Tensors the head does not depend on are never computed.
// Bounds: Hn / B pulls of O(n_layers); at most H0 + Hn + 1 sub-steps of
// O(n_layers) plus O(rows made); sizing adds O(n_layers) per batch.
// The plan (plan.c: ring heights) and the run (executor.c) iterate the same walk, so they make the
// same rows in the same order.
#include "models/cnn/cnn_internal.h"
#include "internal/vd_internal.h"

#include <string.h>

// Rows [*lo, *hi] of the input tensor(s) that output row y of L reads,
// before clamping (rows outside the input are padding).
static void rows_read(const vd_cnn_layer_t *L, uint32_t y, int32_t *lo, int32_t *hi)
{
    const int32_t s = L->stride;
    const int32_t yy = (int32_t)y;
    switch (L->op) {
    case VD_CNN_OP_CONV3X3:
    case VD_CNN_OP_DW3X3:
        *lo = s * yy - 1;
        *hi = s * yy + 1;
        break;
    case VD_CNN_OP_CONV5X5:
        *lo = s * yy - 2;
        *hi = s * yy + 2;
        break;
    case VD_CNN_OP_MAXPOOL2:
        *lo = 2 * yy;
        *hi = 2 * yy + 1;
        break;
    case VD_CNN_OP_UPSAMPLE2:
        *lo = yy / 2;
        *hi = yy / 2;
        break;
    default:   // PW1X1, CONCAT
        *lo = yy;
        *hi = yy;
        break;
    }
}

// Last input row (clamped to the input's last row hlast) that output row y reads.
static uint32_t row_hi(const vd_cnn_layer_t *L, uint32_t y, uint32_t hlast)
{
    int32_t lo, hi;
    rows_read(L, y, &lo, &hi);
    (void)lo;
    return ((uint32_t)hi < hlast) ? (uint32_t)hi : hlast;
}

// Output rows of L (of hout) whose last input row read (clamped to hlast) is below avail: a prefix,
// row_hi being non-decreasing in y; row_hi inverted, so a sub-step costs O(1) per tensor, not per row.
// Every op but the upsample reads up to row hi(y) = hi(0) + (hi(1) - hi(0)) y (rows_read).
static uint32_t rows_ready(const vd_cnn_layer_t *L, uint32_t avail, uint32_t hlast, uint32_t hout)
{
    if (avail > hlast) {
        return hout;   // every row's clamped last input row is <= hlast
    }
    // avail <= hlast: row y is ready iff its unclamped last row hi(y) <= avail - 1.
    int32_t lo, k0, k1;
    rows_read(L, 0u, &lo, &k0);
    rows_read(L, 1u, &lo, &k1);
    uint32_t n;
    if (L->op == VD_CNN_OP_UPSAMPLE2) {
        n = 2u * avail;   // hi = y / 2
    } else {
        n = (avail <= (uint32_t)k0) ? 0u : (avail - 1u - (uint32_t)k0) / (uint32_t)(k1 - k0) + 1u;
    }
    return (n < hout) ? n : hout;
}

static bool reads(const vd_cnn_layer_t *L, uint32_t t)
{
    return L->in == t || (L->op == VD_CNN_OP_CONCAT && L->in2 == t);
}

// Tensor heights and liveness (p->h, p->live) of a plan. Streamed without
// VD_CNN_KEEP_TENSORS, an upsample output whose every live consumer is a
// concat is fused into them (VD_CNN_LIVE_FUSED): never stored or computed, the
// concat reads its source's row y / 2, column x / 2 instead. That drops the
// upsampled rings, twice the source's row bytes each (models/vd_cnn.vdm at
// 320x256: 7 680 B).
void vd__cnn_sched_init(const vd_cnn_model_t *m, const chain_t *c, uint32_t height, uint32_t flags, vd_cnn_plan_t *p)
{
    const uint32_t n = m->n_layers;
    for (uint32_t t = 0u; t <= n; t++) {
        p->h[t] = (uint16_t)(height / c->f[t]);
        p->live[t] = (t == n) ? 1u : 0u;
    }
    for (uint32_t l = n; l-- > 0u;) {
        const vd_cnn_layer_t *L = &m->layers[l];
        if (p->live[l + 1u] != 0u) {
            p->live[L->in] = 1u;
            p->live[L->in2] = (L->op == VD_CNN_OP_CONCAT) ? 1u : p->live[L->in2];
        }
    }
    if ((flags & VD_CNN_STREAM) == 0u || (flags & VD_CNN_KEEP_TENSORS) != 0u) {
        return;
    }
    for (uint32_t l = 0u; l + 1u < n; l++) {   // never the head
        if (m->layers[l].op != VD_CNN_OP_UPSAMPLE2 || p->live[l + 1u] == 0u) {
            continue;
        }
        bool only_concat = true;
        for (uint32_t k = l + 1u; k < n && only_concat; k++) {
            const vd_cnn_layer_t *K = &m->layers[k];
            only_concat = p->live[k + 1u] == 0u || !reads(K, l + 1u) || K->op == VD_CNN_OP_CONCAT;
        }
        p->live[l + 1u] = only_concat ? (uint8_t)VD_CNN_LIVE_FUSED : p->live[l + 1u];
    }
}

// Pull: p->need, the rows every tensor must have for `target` head rows.
static void sched_pull(const vd_cnn_model_t *m, vd_cnn_plan_t *p, uint32_t target)
{
    const uint32_t n = m->n_layers;
    for (uint32_t t = 0u; t < n; t++) {
        p->need[t] = p->done[t];
    }
    p->need[n] = (uint16_t)target;
    for (uint32_t l = n; l-- > 0u;) {
        const vd_cnn_layer_t *L = &m->layers[l];
        if (p->live[l + 1u] == 0u || p->need[l + 1u] == 0u) {
            continue;
        }
        const uint32_t r = row_hi(L, p->need[l + 1u] - 1u, p->h[L->in] - 1u) + 1u;
        p->need[L->in] = (uint16_t)((r > p->need[L->in]) ? r : p->need[L->in]);
        if (L->op == VD_CNN_OP_CONCAT) {
            p->need[L->in2] = (uint16_t)((r > p->need[L->in2]) ? r : p->need[L->in2]);
        }
    }
}

// Push: p->req, the rows every tensor has after one sub-step: tensor 0
// p->band more input rows (up to its need), then in layer order
// each computed tensor every row whose input rows exist, up to its need.
// pulled: the need grew this sub-step (sched_pull); else a tensor whose inputs gained no row (req ==
// done: done holds the previous sub-step's req) keeps its rows, as its readiness and need are unchanged.
static void sched_push(const vd_cnn_model_t *m, vd_cnn_plan_t *p, bool pulled)
{
    const uint32_t n = m->n_layers;
    const uint32_t in_next = p->done[0] + p->band;
    p->req[0] = (uint16_t)((in_next < p->need[0]) ? in_next : ((p->done[0] < p->need[0]) ? p->need[0] : p->done[0]));
    for (uint32_t t = 1u; t <= n; t++) {
        const vd_cnn_layer_t *L = &m->layers[t - 1u];
        uint32_t y = p->done[t];
        const bool grew = p->req[L->in] != p->done[L->in] ||
                          (L->op == VD_CNN_OP_CONCAT && p->req[L->in2] != p->done[L->in2]);
        if (p->live[t] != 0u && (pulled || grew)) {
            uint32_t avail = p->req[L->in];
            if (L->op == VD_CNN_OP_CONCAT && p->req[L->in2] < avail) {
                avail = p->req[L->in2];
            }
            // Rows from done while below the need and ready.
            const uint32_t ready = rows_ready(L, avail, (uint32_t)p->h[L->in] - 1u, p->h[t]);
            const uint32_t upto = (ready < p->need[t]) ? ready : p->need[t];
            y = (upto > y) ? upto : y;
        }
        p->req[t] = (uint16_t)y;
    }
}

// The oldest input row that layer L, which makes tensor u, still reads
// (UINT32_MAX once u is complete).
static uint32_t consumer_row(const vd_cnn_layer_t *L, const vd_cnn_plan_t *p, uint32_t u)
{
    if (p->done[u] >= p->h[u]) {
        return UINT32_MAX;
    }
    int32_t lo, hi;
    rows_read(L, p->done[u], &lo, &hi);
    (void)hi;
    return (lo > 0) ? (uint32_t)lo : 0u;
}

// Oldest row of tensor u that its live consumers still read (p->req[u] when
// none). For the consumers of a fused upsample, which are never fused.
static uint32_t read_oldest(const vd_cnn_model_t *m, const vd_cnn_plan_t *p, uint32_t u)
{
    uint32_t oldest = p->req[u];
    for (uint32_t l = u; l < m->n_layers; l++) {
        if (p->live[l + 1u] != 0u && reads(&m->layers[l], u)) {
            const uint32_t r = consumer_row(&m->layers[l], p, l + 1u);
            oldest = (r < oldest) ? r : oldest;
        }
    }
    return oldest;
}

// Oldest row of tensor t that a live, unfinished consumer still reads
// (p->req[t] when none). Row y of a fused upsample of t is row y / 2 of t,
// read when the upsample's concats read it.
static uint32_t sched_oldest(const vd_cnn_model_t *m, const vd_cnn_plan_t *p, uint32_t t)
{
    uint32_t oldest = p->req[t];
    for (uint32_t l = t; l < m->n_layers; l++) {
        if (p->live[l + 1u] == 0u || !reads(&m->layers[l], t)) {
            continue;
        }
        const uint32_t r = (p->live[l + 1u] == VD_CNN_LIVE_FUSED) ? read_oldest(m, p, l + 1u) / 2u
                                                           : consumer_row(&m->layers[l], p, l + 1u);
        oldest = (r < oldest) ? r : oldest;
    }
    return oldest;
}

// Next sub-step of the streamed schedule into p->req (rows to make: req[t]
// > done[t]; the caller makes them and sets done = req); false once the
// head is complete. *target: head rows of the current band, 0 to start
// (with p->done all 0). Each call adds an input row or completes the band's
// need (sched_push), so a walk takes at most H0 + Hn + 1 calls. The plan
// (ring sizing) and the run iterate the same way, so they make the same
// rows in the same order.
bool vd__cnn_sched_next(const vd_cnn_model_t *m, vd_cnn_plan_t *p, uint32_t *target)
{
    const uint32_t n = m->n_layers;
    const bool pulled = p->done[n] >= *target;
    if (pulled) {
        if (*target >= p->h[n]) {
            return false;
        }
        *target = (*target + p->band < p->h[n]) ? *target + p->band : p->h[n];
        sched_pull(m, p, *target);
    }
    sched_push(m, p, pulled);
    return true;
}

void vd__cnn_sched_start(vd_cnn_plan_t *p, uint32_t *target, uint32_t *max_steps)
{
    memset(p->done, 0, sizeof p->done);
    memset(p->req, 0, sizeof p->req);
    *target = 0u;
    *max_steps = (uint32_t)p->h[0] + p->h[0] + 2u;   // H0 + Hn + 1 < 2 H0 + 2
}

// Oldest row of tensor t a live consumer still reads after this sub-step; for the head with
// VD_CNN_HEAD_RING, its decoder (vd_cnn_run_rows_decode): rows from done - 1 are undecided, and the peak
// test of row done - 1 reads row done - 2.
static uint32_t oldest_read(const vd_cnn_model_t *m, const vd_cnn_plan_t *p, uint32_t t, bool ring_head)
{
    if (t == m->n_layers && ring_head) {
        return (p->done[t] >= 2u) ? p->done[t] - 2u : 0u;
    }
    return sched_oldest(m, p, t);
}

// p->rows: ring heights. Whole plane: every tensor's height. Streamed: the
// walk above; the head (read by vd_cnn_decode) stays whole unless VD_CNN_HEAD_RING (then the rows its
// decoder still reads), and with VD_CNN_KEEP_TENSORS every computed tensor does.
void vd__cnn_sched_rows(const vd_cnn_model_t *m, const chain_t *c, uint32_t height, uint32_t flags, vd_cnn_plan_t *p)
{
    const uint32_t n = m->n_layers;
    vd__cnn_sched_init(m, c, height, flags, p);
    const bool stream = (flags & VD_CNN_STREAM) != 0u;
    const bool keep = (flags & VD_CNN_KEEP_TENSORS) != 0u;
    const bool ring_head = stream && !keep && (flags & VD_CNN_HEAD_RING) != 0u;
    for (uint32_t t = 0u; t <= n; t++) {
        p->rows[t] = (!stream || ((keep || (t == n && !ring_head)) && p->live[t] != 0u)) ? p->h[t] : 0u;
    }
    if (!stream) {
        return;
    }
    // Ring heights: per tensor the largest span from the oldest row a live
    // consumer still reads to the newest row made.
    uint32_t target, max_steps;
    vd__cnn_sched_start(p, &target, &max_steps);
    for (uint32_t k = 0u; k < max_steps && vd__cnn_sched_next(m, p, &target); k++) {
        for (uint32_t t = 0u; t <= n; t++) {
            if (p->req[t] > p->done[t]) {
                const uint32_t span = p->req[t] - oldest_read(m, p, t, ring_head);
                p->rows[t] = (uint16_t)((span > p->rows[t]) ? span : p->rows[t]);
                p->done[t] = p->req[t];
            }
        }
    }
    VD_ASSERT(p->done[n] == p->h[n]);
    for (uint32_t t = 0u; t <= n; t++) {
        // A computed tensor is read, so some batch had a span >= 1; the
        // floor only keeps vd_cnn_ring_row's modulo defined whatever happens.
        // A fused upsample has no rows.
        const bool fused = p->live[t] == VD_CNN_LIVE_FUSED;
        const uint32_t min_rows = (fused || p->live[t] == 0u) ? 0u : 1u;
        p->rows[t] = fused ? 0u : (uint16_t)((p->rows[t] < min_rows) ? min_rows : p->rows[t]);
    }
}
