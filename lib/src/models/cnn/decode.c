// SPDX-License-Identifier: MIT
// CNN decoder: boxes from the head (heatmap peaks, top-K, sizes and offsets from the model's decode
// tables), and a score threshold as a logit threshold.
//
// Algorithm (CenterNet-like): 3x3 local maxima of the heatmap channel with a raster-order tie rule (a
// plateau yields its first cell), kept top-K by insertion (logit descending, then raster order); each
// peak's box from the Q8 decode tables (channels 1-2 size, 3-4 centre offset), in int64, rounded to frame
// pixels by floor division and clamped to the frame. A score threshold maps to a logit threshold by
// binary search of the non-decreasing score table (checked by the loader).
// Reference: tools/vdtools/formats/cnn_ref.py (bit-exact); format docs/model-format.md ("CNN kind").
// Bounds: 8 compares per heatmap cell at most, O(K) per inserted peak; stack ~380 B (Cortex-M7 -Os).
#include "vd/cnn.h"

#include "models/cnn/cnn_internal.h"
#include "internal/vd_internal.h"

#include <string.h>

static int32_t table_at(const vd_cnn_model_t *m, uint32_t ch, int32_t v)
{
    return vd_cnn_rd_i32(m->decode_table + 4u * (ch * 256u + (uint32_t)(v + 128)));
}

uint32_t vd__cnn_score_of_logit(const vd_cnn_model_t *m, int32_t v)
{
    return (uint32_t)table_at(m, 0u, v);
}

// floor(a / d) for d > 0 (C division truncates toward zero).
static int64_t floor_div(int64_t a, int64_t d)
{
    int64_t q = a / d;
    if ((a % d) != 0 && a < 0) {
        q -= 1;
    }
    return q;
}

static int64_t clamp64(int64_t v, int64_t lo, int64_t hi)
{
    return (v < lo) ? lo : ((v > hi) ? hi : v);
}

// Heatmap peak test: > the neighbours before (y, x) in raster order, >= the
// ones after, so a plateau yields exactly its first cell in raster order.
static bool is_peak(const int8_t *hm, uint32_t w, uint32_t h, uint32_t c_n, uint32_t x, uint32_t y)
{
    const int32_t v = hm[((size_t)y * w + x) * c_n];
    for (int32_t dy = -1; dy <= 1; dy++) {
        for (int32_t dx = -1; dx <= 1; dx++) {
            const int32_t ny = (int32_t)y + dy;
            const int32_t nx = (int32_t)x + dx;
            if ((dy == 0 && dx == 0) || ny < 0 || nx < 0 || ny >= (int32_t)h || nx >= (int32_t)w) {
                continue;
            }
            const int32_t nv = hm[((size_t)ny * w + (size_t)nx) * c_n];
            const bool before = dy < 0 || (dy == 0 && dx < 0);
            if (before ? !(v > nv) : !(v >= nv)) {
                return false;
            }
        }
    }
    return true;
}

