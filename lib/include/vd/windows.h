// SPDX-License-Identifier: MIT
// Sliding-window candidate boxes (the hypothesis stage of paper 003) restricted by per-distance size bands
// (paper 000 Table 1) and an optional flat-ground model of the camera mounting.
//
// Geometry. A window is a box {x, y, w, h}; its "bottom row" is y + h - 1, the
// row where a vehicle touches the road. The user describes the camera mounting
// with up to VD_WINDOWS_MAX_BANDS distance bands, each a range of bottom rows
// and the window heights allowed there (paper 000, Table 1: near 0-100 m
// 50..200 px, middle 100-150 m 25..70 px, far > 150 m 10..30 px; which rows
// are near/middle/far depends on the mounting, so the rows are the user's).
//
// Ground-plane constraint (optional, road-level cameras). For a pinhole camera
// at height H_c above a flat road, looking parallel to it, a vehicle of real
// height H_v whose bottom is at image row y_b (below the horizon row y_h) is at
// distance Z = f * H_c / (y_b - y_h) and appears h = f * H_v / Z =
// (H_v / H_c) * (y_b - y_h) pixels tall: the expected height grows linearly
// with the distance of the bottom row below the horizon. With k = H_v / H_c
// (e.g. a 1.5 m car seen from 1.0 m: k = 1.5; MSRS fits about k 1.6, y_h 230
// for 640 x 480) and a tolerance factor t for vehicle heights, pitch and road
// slope, a window of height h and bottom y_b is kept when
//     k * (y_b - y_h) / t  <=  h  <=  k * (y_b - y_h) * t.
// Drone views (HIT-UAV) have no horizon: leave the ground model off and give
// one band with the altitude's size range.
//
// Pre-filter and ranking (not in the papers; issue 7). Most windows cover
// flat road or sky. A window's level is the standard deviation of the 4x4-cell
// means (vd_resample_box_*) of the cells inside it, from two integral images
// (sum and sum of squares of the cell means) in O(1) per window. Windows below
// a minimum level are dropped (a minimum of 4 keeps every window that matches
// a car on MSRS/HIT-UAV training frames and drops about half of all windows),
// and vd_windows_rank hands out the most structured ones that fit a budget.
#ifndef VD_WINDOWS_H
#define VD_WINDOWS_H

#include <stddef.h>
#include <stdint.h>

#include "vd/config.h"
#include "vd/status.h"
#include "vd/image.h"
#include "vd/threshold.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VD_WINDOWS_MAX_BANDS 4u     // distance bands per configuration
#define VD_WINDOWS_MAX_ASPECTS 4u   // window shapes per configuration
#define VD_WINDOWS_MAX_SCALES 48u   // heights in the scale ladder (checked by the config)

// One distance band: windows whose bottom row lies in [y_min, y_max]
// (inclusive, image rows; parts outside the frame are ignored) may have a
// height in [min_h, max_h] pixels (1 <= min_h <= max_h <= VD_MAX_DIM).
typedef struct vd_window_band {
    int32_t y_min;
    int32_t y_max;
    uint16_t min_h;
    uint16_t max_h;
} vd_window_band_t;

// Generator settings. A zeroed struct (with frame_w/frame_h set) gives the
// defaults noted per field. Every field is checked by vd_windows_check().
typedef struct vd_windows_cfg {
    uint32_t frame_w;           // frame size the windows are for, 1..VD_MAX_DIM (no default)
    uint32_t frame_h;
    uint8_t n_bands;            // bands used, 0..VD_WINDOWS_MAX_BANDS; 0 = one band covering
                                //   every row with heights 10..200 (Table 1's extremes)
    uint8_t n_aspects;          // aspects used, 0..VD_WINDOWS_MAX_ASPECTS; 0 = one aspect, 256
    uint16_t scale_step_q8;     // ratio between successive heights, Q8, 288..1024 (1.125..4);
                                //   0 = 320 (1.25). Heights: h_0 = smallest band min_h, h_{i+1} =
                                //   max(h_i + 1, (h_i * step + 128) >> 8), up to the largest max_h;
                                //   more than VD_WINDOWS_MAX_SCALES heights -> VD_ERR_ARG.
    uint16_t stride_q8;         // step between windows as a fraction of the window's own width
                                //   (x) and height (y), Q8, 16..512; 0 = 64 (a quarter window);
                                //   the step is at least 1 px
    uint16_t aspect_q8[VD_WINDOWS_MAX_ASPECTS];  // window height / width, Q8, 64..1024
                                //   (as vd_components_rules_t); width = max(1, round(h * 256 / aspect))
    vd_window_band_t bands[VD_WINDOWS_MAX_BANDS];
    int32_t horizon_y;          // ground model: horizon row y_h (may lie outside the frame,
                                //   |y_h| <= VD_MAX_DIM); used only when ground_k_q8 > 0
    uint16_t ground_k_q8;       // ground model slope k in Q8 (h per row below the horizon);
                                //   0 = no ground model
    uint16_t ground_tol_q8;     // tolerance factor t in Q8, 256..4096; 0 = 512 (a factor of 2)
    uint32_t max_windows;       // per-frame budget, 1..1048576; 0 = 2048
} vd_windows_cfg_t;

