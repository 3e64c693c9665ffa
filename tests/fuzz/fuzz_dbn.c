// SPDX-License-Identifier: MIT
// Fuzz harness: the .vdm model loader (vd_dbn_load) and inference on whatever it accepts (vd_dbn_classify).
//
// Input: one control byte, then the blob (or a plain blob starting with "VDMF"). Control bit 0 set: the harness
// rewrites the blob's CRC-32 field (when the claimed total size lies inside
// the input) so mutations get past the checksum and reach the structural
// checks; bit 1: the blob is offered with 1..3 extra trailing bytes (flash
// padding, which the loader must ignore). A loaded model must be
// self-consistent and must classify any input with an exactly sized
// workspace; a short workspace must give VD_ERR_WORKSPACE.
#include "fuzz_common.h"
#include "vd/dbn.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1u) {
        vd_dbn_model_t m;
        FZ_CHECK(vd_dbn_load(&m, "", 0u) == VD_ERR_ARG);
        return 0;
    }
    // A plain .vdm file (models/*.vdm replayed by CTest) is taken as it is, without a control byte.
    const int plain = size >= 4u && memcmp(data, "VDMF", 4u) == 0;
    const uint8_t ctl = plain ? 0u : data[0];
    const size_t n = plain ? size : size - 1u;
    const size_t pad = (ctl & 2u) ? 1u + (ctl >> 6) % 3u : 0u;
    uint8_t *blob = fz_alloc(n + pad);
    if (n) {
        memcpy(blob, plain ? data : data + 1, n);
    }
    memset(blob + n, 0xFF, pad);
    if ((ctl & 1u) && n >= VD_DBN_HEADER_SIZE) {
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
    vd_dbn_model_t m;
    memset(&m, 0x5A, sizeof(m));
    vd_status_t st = bytes ? vd_dbn_load(&m, blob, bytes) : VD_ERR_MODEL;
    FZ_CHECK(st == VD_OK || st == VD_ERR_MODEL);
    if (st == VD_OK) {
        FZ_CHECK(m.blob == blob && m.size <= bytes && m.size >= VD_DBN_HEADER_SIZE);
        FZ_CHECK(m.n_layers >= 1u && m.n_layers <= VD_DBN_MAX_LAYERS);
        FZ_CHECK(m.input_w >= 1u && m.input_w <= VD_DBN_MAX_INPUT_DIM);
        FZ_CHECK(m.input_h >= 1u && m.input_h <= VD_DBN_MAX_INPUT_DIM);
        FZ_CHECK(m.input_mode == VD_DBN_INPUT_GREY || m.input_mode == VD_DBN_INPUT_SHAPE);
        FZ_CHECK(m.name[16] == '\0');
        FZ_CHECK(m.layers[0].in == (uint32_t)m.input_w * m.input_h);
        FZ_CHECK(m.layers[m.n_layers - 1u].out == 1u);
        for (uint32_t l = 0u; l < m.n_layers; l++) {
            const vd_dbn_layer_t *L = &m.layers[l];
            FZ_CHECK(L->out >= 1u && L->out <= m.max_units && L->in >= 1u && L->in <= VD_DBN_MAX_UNITS);
            if (l > 0u) {
                FZ_CHECK(L->in == m.layers[l - 1u].out);
            }
            // Every array lies inside the blob's total size.
            const uint8_t *end = blob + m.size;
            FZ_CHECK((const uint8_t *)L->weights >= blob && (const uint8_t *)L->weights + (size_t)L->in * L->out <= end);
            FZ_CHECK(L->bias_le >= blob && L->bias_le + 4u * (size_t)L->out <= end);
            FZ_CHECK(L->mult_le >= blob && L->mult_le + 4u * (size_t)L->out <= end);
            FZ_CHECK((const uint8_t *)L->shift >= blob && (const uint8_t *)L->shift + L->out <= end);
        }
        size_t wsb = 0u;
        FZ_CHECK(vd_dbn_workspace_size(&m, &wsb) == VD_OK && wsb > 0u);
        const size_t in_n = (size_t)m.input_w * m.input_h;
        uint8_t *input = fz_alloc(in_n);
        void *ws = fz_alloc(wsb);
        uint8_t score = 0u;
        FZ_CHECK(vd_dbn_classify(&m, input, ws, wsb - 1u, &score) == VD_ERR_WORKSPACE);
        // Three inputs: all 0, all 255, and a pattern from the blob itself.
        for (int k = 0; k < 3; k++) {
            for (size_t i = 0u; i < in_n; i++) {
                input[i] = k == 0 ? 0u : k == 1 ? 255u : blob[i % bytes];
            }
            uint8_t s1 = 0u, s2 = 1u;
            FZ_CHECK(vd_dbn_classify(&m, input, ws, wsb, &s1) == VD_OK);
            FZ_CHECK(vd_dbn_classify(&m, input, ws, wsb, &s2) == VD_OK);
            FZ_CHECK(s1 == s2);  // deterministic, no state kept in the model or workspace
        }
        free(ws);
        free(input);
    }
    free(blob);
    return 0;
}
