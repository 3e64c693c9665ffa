// SPDX-License-Identifier: MIT
// V4L2 capture back end: GREY/Y16 negotiation, mmap streaming, bounded retries, device-loss and drop accounting.
//
// Algorithm (V4L2 API, "Streaming I/O (Memory Mapping)"): open O_NONBLOCK,
// QUERYCAP (capture + streaming), S_FMT (Y16 and/or GREY, requested size),
// S_PARM (time per frame); start = REQBUFS n, QUERYBUF + mmap each, QBUF each,
// STREAMON; next = poll(POLLIN, remaining time) then DQBUF, retrying EINTR and
// EAGAIN at most VD_V4L2_MAX_RETRIES times per call; every dequeued buffer is
// checked (index known and queued by us, no error flag, bytesused covers the
// frame) before it is handed out, and gaps in v4l2_buffer.sequence are counted
// as dropped frames; release = QBUF; stop = STREAMOFF, munmap, REQBUFS 0.
// Bounds: at most VD_V4L2_MAX_BUFFERS buffers; next() makes at most
// 2 * (VD_V4L2_MAX_RETRIES + 1) system calls and waits at most timeout_ms
// (plus one poll slice after an EINTR); no allocation after open.
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE
#endif

#include "vd_port/v4l2.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

#include <linux/videodev2.h>

typedef enum buf_state {
    BUF_IDLE = 0,    // mapped, owned by us, not queued (after a failed QBUF)
    BUF_QUEUED = 1,  // owned by the driver
    BUF_USER = 2     // handed out by next(), waiting for release()
} buf_state_t;

typedef struct v4l2_buf {
    void *addr;
    size_t length;
    buf_state_t state;
} v4l2_buf_t;

typedef struct v4l2_impl {
    vd_v4l2_sys_t sys;
    char device[256];
    int fd;
    uint32_t width;
    uint32_t height;
    uint32_t bytesperline;
    size_t need;             // bytes a complete frame occupies: stride * (h - 1) + width * bpp
    vd_pixfmt_t format;
    uint32_t fps_num;
    uint32_t fps_den;
    uint32_t n_req;
    uint32_t n_bufs;
    v4l2_buf_t bufs[VD_V4L2_MAX_BUFFERS];
    bool lost;
    bool have_seq;
    uint32_t last_seq;
    uint32_t held;
} v4l2_impl_t;

static v4l2_impl_t *impl_of(const vd_capture_t *cap)
{
    return (v4l2_impl_t *)cap->impl;
}

static bool errno_is_gone(int e)
{
    return e == ENODEV || e == ENXIO;
}

static vd_status_t errno_status(int e)
{
    return errno_is_gone(e) ? VD_ERR_NODEV : VD_ERR_IO;
}

// ioctl with EINTR retried (bounded); returns 0 or errno.
static int xioctl(v4l2_impl_t *v, unsigned long req, void *arg)
{
    int e = 0;
    for (uint32_t i = 0; i <= VD_V4L2_MAX_RETRIES; i++) {
        errno = 0;
        if (v->sys.ioctl(v->sys.ctx, v->fd, req, arg) == 0) {
            return 0;
        }
        e = errno != 0 ? errno : EIO;
        if (e != EINTR) {
            return e;
        }
    }
    return e;
}

static void fourcc_text(uint32_t f, char out[5])
{
    for (int i = 0; i < 4; i++) {
        char c = (char)((f >> (8 * i)) & 0xFFu);
        out[i] = (c >= 32 && c < 127) ? c : '?';
    }
    out[4] = '\0';
}

static bool host_is_little_endian(void)
{
    const uint16_t one = 1u;
    uint8_t b;
    memcpy(&b, &one, 1u);
    return b == 1u;
}

