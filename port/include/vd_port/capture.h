// SPDX-License-Identifier: MIT
// One capture interface for every frame source (V4L2 camera, recorded files): open, start, next, release, stop, close.
#ifndef VD_PORT_CAPTURE_H
#define VD_PORT_CAPTURE_H

// Usage (host code; a port is the only place that talks to the OS):
//
//     vd_capture_t cap;                       // caller owns the object (may be static)
//     vd_capture_opts_t opts;
//     vd_capture_opts_default(&opts);
//     if (vd_capture_open(&cap, "/dev/video0", &opts) != VD_OK) { puts(vd_capture_error(&cap)); ... }
//     vd_capture_start(&cap);
//     for (;;) {
//         vd_frame_t f;
//         vd_status_t st = vd_capture_next(&cap, 1000, &f);
//         if (st == VD_ERR_RANGE && vd_capture_at_end(&cap)) break;   // recorded sequence finished
//         if (st != VD_OK) { ...report vd_capture_error(&cap); decide (see below)... continue; }
//         ...use f (a zero-copy view) and vd_capture_frame_name(&cap)...
//         vd_capture_release(&cap, &f);       // f.data is invalid from here on
//     }
//     vd_capture_stop(&cap);                  // optional: close() stops too
//     vd_capture_close(&cap);                 // frees everything; safe after a failed open
//
// States: CLOSED --open--> OPEN --start--> STREAMING (--next--> HOLDING --release--> STREAMING)
//         --stop--> OPEN --start--> ... ; close from any state. One frame is held at a time:
//         next() while holding gives VD_ERR_STATE, so a buffer is never handed out twice.
// Recoverable errors of next(): VD_ERR_TIMEOUT, VD_ERR_AGAIN, VD_ERR_IO (one bad buffer or
// one bad file: it was skipped), VD_ERR_FORMAT (one bad file, skipped). Fatal: VD_ERR_NODEV
// (device gone: stop + close, or stop + start to try again). End of a recording:
// VD_ERR_RANGE with vd_capture_at_end() true.

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "vd/image.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

// Length of the last-error text buffer, including the NUL.
#define VD_CAPTURE_ERROR_LEN 320u

// Event counters since open (never reset by stop/start).
typedef struct vd_capture_counters {
    uint64_t frames;        // frames handed out by next()
    uint64_t dropped;       // frames lost, from gaps in the source sequence numbers
    uint64_t retries;       // EAGAIN / EINTR retries inside next() (poll or DQBUF)
    uint64_t timeouts;      // next() calls that ended in VD_ERR_TIMEOUT
    uint64_t short_buffers; // buffers with fewer bytes than the negotiated frame (skipped, re-queued)
    uint64_t bad_buffers;   // buffers the driver returned with an unknown or not-queued index, or the error flag
    uint64_t errors;        // next() calls that failed with any status but VD_ERR_TIMEOUT and end-of-recording
} vd_capture_counters_t;

typedef struct vd_capture vd_capture_t;

// A back end: a table of functions implemented once per source. The generic
// layer (vd_capture_*) checks states and arguments before calling them, so a
// back end may assume: start only when OPEN, next only when STREAMING and no
// frame held, release only with the frame it handed out, stop only when
// STREAMING (a held frame is reclaimed by stop), close exactly once.
// Each returns a status and, on failure, sets the error text with
// vd_capture_fail(). See docs/porting.md.
typedef struct vd_capture_ops {
    const char *name;                                                         // "v4l2", "file", ...
    vd_status_t (*start)(vd_capture_t *cap);
    vd_status_t (*next)(vd_capture_t *cap, int32_t timeout_ms, vd_frame_t *frame);
    vd_status_t (*release)(vd_capture_t *cap, const vd_frame_t *frame);
    vd_status_t (*stop)(vd_capture_t *cap);
    void (*close)(vd_capture_t *cap);                                          // free impl
    const char *(*frame_name)(const vd_capture_t *cap);                        // may be NULL
    void (*format)(const vd_capture_t *cap, uint32_t *w, uint32_t *h, vd_pixfmt_t *fmt); // may be NULL
} vd_capture_ops_t;

