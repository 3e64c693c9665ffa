// SPDX-License-Identifier: MIT
// V4L2 back end against a fake device: negotiation, streaming, every scripted fault, stop/start, no leaks.
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE
#endif

#include "unity.h"
#include "fake_v4l2.h"
#include "vd_port/capture.h"
#include "vd_port/v4l2.h"

#include <errno.h>
#include <string.h>

#include <linux/videodev2.h>

static fake_dev_t g_dev;
static vd_v4l2_sys_t g_sys;
static vd_capture_t g_cap;

void setUp(void)
{
    fake_init(&g_dev);
    g_sys = fake_sys(&g_dev);
    memset(&g_cap, 0, sizeof(g_cap));
}

// Every test ends with the capture closed and the fake holding nothing of ours.
void tearDown(void)
{
    vd_capture_close(&g_cap);
    TEST_ASSERT_EQUAL_UINT32(0u, fake_mapped(&g_dev));
    TEST_ASSERT_FALSE(g_dev.is_open);
    TEST_ASSERT_EQUAL_UINT32(g_dev.n_mmap, g_dev.n_munmap);
    TEST_ASSERT_EQUAL_UINT32(0u, g_dev.double_qbuf);
    TEST_ASSERT_EQUAL_UINT32(0u, g_dev.busy_errors);
    fake_free(&g_dev);
}

static vd_v4l2_cfg_t cfg_of(uint32_t w, uint32_t h, vd_pixfmt_t fmt, uint32_t fps)
{
    vd_v4l2_cfg_t c;
    memset(&c, 0, sizeof(c));
    c.device = "/dev/fake0";
    c.width = w;
    c.height = h;
    c.format = fmt;
    c.fps = fps;
    c.n_buffers = 4u;
    c.sys = &g_sys;
    return c;
}

static void open_default(void)
{
    vd_v4l2_cfg_t c = cfg_of(160u, 120u, (vd_pixfmt_t)0, 30u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_v4l2_open(&g_cap, &c));
}

static void open_and_start(void)
{
    open_default();
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
}

// Takes one frame, checks it is a buffer the driver no longer holds, releases it.
static uint32_t take_frame(void)
{
    vd_frame_t f;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 100, &f));
    int idx = fake_index_of(&g_dev, f.data);
    TEST_ASSERT_TRUE(idx >= 0);
    TEST_ASSERT_FALSE_MESSAGE(g_dev.bufs[idx].queued, "handed out a buffer the driver still owns");
    TEST_ASSERT_EQUAL_HEX8((uint8_t)(f.seq & 0xFFu), ((const uint8_t *)f.data)[0]);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &f));
    return f.seq;
}

static void test_open_negotiates_y16_size_fps(void)
{
    open_default();
    uint32_t w, h, num, den;
    vd_pixfmt_t f;
    vd_capture_format(&g_cap, &w, &h, &f);
    TEST_ASSERT_EQUAL_UINT32(160u, w);
    TEST_ASSERT_EQUAL_UINT32(120u, h);
    TEST_ASSERT_EQUAL_INT(VD_PIX_U16, f);
    vd_v4l2_get_fps(&g_cap, &num, &den);
    TEST_ASSERT_EQUAL_UINT32(30u, num);
    TEST_ASSERT_EQUAL_UINT32(1u, den);
    TEST_ASSERT_EQUAL_UINT32(V4L2_PIX_FMT_Y16, g_dev.pixfmt);
    TEST_ASSERT_EQUAL_INT(VD_CAPTURE_OPEN, vd_capture_get_state(&g_cap));
    TEST_ASSERT_EQUAL_STRING("/dev/fake0", vd_capture_frame_name(&g_cap));
}

static void test_open_falls_back_to_grey(void)
{
    g_dev.formats[0] = V4L2_PIX_FMT_GREY;
    g_dev.n_formats = 1u;
    vd_v4l2_cfg_t c = cfg_of(0u, 0u, (vd_pixfmt_t)0, 0u);   // keep the driver's size and rate
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_v4l2_open(&g_cap, &c));
    uint32_t w, h, num, den;
    vd_pixfmt_t f;
    vd_capture_format(&g_cap, &w, &h, &f);
    TEST_ASSERT_EQUAL_INT(VD_PIX_U8, f);
    TEST_ASSERT_EQUAL_UINT32(160u, w);
    TEST_ASSERT_EQUAL_UINT32(120u, h);
    vd_v4l2_get_fps(&g_cap, &num, &den);
    TEST_ASSERT_EQUAL_UINT32(9u, num);   // the fake's own rate, read with G_PARM
    TEST_ASSERT_EQUAL_UINT32(1u, den);
}

