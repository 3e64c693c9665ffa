// SPDX-License-Identifier: MIT
// Private: the one enumeration of sliding windows, shared by windows.c and the detector.
#ifndef VD_WINDOWS_INTERNAL_H
#define VD_WINDOWS_INTERNAL_H

#include <stdint.h>

#include "vd/windows.h"

// Called once per window, in vd_windows_generate's order; must not keep `win`.
typedef void (*vd_windows_visit_fn)(void *ctx, const vd_rect_t *win);

// Enumerates every window of a resolved config (vd_windows_resolve) without
// storing any: visit (may be NULL to only count) gets each one. Returns the
// number of windows. Bounded by the config: VD_WINDOWS_MAX_SCALES heights x
// n_aspects x rows x columns of the frame.
uint64_t vd_windows_walk(const vd_windows_cfg_t *c, vd_windows_visit_fn visit, void *ctx);

#endif
