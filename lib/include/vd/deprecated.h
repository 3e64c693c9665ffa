// SPDX-License-Identifier: MIT
// Names of vd 0.1 that 0.2 renamed (docs/changelog.md): aliases for one release, removed in 0.3.
// Included by vd/vd.h; define VD_NO_DEPRECATED to check that a program uses only the new names.
#ifndef VD_DEPRECATED_H
#define VD_DEPRECATED_H

#ifndef VD_NO_DEPRECATED

#include "vd/components.h"
#include "vd/contour.h"
#include "vd/rect.h"
#include "vd/refine.h"
#include "vd/calib.h"
#include "vd/dbn.h"

// contour.h: the header's prefix is vd_contour_.
#define vd_contours_workspace_size vd_contour_workspace_size
#define vd_contours_find_external vd_contour_find_external
#define VD_CHAIN_NONE VD_CONTOUR_CHAIN_NONE

// components.h: vd_cc_ -> vd_components_.
#define vd_cc_stats vd_components_stats
#define vd_cc_stats_t vd_components_stats_t
#define vd_cc_rules vd_components_rules
#define vd_cc_rules_t vd_components_rules_t
#define vd_cc_rules_default vd_components_rules_default
#define vd_cc_rules_resolve vd_components_rules_resolve

// refine.h: every name starts with vd_refine_ / VD_REFINE_.
#define vd_fill_holes_workspace_size vd_refine_fill_holes_workspace_size
#define vd_fill_holes_u8 vd_refine_fill_holes_u8
#define vd_edges_u8 vd_refine_edges_u8
#define vd_maxdist_from_hist vd_refine_maxdist_from_hist
#define VD_MAXDIST_MAX_COUNT VD_REFINE_MAXDIST_MAX_COUNT

// rect.h: the box helpers left image.h and components.h (vd_rect_expand and
// vd_rect_clip keep their names).
#define vd_roi_resolve vd_rect_roi_resolve
#define VD_EXPAND_W_Q8 VD_RECT_EXPAND_W_Q8
#define VD_EXPAND_H_Q8 VD_RECT_EXPAND_H_Q8

// calib.h: the calibration left threshold.h (its functions keep their names).
#define VD_CK_PER_0C VD_CALIB_CK_PER_0C

// dbn.h: the DBN model type carries its module's prefix, like vd_cnn_model_t.
#define vd_model_t vd_dbn_model_t

#endif
#endif