// Checks `cfg` and fills its zero fields with the defaults above (in place).
// Returns VD_OK; VD_ERR_ARG for NULL cfg or any value out of range (frame size,
// band with min_h > max_h or y_min > y_max, too many scales, aspect, stride,
// tolerance, horizon, budget).
VD_API vd_status_t vd_windows_resolve(vd_windows_cfg_t *cfg);

// Writes the windows of one frame in a fixed order: by height (smallest
// first), then aspect (cfg order), then row y, then column x (raster). For a
// height h and width w the grid is y = oy + j*sy, x = ox + i*sx with
// sx = max(1, (w * stride_q8) >> 8), sy = max(1, (h * stride_q8) >> 8) and the
// leftover margin split evenly: ox = ((frame_w - w) % sx) / 2, same for oy.
// A grid box is written when it lies inside the frame, some band holds its
// bottom row with min_h <= h <= max_h, and the ground model (if any) accepts
// it. Boxes are never written twice.
//   cfg    settings (zero fields = defaults; resolved internally, not modified).
//   out    array of `cap` boxes (NULL allowed when cap is 0).
//   cap    capacity of out; the effective cap is min(cap, cfg->max_windows).
//   count  out: windows written.
// Returns VD_OK; VD_ERR_CAPACITY when more windows exist than the effective
// cap (the first ones in the order above are written, *count = that cap);
// VD_ERR_ARG for NULL count, out NULL with cap > 0, or a cfg rejected by
// vd_windows_resolve (then *count = 0).
// Time O(windows + heights * aspects * (rows + columns)); stack < 256 bytes;
// no workspace.
VD_API vd_status_t vd_windows_generate(const vd_windows_cfg_t *cfg, vd_rect_t *out, size_t cap, size_t *count);

// Number of windows vd_windows_generate would produce without any cap (so a
// caller can size its buffer or choose a stride). Same errors as
// vd_windows_resolve (VD_ERR_ARG also for NULL total).
VD_API vd_status_t vd_windows_count(const vd_windows_cfg_t *cfg, uint32_t *total);

// Called once per window, in vd_windows_generate's order; must not keep `win`.
typedef void (*vd_windows_visit_fn)(void *ctx, const vd_rect_t *win);

#define VD_WINDOWS_CELL 4u   // side of a pre-filter cell in pixels
// Largest cell grid (cells per frame) whose sums of squared cell means fit
// uint32 for any window: cells * 255^2 < 2^32. (The integrals themselves wrap
// modulo 2^32; a difference of four corners is exact when the true window
// sum fits.) 66 051 cells: e.g. 1024 x 1024 frames.
#define VD_WINDOWS_MAX_CELLS 66051u

// Integral images of one frame's cell means (vd_windows_prefilter_init).
// Fields are private; valid while the workspace it was built in is.
typedef struct vd_windows_prefilter {
    const uint32_t *sum;   // (gw+1) x (gh+1) integral of the means, then the one of their squares
    uint16_t gw;           // cell grid: frame width / 4 (<= 2048; the last width % 4 columns are not covered)
    uint16_t gh;           // frame height / 4 (likewise the last rows)
} vd_windows_prefilter_t;

