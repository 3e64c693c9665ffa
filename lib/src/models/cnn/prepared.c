// SPDX-License-Identifier: MIT
// CNN prepared weights: vd_cnn_prepared_size and vd_cnn_prepare, an optional host speed-up.
//
// Why: a streamed run calls each layer once per band of rows, and the x86 kernels pack the layer's weights
// and make its requantisation constants on every call (the scratch is shared by all layers, so nothing
// survives a call). The deep layers have the most weights and the fewest pixels per row, so on x86 that
// per-call work was about a tenth of a frame (perf, docs/performance.md). A caller with memory to spare (a
// host, never the 256 KiB ECU budget) gives one buffer per model; vd_cnn_prepare fills it once with every
// CONV / PW / DW layer's set-up as the kernels would make it, and runs read it back.
// Layout: a header (vd_cnn_prep_hdr_t: the kernel set, the model's blob address and CRC, each layer's
// offset), then per CONV / PW / DW layer its area (kernels/x86.c vd__cnn_x86_prep_layer), at multiples of 64
// bytes from the buffer's start.
// Only the x86 back end has such areas: elsewhere the size is 0 and runs never look.
// Bounds: O(n_layers) for the size, O(weights) for the fill; no allocation, no state outside the buffer.
#include "vd/cnn.h"

#include "models/cnn/cnn_internal.h"
#include "internal/vd_internal.h"

#include <string.h>

// The total bytes for kernel set `level` (0 without one), and the header's offsets when hdr is not NULL.
static size_t prep_total(const vd_cnn_model_t *m, const chain_t *c, uint32_t level, vd_cnn_prep_hdr_t *hdr)
{
#if defined(VD_CNN_X86)
    if (level == VD_CNN_X86_NONE) {
        return 0u;
    }
    size_t at = VD_CNN_PREP_HDR;
    for (uint32_t l = 0u; l < m->n_layers; l++) {
        const vd_cnn_layer_t *L = &m->layers[l];
        const bool x86_op = L->op == VD_CNN_OP_CONV3X3 || L->op == VD_CNN_OP_CONV5X5 || L->op == VD_CNN_OP_PW1X1 ||
                            L->op == VD_CNN_OP_DW3X3;   // the layers with an x86 kernel
        if (hdr != NULL) {
            hdr->off[l] = x86_op ? (uint32_t)at : 0u;
        }
        at += x86_op ? vd__cnn_x86_prep_layer(L, c->zp[L->in], level, NULL) : 0u;
    }
    return at;
#else
    (void)m;
    (void)c;
    (void)level;
    (void)hdr;
    return 0u;
#endif
}

vd_status_t vd_cnn_prepared_size(const vd_cnn_model_t *m, size_t *bytes)
{
    VD_VERIFY(m != NULL && bytes != NULL, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(vd__cnn_model_ok(m, &c), VD_ERR_STATE);
    *bytes = prep_total(m, &c, vd__cnn_x86_run_level(0u), NULL);
    return VD_OK;
}

vd_status_t vd_cnn_prepare(vd_cnn_model_t *m, void *buf, size_t bytes)
{
    VD_VERIFY(m != NULL, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(vd__cnn_model_ok(m, &c), VD_ERR_STATE);
    const uint32_t level = vd__cnn_x86_run_level(0u);
    vd_cnn_prep_hdr_t hdr;
    memset(&hdr, 0, sizeof hdr);
    const size_t need = prep_total(m, &c, level, &hdr);
    m->prepared = NULL;
    if (need == 0u) {
        return VD_OK;
    }
    VD_VERIFY(buf != NULL && ((uintptr_t)buf % (uintptr_t)VD_WORKSPACE_ALIGN) == 0u && bytes >= need,
              VD_ERR_WORKSPACE);
    VD_VERIFY(need <= UINT32_MAX, VD_ERR_OVERFLOW);
#if defined(VD_CNN_X86)
    uint8_t *b = (uint8_t *)buf;
    for (uint32_t l = 0u; l < m->n_layers; l++) {
        if (hdr.off[l] != 0u) {
            const vd_cnn_layer_t *L = &m->layers[l];
            (void)vd__cnn_x86_prep_layer(L, c.zp[L->in], level, b + hdr.off[l]);
        }
    }
#endif
    hdr.magic = VD_CNN_PREP_MAGIC;
    hdr.level = level;
    hdr.crc32 = m->crc32;
    hdr.bytes = (uint32_t)need;
    hdr.blob = m->blob;
    memcpy(buf, &hdr, sizeof hdr);
    m->prepared = (const uint8_t *)buf;
    return VD_OK;
}

bool vd__cnn_prepared_for(const vd_cnn_model_t *m, const chain_t *c, uint32_t level, const vd_cnn_prep_hdr_t **hdr)
{
    *hdr = NULL;
#if defined(VD_CNN_X86)
    if (m->prepared == NULL) {
        return true;
    }
    const vd_cnn_prep_hdr_t *h = (const vd_cnn_prep_hdr_t *)(const void *)m->prepared;
    if (h->magic != VD_CNN_PREP_MAGIC || h->blob != m->blob || h->crc32 != m->crc32 || h->level == 0u ||
        h->level > VD_CNN_X86_AVX512) {
        return false;
    }
    // The layout made again (O(n_layers)): a damaged header must not send a kernel outside the buffer.
    vd_cnn_prep_hdr_t want;
    memset(&want, 0, sizeof want);
    if (prep_total(m, c, h->level, &want) != h->bytes || memcmp(want.off, h->off, sizeof want.off) != 0) {
        return false;
    }
    *hdr = (h->level == level) ? h : NULL;
    return true;
#else
    (void)c;
    (void)level;
    return m->prepared == NULL;   // vd_cnn_prepare never sets it here
#endif
}
