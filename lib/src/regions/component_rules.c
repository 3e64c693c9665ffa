// SPDX-License-Identifier: MIT
// Shape rules of connected components (components.h): aspect ratio and area
// limits, and the filter that keeps the components within them.
//
// Algorithm: aspect h/w in Q8 rounded half up, compared with inclusive
// limits; area in [min_area, max_area] (max_area 0: no upper limit).
// Bounds: time O(n), stack O(1), no workspace.
#include "vd/components.h"

#include "internal/vd_internal.h"

void vd_components_rules_default(vd_components_rules_t *rules)
{
    if (rules == NULL) {
        return;
    }
    rules->aspect_min_q8 = 77u;  // 0.3 * 256 = 76.8
    rules->aspect_max_q8 = 384u; // 1.5 * 256
    rules->min_area = 120u;
    rules->max_area = 0u;
}

// The consistency that vd_components_rules_resolve and vd_components_filter demand.
static vd_status_t rules_check(const vd_components_rules_t *rules)
{
    VD_VERIFY(rules->aspect_min_q8 <= rules->aspect_max_q8, VD_ERR_ARG);
    VD_VERIFY(rules->max_area == 0u || rules->min_area <= rules->max_area, VD_ERR_ARG);
    return VD_OK;
}

vd_status_t vd_components_rules_resolve(vd_components_rules_t *rules)
{
    VD_VERIFY(rules != NULL, VD_ERR_ARG);
    if (rules->aspect_min_q8 == 0u && rules->aspect_max_q8 == 0u && rules->min_area == 0u && rules->max_area == 0u) {
        vd_components_rules_default(rules);
    }
    return rules_check(rules);
}

// round-half-up(256 * h / w) for w, h >= 1; 512 * h < 2^41 in uint64.
static uint64_t cc_aspect_q8(const vd_rect_t *b)
{
    const uint64_t w = (uint64_t)b->w;
    return (512u * (uint64_t)b->h + w) / (2u * w);
}

vd_status_t vd_components_filter(vd_component_t *comps, size_t n, const vd_components_rules_t *rules, size_t *kept)
{
    VD_VERIFY(kept != NULL, VD_ERR_ARG);
    *kept = 0u;
    VD_VERIFY(rules != NULL && (comps != NULL || n == 0u), VD_ERR_ARG);
    VD_TRY(rules_check(rules));
    for (size_t i = 0u; i < n; i++) { // validate all before touching any
        VD_VERIFY(comps[i].box.w > 0 && comps[i].box.h > 0, VD_ERR_ARG);
    }
    size_t k = 0u;
    for (size_t i = 0u; i < n; i++) {
        const uint64_t asp = cc_aspect_q8(&comps[i].box);
        const uint32_t area = comps[i].area;
        bool ok = asp >= rules->aspect_min_q8 && asp <= rules->aspect_max_q8 && area >= rules->min_area &&
                  (rules->max_area == 0u || area <= rules->max_area);
        if (ok) {
            if (k != i) {
                comps[k] = comps[i];
            }
            k++;
        }
    }
    *kept = k;
    return VD_OK;
}
