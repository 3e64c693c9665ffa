// SPDX-License-Identifier: MIT
// Fuzz harness: the whole detector (vd_detector_*) on arbitrary frames (8/16-bit, strides) and configurations.
//
// Input layout: frame w, h (1..64), row padding, format selector, output
// capacity, flags (model, temporal, fuzzed cfg, bit-packed pixels, small
// max_*), a 32-bit mask of which cfg fields take fuzzed values (the others
// stay 0 = paper default), the field values, then pixels. Flag 32 picks the shipped
// 32x32 model instead of the tiny 8x8 one. Flag 64 adds the CNN source with the shipped
// compact network (models/vd_cnn_compact.vdm): one more byte picks the sources (with or
// without the CNN bit, values above the documented set included), cnn_rescore (0..3) and
// whether the network's score threshold is fuzzed (a u16, 0 = the model's, > 32768 invalid);
// mask bit 29 fuzzes cnn_flip (0..3: the fused flip pass, and invalid values) and, from the same byte,
// cnn_res (0..3: half, full and quarter resolution input, and an invalid value).
// Mask bits 30 and 31 fuzz temporal_cfg.flags (VD_TEMPORAL_SCORES, invalid bits) and coast_frames;
// the seed u8_cnn_track_scores runs the track scores on the CNN's boxes.
// Checks: the size
// query and init agree; a frame inside the configured maximum gives VD_OK or
// VD_ERR_CAPACITY with every box inside the frame; a bad frame gives its
// status and the same detector then still runs a good frame.
#include "fuzz_common.h"
#include "vd/detector.h"

#ifndef VD_SOURCE_DIR
#define VD_SOURCE_DIR "."
#endif

// Loads a model file once into `blob` (cap bytes); NULL if absent or rejected.
static const vd_dbn_model_t *load_once(const char *path, int *tried, uint32_t *blob, size_t cap, vd_dbn_model_t *m)
{
    if (*tried) {
        return m->blob ? m : NULL;
    }
    *tried = 1;
    memset(m, 0, sizeof(*m));
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        return NULL;
    }
    const size_t n = fread(blob, 1u, cap, f);
    fclose(f);
    if (n == 0u || vd_dbn_load(m, blob, n) != VD_OK) {
        memset(m, 0, sizeof(*m));
        return NULL;
    }
    return m;
}

// The committed tiny model (8x8 grey input) or, with `compact`, the shipped 32x32 model
// models/vd_dbn_compact.vdm (1024-48-16-1) when present (else the tiny one).
static const vd_dbn_model_t *test_model(int compact)
{
    static int tried_tiny, tried_compact;
    static uint32_t tiny_blob[1024], compact_blob[65536 / 4];
    static vd_dbn_model_t tiny, comp;
    const vd_dbn_model_t *t = load_once(VD_SOURCE_DIR "/tests/data/golden_tiny.vdm", &tried_tiny, tiny_blob,
                                    sizeof(tiny_blob), &tiny);
    if (compact) {
        const vd_dbn_model_t *c = load_once(VD_SOURCE_DIR "/models/vd_dbn_compact.vdm", &tried_compact, compact_blob,
                                        sizeof(compact_blob), &comp);
        return c ? c : t;
    }
    return t;
}

// The shipped compact CNN, loaded once in place (NULL when absent or rejected).
static const vd_cnn_model_t *test_cnn(void)
{
    static int tried;
    static uint32_t blob[131072 / 4];
    static vd_cnn_model_t m;
    if (!tried) {
        tried = 1;
        memset(&m, 0, sizeof(m));
        FILE *f = fopen(VD_SOURCE_DIR "/models/vd_cnn_compact.vdm", "rb");
        if (f != NULL) {
            const size_t n = fread(blob, 1u, sizeof(blob), f);
            fclose(f);
            if (n == 0u || n == sizeof(blob) || vd_cnn_load(&m, blob, n) != VD_OK) {
                memset(&m, 0, sizeof(m));
            }
        }
    }
    return m.blob ? &m : NULL;
}

static int rect_inside(const vd_rect_t *r, uint32_t w, uint32_t h)
{
    return r->w >= 1 && r->h >= 1 && r->x >= 0 && r->y >= 0 && (uint32_t)r->x + (uint32_t)r->w <= w &&
           (uint32_t)r->y + (uint32_t)r->h <= h;
}

