// SPDX-License-Identifier: MIT
// Test driver for the GStreamer element vdfir (docs/gstreamer.md), run by CTest:
//   test_gst_vdfir png8 OUTDIR INDIR N        first N images of INDIR (sorted) decoded by GStreamer
//                                            (decodebin, videoconvert to GRAY8) into OUTDIR/frame_NNNN.png
//   test_gst_vdfir raw16 OUTFILE INDIR W H   INDIR's 16-bit frames (vd_port's reader) as one raw
//                                            GRAY16_LE file of W x H frames
//   test_gst_vdfir counts16 OUTFILE INDIR W H  INDIR's 8-bit frames as a camera's raw counts, value x 64
//                                            + 1000, likewise (not radiometric: grey-window auto)
//   test_gst_vdfir invert8 OUTFILE INDIR W H [BLANK]  INDIR's 8-bit frames as a black-hot camera shows
//                                            them, 255 - value, as one raw GRAY8 file, after BLANK uniform
//                                            frames (value 110: a camera's shutter, a lens cap)
//   test_gst_vdfir compare JSONL PIPELINE    runs PIPELINE (with "vdfir name=det" and "fakesink
//                                            name=sink"); every buffer's ROI metas and every element
//                                            message must equal JSONL (vd_fir_demo --json) line by line
//   test_gst_vdfir error TEXT PIPELINE       PIPELINE must end with a GStreamer ERROR message (not
//                                            a crash, not EOS) whose text contains TEXT
//   test_gst_vdfir resolution R PIPELINE     PIPELINE (with vdfir) must post one "vdfir-resolution"
//                                            message choosing R (half, full or quarter; R,POL: and the
//                                            polarity POL, white-hot or black-hot) with the 32nd frame
//                                            (R,POL,SEQ,N: with frame SEQ after N measured), or none
//                                            (R = none), and a "vdfir" message per frame with seq 0, 1, ..
//                                            unbroken by the switch
// The frames are decoded once and then read losslessly by both the demo and the element:
// JPEG decoders differ (stb_image in the demo, libjpeg-turbo in jpegdec), PNG does not.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gst/gst.h>
#include <gst/video/video.h>
#include <glib/gstdio.h>

#include "flipagree.h"
#include "json.h"
#include "vd_port/capture.h"

#define MAX_DETS 4096

typedef struct det {
    int x, y, w, h;
    double score;
    long track;   // -1 = none
    char state[16];
    char source[16];
} det_t;

typedef struct frame_dets {
    det_t *d;
    size_t n;
    long msg_n;   // detections in the frame's element message (-1 = no message)
} frame_dets_t;

// Filled by the streaming thread (handoff: buffers in order) and the main thread (bus
// messages, by seq): every access holds lock.
typedef struct got {
    GMutex lock;
    frame_dets_t *f;
    size_t n, cap;
    size_t buffers;
    gboolean bad_meta;
    gboolean draw;          // vdfir's draw property: each box's corner must then be white
    size_t drawn_checked;   // boxes whose drawn corner was checked
    size_t not_drawn;       // ... and found not white
} got_t;

static int fail(const char *what)
{
    fprintf(stderr, "test_gst_vdfir: FAIL: %s\n", what);
    return 1;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

// Runs a pipeline to its end; returns the ERROR message (caller unrefs) or NULL at EOS.
// on_msg (may be NULL) sees every other message.
static GstMessage *run_pipeline(GstElement *pipe, void (*on_msg)(GstMessage *, void *), void *user)
{
    GstBus *bus = gst_element_get_bus(pipe);
    GstMessage *err = NULL;
    if (gst_element_set_state(pipe, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE) {
        // The element posted its ERROR before failing the state change: take it from the bus.
        err = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR);
        if (err == NULL) {
            err = gst_message_new_error(NULL, g_error_new_literal(GST_CORE_ERROR, GST_CORE_ERROR_STATE_CHANGE,
                                                                   "state change failed without an error message"),
                                        "");
        }
        gst_element_set_state(pipe, GST_STATE_NULL);
        gst_object_unref(bus);
        return err;
    }
    for (;;) {
        GstMessage *m = gst_bus_timed_pop(bus, 120 * GST_SECOND);
        if (m == NULL) {
            err = gst_message_new_error(NULL, g_error_new_literal(GST_CORE_ERROR, GST_CORE_ERROR_FAILED,
                                                                   "timeout: no EOS within 120 s"),
                                        "");
            break;
        }
        if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ERROR) {
            err = m;
            break;
        }
        if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_EOS) {
            gst_message_unref(m);
            break;
        }
        if (on_msg != NULL) {
            on_msg(m, user);
        }
        gst_message_unref(m);
    }
    gst_element_set_state(pipe, GST_STATE_NULL);
    gst_object_unref(bus);
    return err;
}