// Tries one pixel format at width x height; 0 when the driver took it as asked, EINVAL when it
// substituted another format (name in *got), or an errno.
static int try_format(v4l2_impl_t *v, uint32_t fourcc, uint32_t w, uint32_t h, struct v4l2_format *fmt, uint32_t *got)
{
    memset(fmt, 0, sizeof(*fmt));
    fmt->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    fmt->fmt.pix.width = w;
    fmt->fmt.pix.height = h;
    fmt->fmt.pix.pixelformat = fourcc;
    fmt->fmt.pix.field = V4L2_FIELD_NONE;
    int e = xioctl(v, VIDIOC_S_FMT, fmt);
    if (e != 0) {
        *got = 0u;
        return e;
    }
    *got = fmt->fmt.pix.pixelformat;
    return fmt->fmt.pix.pixelformat == fourcc ? 0 : EINVAL;
}

static vd_status_t negotiate_format(vd_capture_t *cap, v4l2_impl_t *v, const vd_v4l2_cfg_t *cfg)
{
    uint32_t w = cfg->width;
    uint32_t h = cfg->height;
    struct v4l2_format fmt;
    if (w == 0u) {
        memset(&fmt, 0, sizeof(fmt));
        fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        int e = xioctl(v, VIDIOC_G_FMT, &fmt);
        if (e != 0) {
            return vd_capture_fail(cap, errno_status(e), "%s: VIDIOC_G_FMT failed: %s", v->device, strerror(e));
        }
        w = fmt.fmt.pix.width;
        h = fmt.fmt.pix.height;
    }
    const uint32_t cands[2] = {V4L2_PIX_FMT_Y16, V4L2_PIX_FMT_GREY};
    uint32_t first = (cfg->format == VD_PIX_U8) ? 1u : 0u;
    uint32_t last = (cfg->format == VD_PIX_U16) ? 0u : 1u;
    uint32_t chosen = 0u;
    uint32_t offered = 0u;
    for (uint32_t i = first; i <= last; i++) {
        if (cands[i] == V4L2_PIX_FMT_Y16 && !host_is_little_endian()) {
            continue;   // Y16 is little-endian; a zero-copy view needs host order
        }
        uint32_t got = 0u;
        int e = try_format(v, cands[i], w, h, &fmt, &got);
        if (e == 0) {
            chosen = cands[i];
            break;
        }
        if (e != EINVAL) {
            return vd_capture_fail(cap, errno_status(e), "%s: VIDIOC_S_FMT failed: %s", v->device, strerror(e));
        }
        if (got != 0u) {
            offered = got;
        }
    }
    if (chosen == 0u) {
        char name[5];
        fourcc_text(offered, name);
        return vd_capture_fail(cap, VD_ERR_FORMAT, "%s: the driver does not deliver %s (it offered '%s'); vd needs GREY or Y16",
                               v->device, cfg->format == VD_PIX_U8 ? "GREY" : cfg->format == VD_PIX_U16 ? "Y16" : "Y16 or GREY",
                               offered != 0u ? name : "none");
    }
    const struct v4l2_pix_format *p = &fmt.fmt.pix;
    uint32_t bpp = chosen == V4L2_PIX_FMT_Y16 ? 2u : 1u;
    if (p->width == 0u || p->height == 0u || p->width > VD_MAX_DIM || p->height > VD_MAX_DIM) {
        return vd_capture_fail(cap, VD_ERR_FORMAT, "%s: driver frame size %ux%u outside 1..%u", v->device,
                               (unsigned)p->width, (unsigned)p->height, (unsigned)VD_MAX_DIM);
    }
    if (p->field != V4L2_FIELD_NONE && p->field != V4L2_FIELD_ANY) {
        return vd_capture_fail(cap, VD_ERR_FORMAT, "%s: interlaced frames (field %u) are not supported", v->device,
                               (unsigned)p->field);
    }
    uint32_t row = p->width * bpp;   // <= 16384, no overflow
    uint32_t stride = p->bytesperline != 0u ? p->bytesperline : row;
    if (stride < row || (bpp == 2u && (stride & 1u) != 0u)) {
        return vd_capture_fail(cap, VD_ERR_FORMAT, "%s: driver row stride %u is unusable for width %u", v->device,
                               (unsigned)stride, (unsigned)p->width);
    }
    size_t need = (size_t)stride * (size_t)(p->height - 1u) + (size_t)row;   // < 2^32 * 2^13, fits size_t on 64-bit
    if (p->sizeimage != 0u && (size_t)p->sizeimage < need) {
        return vd_capture_fail(cap, VD_ERR_FORMAT, "%s: driver image size %u is smaller than %ux%u needs", v->device,
                               (unsigned)p->sizeimage, (unsigned)p->width, (unsigned)p->height);
    }
    v->width = p->width;
    v->height = p->height;
    v->bytesperline = stride;
    v->need = need;
    v->format = bpp == 2u ? VD_PIX_U16 : VD_PIX_U8;
    return VD_OK;
}

