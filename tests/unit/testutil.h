// SPDX-License-Identifier: MIT
// Helpers for vd's unit tests: guarded workspaces, small images, real-data paths.
#ifndef VD_TESTUTIL_H
#define VD_TESTUTIL_H

#include <stddef.h>
#include <stdint.h>
#include <stdbool.h>
#include "vd/vd.h"

// A workspace of exactly `bytes` usable bytes, VD_WORKSPACE_ALIGN-aligned, with
// guard bytes before and after. tu_guard_check() fails the test if a guard was
// written. At most one guarded buffer per slot (0..3) is live at once.
void *tu_guarded_alloc(int slot, size_t bytes);
void tu_guard_check(int slot);
void tu_guarded_free(int slot);

// Asserts the workspace contract of a size query + consumer:
// `run(ws, bytes, ctx)` must return VD_ERR_WORKSPACE for bytes-1 and for a
// misaligned pointer, VD_OK for exactly `bytes`, and leave the guards intact.
typedef vd_status_t (*tu_ws_fn)(void *ws, size_t bytes, void *ctx);
void tu_check_workspace_contract(size_t bytes, tu_ws_fn run, void *ctx);

// Asserts two rectangles equal, field by field, with msg on failure.
void tu_assert_rect_equal(const vd_rect_t *want, const vd_rect_t *got, const char *msg);

// Deterministic pseudo-random numbers (xorshift32) for naive-vs-fast tests.
uint32_t tu_rand(uint32_t *state);

// Reference temperature of a raw value under a calibration, in centi-kelvin:
// offset_ck + round-half-up(raw * gain_q16 / 65536) by C division (independent
// of the library's shifts); int64, so it never saturates.
int64_t tu_calib_temp_ck(const vd_calib_t *c, uint32_t raw);

// Path of the shared data directory (../shared/data beside the project) or NULL
// if it is absent; tests that need it call TEST_IGNORE_MESSAGE with a reason.
const char *tu_data_dir(void);

// Little-endian field writers/readers and the .vdm CRC (bytes [16, total) into
// offset 12, total at offset 8) for tests that build model blobs by hand.
void tu_wr16(uint8_t *p, uint32_t v);
void tu_wr32(uint8_t *p, uint32_t v);
uint32_t tu_rd32(const uint8_t *p);
/* CRC-32 (IEEE) of n bytes, computed bit by bit (tu_crc32("123456789", 9) == 0xCBF43926). */
uint32_t tu_crc32(const uint8_t *p, size_t n);
void tu_vdm_fix_crc(uint8_t *blob);

#endif
