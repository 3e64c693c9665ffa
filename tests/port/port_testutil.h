// SPDX-License-Identifier: MIT
// Helpers for the port tests: a scratch directory and small file writers.
#ifndef VD_PORT_TESTUTIL_H
#define VD_PORT_TESTUTIL_H

#include <stddef.h>
#include <stdint.h>

// Creates a fresh scratch directory (mkdtemp under $TMPDIR or /tmp) and returns its path.
const char *pt_tmpdir(void);
// Removes the scratch directory and everything in it (one level of sub-directories).
void pt_tmpdir_remove(void);
// Path "<tmpdir>/<name>" in a static rotating buffer (valid for 8 calls).
const char *pt_path(const char *name);
// Writes bytes to <tmpdir>/<name>; returns the full path.
const char *pt_write(const char *name, const void *data, size_t len);
// Writes a PGM P5 file with the given header text (e.g. "P5\n4 3\n255\n") followed by len bytes.
const char *pt_write_pgm(const char *name, const char *header, const void *data, size_t len);
// Reads a whole file into a static buffer (at most cap bytes); returns its length or -1.
long pt_read(const char *path, uint8_t *buf, size_t cap);

#endif
