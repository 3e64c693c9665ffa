// SPDX-License-Identifier: MIT
// A fake V4L2 capture device: the ioctls vd's back end uses, mmap'd buffers in heap memory, scripted faults.
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE
#endif

#include "fake_v4l2.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include <linux/videodev2.h>

#define FAKE_OFFSET_STEP 0x10000u

void fake_init(fake_dev_t *dev)
{
    memset(dev, 0, sizeof(*dev));
    dev->formats[0] = V4L2_PIX_FMT_Y16;
    dev->formats[1] = V4L2_PIX_FMT_GREY;
    dev->n_formats = 2u;
    dev->max_w = 640u;
    dev->max_h = 480u;
    dev->width = 160u;
    dev->height = 120u;
    dev->pixfmt = V4L2_PIX_FMT_Y16;
    dev->bytesperline = 320u;
    dev->sizeimage = 320u * 120u;
}

void fake_push(fake_dev_t *dev, fake_fault_t f, uint32_t arg)
{
    if (dev->n_script < FAKE_MAX_SCRIPT) {
        dev->script[dev->n_script].fault = f;
        dev->script[dev->n_script].arg = arg;
        dev->n_script++;
    }
}

static fake_fault_t take(fake_dev_t *dev, bool (*match)(fake_fault_t), uint32_t *arg)
{
    if (dev->pos < dev->n_script && match(dev->script[dev->pos].fault)) {
        *arg = dev->script[dev->pos].arg;
        return dev->script[dev->pos++].fault;
    }
    return FK_NONE;
}

static bool is_poll_fault(fake_fault_t f)
{
    return f == FK_POLL_TIMEOUT || f == FK_POLL_EINTR;
}

static bool is_dqbuf_fault(fake_fault_t f)
{
    return f >= FK_DQBUF_EAGAIN && f <= FK_SEQ_GAP;
}

static bool is_qbuf_fault(fake_fault_t f)
{
    return f == FK_QBUF_EIO;
}

static uint32_t bpp_of(uint32_t fourcc)
{
    return fourcc == V4L2_PIX_FMT_GREY ? 1u : 2u;
}

static void free_bufs(fake_dev_t *dev)
{
    for (uint32_t i = 0; i < dev->n_bufs; i++) {
        free(dev->bufs[i].mem);
        memset(&dev->bufs[i], 0, sizeof(dev->bufs[i]));
    }
    dev->n_bufs = 0u;
    dev->fifo_n = 0u;
}

void fake_free(fake_dev_t *dev)
{
    free_bufs(dev);
}

static int fail(int e)
{
    errno = e;
    return -1;
}

static int f_open(void *ctx, const char *path, int flags)
{
    fake_dev_t *dev = (fake_dev_t *)ctx;
    (void)path;
    (void)flags;
    if (dev->open_errno != 0) {
        return fail(dev->open_errno);
    }
    dev->is_open = true;
    dev->n_open++;
    return FAKE_FD;
}

static int f_close(void *ctx, int fd)
{
    fake_dev_t *dev = (fake_dev_t *)ctx;
    if (fd != FAKE_FD || !dev->is_open) {
        return fail(EBADF);
    }
    dev->is_open = false;
    dev->n_close++;
    return 0;
}

static void fill_frame(fake_dev_t *dev, uint32_t i, uint32_t seq)
{
    // Each frame is filled with its sequence number (low byte) so tests can tell frames apart.
    memset(dev->bufs[i].mem, (int)(seq & 0xFFu), dev->bufs[i].len);
}

static int do_dqbuf(fake_dev_t *dev, struct v4l2_buffer *b)
{
    uint32_t arg = 0u;
    fake_fault_t f = take(dev, is_dqbuf_fault, &arg);
    dev->dqbufs++;
    switch (f) {
    case FK_DQBUF_EAGAIN:
        return fail(EAGAIN);
    case FK_DQBUF_EINTR:
        return fail(EINTR);
    case FK_DQBUF_EIO:
        return fail(EIO);
    case FK_DQBUF_ENODEV:
        dev->gone = true;
        return fail(ENODEV);
    case FK_DQBUF_BAD_INDEX:
        b->index = 99u;
        b->bytesused = dev->sizeimage;
        b->sequence = dev->seq;
        return 0;
    case FK_DQBUF_NOT_QUEUED:
        for (uint32_t i = 0; i < dev->n_bufs; i++) {
            if (!dev->bufs[i].queued) {
                b->index = i;
                b->bytesused = dev->sizeimage;
                b->sequence = dev->seq;
                return 0;
            }
        }
        return fail(EIO);
    case FK_SEQ_GAP:
        dev->seq += arg;
        break;
    default:
        break;
    }
    if (!dev->streaming) {
        return fail(EINVAL);
    }
    if (dev->fifo_n == 0u) {
        return fail(EAGAIN);
    }
    uint32_t i = dev->fifo[0];
    memmove(dev->fifo, dev->fifo + 1, (dev->fifo_n - 1u) * sizeof(dev->fifo[0]));
    dev->fifo_n--;
    dev->bufs[i].queued = false;
    uint32_t seq = dev->seq++;
    fill_frame(dev, i, seq);
    b->index = i;
    b->bytesused = f == FK_DQBUF_SHORT ? dev->sizeimage / 2u : dev->sizeimage;
    b->flags = f == FK_DQBUF_ERRFLAG ? V4L2_BUF_FLAG_ERROR : 0u;
    b->sequence = seq;
    b->timestamp.tv_sec = (long)seq;
    b->timestamp.tv_usec = 500;
    b->length = (uint32_t)dev->bufs[i].len;
    return 0;
}

