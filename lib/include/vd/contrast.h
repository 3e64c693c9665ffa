// SPDX-License-Identifier: MIT
// Contrast candidates: regions that differ from their surroundings, warmer OR colder (parked cars with cold
// engines), from a local-contrast map |I - box mean| thresholded and labelled with components.h.
#ifndef VD_CONTRAST_H
#define VD_CONTRAST_H

#include <stddef.h>
#include <stdint.h>

#include "vd/config.h"
#include "vd/status.h"
#include "vd/image.h"
#include "vd/components.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VD_CONTRAST_MAX_RADIUS 127u

// Polarity of the contrast map (cfg.polarity).
#define VD_CONTRAST_BOTH 0u   // |I - mean|: warmer or colder than the surroundings
#define VD_CONTRAST_WARM 1u   // max(0, I - mean)
#define VD_CONTRAST_COLD 2u   // max(0, mean - I)

// Threshold modes (cfg.thr_mode).
#define VD_CONTRAST_THR_FIXED 0u       // contrast >= thr_u8
#define VD_CONTRAST_THR_PERCENTILE 1u  // contrast >= max(thr_u8, p-th permille of the contrast map)

// Settings; zero fields take the defaults noted.
typedef struct vd_contrast_cfg {
    uint16_t radius;           // box half-size r: the mean is over (2r+1) x (2r+1), 1..VD_CONTRAST_MAX_RADIUS;
                               //   0 = 16 (a box of 33 px: bigger than the middle-distance cars, so
                               //   their whole body differs from the mean, not only their outline)
    uint8_t polarity;          // VD_CONTRAST_BOTH (0) / _WARM / _COLD
    uint8_t thr_mode;          // VD_CONTRAST_THR_FIXED (0) or VD_CONTRAST_THR_PERCENTILE
    uint8_t thr_u8;            // fixed threshold, or the floor in percentile mode, 1..255; 0 = 24
    uint8_t reserved;
    uint16_t permille;         // percentile mode: p in 1/1000, 1..1000; 0 = 950
    vd_components_rules_t rules;       // all four fields 0 = paper (aspect h/w 0.3..1.5, area >= 120)
} vd_contrast_cfg_t;

// Resolves cfg in place: zero fields take the defaults above (rules through
// vd_components_rules_resolve), then every range is checked, so a bad setting fails
// where a configuration is accepted (the detector's init), not per frame.
// Returns VD_OK; VD_ERR_ARG for NULL cfg, radius > VD_CONTRAST_MAX_RADIUS,
// polarity or thr_mode unknown, permille > 1000, or rules rejected.
VD_API vd_status_t vd_contrast_cfg_resolve(vd_contrast_cfg_t *cfg);

// Workspace of vd_contrast_map_u8 for frames up to max_width wide: column sums,
// 4 * max_width bytes. Returns VD_OK; VD_ERR_ARG for NULL bytes or a width of 0
// or above VD_MAX_DIM.
VD_API vd_status_t vd_contrast_map_workspace_size(uint32_t max_width, size_t *bytes);

// Local-contrast map of the whole frame:
//   mean(x, y) = round-half-up(sum / n) over the (2r+1)^2 box around (x, y)
//   clipped to the frame (n = pixels of the clipped box), and
//   dst(x, y) = |src - mean| (BOTH), max(0, src - mean) (WARM) or
//   max(0, mean - src) (COLD), 0..255.
//   src       8-bit frame view (any stride).
//   radius    1..VD_CONTRAST_MAX_RADIUS.
//   polarity  VD_CONTRAST_BOTH / _WARM / _COLD.
//   ws, bytes VD_WORKSPACE_ALIGN-aligned, >= vd_contrast_map_workspace_size(src->width).
//   dst       writable image of the same size as src, must not alias it.
// Returns VD_OK; VD_ERR_ARG for NULL or invalid views, size mismatch, radius or
// polarity out of range; VD_ERR_WORKSPACE for a NULL, misaligned or short workspace.
// Time O(W*H) independent of r (running column and row sums); stack O(1).
VD_API vd_status_t vd_contrast_map_u8(const vd_view_u8_t *src, uint32_t radius, uint8_t polarity, void *ws, size_t bytes,
                               vd_image_u8_t *dst);

// Workspace of vd_contrast_candidates for frames up to max_width x max_height.
// The frame is processed in strips of one row pair, so only the width counts
// (the height is range-checked): column sums (2W), the strip's two map rows
// (2W), three rows of runs (3 x 8 x ceil(W/2)), labelling nodes (40 x 3 x
// ceil(W/2)) and a histogram (1 KiB), each slice aligned: about 78 bytes per
// column. 640 wide: 49 664 bytes (the whole-frame map and labelling it
// replaced took 1 650 696 at 640 x 512).
// Returns VD_OK; VD_ERR_ARG for NULL bytes or a dimension 0 or above VD_MAX_DIM.
VD_API vd_status_t vd_contrast_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes);

// Contrast candidates of one 8-bit frame: contrast map -> threshold (fixed or
// percentile, pixel kept when contrast >= thr) -> 8-connected components
// (vd_components_label, its order) -> vd_components_filter with cfg->rules.
// Computed in strips of two map rows, labelled as they come (a component is
// written once no run of the strip's second row reaches it), with exactly
// the result of the whole-frame map labelled by vd_components_label: the
// same components, order and capacity behaviour. Percentile mode labels at
// thr_u8 while it builds the map's histogram, and makes the map again only
// when the percentile is above thr_u8. Time O(W*H); stack O(1).
//   src     8-bit frame view.
//   cfg     settings (NULL = defaults); not modified.
//   ws, bytes  >= vd_contrast_workspace_size(src->width, src->height), aligned.
//   out, cap   component array (boxes in image coordinates); cap also bounds
//           the labelling: when more than cap components exist before the
//           rules, the first cap are filtered and VD_ERR_CAPACITY is returned.
//   count   out: candidates written (after the rules).
//   thr_used  out (may be NULL): the contrast threshold applied.
// Returns VD_OK; VD_ERR_CAPACITY as above (outputs valid); VD_ERR_ARG for NULL
// src/count, out NULL with cap > 0, an invalid view or cfg value out of range;
// VD_ERR_WORKSPACE for a NULL, misaligned or short workspace (then *count = 0).
VD_API vd_status_t vd_contrast_candidates(const vd_view_u8_t *src, const vd_contrast_cfg_t *cfg, void *ws, size_t bytes,
                                   vd_component_t *out, size_t cap, size_t *count, uint8_t *thr_used);

#ifdef __cplusplus
}
#endif
#endif
