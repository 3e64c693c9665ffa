// SPDX-License-Identifier: MIT
// Boosted-stump verifier over selected int8 CNN feature maps (paper 003).
//
// Algorithm: run the embedded CNN on the crop with every tensor kept, take
// the selected maps (tensor, channel) and add, per stump, its left value
// when the int8 feature is <= its threshold, else its right value. The sum
// is an int32: |value| <= 32767 and n_stumps <= 4096 give |score| < 2^27.
// Reference: Freund & Schapire's AdaBoost with decision stumps as trained
// by tools/vdtools/training/boost_train.py; integer reference tools/vdtools/formats/boost_vdm.py
// (bit-exact). Bounds: load O(total_size); score = one CNN run plus
// n_stumps compares; no heap, no float.
#include "vd/boost.h"

#include "models/blob_internal.h"
#include "core/crc32.h"
#include "internal/vd_internal.h"

#include <string.h>

// Bytes 0..15: the container (magic, version, sizes; models/blob_internal.h checks it).
#define H_CRC 12u
#define H_KIND 16u
#define H_N_MAPS 17u
#define H_N_STUMPS 18u
#define H_CNN_OFF 20u
#define H_CNN_LEN 24u
#define H_MAPS_OFF 28u
#define H_STUMPS_OFF 32u
#define H_THRESHOLD 36u
#define H_NAME 40u
#define H_NAME_LEN 16u
#define H_RES 56u
#define VALUE_MAX 32767

static int32_t rd_i16(const uint8_t *p)
{
    const uint32_t u = vd_blob_u16(p);
    return (u >= 0x8000u) ? (int32_t)u - 65536 : (int32_t)u;
}

static int32_t i8_of(uint8_t u)
{
    return (u >= 0x80u) ? (int32_t)u - 256 : (int32_t)u;
}

// Downsample factor of tensor t of a loaded CNN (the loader has checked the chain).
static uint32_t factor_of(const vd_cnn_model_t *c, uint32_t t)
{
    uint32_t f[VD_CNN_MAX_TENSORS];
    f[0] = 1u;
    for (uint32_t l = 0u; l < t; l++) {
        const vd_cnn_layer_t *L = &c->layers[l];
        uint32_t v = f[L->in];
        if (L->op == VD_CNN_OP_CONV3X3 || L->op == VD_CNN_OP_DW3X3 || L->op == VD_CNN_OP_CONV5X5) {
            v *= L->stride;
        } else if (L->op == VD_CNN_OP_MAXPOOL2) {
            v *= 2u;
        } else if (L->op == VD_CNN_OP_UPSAMPLE2) {
            v /= 2u;
        }
        f[l + 1u] = v;
    }
    return f[t];
}

static vd_status_t finish_load(vd_boost_model_t *m, const uint8_t *b, uint32_t total, uint32_t crc,
                               uint32_t maps_off, uint32_t st_off, uint32_t n_maps, uint32_t n_stumps,
                               uint32_t cnn_len);

size_t vd_boost_model_bytes(void)
{
    return sizeof(vd_boost_model_t);
}