// gst_parse_launch returns a pipeline even when an element is missing; any error is fatal here.
static GstElement *parse(const char *desc)
{
    GError *e = NULL;
    GstElement *p = gst_parse_launch(desc, &e);
    if (e != NULL) {
        fprintf(stderr, "test_gst_vdfir: %s: %s\n", desc, e->message);
        g_error_free(e);
        if (p != NULL) {
            gst_object_unref(p);
        }
        return NULL;
    }
    return p;
}

static int print_error(GstMessage *m, const char *ctx)
{
    GError *e = NULL;
    gchar *dbg = NULL;
    gst_message_parse_error(m, &e, &dbg);
    fprintf(stderr, "test_gst_vdfir: %s: ERROR from %s: %s\n", ctx, GST_MESSAGE_SRC_NAME(m) ? GST_MESSAGE_SRC_NAME(m) : "?",
            e->message);
    g_error_free(e);
    g_free(dbg);
    return 1;
}

// --- png8 -------------------------------------------------------------------------
static int cmd_png8(const char *out_dir, const char *in_dir, long max)
{
    GDir *d = g_dir_open(in_dir, 0, NULL);
    if (d == NULL) {
        fprintf(stderr, "test_gst_vdfir: SKIP: no frames at %s\n", in_dir);
        return 77;
    }
    GPtrArray *names = g_ptr_array_new_with_free_func(g_free);
    const gchar *n;
    while ((n = g_dir_read_name(d)) != NULL) {
        if (g_str_has_suffix(n, ".jpg") || g_str_has_suffix(n, ".png") || g_str_has_suffix(n, ".jpeg")) {
            g_ptr_array_add(names, g_strdup(n));
        }
    }
    g_dir_close(d);
    qsort(names->pdata, names->len, sizeof(gpointer), cmp_str);
    g_mkdir_with_parents(out_dir, 0777);
    // Frames of an earlier run (e.g. a longer input) would join this sequence.
    GDir *od = g_dir_open(out_dir, 0, NULL);
    if (od != NULL) {
        while ((n = g_dir_read_name(od)) != NULL) {
            if (g_str_has_prefix(n, "frame_") && g_str_has_suffix(n, ".png")) {
                gchar *old = g_build_filename(out_dir, n, NULL);
                g_remove(old);
                g_free(old);
            }
        }
        g_dir_close(od);
    }
    int rc = 0;
    guint count = 0;
    for (guint i = 0; i < names->len && (max <= 0 || (long)i < max); i++) {
        gchar *in = g_build_filename(in_dir, g_ptr_array_index(names, i), NULL);
        gchar *out = g_strdup_printf("%s/frame_%04u.png", out_dir, i);
        gchar *desc = g_strdup_printf("filesrc location=\"%s\" ! decodebin ! videoconvert ! video/x-raw,format=GRAY8 "
                                      "! pngenc ! filesink location=\"%s\"",
                                      in, out);
        GstElement *p = parse(desc);
        if (p == NULL) {
            rc = 1;
        } else {
            GstMessage *m = run_pipeline(p, NULL, NULL);
            if (m != NULL) {
                rc = print_error(m, in);
                gst_message_unref(m);
            }
            gst_object_unref(p);
        }
        g_free(in);
        g_free(out);
        g_free(desc);
        if (rc != 0) {
            break;
        }
        count++;
    }
    g_ptr_array_free(names, TRUE);
    if (rc == 0 && count == 0) {
        fprintf(stderr, "test_gst_vdfir: SKIP: no images in %s\n", in_dir);
        return 77;
    }
    if (rc == 0) {
        printf("test_gst_vdfir: %u frames decoded into %s\n", count, out_dir);
    }
    return rc;
}

// --- raw16 ------------------------------------------------------------------------
// counts: INDIR holds 8-bit frames, written as value x 64 + 1000 (raw counts 1000..17320).
enum raw_mode { RAW_COPY16, RAW_COUNTS16, RAW_INVERT8 };

