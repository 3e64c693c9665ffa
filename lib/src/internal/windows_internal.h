// SPDX-License-Identifier: MIT
// Private: the sliding-window band/ground-model test shared by windows.c and the detector.
#ifndef VD_WINDOWS_INTERNAL_H
#define VD_WINDOWS_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "vd/windows.h"

// True when a window of height h whose bottom row is yb lies in one of the
// config's bands and, with a ground model, within its height tolerance.
bool vd_windows_row_ok(const vd_windows_cfg_t *c, uint32_t h, int32_t yb);

#endif