static vd_status_t negotiate_fps(vd_capture_t *cap, v4l2_impl_t *v, uint32_t fps)
{
    struct v4l2_streamparm parm;
    memset(&parm, 0, sizeof(parm));
    parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    int e;
    if (fps != 0u) {
        parm.parm.capture.timeperframe.numerator = 1u;
        parm.parm.capture.timeperframe.denominator = fps;
        e = xioctl(v, VIDIOC_S_PARM, &parm);
    } else {
        e = xioctl(v, VIDIOC_G_PARM, &parm);
    }
    if (e == EINVAL || e == ENOTTY) {
        return VD_OK;   // the driver has no frame-rate control: keep its own rate
    }
    if (e != 0) {
        return vd_capture_fail(cap, errno_status(e), "%s: VIDIOC_%s_PARM failed: %s", v->device, fps != 0u ? "S" : "G",
                               strerror(e));
    }
    if ((parm.parm.capture.capability & V4L2_CAP_TIMEPERFRAME) != 0u &&
        parm.parm.capture.timeperframe.numerator != 0u) {
        // fps = den / num
        v->fps_num = parm.parm.capture.timeperframe.denominator;
        v->fps_den = parm.parm.capture.timeperframe.numerator;
    }
    return VD_OK;
}

static void release_buffers(v4l2_impl_t *v)
{
    for (uint32_t i = 0; i < v->n_bufs; i++) {
        if (v->bufs[i].addr != NULL) {
            (void)v->sys.munmap(v->sys.ctx, v->bufs[i].addr, v->bufs[i].length);
        }
        v->bufs[i].addr = NULL;
        v->bufs[i].length = 0u;
        v->bufs[i].state = BUF_IDLE;
    }
    if (v->n_bufs != 0u && !v->lost) {
        struct v4l2_requestbuffers req;
        memset(&req, 0, sizeof(req));
        req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        req.memory = V4L2_MEMORY_MMAP;
        req.count = 0u;
        (void)xioctl(v, VIDIOC_REQBUFS, &req);   // frees the driver's buffers; failure leaves nothing of ours
    }
    v->n_bufs = 0u;
}

static vd_status_t qbuf(v4l2_impl_t *v, uint32_t index, int *err)
{
    struct v4l2_buffer b;
    memset(&b, 0, sizeof(b));
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = index;
    int e = xioctl(v, VIDIOC_QBUF, &b);
    *err = e;
    if (e != 0) {
        v->bufs[index].state = BUF_IDLE;
        if (errno_is_gone(e)) {
            v->lost = true;
        }
        return errno_status(e);
    }
    v->bufs[index].state = BUF_QUEUED;
    return VD_OK;
}