vd_status_t vd_boost_load(vd_boost_model_t *m, const void *blob, size_t bytes)
{
    VD_VERIFY(m != NULL && blob != NULL && bytes != 0u, VD_ERR_ARG);
    VD_VERIFY(((uintptr_t)blob % 4u) == 0u, VD_ERR_ARG);
    const uint8_t *b = (const uint8_t *)blob;
    uint16_t version;
    uint32_t total;
    VD_TRY(vd_blob_container(b, bytes, VD_BOOST_FORMAT_VERSION, VD_BOOST_FORMAT_VERSION, VD_BOOST_HEADER_SIZE,
                             &version, &total));
    const uint32_t crc = vd_blob_u32(b + H_CRC);   // checked by vd_blob_container
    VD_VERIFY(b[H_KIND] == VD_BOOST_KIND, VD_ERR_MODEL);
    const uint32_t n_maps = b[H_N_MAPS];
    const uint32_t n_stumps = vd_blob_u16(b + H_N_STUMPS);
    const uint32_t cnn_off = vd_blob_u32(b + H_CNN_OFF);
    const uint32_t cnn_len = vd_blob_u32(b + H_CNN_LEN);
    const uint32_t maps_off = vd_blob_u32(b + H_MAPS_OFF);
    const uint32_t st_off = vd_blob_u32(b + H_STUMPS_OFF);
    VD_VERIFY(n_maps >= 1u && n_maps <= VD_BOOST_MAX_MAPS, VD_ERR_MODEL);
    VD_VERIFY(n_stumps >= 1u && n_stumps <= VD_BOOST_MAX_STUMPS, VD_ERR_MODEL);
    VD_VERIFY(vd_blob_name_ok(b + H_NAME, H_NAME_LEN), VD_ERR_MODEL);
    VD_VERIFY(vd_blob_all_zero(b + H_RES, VD_BOOST_HEADER_SIZE - H_RES), VD_ERR_MODEL);
    // The three sections in order, 4-byte aligned, disjoint, inside the blob.
    const uint32_t maps_len = 4u * n_maps;
    const uint32_t st_len = VD_BOOST_STUMP_SIZE * n_stumps;
    VD_VERIFY(vd_blob_segment_ok(maps_off, maps_len, VD_BOOST_HEADER_SIZE, total), VD_ERR_MODEL);
    VD_VERIFY(vd_blob_segment_ok(st_off, st_len, maps_off + maps_len, total), VD_ERR_MODEL);
    VD_VERIFY(vd_blob_segment_ok(cnn_off, cnn_len, st_off + st_len, total), VD_ERR_MODEL);
    VD_VERIFY(cnn_len >= VD_CNN_HEADER_SIZE, VD_ERR_MODEL);

    // The CNN goes straight into *m (a vd_cnn_model_t is ~1.6 KB: not on the stack).
    VD_VERIFY(vd_cnn_load(&m->cnn, b + cnn_off, cnn_len) == VD_OK, VD_ERR_MODEL);
    const vd_status_t st = finish_load(m, b, total, crc, maps_off, st_off, n_maps, n_stumps, cnn_len);
    if (st != VD_OK) {
        memset(m, 0, sizeof *m);   // not loaded
    }
    return st;
}

// The checks after the embedded CNN loaded into m->cnn; fills the rest of *m.
static vd_status_t finish_load(vd_boost_model_t *m, const uint8_t *b, uint32_t total, uint32_t crc,
                               uint32_t maps_off, uint32_t st_off, uint32_t n_maps, uint32_t n_stumps,
                               uint32_t cnn_len)
{
    const vd_cnn_model_t *cnn = &m->cnn;
    VD_VERIFY(cnn->size == cnn_len, VD_ERR_MODEL);
    const uint32_t cw = cnn->input_w, ch = cnn->input_h;
    uint32_t len[VD_BOOST_MAX_MAPS];
    uint32_t n_feat = 0u;
    for (uint32_t i = 0u; i < n_maps; i++) {
        const uint8_t *e = b + maps_off + 4u * i;
        const uint32_t t = e[0];
        const uint32_t c = vd_blob_u16(e + 2);
        VD_VERIFY(e[1] == 0u && t >= 1u && t <= cnn->n_layers && c < cnn->layers[t - 1u].cout, VD_ERR_MODEL);
        const uint32_t f = factor_of(cnn, t);
        len[i] = (cw / f) * (ch / f);   // input size is a multiple of every factor (vd_cnn_load)
        n_feat += len[i];
    }
    int32_t span = 0;   // <= 4096 * 32767 < 2^27
    for (uint32_t k = 0u; k < n_stumps; k++) {
        const uint8_t *s = b + st_off + VD_BOOST_STUMP_SIZE * k;
        const uint32_t pos = vd_blob_u16(s);
        const uint32_t mi = s[2];
        const int32_t lv = rd_i16(s + 4), rv = rd_i16(s + 6);
        VD_VERIFY(mi < n_maps && pos < len[mi], VD_ERR_MODEL);
        VD_VERIFY(lv >= -VALUE_MAX && rv >= -VALUE_MAX, VD_ERR_MODEL);
        const int32_t al = (lv < 0) ? -lv : lv, ar = (rv < 0) ? -rv : rv;
        span += (al > ar) ? al : ar;
    }
    m->blob = b;
    m->size = total;
    m->crc32 = crc;
    m->n_maps = n_maps;
    for (uint32_t i = 0u; i < n_maps; i++) {
        const uint8_t *e = b + maps_off + 4u * i;
        m->map_tensor[i] = e[0];
        m->map_channel[i] = vd_blob_u16(e + 2);
        m->map_len[i] = len[i];
    }
    m->n_features = n_feat;
    m->n_stumps = n_stumps;
    m->stumps = b + st_off;
    m->threshold = (int32_t)vd_blob_u32(b + H_THRESHOLD);
    m->score_span = (span < 1) ? 1 : span;
    m->crop_w = (uint16_t)cw;
    m->crop_h = (uint16_t)ch;
    memcpy(m->name, b + H_NAME, H_NAME_LEN);
    m->name[H_NAME_LEN] = '\0';
    return VD_OK;
}

