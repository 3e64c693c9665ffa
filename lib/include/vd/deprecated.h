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
#include "vd/detection.h"
#include "vd/detector.h"

// cnn.h: `_qN` names only Q formats; the header's heatmap threshold is an int8 code of the head.
#define score_threshold_q score_threshold_i8

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

// detection.h: its constants carry its prefix (issue 37).
#define VD_SOURCE_HOTSPOT VD_DETECTION_SOURCE_HOTSPOT
#define VD_SOURCE_WINDOW VD_DETECTION_SOURCE_WINDOW
#define VD_SOURCE_CONTRAST VD_DETECTION_SOURCE_CONTRAST
#define VD_SOURCE_CNN VD_DETECTION_SOURCE_CNN
#define VD_DET_FLAG_UNVERIFIED VD_DETECTION_FLAG_UNVERIFIED
#define VD_DET_FLAG_DECIMATED VD_DETECTION_FLAG_DECIMATED
#define VD_DET_FLAG_CONTOUR_TRUNC VD_DETECTION_FLAG_CONTOUR_TRUNC
#define VD_DET_FLAG_RECOVERED VD_DETECTION_FLAG_RECOVERED

// detector.h: the stage indices and the fusion IoU carry its prefix (issue 37).
#define VD_DET_STAGE_THRESHOLD VD_DETECTOR_STAGE_THRESHOLD
#define VD_DET_STAGE_COMPONENTS VD_DETECTOR_STAGE_COMPONENTS
#define VD_DET_STAGE_REFINE VD_DETECTOR_STAGE_REFINE
#define VD_DET_STAGE_CONTOUR VD_DETECTOR_STAGE_CONTOUR
#define VD_DET_STAGE_SAMPLE VD_DETECTOR_STAGE_SAMPLE
#define VD_DET_STAGE_DBN VD_DETECTOR_STAGE_DBN
#define VD_DET_STAGE_NMS VD_DETECTOR_STAGE_NMS
#define VD_DET_STAGE_TEMPORAL VD_DETECTOR_STAGE_TEMPORAL
#define VD_DET_STAGE_CONTRAST VD_DETECTOR_STAGE_CONTRAST
#define VD_DET_STAGE_WINDOWS VD_DETECTOR_STAGE_WINDOWS
#define VD_DET_STAGE_CNN VD_DETECTOR_STAGE_CNN
#define VD_DET_STAGE_TOTAL VD_DETECTOR_STAGE_TOTAL
#define VD_DET_STAGE_COUNT VD_DETECTOR_STAGE_COUNT
#define VD_CNN_FLIP_IOU_Q15 VD_DETECTOR_CNN_FLIP_IOU_Q15

#endif
#endif