static void test_driver_clamps_size_and_pads_rows(void)
{
    g_dev.pad = 6u;
    vd_v4l2_cfg_t c = cfg_of(1000u, 900u, VD_PIX_U16, 0u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_v4l2_open(&g_cap, &c));
    uint32_t w, h;
    vd_capture_format(&g_cap, &w, &h, NULL);
    TEST_ASSERT_EQUAL_UINT32(640u, w);
    TEST_ASSERT_EQUAL_UINT32(480u, h);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    vd_frame_t f;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 10, &f));
    TEST_ASSERT_EQUAL_size_t(640u * 2u + 6u, f.stride);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_frame_check(&f));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &f));
}

static void test_unsupported_format_is_rejected(void)
{
    g_dev.formats[0] = V4L2_PIX_FMT_YUYV;
    g_dev.n_formats = 1u;
    vd_v4l2_cfg_t c = cfg_of(160u, 120u, (vd_pixfmt_t)0, 0u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_v4l2_open(&g_cap, &c));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "YUYV"));
    TEST_ASSERT_EQUAL_INT(VD_CAPTURE_CLOSED, vd_capture_get_state(&g_cap));
    TEST_ASSERT_EQUAL_UINT32(1u, g_dev.n_close);   // nothing left open

    // Asking for Y16 from a GREY-only driver is also a format error.
    fake_init(&g_dev);
    g_dev.formats[0] = V4L2_PIX_FMT_GREY;
    g_dev.n_formats = 1u;
    c = cfg_of(160u, 120u, VD_PIX_U16, 0u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_FORMAT, vd_v4l2_open(&g_cap, &c));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "GREY"));
}

static void test_open_errors(void)
{
    vd_v4l2_cfg_t c = cfg_of(160u, 120u, (vd_pixfmt_t)0, 0u);
    g_dev.open_errno = ENOENT;
    TEST_ASSERT_EQUAL_INT(VD_ERR_NODEV, vd_v4l2_open(&g_cap, &c));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "/dev/fake0"));
    g_dev.open_errno = EACCES;
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_v4l2_open(&g_cap, &c));
    g_dev.open_errno = 0;
    g_dev.no_streaming = true;
    TEST_ASSERT_EQUAL_INT(VD_ERR_NODEV, vd_v4l2_open(&g_cap, &c));
    TEST_ASSERT_EQUAL_UINT32(g_dev.n_open, g_dev.n_close);
    g_dev.no_streaming = false;
    g_dev.no_timeperframe = true;   // no frame-rate control is not an error
    c.fps = 25u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_v4l2_open(&g_cap, &c));
    uint32_t num = 7u, den = 7u;
    vd_v4l2_get_fps(&g_cap, &num, &den);
    TEST_ASSERT_EQUAL_UINT32(0u, num);
    vd_capture_close(&g_cap);

    c = cfg_of(160u, 0u, (vd_pixfmt_t)0, 0u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_v4l2_open(&g_cap, &c));
    c = cfg_of(160u, 120u, (vd_pixfmt_t)7, 0u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_v4l2_open(&g_cap, &c));
    c = cfg_of(160u, 120u, (vd_pixfmt_t)0, 0u);
    c.n_buffers = 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_v4l2_open(&g_cap, &c));
    c.n_buffers = VD_V4L2_MAX_BUFFERS + 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_v4l2_open(&g_cap, &c));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_v4l2_open(&g_cap, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_v4l2_open(NULL, &c));
}

