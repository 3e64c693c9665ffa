// SPDX-License-Identifier: MIT
// Fuzz harness: connected components (label, filter, expand) on arbitrary masks, ROIs, capacities and rules.
//
// Input layout: w, h (1..64), row padding, capacity, flags (bit-packed pixels,
// ROI given, short workspace), ROI bytes, rules, scales, then pixels. Checks the
// documented status for each case and, on success, the output invariants:
// boxes inside the ROI, areas that sum to the foreground count, centroids
// inside their boxes, filter results that pass the rules, expanded boxes inside
// the frame.
#include "fuzz_common.h"
#include "vd/components.h"

static int roi_valid(const vd_rect_t *r, uint32_t w, uint32_t h)
{
    return r->w > 0 && r->h > 0 && r->x >= 0 && r->y >= 0 && (int64_t)r->x + r->w <= (int64_t)w &&
           (int64_t)r->y + r->h <= (int64_t)h;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader_t r;
    fz_init(&r, data, size);
    const uint32_t w = 1u + fz_u8(&r) % 64u;
    const uint32_t h = 1u + fz_u8(&r) % 64u;
    const size_t stride = w + fz_u8(&r) % 8u;
    const size_t cap = fz_u8(&r) % 80u;
    const uint8_t flags = fz_u8(&r);
    vd_rect_t roi = {0, 0, (int32_t)w, (int32_t)h};
    if (flags & 2u) {
        roi.x = (int8_t)fz_u8(&r);
        roi.y = (int8_t)fz_u8(&r);
        roi.w = (int8_t)fz_u8(&r);
        roi.h = (int8_t)fz_u8(&r);
    }
    vd_cc_rules_t rules;
    rules.aspect_min_q8 = fz_u16(&r);
    rules.aspect_max_q8 = fz_u16(&r);
    rules.min_area = fz_u16(&r);
    rules.max_area = fz_u16(&r);
    const uint16_t ws_q8 = fz_u16(&r);
    const uint16_t hs_q8 = fz_u16(&r);

    const size_t mbytes = fz_plane_bytes(stride, h, w);
    uint8_t *mask = fz_alloc(mbytes);
    fz_fill_plane(&r, mask, w, h, stride, (flags & 1u) != 0u, (uint8_t)(1u + (flags >> 4)));
    vd_view_u8_t v = {mask, w, h, stride};

    const int valid = roi_valid(&roi, w, h);
    const vd_rect_t whole = {0, 0, (int32_t)w, (int32_t)h};
    const vd_rect_t *pr = (flags & 2u) ? &roi : NULL;
    const vd_rect_t eff = (flags & 2u) ? roi : whole;

    size_t wsb = 0u;
    FZ_CHECK(vd_components_workspace_size(w, h, &wsb) == VD_OK);
    if (valid) {
        FZ_CHECK(vd_components_workspace_size((uint32_t)eff.w, (uint32_t)eff.h, &wsb) == VD_OK);
    }
    const int short_ws = (flags & 4u) != 0u;
    const size_t give = short_ws ? wsb - 1u : wsb;
    void *ws = fz_alloc(give);
    vd_component_t *out = cap ? fz_alloc(cap * sizeof(vd_component_t)) : NULL;
    size_t count = 12345u;
    vd_status_t st = vd_components_label(&v, pr, ws, give, out, cap, &count);

    if (!valid) {
        FZ_CHECK(st == VD_ERR_ARG && count == 0u);
    } else if (short_ws) {
        FZ_CHECK(st == VD_ERR_WORKSPACE && count == 0u);
    } else {
        FZ_CHECK(st == VD_OK || st == VD_ERR_CAPACITY);
        FZ_CHECK(count <= cap);
        if (st == VD_ERR_CAPACITY) {
            FZ_CHECK(count == cap);
        }
        uint64_t fg = 0u;
        for (int32_t y = eff.y; y < eff.y + eff.h; y++) {
            for (int32_t x = eff.x; x < eff.x + eff.w; x++) {
                fg += mask[(size_t)y * stride + (size_t)x] != 0u;
            }
        }
        uint64_t sum = 0u;
        for (size_t i = 0u; i < count; i++) {
            const vd_component_t *c = &out[i];
            FZ_CHECK(c->box.w >= 1 && c->box.h >= 1);
            FZ_CHECK(c->box.x >= eff.x && c->box.y >= eff.y);
            FZ_CHECK(c->box.x + c->box.w <= eff.x + eff.w && c->box.y + c->box.h <= eff.y + eff.h);
            FZ_CHECK(c->area >= 1u && (uint64_t)c->area <= (uint64_t)c->box.w * (uint64_t)c->box.h);
            FZ_CHECK(c->cx_q8 >= (uint32_t)c->box.x * 256u && c->cx_q8 <= (uint32_t)(c->box.x + c->box.w - 1) * 256u);
            FZ_CHECK(c->cy_q8 >= (uint32_t)c->box.y * 256u && c->cy_q8 <= (uint32_t)(c->box.y + c->box.h - 1) * 256u);
            sum += c->area;
        }
        FZ_CHECK(sum <= fg);
        if (st == VD_OK) {
            FZ_CHECK(sum == fg);
        }

        // Filter with fuzzed rules: inconsistent rules -> VD_ERR_ARG, else every kept one passes.
        size_t kept = 999u;
        const int rules_ok = rules.aspect_min_q8 <= rules.aspect_max_q8 &&
                             (rules.max_area == 0u || rules.min_area <= rules.max_area);
        vd_status_t fs = vd_components_filter(out, count, &rules, &kept);
        if (!rules_ok) {
            FZ_CHECK(fs == VD_ERR_ARG);
        } else {
            FZ_CHECK(fs == VD_OK && kept <= count);
            for (size_t i = 0u; i < kept; i++) {
                const vd_component_t *c = &out[i];
                const uint32_t asp = (uint32_t)((256u * (uint32_t)c->box.h * 2u + (uint32_t)c->box.w) /
                                                (2u * (uint32_t)c->box.w));
                FZ_CHECK(asp >= rules.aspect_min_q8 && asp <= rules.aspect_max_q8);
                FZ_CHECK(c->area >= rules.min_area && (rules.max_area == 0u || c->area <= rules.max_area));
            }
            // Expansion about the centre, clipped to the frame.
            for (size_t i = 0u; i < kept; i++) {
                vd_rect_t e;
                vd_status_t es = vd_rect_expand(&out[i].box, ws_q8, hs_q8, w, h, &e);
                if (ws_q8 == 0u || hs_q8 == 0u) {
                    FZ_CHECK(es == VD_ERR_ARG);
                    continue;
                }
                FZ_CHECK(es == VD_OK || es == VD_ERR_ARG);
                if (es == VD_OK) {
                    FZ_CHECK(e.w >= 1 && e.h >= 1 && e.x >= 0 && e.y >= 0);
                    FZ_CHECK((uint32_t)(e.x + e.w) <= w && (uint32_t)(e.y + e.h) <= h);
                }
            }
        }
    }
    // Expansion of an arbitrary (possibly off-frame or huge) box never misbehaves.
    {
        vd_rect_t e;
        vd_status_t es = vd_rect_expand(&roi, ws_q8, hs_q8, w, h, &e);
        FZ_CHECK(es == VD_OK || es == VD_ERR_ARG);
        if (es == VD_OK) {
            FZ_CHECK(e.w >= 1 && e.h >= 1 && e.x >= 0 && e.y >= 0);
            FZ_CHECK((uint32_t)(e.x + e.w) <= w && (uint32_t)(e.y + e.h) <= h);
        }
    }
    free(out);
    free(ws);
    free(mask);
    return 0;
}
