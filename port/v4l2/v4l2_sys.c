// SPDX-License-Identifier: MIT
// Default system-call table of the V4L2 back end: libv4l2 when available, else the plain calls.
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE
#endif

#include "vd_port/v4l2.h"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#if defined(VD_PORT_HAVE_LIBV4L2)
#include <libv4l2.h>
#endif

static int sys_open(void *ctx, const char *path, int flags)
{
    (void)ctx;
#if defined(VD_PORT_HAVE_LIBV4L2)
    return v4l2_open(path, flags);
#else
    return open(path, flags);
#endif
}

static int sys_close(void *ctx, int fd)
{
    (void)ctx;
#if defined(VD_PORT_HAVE_LIBV4L2)
    return v4l2_close(fd);
#else
    return close(fd);
#endif
}

static int sys_ioctl(void *ctx, int fd, unsigned long request, void *arg)
{
    (void)ctx;
#if defined(VD_PORT_HAVE_LIBV4L2)
    return v4l2_ioctl(fd, request, arg);
#else
    return ioctl(fd, request, arg);
#endif
}

static void *sys_mmap(void *ctx, void *addr, size_t length, int prot, int flags, int fd, int64_t offset)
{
    (void)ctx;
#if defined(VD_PORT_HAVE_LIBV4L2)
    return v4l2_mmap(addr, length, prot, flags, fd, offset);
#else
    return mmap(addr, length, prot, flags, fd, (off_t)offset);
#endif
}

static int sys_munmap(void *ctx, void *addr, size_t length)
{
    (void)ctx;
#if defined(VD_PORT_HAVE_LIBV4L2)
    return v4l2_munmap(addr, length);
#else
    return munmap(addr, length);
#endif
}

static int sys_poll(void *ctx, struct pollfd *fds, nfds_t nfds, int timeout_ms)
{
    (void)ctx;
    return poll(fds, nfds, timeout_ms);
}

static const vd_v4l2_sys_t g_default_sys = {
    NULL, sys_open, sys_close, sys_ioctl, sys_mmap, sys_munmap, sys_poll
};

const vd_v4l2_sys_t *vd_v4l2_sys_default(void)
{
    return &g_default_sys;
}
