// SPDX-License-Identifier: MIT
// CNN workspace plan: the items of a run (tensors, histogram, scratch), their lifetimes and offsets; the
// size queries, vd_cnn_macs, and vd_cnn_tensor, which reads a tensor back through the run record.
//
// Algorithm: deterministic first-fit liveness planning. Items are placed in index order (tensor 0,
// histogram, then per layer its output and its scratch), each at the lowest offset (multiple of
// VD_CNN_ITEM_ALIGN) where it overlaps no placed item whose lifetime intersects its own; a list of
// placed items sorted by offset makes one item O(items). Whole plane, a tensor lives from the layer
// that makes it to its last reader (every one to the end with VD_CNN_KEEP_TENSORS) and a scratch for
// its layer only. Streamed (VD_CNN_STREAM), tensors are rings whose heights come from the row schedule
// (schedule.c), every item lives for the whole run (the layers interleave) and one scratch, sized for
// the largest layer, serves all of them; with the CMSIS back end's DSP kernels the other layers' scratch
// items (and a piece of item 1 for layer 0) hold prepared areas (prep_size). The plan is written to the
// workspace's run record, so the size query and the run compute the same offsets.
// A run keeps the ring heights of the run before in the same workspace (same model, size and flags:
// vd__cnn_plan_for_run), so a detector's second and later frames skip the sizing walk.
// Bounds: O(items^2) for the plan (items <= 2 + 2 L) plus the schedule's ring sizing
// O((H0 + Hn) L^2) when the heights are not kept; stack ~1.5 KiB for the size query (the plan on the
// stack), vd_cnn_tensor ~320 B (reads the run record back instead).
#include "vd/cnn.h"

#include "models/cnn/cnn_internal.h"
#include "core/crc32.h"
#include "internal/vd_internal.h"

#include <string.h>

// Scratch bytes (0: none) and layout of layer L, from its kernel's query.
static uint64_t scratch_of(const vd_cnn_layer_t *L, bool stream, scratch_layout_t *s)
{
    if (L->op == VD_CNN_OP_DW3X3) {
        return vd__cnn_dw3x3_scratch(L, s);   // no chunks: the same layout either way
    }
    if (vd_cnn_spatial_conv(L->op) || L->op == VD_CNN_OP_PW1X1) {
        return vd__cnn_conv_scratch(L, stream, s);
    }
    memset(s, 0, sizeof *s);
    return 0u;
}

#if defined(VD_CNN_CMSIS)
// Streamed, the CMSIS back end's prepared areas (vd_cnn_prep_at: item 3 + 2l, layer 0's in item 1): a
// layer's DSP set-up (weights widened, requantisation constants) made on its first call of a run instead
// of on every call, which is one output row. Not every layer's fits a small device's workspace, so a
// deterministic rule, a pure function of the model, size and flags like the rest of the plan: the layers
// by output height (calls per run), tallest first, then by index, each taken if the workspace stays within
// VD_CNN_PREP_CAP (224 KiB: a 256 KiB detector workspace keeps room for its other slices). Streamed,
// every item lives for the whole run, so the workspace is the record plus the sum of the items.
static void prep_size(const vd_cnn_model_t *m, vd_cnn_plan_t *p)
{
    const uint32_t n = m->n_layers;
    uint64_t used = VD_CNN_REC_BYTES;
    for (uint32_t i = 0u; i < p->n_items; i++) {
        used += p->len[i];
    }
    uint32_t seen = 0u;   // bit l: layer l considered (a mask, not an array of sizes: the size query's stack)
    for (uint32_t k = 0u; k < n; k++) {
        uint32_t best = n;
        for (uint32_t l = 0u; l < n; l++) {
            if ((seen & (1u << l)) == 0u && (best == n || p->h[l + 1u] > p->h[best + 1u])) {
                best = l;
            }
        }
        seen |= 1u << best;
        const vd_cnn_layer_t *L = &m->layers[best];
        const uint32_t want = (p->live[best + 1u] != 0u && vd_cnn_weighted(L->op)) ? vd__cnn_cmsis_prep_bytes(L) : 0u;
        if (want != 0u && used + want <= VD_CNN_PREP_CAP) {
            used += want;
            p->len[(best == 0u) ? 1u : 3u + 2u * best] += want;
        }
    }
}
#endif

