// SPDX-License-Identifier: MIT
// Fuzz harness: the CNN loader (vd_cnn_load) and, on whatever it accepts, vd_cnn_run (whole plane and
// streamed, and streamed with its weights prepared), vd_cnn_decode and vd_cnn_run_rows_decode (the head a
// ring) on a tiny input.
//
// Input: one control byte, then the blob (or a plain blob starting with "VDMF"). Control bit 0: rewrite
// the blob's CRC-32 field (when the claimed total size lies inside the input) so mutations reach the
// structural checks; bit 1: offer the blob with 1..3 extra trailing bytes (flash padding, ignored by the
// loader); bit 2: run at twice the model's alignment in width; bits 3-7: frame size for decoding.
// A loaded model must be self-consistent; the workspace query must agree with the run (one byte less
// gives VD_ERR_WORKSPACE), also for the streamed run (VD_CNN_STREAM, from the plane and from a row
// source), whose head must equal the whole-plane head; the run must be deterministic whatever the
// workspace held; decoded boxes lie
// inside the frame, at most the capacity, in logit order. Networks above 4 M multiply-adds or 32 MB of
// workspace are only loaded and sized (keeps an execution fast).
#include "fuzz_common.h"
#include "vd/cnn.h"

#define MAX_MACS 4000000u
#define MAX_WS (32u << 20)

static int inside(const void *p, size_t len, const uint8_t *lo, const uint8_t *hi)
{
    const uint8_t *q = (const uint8_t *)p;
    return q >= lo && len <= (size_t)(hi - q);
}

static void check_model(const vd_cnn_model_t *m, const uint8_t *blob, size_t bytes)
{
    FZ_CHECK(m->blob == blob && m->size <= bytes && m->size >= VD_CNN_HEADER_SIZE);
    FZ_CHECK(m->n_layers >= 1u && m->n_layers <= VD_CNN_MAX_LAYERS);
    FZ_CHECK(m->out_channels == 3u || m->out_channels == 5u);
    FZ_CHECK(m->out_stride == 4u || m->out_stride == 8u);
    FZ_CHECK(m->align >= m->out_stride && m->align <= VD_CNN_MAX_FACTOR && (m->align & (m->align - 1u)) == 0u);
    FZ_CHECK(m->input_w % m->align == 0u && m->input_h % m->align == 0u);
    FZ_CHECK(m->max_peaks >= 1u && m->max_peaks <= VD_CNN_MAX_PEAKS && m->name[16] == '\0');
    const uint8_t *end = blob + m->size;
    FZ_CHECK(inside(m->decode_table, 1024u * m->out_channels, blob, end));
    for (uint32_t l = 0u; l < m->n_layers; l++) {
        const vd_cnn_layer_t *L = &m->layers[l];
        FZ_CHECK(L->op >= VD_CNN_OP_CONV3X3 && L->op <= VD_CNN_OP_CONV5X5 && L->in <= l);
        FZ_CHECK(L->cin >= 1u && L->cin <= VD_CNN_MAX_CHANNELS && L->cout >= 1u && L->cout <= VD_CNN_MAX_CHANNELS);
        FZ_CHECK(L->act_min <= L->act_max);
        if (L->op > VD_CNN_OP_PW1X1 && L->op != VD_CNN_OP_CONV5X5) {
            FZ_CHECK(L->w == NULL && L->bias == NULL && L->mult == NULL && L->shift == NULL);
            continue;
        }
        const size_t k = L->op == VD_CNN_OP_CONV3X3   ? 9u * L->cin
                         : L->op == VD_CNN_OP_CONV5X5 ? 25u * L->cin
                         : L->op == VD_CNN_OP_DW3X3   ? 9u
                                                      : L->cin;
        const size_t wl = L->op == VD_CNN_OP_DW3X3 ? 9u * (size_t)L->cout : k * L->cout;
        FZ_CHECK(inside(L->w, wl, blob, end) && inside(L->bias, 4u * (size_t)L->cout, blob, end));
        FZ_CHECK(inside(L->mult, 4u * (size_t)L->cout, blob, end) && inside(L->shift, L->cout, blob, end));
    }
    FZ_CHECK(m->layers[m->n_layers - 1u].cout == m->out_channels);
}

typedef struct plane {
    const uint8_t *img;
    uint32_t w;
} plane_t;

static void plane_row(void *ctx, uint32_t y, uint8_t *dst)
{
    const plane_t *p = (const plane_t *)ctx;
    memcpy(dst, p->img + (size_t)y * p->w, p->w);
}

