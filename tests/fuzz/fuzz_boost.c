// SPDX-License-Identifier: MIT
// Fuzz harness: the boosted-stump verifier (vd/boost.h, format version 4): vd_boost_load and, on whatever it
// accepts, the workspace query, one vd_boost_score and vd_boost_features on a crop made of the input's bytes.
//
// Input: one control byte, then the blob (or a plain blob starting with "VDMF", taken as it is). Control
// bit 0: rewrite the outer CRC-32 (when the claimed total size lies inside the input) so mutations reach
// the structural checks; bit 1: also rewrite the embedded CNN's CRC (when its claimed offset and length lie
// inside), first, so mutations inside the CNN reach vd_cnn_load's checks; bit 2: offer 1..3 extra trailing
// bytes (ignored by the loader); bit 3: a crop row stride of crop_w + 5 instead of crop_w.
// A rejected blob leaves *m untouched or zeroed (docs/model-format.md); a loaded model is self-consistent
// (pointers inside the blob, map lengths from the CNN's factors); the workspace query agrees with the run
// (one byte less gives VD_ERR_WORKSPACE); the score equals the stump sum recomputed here from the features,
// |score| <= score_span; two runs agree whatever the workspace held. Networks above MAX_MACS multiply-adds
// or MAX_WS bytes of workspace are only loaded and sized (keeps an execution fast).
#include "fuzz_common.h"
#include "vd/boost.h"

#define MAX_MACS 16000000u   // the shipped models/vd_boost.vdm (12.3 M) still runs
#define MAX_WS (32u << 20)

static uint32_t rd16(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8);
}

static void wr32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

// Rewrites the CRC of the container at b (n bytes available) when its total size lies inside.
static void fix_crc(uint8_t *b, size_t n)
{
    if (n < 16u) {
        return;
    }
    const uint32_t total = fz_rd32(b + 8);
    if (total >= 16u && total <= n) {
        wr32(b + 12, fz_crc32(b + 16, total - 16u));
    }
}

static int inside(const void *p, size_t len, const uint8_t *lo, const uint8_t *hi)
{
    const uint8_t *q = (const uint8_t *)p;
    return q >= lo && len <= (size_t)(hi - q);
}

static int all_zero(const void *p, size_t n)
{
    const uint8_t *q = (const uint8_t *)p;
    for (size_t i = 0u; i < n; i++) {
        if (q[i] != 0u) {
            return 0;
        }
    }
    return 1;
}

static int32_t i16_of(const uint8_t *p)
{
    const uint32_t u = rd16(p);
    return u >= 0x8000u ? (int32_t)u - 65536 : (int32_t)u;
}

static void check_model(const vd_boost_model_t *m, const uint8_t *blob, size_t bytes)
{
    const uint8_t *end = blob + m->size;
    FZ_CHECK(m->blob == blob && m->size <= bytes && m->size >= VD_BOOST_HEADER_SIZE && m->size % 4u == 0u);
    FZ_CHECK(m->n_maps >= 1u && m->n_maps <= VD_BOOST_MAX_MAPS);
    FZ_CHECK(m->n_stumps >= 1u && m->n_stumps <= VD_BOOST_MAX_STUMPS);
    FZ_CHECK(inside(m->stumps, (size_t)VD_BOOST_STUMP_SIZE * m->n_stumps, blob, end));
    FZ_CHECK(inside(m->cnn.blob, m->cnn.size, blob, end) && m->cnn.blob >= m->stumps + 8u * m->n_stumps);
    FZ_CHECK(m->crop_w == m->cnn.input_w && m->crop_h == m->cnn.input_h && m->name[16] == '\0');
    FZ_CHECK(m->score_span >= 1);
    uint32_t nf = 0u;
    for (uint32_t i = 0u; i < m->n_maps; i++) {
        const uint32_t t = m->map_tensor[i];
        FZ_CHECK(t >= 1u && t <= m->cnn.n_layers && m->map_channel[i] < m->cnn.layers[t - 1u].cout);
        FZ_CHECK(m->map_len[i] >= 1u && m->map_len[i] <= (uint32_t)m->crop_w * m->crop_h);
        nf += m->map_len[i];
    }
    FZ_CHECK(nf == m->n_features);
    int64_t span = 0;
    for (uint32_t k = 0u; k < m->n_stumps; k++) {
        const uint8_t *s = m->stumps + 8u * k;
        FZ_CHECK(s[2] < m->n_maps && rd16(s) < m->map_len[s[2]]);
        const int32_t l = i16_of(s + 4), r = i16_of(s + 6);
        FZ_CHECK(l != -32768 && r != -32768);
        span += (l < 0 ? -l : l) > (r < 0 ? -r : r) ? (l < 0 ? -l : l) : (r < 0 ? -r : r);
    }
    FZ_CHECK(span == m->score_span || (span == 0 && m->score_span == 1));
}

