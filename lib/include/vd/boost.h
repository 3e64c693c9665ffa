// SPDX-License-Identifier: MIT
// Boosted-stump verifier (paper 003): selected feature maps of an int8 CNN
// (vd/cnn.h) scored by AdaBoost decision stumps in fixed point.
//
// A .vdm of the boosted kind (format version 4, docs/model-format.md
// "Boosted kind") holds a complete version-3 CNN blob, the list of selected
// maps (tensor, channel) and the stumps. The score of a crop is
//   score = sum over stumps of (x[map][pos] <= thr ? left : right)
// with x the int8 value of the map element, thr int8, left/right int16
// (AdaBoost weights in a Q-format chosen by the exporter); the crop is a
// vehicle when score >= the model's threshold. Integer only, no heap; bit-
// exact with tools/vdtools/formats/boost_vdm.py. Lifetime as vd/cnn.h: the model
// points into the blob, which must outlive it.
//
// Typical use:
//   static vd_boost_model_t m;  vd_boost_load(&m, blob, n);
//   vd_boost_workspace_size(&m, &bytes);            // once
//   vd_boost_score(&m, crop64, 64, ws, bytes, &s);  // s >= m.threshold: vehicle
#ifndef VD_BOOST_H
#define VD_BOOST_H

#include <stddef.h>
#include <stdint.h>

#include "vd/cnn.h"
#include "vd/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VD_BOOST_FORMAT_VERSION 4u
#define VD_BOOST_KIND 3u
#define VD_BOOST_HEADER_SIZE 64u
#define VD_BOOST_STUMP_SIZE 8u
// Largest number of selected maps and of stumps.
#define VD_BOOST_MAX_MAPS 16u
#define VD_BOOST_MAX_STUMPS 4096u

// A loaded model (fill it only with vd_boost_load). Pointers into the blob.
typedef struct vd_boost_model {
    vd_cnn_model_t cnn;                       // the embedded feature network
    const uint8_t *blob;                      // NULL: not loaded
    uint32_t size;                            // total_size
    uint32_t crc32;
    uint32_t n_maps;                          // 1..VD_BOOST_MAX_MAPS
    uint8_t map_tensor[VD_BOOST_MAX_MAPS];    // tensor index 1..n_layers
    uint16_t map_channel[VD_BOOST_MAX_MAPS];  // channel of that tensor
    uint32_t map_len[VD_BOOST_MAX_MAPS];      // elements (w * h) at the crop size
    uint32_t n_features;                      // sum of map_len
    uint32_t n_stumps;                        // 1..VD_BOOST_MAX_STUMPS
    const uint8_t *stumps;                    // n_stumps entries of 8 bytes (docs/model-format.md)
    int32_t threshold;                        // accept when score >= threshold
    int32_t score_span;                       // sum over stumps of max(|left|, |right|) >= |score|, >= 1
    uint16_t crop_w;                          // crop size = the CNN's nominal input size
    uint16_t crop_h;
    char name[17];
} vd_boost_model_t;

// Validates a version-4 blob in place (header, CRC, kind, maps, stumps, and
// the embedded CNN with vd_cnn_load, straight into m->cnn) and fills *m.
// *m is untouched when the blob fails before its CNN loads, zeroed (not
// loaded) when it fails after.
// blob: 4-byte aligned, bytes >= total_size. Returns VD_OK; VD_ERR_ARG for
// NULL arguments, bytes 0 or a misaligned blob; VD_ERR_MODEL for anything
// wrong in the blob (including every reason vd_cnn_load rejects the CNN).
// Time O(total_size); stack: own frame 280 bytes (Cortex-M7 -Os, -fstack-usage)
// plus vd_cnn_load's.
VD_API vd_status_t vd_boost_load(vd_boost_model_t *m, const void *blob, size_t bytes);

// Workspace bytes of one score: the CNN at crop_w x crop_h with every tensor
// kept (VD_CNN_KEEP_TENSORS, the selected maps are read after the run).
VD_API vd_status_t vd_boost_workspace_size(const vd_boost_model_t *m, size_t *bytes);

// Score of one crop_w x crop_h uint8 crop (row stride stride_bytes).
// Returns VD_OK; VD_ERR_ARG for NULL pointers or stride_bytes < crop_w;
// VD_ERR_STATE if m is not loaded; VD_ERR_WORKSPACE for a short/misaligned ws.
// Time: the CNN (vd_cnn_macs at the crop size) + n_stumps compares. Stack:
// own frames 160 + 112 bytes (Cortex-M7 -Os) plus vd_cnn_run_ex's or vd_cnn_tensor's.
VD_API vd_status_t vd_boost_score(const vd_boost_model_t *m, const uint8_t *crop, uint32_t stride_bytes, void *ws,
                           size_t bytes, int32_t *score);

// The feature vector (the selected maps concatenated, raster order) of one
// crop, for parity tests and training. capacity >= m->n_features.
VD_API vd_status_t vd_boost_features(const vd_boost_model_t *m, const uint8_t *crop, uint32_t stride_bytes, void *ws,
                              size_t bytes, int8_t *features, size_t capacity);

// The model's accept threshold and feature count (bindings without the struct layout).
VD_API vd_status_t vd_boost_threshold(const vd_boost_model_t *m, int32_t *threshold, uint32_t *n_features);

// sizeof(vd_boost_model_t), for bindings.
VD_API size_t vd_boost_model_bytes(void);

#ifdef __cplusplus
}
#endif
#endif
