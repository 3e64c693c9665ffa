# SPDX-License-Identifier: MIT
# vd 0.1 -> 0.2 names (docs/changelog.md), whole identifiers: sed -i -f tools/api-0.2.sed FILE...
s/\bvd_contours_workspace_size\b/vd_contour_workspace_size/g
s/\bvd_contours_find_external\b/vd_contour_find_external/g
s/\bVD_CHAIN_NONE\b/VD_CONTOUR_CHAIN_NONE/g
s/\bvd_cc_stats_t\b/vd_components_stats_t/g
s/\bvd_cc_stats\b/vd_components_stats/g
s/\bvd_cc_rules_t\b/vd_components_rules_t/g
s/\bvd_cc_rules_default\b/vd_components_rules_default/g
s/\bvd_cc_rules_resolve\b/vd_components_rules_resolve/g
s/\bvd_cc_rules\b/vd_components_rules/g
s/\bvd_fill_holes_workspace_size\b/vd_refine_fill_holes_workspace_size/g
s/\bvd_fill_holes_u8\b/vd_refine_fill_holes_u8/g
s/\bvd_edges_u8\b/vd_refine_edges_u8/g
s/\bvd_maxdist_from_hist\b/vd_refine_maxdist_from_hist/g
s/\bVD_MAXDIST_MAX_COUNT\b/VD_REFINE_MAXDIST_MAX_COUNT/g
s/\bVD_EXPAND_W_Q8\b/VD_RECT_EXPAND_W_Q8/g
s/\bVD_EXPAND_H_Q8\b/VD_RECT_EXPAND_H_Q8/g
s/\bvd_roi_resolve\b/vd_rect_roi_resolve/g
s/\bVD_CK_PER_0C\b/VD_CALIB_CK_PER_0C/g
s/\bvd_model_t\b/vd_dbn_model_t/g
s/\bstruct vd_model\b/struct vd_dbn_model/g