static int f_ioctl(void *ctx, int fd, unsigned long req, void *arg)
{
    fake_dev_t *dev = (fake_dev_t *)ctx;
    if (fd != FAKE_FD || !dev->is_open) {
        return fail(EBADF);
    }
    if (dev->gone) {
        return fail(ENODEV);
    }
    if (req == VIDIOC_QUERYCAP) {
        struct v4l2_capability *c = (struct v4l2_capability *)arg;
        memset(c, 0, sizeof(*c));
        memcpy(c->driver, "fake", 5);
        c->device_caps = V4L2_CAP_VIDEO_CAPTURE | (dev->no_streaming ? 0u : V4L2_CAP_STREAMING);
        c->capabilities = c->device_caps | V4L2_CAP_DEVICE_CAPS;
        return 0;
    }
    if (req == VIDIOC_G_FMT || req == VIDIOC_S_FMT) {
        struct v4l2_format *fmt = (struct v4l2_format *)arg;
        if (fmt->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) {
            return fail(EINVAL);
        }
        if (req == VIDIOC_S_FMT) {
            if (dev->n_bufs != 0u || dev->streaming) {
                dev->busy_errors++;
                return fail(EBUSY);
            }
            uint32_t pf = dev->formats[0];
            for (uint32_t k = 0; k < dev->n_formats; k++) {
                if (dev->formats[k] == fmt->fmt.pix.pixelformat) {
                    pf = dev->formats[k];
                }
            }
            uint32_t w = fmt->fmt.pix.width == 0u ? 1u : fmt->fmt.pix.width;
            uint32_t h = fmt->fmt.pix.height == 0u ? 1u : fmt->fmt.pix.height;
            dev->width = w > dev->max_w ? dev->max_w : w;
            dev->height = h > dev->max_h ? dev->max_h : h;
            dev->pixfmt = pf;
            dev->bytesperline = dev->width * bpp_of(pf) + dev->pad;
            dev->sizeimage = dev->bytesperline * dev->height;
        }
        memset(&fmt->fmt.pix, 0, sizeof(fmt->fmt.pix));
        fmt->fmt.pix.width = dev->width;
        fmt->fmt.pix.height = dev->height;
        fmt->fmt.pix.pixelformat = dev->pixfmt;
        fmt->fmt.pix.field = V4L2_FIELD_NONE;
        fmt->fmt.pix.bytesperline = dev->bytesperline;
        fmt->fmt.pix.sizeimage = dev->sizeimage;
        return 0;
    }
    if (req == VIDIOC_S_PARM || req == VIDIOC_G_PARM) {
        struct v4l2_streamparm *p = (struct v4l2_streamparm *)arg;
        if (dev->no_timeperframe) {
            return fail(EINVAL);
        }
        if (req == VIDIOC_S_PARM && p->parm.capture.timeperframe.numerator != 0u) {
            dev->fps_num = p->parm.capture.timeperframe.numerator;
            dev->fps_den = p->parm.capture.timeperframe.denominator;
        }
        memset(&p->parm, 0, sizeof(p->parm));
        p->parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
        p->parm.capture.timeperframe.numerator = dev->fps_num != 0u ? dev->fps_num : 1u;
        p->parm.capture.timeperframe.denominator = dev->fps_num != 0u ? dev->fps_den : 9u;
        return 0;
    }
    if (req == VIDIOC_REQBUFS) {
        struct v4l2_requestbuffers *r = (struct v4l2_requestbuffers *)arg;
        if (r->memory != V4L2_MEMORY_MMAP || r->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) {
            return fail(EINVAL);
        }
        if (dev->streaming || fake_mapped(dev) != 0u) {
            dev->busy_errors++;
            return fail(EBUSY);
        }
        free_bufs(dev);
        if (r->count == 0u) {
            dev->n_reqbufs0++;
            return 0;
        }
        uint32_t n = dev->grant != 0u ? dev->grant : (r->count > FAKE_MAX_BUFS ? FAKE_MAX_BUFS : r->count);
        uint32_t alloc = n > FAKE_MAX_BUFS ? FAKE_MAX_BUFS : n;
        for (uint32_t i = 0; i < alloc; i++) {
            dev->bufs[i].mem = (uint8_t *)calloc(1u, dev->sizeimage);
            dev->bufs[i].len = dev->sizeimage;
        }
        dev->n_bufs = alloc;
        r->count = n;
        return 0;
    }
    if (req == VIDIOC_QUERYBUF) {
        struct v4l2_buffer *b = (struct v4l2_buffer *)arg;
        if (b->index >= dev->n_bufs) {
            return fail(EINVAL);
        }
        b->length = (uint32_t)dev->bufs[b->index].len;
        b->m.offset = b->index * FAKE_OFFSET_STEP;
        return 0;
    }
    if (req == VIDIOC_QBUF) {
        struct v4l2_buffer *b = (struct v4l2_buffer *)arg;
        uint32_t a = 0u;
        if (take(dev, is_qbuf_fault, &a) == FK_QBUF_EIO) {
            return fail(EIO);
        }
        if (b->index >= dev->n_bufs) {
            return fail(EINVAL);
        }
        if (dev->bufs[b->index].queued) {
            dev->double_qbuf++;
            return fail(EINVAL);
        }
        dev->bufs[b->index].queued = true;
        dev->fifo[dev->fifo_n++] = b->index;
        return 0;
    }
    if (req == VIDIOC_DQBUF) {
        return do_dqbuf(dev, (struct v4l2_buffer *)arg);
    }
    if (req == VIDIOC_STREAMON) {
        if (dev->n_bufs == 0u) {
            return fail(EINVAL);
        }
        dev->streaming = true;
        dev->n_streamon++;
        return 0;
    }
    if (req == VIDIOC_STREAMOFF) {
        dev->streaming = false;
        for (uint32_t i = 0; i < dev->n_bufs; i++) {
            dev->bufs[i].queued = false;
        }
        dev->fifo_n = 0u;
        dev->n_streamoff++;
        return 0;
    }
    return fail(ENOTTY);
}

