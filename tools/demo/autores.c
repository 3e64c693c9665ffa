// SPDX-License-Identifier: MIT
// --cnn-full-res auto: which resolution the networks should read a recording at, measured on its first frames
// (the measurement itself: common/flipagree.c, which the GStreamer element shares).
#include "autores.h"

#include <stdio.h>
#include <string.h>

vd_status_t demo_autores_measure(const demo_opts_t *o, const char *input, const vd_capture_opts_t *copts,
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
    while (st == VD_OK && out->frames < DEMO_AUTORES_MAX_FRAMES &&
           (o->max_frames == 0u || out->frames < o->max_frames)) {
        vd_frame_t f;
        st = vd_capture_next(&cap, o->timeout_ms, &f);
        if (st == VD_ERR_RANGE && vd_capture_at_end(&cap)) {
            st = VD_OK;
            break;
        }
        if (st != VD_OK) {
            snprintf(err, err_len, "%s", vd_capture_error(&cap));
            break;
        }
        if (fa == NULL) {
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
