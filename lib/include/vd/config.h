// SPDX-License-Identifier: MIT
// Compile-time configuration of vd. Firmware may provide its own "vd_user_config.h"
// (define VD_USER_CONFIG_FILE or put it on the include path with VD_HAVE_USER_CONFIG)
// to override any default below; each default is documented where it is set.
#ifndef VD_CONFIG_H
#define VD_CONFIG_H

#if defined(VD_USER_CONFIG_FILE)
#include VD_USER_CONFIG_FILE
#elif defined(VD_HAVE_USER_CONFIG)
#include "vd_user_config.h"
#endif

// Largest accepted frame width/height in pixels. 8192 keeps every
// width*height product below 2^26, so pixel counts, sums of 8-bit values
// (< 2^34 needs uint64) and coordinates fit the types used in lib/.
#ifndef VD_MAX_DIM
#define VD_MAX_DIM 8192u
#endif

// Internal invariant check (our own bugs, never outside input). Defaults to
// nothing so release firmware pays no cost; the test build defines
// VD_ASSERT_ENABLE to trap. Firmware can route it to its own fault handler.
#ifndef VD_ASSERT
#if defined(VD_ASSERT_ENABLE)
#define VD_ASSERT(cond) do { if (!(cond)) { __builtin_trap(); } } while (0)
#else
#define VD_ASSERT(cond) ((void)0)
#endif
#endif

// Alignment (bytes) that every *_init() demands of a caller workspace; 8 covers
// int64 and pointers on every supported target.
#ifndef VD_WORKSPACE_ALIGN
#define VD_WORKSPACE_ALIGN 8u
#endif

// Marks every public function of lib/include/vd. The library is compiled with -fvisibility=hidden
// (gcc, clang), so a shared build (libvd.so) exports these functions and nothing else; internal
// cross-file functions carry the prefix vd__ (docs/architecture.md, "Names"). Firmware may define it
// first, e.g. empty, or __declspec(dllexport) / dllimport for a Windows DLL.
#ifndef VD_API
#if defined(__GNUC__)
#define VD_API __attribute__((visibility("default")))
#else
#define VD_API
#endif
#endif

#endif