static int cmd_raw16(const char *out_path, const char *in_dir, uint32_t w, uint32_t h, enum raw_mode mode,
                     uint32_t blank)
{
    const bool counts = mode != RAW_COPY16;   // 8-bit frames in
    vd_capture_t cap;
    vd_capture_opts_t o;
    vd_capture_opts_default(&o);
    o.same_size = true;
    if (vd_capture_open(&cap, in_dir, &o) != VD_OK || vd_capture_start(&cap) != VD_OK) {
        fprintf(stderr, "test_gst_vdfir: SKIP: %s\n", vd_capture_error(&cap));
        vd_capture_close(&cap);
        return 77;
    }
    FILE *f = fopen(out_path, "wb");
    if (f == NULL) {
        vd_capture_close(&cap);
        return fail("cannot create the raw file");
    }
    int rc = 0;
    unsigned count = 0;
    uint16_t *row = malloc((size_t)w * 2u);
    if (row != NULL && blank > 0u) {   // (8-bit rows: invert8 only)
        memset(row, 110, w);
        for (uint64_t i = 0; i < (uint64_t)blank * h && rc == 0; i++) {
            rc = fwrite(row, 1u, w, f) == w ? 0 : 1;
        }
    }
    for (;;) {
        vd_frame_t fr;
        vd_status_t st = vd_capture_next(&cap, 0, &fr);
        if (st == VD_ERR_RANGE && vd_capture_at_end(&cap)) {
            break;
        }
        const vd_pixfmt_t want = counts ? VD_PIX_U8 : VD_PIX_U16;
        if (st != VD_OK || fr.format != want || fr.width != w || fr.height != h || row == NULL) {
            fprintf(stderr, "test_gst_vdfir: %s: not a %ux%u %s-bit frame\n", vd_capture_frame_name(&cap),
                    (unsigned)w, (unsigned)h, counts ? "8" : "16");
            if (st == VD_OK) {
                vd_capture_release(&cap, &fr);
            }
            rc = 1;
            break;
        }
        for (uint32_t y = 0; y < h; y++) {
            const uint8_t *line = (const uint8_t *)fr.data + (size_t)y * fr.stride;
            for (uint32_t x = 0; x < w; x++) {   // little-endian bytes whatever the host
                uint16_t v;
                if (mode == RAW_INVERT8) {
                    ((uint8_t *)row)[x] = (uint8_t)(255u - line[x]);
                    continue;
                }
                if (counts) {
                    v = (uint16_t)(line[x] * 64u + 1000u);
                } else {
                    memcpy(&v, line + 2u * x, 2);
                }
                uint8_t b[2] = {(uint8_t)(v & 0xffu), (uint8_t)(v >> 8)};
                memcpy(&row[x], b, 2);
            }
            if (fwrite(row, mode == RAW_INVERT8 ? 1u : 2u, w, f) != w) {
                rc = 1;
            }
        }
        vd_capture_release(&cap, &fr);
        count++;
    }
    free(row);
    vd_capture_close(&cap);
    if (fclose(f) != 0 || rc != 0 || count == 0) {
        return fail("raw16: no frames written");
    }
    printf("test_gst_vdfir: %u frames of %ux%u in %s\n", count, (unsigned)w, (unsigned)h, out_path);
    return 0;
}

// --- compare ----------------------------------------------------------------------
static frame_dets_t *frame_at(got_t *g, size_t i)
{
    while (g->n <= i) {
        if (g->n == g->cap) {
            g->cap = g->cap ? g->cap * 2 : 64;
            g->f = g_renew(frame_dets_t, g->f, g->cap);
        }
        g->f[g->n].d = NULL;
        g->f[g->n].n = 0;
        g->f[g->n].msg_n = -1;
        g->n++;
    }
    return &g->f[i];
}

static void read_fields(const GstStructure *s, det_t *d)
{
    double score = -1;
    guint track = 0;
    gst_structure_get_double(s, "score", &score);
    d->score = score;
    d->track = gst_structure_get_uint(s, "track-id", &track) ? (long)track : -1;
    const gchar *st = gst_structure_get_string(s, "state");
    const gchar *src = gst_structure_get_string(s, "source");
    snprintf(d->state, sizeof d->state, "%s", st ? st : "?");
    snprintf(d->source, sizeof d->source, "%s", src ? src : "?");
}