static vd_status_t v4l2_start(vd_capture_t *cap)
{
    v4l2_impl_t *v = impl_of(cap);
    struct v4l2_requestbuffers req;
    memset(&req, 0, sizeof(req));
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    req.count = v->n_req;
    v->lost = false;
    v->have_seq = false;
    int e = xioctl(v, VIDIOC_REQBUFS, &req);
    if (e != 0) {
        if (errno_is_gone(e)) {
            v->lost = true;
        }
        return vd_capture_fail(cap, errno_status(e), "%s: VIDIOC_REQBUFS failed: %s", v->device, strerror(e));
    }
    if (req.count < 2u || req.count > VD_V4L2_MAX_BUFFERS) {
        v->n_bufs = req.count > VD_V4L2_MAX_BUFFERS ? VD_V4L2_MAX_BUFFERS : req.count;
        v->n_bufs = v->n_bufs == 0u ? 1u : v->n_bufs;   // makes release_buffers send REQBUFS 0
        release_buffers(v);
        return vd_capture_fail(cap, VD_ERR_IO, "%s: driver granted %u buffers (need 2..%u)", v->device,
                               (unsigned)req.count, (unsigned)VD_V4L2_MAX_BUFFERS);
    }
    v->n_bufs = req.count;
    vd_status_t st = VD_OK;
    for (uint32_t i = 0; i < v->n_bufs && st == VD_OK; i++) {
        struct v4l2_buffer b;
        memset(&b, 0, sizeof(b));
        b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.memory = V4L2_MEMORY_MMAP;
        b.index = i;
        e = xioctl(v, VIDIOC_QUERYBUF, &b);
        if (e != 0) {
            st = vd_capture_fail(cap, errno_status(e), "%s: VIDIOC_QUERYBUF %u failed: %s", v->device, (unsigned)i,
                                 strerror(e));
            break;
        }
        if ((size_t)b.length < v->need) {
            st = vd_capture_fail(cap, VD_ERR_IO, "%s: buffer %u has %u bytes, a frame needs %zu", v->device,
                                 (unsigned)i, (unsigned)b.length, v->need);
            break;
        }
        errno = 0;
        void *p = v->sys.mmap(v->sys.ctx, NULL, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, v->fd,
                              (int64_t)b.m.offset);
        if (p == MAP_FAILED || p == NULL) {
            e = errno != 0 ? errno : ENOMEM;
            st = vd_capture_fail(cap, errno_status(e), "%s: mmap of buffer %u failed: %s", v->device, (unsigned)i,
                                 strerror(e));
            break;
        }
        v->bufs[i].addr = p;
        v->bufs[i].length = b.length;
        v->bufs[i].state = BUF_IDLE;
    }
    for (uint32_t i = 0; i < v->n_bufs && st == VD_OK; i++) {
        if (qbuf(v, i, &e) != VD_OK) {
            st = vd_capture_fail(cap, errno_status(e), "%s: VIDIOC_QBUF %u failed: %s", v->device, (unsigned)i,
                                 strerror(e));
        }
    }
    if (st == VD_OK) {
        enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        e = xioctl(v, VIDIOC_STREAMON, &type);
        if (e != 0) {
            st = vd_capture_fail(cap, errno_status(e), "%s: VIDIOC_STREAMON failed: %s", v->device, strerror(e));
        }
    }
    if (st != VD_OK) {
        if (st == VD_ERR_NODEV) {
            v->lost = true;
        }
        release_buffers(v);
    }
    return st;
}

static int64_t now_ms(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) {
        return 0;
    }
    return (int64_t)ts.tv_sec * 1000 + (int64_t)(ts.tv_nsec / 1000000);
}

// Re-queues buffer i after a skipped frame; a failure is reported instead of `st`.
static vd_status_t requeue_skipped(vd_capture_t *cap, v4l2_impl_t *v, uint32_t i, vd_status_t st)
{
    int e;
    if (qbuf(v, i, &e) != VD_OK) {
        return vd_capture_fail(cap, errno_status(e), "%s: re-queueing buffer %u failed: %s", v->device, (unsigned)i,
                               strerror(e));
    }
    return st;
}

