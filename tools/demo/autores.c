// SPDX-License-Identifier: MIT
// --cnn-full-res auto: which resolution the networks should read a recording at, measured on 64 frames spread
// over it
// (the measurement itself: common/flipagree.c, which the GStreamer element shares).
#include "autores.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "models.h"
#include "vd_port/file.h"

// The recording's frames the measurement may draw from: all (vd_file_frame_total), at most --frames; 0 when the
// capture cannot say (then its first frames are read one after another).
static uint64_t recording_frames(const demo_opts_t *o, const vd_capture_t *cap)
{
    uint64_t total = 0u;
    if (vd_file_frame_total(cap, &total) != VD_OK) {
        return 0u;
    }
    return (o->max_frames != 0u && total > o->max_frames) ? o->max_frames : total;
}

vd_status_t demo_autores_measure(demo_opts_t *o, const char *input, const vd_capture_opts_t *copts,
                                 demo_autores_t *out, char *err, size_t err_len)
{
    memset(out, 0, sizeof *out);
    const double t0 = demo_now_s();
    vd_capture_t cap;
    demo_flipagree_t *fa = NULL;
    vd_status_t st = vd_capture_open(&cap, input, copts);
    if (st == VD_OK) {
        st = vd_capture_start(&cap);
    }
    if (st != VD_OK) {
        snprintf(err, err_len, "%s", vd_capture_error(&cap)[0] ? vd_capture_error(&cap) : input);
    }
    out->total = st == VD_OK ? recording_frames(o, &cap) : 0u;
    // frames the measurement may read: the recording's (or, not known, --frames or any number up to the end)
    const uint64_t limit = out->total != 0u ? out->total : (o->max_frames != 0u ? o->max_frames : UINT64_MAX);
    uint64_t pos = 0u;   // the next frame the capture hands out
    while (st == VD_OK && out->frames < DEMO_AUTORES_SPREAD_FRAMES && out->frames < limit) {
        if (out->total != 0u) {   // spread over the recording: pass over the frames between two samples
            const uint64_t want = demo_autores_sample(out->total, out->frames);
            st = want > pos ? vd_file_skip(&cap, want - pos) : VD_OK;
            pos = want + 1u;
        }
        vd_frame_t f;
        if (st == VD_OK) {
            st = vd_capture_next(&cap, o->timeout_ms, &f);
        }
        if (st == VD_ERR_RANGE && vd_capture_at_end(&cap)) {
            st = VD_OK;
            break;
        }
        if (st != VD_OK) {
            snprintf(err, err_len, "%s", vd_capture_error(&cap));
            break;
        }
        if (fa == NULL) {
            demo_grey_decide(o, &f);   // the measurement's networks read grey as the run's will
            st = demo_flipagree_new(&fa, o, &f, err, err_len);
        }
        if (st == VD_OK) {
            st = demo_flipagree_add(fa, &f, out);
            if (st != VD_OK) {
                snprintf(err, err_len, "--cnn-full-res auto: %s: detector failed", vd_capture_frame_name(&cap));
            }
        }
        vd_capture_release(&cap, &f);
    }
    vd_capture_close(&cap);
    demo_flipagree_free(fa);
    if (st == VD_OK) {
        demo_autores_decide(out);
    }
    out->seconds = demo_now_s() - t0;
    return st;
}