static void on_handoff(GstElement *sink, GstBuffer *buf, GstPad *pad, gpointer user)
{
    (void)sink;
    (void)pad;
    got_t *g = user;
    gpointer state = NULL;
    GstMeta *meta;
    size_t n = 0;
    gboolean bad = FALSE;
    det_t *d = g_new0(det_t, MAX_DETS);
    while ((meta = gst_buffer_iterate_meta_filtered(buf, &state, GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE)) !=
           NULL) {
        GstVideoRegionOfInterestMeta *roi = (GstVideoRegionOfInterestMeta *)meta;
        GstStructure *s = gst_video_region_of_interest_meta_get_param(roi, "vd-detection");
        if (roi->id < 0 || roi->id >= MAX_DETS || s == NULL ||
            g_quark_to_string(roi->roi_type) == NULL || strcmp(g_quark_to_string(roi->roi_type), "vehicle") != 0) {
            bad = TRUE;
            continue;
        }
        det_t *x = &d[roi->id];   // id = the detection's index in the demo's order
        x->x = (int)roi->x;
        x->y = (int)roi->y;
        x->w = (int)roi->w;
        x->h = (int)roi->h;
        read_fields(s, x);
        n++;
    }
    size_t checked = 0, missing = 0;
    GstCaps *caps = g->draw ? gst_pad_get_current_caps(pad) : NULL;
    GstVideoInfo info;
    GstVideoFrame vf;
    if (caps != NULL && gst_video_info_from_caps(&info, caps) && gst_video_frame_map(&vf, &info, buf, GST_MAP_READ)) {
        const guint8 *plane = GST_VIDEO_FRAME_PLANE_DATA(&vf, 0);
        const gsize stride = (gsize)GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 0);
        const gboolean wide = GST_VIDEO_INFO_COMP_DEPTH(&info, 0) > 8;
        for (size_t i = 0; i < MAX_DETS && checked < n; i++) {
            if (d[i].w <= 0 || d[i].h <= 0) {
                continue;
            }
            checked++;
            if (d[i].x < 0 || d[i].y < 0 || d[i].x >= GST_VIDEO_INFO_WIDTH(&info) ||
                d[i].y >= GST_VIDEO_INFO_HEIGHT(&info)) {
                missing++;   // a box outside the frame cannot have been drawn
                continue;
            }
            const guint8 *row = plane + (gsize)d[i].y * stride;
            guint v = wide ? ((const guint16 *)(const void *)row)[d[i].x] : row[d[i].x];
            missing += v != (wide ? 0xffffu : 0xffu);
        }
        gst_video_frame_unmap(&vf);
    }
    if (caps != NULL) {
        gst_caps_unref(caps);
    }
    g_mutex_lock(&g->lock);
    g->drawn_checked += checked;
    g->not_drawn += missing;
    frame_dets_t *f = frame_at(g, g->buffers++);
    g->bad_meta = g->bad_meta || bad;
    f->d = d;
    f->n = n;
    g_mutex_unlock(&g->lock);
}

static void on_message(GstMessage *m, void *user)
{
    got_t *g = user;
    const GstStructure *s = gst_message_get_structure(m);
    if (GST_MESSAGE_TYPE(m) != GST_MESSAGE_ELEMENT || s == NULL || !gst_structure_has_name(s, "vdfir")) {
        return;
    }
    guint64 seq = 0;
    const GValue *list = gst_structure_get_value(s, "detections");
    g_mutex_lock(&g->lock);
    if (!gst_structure_get_uint64(s, "seq", &seq) || list == NULL || !GST_VALUE_HOLDS_ARRAY(list)) {
        g->bad_meta = TRUE;
        g_mutex_unlock(&g->lock);
        return;
    }
    frame_at(g, (size_t)seq)->msg_n = (long)gst_value_array_get_size(list);
    g_mutex_unlock(&g->lock);
}

