// SPDX-License-Identifier: MIT
// Progress of vd_fir_demo on stderr (progress.c): on a terminal one line redrawn in place,
// otherwise a plain line every 50 frames and at the last one.
#ifndef VD_DEMO_PROGRESS_H
#define VD_DEMO_PROGRESS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

typedef struct demo_progress {
    bool on;          // false with --quiet: nothing is written
    bool tty;         // stderr is a terminal
    uint64_t total;   // frames expected (0 = unknown: no percentage, no time left)
    double t0;        // start time, seconds (any monotonic clock)
    double last;      // last redraw (terminal), seconds; < 0 before the first
    bool drawn;       // a terminal line is on screen (ended by demo_progress_end)
} demo_progress_t;

void demo_progress_start(demo_progress_t *p, bool on, bool tty, uint64_t total, double now_s);
// After frame number `done` (1-based) named `name` with n_det detections, at time now_s.
void demo_progress_frame(demo_progress_t *p, FILE *f, uint64_t done, const char *name, size_t n_det, double now_s);
// Ends a terminal line with a newline (nothing otherwise).
void demo_progress_end(demo_progress_t *p, FILE *f);
// The progress text without line control: "[done/total pct%] R frames/s, M:SS left | name: n detections"
// ("[done] R frames/s | name: n detections" when total is 0). Returns its length (cut at cap - 1).
size_t demo_progress_text(char *buf, size_t cap, uint64_t done, uint64_t total, double elapsed_s,
                          const char *name, size_t n_det);

#endif