static vd_status_t v4l2_next(vd_capture_t *cap, int32_t timeout_ms, vd_frame_t *frame)
{
    v4l2_impl_t *v = impl_of(cap);
    if (v->lost) {
        return vd_capture_fail(cap, VD_ERR_NODEV, "%s: device lost; stop and start again or close", v->device);
    }
    int64_t deadline = timeout_ms >= 0 ? now_ms() + (int64_t)timeout_ms : 0;
    for (uint32_t attempt = 0; attempt <= VD_V4L2_MAX_RETRIES; attempt++) {
        if (attempt != 0u) {
            cap->counters.retries++;
        }
        int wait = -1;
        if (timeout_ms >= 0) {
            int64_t rem = deadline - now_ms();
            wait = rem <= 0 ? 0 : (rem > INT32_MAX ? INT32_MAX : (int)rem);
        }
        struct pollfd pfd;
        pfd.fd = v->fd;
        pfd.events = POLLIN;
        pfd.revents = 0;
        errno = 0;
        int r = v->sys.poll(v->sys.ctx, &pfd, 1u, wait);
        if (r < 0) {
            int e = errno != 0 ? errno : EIO;
            if (e == EINTR || e == EAGAIN) {
                continue;
            }
            return vd_capture_fail(cap, errno_status(e), "%s: poll failed: %s", v->device, strerror(e));
        }
        if (r == 0) {
            return vd_capture_fail(cap, VD_ERR_TIMEOUT, "%s: no frame within %d ms", v->device, (int)timeout_ms);
        }
        if ((pfd.revents & POLLNVAL) != 0) {
            return vd_capture_fail(cap, VD_ERR_IO, "%s: poll: descriptor not open", v->device);
        }
        struct v4l2_buffer b;
        memset(&b, 0, sizeof(b));
        b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.memory = V4L2_MEMORY_MMAP;
        errno = 0;
        if (v->sys.ioctl(v->sys.ctx, v->fd, VIDIOC_DQBUF, &b) != 0) {
            int e = errno != 0 ? errno : EIO;
            if (e == EAGAIN || e == EINTR) {
                continue;
            }
            if (errno_is_gone(e)) {
                v->lost = true;
                return vd_capture_fail(cap, VD_ERR_NODEV, "%s: device lost while streaming (%s)", v->device, strerror(e));
            }
            return vd_capture_fail(cap, VD_ERR_IO, "%s: VIDIOC_DQBUF failed: %s", v->device, strerror(e));
        }
        if (b.index >= v->n_bufs || v->bufs[b.index].state != BUF_QUEUED) {
            // Never trust the index: a buffer we did not queue may be in the caller's hands.
            cap->counters.bad_buffers++;
            return vd_capture_fail(cap, VD_ERR_IO, "%s: driver returned buffer %u which is not queued (%u buffers); skipped",
                                   v->device, (unsigned)b.index, (unsigned)v->n_bufs);
        }
        uint32_t i = b.index;
        v->bufs[i].state = BUF_IDLE;
        if (v->have_seq) {
            uint32_t gap = b.sequence - v->last_seq - 1u;   // modulo 2^32: wraps correctly
            if (b.sequence != v->last_seq && gap < 0x80000000u) {
                cap->counters.dropped += gap;
            }
        }
        v->have_seq = true;
        v->last_seq = b.sequence;
        if ((b.flags & V4L2_BUF_FLAG_ERROR) != 0u) {
            cap->counters.bad_buffers++;
            return requeue_skipped(cap, v, i,
                                   vd_capture_fail(cap, VD_ERR_IO, "%s: driver flagged frame %u as corrupt; skipped",
                                                   v->device, (unsigned)b.sequence));
        }
        if ((size_t)b.bytesused < v->need || (size_t)b.bytesused > v->bufs[i].length) {
            cap->counters.short_buffers++;
            return requeue_skipped(cap, v, i,
                                   vd_capture_fail(cap, VD_ERR_IO, "%s: frame %u has %u bytes, expected %zu; skipped",
                                                   v->device, (unsigned)b.sequence, (unsigned)b.bytesused, v->need));
        }
        v->bufs[i].state = BUF_USER;
        v->held = i;
        frame->data = v->bufs[i].addr;
        frame->width = v->width;
        frame->height = v->height;
        frame->stride = v->bytesperline;
        frame->format = v->format;
        frame->seq = b.sequence;
        frame->timestamp_us = (b.timestamp.tv_sec >= 0 && b.timestamp.tv_usec >= 0)
                                  ? (uint64_t)b.timestamp.tv_sec * 1000000u + (uint64_t)b.timestamp.tv_usec
                                  : 0u;
        return VD_OK;
    }
    return vd_capture_fail(cap, VD_ERR_AGAIN, "%s: no frame after %u EAGAIN/EINTR retries", v->device,
                           (unsigned)VD_V4L2_MAX_RETRIES);
}