// The score the stumps give on a feature vector (the format's formula, evaluated here).
static int64_t ref_score(const vd_boost_model_t *m, const int8_t *f)
{
    uint32_t off[VD_BOOST_MAX_MAPS];
    uint32_t o = 0u;
    for (uint32_t i = 0u; i < m->n_maps; i++) {
        off[i] = o;
        o += m->map_len[i];
    }
    int64_t sum = 0;
    for (uint32_t k = 0u; k < m->n_stumps; k++) {
        const uint8_t *s = m->stumps + 8u * k;
        const int32_t x = f[off[s[2]] + rd16(s)];
        const int32_t thr = s[3] >= 0x80u ? (int32_t)s[3] - 256 : (int32_t)s[3];
        sum += x <= thr ? i16_of(s + 4) : i16_of(s + 6);
    }
    return sum;
}

static void run_checks(const vd_boost_model_t *m, const uint8_t *blob, size_t bytes, uint8_t ctl)
{
    size_t wsb = 0u;
    uint64_t macs = 0u;
    const vd_status_t st = vd_boost_workspace_size(m, &wsb);
    FZ_CHECK(st == VD_OK || st == VD_ERR_OVERFLOW);
    FZ_CHECK(vd_cnn_macs(&m->cnn, m->crop_w, m->crop_h, &macs) == VD_OK);
    if (st != VD_OK || macs > MAX_MACS || wsb > MAX_WS) {
        return;
    }
    FZ_CHECK(wsb > 0u);
    const uint32_t stride = m->crop_w + ((ctl & 8u) ? 5u : 0u);
    const size_t n_img = (size_t)stride * m->crop_h;
    uint8_t *img = fz_alloc(n_img);
    for (size_t i = 0u; i < n_img; i++) {
        img[i] = blob[(i * 13u) % bytes];
    }
    uint8_t *ws = fz_alloc(wsb);
    int32_t s1 = 0, s2 = 0;
    FZ_CHECK(vd_boost_score(m, img, stride, ws, wsb - 1u, &s1) == VD_ERR_WORKSPACE);
    FZ_CHECK(vd_boost_score(m, img, m->crop_w - 1u, ws, wsb, &s1) == VD_ERR_ARG);
    memset(ws, 0x00, wsb);
    FZ_CHECK(vd_boost_score(m, img, stride, ws, wsb, &s1) == VD_OK);
    FZ_CHECK(s1 <= m->score_span && s1 >= -m->score_span);
    memset(ws, 0xA5, wsb);
    int8_t *f = fz_alloc(m->n_features + 1u);
    f[m->n_features] = 0x3C;
    FZ_CHECK(vd_boost_features(m, img, stride, ws, wsb, f, m->n_features - 1u) == VD_ERR_ARG);
    FZ_CHECK(vd_boost_features(m, img, stride, ws, wsb, f, m->n_features) == VD_OK);
    FZ_CHECK(f[m->n_features] == 0x3C);   // capacity respected
    FZ_CHECK(ref_score(m, f) == (int64_t)s1);
    memset(ws, 0x5A, wsb);
    FZ_CHECK(vd_boost_score(m, img, stride, ws, wsb, &s2) == VD_OK && s2 == s1);   // no state, no stale reads
    int32_t thr = 0;
    uint32_t nf = 0u;
    FZ_CHECK(vd_boost_threshold(m, &thr, &nf) == VD_OK && thr == m->threshold && nf == m->n_features);
    free(f);
    free(ws);
    free(img);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    vd_boost_model_t m;
    if (size < 1u) {
        FZ_CHECK(vd_boost_load(&m, "", 0u) == VD_ERR_ARG);
        return 0;
    }
    const int plain = size >= 4u && memcmp(data, "VDMF", 4u) == 0;
    const uint8_t ctl = plain ? 0u : data[0];
    const size_t n = plain ? size : size - 1u;
    const size_t pad = (ctl & 4u) ? 1u + (ctl >> 6) % 3u : 0u;
    uint8_t *blob = fz_alloc(n + pad);
    if (n) {
        memcpy(blob, plain ? data : data + 1, n);
    }
    memset(blob + n, 0xFF, pad);
    if ((ctl & 2u) && n >= VD_BOOST_HEADER_SIZE) {
        const uint32_t off = fz_rd32(blob + 20), len = fz_rd32(blob + 24);
        if (off % 4u == 0u && off <= n && len <= n - off) {
            fix_crc(blob + off, len);
        }
    }
    if (ctl & 1u) {
        fix_crc(blob, n);
    }
    const size_t bytes = n + pad;
    memset(&m, 0x5A, sizeof m);
    const vd_boost_model_t before = m;
    const vd_status_t st = bytes ? vd_boost_load(&m, blob, bytes) : VD_ERR_ARG;
    FZ_CHECK(st == VD_OK || st == VD_ERR_MODEL || (bytes == 0u && st == VD_ERR_ARG));
    if (st != VD_OK) {
        // Untouched (failed before the CNN loaded) or zeroed (after): never half a model.
        FZ_CHECK(memcmp(&m, &before, sizeof m) == 0 || all_zero(&m, sizeof m));
        if (all_zero(&m, sizeof m)) {
            size_t wsb = 0u;
            FZ_CHECK(vd_boost_workspace_size(&m, &wsb) == VD_ERR_STATE);
        }
    } else {
        check_model(&m, blob, bytes);
        run_checks(&m, blob, bytes, ctl);
    }
    free(blob);
    return 0;
}