static void *f_mmap(void *ctx, void *addr, size_t length, int prot, int flags, int fd, int64_t offset)
{
    fake_dev_t *dev = (fake_dev_t *)ctx;
    (void)addr;
    (void)prot;
    (void)flags;
    if (fd != FAKE_FD || dev->gone) {
        errno = dev->gone ? ENODEV : EBADF;
        return MAP_FAILED;
    }
    uint64_t i = (uint64_t)offset / FAKE_OFFSET_STEP;
    if (i >= dev->n_bufs || length != dev->bufs[i].len || dev->bufs[i].mapped) {
        errno = EINVAL;
        return MAP_FAILED;
    }
    dev->bufs[i].mapped = true;
    dev->n_mmap++;
    return dev->bufs[i].mem;
}

static int f_munmap(void *ctx, void *addr, size_t length)
{
    fake_dev_t *dev = (fake_dev_t *)ctx;
    for (uint32_t i = 0; i < dev->n_bufs; i++) {
        if (dev->bufs[i].mem == addr && dev->bufs[i].mapped && dev->bufs[i].len == length) {
            dev->bufs[i].mapped = false;
            dev->n_munmap++;
            return 0;
        }
    }
    return fail(EINVAL);
}

static int f_poll(void *ctx, struct pollfd *fds, nfds_t nfds, int timeout_ms)
{
    fake_dev_t *dev = (fake_dev_t *)ctx;
    uint32_t arg = 0u;
    (void)timeout_ms;
    dev->polls++;
    if (nfds != 1u || fds[0].fd != FAKE_FD) {
        return fail(EINVAL);
    }
    fake_fault_t f = take(dev, is_poll_fault, &arg);
    if (f == FK_POLL_TIMEOUT) {
        return 0;
    }
    if (f == FK_POLL_EINTR) {
        return fail(EINTR);
    }
    if (dev->gone) {
        fds[0].revents = POLLERR | POLLHUP;
        return 1;
    }
    // A scripted DQBUF fault makes the fd readable so the fault is reached.
    bool dq_fault = dev->pos < dev->n_script && is_dqbuf_fault(dev->script[dev->pos].fault);
    if (dev->streaming && (dev->fifo_n != 0u || dq_fault)) {
        fds[0].revents = POLLIN;
        return 1;
    }
    return 0;   // nothing would arrive: report the timeout at once
}

vd_v4l2_sys_t fake_sys(fake_dev_t *dev)
{
    vd_v4l2_sys_t s;
    s.ctx = dev;
    s.open = f_open;
    s.close = f_close;
    s.ioctl = f_ioctl;
    s.mmap = f_mmap;
    s.munmap = f_munmap;
    s.poll = f_poll;
    return s;
}

uint32_t fake_mapped(const fake_dev_t *dev)
{
    uint32_t n = 0u;
    for (uint32_t i = 0; i < dev->n_bufs; i++) {
        n += dev->bufs[i].mapped ? 1u : 0u;
    }
    return n;
}

uint32_t fake_queued(const fake_dev_t *dev)
{
    uint32_t n = 0u;
    for (uint32_t i = 0; i < dev->n_bufs; i++) {
        n += dev->bufs[i].queued ? 1u : 0u;
    }
    return n;
}

int fake_index_of(const fake_dev_t *dev, const void *p)
{
    for (uint32_t i = 0; i < dev->n_bufs; i++) {
        if (dev->bufs[i].mem == p) {
            return (int)i;
        }
    }
    return -1;
}