static void test_stream_frames_and_restart(void)
{
    open_and_start();
    TEST_ASSERT_EQUAL_UINT32(4u, g_dev.n_bufs);
    TEST_ASSERT_EQUAL_UINT32(4u, fake_mapped(&g_dev));
    vd_frame_t f;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 100, &f));
    TEST_ASSERT_EQUAL_UINT32(160u, f.width);
    TEST_ASSERT_EQUAL_UINT32(120u, f.height);
    TEST_ASSERT_EQUAL_size_t(320u, f.stride);
    TEST_ASSERT_EQUAL_INT(VD_PIX_U16, f.format);
    TEST_ASSERT_EQUAL_UINT32(0u, f.seq);
    TEST_ASSERT_EQUAL_UINT64(500u, f.timestamp_us);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &f));
    for (uint32_t i = 1; i < 10u; i++) {
        TEST_ASSERT_EQUAL_UINT32(i, take_frame());
    }
    TEST_ASSERT_EQUAL_UINT32(4u, fake_queued(&g_dev));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));
    TEST_ASSERT_EQUAL_UINT32(0u, fake_mapped(&g_dev));
    TEST_ASSERT_EQUAL_UINT32(1u, g_dev.n_streamoff);
    TEST_ASSERT_EQUAL_UINT32(1u, g_dev.n_reqbufs0);
    TEST_ASSERT_EQUAL_INT(VD_CAPTURE_OPEN, vd_capture_get_state(&g_cap));
    for (int round = 0; round < 3; round++) {
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
        for (int i = 0; i < 5; i++) {
            (void)take_frame();
        }
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));
        TEST_ASSERT_EQUAL_UINT32(0u, fake_mapped(&g_dev));
    }
    vd_capture_counters_t k;
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(25u, k.frames);
    TEST_ASSERT_EQUAL_UINT64(0u, k.dropped);
    TEST_ASSERT_EQUAL_UINT64(0u, k.errors);
    TEST_ASSERT_EQUAL_UINT32(4u, g_dev.n_streamon);
}

static void test_state_rules_never_hand_out_twice(void)
{
    vd_frame_t f, g;
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_capture_start(&g_cap));      // never opened
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_capture_next(&g_cap, 0, &f));
    open_default();
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_capture_next(&g_cap, 0, &f)); // not started
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));               // stop when open: no-op
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_capture_start(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_capture_release(&g_cap, &f)); // nothing held
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 10, &f));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_capture_next(&g_cap, 10, &g)); // still holding f
    g = f;
    g.data = (const uint8_t *)f.data + 2;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_capture_release(&g_cap, &g));    // not the frame handed out
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_capture_release(&g_cap, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_capture_next(&g_cap, 10, NULL));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &f));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_capture_release(&g_cap, &f)); // twice
    // 40 frames through 4 buffers: each one handed out was owned by us, never double-queued.
    for (int i = 0; i < 40; i++) {
        (void)take_frame();
    }
    // stop while holding a frame reclaims it
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 10, &f));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_capture_release(&g_cap, &f));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    (void)take_frame();
    vd_capture_close(&g_cap);
    vd_capture_close(&g_cap);   // twice is fine
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_capture_start(&g_cap));
    vd_capture_close(NULL);
    TEST_ASSERT_EQUAL_STRING("", vd_capture_error(NULL));
}

static void test_eagain_eintr_are_retried(void)
{
    open_and_start();
    fake_push(&g_dev, FK_POLL_EINTR, 0u);
    fake_push(&g_dev, FK_DQBUF_EAGAIN, 0u);
    fake_push(&g_dev, FK_DQBUF_EINTR, 0u);
    fake_push(&g_dev, FK_POLL_EINTR, 0u);
    fake_push(&g_dev, FK_DQBUF_EAGAIN, 0u);
    TEST_ASSERT_EQUAL_UINT32(0u, take_frame());
    vd_capture_counters_t k;
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(5u, k.retries);
    TEST_ASSERT_EQUAL_UINT64(1u, k.frames);
    TEST_ASSERT_EQUAL_UINT64(0u, k.errors);
}

static void test_retry_limit_gives_again(void)
{
    open_and_start();
    for (uint32_t i = 0; i < VD_V4L2_MAX_RETRIES + 4u; i++) {
        fake_push(&g_dev, FK_DQBUF_EAGAIN, 0u);
    }
    vd_frame_t f;
    TEST_ASSERT_EQUAL_INT(VD_ERR_AGAIN, vd_capture_next(&g_cap, 100, &f));
    TEST_ASSERT_NULL(f.data);
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "retries"));
    TEST_ASSERT_EQUAL_UINT32(VD_V4L2_MAX_RETRIES + 1u, g_dev.dqbufs);   // bounded
    TEST_ASSERT_EQUAL_UINT32(0u, take_frame());                         // usable afterwards
}