// Length and lifetime (p->len, p->first, p->last) of every item. Streamed,
// every item lives for the whole run and one scratch (item 3) serves every layer
// (then the CMSIS back end's prepared areas, prep_size).
static vd_status_t items_size(const vd_cnn_model_t *m, const chain_t *c, uint32_t width, uint32_t flags,
                              vd_cnn_plan_t *p)
{
    const uint32_t n = m->n_layers;
    const bool keep = (flags & VD_CNN_KEEP_TENSORS) != 0u;
    const bool stream = (flags & VD_CNN_STREAM) != 0u;
    uint64_t scratch_max = 0u;
    for (uint32_t l = 0u; l < n && stream; l++) {
        scratch_layout_t s;
        const uint64_t len = scratch_of(&m->layers[l], true, &s);
        scratch_max = (len > scratch_max) ? len : scratch_max;
    }
    uint8_t last_read[VD_CNN_MAX_TENSORS];
    for (uint32_t t = 0u; t <= n; t++) {
        last_read[t] = (uint8_t)t;
    }
    for (uint32_t l = 0u; l < n; l++) {
        const vd_cnn_layer_t *L = &m->layers[l];
        last_read[L->in] = (uint8_t)(l + 1u);
        if (L->op == VD_CNN_OP_CONCAT) {
            last_read[L->in2] = (uint8_t)(l + 1u);
        }
    }
    p->n_items = 2u + 2u * n;
    for (uint32_t i = 0u; i < p->n_items; i++) {
        uint64_t len;
        uint32_t first, last;
        if (i == 0u) {
            len = (uint64_t)width * p->rows[0];
            first = 0u;
            last = keep ? n : last_read[0];
        } else if (i == 1u) {
            len = (m->input_norm != VD_CNN_NORM_NONE) ? VD_CNN_HIST_BYTES : 0u;
            len += stream ? vd_cnn_round_up(width, VD_CNN_ITEM_ALIGN) : 0u;   // row buffer of vd_cnn_run_rows
            first = 0u;
            last = 0u;
        } else if (i % 2u == 0u) {
            const uint32_t t = i / 2u;   // tensor t = layer t-1's output
            len = vd_cnn_tensor_bytes(c, t, width, p->rows[t]);
            first = t;
            last = (keep || t == n) ? n : last_read[t];
        } else if (stream) {
            len = (i == 3u) ? scratch_max : 0u;
            first = 0u;
            last = 0u;
        } else {
            scratch_layout_t s;
            len = scratch_of(&m->layers[i / 2u - 1u], false, &s);
            first = i / 2u;
            last = first;
        }
        if (stream) {
            first = 0u;
            last = n;
        }
        VD_VERIFY(len <= (uint64_t)UINT32_MAX - 2u * VD_CNN_ITEM_ALIGN, VD_ERR_OVERFLOW);
        p->len[i] = vd_cnn_round_up((uint32_t)len, VD_CNN_ITEM_ALIGN);
        p->first[i] = (uint8_t)first;
        p->last[i] = (uint8_t)last;
    }
#if defined(VD_CNN_CMSIS)
    if (stream) {   // with VD_CNN_PORTABLE too: the flag changes the kernels, never the workspace
        prep_size(m, p);
    }
#endif
    return VD_OK;
}

// First-fit offsets of the sized items (from the end of the run record);
// *end: the bytes they span.
static vd_status_t items_place(vd_cnn_plan_t *p, uint64_t *end_out)
{
    uint8_t order[VD_CNN_MAX_ITEMS];   // placed items by offset
    uint32_t n_placed = 0u;
    uint64_t end = 0u;
    for (uint32_t i = 0u; i < p->n_items; i++) {
        p->off[i] = 0u;
        if (p->len[i] == 0u) {
            continue;
        }
        uint64_t off = 0u;
        uint32_t pos = 0u;   // insertion point in order[]
        for (uint32_t k = 0u; k < n_placed; k++) {
            const uint32_t j = order[k];
            if (p->first[j] > p->last[i] || p->first[i] > p->last[j]) {
                continue;   // never live at the same time
            }
            if (off + p->len[i] <= p->off[j]) {
                break;      // fits in the gap before j
            }
            const uint64_t e = (uint64_t)p->off[j] + p->len[j];
            off = (e > off) ? e : off;
        }
        VD_VERIFY(off + p->len[i] <= (uint64_t)UINT32_MAX - VD_CNN_REC_BYTES, VD_ERR_OVERFLOW);
        p->off[i] = (uint32_t)off;
        while (pos < n_placed && p->off[order[pos]] <= p->off[i]) {
            pos++;
        }
        for (uint32_t k = n_placed; k > pos; k--) {
            order[k] = order[k - 1u];
        }
        order[pos] = (uint8_t)i;
        n_placed++;
        end = (off + p->len[i] > end) ? off + p->len[i] : end;
    }
    *end_out = end;
    return VD_OK;
}