static vd_status_t v4l2_release(vd_capture_t *cap, const vd_frame_t *frame)
{
    v4l2_impl_t *v = impl_of(cap);
    (void)frame;
    uint32_t i = v->held;
    if (i >= v->n_bufs || v->bufs[i].state != BUF_USER) {
        return vd_capture_fail(cap, VD_ERR_STATE, "%s: release: no buffer held", v->device);
    }
    int e;
    if (qbuf(v, i, &e) != VD_OK) {
        return vd_capture_fail(cap, errno_status(e), "%s: VIDIOC_QBUF %u failed: %s", v->device, (unsigned)i, strerror(e));
    }
    return VD_OK;
}

static vd_status_t v4l2_stop(vd_capture_t *cap)
{
    v4l2_impl_t *v = impl_of(cap);
    vd_status_t st = VD_OK;
    enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    int e = xioctl(v, VIDIOC_STREAMOFF, &type);
    if (e != 0 && !v->lost) {
        if (errno_is_gone(e)) {
            v->lost = true;
        }
        st = vd_capture_fail(cap, errno_status(e), "%s: VIDIOC_STREAMOFF failed: %s", v->device, strerror(e));
    }
    release_buffers(v);
    return st;
}

static void v4l2_close(vd_capture_t *cap)
{
    v4l2_impl_t *v = impl_of(cap);
    if (v == NULL) {
        return;
    }
    if (v->fd >= 0) {
        (void)v->sys.close(v->sys.ctx, v->fd);
    }
    free(v);
    cap->impl = NULL;
}

static const char *v4l2_frame_name(const vd_capture_t *cap)
{
    return impl_of(cap)->device;
}

static void v4l2_format(const vd_capture_t *cap, uint32_t *w, uint32_t *h, vd_pixfmt_t *f)
{
    const v4l2_impl_t *v = impl_of(cap);
    *w = v->width;
    *h = v->height;
    *f = v->format;
}

static const vd_capture_ops_t g_v4l2_ops = {
    "v4l2", v4l2_start, v4l2_next, v4l2_release, v4l2_stop, v4l2_close, v4l2_frame_name, v4l2_format
};

void vd_v4l2_get_fps(const vd_capture_t *cap, uint32_t *num, uint32_t *den)
{
    uint32_t n = 0u;
    uint32_t d = 0u;
    if (cap != NULL && cap->ops == &g_v4l2_ops && cap->impl != NULL) {
        n = impl_of(cap)->fps_num;
        d = impl_of(cap)->fps_den;
    }
    if (num != NULL) {
        *num = n;
    }
    if (den != NULL) {
        *den = d;
    }
}

