// SPDX-License-Identifier: MIT
// V4L2 capture back end (GREY / Y16, mmap streaming) with an injectable system-call table.
#ifndef VD_PORT_V4L2_H
#define VD_PORT_V4L2_H

#include <poll.h>
#include <stdint.h>
#include <stddef.h>

#include "vd_port/capture.h"

#ifdef __cplusplus
extern "C" {
#endif

// Every system call the back end makes goes through this table, so tests can
// put a fake device behind it. Each function behaves like its POSIX/libv4l2
// namesake (returns -1 / MAP_FAILED and sets errno on failure) and gets `ctx`
// as its first argument.
typedef struct vd_v4l2_sys {
    void *ctx;
    int (*open)(void *ctx, const char *path, int flags);
    int (*close)(void *ctx, int fd);
    int (*ioctl)(void *ctx, int fd, unsigned long request, void *arg);
    void *(*mmap)(void *ctx, void *addr, size_t length, int prot, int flags, int fd, int64_t offset);
    int (*munmap)(void *ctx, void *addr, size_t length);
    int (*poll)(void *ctx, struct pollfd *fds, nfds_t nfds, int timeout_ms);
} vd_v4l2_sys_t;

// The default table: libv4l2 (v4l2_open, v4l2_ioctl, v4l2_mmap, ...) when built with
// VD_WITH_V4L2, else the plain system calls; poll() in both cases. Static storage.
const vd_v4l2_sys_t *vd_v4l2_sys_default(void);

// Most EAGAIN/EINTR retries inside one next() call before it gives VD_ERR_AGAIN.
#define VD_V4L2_MAX_RETRIES 16u
// Most mmap buffers.
#define VD_V4L2_MAX_BUFFERS 32u

typedef struct vd_v4l2_cfg {
    const char *device;      // e.g. "/dev/video0"; copied
    uint32_t width;          // 0 = keep the driver's current size (both must be 0 or both set)
    uint32_t height;
    uint32_t fps;            // 0 = keep the driver's frame rate
    vd_pixfmt_t format;      // VD_PIX_U8 = GREY, VD_PIX_U16 = Y16, 0 = Y16 if the driver takes it, else GREY
    uint32_t n_buffers;      // 0 = 4; 2..VD_V4L2_MAX_BUFFERS
    const vd_v4l2_sys_t *sys; // NULL = vd_v4l2_sys_default(); must outlive the capture
} vd_v4l2_cfg_t;

// Opens the device (O_RDWR | O_NONBLOCK), checks VIDIOC_QUERYCAP (video capture + streaming),
// negotiates the format with VIDIOC_S_FMT (the driver may change the size: read it back with
// vd_capture_format) and the frame rate with VIDIOC_S_PARM (ignored if the driver cannot).
// Buffers are requested by vd_capture_start(), so stop/start cycles re-negotiate nothing.
// Returns VD_OK (state OPEN); VD_ERR_ARG (NULL, device NULL, width xor height 0, n_buffers
// out of range, format other than 0/U8/U16); VD_ERR_NODEV (no such device, or not a
// streaming capture device); VD_ERR_IO (open or ioctl failed otherwise); VD_ERR_FORMAT (the
// driver does not deliver GREY/Y16, or its size/stride is unusable, or Y16 on a big-endian host).
// On failure the error text is set and nothing is left open.
vd_status_t vd_v4l2_open(vd_capture_t *cap, const vd_v4l2_cfg_t *cfg);

// The frame rate the driver reported after S_PARM as a fraction (0/0 if unknown).
void vd_v4l2_get_fps(const vd_capture_t *cap, uint32_t *num, uint32_t *den);

#ifdef __cplusplus
}
#endif
#endif
