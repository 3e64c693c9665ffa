// SPDX-License-Identifier: MIT
// Candidate-region segmentation of paper 001 §3 (steps 2-5): median, global
// Otsu, hole filling, edge image, local max-distance thresholds at edge points.
#ifndef VD_REFINE_H
#define VD_REFINE_H

#include <stddef.h>
#include <stdint.h>

#include "vd/image.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Largest total count vd_refine_maxdist_from_hist accepts: with n <= 255 every
// intermediate of the exact comparison fits in 64 bits (see refine.c).
#define VD_REFINE_MAXDIST_MAX_COUNT 255u
// Largest local window side (15 * 15 = 225 <= VD_REFINE_MAXDIST_MAX_COUNT).
#define VD_REFINE_MAX_WINDOW 15u

// Settings of vd_refine_region. vd_refine_cfg_default() gives the paper's:
// median 3, edge_step 5, window 5.
typedef struct vd_refine_cfg {
    uint8_t median_ksize;  // 0 = no median filter, 3 or 5 (cv2.medianBlur)
    uint8_t edge_step;     // take every edge_step-th edge point (raster order), >= 1
    uint8_t window;        // local window side, odd, 3..VD_REFINE_MAX_WINDOW
} vd_refine_cfg_t;

// Fills *cfg with the paper's settings (3, 5, 5). cfg must not be NULL.
VD_API void vd_refine_cfg_default(vd_refine_cfg_t *cfg);

// What vd_refine_region did (for tests, tuning and logs).
typedef struct vd_refine_stats {
    uint8_t otsu_thr;        // global Otsu threshold t of the filtered region (foreground > t)
    uint32_t edge_points;    // pixels of the edge image E (before selection)
    uint32_t local_windows;  // windows re-binarised (selected points whose window had >= 2 grey levels)
    uint32_t fg_pixels;      // 255 pixels of the final mask
} vd_refine_stats_t;

// Maximum-distance threshold of paper 001 eq. (1) on a histogram: the T that
// maximises R(T) = (sum_{i<=T} i*P_i - mu*P(T))^2 / (P(T) * (1 - P(T))),
// P(T) = sum_{i<=T} P_i, mu the mean level (Otsu's between-class criterion).
// Exact integer arithmetic; the smallest maximising T is returned and pixels
// > T are foreground.
//   hist  256 counts, total n with 1 <= n <= VD_REFINE_MAXDIST_MAX_COUNT.
//   thr   receives T (unchanged on error).
// Returns VD_OK; VD_ERR_ARG for NULL pointers; VD_ERR_RANGE if n is 0 or
// above VD_REFINE_MAXDIST_MAX_COUNT, or fewer than two grey levels occur (no split
// exists; vd_refine_region then keeps its previous decision).
VD_API vd_status_t vd_refine_maxdist_from_hist(const uint32_t hist[256], uint8_t *thr);

// Workspace of vd_refine_fill_holes_u8 for masks up to max_width x max_height:
// 4 * max_width * max_height bytes (a stack of pixel indices; each pixel is pushed at
// most once). Returns VD_OK; VD_ERR_ARG for a NULL pointer or a dimension 0
// or above VD_MAX_DIM.
VD_API vd_status_t vd_refine_fill_holes_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes);

// Fills the holes of a mask in place: background pixels not 4-connected to
// the mask's outer border become foreground (so foreground is 8-connected,
// background 4-connected, as scipy.ndimage.binary_fill_holes does).
//   mask   writable, nonzero = foreground on input; 0/255 on output.
//   ws     workspace of vd_refine_fill_holes_workspace_size(mask->width, mask->height) bytes.
// Returns VD_OK; VD_ERR_ARG for a bad image; VD_ERR_WORKSPACE for a NULL,
// misaligned or short workspace (mask untouched then).
VD_API vd_status_t vd_refine_fill_holes_u8(vd_image_u8_t *mask, void *ws, size_t bytes);

// Edge image: dst = 255 where the mask pixel is foreground (nonzero) and at
// least one of its 4 neighbours is background, else 0. The ROI is treated as
// an image of its own surrounded by background, so foreground on the ROI
// border is edge (the same closure cv2.findContours applies).
//   mask  read-only; roi NULL = whole mask, else inside it.
//   dst   roi-sized (width == roi.w, height == roi.h); must not alias mask.
// Returns VD_OK; VD_ERR_ARG for bad views, a bad ROI or a wrong dst size.
VD_API vd_status_t vd_refine_edges_u8(const vd_view_u8_t *mask, const vd_rect_t *roi, vd_image_u8_t *dst);

// Workspace of vd_refine_region for ROIs up to max_width x max_height: the filtered
// region (w*h bytes, rounded up to the alignment: P) and a region of
// max(4*w*h, P + 1024) bytes: the hole-filling stack, later the edge image
// (w*h) with the 256-bin uint32 histogram at offset P. 5*w*h bytes plus
// alignment from w*h >= 342 on; smaller ROIs need up to 1 KiB more.
// Returns VD_OK; VD_ERR_ARG for a NULL pointer or a dimension 0 or above
// VD_MAX_DIM; VD_ERR_OVERFLOW if the size does not fit size_t.
VD_API vd_status_t vd_refine_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes);

// Segments one candidate area (paper 001 §3, steps 2-5; step 1, the expansion,
// is vd_rect_expand in rect.h):
//   F = median(src)[roi]  (cfg->median_ksize; cv2.medianBlur on the full
//       image, so pixels just outside the ROI take part),
//   t = Otsu(F); M = F > t; fill the holes of M; E = edges of M;
//   for every cfg->edge_step-th pixel of E in raster order (the 1st, the
//   (1+step)-th, ...), in the window x window neighbourhood clipped to the ROI:
//   T = vd_refine_maxdist_from_hist(histogram of F there); mask = F > T there
//   (later windows overwrite earlier ones where they overlap; windows with one
//   grey level leave the mask as it is).
//   src    read-only 8-bit image; roi NULL = whole image, else inside it.
//   cfg    settings (NULL = vd_refine_cfg_default()).
//   ws     workspace of vd_refine_workspace_size(roi.w, roi.h) bytes.
//   mask   roi-sized output, 0/255; must not alias src.
//   stats  may be NULL.
// Returns VD_OK; VD_ERR_ARG for bad views, ROI, cfg or mask size;
// VD_ERR_WORKSPACE for a NULL, misaligned or short workspace.
VD_API vd_status_t vd_refine_region(const vd_view_u8_t *src, const vd_rect_t *roi, const vd_refine_cfg_t *cfg,
                             void *ws, size_t bytes, vd_image_u8_t *mask, vd_refine_stats_t *stats);

#ifdef __cplusplus
}
#endif
#endif