static int check_frame(const demo_json_t *doc, size_t line, const frame_dets_t *f)
{
    int64_t dets = demo_json_get(doc, 0, "detections");
    if (dets < 0) {
        return fail("demo JSON line without detections");
    }
    size_t n = doc->tok[dets].size;
    if (n != f->n || (long)n != f->msg_n) {
        fprintf(stderr, "test_gst_vdfir: FAIL: frame %zu: demo %zu detections, metas %zu, message %ld\n", line, n,
                f->n, f->msg_n);
        return 1;
    }
    size_t i = 0;
    // Siblings run past the array's end (json.c): iterate its count.
    for (int64_t e = demo_json_first(doc, (uint32_t)dets); i < n && e >= 0;
         e = demo_json_sibling(doc, (uint32_t)e), i++) {
        const det_t *x = &f->d[i];
        int64_t box = demo_json_get(doc, (uint32_t)e, "box");
        double b[4] = {0, 0, 0, 0}, score = -1, track = -1;
        int k = 0;
        for (int64_t v = box >= 0 ? demo_json_first(doc, (uint32_t)box) : -1; v >= 0 && k < 4;
             v = demo_json_sibling(doc, (uint32_t)v)) {
            demo_json_number(doc, v, &b[k++]);
        }
        demo_json_number(doc, demo_json_get(doc, (uint32_t)e, "score"), &score);
        int64_t t = demo_json_get(doc, (uint32_t)e, "track");
        if (t >= 0 && doc->tok[t].type == DEMO_JSON_NUMBER) {
            demo_json_number(doc, t, &track);
        }
        char state[16] = "", source[16] = "";
        demo_json_string(doc, demo_json_get(doc, (uint32_t)e, "state"), state, sizeof state);
        demo_json_string(doc, demo_json_get(doc, (uint32_t)e, "source"), source, sizeof source);
        // The demo prints the score with 3 decimals: equal within half a unit of the last digit.
        if (k != 4 || b[0] != x->x || b[1] != x->y || b[2] != x->w || b[3] != x->h || (long)track != x->track ||
            score < x->score - 0.0005 || score > x->score + 0.0005 || strcmp(state, x->state) != 0 ||
            strcmp(source, x->source) != 0) {
            fprintf(stderr,
                    "test_gst_vdfir: FAIL: frame %zu detection %zu: demo [%g %g %g %g] %.3f track %ld %s %s, "
                    "element [%d %d %d %d] %.3f track %ld %s %s\n",
                    line, i, b[0], b[1], b[2], b[3], score, (long)track, state, source, x->x, x->y, x->w, x->h,
                    x->score, x->track, x->state, x->source);
            return 1;
        }
    }
    return 0;
}

static int cmd_compare(const char *jsonl, const char *desc)
{
    char *text = NULL;
    size_t len = 0;
    char err[512];
    if (demo_read_file(jsonl, 256u * 1024u * 1024u, &text, &len, err, sizeof err) != VD_OK) {
        fprintf(stderr, "test_gst_vdfir: %s\n", err);
        return 1;
    }
    GstElement *pipe = parse(desc);
    if (pipe == NULL) {
        free(text);
        return 1;
    }
    got_t g;
    memset(&g, 0, sizeof g);
    g_mutex_init(&g.lock);
    GstElement *sink = gst_bin_get_by_name(GST_BIN(pipe), "sink");
    if (sink == NULL) {
        gst_object_unref(pipe);
        free(text);
        return fail("the pipeline needs fakesink name=sink");
    }
    g_object_set(sink, "signal-handoffs", TRUE, NULL);
    GstElement *det = gst_bin_get_by_name(GST_BIN(pipe), "det");
    if (det != NULL) {
        g_object_get(det, "draw", &g.draw, NULL);
        gst_object_unref(det);
    }
    g_signal_connect(sink, "handoff", G_CALLBACK(on_handoff), &g);
    GstMessage *m = run_pipeline(pipe, on_message, &g);
    gst_object_unref(sink);
    gst_object_unref(pipe);
    int rc = 0;
    if (m != NULL) {
        rc = print_error(m, "compare");
        gst_message_unref(m);
    }
    if (g.bad_meta) {
        rc = fail("a meta or message without the vd-detection fields");
    }
    // One JSON line per frame, in order.
    size_t line = 0, total = 0;
    char *p = text;
    while (rc == 0 && p < text + len && *p != '\0') {
        char *nl = strchr(p, '\n');
        size_t l = nl ? (size_t)(nl - p) : strlen(p);
        demo_json_t doc;
        memset(&doc, 0, sizeof doc);
        if (demo_json_parse(&doc, p, l, err, sizeof err) != VD_OK) {
            fprintf(stderr, "test_gst_vdfir: %s line %zu: %s\n", jsonl, line + 1, err);
            rc = 1;
            break;
        }
        if (line >= g.n) {
            fprintf(stderr, "test_gst_vdfir: FAIL: the demo has more frames than the %zu the element saw\n", g.n);
            rc = 1;
        } else {
            rc = check_frame(&doc, line, &g.f[line]);
            total += g.f[line].n;
        }
        demo_json_free(&doc);
        line++;
        p += l + (nl ? 1u : 0u);
    }
    if (rc == 0 && line != g.n) {
        fprintf(stderr, "test_gst_vdfir: FAIL: demo %zu frames, element %zu\n", line, g.n);
        rc = 1;
    }
    // An empty comparison proves nothing.
    if (rc == 0 && total == 0) {
        rc = fail("no detections on these frames: nothing was compared");
    }
    // draw=true: the boxes are in the pixels too.
    if (rc == 0 && g.draw && (g.not_drawn != 0 || g.drawn_checked != total)) {
        fprintf(stderr, "test_gst_vdfir: FAIL: draw=true but %zu of %zu box corners are not white (%zu checked)\n",
                g.not_drawn, total, g.drawn_checked);
        rc = 1;
    }
    if (rc == 0) {
        printf("test_gst_vdfir: %zu frames, %zu detections: metas and messages equal the demo's JSON Lines%s\n", line,
               total, g.draw ? "; every box drawn" : "");
    }
    for (size_t i = 0; i < g.n; i++) {
        g_free(g.f[i].d);
    }
    g_free(g.f);
    g_mutex_clear(&g.lock);
    free(text);
    return rc;
}