static void check_run(vd_status_t st, const vd_detection_t *out, size_t count, size_t cap, uint32_t w, uint32_t h,
                      int has_model)
{
    FZ_CHECK(count <= cap);
    if (st != VD_OK && st != VD_ERR_CAPACITY) {
        FZ_CHECK(count == 0u);
        return;
    }
    for (size_t i = 0u; i < count; i++) {
        const vd_detection_t *d = &out[i];
        FZ_CHECK(rect_inside(&d->box, w, h));
        if (!(d->flags & VD_DETECTION_FLAG_RECOVERED)) {
            FZ_CHECK(rect_inside(&d->candidate, w, h));
            FZ_CHECK(d->source >= VD_DETECTION_SOURCE_HOTSPOT && d->source <= VD_DETECTION_SOURCE_CNN);
            if (!has_model && d->source != VD_DETECTION_SOURCE_CNN) {
                FZ_CHECK(d->score_q8 == 255u && (d->flags & VD_DETECTION_FLAG_UNVERIFIED));
            }
        }
        FZ_CHECK(d->complexity_q15 <= 32768u);
    }
}

// Documented ranges of detector.h, field by field: returns -1 when some field is out of its
// documented range (init must then say VD_ERR_ARG), 1 when every fuzzed field is clearly inside
// (init must succeed), 0 when the header leaves the combination open (the shape rules when only
// some of the four are set, reserved fields, a default max_detections above a small
// max_candidates) or for max_region_w/h below 16, which detector.h documents as out of range but
// the detector accepts (reported to its owner; tolerated here so CI stays green meanwhile).
static int cfg_verdict(const vd_detector_cfg_t *c, uint32_t fmask, int has_model)
{
    int open = 0;
    const int32_t hot = c->hot_thr_ck ? c->hot_thr_ck : 30315;
    const int32_t lo = c->grey_lo_ck ? c->grey_lo_ck : hot - 3000;
    const int32_t hi = c->grey_hi_ck ? c->grey_hi_ck : hot + 2100;
    const uint32_t cand = c->max_candidates ? c->max_candidates : 64u;
    int64_t top = 0;   // percentile grey window: the temperature of raw 65535 (calib.h's rounding)
    if (c->calib.gain_q16 >= 0) {
        const int64_t g = c->calib.gain_q16 ? c->calib.gain_q16 : 65536;
        top = (int64_t)c->calib.offset_ck + ((65535 * g + 32768) >> 16);
    }
    // grey_tail_permille is checked in either mode (every field out of its range is VD_ERR_ARG)
    if (c->grey_mode > 1u || c->grey_tail_permille > 499u ||
        (c->grey_mode == 1u && top > (int64_t)INT32_MAX - VD_DETECTOR_GREY_MIN_SPAN_CK)) {
        return -1;
    }
    if (c->thr_mode > 1u || c->adaptive_permille > 1000u || c->hot_thr_ck < 0 || c->calib.gain_q16 < 0 || lo >= hi ||
        (c->expand_w_q8 && (c->expand_w_q8 < 256u || c->expand_w_q8 > 2048u)) ||
        (c->expand_h_q8 && (c->expand_h_q8 < 256u || c->expand_h_q8 > 2048u)) ||
        (c->median_ksize != 0u && c->median_ksize != 1u && c->median_ksize != 3u && c->median_ksize != 5u) ||
        (c->window && (!(c->window & 1u) || c->window < 3u || c->window > VD_REFINE_MAX_WINDOW)) ||
        c->nms_iou_q15 > 32768u || cand > 4096u || (c->max_detections && c->max_detections > cand) ||
        c->max_region_w > c->max_width || c->max_region_h > c->max_height ||
        (c->temporal && c->max_tracks > 1024u) || c->sources > 0x0Fu || c->cnn_score_thr_q15 > 32768u ||
        c->cnn_rescore > 1u || c->cnn_flip > 1u || c->cnn_res > 2u || c->cnn_invert > 1u || (c->temporal_cfg.flags & ~0x1Fu) != 0u || ((c->sources & VD_DETECTOR_SRC_CNN) && c->cnn_model == NULL) ||
        ((c->sources & VD_DETECTOR_SRC_CNN) && c->cnn_rescore && !has_model)) {
        return -1;
    }
    if ((fmask & (0xFu << 9)) || (fmask & (1u << 27)) || (c->max_detections == 0u && cand < 32u) ||
        (c->max_region_w && c->max_region_w < 16u) || (c->max_region_h && c->max_region_h < 16u)) {
        open = 1;
    }
    return open ? 0 : 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader_t r;
    fz_init(&r, data, size);
    const uint32_t w = 1u + fz_u8(&r) % 64u;
    const uint32_t h = 1u + fz_u8(&r) % 64u;
    const uint32_t pad = fz_u8(&r) % 8u;
    const uint8_t fsel = fz_u8(&r);
    const size_t cap = fz_u8(&r) % 24u;
    const uint8_t flags = fz_u8(&r);
    const uint32_t fmask = (flags & 4u) ? fz_u32(&r) : 0u;

    vd_detector_cfg_t cfg;
    memset(&cfg, 0, sizeof(cfg));
    cfg.max_width = (flags & 16u) ? 1u + fz_u8(&r) % 64u : 64u;
    cfg.max_height = (flags & 16u) ? 1u + fz_u8(&r) % 64u : 64u;
    cfg.temporal = (flags & 2u) != 0u;
#define FZ_FIELD(bit, field, expr)       \
    do {                                 \
        if (fmask & (1u << (bit))) {     \
            cfg.field = (expr);          \
        }                                \
    } while (0)
    FZ_FIELD(0, thr_mode, (uint8_t)(fz_u8(&r) % 3u));
    FZ_FIELD(1, hot_thr_u8, fz_u8(&r));
    FZ_FIELD(2, adaptive_floor_u8, fz_u8(&r));
    FZ_FIELD(3, adaptive_permille, (uint16_t)(fz_u16(&r) % 1100u));
    FZ_FIELD(4, hot_thr_ck, (int32_t)(int16_t)fz_u16(&r) + 30000);
    FZ_FIELD(5, calib.gain_q16, (int32_t)fz_u32(&r));
    FZ_FIELD(6, calib.offset_ck, (int32_t)(int16_t)fz_u16(&r));
    FZ_FIELD(7, grey_lo_ck, (int32_t)(int16_t)fz_u16(&r) + 28000);
    FZ_FIELD(8, grey_hi_ck, (int32_t)(int16_t)fz_u16(&r) + 32000);
    FZ_FIELD(9, rules.aspect_min_q8, fz_u16(&r));
    FZ_FIELD(10, rules.aspect_max_q8, fz_u16(&r));
    FZ_FIELD(11, rules.min_area, fz_u16(&r));
    FZ_FIELD(12, rules.max_area, fz_u16(&r));
    FZ_FIELD(13, expand_w_q8, fz_u16(&r));
    FZ_FIELD(14, expand_h_q8, fz_u16(&r));
    FZ_FIELD(15, median_ksize, fz_u8(&r));
    FZ_FIELD(16, edge_step, fz_u8(&r));
    FZ_FIELD(17, window, fz_u8(&r));
    FZ_FIELD(18, score_thr_q8, fz_u8(&r));
    FZ_FIELD(19, nms_iou_q15, fz_u16(&r));
    FZ_FIELD(20, max_components, (uint16_t)(fz_u16(&r) % 2048u));
    FZ_FIELD(21, max_candidates, (uint16_t)(fz_u16(&r) % 5000u));
    FZ_FIELD(22, max_detections, (uint16_t)(fz_u8(&r) % 80u));
    FZ_FIELD(23, max_region_w, (uint16_t)(fz_u8(&r) % 80u));
    FZ_FIELD(24, max_region_h, (uint16_t)(fz_u8(&r) % 80u));
    FZ_FIELD(25, max_tracks, (uint16_t)(fz_u16(&r) % 1100u));
    FZ_FIELD(26, temporal_cfg.confirm_frames, fz_u8(&r));
    FZ_FIELD(27, win_min_std_u8, fz_u8(&r));
    FZ_FIELD(28, max_runs, (uint32_t)fz_u16(&r));
    if (fmask & (1u << 29)) {
        const uint8_t fb = fz_u8(&r);
        cfg.cnn_flip = (uint8_t)(fb % 4u);
        cfg.cnn_res = (uint8_t)((fb >> 2) % 4u);
        cfg.cnn_invert = (uint8_t)((fb >> 4) % 3u);
    }
    FZ_FIELD(30, temporal_cfg.flags, (uint8_t)(fz_u8(&r) % 0x30u));   // incl. VD_TEMPORAL_SCORES and invalid bits
    FZ_FIELD(31, temporal_cfg.coast_frames, fz_u8(&r));
#undef FZ_FIELD
    if (flags & 128u) {   // the per-frame grey window of 16-bit frames, incl. an invalid mode and tails
        const uint16_t gb = fz_u16(&r);
        cfg.grey_mode = (uint8_t)(gb % 3u);
        cfg.grey_tail_permille = (uint16_t)((gb >> 2) % 560u);
    }
    if (flags & 64u) {
        const uint8_t cb = fz_u8(&r);
        cfg.sources = (uint8_t)((cb & 0x0Fu) | ((cb & 0x80u) ? 0x10u : 0u));
        cfg.cnn_rescore = (uint8_t)((cb >> 4) & 3u);
        cfg.cnn_score_thr_q15 = (cb & 0x40u) ? (uint16_t)(fz_u16(&r) % 33000u) : 0u;
        cfg.cnn_model = test_cnn();
    }

    const vd_dbn_model_t *model = (flags & 1u) ? test_model((flags & 32u) != 0u) : NULL;
    size_t wsb = 0u;
    vd_status_t sq = vd_detector_workspace_size(&cfg, model, &wsb);
    FZ_CHECK(sq == VD_OK || sq == VD_ERR_ARG || sq == VD_ERR_OVERFLOW);
    const int verdict = cfg_verdict(&cfg, fmask, model != NULL);
    if (verdict < 0) {
        FZ_CHECK(sq == VD_ERR_ARG);
    } else if (verdict > 0) {
        FZ_CHECK(sq == VD_OK || sq == VD_ERR_OVERFLOW);
    }
    vd_detector_t det;
    if (sq != VD_OK) {
        uint64_t tiny[8];
        FZ_CHECK(vd_detector_init(&det, &cfg, model, tiny, sizeof(tiny)) == sq);
        return 0;
    }
    void *ws = fz_alloc(wsb);
    FZ_CHECK(vd_detector_init(&det, &cfg, model, ws, wsb - 1u) == VD_ERR_WORKSPACE);
    FZ_CHECK(vd_detector_init(&det, &cfg, model, ws, wsb) == VD_OK);

    // The frame.
    const int u16 = (fsel % 4u) == 1u;
    const size_t bpp = u16 ? 2u : 1u;
    const size_t stride = ((size_t)w + pad) * bpp;
    const size_t fbytes = fz_plane_bytes(stride, h, (size_t)w * bpp);
    uint8_t *pix = fz_alloc(fbytes);
    if (u16) {
        // Samples near the 30 C threshold (raw = centi-kelvin with the default calibration),
        // with the raw 16-bit range reachable through the top bits.
        for (uint32_t y = 0u; y < h; y++) {
            uint16_t *row = (uint16_t *)(void *)(pix + (size_t)y * stride);
            for (uint32_t x = 0u; x < w; x++) {
                const uint8_t b = fz_u8(&r);
                row[x] = (b >= 250u) ? (uint16_t)(b == 255u ? 65535u : (b - 250u) * 13000u)
                                     : (uint16_t)(29000u + 12u * b);
            }
        }
    } else {
        fz_fill_plane(&r, pix, w, h, stride, (flags & 8u) != 0u, 200u);
    }
    vd_frame_t frame;
    memset(&frame, 0, sizeof(frame));
    frame.data = pix;
    frame.width = w;
    frame.height = h;
    frame.stride = stride;
    frame.format = (fsel % 4u) == 2u ? (vd_pixfmt_t)7 : (u16 ? VD_PIX_U16 : VD_PIX_U8);

    vd_detection_t *out = cap ? fz_alloc(cap * sizeof(vd_detection_t)) : NULL;
    const int fits = w <= det.cfg.max_width && h <= det.cfg.max_height;
    for (int k = 0; k < 3; k++) {
        size_t count = 999u;
        frame.seq = (uint32_t)k;
        vd_status_t st = vd_detector_run(&det, &frame, out, cap, &count);
        if (frame.format == (vd_pixfmt_t)7) {
            FZ_CHECK(st == VD_ERR_FORMAT || st == VD_ERR_ARG);
        } else if (!fits) {
            FZ_CHECK(st == VD_ERR_ARG);
        } else {
            FZ_CHECK(st == VD_OK || st == VD_ERR_CAPACITY);
        }
        check_run(st, out, count, cap, w, h, model != NULL);
        FZ_CHECK(vd_detector_last_stats(&det) != NULL);
#ifdef FZ_DEBUG
        {
            const vd_detector_stats_t *s = vd_detector_last_stats(&det);
            fprintf(stderr, "run %d: status %d, %zu detections (hot %u, comps %u, kept %u, refined %u, verified %u, cnn %u)\n", k,
                    (int)st, count, s->hot_pixels, s->components, s->kept, s->refined, s->verified, s->cnn_boxes);
        }
#endif
    }
    // A bad frame between good ones leaves the detector usable.
    {
        vd_frame_t bad = frame;
        bad.data = NULL;
        size_t count = 5u;
        vd_status_t sb = vd_detector_run(&det, &bad, out, cap, &count);
        FZ_CHECK((sb == VD_ERR_ARG || (sb == VD_ERR_FORMAT && frame.format == (vd_pixfmt_t)7)) && count == 0u);
        bad = frame;
        bad.stride = (size_t)w * bpp - 1u;
        FZ_CHECK(vd_detector_run(&det, &bad, out, cap, &count) != VD_OK);
        if (frame.format != (vd_pixfmt_t)7 && fits) {
            vd_status_t st = vd_detector_run(&det, &frame, out, cap, &count);
            FZ_CHECK(st == VD_OK || st == VD_ERR_CAPACITY);
            check_run(st, out, count, cap, w, h, model != NULL);
        }
    }
    free(out);
    free(pix);
    free(ws);
    return 0;
}