// Items, offsets and the key vd_cnn_tensor checks after the run, of a plan whose ring heights are set.
static vd_status_t plan_items(const vd_cnn_model_t *m, const chain_t *c, uint32_t width, uint32_t height,
                              uint32_t flags, vd_cnn_plan_t *p)
{
    VD_TRY(items_size(m, c, width, flags, p));
    uint64_t end;
    VD_TRY(items_place(p, &end));
    for (uint32_t i = 0u; i < p->n_items; i++) {
        p->off[i] += VD_CNN_REC_BYTES;
    }
    VD_VERIFY(end + VD_CNN_REC_BYTES <= (uint64_t)UINT32_MAX && end + VD_CNN_REC_BYTES <= (uint64_t)SIZE_MAX,
              VD_ERR_OVERFLOW);
    p->total = (uint32_t)(end + VD_CNN_REC_BYTES);
    p->flags = flags;
    p->width = width;
    p->height = height;
    p->crc = m->crc32;
    p->size = m->size;
    return VD_OK;
}

// CRC-32 of the ring heights, tensor heights and liveness of tensors 0..n.
static uint32_t rows_crc(const vd_cnn_plan_t *p, uint32_t n)
{
    uint32_t crc = vd__crc32(0u, p->rows, (n + 1u) * sizeof p->rows[0]);
    crc = vd__crc32(crc, p->h, (n + 1u) * sizeof p->h[0]);
    crc = vd__crc32(crc, p->live, (n + 1u) * sizeof p->live[0]);
    return vd__crc32(crc, &p->band, sizeof p->band);
}

// The plan with band b (the ring heights from the row schedule, their CRC, the items).
static vd_status_t plan_band(const vd_cnn_model_t *m, const chain_t *c, uint32_t width, uint32_t height,
                             uint32_t flags, uint32_t b, vd_cnn_plan_t *p)
{
    p->band = (uint8_t)b;
    vd__cnn_sched_rows(m, c, height, flags, p);
    p->rows_crc = rows_crc(p, m->n_layers);
    return plan_items(m, c, width, height, flags, p);
}

// The plan of a run: ring heights (the row schedule), items, offsets; the
// key vd_cnn_tensor checks after the run. Streamed, the band (cnn_internal.h, VD_CNN_BAND_CAP): 1 when
// that plan's workspace exceeds the cap (the larger networks, whose rings set the detector's workspace),
// else the tallest band from VD_CNN_BAND_MAX down whose workspace stays within it. A pure function of the
// model, size and flags like the rest of the plan; up to 2 + log2(VD_CNN_BAND_MAX) sizing walks.
vd_status_t vd__cnn_plan_make(const vd_cnn_model_t *m, const chain_t *c, uint32_t width, uint32_t height,
                             uint32_t flags, vd_cnn_plan_t *p)
{
    // A ring head is streamed, and KEEP_TENSORS keeps every tensor whole.
    VD_VERIFY((flags & VD_CNN_HEAD_RING) == 0u ||
                  (flags & (VD_CNN_STREAM | VD_CNN_KEEP_TENSORS)) == VD_CNN_STREAM,
              VD_ERR_ARG);
    VD_TRY(plan_band(m, c, width, height, flags, 1u, p));
    if ((flags & VD_CNN_STREAM) == 0u || p->total > VD_CNN_BAND_CAP) {
        return VD_OK;
    }
    for (uint32_t b = VD_CNN_BAND_MAX; b >= 2u; b /= 2u) {
        VD_TRY(plan_band(m, c, width, height, flags, b, p));
        if (p->total <= VD_CNN_BAND_CAP) {
            return VD_OK;
        }
    }
    return plan_band(m, c, width, height, flags, 1u, p);
}