vd_status_t vd_cnn_decode(const vd_cnn_model_t *m, const vd_cnn_output_t *out, int32_t thr_i8, uint32_t max_peaks,
                          uint32_t frame_w, uint32_t frame_h, vd_cnn_box_t *boxes, size_t capacity, size_t *count)
{
    VD_VERIFY(m != NULL && out != NULL && count != NULL && (boxes != NULL || capacity == 0u), VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(vd__cnn_model_ok(m, &c), VD_ERR_STATE);
    const uint32_t s = m->out_stride;
    VD_VERIFY(out->data != NULL && out->c == m->out_channels && out->stride == s && out->w >= 1u &&
                  out->h >= 1u && out->w <= VD_CNN_MAX_SIDE / s && out->h <= VD_CNN_MAX_SIDE / s,
              VD_ERR_ARG);
    VD_VERIFY(frame_w >= 1u && frame_w <= VD_MAX_DIM && frame_h >= 1u && frame_h <= VD_MAX_DIM, VD_ERR_ARG);
    int32_t thr = m->score_threshold_i8;
    if (thr_i8 != VD_CNN_THR_DEFAULT) {
        VD_VERIFY(thr_i8 >= -128 && thr_i8 <= 127, VD_ERR_ARG);
        thr = thr_i8;
    }
    uint32_t k_max = (max_peaks == 0u) ? m->max_peaks : max_peaks;
    const size_t k = ((size_t)k_max < capacity) ? (size_t)k_max : capacity;
    const uint32_t w = out->w, h = out->h, c_n = out->c;
    const int8_t *hm = out->data;

    // 1-2. Peaks in raster order into the top-K array (logit descending,
    // then raster order: an equal logit found later goes after).
    size_t n = 0u;
    for (uint32_t y = 0u; y < h && k > 0u; y++) {
        for (uint32_t x = 0u; x < w; x++) {
            const int32_t v = hm[((size_t)y * w + x) * c_n];
            if (v < thr || (n == k && v <= boxes[k - 1u].logit) || !is_peak(hm, w, h, c_n, x, y)) {
                continue;
            }
            size_t pos = n;
            while (pos > 0u && boxes[pos - 1u].logit < v) {
                pos--;
            }
            const size_t keep = (n < k) ? n : k - 1u;   // entries that stay
            if (keep > pos) {
                memmove(&boxes[pos + 1u], &boxes[pos], (keep - pos) * sizeof boxes[0]);
            }
            boxes[pos].rect.x = (int32_t)x;   // grid cell until step 3
            boxes[pos].rect.y = (int32_t)y;
            boxes[pos].rect.w = 0;
            boxes[pos].rect.h = 0;
            boxes[pos].logit = (int8_t)v;
            boxes[pos].score_q15 = 0u;
            n = keep + 1u;
        }
    }

    // 3. Boxes, in frame pixels (int64 throughout).
    const int64_t den_x = (int64_t)w * s * 256;   // network input width in Q8
    const int64_t den_y = (int64_t)h * s * 256;
    for (size_t i = 0u; i < n; i++) {
        vd_cnn_box_t *b = &boxes[i];
        const uint32_t x = (uint32_t)b->rect.x, y = (uint32_t)b->rect.y;
        const int8_t *cell = hm + ((size_t)y * w + x) * c_n;
        const int64_t off_x = (c_n == 5u) ? table_at(m, 3u, cell[3]) : 128;
        const int64_t off_y = (c_n == 5u) ? table_at(m, 4u, cell[4]) : 128;
        const int64_t cx = ((int64_t)x * 256 + off_x) * s;
        const int64_t cy = ((int64_t)y * 256 + off_y) * s;
        const int64_t bw = table_at(m, 1u, cell[1]);
        const int64_t bh = table_at(m, 2u, cell[2]);
        const int64_t x0n = cx - bw / 2, x1n = x0n + bw;
        const int64_t y0n = cy - bh / 2, y1n = y0n + bh;
        const int64_t x0 = clamp64(floor_div(x0n * frame_w + den_x / 2, den_x), 0, (int64_t)frame_w - 1);
        const int64_t x1 = clamp64(floor_div(x1n * frame_w + den_x / 2, den_x), x0 + 1, frame_w);
        const int64_t y0 = clamp64(floor_div(y0n * frame_h + den_y / 2, den_y), 0, (int64_t)frame_h - 1);
        const int64_t y1 = clamp64(floor_div(y1n * frame_h + den_y / 2, den_y), y0 + 1, frame_h);
        b->rect.x = (int32_t)x0;
        b->rect.y = (int32_t)y0;
        b->rect.w = (int32_t)(x1 - x0);
        b->rect.h = (int32_t)(y1 - y0);
        b->score_q15 = (uint16_t)table_at(m, 0u, b->logit);
    }
    *count = n;
    return VD_OK;
}

vd_status_t vd_cnn_thr_from_score(const vd_cnn_model_t *m, uint32_t score_q15, int32_t *thr_i8)
{
    VD_VERIFY(m != NULL && thr_i8 != NULL && score_q15 <= (uint32_t)VD_CNN_SCORE_ONE_Q15, VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(vd__cnn_model_ok(m, &c), VD_ERR_STATE);
    // Lower bound in the non-decreasing score table (the loader checked the order).
    int32_t lo = -128;
    int32_t hi = 128;   // one past 127: "no logit reaches it"
    while (lo < hi) {
        const int32_t mid = lo + (hi - lo) / 2;
        if ((uint32_t)table_at(m, 0u, mid) >= score_q15) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    VD_VERIFY(lo <= 127, VD_ERR_RANGE);
    *thr_i8 = lo;
    return VD_OK;
}
