// SPDX-License-Identifier: MIT
// vd_capture_open: picks the back end (V4L2 camera or recorded files) for a source name.
//
// The one place that knows every back end: they depend on the generic layer
// (capture.c), and this factory on them, so the port has no include cycle.
// Bounds: one stat() and the chosen back end's open; no allocation here.
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "vd_port/capture.h"
#include "vd_port/file.h"
#include "vd_port/v4l2.h"

#include <string.h>
#include <sys/stat.h>

static bool starts_with(const char *s, const char *prefix)
{
    return strncmp(s, prefix, strlen(prefix)) == 0;
}

vd_status_t vd_capture_open(vd_capture_t *cap, const char *input, const vd_capture_opts_t *opts)
{
    vd_capture_opts_t def;
    if (cap == NULL) {
        return VD_ERR_ARG;
    }
    memset(cap, 0, sizeof(*cap));
    if (input == NULL || input[0] == '\0') {
        return vd_capture_fail(cap, VD_ERR_ARG, "no input given");
    }
    if (opts == NULL) {
        vd_capture_opts_default(&def);
        opts = &def;
    }
    // "/dev/..." is a camera unless it is a plain file or folder (e.g. frames in /dev/shm).
    struct stat sb;
    bool is_dev = starts_with(input, "/dev/") &&
                  (stat(input, &sb) != 0 || (!S_ISDIR(sb.st_mode) && !S_ISREG(sb.st_mode)));
    if (is_dev) {
#if defined(VD_PORT_HAVE_V4L2_BACKEND)
        vd_v4l2_cfg_t cfg;
        memset(&cfg, 0, sizeof(cfg));
        cfg.device = input;
        cfg.width = opts->width;
        cfg.height = opts->height;
        cfg.fps = opts->fps;
        cfg.format = opts->format;
        cfg.n_buffers = opts->n_buffers;
        return vd_v4l2_open(cap, &cfg);
#else
        return vd_capture_fail(cap, VD_ERR_NODEV, "%s: built without the V4L2 back end", input);
#endif
    }
    return vd_file_open(cap, input, VD_FILE_AUTO, opts);
}
