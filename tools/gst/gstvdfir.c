// SPDX-License-Identifier: MIT
// GStreamer element "vdfir": runs the vd detector in place on each video frame
// (GRAY8, GRAY16_LE, or the luma plane of planar/semi-planar YUV), attaches one
// GstVideoRegionOfInterestMeta ("vehicle") per detection and posts one element
// message per frame. Options, model resolution and detector settings are
// vd_fir_demo's own (the library vd_demo_common, tools/demo/common: args.c,
// models.c), so the element and the demo give the same detections on the same
// frames. docs/gstreamer.md.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gst/gst.h>
#include <gst/video/video.h>
#include <gst/video/gstvideofilter.h>

#include "args.h"
#include "flipagree.h"
#include "models.h"
#include "vd/vd.h"

#ifndef VD_DEMO_MODELS_DIR
#define VD_DEMO_MODELS_DIR "models"
#endif
#ifndef VD_GST_VERSION
#define VD_GST_VERSION "0.1.0"
#endif

GST_DEBUG_CATEGORY_STATIC(vdfir_debug);
#define GST_CAT_DEFAULT vdfir_debug

#define GST_TYPE_VDFIR (gst_vdfir_get_type())
G_DECLARE_FINAL_TYPE(GstVdFir, gst_vdfir, GST, VDFIR, GstVideoFilter)

struct _GstVdFir {
    GstVideoFilter parent;
    // properties (changed in NULL/READY only: the options point into them)
    gchar *model;
    gchar *config;
    gchar *sources;
    gboolean draw;
    // resolved at start()
    demo_opts_t opts;
    demo_models_t models;
    gboolean loaded;
    // made at set_info() for the negotiated size
    vd_detector_t det;
    void *ws;
    gboolean det_ready;
    vd_detection_t *dets;
    size_t dets_cap;
    guint32 width, height;
    guint64 seq;
    // --cnn-full-res auto (the demo's default): the first frames of a size measured as they pass
    demo_autores_live_t ar;
};

enum { PROP_0, PROP_MODEL, PROP_CONFIG, PROP_DRAW, PROP_SOURCES };

// 16-bit frames are read as the host's uint16 (vd's U16): GRAY16_LE on little-endian hosts
// (GRAY16_BE on big-endian ones); videoconvert swaps bytes where needed.
#if G_BYTE_ORDER == G_LITTLE_ENDIAN
#define VDFIR_GRAY16 "GRAY16_LE"
#define VDFIR_GRAY16_FORMAT GST_VIDEO_FORMAT_GRAY16_LE
#else
#define VDFIR_GRAY16 "GRAY16_BE"
#define VDFIR_GRAY16_FORMAT GST_VIDEO_FORMAT_GRAY16_BE
#endif
#define VDFIR_FORMATS "{ GRAY8, " VDFIR_GRAY16 ", I420, YV12, NV12, NV21, Y41B, Y42B, Y444 }"

G_DEFINE_TYPE(GstVdFir, gst_vdfir, GST_TYPE_VIDEO_FILTER)

static uint32_t clock_us(void *user)
{
    (void)user;
    return (uint32_t)(g_get_monotonic_time() & 0xffffffffu);
}

static void free_detector(GstVdFir *self)
{
    free(self->ws);
    self->ws = NULL;
    g_free(self->dets);
    self->dets = NULL;
    self->det_ready = FALSE;
}

// Starts --cnn-full-res auto's measurement over for frames of a new size (half resolution meanwhile), when
// the options ask for it and the CNN source runs.
static void autores_reset(GstVdFir *self)
{
    demo_autores_live_free(&self->ar);
    memset(&self->ar, 0, sizeof self->ar);
    if ((self->opts.cnn_res_auto || self->opts.cnn_polarity_auto) && self->models.have_cnn &&
        (self->opts.cfg.sources & VD_DETECTOR_SRC_CNN) != 0u) {
        demo_autores_live_start(&self->ar);
    }
    if (self->ar.on && self->opts.cnn_res_auto) {
        self->opts.cfg.cnn_res = VD_DETECTOR_CNN_RES_HALF;
    }
    if (self->ar.on && self->opts.cnn_polarity_auto) {
        self->opts.cfg.cnn_invert = 0u;   // white-hot until the choice
    }
}

