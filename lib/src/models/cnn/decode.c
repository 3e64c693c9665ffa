// SPDX-License-Identifier: MIT
// CNN decoder: boxes from the head (heatmap peaks, top-K, sizes and offsets from the model's decode
// tables), and a score threshold as a logit threshold.
//
// Algorithm (CenterNet-like): 3x3 local maxima of the heatmap channel with a raster-order tie rule (a
// plateau yields its first cell), kept top-K by insertion (logit descending, then raster order); each
// peak's box, made when it enters the top-K, from the Q8 decode tables (channels 1-2 size, 3-4 centre
// offset), in int64, rounded to frame pixels by floor division and clamped to the frame. Row by row
// (vd__cnn_decode_rows), so that a streamed run decodes a ring of head rows (VD_CNN_HEAD_RING). A score
// threshold maps to a logit threshold by binary search of the non-decreasing score table (checked by the
// loader).
// Reference: tools/vdtools/formats/cnn_ref.py (bit-exact); format docs/model-format.md ("CNN kind").
// Bounds: 8 compares per heatmap cell at most, O(K) per inserted peak plus its box; stack ~380 B (Cortex-M7
// -Os).
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

// Head row y in a ring of rr rows of rb bytes (rr = h: the whole head).
static const int8_t *row_at(const int8_t *ring, uint32_t rr, size_t rb, uint32_t y)
{
    return ring + (size_t)(y % rr) * rb;
}

// Heatmap peak test of cell x of row `mid` (above / below: the rows around it, NULL outside the grid):
// > the neighbours before it in raster order, >= the ones after, so a plateau yields exactly its first
// cell in raster order.
static bool is_peak(const int8_t *above, const int8_t *mid, const int8_t *below, uint32_t w, uint32_t c_n,
                    uint32_t x)
{
    const size_t at = (size_t)x * c_n;
    const int32_t v = mid[at];
    const bool left = x > 0u;
    const bool right = x + 1u < w;
    if (above != NULL && ((left && !(v > above[at - c_n])) || !(v > above[at]) || (right && !(v > above[at + c_n])))) {
        return false;
    }
    if ((left && !(v > mid[at - c_n])) || (right && !(v >= mid[at + c_n]))) {
        return false;
    }
    return below == NULL ||
           !((left && !(v >= below[at - c_n])) || !(v >= below[at]) || (right && !(v >= below[at + c_n])));
}

// The box of the peak at cell (x, y) (its channels at cell), in frame pixels (int64 throughout).
static void box_of(const dec_state_t *d, const int8_t *cell, uint32_t x, uint32_t y, vd_cnn_box_t *b)
{
    const vd_cnn_model_t *m = d->m;
    const int64_t s = m->out_stride;
    const bool offsets = m->out_channels == 5u;
    const int64_t den_x = (int64_t)d->w * s * 256;   // network input width in Q8
    const int64_t den_y = (int64_t)d->h * s * 256;
    const int64_t off_x = offsets ? table_at(m, 3u, cell[3]) : 128;
    const int64_t off_y = offsets ? table_at(m, 4u, cell[4]) : 128;
    const int64_t cx = ((int64_t)x * 256 + off_x) * s;
    const int64_t cy = ((int64_t)y * 256 + off_y) * s;
    const int64_t bw = table_at(m, 1u, cell[1]);
    const int64_t bh = table_at(m, 2u, cell[2]);
    const int64_t x0n = cx - bw / 2, x1n = x0n + bw;
    const int64_t y0n = cy - bh / 2, y1n = y0n + bh;
    const int64_t fw = d->frame_w, fh = d->frame_h;
    const int64_t x0 = clamp64(floor_div(x0n * fw + den_x / 2, den_x), 0, fw - 1);
    const int64_t x1 = clamp64(floor_div(x1n * fw + den_x / 2, den_x), x0 + 1, fw);
    const int64_t y0 = clamp64(floor_div(y0n * fh + den_y / 2, den_y), 0, fh - 1);
    const int64_t y1 = clamp64(floor_div(y1n * fh + den_y / 2, den_y), y0 + 1, fh);
    b->rect.x = (int32_t)x0;
    b->rect.y = (int32_t)y0;
    b->rect.w = (int32_t)(x1 - x0);
    b->rect.h = (int32_t)(y1 - y0);
    b->logit = cell[0];
    b->score_q15 = (uint16_t)table_at(m, 0u, cell[0]);
}

