// SPDX-License-Identifier: MIT
// Linear radiometric calibration of a 16-bit camera: raw <-> temperature and the temperature -> grey map.
#ifndef VD_CALIB_H
#define VD_CALIB_H

#include <stdint.h>

#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Linear radiometric calibration of a 16-bit camera:
//   temperature_ck(raw) = offset_ck + round(raw * gain_q16 / 65536)
// in centi-kelvin (1 ck = 0.01 K), where round() is round-half-up, i.e.
// floor((raw * gain_q16 + 32768) / 65536) (raw * gain_q16 is never negative).
// gain_q16: centi-kelvin per raw count in Q16.16, 0 ..INT32_MAX (a negative gain
//           is rejected with VD_ERR_ARG: temperature must not fall as raw rises).
// offset_ck: temperature of raw 0 in centi-kelvin, any int32.
// Example: a TLinear camera with 0.01 K resolution has gain_q16 = 65536 (1.0)
// and offset_ck = 0, so raw 30315 is 303.15 K = 30.00 degC.
typedef struct vd_calib {
    int32_t gain_q16;
    int32_t offset_ck;
} vd_calib_t;

// Offset between kelvin and degrees Celsius in centi units (273.15 K).
#define VD_CALIB_CK_PER_0C 27315

// Temperature of one raw value: *ck = offset_ck + round-half-up(raw * gain_q16 / 65536).
// Returns VD_OK; VD_ERR_ARG for NULL pointers or a negative gain; VD_ERR_RANGE
// if the temperature does not fit an int32 (then *ck is unchanged).
VD_API vd_status_t vd_calib_ck_from_raw(const vd_calib_t *cal, uint16_t raw, int32_t *ck);

// Smallest raw value whose temperature (above) is >= ck: with a non-negative
// gain the temperature never falls as raw rises, so `raw >= *raw_out` is
// exactly `temperature >= ck`. Computed in closed form (no search).
// Returns VD_OK; VD_ERR_ARG for NULL pointers or a negative gain; VD_ERR_RANGE
// if no raw value in 0..65535 reaches ck (then *raw is unchanged).
VD_API vd_status_t vd_calib_raw_from_ck(const vd_calib_t *cal, int32_t ck, uint16_t *raw);

// As vd_calib_raw_from_ck for a temperature in centi-degrees Celsius
// (3000 = 30.00 degC): ck = centi_c + VD_CALIB_CK_PER_0C. Same statuses.
VD_API vd_status_t vd_calib_raw_from_centi_celsius(const vd_calib_t *cal, int32_t centi_c, uint16_t *raw);

// Linear map of temperatures to 8-bit grey, for the planes that refinement,
// the window pre-filter and the network need from a 16-bit frame (a fixed
// window around the hot threshold, like a Lepton AGC with a fixed range):
//   grey(raw) = clamp(((T - lo_ck) * mul_q16 + 2^15) >> 16, 0, 255),
//   mul_q16 = round-half-up(255 * 2^16 / (hi_ck - lo_ck)),
// T = vd_calib_ck_from_raw(calib, raw) (a temperature beyond int32, possible
// only with an extreme offset_ck, counts as 0 ck), >> a floor shift. The
// result is within 1 grey level of clamp((T - lo_ck) * 255 / (hi_ck - lo_ck)).
// Fill it with vd_calib_grey_init; the fields are read-only afterwards.
typedef struct vd_calib_grey {
    vd_calib_t calib;   // raw -> centi-kelvin
    int32_t lo_ck;      // temperature of grey 0
    int32_t hi_ck;      // temperature of grey 255 (> lo_ck)
    int64_t mul_q16;    // 255 * 2^16 / (hi_ck - lo_ck), rounded; 1..255 * 2^16
} vd_calib_grey_t;

// Sets up `map` for vd_calib_grey_u8 (copies *cal).
// Returns VD_OK; VD_ERR_ARG for NULL pointers, a negative gain or lo_ck >= hi_ck.
VD_API vd_status_t vd_calib_grey_init(vd_calib_grey_t *map, const vd_calib_t *cal, int32_t lo_ck, int32_t hi_ck);

// Grey level 0..255 of one raw value through an initialised map (above).
// O(1), no checks: `map` must come from vd_calib_grey_init.
VD_API uint8_t vd_calib_grey_u8(const vd_calib_grey_t *map, uint16_t raw);

// Smallest raw value whose grey level through `map` is >= grey: since the map
// never falls as raw rises, `raw >= *raw_out` is exactly
// `vd_calib_grey_u8(map, raw) >= grey` (an 8-bit threshold carried to a
// 16-bit frame, e.g. the hot-spot threshold in a frame's own grey window).
// Closed form, O(1): grey 0 gives 0; else the least temperature
// lo_ck + ceil((grey * 2^16 - 2^15) / mul_q16), then vd_calib_raw_from_ck.
// Exact for a calibration whose temperatures of raw 0..65535 fit an int32
// (every one vd_detector_cfg_resolve accepts with the per-frame window): the
// map counts a temperature beyond int32 as 0 ck, which this inverse does not.
// Returns VD_OK; VD_ERR_ARG for NULL pointers, a negative gain or a map not
// from vd_calib_grey_init (mul_q16 <= 0); VD_ERR_RANGE if no raw value in
// 0..65535 reaches `grey` (then *raw is unchanged).
VD_API vd_status_t vd_calib_grey_raw_at(const vd_calib_grey_t *map, uint8_t grey, uint16_t *raw);

#ifdef __cplusplus
}
#endif
#endif