static gboolean gst_vdfir_start(GstBaseTransform *bt)
{
    GstVdFir *self = GST_VDFIR(bt);
    // The demo's command line: the same parser gives the same settings and errors.
    char *argv[10];
    int argc = 0;
    argv[argc++] = (char *)"vdfir";
    if (self->config != NULL) {
        argv[argc++] = (char *)"--config";
        argv[argc++] = self->config;
    }
    if (self->model != NULL) {
        argv[argc++] = (char *)"--model";
        argv[argc++] = self->model;
    }
    if (self->sources != NULL) {
        argv[argc++] = (char *)"--sources";
        argv[argc++] = self->sources;
    }
    argv[argc] = NULL;
    // The parser writes its error line (and --help text, never asked for) to streams.
    char *msg = NULL, *help = NULL;
    size_t msg_len = 0, help_len = 0;
    FILE *errf = open_memstream(&msg, &msg_len);
    FILE *outf = open_memstream(&help, &help_len);
    int a = -1;
    if (errf != NULL && outf != NULL) {
        a = demo_args_parse_to(&self->opts, argc, argv, outf, errf);
    }
    if (outf != NULL) {
        fclose(outf);
    }
    if (errf != NULL) {
        fclose(errf);
    }
    free(help);
    if (a != 0) {
        gchar *m = g_strstrip(g_strdup(msg != NULL && msg[0] != '\0' ? msg : "invalid settings"));
        // The parser's line names the demo; the setting's text is what matters here.
        const char *prefix = "vd_fir_demo: error: ";
        const char *text = g_str_has_prefix(m, prefix) ? m + strlen(prefix) : m;
        GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("vdfir: %s", text), (NULL));
        g_free(m);
        free(msg);
        return FALSE;
    }
    free(msg);
    char err[1024];
    memset(&self->models, 0, sizeof self->models);
    vd_status_t st = demo_models_load(&self->models, &self->opts, VD_DEMO_MODELS_DIR, err, sizeof err);
    if (st != VD_OK) {
        demo_models_free(&self->models);
        GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("vdfir: %s (%s)", err, vd_status_str(st)), (NULL));
        return FALSE;
    }
    self->loaded = TRUE;
    GST_INFO_OBJECT(self, "sources 0x%x, CNN %s, DBN %s", (unsigned)self->opts.cfg.sources,
                    self->models.have_cnn ? self->models.cnn_path : "none",
                    self->models.have_model ? self->models.model_path : "none");
    return TRUE;
}

static gboolean gst_vdfir_stop(GstBaseTransform *bt)
{
    GstVdFir *self = GST_VDFIR(bt);
    free_detector(self);
    demo_autores_live_free(&self->ar);
    self->ar.on = false;
    if (self->loaded) {
        demo_models_free(&self->models);
        self->loaded = FALSE;
    }
    return TRUE;
}

// A fresh detector (empty tracks) for width x height frames.
static gboolean init_detector(GstVdFir *self, guint32 width, guint32 height)
{
    free_detector(self);
    vd_detector_cfg_t cfg;
    demo_detector_cfg(&self->opts, width, height, &cfg);
    cfg.clock_us = clock_us;
    cfg.clock_user = NULL;
    size_t bytes = 0;
    const vd_dbn_model_t *m = self->models.have_model ? &self->models.model : NULL;
    vd_status_t st = vd_detector_workspace_size(&cfg, m, &bytes);
    if (st != VD_OK) {
        GST_ELEMENT_ERROR(self, CORE, NEGOTIATION,
                          ("vdfir: detector settings rejected for %ux%u frames (%s)", width, height,
                           vd_status_str(st)),
                          (NULL));
        return FALSE;
    }
    if (posix_memalign(&self->ws, 64, bytes ? bytes : 1) != 0) {
        self->ws = NULL;
        GST_ELEMENT_ERROR(self, RESOURCE, NO_SPACE_LEFT, ("vdfir: out of memory (%zu bytes)", bytes), (NULL));
        return FALSE;
    }
    st = vd_detector_init(&self->det, &cfg, m, self->ws, bytes);
    if (st != VD_OK) {
        GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("vdfir: detector initialisation failed (%s)", vd_status_str(st)),
                          (NULL));
        free_detector(self);
        return FALSE;
    }
    self->dets_cap = (size_t)self->det.cfg.max_detections + self->det.cfg.max_tracks + 1u;
    self->dets = g_new0(vd_detection_t, self->dets_cap);
    self->width = width;
    self->height = height;
    self->seq = 0;
    self->det_ready = TRUE;
    return TRUE;
}