vd_status_t vd__cnn_decode_start(const vd_cnn_model_t *m, uint32_t w, uint32_t h, const vd_cnn_decode_opts_t *o,
                                 vd_cnn_box_t *boxes, size_t capacity, dec_state_t *d)
{
    VD_VERIFY(o != NULL && (boxes != NULL || capacity == 0u), VD_ERR_ARG);
    const uint32_t s = m->out_stride;
    VD_VERIFY(w >= 1u && h >= 1u && w <= VD_CNN_MAX_SIDE / s && h <= VD_CNN_MAX_SIDE / s, VD_ERR_ARG);
    VD_VERIFY(o->frame_w >= 1u && o->frame_w <= VD_MAX_DIM && o->frame_h >= 1u && o->frame_h <= VD_MAX_DIM,
              VD_ERR_ARG);
    int32_t thr = m->score_threshold_i8;
    if (o->thr_i8 != VD_CNN_THR_DEFAULT) {
        VD_VERIFY(o->thr_i8 >= -128 && o->thr_i8 <= 127, VD_ERR_ARG);
        thr = o->thr_i8;
    }
    const uint32_t k_max = (o->max_peaks == 0u) ? m->max_peaks : o->max_peaks;
    d->m = m;
    d->boxes = boxes;
    d->k = ((size_t)k_max < capacity) ? (size_t)k_max : capacity;
    d->n = 0u;
    d->thr = thr;
    d->w = w;
    d->h = h;
    d->frame_w = o->frame_w;
    d->frame_h = o->frame_h;
    d->next = 0u;
    return VD_OK;
}

// Peaks in raster order into the top-K array (logit descending, then raster order: an equal logit found
// later goes after), each with its box.
void vd__cnn_decode_rows(dec_state_t *d, const int8_t *ring, uint32_t ring_rows, uint32_t avail)
{
    const uint32_t end = (avail >= d->h) ? d->h : ((avail >= 1u) ? avail - 1u : 0u);
    const uint32_t w = d->w, c_n = d->m->out_channels;
    const size_t rb = (size_t)w * c_n;
    const size_t k = d->k;
    const int32_t thr = d->thr;
    vd_cnn_box_t *boxes = d->boxes;
    size_t n = d->n;
    for (uint32_t y = d->next; y < end && k > 0u; y++) {
        const int8_t *row = row_at(ring, ring_rows, rb, y);
        const int8_t *above = (y > 0u) ? row_at(ring, ring_rows, rb, y - 1u) : NULL;
        const int8_t *below = (y + 1u < d->h) ? row_at(ring, ring_rows, rb, y + 1u) : NULL;
        for (uint32_t x = 0u; x < w; x++) {
            const int32_t v = row[(size_t)x * c_n];
            if (v < thr || (n == k && v <= boxes[k - 1u].logit) || !is_peak(above, row, below, w, c_n, x)) {
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
            box_of(d, row + (size_t)x * c_n, x, y, &boxes[pos]);
            n = keep + 1u;
        }
    }
    d->n = n;
    d->next = (end > d->next) ? end : d->next;
}

vd_status_t vd_cnn_decode(const vd_cnn_model_t *m, const vd_cnn_output_t *out, int32_t thr_i8, uint32_t max_peaks,
                          uint32_t frame_w, uint32_t frame_h, vd_cnn_box_t *boxes, size_t capacity, size_t *count)
{
    VD_VERIFY(m != NULL && out != NULL && count != NULL && (boxes != NULL || capacity == 0u), VD_ERR_ARG);
    chain_t c;
    VD_VERIFY(vd__cnn_model_ok(m, &c), VD_ERR_STATE);
    VD_VERIFY(out->data != NULL && out->c == m->out_channels && out->stride == m->out_stride, VD_ERR_ARG);
    const vd_cnn_decode_opts_t o = {thr_i8, max_peaks, frame_w, frame_h};
    dec_state_t d;
    VD_TRY(vd__cnn_decode_start(m, out->w, out->h, &o, boxes, capacity, &d));
    vd__cnn_decode_rows(&d, out->data, d.h, d.h);
    *count = d.n;
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