typedef enum vd_capture_state {
    VD_CAPTURE_CLOSED = 0,
    VD_CAPTURE_OPEN = 1,
    VD_CAPTURE_STREAMING = 2,
    VD_CAPTURE_HOLDING = 3
} vd_capture_state_t;

// The capture object. The caller owns it (static, stack or heap); the back
// end's private state (`impl`) is allocated by open and freed by close. Read
// the fields only through the functions below.
struct vd_capture {
    const vd_capture_ops_t *ops;   // NULL when closed
    void *impl;                    // back-end state, owned by the port
    vd_capture_state_t state;
    bool at_end;                   // a recorded source has no more frames
    const void *held;              // data pointer of the frame held by the caller
    vd_capture_counters_t counters;
    char error[VD_CAPTURE_ERROR_LEN];
};

// Options of vd_capture_open(); vd_capture_opts_default() fills the defaults.
typedef struct vd_capture_opts {
    // V4L2 (a path starting with "/dev/"):
    uint32_t width;          // requested size; 0 = keep the driver's current size
    uint32_t height;
    uint32_t fps;            // requested frame rate; 0 = keep the driver's
    vd_pixfmt_t format;      // VD_PIX_U8 (GREY), VD_PIX_U16 (Y16), 0 = Y16 if offered else GREY
    uint32_t n_buffers;      // mmap buffers to request; 0 = 4
    // Raw files (".raw", ".y16", ".gray", ".bin", or any file not recognised as an image):
    uint32_t raw_width;      // frame size of raw files; 0 = raw files are rejected
    uint32_t raw_height;
    vd_pixfmt_t raw_format;  // VD_PIX_U16 (default; Y16 little-endian) or VD_PIX_U8
    bool raw_big_endian;     // raw 16-bit samples are big-endian
    // Recorded sequences:
    bool same_size;          // every frame must have the first frame's size and format (VD_ERR_FORMAT otherwise)
} vd_capture_opts_t;

// Fills *opts with the defaults above. NULL is ignored.
void vd_capture_opts_default(vd_capture_opts_t *opts);

// Opens a source by name:
//   "/dev/..."      V4L2 device (vd_v4l2_open, real system calls), unless it is a regular file or directory
//   a directory     every *.pgm *.png *.jpg *.jpeg *.raw *.y16 *.gray file in it, sorted by name (strcmp)
//   "*.txt", "*.lst" a list file: one path per line (relative to the list's directory); '#' comments and blank lines skipped
//   any other file  one image (PGM P5 8/16-bit, PNG 8/16-bit, JPEG) or one raw file (one or more frames)
// `cap` is always initialised, so vd_capture_error() and vd_capture_close() are valid afterwards
// even on failure. opts NULL = defaults.
// Returns VD_OK (state OPEN); VD_ERR_ARG (cap or input NULL, bad option); VD_ERR_IO (missing or
// unreadable path, empty directory or list); VD_ERR_FORMAT (unsupported format, malformed list);
// VD_ERR_NODEV (no such device or not a capture device); VD_ERR_OVERFLOW (size arithmetic).
vd_status_t vd_capture_open(vd_capture_t *cap, const char *input, const vd_capture_opts_t *opts);

// Starts streaming (V4L2: REQBUFS, QUERYBUF, mmap, QBUF, STREAMON; files: rewinds to the first frame).
// Returns VD_OK; VD_ERR_ARG (cap NULL); VD_ERR_STATE (not OPEN); a back-end status
// (VD_ERR_IO, VD_ERR_NODEV, ...) with the error text set, leaving the capture OPEN.
vd_status_t vd_capture_start(vd_capture_t *cap);

