// SPDX-License-Identifier: MIT
// vd_fir_demo's output files (out.c): a file is written as "<dir>/.<name>.tmp.<pid>" and
// renamed over its final name on commit; abort removes it. Directories made like mkdir -p.
#ifndef VD_DEMO_OUT_H
#define VD_DEMO_OUT_H

#include <stdio.h>

#include "vd/status.h"

typedef struct demo_atomic {
    char final_path[4096];
    char tmp_path[4200];
    FILE *f;
} demo_atomic_t;

vd_status_t demo_atomic_open(demo_atomic_t *a, const char *path, char *err, size_t err_len);
vd_status_t demo_atomic_commit(demo_atomic_t *a, char *err, size_t err_len);
void demo_atomic_abort(demo_atomic_t *a);
// Creates a directory and its parents (like mkdir -p).
vd_status_t demo_mkdirs(const char *path, char *err, size_t err_len);
// The file name part of a path ("a/b/c.pgm" -> "c.pgm").
const char *demo_basename(const char *path);

#endif