// True when the record p, written by a complete run (or vd__cnn_plan_ahead) with the same model, size and
// flags, holds ring heights and a band this run can keep: heights and liveness recomputed equal the kept
// ones (CRC), every ring within its tensor and a computed tensor's at least one row (the ring row
// modulo). The record is caller memory: what is kept is checked, and the items are sized from the kept
// heights, so a record changed since the last run can make a run compute wrong values only after forging
// the CRC, never write outside its items.
static bool rows_kept(const vd_cnn_model_t *m, const chain_t *c, uint32_t width, uint32_t height, uint32_t flags,
                      vd_cnn_plan_t *p)
{
    const uint32_t n = m->n_layers;
    const bool planned = p->magic == VD_CNN_REC_MAGIC || p->magic == VD_CNN_PLAN_MAGIC;
    if (!planned || p->flags != flags || p->width != width || p->height != height || p->crc != m->crc32 ||
        p->size != m->size || p->band < 1u || p->band > VD_CNN_BAND_MAX) {
        return false;
    }
    const uint32_t kept = p->rows_crc;
    vd__cnn_sched_init(m, c, height, flags, p);
    for (uint32_t t = 0u; t <= n; t++) {
        const bool computed = p->live[t] != 0u && p->live[t] != VD_CNN_LIVE_FUSED;
        if (p->rows[t] > p->h[t] || (computed && p->rows[t] == 0u) ||
            (p->live[t] == VD_CNN_LIVE_FUSED && p->rows[t] != 0u)) {
            return false;
        }
    }
    return rows_crc(p, n) == kept;
}

vd_status_t vd__cnn_plan_for_run(const vd_cnn_model_t *m, const chain_t *c, uint32_t width, uint32_t height,
                                 uint32_t flags, vd_cnn_plan_t *p, bool *after_run)
{
    const uint32_t pf = flags & ~VD_CNN_RUN_ONLY_FLAGS;
    const bool keep = (flags & VD_CNN_REUSE_PLAN) != 0u && rows_kept(m, c, width, height, pf, p);
    *after_run = keep && p->magic == VD_CNN_REC_MAGIC;
    p->magic = 0u;   // set again by a complete run
    if (!keep) {
        return vd__cnn_plan_make(m, c, width, height, pf, p);
    }
    return plan_items(m, c, width, height, pf, p);
}

vd_status_t vd__cnn_plan_ahead(const vd_cnn_model_t *m, uint32_t width, uint32_t height, uint32_t flags, void *ws,
                               size_t bytes)
{
    VD_VERIFY(m != NULL && (flags & ~VD_CNN_RUN_FLAGS) == 0u, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(vd__cnn_model_ok(m, &c), VD_ERR_STATE);
    VD_VERIFY(vd__cnn_size_ok(m, width, height), VD_ERR_ARG);
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % (uintptr_t)VD_WORKSPACE_ALIGN) == 0u, VD_ERR_WORKSPACE);
    VD_VERIFY(bytes >= VD_CNN_REC_BYTES, VD_ERR_WORKSPACE);
    vd_cnn_plan_t *p = (vd_cnn_plan_t *)ws;
    p->magic = 0u;
    VD_TRY(vd__cnn_plan_make(m, &c, width, height, flags & ~VD_CNN_RUN_ONLY_FLAGS, p));
    VD_VERIFY(bytes >= p->total, VD_ERR_WORKSPACE);
    p->magic = VD_CNN_PLAN_MAGIC;
    return VD_OK;
}