// Workspace of vd_windows_prefilter_init for frames up to max_width x
// max_height: two (max_width/4 + 1) x (max_height/4 + 1) uint32 integrals
// (166 152 bytes at 640 x 512).
// Returns VD_OK; VD_ERR_ARG for NULL bytes, a dimension 0 or above
// VD_MAX_DIM, or a cell grid above VD_WINDOWS_MAX_CELLS.
VD_API vd_status_t vd_windows_prefilter_workspace_size(uint32_t max_width, uint32_t max_height, size_t *bytes);

// Builds the pre-filter of one frame in `ws`: the cell means g (rounded, as
// vd_resample_box_u8 with k = 4; a 16-bit frame's means mapped to grey by
// `grey`, as vd_resample_box_u16) and the integrals of g and g^2.
//   pf     out; refers to ws, which must outlive its use.
//   frame  8- or 16-bit frame (vd_frame_check).
//   grey   16-bit frames: an initialised map (vd_calib_grey_init); ignored
//          (may be NULL) for 8-bit frames.
//   ws, bytes  VD_WORKSPACE_ALIGN-aligned, >= vd_windows_prefilter_workspace_size(frame size).
// Returns VD_OK; VD_ERR_ARG for NULL pf/frame, a NULL grey with a 16-bit
// frame, or a cell grid above VD_WINDOWS_MAX_CELLS; VD_ERR_FORMAT or VD_ERR_ARG
// for a frame failing vd_frame_check; VD_ERR_WORKSPACE for a NULL, misaligned
// or short workspace. Time O(W*H); stack < 200 bytes.
VD_API vd_status_t vd_windows_prefilter_init(vd_windows_prefilter_t *pf, const vd_frame_t *frame,
                                      const vd_calib_grey_t *grey, void *ws, size_t bytes);

// Pre-filter level of a window: floor(standard deviation) of the cell means
// g over the cells [cx0, cx1) x [cy0, cy1), clamped to 255 (the population
// variance (n * sum g^2 - (sum g)^2) / n^2, floored, then an integer square
// root). Per axis the cells are those lying entirely inside the window,
// cx0 = ceil(x / 4), cx1 = min(floor((x + w) / 4), gw); when none does, the
// one cell cx1 - 1 (cell 0 if cx1 is 0). 0 when the frame is narrower or
// lower than one cell. O(1): `win` is not checked (a box of the frame the
// pre-filter was built from; a box outside it gives some level, safely).
VD_API uint32_t vd_windows_prefilter_level(const vd_windows_prefilter_t *pf, const vd_rect_t *win);

// Counts of vd_windows_rank.
typedef struct vd_windows_rank_stats {
    uint32_t windows;   // windows enumerated (saturates at UINT32_MAX)
    uint32_t passed;    // windows with level >= min_std (before the budget)
} vd_windows_rank_stats_t;

// The best windows of a frame within a budget: enumerates the windows of cfg
// (as vd_windows_generate, without its max_windows cap) twice. Pass one makes
// the histogram of the levels >= min_std; from it, the level `cut` where the
// budget runs out (highest levels first). Pass two calls visit(ctx, win) for
// every window of level > cut and for the first (room - windows above cut)
// windows of level == cut, in vd_windows_generate's order: at most `room`
// calls, the highest levels, ties in generator order.
//   cfg      settings for the frame (frame_w/frame_h = the frame's size; zero
//            fields = defaults; resolved internally, not modified).
//   pf       the frame's pre-filter.
//   min_std  lowest level passed (0..255).
//   room     budget; 0 = only pass one (stats, no calls).
//   hist     caller scratch of 256 counters (overwritten).
//   visit    called per selected window (NULL only when room is 0).
//   stats    out, may be NULL.
// Returns VD_OK; VD_ERR_ARG for NULL cfg/pf/hist, a NULL visit with room > 0,
// or a cfg rejected by vd_windows_resolve. Time O(windows) twice; stack: a
// resolved copy of cfg plus ~100 bytes, plus the visitor's.
VD_API vd_status_t vd_windows_rank(const vd_windows_cfg_t *cfg, const vd_windows_prefilter_t *pf, uint8_t min_std,
                            size_t room, uint32_t hist[256], vd_windows_visit_fn visit, void *ctx,
                            vd_windows_rank_stats_t *stats);

#ifdef __cplusplus
}
#endif
#endif
