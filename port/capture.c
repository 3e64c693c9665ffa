// SPDX-License-Identifier: MIT
// Generic capture layer: state machine, argument checks and error text shared by every back end.
//
// The generic layer owns the rules a caller can rely on whatever the source:
// one held frame at a time (so no buffer is handed out twice), release only
// of the held frame, stop/start cycles, close from any state. Back ends
// (port/v4l2, port/file) only do their I/O. Bounds: O(1) per call plus the
// back end's work; no allocation here. Choosing a back end by name
// (vd_capture_open) is capture_open.c: the back ends call this layer, never
// the other way round.
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "vd_port/capture.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

void vd_capture_opts_default(vd_capture_opts_t *opts)
{
    if (opts == NULL) {
        return;
    }
    memset(opts, 0, sizeof(*opts));
    opts->n_buffers = 4u;
    opts->raw_format = VD_PIX_U16;
}

vd_status_t vd_capture_fail(vd_capture_t *cap, vd_status_t st, const char *fmt, ...)
{
    if (cap != NULL && fmt != NULL) {
        va_list ap;
        va_start(ap, fmt);
        (void)vsnprintf(cap->error, sizeof(cap->error), fmt, ap);
        va_end(ap);
    }
    return st;
}

void vd_capture_attach(vd_capture_t *cap, const vd_capture_ops_t *ops, void *impl)
{
    memset(cap, 0, sizeof(*cap));
    cap->ops = ops;
    cap->impl = impl;
    cap->state = VD_CAPTURE_OPEN;
}

vd_status_t vd_capture_start(vd_capture_t *cap)
{
    if (cap == NULL) {
        return VD_ERR_ARG;
    }
    if (cap->state != VD_CAPTURE_OPEN || cap->ops == NULL) {
        return vd_capture_fail(cap, VD_ERR_STATE, "start: capture is %s",
                               cap->state == VD_CAPTURE_CLOSED ? "not open" : "already streaming");
    }
    cap->at_end = false;
    vd_status_t st = cap->ops->start(cap);
    if (st == VD_OK) {
        cap->state = VD_CAPTURE_STREAMING;
        cap->held = NULL;
    }
    return st;
}

vd_status_t vd_capture_next(vd_capture_t *cap, int32_t timeout_ms, vd_frame_t *frame)
{
    if (cap == NULL) {
        return VD_ERR_ARG;
    }
    if (frame == NULL) {
        return vd_capture_fail(cap, VD_ERR_ARG, "next: frame is NULL");
    }
    if (cap->state == VD_CAPTURE_HOLDING) {
        return vd_capture_fail(cap, VD_ERR_STATE, "next: the previous frame was not released");
    }
    if (cap->state != VD_CAPTURE_STREAMING) {
        return vd_capture_fail(cap, VD_ERR_STATE, "next: capture is not streaming");
    }
    memset(frame, 0, sizeof(*frame));
    vd_status_t st = cap->ops->next(cap, timeout_ms, frame);
    if (st == VD_OK) {
        if (vd_frame_check(frame) != VD_OK) {
            // A back end bug must not reach the detector as a bad view.
            cap->counters.errors++;
            memset(frame, 0, sizeof(*frame));
            return vd_capture_fail(cap, VD_ERR_FORMAT, "next: back end produced an invalid frame");
        }
        cap->state = VD_CAPTURE_HOLDING;
        cap->held = frame->data;
        cap->counters.frames++;
        return VD_OK;
    }
    memset(frame, 0, sizeof(*frame));
    if (st == VD_ERR_TIMEOUT) {
        cap->counters.timeouts++;
    } else if (!(st == VD_ERR_RANGE && cap->at_end)) {
        cap->counters.errors++;   // the end of a recording is not an error event
    }
    return st;
}

vd_status_t vd_capture_release(vd_capture_t *cap, const vd_frame_t *frame)
{
    if (cap == NULL) {
        return VD_ERR_ARG;
    }
    if (cap->state != VD_CAPTURE_HOLDING) {
        return vd_capture_fail(cap, VD_ERR_STATE, "release: no frame is held");
    }
    if (frame == NULL || frame->data != cap->held) {
        return vd_capture_fail(cap, VD_ERR_ARG, "release: not the frame handed out by next");
    }
    cap->state = VD_CAPTURE_STREAMING;
    cap->held = NULL;
    return cap->ops->release(cap, frame);
}

vd_status_t vd_capture_stop(vd_capture_t *cap)
{
    if (cap == NULL) {
        return VD_ERR_ARG;
    }
    if (cap->state == VD_CAPTURE_CLOSED || cap->ops == NULL) {
        return vd_capture_fail(cap, VD_ERR_STATE, "stop: capture is not open");
    }
    cap->at_end = false;
    if (cap->state == VD_CAPTURE_OPEN) {
        return VD_OK;
    }
    vd_status_t st = cap->ops->stop(cap);
    cap->state = VD_CAPTURE_OPEN;
    cap->held = NULL;
    return st;
}

void vd_capture_close(vd_capture_t *cap)
{
    if (cap == NULL) {
        return;
    }
    if (cap->ops != NULL) {
        if (cap->state == VD_CAPTURE_STREAMING || cap->state == VD_CAPTURE_HOLDING) {
            (void)cap->ops->stop(cap);
        }
        cap->ops->close(cap);
    }
    cap->ops = NULL;
    cap->impl = NULL;
    cap->held = NULL;
    cap->state = VD_CAPTURE_CLOSED;
}

const char *vd_capture_error(const vd_capture_t *cap)
{
    if (cap == NULL) {
        return "";
    }
    // The buffer is always NUL-terminated by vsnprintf/memset; guard anyway.
    return memchr(cap->error, '\0', sizeof(cap->error)) != NULL ? cap->error : "";
}

void vd_capture_get_counters(const vd_capture_t *cap, vd_capture_counters_t *out)
{
    if (out == NULL) {
        return;
    }
    if (cap == NULL) {
        memset(out, 0, sizeof(*out));
        return;
    }
    *out = cap->counters;
}

const char *vd_capture_frame_name(const vd_capture_t *cap)
{
    if (cap == NULL || cap->ops == NULL || cap->ops->frame_name == NULL) {
        return "";
    }
    const char *n = cap->ops->frame_name(cap);
    return n != NULL ? n : "";
}

bool vd_capture_at_end(const vd_capture_t *cap)
{
    return cap != NULL && cap->at_end;
}

void vd_capture_format(const vd_capture_t *cap, uint32_t *width, uint32_t *height, vd_pixfmt_t *format)
{
    uint32_t w = 0u;
    uint32_t h = 0u;
    vd_pixfmt_t f = (vd_pixfmt_t)0;
    if (cap != NULL && cap->ops != NULL && cap->ops->format != NULL) {
        cap->ops->format(cap, &w, &h, &f);
    }
    if (width != NULL) {
        *width = w;
    }
    if (height != NULL) {
        *height = h;
    }
    if (format != NULL) {
        *format = f;
    }
}

vd_capture_state_t vd_capture_get_state(const vd_capture_t *cap)
{
    return cap != NULL ? cap->state : VD_CAPTURE_CLOSED;
}