static void test_poll_timeout(void)
{
    open_and_start();
    fake_push(&g_dev, FK_POLL_TIMEOUT, 0u);
    vd_frame_t f;
    TEST_ASSERT_EQUAL_INT(VD_ERR_TIMEOUT, vd_capture_next(&g_cap, 5, &f));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "5 ms"));
    vd_capture_counters_t k;
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(1u, k.timeouts);
    TEST_ASSERT_EQUAL_UINT64(0u, k.errors);
    TEST_ASSERT_EQUAL_INT(VD_CAPTURE_STREAMING, vd_capture_get_state(&g_cap));
    TEST_ASSERT_EQUAL_UINT32(0u, take_frame());
}

static void test_enodev_mid_stream(void)
{
    open_and_start();
    (void)take_frame();
    (void)take_frame();
    fake_push(&g_dev, FK_DQBUF_ENODEV, 0u);
    vd_frame_t f;
    TEST_ASSERT_EQUAL_INT(VD_ERR_NODEV, vd_capture_next(&g_cap, 100, &f));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "lost"));
    TEST_ASSERT_EQUAL_INT(VD_ERR_NODEV, vd_capture_next(&g_cap, 100, &f));   // sticky
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));                  // cleans up despite the loss
    TEST_ASSERT_EQUAL_UINT32(0u, fake_mapped(&g_dev));
    TEST_ASSERT_EQUAL_INT(VD_ERR_NODEV, vd_capture_start(&g_cap));          // still gone
    TEST_ASSERT_EQUAL_INT(VD_CAPTURE_OPEN, vd_capture_get_state(&g_cap));
    vd_capture_counters_t k;
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(2u, k.frames);
    TEST_ASSERT_EQUAL_UINT64(2u, k.errors);
}

static void test_enodev_while_holding_then_close(void)
{
    open_and_start();
    vd_frame_t f;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 100, &f));
    g_dev.gone = true;   // unplugged while the caller holds a frame
    TEST_ASSERT_EQUAL_INT(VD_ERR_NODEV, vd_capture_release(&g_cap, &f));
    TEST_ASSERT_EQUAL_INT(VD_ERR_NODEV, vd_capture_next(&g_cap, 100, &f));
    // tearDown closes while streaming: every mapping released, fd closed.
}

static void test_unknown_index_is_not_handed_out(void)
{
    open_and_start();
    fake_push(&g_dev, FK_DQBUF_BAD_INDEX, 0u);
    vd_frame_t f;
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_next(&g_cap, 100, &f));
    TEST_ASSERT_NULL(f.data);
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "99"));
    vd_capture_counters_t k;
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(1u, k.bad_buffers);
    TEST_ASSERT_EQUAL_UINT32(0u, take_frame());
}

static void test_not_queued_index_is_not_handed_out(void)
{
    open_and_start();
    vd_frame_t f;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 100, &f));
    int held = fake_index_of(&g_dev, f.data);
    fake_push(&g_dev, FK_QBUF_EIO, 0u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_release(&g_cap, &f));   // buffer now owned by nobody
    TEST_ASSERT_FALSE(g_dev.bufs[held].queued);
    fake_push(&g_dev, FK_DQBUF_NOT_QUEUED, 0u);                         // driver returns it anyway
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_next(&g_cap, 100, &f));
    TEST_ASSERT_NULL(f.data);
    vd_capture_counters_t k;
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(1u, k.bad_buffers);
    // The three buffers still circulating keep working.
    for (int i = 0; i < 9; i++) {
        vd_frame_t g;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_next(&g_cap, 100, &g));
        TEST_ASSERT_TRUE(fake_index_of(&g_dev, g.data) != held);
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_release(&g_cap, &g));
    }
    // A stop/start cycle recovers all four.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    TEST_ASSERT_EQUAL_UINT32(4u, fake_queued(&g_dev));
}

