// SPDX-License-Identifier: MIT
// A fake V4L2 capture device behind vd_v4l2_sys_t, with scripted faults, for tests without hardware.
#ifndef VD_TEST_FAKE_V4L2_H
#define VD_TEST_FAKE_V4L2_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "vd_port/v4l2.h"

#define FAKE_MAX_BUFS 8u
#define FAKE_MAX_SCRIPT 64u
#define FAKE_FD 42

// A scripted fault. Poll faults are taken by the next poll() call, DQBUF/QBUF faults by the next
// such ioctl, when the fault is at the head of the script.
typedef enum fake_fault {
    FK_NONE = 0,
    FK_POLL_TIMEOUT,     // poll returns 0
    FK_POLL_EINTR,       // poll fails with EINTR
    FK_DQBUF_EAGAIN,     // DQBUF fails with EAGAIN
    FK_DQBUF_EINTR,      // DQBUF fails with EINTR
    FK_DQBUF_ENODEV,     // device unplugged: this and every later call fails with ENODEV
    FK_DQBUF_EIO,        // DQBUF fails with EIO
    FK_DQBUF_BAD_INDEX,  // DQBUF returns index 99 (no buffer popped)
    FK_DQBUF_NOT_QUEUED, // DQBUF returns the index of a buffer that is not queued (no buffer popped)
    FK_DQBUF_SHORT,      // DQBUF returns a frame with bytesused = sizeimage / 2
    FK_DQBUF_ERRFLAG,    // DQBUF returns a frame with V4L2_BUF_FLAG_ERROR
    FK_SEQ_GAP,          // the next DQBUF skips `arg` sequence numbers (frames dropped by the driver)
    FK_QBUF_EIO          // the next QBUF fails with EIO
} fake_fault_t;

typedef struct fake_step {
    fake_fault_t fault;
    uint32_t arg;
} fake_step_t;

typedef struct fake_buf {
    uint8_t *mem;
    size_t len;
    bool mapped;
    bool queued;
} fake_buf_t;

typedef struct fake_dev {
    // --- configuration (set before open) ---
    uint32_t formats[4];       // pixel formats the driver takes (fourcc); others are replaced by formats[0]
    uint32_t n_formats;
    uint32_t max_w, max_h;     // the driver clamps sizes to these
    uint32_t pad;              // extra bytes per row (bytesperline = width * bpp + pad)
    int open_errno;            // open fails with this errno when non-zero
    bool no_streaming;         // QUERYCAP without V4L2_CAP_STREAMING
    bool no_timeperframe;      // S_PARM/G_PARM fail with EINVAL
    uint32_t grant;            // REQBUFS grants this many buffers (0 = min(request, FAKE_MAX_BUFS))
    // --- script ---
    fake_step_t script[FAKE_MAX_SCRIPT];
    size_t n_script;
    size_t pos;
    // --- state ---
    bool is_open;
    bool gone;
    bool streaming;
    uint32_t width, height, pixfmt, bytesperline, sizeimage;
    uint32_t fps_den, fps_num;
    fake_buf_t bufs[FAKE_MAX_BUFS];
    uint32_t n_bufs;
    uint32_t fifo[FAKE_MAX_BUFS];
    uint32_t fifo_n;
    uint32_t seq;
    uint32_t pending_gap;
    // --- statistics ---
    uint32_t n_open, n_close, n_mmap, n_munmap, n_streamon, n_streamoff, n_reqbufs0;
    uint32_t double_qbuf;      // QBUF of a buffer already queued (a capture bug)
    uint32_t busy_errors;      // REQBUFS/S_FMT refused with EBUSY (a capture bug)
    uint32_t polls, dqbufs;
} fake_dev_t;

// Resets *dev to a 160x120 device taking Y16 and GREY, max 640x480, no faults.
void fake_init(fake_dev_t *dev);
// Appends a fault step to the script.
void fake_push(fake_dev_t *dev, fake_fault_t f, uint32_t arg);
// A system-call table whose ctx is dev.
vd_v4l2_sys_t fake_sys(fake_dev_t *dev);
// Buffers currently mapped (must be 0 after stop/close).
uint32_t fake_mapped(const fake_dev_t *dev);
// Buffers currently queued.
uint32_t fake_queued(const fake_dev_t *dev);
// Index of the buffer whose memory is at p, or -1.
int fake_index_of(const fake_dev_t *dev, const void *p);
// Frees the fake's buffer memory.
void fake_free(fake_dev_t *dev);

#endif