// Waits at most timeout_ms milliseconds (< 0: forever; recorded files never wait) for the next
// frame and fills *frame with a zero-copy view on the port's buffer, valid until
// vd_capture_release(), vd_capture_stop() or vd_capture_close(). frame->seq is the source's
// sequence number (files: the index in the sequence), frame->timestamp_us its time stamp.
// Returns VD_OK (state HOLDING); VD_ERR_ARG (NULL pointer); VD_ERR_STATE (not streaming, or a
// frame is still held); VD_ERR_TIMEOUT (no frame in time); VD_ERR_AGAIN (EAGAIN/EINTR retry limit
// reached); VD_ERR_IO (a short/bad buffer or unreadable file was skipped; call again);
// VD_ERR_FORMAT (a malformed or unsupported file was skipped, or a size change with same_size);
// VD_ERR_NODEV (device lost; every later next() returns it too); VD_ERR_RANGE (end of a recording,
// vd_capture_at_end() is true). Every failure sets the error text and a counter.
vd_status_t vd_capture_next(vd_capture_t *cap, int32_t timeout_ms, vd_frame_t *frame);

// Gives the held frame back to the port (V4L2: QBUF). frame must be the one next() filled in.
// Returns VD_OK (state STREAMING); VD_ERR_ARG (NULL, or not the held frame); VD_ERR_STATE (no
// frame held); VD_ERR_NODEV / VD_ERR_IO (re-queueing failed; the frame is released anyway).
vd_status_t vd_capture_release(vd_capture_t *cap, const vd_frame_t *frame);

// Stops streaming and returns every buffer (V4L2: STREAMOFF, munmap, REQBUFS 0). A held frame
// becomes invalid. Stopping an OPEN capture is a no-op. The capture is OPEN afterwards even when
// the device is gone, so start() may be tried again.
// Returns VD_OK; VD_ERR_ARG (cap NULL); VD_ERR_STATE (closed); VD_ERR_IO/VD_ERR_NODEV (STREAMOFF
// failed; the buffers are released anyway).
vd_status_t vd_capture_stop(vd_capture_t *cap);

// Stops if needed, releases every resource (fds, mappings, memory) and marks the capture CLOSED.
// Safe on a closed, never-opened (zeroed) or failed-open capture, and on NULL.
void vd_capture_close(vd_capture_t *cap);

// The last error text (English, one line, names the file/device and the cause); "" if none.
// Never NULL (NULL cap gives "").
const char *vd_capture_error(const vd_capture_t *cap);

// Copies the counters into *out (zeros for NULL cap). out must not be NULL.
void vd_capture_get_counters(const vd_capture_t *cap, vd_capture_counters_t *out);

// Name of the frame last handed out by next(): the file path for files ("path#k" for frame k of a
// multi-frame raw file), the device path for V4L2. Valid until the next next()/close().
// Never NULL ("" when unknown).
const char *vd_capture_frame_name(const vd_capture_t *cap);

// True when a recorded source has handed out all its frames (next() then returns VD_ERR_RANGE);
// false again after stop() or start().
bool vd_capture_at_end(const vd_capture_t *cap);

// The negotiated frame size and format (V4L2 after open; files: the last frame read, 0 before).
// Any output pointer may be NULL.
void vd_capture_format(const vd_capture_t *cap, uint32_t *width, uint32_t *height, vd_pixfmt_t *format);

// Current state (VD_CAPTURE_CLOSED for NULL).
vd_capture_state_t vd_capture_get_state(const vd_capture_t *cap);

// For back ends: sets the error text (printf format) and returns st, so a back end writes
// `return vd_capture_fail(cap, VD_ERR_IO, "cannot open %s: %s", path, strerror(errno));`.
vd_status_t vd_capture_fail(vd_capture_t *cap, vd_status_t st, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

// For back ends: initialises cap (zeroed, state OPEN, error "") with ops and impl.
void vd_capture_attach(vd_capture_t *cap, const vd_capture_ops_t *ops, void *impl);

#ifdef __cplusplus
}
#endif
#endif