vd_status_t vd_v4l2_open(vd_capture_t *cap, const vd_v4l2_cfg_t *cfg)
{
    if (cap == NULL) {
        return VD_ERR_ARG;
    }
    memset(cap, 0, sizeof(*cap));
    if (cfg == NULL || cfg->device == NULL) {
        return vd_capture_fail(cap, VD_ERR_ARG, "v4l2: no device given");
    }
    if ((cfg->width == 0u) != (cfg->height == 0u) || cfg->width > VD_MAX_DIM || cfg->height > VD_MAX_DIM) {
        return vd_capture_fail(cap, VD_ERR_ARG, "%s: requested size %ux%u invalid (both 0, or 1..%u)", cfg->device,
                               (unsigned)cfg->width, (unsigned)cfg->height, (unsigned)VD_MAX_DIM);
    }
    if (cfg->format != 0 && cfg->format != VD_PIX_U8 && cfg->format != VD_PIX_U16) {
        return vd_capture_fail(cap, VD_ERR_ARG, "%s: unknown pixel format %d", cfg->device, (int)cfg->format);
    }
    uint32_t n_req = cfg->n_buffers == 0u ? 4u : cfg->n_buffers;
    if (n_req < 2u || n_req > VD_V4L2_MAX_BUFFERS) {
        return vd_capture_fail(cap, VD_ERR_ARG, "%s: %u buffers requested (2..%u)", cfg->device, (unsigned)n_req,
                               (unsigned)VD_V4L2_MAX_BUFFERS);
    }
    if (strlen(cfg->device) >= sizeof(((v4l2_impl_t *)0)->device)) {
        return vd_capture_fail(cap, VD_ERR_ARG, "v4l2: device path too long");
    }
    const vd_v4l2_sys_t *sys = cfg->sys != NULL ? cfg->sys : vd_v4l2_sys_default();
    if (sys->open == NULL || sys->close == NULL || sys->ioctl == NULL || sys->mmap == NULL || sys->munmap == NULL ||
        sys->poll == NULL) {
        return vd_capture_fail(cap, VD_ERR_ARG, "%s: incomplete system-call table", cfg->device);
    }
    v4l2_impl_t *v = (v4l2_impl_t *)calloc(1u, sizeof(*v));
    if (v == NULL) {
        return vd_capture_fail(cap, VD_ERR_IO, "%s: out of memory", cfg->device);
    }
    v->sys = *sys;
    v->fd = -1;
    v->n_req = n_req;
    (void)snprintf(v->device, sizeof(v->device), "%s", cfg->device);

    vd_status_t st = VD_OK;
    errno = 0;
    v->fd = v->sys.open(v->sys.ctx, v->device, O_RDWR | O_NONBLOCK);
    if (v->fd < 0) {
        int e = errno != 0 ? errno : ENODEV;
        // libv4l2's open already queries the device: ENOTTY/EINVAL mean "not a V4L2 device".
        bool nodev = e == ENOENT || e == ENOTTY || e == EINVAL || errno_is_gone(e);
        st = vd_capture_fail(cap, nodev ? VD_ERR_NODEV : VD_ERR_IO, "%s: cannot open%s: %s", v->device,
                             (e == ENOTTY || e == EINVAL) ? " (not a V4L2 device)" : "", strerror(e));
    }
    if (st == VD_OK) {
        struct v4l2_capability qc;
        memset(&qc, 0, sizeof(qc));
        int e = xioctl(v, VIDIOC_QUERYCAP, &qc);
        if (e != 0) {
            st = vd_capture_fail(cap, (e == EINVAL || e == ENOTTY) ? VD_ERR_NODEV : errno_status(e),
                                 "%s: not a V4L2 device (VIDIOC_QUERYCAP: %s)", v->device, strerror(e));
        } else {
            uint32_t caps = (qc.capabilities & V4L2_CAP_DEVICE_CAPS) != 0u ? qc.device_caps : qc.capabilities;
            if ((caps & V4L2_CAP_VIDEO_CAPTURE) == 0u || (caps & V4L2_CAP_STREAMING) == 0u) {
                st = vd_capture_fail(cap, VD_ERR_NODEV, "%s: not a streaming video capture device (caps 0x%08x)",
                                     v->device, (unsigned)caps);
            }
        }
    }
    if (st == VD_OK) {
        st = negotiate_format(cap, v, cfg);
    }
    if (st == VD_OK) {
        st = negotiate_fps(cap, v, cfg->fps);
    }
    if (st != VD_OK) {
        if (v->fd >= 0) {
            (void)v->sys.close(v->sys.ctx, v->fd);
        }
        free(v);
        return st;
    }
    vd_capture_attach(cap, &g_v4l2_ops, v);
    return VD_OK;
}
