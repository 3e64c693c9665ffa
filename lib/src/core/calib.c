// SPDX-License-Identifier: MIT
// Linear radiometric calibration: raw <-> centi-kelvin and the temperature -> grey map.
//
// Algorithm: temperature = offset + round-half-up(raw * gain_q16 / 2^16); its
// inverse (smallest raw at least as hot as a temperature) is one ceiling
// division, no search. The temperature -> grey map is
// ((T - lo) * mul_q16 + 2^15) >> 16 with mul_q16 = round(255 * 2^16 / (hi - lo))
// (one multiply per pixel instead of a division), clamped to 0..255; the
// shift is a floor shift (internal/shift_internal.h) because T - lo may be
// negative. Its inverse (smallest raw at a grey level) is one ceiling
// division to a temperature, then the raw inverse. Convention: TLinear radiometric cameras (0.01 K per count, calib.h).
// Bounds: O(1) per call; stack <= 32 bytes on Cortex-M (docs/embedded.md).
// Arithmetic: raw * gain_q16 < 2^16 * 2^31 = 2^47 and ck - offset_ck is in
// +-2^32, so (ck - offset_ck) * 65536 < 2^49: all in int64_t; in the grey
// map |T - lo| < 2^32 and mul_q16 <= 255 * 2^16 < 2^24, product < 2^56.
#include "vd/calib.h"
#include "internal/calib_internal.h"
#include "internal/shift_internal.h"
#include "internal/vd_internal.h"

vd_status_t vd_calib_ck_from_raw(const vd_calib_t *cal, uint16_t raw, int32_t *ck)
{
    VD_VERIFY(cal != NULL && ck != NULL, VD_ERR_ARG);
    VD_VERIFY(cal->gain_q16 >= 0, VD_ERR_ARG);
    int64_t t = (int64_t)cal->offset_ck + vd_shr_round_i64((int64_t)raw * (int64_t)cal->gain_q16, 16u);
    VD_VERIFY(t >= (int64_t)INT32_MIN && t <= (int64_t)INT32_MAX, VD_ERR_RANGE);
    *ck = (int32_t)t;
    return VD_OK;
}

// Smallest raw with offset + floor((raw * g + 2^15) / 2^16) >= ck, for ck as int64.
// floor(v / 2^16) >= k  <=>  v >= k * 2^16 for integer k, so the condition is
// raw * g >= k * 2^16 - 2^15 with k = ck - offset: a ceiling division.
static vd_status_t raw_from_ck64(const vd_calib_t *cal, int64_t ck, uint16_t *raw)
{
    VD_VERIFY(cal != NULL && raw != NULL, VD_ERR_ARG);
    VD_VERIFY(cal->gain_q16 >= 0, VD_ERR_ARG);
    const int64_t need = (ck - (int64_t)cal->offset_ck) * 65536 - 32768;
    if (need <= 0) {
        *raw = 0u; // raw 0 is already hot enough
        return VD_OK;
    }
    VD_VERIFY(cal->gain_q16 > 0, VD_ERR_RANGE); // constant temperature below ck
    const int64_t g = (int64_t)cal->gain_q16;
    const int64_t r = (need + g - 1) / g;
    VD_VERIFY(r <= 65535, VD_ERR_RANGE);
    *raw = (uint16_t)r;
    return VD_OK;
}

vd_status_t vd_calib_raw_from_ck(const vd_calib_t *cal, int32_t ck, uint16_t *raw)
{
    return raw_from_ck64(cal, (int64_t)ck, raw);
}

vd_status_t vd_calib_raw_from_centi_celsius(const vd_calib_t *cal, int32_t centi_c, uint16_t *raw)
{
    return raw_from_ck64(cal, (int64_t)centi_c + VD_CALIB_CK_PER_0C, raw);
}

vd_status_t vd_calib_grey_init(vd_calib_grey_t *map, const vd_calib_t *cal, int32_t lo_ck, int32_t hi_ck)
{
    VD_VERIFY(map != NULL && cal != NULL, VD_ERR_ARG);
    VD_VERIFY(cal->gain_q16 >= 0 && lo_ck < hi_ck, VD_ERR_ARG);
    const int64_t span = (int64_t)hi_ck - lo_ck;
    map->calib = *cal;
    map->lo_ck = lo_ck;
    map->hi_ck = hi_ck;
    map->mul_q16 = ((int64_t)255 * 65536 + span / 2) / span;
    return VD_OK;
}

uint8_t vd_calib_grey_u8(const vd_calib_grey_t *map, uint16_t raw)
{
    return vd__calib_grey_u8(map, raw);   // internal/calib_internal.h: out of int32 counts as 0 ck (documented)
}

vd_status_t vd_calib_grey_raw_at(const vd_calib_grey_t *map, uint8_t grey, uint16_t *raw)
{
    VD_VERIFY(map != NULL && raw != NULL, VD_ERR_ARG);
    VD_VERIFY(map->mul_q16 > 0, VD_ERR_ARG);   // the gain is raw_from_ck64's to check
    if (grey == 0u) {
        *raw = 0u;   // every sample is at grey 0 or above
        return VD_OK;
    }
    // floor(((T - lo) * mul + 2^15) / 2^16) >= g  <=>  (T - lo) * mul >= g * 2^16 - 2^15 (> 0): a ceiling division.
    const int64_t need = (int64_t)grey * 65536 - 32768;
    const int64_t ck = (int64_t)map->lo_ck + (need + map->mul_q16 - 1) / map->mul_q16;
    return raw_from_ck64(&map->calib, ck, raw);
}