static bool loaded(const vd_boost_model_t *m)
{
    return m->blob != NULL && m->n_maps >= 1u && m->n_maps <= VD_BOOST_MAX_MAPS && m->n_stumps >= 1u &&
           m->n_stumps <= VD_BOOST_MAX_STUMPS && m->stumps != NULL;
}

vd_status_t vd_boost_workspace_size(const vd_boost_model_t *m, size_t *bytes)
{
    VD_VERIFY(m != NULL && bytes != NULL, VD_ERR_ARG);
    VD_VERIFY(loaded(m), VD_ERR_STATE);
    return vd_cnn_workspace_size_ex(&m->cnn, m->crop_w, m->crop_h, VD_CNN_KEEP_TENSORS, bytes);
}

// The selected maps of a run: data pointer, channel step and channel offset.
typedef struct maps {
    const int8_t *p[VD_BOOST_MAX_MAPS];
    uint32_t step[VD_BOOST_MAX_MAPS];
} maps_t;

static vd_status_t run_maps(const vd_boost_model_t *m, const uint8_t *crop, uint32_t stride_bytes, void *ws,
                            size_t bytes, maps_t *mp)
{
    VD_VERIFY(m != NULL && crop != NULL, VD_ERR_ARG);
    VD_VERIFY(loaded(m), VD_ERR_STATE);
    VD_VERIFY(stride_bytes >= m->crop_w, VD_ERR_ARG);
    vd_cnn_output_t out;
    VD_TRY(vd_cnn_run_ex(&m->cnn, crop, m->crop_w, m->crop_h, stride_bytes, VD_CNN_KEEP_TENSORS, ws, bytes, &out));
    for (uint32_t i = 0u; i < m->n_maps; i++) {
        vd_cnn_output_t t;
        VD_TRY(vd_cnn_tensor(&m->cnn, ws, bytes, m->crop_w, m->crop_h, m->map_tensor[i], &t));
        VD_VERIFY(m->map_channel[i] < t.c && t.w * t.h == m->map_len[i], VD_ERR_STATE);
        mp->p[i] = t.data + m->map_channel[i];
        mp->step[i] = t.c;
    }
    return VD_OK;
}

vd_status_t vd_boost_score(const vd_boost_model_t *m, const uint8_t *crop, uint32_t stride_bytes, void *ws,
                           size_t bytes, int32_t *score)
{
    VD_VERIFY(score != NULL, VD_ERR_ARG);
    maps_t mp;
    VD_TRY(run_maps(m, crop, stride_bytes, ws, bytes, &mp));
    int32_t sum = 0;
    for (uint32_t k = 0u; k < m->n_stumps; k++) {
        const uint8_t *s = m->stumps + VD_BOOST_STUMP_SIZE * k;
        const uint32_t pos = vd_blob_u16(s);
        const uint32_t mi = s[2];
        const int32_t x = mp.p[mi][(size_t)pos * mp.step[mi]];
        sum += (x <= i8_of(s[3])) ? rd_i16(s + 4) : rd_i16(s + 6);
    }
    *score = sum;
    return VD_OK;
}

vd_status_t vd_boost_features(const vd_boost_model_t *m, const uint8_t *crop, uint32_t stride_bytes, void *ws,
                              size_t bytes, int8_t *features, size_t capacity)
{
    VD_VERIFY(features != NULL && m != NULL && capacity >= m->n_features, VD_ERR_ARG);
    maps_t mp;
    VD_TRY(run_maps(m, crop, stride_bytes, ws, bytes, &mp));
    size_t o = 0u;
    for (uint32_t i = 0u; i < m->n_maps; i++) {
        for (uint32_t j = 0u; j < m->map_len[i]; j++) {
            features[o++] = mp.p[i][(size_t)j * mp.step[i]];
        }
    }
    return VD_OK;
}

vd_status_t vd_boost_threshold(const vd_boost_model_t *m, int32_t *threshold, uint32_t *n_features)
{
    VD_VERIFY(m != NULL && threshold != NULL && n_features != NULL, VD_ERR_ARG);
    VD_VERIFY(loaded(m), VD_ERR_STATE);
    *threshold = m->threshold;
    *n_features = m->n_features;
    return VD_OK;
}
