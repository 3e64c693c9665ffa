// SPDX-License-Identifier: MIT
// Private: the temperature -> grey map of calib.h inline, for the loops that map every sample of a 16-bit
// frame (resample.c's box averages, made for every network pass of every frame). vd_calib_grey_u8 is this
// function, so the two cannot drift apart.
#ifndef VD_CALIB_INTERNAL_H
#define VD_CALIB_INTERNAL_H

#include <stdint.h>

#include "vd/calib.h"
#include "internal/shift_internal.h"

// vd_calib_grey_u8 (calib.h) of raw <= 65535 through a map from vd_calib_grey_init (gain >= 0): the
// temperature offset + round-half-up(raw * gain / 2^16), 0 ck when it leaves int32 (as
// vd_calib_ck_from_raw's failure leaves it), then clamp(round-half-up((T - lo) * mul / 2^16), 0, 255).
// Bounds as calib.c's: raw * gain < 2^47, |T - lo| < 2^32, mul < 2^24.
static inline uint8_t vd__calib_grey_u8(const vd_calib_grey_t *map, uint32_t raw)
{
    int64_t t = (int64_t)map->calib.offset_ck + vd_shr_round_i64((int64_t)raw * (int64_t)map->calib.gain_q16, 16u);
    if (t < (int64_t)INT32_MIN || t > (int64_t)INT32_MAX) {
        t = 0;
    }
    const int64_t g = vd_shr_round_i64((t - map->lo_ck) * map->mul_q16, 16u);
    if (g < 0) {
        return 0u;
    }
    return (g > 255) ? 255u : (uint8_t)g;
}

#endif