static gboolean gst_vdfir_set_info(GstVideoFilter *vf, GstCaps *incaps, GstVideoInfo *in_info, GstCaps *outcaps,
                                   GstVideoInfo *out_info)
{
    (void)incaps;
    (void)outcaps;
    (void)out_info;
    GstVdFir *self = GST_VDFIR(vf);
    const guint32 w = (guint32)GST_VIDEO_INFO_WIDTH(in_info);
    const guint32 h = (guint32)GST_VIDEO_INFO_HEIGHT(in_info);
    if (self->det_ready && w == self->width && h == self->height) {
        return TRUE;   // same size (e.g. a format change): tracks and the resolution's measurement continue
    }
    autores_reset(self);
    return init_detector(self, w, h);
}

static gboolean gst_vdfir_sink_event(GstBaseTransform *bt, GstEvent *event)
{
    GstVdFir *self = GST_VDFIR(bt);
    // A seek breaks the sequence: start over with no tracks, like a new run of the demo.
    if (GST_EVENT_TYPE(event) == GST_EVENT_FLUSH_STOP && self->det_ready) {
        (void)init_detector(self, self->width, self->height);
    }
    return GST_BASE_TRANSFORM_CLASS(gst_vdfir_parent_class)->sink_event(bt, event);
}

// A 2-pixel box outline at value v (8-bit or 16-bit plane), clipped to the plane.
static void draw_box(guint8 *p, gsize stride, guint32 pw, guint32 ph, gboolean wide, const vd_rect_t *r)
{
    const guint16 v = 0xffffu;
    const gint64 x0 = r->x, y0 = r->y, x1 = (gint64)r->x + r->w - 1, y1 = (gint64)r->y + r->h - 1;
    for (gint64 y = y0; y <= y1; y++) {
        if (y < 0 || y >= (gint64)ph) {
            continue;
        }
        const gboolean edge_row = y < y0 + 2 || y > y1 - 2;
        for (gint64 x = x0; x <= x1; x++) {
            if (x < 0 || x >= (gint64)pw) {
                continue;
            }
            if (!edge_row && x >= x0 + 2 && x <= x1 - 2) {
                x = x1 - 2;   // skip the inside of the row
                continue;
            }
            guint8 *px = p + (gsize)y * stride;
            if (wide) {
                ((guint16 *)(void *)px)[x] = v;
            } else {
                px[x] = 0xffu;
            }
        }
    }
}

static GstStructure *detection_structure(const vd_detection_t *d, gboolean with_box)
{
    GstStructure *s = gst_structure_new("vd-detection", "score", G_TYPE_DOUBLE, d->score_q8 / 255.0, "state",
                                        G_TYPE_STRING, vd_detection_state_name(d->state), "source", G_TYPE_STRING,
                                        vd_detection_source_name(d->source), "flags", G_TYPE_UINT, (guint)d->flags, NULL);
    // No track (temporal off, or not tracked): no "track-id", as the demo's JSON has null.
    if (d->track_id != 0 && d->state != VD_TRACK_NONE) {
        gst_structure_set(s, "track-id", G_TYPE_UINT, (guint)d->track_id, NULL);
    }
    if (with_box) {
        gst_structure_set(s, "x", G_TYPE_INT, (gint)d->box.x, "y", G_TYPE_INT, (gint)d->box.y, "w", G_TYPE_INT,
                          (gint)d->box.w, "h", G_TYPE_INT, (gint)d->box.h, NULL);
    }
    return s;
}