// --- resolution ---------------------------------------------------------------------
typedef struct res_got {
    int messages;        // vdfir-resolution messages
    gboolean full;
    char res[16];        // "resolution": half, full or quarter
    char polarity[16];   // "polarity": white-hot or black-hot
    double inv_rating[3];   // "rating-*-inverted" (-1: not measured or no box)
    double inv_score[3], inv_agree[3];
    guint frames;
    guint64 from_seq;
    double agree[3];     // [cfg.cnn_res]: half, full, quarter
    double score[3];     // mean box score
    double rating[3];    // what the choice compares: score + agreement / 4
    guint64 next_seq;    // the seq the next vdfir message must carry
    gboolean seq_broken;
} res_got_t;

static void on_res_message(GstMessage *m, void *user)
{
    res_got_t *g = user;
    const GstStructure *s = gst_message_get_structure(m);
    if (GST_MESSAGE_TYPE(m) != GST_MESSAGE_ELEMENT || s == NULL) {
        return;
    }
    if (gst_structure_has_name(s, "vdfir")) {
        guint64 seq = 0;
        g->seq_broken = g->seq_broken || !gst_structure_get_uint64(s, "seq", &seq) || seq != g->next_seq;
        g->next_seq++;
    } else if (gst_structure_has_name(s, "vdfir-resolution")) {
        g->messages++;
        const char *res = gst_structure_get_string(s, "resolution");
        const char *pol = gst_structure_get_string(s, "polarity");
        if (res != NULL) {
            snprintf(g->res, sizeof g->res, "%s", res);
        }
        if (pol != NULL) {
            snprintf(g->polarity, sizeof g->polarity, "%s", pol);
        }
        static const char *const res_names[3] = {"half", "full", "quarter"};
        for (int k = 0; k < 3; k++) {
            char rn[40], sn[40], an[40];
            snprintf(rn, sizeof rn, "rating-%s-inverted", res_names[k]);
            snprintf(sn, sizeof sn, "score-%s-inverted", res_names[k]);
            snprintf(an, sizeof an, "agreement-%s-inverted", res_names[k]);
            if (pol == NULL || !gst_structure_get_double(s, rn, &g->inv_rating[k]) ||
                !gst_structure_get_double(s, sn, &g->inv_score[k]) || !gst_structure_get_double(s, an, &g->inv_agree[k])) {
                g->messages = 100;
            }
        }
        if (res == NULL || !gst_structure_get_boolean(s, "full", &g->full) ||
            !gst_structure_get_uint(s, "frames", &g->frames) || !gst_structure_get_uint64(s, "from-seq", &g->from_seq) ||
            !gst_structure_get_double(s, "rating-half", &g->rating[0]) ||
            !gst_structure_get_double(s, "rating-full", &g->rating[1]) ||
            !gst_structure_get_double(s, "rating-quarter", &g->rating[2]) ||
            !gst_structure_get_double(s, "score-half", &g->score[0]) ||
            !gst_structure_get_double(s, "score-full", &g->score[1]) ||
            !gst_structure_get_double(s, "score-quarter", &g->score[2]) ||
            !gst_structure_get_double(s, "agreement-half", &g->agree[0]) ||
            !gst_structure_get_double(s, "agreement-full", &g->agree[1]) ||
            !gst_structure_get_double(s, "agreement-quarter", &g->agree[2])) {
            g->messages = 100;   // a message without its fields
        }
    }
}