static void run_checks(const vd_cnn_model_t *m, const uint8_t *blob, size_t bytes, uint8_t ctl)
{
    const uint32_t w = m->align * ((ctl & 4u) ? 2u : 1u);
    const uint32_t h = m->align;
    size_t wsb = 0u;
    uint64_t macs = 0u;
    const vd_status_t st = vd_cnn_workspace_size(m, w, h, &wsb);
    if (w > VD_CNN_MAX_SIDE) {
        FZ_CHECK(st == VD_ERR_ARG);
        return;
    }
    FZ_CHECK(st == VD_OK || st == VD_ERR_OVERFLOW);
    FZ_CHECK(vd_cnn_macs(m, w, h, &macs) == VD_OK);
    FZ_CHECK(vd_cnn_workspace_size(m, w + 1u, h, &wsb) == VD_ERR_ARG);   // align >= out_stride >= 4
    if (st != VD_OK || macs > MAX_MACS) {
        return;
    }
    FZ_CHECK(vd_cnn_workspace_size(m, w, h, &wsb) == VD_OK && wsb > 0u);
    if (wsb > MAX_WS) {
        return;
    }
    uint8_t *img = fz_alloc((size_t)w * h);
    for (size_t i = 0u; i < (size_t)w * h; i++) {
        img[i] = blob[(i * 7u) % bytes];
    }
    uint8_t *ws = fz_alloc(wsb);
    vd_cnn_output_t out, out2;
    FZ_CHECK(vd_cnn_run(m, img, w, h, w, ws, wsb - 1u, &out) == VD_ERR_WORKSPACE);
    memset(ws, 0x00, wsb);
    FZ_CHECK(vd_cnn_run(m, img, w, h, w, ws, wsb, &out) == VD_OK);
    FZ_CHECK(out.w == w / m->out_stride && out.h == h / m->out_stride && out.c == m->out_channels);
    FZ_CHECK(out.stride == m->out_stride && inside(out.data, (size_t)out.w * out.h * out.c, ws, ws + wsb));
    const size_t head = (size_t)out.w * out.h * out.c;
    int8_t *copy = fz_alloc(head);
    memcpy(copy, out.data, head);
    memset(ws, 0xA5, wsb);
    FZ_CHECK(vd_cnn_run(m, img, w, h, w, ws, wsb, &out2) == VD_OK);
    FZ_CHECK(out2.data == out.data && memcmp(copy, out2.data, head) == 0);   // no state, no stale reads
    vd_cnn_output_t t;
    FZ_CHECK(vd_cnn_tensor(m, ws, wsb, w, h, m->n_layers, &t) == VD_OK && t.data == out.data);

    // The streamed executor: its own exact workspace, the same head bytes,
    // from the plane and from a row source.
    size_t sb = 0u;
    FZ_CHECK(vd_cnn_workspace_size_ex(m, w, h, VD_CNN_STREAM, &sb) == VD_OK && sb > 0u);
    uint8_t *ws2 = fz_alloc(sb);
    memset(ws2, 0x5A, sb);
    FZ_CHECK(vd_cnn_run_ex(m, img, w, h, w, VD_CNN_STREAM, ws2, sb - 1u, &out2) == VD_ERR_WORKSPACE);
    FZ_CHECK(vd_cnn_run_ex(m, img, w, h, w, VD_CNN_STREAM, ws2, sb, &out2) == VD_OK);
    FZ_CHECK(inside(out2.data, head, ws2, ws2 + sb) && memcmp(copy, out2.data, head) == 0);
    memset(ws2, 0xA5, sb);
    plane_t pl = {img, w};
    const vd_cnn_rows_t rows = {plane_row, &pl};
    FZ_CHECK(vd_cnn_run_rows(m, &rows, w, h, VD_CNN_STREAM, ws2, sb, &out2) == VD_OK);
    FZ_CHECK(memcmp(copy, out2.data, head) == 0);
    // Prepared weights (vd_cnn_prepare; on x86 hosts, size 0 elsewhere): the same head, and a buffer
    // that is not the model's refused.
    vd_cnn_model_t pm = *m;
    size_t pb = 0u;
    FZ_CHECK(vd_cnn_prepared_size(&pm, &pb) == VD_OK);
    uint8_t *pbuf = fz_alloc(pb + 1u);
    FZ_CHECK(vd_cnn_prepare(&pm, pbuf, pb) == VD_OK && (pb == 0u) == (pm.prepared == NULL));
    FZ_CHECK(vd_cnn_run_ex(&pm, img, w, h, w, VD_CNN_STREAM, ws2, sb, &out2) == VD_OK);
    FZ_CHECK(memcmp(copy, out2.data, head) == 0);
    if (pb > 0u) {
        pbuf[8] ^= 1u;   // the model's CRC in the header
        FZ_CHECK(vd_cnn_run_ex(&pm, img, w, h, w, VD_CNN_STREAM, ws2, sb, &out2) == VD_ERR_STATE);
    }
    free(pbuf);
    free(ws2);

    // Decoding: default and extreme thresholds, small capacities, a frame of 1..32 pixels.
    const uint32_t fw = 1u + (ctl >> 3), fh = 1u + ((ctl >> 3) ^ 7u);
    static const int32_t thr[3] = {VD_CNN_THR_DEFAULT, -128, 127};
    for (int k = 0; k < 3; k++) {
        vd_cnn_box_t boxes[5];
        size_t n = 99u;
        const size_t cap = (size_t)k + 3u;
        FZ_CHECK(vd_cnn_decode(m, &out, thr[k], (uint32_t)k, fw, fh, boxes, cap, &n) == VD_OK);
        FZ_CHECK(n <= cap);
        for (size_t i = 0u; i < n; i++) {
            const vd_rect_t *r = &boxes[i].rect;
            FZ_CHECK(r->x >= 0 && r->y >= 0 && r->w >= 1 && r->h >= 1);
            FZ_CHECK((uint32_t)(r->x + r->w) <= fw && (uint32_t)(r->y + r->h) <= fh);
            FZ_CHECK(boxes[i].score_q15 <= 32768u);
            FZ_CHECK(i == 0u || boxes[i - 1u].logit >= boxes[i].logit);
            FZ_CHECK(thr[k] == VD_CNN_THR_DEFAULT || boxes[i].logit >= thr[k]);
        }
        // Decoded as the rows are made, the head a ring (VD_CNN_HEAD_RING): the same boxes, in its own
        // exact workspace.
        const uint32_t rf = VD_CNN_STREAM | VD_CNN_HEAD_RING;
        size_t rb = 0u;
        FZ_CHECK(vd_cnn_workspace_size_ex(m, w, h, rf, &rb) == VD_OK && rb > 0u && rb <= sb);
        uint8_t *ws3 = fz_alloc(rb);
        memset(ws3, 0x3C, rb);
        const vd_cnn_decode_opts_t o = {thr[k], (uint32_t)k, fw, fh};
        vd_cnn_box_t rboxes[5];
        size_t rn = 98u;
        FZ_CHECK(vd_cnn_run_rows_decode(m, &rows, w, h, rf, ws3, rb - 1u, &o, rboxes, cap, &rn) == VD_ERR_WORKSPACE);
        FZ_CHECK(vd_cnn_run_rows_decode(m, &rows, w, h, rf, ws3, rb, &o, rboxes, cap, &rn) == VD_OK && rn == n);
        for (size_t i = 0u; i < n; i++) {
            FZ_CHECK(memcmp(&rboxes[i].rect, &boxes[i].rect, sizeof boxes[i].rect) == 0);
            FZ_CHECK(rboxes[i].score_q15 == boxes[i].score_q15 && rboxes[i].logit == boxes[i].logit);
        }
        free(ws3);
    }
    free(copy);
    free(ws);
    free(img);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    vd_cnn_model_t m;
    if (size < 1u) {
        FZ_CHECK(vd_cnn_load(&m, "", 0u) == VD_ERR_ARG);
        return 0;
    }
    // A plain .vdm file is taken as it is, without a control byte.
    const int plain = size >= 4u && memcmp(data, "VDMF", 4u) == 0;
    const uint8_t ctl = plain ? 0u : data[0];
    const size_t n = plain ? size : size - 1u;
    const size_t pad = (ctl & 2u) ? 1u + (ctl >> 6) % 3u : 0u;
    uint8_t *blob = fz_alloc(n + pad);
    if (n) {
        memcpy(blob, plain ? data : data + 1, n);
    }
    memset(blob + n, 0xFF, pad);
    if ((ctl & 1u) && n >= VD_CNN_HEADER_SIZE) {
        const uint32_t total = fz_rd32(blob + 8);
        if (total >= 16u && total <= n) {
            const uint32_t c = fz_crc32(blob + 16, total - 16u);
            blob[12] = (uint8_t)c;
            blob[13] = (uint8_t)(c >> 8);
            blob[14] = (uint8_t)(c >> 16);
            blob[15] = (uint8_t)(c >> 24);
        }
    }
    const size_t bytes = n + pad;
    memset(&m, 0x5A, sizeof m);
    const vd_cnn_model_t before = m;
    const vd_status_t st = bytes ? vd_cnn_load(&m, blob, bytes) : VD_ERR_MODEL;
    FZ_CHECK(st == VD_OK || st == VD_ERR_MODEL);
    if (st != VD_OK) {
        FZ_CHECK(memcmp(&m, &before, sizeof m) == 0);   // *m written only on success
    } else {
        check_model(&m, blob, bytes);
        run_checks(&m, blob, bytes, ctl);
    }
    free(blob);
    return 0;
}