static void test_short_and_corrupt_buffers_are_skipped_and_requeued(void)
{
    open_and_start();
    fake_push(&g_dev, FK_DQBUF_SHORT, 0u);
    vd_frame_t f;
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_next(&g_cap, 100, &f));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "bytes"));
    TEST_ASSERT_EQUAL_UINT32(4u, fake_queued(&g_dev));   // given back to the driver
    fake_push(&g_dev, FK_DQBUF_ERRFLAG, 0u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_next(&g_cap, 100, &f));
    TEST_ASSERT_EQUAL_UINT32(4u, fake_queued(&g_dev));
    fake_push(&g_dev, FK_DQBUF_EIO, 0u);
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_next(&g_cap, 100, &f));
    TEST_ASSERT_EQUAL_UINT32(2u, take_frame());
    vd_capture_counters_t k;
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(1u, k.short_buffers);
    TEST_ASSERT_EQUAL_UINT64(1u, k.bad_buffers);
    TEST_ASSERT_EQUAL_UINT64(3u, k.errors);
    TEST_ASSERT_EQUAL_UINT64(1u, k.frames);
    TEST_ASSERT_EQUAL_UINT64(0u, k.dropped);   // skipped frames are not counted as drops
}

static void test_sequence_gaps_count_drops(void)
{
    open_and_start();
    TEST_ASSERT_EQUAL_UINT32(0u, take_frame());
    fake_push(&g_dev, FK_SEQ_GAP, 3u);
    TEST_ASSERT_EQUAL_UINT32(4u, take_frame());
    TEST_ASSERT_EQUAL_UINT32(5u, take_frame());
    fake_push(&g_dev, FK_SEQ_GAP, 2u);
    TEST_ASSERT_EQUAL_UINT32(8u, take_frame());
    vd_capture_counters_t k;
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(5u, k.dropped);
    TEST_ASSERT_EQUAL_UINT64(4u, k.frames);
    // A restart begins a new sequence: no drop is counted across it.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));
    g_dev.seq = 1000u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    TEST_ASSERT_EQUAL_UINT32(1000u, take_frame());
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(5u, k.dropped);
    // Wrap-around of the 32-bit sequence counts correctly.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_stop(&g_cap));
    g_dev.seq = 0xFFFFFFFEu;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    (void)take_frame();
    fake_push(&g_dev, FK_SEQ_GAP, 2u);   // 0xFFFFFFFF and 0 lost
    TEST_ASSERT_EQUAL_UINT32(1u, take_frame());
    vd_capture_get_counters(&g_cap, &k);
    TEST_ASSERT_EQUAL_UINT64(7u, k.dropped);
}

static void test_too_few_buffers_then_recover(void)
{
    open_default();
    g_dev.grant = 1u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_IO, vd_capture_start(&g_cap));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "granted 1"));
    TEST_ASSERT_EQUAL_INT(VD_CAPTURE_OPEN, vd_capture_get_state(&g_cap));
    g_dev.grant = 0u;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_capture_start(&g_cap));
    (void)take_frame();
}

static void test_open_by_name_without_device(void)
{
    vd_capture_opts_t o;
    vd_capture_opts_default(&o);
    TEST_ASSERT_EQUAL_INT(VD_ERR_NODEV, vd_capture_open(&g_cap, "/dev/vd-no-such-video-device", &o));
    TEST_ASSERT_NOT_NULL(strstr(vd_capture_error(&g_cap), "/dev/vd-no-such-video-device"));
    TEST_ASSERT_EQUAL_INT(VD_ERR_NODEV, vd_capture_open(&g_cap, "/dev/null", NULL));   // not a V4L2 device
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_open_negotiates_y16_size_fps);
    RUN_TEST(test_open_falls_back_to_grey);
    RUN_TEST(test_driver_clamps_size_and_pads_rows);
    RUN_TEST(test_unsupported_format_is_rejected);
    RUN_TEST(test_open_errors);
    RUN_TEST(test_stream_frames_and_restart);
    RUN_TEST(test_state_rules_never_hand_out_twice);
    RUN_TEST(test_eagain_eintr_are_retried);
    RUN_TEST(test_retry_limit_gives_again);
    RUN_TEST(test_poll_timeout);
    RUN_TEST(test_enodev_mid_stream);
    RUN_TEST(test_enodev_while_holding_then_close);
    RUN_TEST(test_unknown_index_is_not_handed_out);
    RUN_TEST(test_not_queued_index_is_not_handed_out);
    RUN_TEST(test_short_and_corrupt_buffers_are_skipped_and_requeued);
    RUN_TEST(test_sequence_gaps_count_drops);
    RUN_TEST(test_too_few_buffers_then_recover);
    RUN_TEST(test_open_by_name_without_device);
    return UNITY_END();
}