// --cnn-full-res auto on the first frames as they pass (the demo measures 64 frames spread over a recording before
// its run; a stream cannot wait): frame f, unchanged yet, into the measurement; at DEMO_AUTORES_MAX_FRAMES the
// choice, posted as a "vdfir-resolution" element message, and at full resolution a new detector from this
// frame on (tracks start over, seq continues). A measurement that cannot run leaves half resolution with a
// warning. FALSE: the new detector failed (its error is posted).
static gboolean autores_step(GstVdFir *self, const vd_frame_t *f)
{
    char err[512] = "";
    bool now = false;
    const vd_status_t st = demo_autores_live_frame(&self->ar, &self->opts, f, self->seq, &now, err, sizeof err);
    if (st != VD_OK) {
        GST_ELEMENT_WARNING(self, STREAM, FAILED,
                            ("vdfir: cnn-full-res/cnn-polarity auto: %s: %s resolution, %s", err[0] ? err : vd_status_str(st),
                             demo_cnn_res_name(self->opts.cfg.cnn_res), demo_polarity_name(self->opts.cfg.cnn_invert)),
                            (NULL));
        return TRUE;
    }
    char note[160];
    if (demo_autores_live_wait_began(&self->ar, note, sizeof note)) {
        GST_INFO_OBJECT(self, "cnn-full-res/cnn-polarity auto: %s", note);
    }
    if (!now) {
        return TRUE;
    }
    const demo_autores_t *a = &self->ar.a;
    const gboolean full = a->res == VD_DETECTOR_CNN_RES_FULL;
    const char *polarity = demo_polarity_name(self->opts.cfg.cnn_invert ^ a->inverted);
    char figures[DEMO_AUTORES_DESCRIBE_MAX];
    demo_autores_describe(a, self->opts.cfg.cnn_invert != 0u, figures, sizeof figures);
    GST_INFO_OBJECT(self, "cnn input: %s resolution, %s from frame %" G_GUINT64_FORMAT " (%s over %u frames; %.2f s)",
                    demo_cnn_res_name(a->res), polarity, self->seq, figures,
                    (unsigned)a->frames, a->seconds);
    // "full" stays for the applications written against it; "resolution" names the choice (half, full, quarter),
    // "polarity" the polarity the networks read from then on; "*-inverted": the frames inverted (-1: not measured)
    GstStructure *ms = gst_structure_new(
        "vdfir-resolution", "full", G_TYPE_BOOLEAN, full, "resolution", G_TYPE_STRING, demo_cnn_res_name(a->res),
        "polarity", G_TYPE_STRING, polarity, "from-seq", G_TYPE_UINT64, self->seq,
        "frames", G_TYPE_UINT, (guint)a->frames, "seconds", G_TYPE_DOUBLE, a->seconds, NULL);
    static const char *const kinds[] = {"rating", "score", "agreement"};
    for (unsigned k = 0u; k < DEMO_AUTORES_CONFIGS; k++) {
        for (unsigned j = 0u; j < 3u; j++) {
            char name[48];
            snprintf(name, sizeof name, "%s-%s%s", kinds[j], demo_cnn_res_name(k % DEMO_AUTORES_RES),
                     k >= DEMO_AUTORES_RES ? "-inverted" : "");
            gst_structure_set(ms, name, G_TYPE_DOUBLE, demo_autores_figure(a, k, j), NULL);
        }
    }
    gst_element_post_message(GST_ELEMENT(self), gst_message_new_element(GST_OBJECT(self), ms));
    if (!demo_autores_apply(a, &self->opts.cfg)) {
        return TRUE;
    }
    const guint64 seq = self->seq;
    if (!init_detector(self, self->width, self->height)) {
        return FALSE;
    }
    self->seq = seq;
    return TRUE;
}

