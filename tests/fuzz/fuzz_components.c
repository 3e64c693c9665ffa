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

static void same_components(const vd_component_t *a, const vd_component_t *b, size_t n)
{
    for (size_t i = 0u; i < n; i++) {
        FZ_CHECK(a[i].box.x == b[i].box.x && a[i].box.y == b[i].box.y && a[i].box.w == b[i].box.w &&
                 a[i].box.h == b[i].box.h && a[i].area == b[i].area && a[i].cx_q8 == b[i].cx_q8 &&
                 a[i].cy_q8 == b[i].cy_q8);
    }
}

// The thresholding labellers with a run budget (vd_components_label_thr_u8/u16) against
// vd_components_label on the thresholded mask: the same components on VD_OK; on a run-budget
// overflow exactly those of the ROI cut after stats.rows rows; u16 (value * 257) equal to u8.
static void check_thr_labellers(const uint8_t *pix, uint32_t w, uint32_t h, size_t stride, const vd_rect_t *pr,
                                int valid, size_t cap, uint8_t thr, uint16_t budget)
{
    uint8_t *mask = fz_alloc((size_t)w * h);
    uint16_t *p16 = fz_alloc((size_t)w * h * 2u);
    for (uint32_t y = 0u; y < h; y++) {
        for (uint32_t x = 0u; x < w; x++) {
            const uint8_t v = pix[(size_t)y * stride + x];
            mask[(size_t)y * w + x] = v >= thr ? 255u : 0u;
            p16[(size_t)y * w + x] = (uint16_t)(v * 257u);
        }
    }
    const vd_rect_t eff = pr ? *pr : (vd_rect_t){0, 0, (int32_t)w, (int32_t)h};
    const uint32_t rw = valid ? (uint32_t)eff.w : w, rh = valid ? (uint32_t)eff.h : h;
    size_t tb = 0u, full = 0u;
    FZ_CHECK(vd_components_workspace_size(rw, rh, &full) == VD_OK);
    if (budget) {
        FZ_CHECK(vd_components_workspace_size_runs(rw, rh, budget, &tb) == VD_OK && tb <= full);
    } else {
        tb = full;
    }
    void *ws = fz_alloc(tb);
    void *ws_full = fz_alloc(full);
    vd_component_t *a = fz_alloc((cap + 1u) * sizeof(vd_component_t));
    vd_component_t *b = fz_alloc((cap + 1u) * sizeof(vd_component_t));
    vd_component_t *c = fz_alloc((cap + 1u) * sizeof(vd_component_t));
    size_t na = 9u, nb = 9u, nc = 9u;
    vd_components_stats_t sa, sb;
    const vd_view_u8_t v8 = {pix, w, h, stride};
    const vd_view_u16_t v16 = {p16, w, h, (size_t)w * 2u};
    const vd_view_u8_t vm = {mask, w, h, w};
    vd_status_t s8 = vd_components_label_thr_u8(&v8, pr, thr, ws, tb, a, cap, &na, &sa);
    vd_status_t s16 = vd_components_label_thr_u16(&v16, pr, (uint16_t)(thr * 257u), ws, tb, b, cap, &nb, &sb);
    FZ_CHECK(s8 == s16 && na == nb);
    if (!valid) {
        FZ_CHECK(s8 == VD_ERR_ARG && na == 0u);
    } else {
        FZ_CHECK(s8 == VD_OK || s8 == VD_ERR_CAPACITY);
        FZ_CHECK(na <= cap);
        same_components(a, b, na);
        FZ_CHECK(sa.rows == sb.rows && sa.runs == sb.runs && sa.labels == sb.labels && sa.pixels == sb.pixels);
        FZ_CHECK(sa.rows <= rh);
        if (budget == 0u) {
            FZ_CHECK(sa.rows == rh);  // a full-size workspace never runs out
        }
        if (sa.rows == rh) {
            vd_status_t sm = vd_components_label(&vm, pr, ws_full, full, c, cap, &nc);
            FZ_CHECK(sm == s8 && nc == na);
            same_components(a, c, na);
        } else {
            FZ_CHECK(s8 == VD_ERR_CAPACITY && (sa.rows % 2u) == 0u && sa.runs <= tb / 8u);
            if (sa.rows > 0u) {
                const vd_rect_t cut = {eff.x, eff.y, eff.w, (int32_t)sa.rows};
                vd_status_t sm = vd_components_label(&vm, &cut, ws_full, full, c, cap, &nc);
                FZ_CHECK(nc == na && (sm == VD_OK || sm == VD_ERR_CAPACITY));
                same_components(a, c, na);
            } else {
                FZ_CHECK(na == 0u);
            }
        }
    }
    free(c);
    free(b);
    free(a);
    free(ws_full);
    free(ws);
    free(p16);
    free(mask);
}

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
    vd_components_rules_t rules;
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
    // Trailing bytes (after the pixels): threshold and run budget of the thresholding labellers.
    {
        const uint8_t thr = (uint8_t)(fz_u8(&r) + 1u);
        const uint16_t budget = fz_u16(&r);
        check_thr_labellers(mask, w, h, stride, pr, valid, cap, thr, budget);
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