static int cmd_resolution(const char *want_arg, const char *desc)
{
    static const char *const names[3] = {"half", "full", "quarter"};   // cfg.cnn_res order
    char want[32];
    snprintf(want, sizeof want, "%s", want_arg);
    char *want_pol = strchr(want, ',');   // R,POL: the polarity too (cnn-polarity auto)
    guint64 want_seq = 31u;               // R,POL,SEQ,N: the frame of the choice and the frames measured
    guint want_frames = 32u;
    if (want_pol != NULL) {
        *want_pol++ = '\0';
        char *rest = strchr(want_pol, ',');
        if (rest != NULL) {
            *rest++ = '\0';
            char *end = NULL;
            want_seq = g_ascii_strtoull(rest, &end, 10);
            if (end == NULL || *end != ',') {
                return fail("resolution: R,POL,SEQ,N");
            }
            want_frames = (guint)g_ascii_strtoull(end + 1, NULL, 10);
        }
    }
    const gboolean none = strcmp(want, "none") == 0;
    if (!none && strcmp(want, "half") != 0 && strcmp(want, "full") != 0 && strcmp(want, "quarter") != 0) {
        return fail("resolution: R must be half, full, quarter or none");
    }
    GstElement *pipe = parse(desc);
    if (pipe == NULL) {
        return 1;
    }
    res_got_t g;
    memset(&g, 0, sizeof g);
    // Element messages are delivered on the bus in posting order, so seq order is checked as they come.
    GstMessage *m = run_pipeline(pipe, on_res_message, &g);
    gst_object_unref(pipe);
    if (m != NULL) {
        const int rc = print_error(m, "resolution");
        gst_message_unref(m);
        return rc;
    }
    printf("test_gst_vdfir: %" G_GUINT64_FORMAT " frames; %d resolution message(s): %s from frame %" G_GUINT64_FORMAT
           ", %u frames measured, mean box score half %.3f, full %.3f, quarter %.3f, flip agreement half %.3f, full "
           "%.3f, quarter %.3f\n", g.next_seq, g.messages, g.res, g.from_seq, g.frames, g.score[0], g.score[1],
           g.score[2], g.agree[0], g.agree[1], g.agree[2]);
    if (g.seq_broken) {
        return fail("the per-frame messages' seq is not 0, 1, 2, .. (the switch must not restart it)");
    }
    if (none) {
        return g.messages == 0 ? 0 : fail("a resolution message where none was expected");
    }
    if (g.messages != 1) {
        return fail("not exactly one resolution message with its fields");
    }
    if (g.frames != want_frames || g.from_seq != want_seq || g.next_seq <= g.from_seq) {
        return fail("the choice must come with the expected frame (the 32nd, seq 31, unless given) after the "
                    "expected frames measured, before the stream ends");
    }
    for (int k = 0; k < 6; k++) {
        const double agree = k < 3 ? g.agree[k] : g.inv_agree[k - 3], score = k < 3 ? g.score[k] : g.inv_score[k - 3];
        if (!(agree == -1.0 || (agree >= 0.0 && agree <= 1.0))) {
            return fail("an agreement outside [0, 1] (or -1: no box or not measured)");
        }
        const gboolean no_box = score == -1.0;
        if (!(no_box || (score > 0.0 && score <= 1.0)) || no_box != (agree == -1.0)) {
            return fail("a mean box score outside (0, 1] (or -1: no box, as the agreement)");
        }
        // the rating is mean box score + agreement / 4 (flipagree.c demo_autores_rating)
        const double expect = no_box ? -1.0 : score + agree / 4.0, rating = k < 3 ? g.rating[k] : g.inv_rating[k - 3];
        if (rating < expect - 1e-12 || rating > expect + 1e-12) {
            return fail("a rating other than mean box score + agreement / 4");
        }
    }
    // the choice (flipagree.c demo_autores_decide): the highest rating of each polarity, ties to the lower
    // cfg.cnn_res, no box rates 0; the inverted frames' when theirs is higher by more than the margin
    int best = 0, best_inv = 0;
    for (int k = 1; k < 3; k++) {
        best = g.rating[k] > (g.rating[best] > 0.0 ? g.rating[best] : 0.0) ? k : best;
        best_inv = g.inv_rating[k] > (g.inv_rating[best_inv] > 0.0 ? g.inv_rating[best_inv] : 0.0) ? k : best_inv;
    }
    const double as_is = g.rating[best] > 0.0 ? g.rating[best] : 0.0;
    const double other = g.inv_rating[best_inv] > 0.0 ? g.inv_rating[best_inv] : 0.0;
    const gboolean measured_inv = g.inv_score[0] != -1.0 || g.inv_score[1] != -1.0 || g.inv_score[2] != -1.0;
    const gboolean inverted = measured_inv && other > as_is + DEMO_AUTORES_INVERT_MARGIN;
    printf("test_gst_vdfir: %s; inverted rating half %.3f, full %.3f, quarter %.3f\n", g.polarity, g.inv_rating[0],
           g.inv_rating[1], g.inv_rating[2]);
    const int pick = inverted ? best_inv : best;
    if (strcmp(g.res, names[pick]) != 0 || g.full != (pick == 1) ||
        (measured_inv && strcmp(g.polarity, inverted ? "black-hot" : "white-hot") != 0)) {
        return fail("the choice does not follow the ratings");
    }
    if (want_pol != NULL && strcmp(g.polarity, want_pol) != 0) {
        return fail("the element chose another polarity");
    }
    return strcmp(g.res, want) == 0 ? 0 : fail("the element chose another resolution");
}