static GstFlowReturn gst_vdfir_transform_frame_ip(GstVideoFilter *vf, GstVideoFrame *frame)
{
    GstVdFir *self = GST_VDFIR(vf);
    if (!self->det_ready) {
        GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("vdfir: no detector (caps not negotiated)"), (NULL));
        return GST_FLOW_NOT_NEGOTIATED;
    }
    const gboolean wide = GST_VIDEO_FRAME_FORMAT(frame) == VDFIR_GRAY16_FORMAT;
    guint8 *plane = GST_VIDEO_FRAME_PLANE_DATA(frame, 0);
    const gsize stride = (gsize)GST_VIDEO_FRAME_PLANE_STRIDE(frame, 0);
    vd_frame_t f;
    memset(&f, 0, sizeof f);
    f.data = plane;
    f.width = self->width;
    f.height = self->height;
    f.stride = stride;
    f.format = wide ? VD_PIX_U16 : VD_PIX_U8;
    f.seq = (uint32_t)self->seq;
    GstBuffer *buf = frame->buffer;
    if (GST_BUFFER_PTS_IS_VALID(buf)) {
        f.timestamp_us = GST_BUFFER_PTS(buf) / 1000u;
    }
    if (wide && !self->opts.grey_decided) {
        // grey-window auto: the first 16-bit frame decides (a camera's raw counts: each frame's own window);
        // the detector made at negotiation becomes one that reads grey so, before any frame ran through it.
        const uint8_t before = self->opts.cfg.grey_mode;
        demo_grey_decide(&self->opts, &f);
        if (self->opts.cfg.grey_mode != before) {
            GST_INFO_OBJECT(self, "%.1f %% of the first frame's samples lie outside the fixed grey window: "
                                  "grey-window frame", self->opts.grey_outside_permille / 10.0);
            if (!init_detector(self, self->width, self->height)) {
                return GST_FLOW_ERROR;
            }
        }
    }
    if (self->ar.on && !autores_step(self, &f)) {
        return GST_FLOW_ERROR;
    }
    size_t n = 0;
    vd_status_t st = vd_detector_run(&self->det, &f, self->dets, self->dets_cap, &n);
    if (st != VD_OK && st != VD_ERR_CAPACITY) {
        GST_ELEMENT_ERROR(self, STREAM, FAILED, ("vdfir: detector failed on frame %" G_GUINT64_FORMAT " (%s)",
                                                 self->seq, vd_status_str(st)),
                          (NULL));
        return GST_FLOW_ERROR;
    }
    if (st == VD_ERR_CAPACITY) {
        GST_DEBUG_OBJECT(self, "frame %" G_GUINT64_FORMAT ": a detector budget was hit", self->seq);
    }
    GValue list = G_VALUE_INIT;
    g_value_init(&list, GST_TYPE_ARRAY);
    for (size_t i = 0; i < n; i++) {
        const vd_detection_t *d = &self->dets[i];
        GstVideoRegionOfInterestMeta *meta = gst_buffer_add_video_region_of_interest_meta(
            buf, "vehicle", (guint)d->box.x, (guint)d->box.y, (guint)d->box.w, (guint)d->box.h);
        meta->id = (gint)i;
        gst_video_region_of_interest_meta_add_param(meta, detection_structure(d, FALSE));
        GValue v = G_VALUE_INIT;
        g_value_init(&v, GST_TYPE_STRUCTURE);
        GstStructure *s = detection_structure(d, TRUE);
        gst_value_set_structure(&v, s);
        gst_structure_free(s);
        gst_value_array_append_and_take_value(&list, &v);
    }
    const vd_detector_stats_t *stats = vd_detector_last_stats(&self->det);
    GstStructure *ms = gst_structure_new("vdfir", "seq", G_TYPE_UINT64, self->seq, "pts", G_TYPE_UINT64,
                                         (guint64)GST_BUFFER_PTS(buf), "width", G_TYPE_UINT, self->width, "height",
                                         G_TYPE_UINT, self->height, "time-us", G_TYPE_UINT,
                                         (guint)stats->time_us[VD_DETECTOR_STAGE_TOTAL], NULL);
    gst_structure_take_value(ms, "detections", &list);
    gst_element_post_message(GST_ELEMENT(self), gst_message_new_element(GST_OBJECT(self), ms));
    if (self->draw) {
        // After detection; worst first is irrelevant in one colour. Luma only for YUV.
        for (size_t i = 0; i < n; i++) {
            draw_box(plane, stride, self->width, self->height, wide, &self->dets[i].box);
        }
    }
    self->seq++;
    return GST_FLOW_OK;
}

// The options point into these strings: they change only in NULL/READY (GST_PARAM_MUTABLE_READY).
static void set_string(GstVdFir *self, gchar **field, const GValue *value, const char *name)
{
    if (GST_STATE(self) > GST_STATE_READY) {
        GST_WARNING_OBJECT(self, "%s can only be changed in the NULL or READY state", name);
        return;
    }
    gchar *v = g_value_dup_string(value);
    GST_OBJECT_LOCK(self);
    g_free(*field);
    *field = v;
    GST_OBJECT_UNLOCK(self);
}

static void gst_vdfir_set_property(GObject *obj, guint id, const GValue *value, GParamSpec *pspec)
{
    GstVdFir *self = GST_VDFIR(obj);
    switch (id) {
    case PROP_MODEL: set_string(self, &self->model, value, "model"); break;
    case PROP_CONFIG: set_string(self, &self->config, value, "config"); break;
    case PROP_SOURCES: set_string(self, &self->sources, value, "sources"); break;
    case PROP_DRAW: self->draw = g_value_get_boolean(value); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, pspec); break;
    }
}

