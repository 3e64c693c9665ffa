// SPDX-License-Identifier: MIT
// Private helpers shared by lib/ modules: overflow-checked size arithmetic and
// workspace carving. Not installed.
#ifndef VD_INTERNAL_H
#define VD_INTERNAL_H

#include <stddef.h>
#include <stdint.h>
#include <stdbool.h>

#include "vd/config.h"
#include "vd/status.h"

// Bad outside input: return the status from the calling function.
#define VD_VERIFY(cond, st) do { if (!(cond)) { return (st); } } while (0)
// Propagate a failing status.
#define VD_TRY(expr) do { vd_status_t vd_try_st_ = (expr); if (vd_try_st_ != VD_OK) { return vd_try_st_; } } while (0)

// a * b into *out; false on size_t overflow.
static inline bool vd_mul_size(size_t a, size_t b, size_t *out)
{
    if (a != 0u && b > SIZE_MAX / a) {
        return false;
    }
    *out = a * b;
    return true;
}

// a + b into *out; false on size_t overflow.
static inline bool vd_add_size(size_t a, size_t b, size_t *out)
{
    if (b > SIZE_MAX - a) {
        return false;
    }
    *out = a + b;
    return true;
}

// Rounds n up to a multiple of VD_WORKSPACE_ALIGN; false on overflow.
static inline bool vd_align_size(size_t n, size_t *out)
{
    size_t a = (size_t)VD_WORKSPACE_ALIGN;
    if (n > SIZE_MAX - (a - 1u)) {
        return false;
    }
    *out = (n + (a - 1u)) & ~(a - 1u);
    return true;
}

// Bump allocator over a caller workspace, used only inside init/run to carve
// the buffer into arrays; every slice is VD_WORKSPACE_ALIGN aligned.
typedef struct vd_arena {
    uint8_t *base;
    size_t size;
    size_t used;
} vd_arena_t;

static inline vd_status_t vd_arena_init(vd_arena_t *a, void *ws, size_t bytes)
{
    if (ws == NULL || ((uintptr_t)ws % (uintptr_t)VD_WORKSPACE_ALIGN) != 0u) {
        return VD_ERR_WORKSPACE;
    }
    a->base = (uint8_t *)ws;
    a->size = bytes;
    a->used = 0u;
    return VD_OK;
}

// Takes `bytes` (rounded up to the alignment) from the arena; NULL if it does
// not fit, which callers turn into VD_ERR_WORKSPACE.
static inline void *vd_arena_take(vd_arena_t *a, size_t bytes)
{
    size_t n;
    if (!vd_align_size(bytes, &n) || n > a->size - a->used) {
        return NULL;
    }
    void *p = a->base + a->used;
    a->used += n;
    return p;
}

// Accumulates an aligned slice into a size query; false on overflow.
static inline bool vd_size_add_slice(size_t *total, size_t bytes)
{
    size_t n;
    return vd_align_size(bytes, &n) && vd_add_size(*total, n, total);
}

#endif