// --- error ------------------------------------------------------------------------
static int cmd_error(const char *want, const char *desc)
{
    GstElement *pipe = parse(desc);
    if (pipe == NULL) {
        return 1;
    }
    GstMessage *m = run_pipeline(pipe, NULL, NULL);
    gst_object_unref(pipe);
    if (m == NULL) {
        return fail("the pipeline reached EOS: no ERROR message");
    }
    GError *ge = NULL;
    gchar *dbg = NULL;
    gst_message_parse_error(m, &ge, &dbg);
    gchar *all = g_strdup_printf("%s: %s | %s", GST_MESSAGE_SRC_NAME(m) ? GST_MESSAGE_SRC_NAME(m) : "?",
                                 ge->message, dbg ? dbg : "");
    int rc = strstr(all, want) != NULL ? 0 : 1;
    printf("test_gst_vdfir: ERROR message: %s\n", all);
    if (rc != 0) {
        fprintf(stderr, "test_gst_vdfir: FAIL: the error does not mention '%s'\n", want);
    }
    g_free(all);
    g_free(dbg);
    g_error_free(ge);
    gst_message_unref(m);
    return rc;
}

int main(int argc, char **argv)
{
    gst_init(&argc, &argv);
    if (argc == 5 && strcmp(argv[1], "png8") == 0) {
        return cmd_png8(argv[2], argv[3], strtol(argv[4], NULL, 10));
    }
    if (argc == 6 && strcmp(argv[1], "raw16") == 0) {
        return cmd_raw16(argv[2], argv[3], (uint32_t)strtoul(argv[4], NULL, 10), (uint32_t)strtoul(argv[5], NULL, 10),
                         RAW_COPY16, 0u);
    }
    if (argc == 6 && strcmp(argv[1], "counts16") == 0) {
        return cmd_raw16(argv[2], argv[3], (uint32_t)strtoul(argv[4], NULL, 10), (uint32_t)strtoul(argv[5], NULL, 10),
                         RAW_COUNTS16, 0u);
    }
    if ((argc == 6 || argc == 7) && strcmp(argv[1], "invert8") == 0) {
        return cmd_raw16(argv[2], argv[3], (uint32_t)strtoul(argv[4], NULL, 10), (uint32_t)strtoul(argv[5], NULL, 10),
                         RAW_INVERT8, argc == 7 ? (uint32_t)strtoul(argv[6], NULL, 10) : 0u);
    }
    if (argc == 4 && strcmp(argv[1], "compare") == 0) {
        return cmd_compare(argv[2], argv[3]);
    }
    if (argc == 4 && strcmp(argv[1], "error") == 0) {
        return cmd_error(argv[2], argv[3]);
    }
    if (argc == 4 && strcmp(argv[1], "resolution") == 0) {
        return cmd_resolution(argv[2], argv[3]);
    }
    fprintf(stderr, "usage: test_gst_vdfir png8 OUTDIR INDIR N | raw16|counts16 OUTFILE INDIR W H | compare JSONL PIPELINE | "
                    "error TEXT PIPELINE | resolution half|full|none PIPELINE\n");
    return 2;
}