static void gst_vdfir_get_property(GObject *obj, guint id, GValue *value, GParamSpec *pspec)
{
    GstVdFir *self = GST_VDFIR(obj);
    GST_OBJECT_LOCK(self);
    switch (id) {
    case PROP_MODEL: g_value_set_string(value, self->model); break;
    case PROP_CONFIG: g_value_set_string(value, self->config); break;
    case PROP_SOURCES: g_value_set_string(value, self->sources); break;
    case PROP_DRAW: g_value_set_boolean(value, self->draw); break;
    default: G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, pspec); break;
    }
    GST_OBJECT_UNLOCK(self);
}

static void gst_vdfir_finalize(GObject *obj)
{
    GstVdFir *self = GST_VDFIR(obj);
    free_detector(self);
    demo_autores_live_free(&self->ar);
    if (self->loaded) {
        demo_models_free(&self->models);
    }
    g_free(self->model);
    g_free(self->config);
    g_free(self->sources);
    G_OBJECT_CLASS(gst_vdfir_parent_class)->finalize(obj);
}

static void gst_vdfir_class_init(GstVdFirClass *klass)
{
    GObjectClass *oc = G_OBJECT_CLASS(klass);
    GstElementClass *ec = GST_ELEMENT_CLASS(klass);
    GstBaseTransformClass *btc = GST_BASE_TRANSFORM_CLASS(klass);
    GstVideoFilterClass *vfc = GST_VIDEO_FILTER_CLASS(klass);
    oc->set_property = gst_vdfir_set_property;
    oc->get_property = gst_vdfir_get_property;
    oc->finalize = gst_vdfir_finalize;
    const GParamFlags rw = (GParamFlags)(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
    g_object_class_install_property(
        oc, PROP_MODEL,
        g_param_spec_string("model", "Model",
                            "A .vdm model as vd_fir_demo --model: a DBN (versions 1-2), a CNN (version 3, taken as "
                            "the CNN model) or \"none\"; unset = the demo's default from models/",
                            NULL, rw));
    g_object_class_install_property(
        oc, PROP_CONFIG,
        g_param_spec_string("config", "Config",
                            "vd_fir_demo's JSON config file (detector settings, cnn_model, sources); model and sources "
                            "properties override it like the demo's flags",
                            NULL, rw));
    g_object_class_install_property(
        oc, PROP_SOURCES,
        g_param_spec_string("sources", "Sources",
                            "Candidate sources as vd_fir_demo --sources (e.g. hotspot, cnn, hotspot,contrast); unset "
                            "= follow the models at hand",
                            NULL, rw));
    g_object_class_install_property(
        oc, PROP_DRAW,
        g_param_spec_boolean("draw", "Draw", "Draw each detection's box (2 px, white) into the frame (luma plane)",
                             TRUE, (GParamFlags)(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
                                                 GST_PARAM_MUTABLE_PLAYING)));
    gst_element_class_set_static_metadata(ec, "vd FIR vehicle detector", "Filter/Analyzer/Video",
                                          "Detects vehicles in far-infrared frames; attaches "
                                          "GstVideoRegionOfInterestMeta \"vehicle\" and posts a \"vdfir\" element "
                                          "message per frame",
                                          "vd");
    GstCaps *caps = gst_caps_from_string(GST_VIDEO_CAPS_MAKE(VDFIR_FORMATS));
    gst_element_class_add_pad_template(ec, gst_pad_template_new("sink", GST_PAD_SINK, GST_PAD_ALWAYS, caps));
    gst_element_class_add_pad_template(ec, gst_pad_template_new("src", GST_PAD_SRC, GST_PAD_ALWAYS, caps));
    gst_caps_unref(caps);
    btc->start = gst_vdfir_start;
    btc->stop = gst_vdfir_stop;
    btc->sink_event = gst_vdfir_sink_event;
    vfc->set_info = gst_vdfir_set_info;
    vfc->transform_frame_ip = gst_vdfir_transform_frame_ip;
}

static void gst_vdfir_init(GstVdFir *self)
{
    self->draw = TRUE;
    // Metas and drawing happen in place: never passthrough.
    gst_base_transform_set_in_place(GST_BASE_TRANSFORM(self), TRUE);
}

static gboolean plugin_init(GstPlugin *plugin)
{
    GST_DEBUG_CATEGORY_INIT(vdfir_debug, "vdfir", 0, "vd FIR vehicle detector");
    return gst_element_register(plugin, "vdfir", GST_RANK_NONE, GST_TYPE_VDFIR);
}

#define PACKAGE "vd"
GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, vdfir, "vd FIR vehicle detection", plugin_init,
                  VD_GST_VERSION, "MIT/X11", "vd", "vd (tools/gst)")