vd_status_t vd_cnn_workspace_size_ex(const vd_cnn_model_t *m, uint32_t width, uint32_t height, uint32_t flags,
                                     size_t *bytes)
{
    VD_VERIFY(m != NULL && bytes != NULL && (flags & ~VD_CNN_RUN_FLAGS) == 0u, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(vd__cnn_model_ok(m, &c), VD_ERR_STATE);
    VD_VERIFY(vd__cnn_size_ok(m, width, height), VD_ERR_ARG);
    vd_cnn_plan_t p;
    VD_TRY(vd__cnn_plan_make(m, &c, width, height, flags & ~VD_CNN_RUN_ONLY_FLAGS, &p));
    *bytes = p.total;
    return VD_OK;
}

vd_status_t vd_cnn_workspace_size(const vd_cnn_model_t *m, uint32_t width, uint32_t height, size_t *bytes)
{
    return vd_cnn_workspace_size_ex(m, width, height, 0u, bytes);
}

vd_status_t vd_cnn_macs(const vd_cnn_model_t *m, uint32_t width, uint32_t height, uint64_t *macs)
{
    VD_VERIFY(m != NULL && macs != NULL, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(vd__cnn_model_ok(m, &c), VD_ERR_STATE);
    VD_VERIFY(vd__cnn_size_ok(m, width, height), VD_ERR_ARG);
    uint64_t sum = 0u;
    for (uint32_t l = 0u; l < m->n_layers; l++) {
        const vd_cnn_layer_t *L = &m->layers[l];
        const uint64_t px = (uint64_t)(width / c.f[l + 1u]) * (height / c.f[l + 1u]);
        const uint64_t per = (L->op == VD_CNN_OP_DW3X3) ? 9u * (uint64_t)L->cout : (uint64_t)vd_cnn_k_of(L) * L->cout;
        sum += px * per;
    }
    *macs = sum;
    return VD_OK;
}

vd_status_t vd_cnn_tensor(const vd_cnn_model_t *m, const void *ws, size_t bytes, uint32_t width, uint32_t height,
                          uint32_t index, vd_cnn_output_t *t)
{
    VD_VERIFY(m != NULL && t != NULL, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(vd__cnn_model_ok(m, &c), VD_ERR_STATE);
    VD_VERIFY(vd__cnn_size_ok(m, width, height) && index <= m->n_layers, VD_ERR_ARG);
    VD_VERIFY(ws != NULL && ((uintptr_t)ws % (uintptr_t)VD_WORKSPACE_ALIGN) == 0u, VD_ERR_WORKSPACE);
    VD_VERIFY(bytes >= VD_CNN_REC_BYTES, VD_ERR_WORKSPACE);
    const vd_cnn_plan_t *p = (const vd_cnn_plan_t *)ws;
    VD_VERIFY(p->magic == VD_CNN_REC_MAGIC && p->width == width && p->height == height && p->crc == m->crc32 &&
                  p->size == m->size && (p->flags & ~VD_CNN_RUN_FLAGS) == 0u && p->n_items == 2u + 2u * m->n_layers,
              VD_ERR_STATE);
    VD_VERIFY(bytes >= p->total, VD_ERR_WORKSPACE);
    // The plan is read back from the record the run wrote (no plan on the
    // stack: this call is on the detector's path through the boosted
    // verifier). The record is caller memory, so what is used is checked:
    // the tensor lies inside the workspace, after the record, whole.
    const uint32_t it = vd_cnn_item_of_tensor(index);
    const uint64_t tb = vd_cnn_tensor_bytes(&c, index, width, height / c.f[index]);
    VD_VERIFY(p->rows[index] == height / c.f[index] && p->len[it] >= tb && p->off[it] >= VD_CNN_REC_BYTES &&
                  (uint64_t)p->off[it] + p->len[it] <= p->total,
              VD_ERR_STATE);   // streamed: only whole tensors (the head, or every one with KEEP_TENSORS)
    for (uint32_t j = 0u; j < p->n_items; j++) {
        const bool later = p->first[j] > p->last[it];
        const bool overlap = p->len[j] != 0u && (uint64_t)p->off[j] < (uint64_t)p->off[it] + p->len[it] &&
                             (uint64_t)p->off[it] < (uint64_t)p->off[j] + p->len[j];
        VD_VERIFY(!(later && overlap), VD_ERR_STATE);
    }
    t->data = (const int8_t *)((const uint8_t *)ws + p->off[it]);
    t->w = width / c.f[index];
    t->h = height / c.f[index];
    t->c = c.chan[index];
    t->stride = c.f[index];
    t->zp = c.zp[index];
    return VD_OK;
}
