// SPDX-License-Identifier: MIT
// vd_fir_demo's command line (args.c): run options, then the detector settings of settings.h
// (a --config file first, flags over it). The GStreamer element vdfir parses its properties
// through the same function, so both give the same settings and the same error texts.
#ifndef VD_DEMO_ARGS_H
#define VD_DEMO_ARGS_H

#include <stdio.h>

#include "settings.h"

// Parses argv. Returns 0 to run, 1 after --help (exit 0), -1 on a usage error
// (message printed on stderr).
int demo_args_parse(demo_opts_t *o, int argc, char **argv);
// The same with the --help text written to `out` and the error line to `errf`
// (demo_args_parse: stdout, stderr); no other side effect (--config is read).
int demo_args_parse_to(demo_opts_t *o, int argc, char **argv, FILE *out, FILE *errf);
void demo_args_usage(FILE *f);

#endif
