// SPDX-License-Identifier: MIT
// Fuzz harness: external contour tracing on arbitrary masks, strides and capacities.
//
// Input layout: w, h (1..64), row padding, point capacity, contour capacity,
// flags (bit-packed pixels, chain array, short workspace), then pixels.
// Checks the documented status and, for every contour written: points are
// foreground pixels of the mask, consecutive points (cyclically) are
// 8-neighbours, the chain codes describe exactly those moves, the box is the
// points' bounding box, and contours tile points[0 .. n_points).
#include "fuzz_common.h"
#include "vd/contour.h"

static const int8_t k_dx[8] = {1, 1, 0, -1, -1, -1, 0, 1};
static const int8_t k_dy[8] = {0, -1, -1, -1, 0, 1, 1, 1};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader_t r;
    fz_init(&r, data, size);
    const uint32_t w = 1u + fz_u8(&r) % 64u;
    const uint32_t h = 1u + fz_u8(&r) % 64u;
    const size_t stride = w + fz_u8(&r) % 8u;
    const uint16_t pc_raw = fz_u16(&r);
    const size_t ccap = fz_u8(&r) % 64u;
    const uint8_t flags = fz_u8(&r);
    // Mostly a capacity that fits (4 points per pixel is the documented bound), sometimes a tight one.
    const size_t pcap = (flags & 8u) ? (size_t)(pc_raw % 512u) : 4u * (size_t)w * h;

    const size_t mbytes = fz_plane_bytes(stride, h, w);
    uint8_t *mask = fz_alloc(mbytes);
    fz_fill_plane(&r, mask, w, h, stride, (flags & 1u) != 0u, 255u);
    vd_view_u8_t v = {mask, w, h, stride};

    size_t wsb = 0u;
    FZ_CHECK(vd_contour_workspace_size(w, h, &wsb) == VD_OK);
    const int short_ws = (flags & 4u) != 0u;
    const size_t give = short_ws ? wsb - 1u : wsb;
    void *ws = fz_alloc(give);
    vd_point_t *pts = pcap ? fz_alloc(pcap * sizeof(vd_point_t)) : NULL;
    uint8_t *chain = ((flags & 2u) && pcap) ? fz_alloc(pcap) : NULL;
    vd_contour_t *cs = ccap ? fz_alloc(ccap * sizeof(vd_contour_t)) : NULL;
    size_t nc = 777u, np = 777u;

    // A NULL points/contours array is only legal with capacity 0; the API takes
    // non-NULL pointers, so hand a dummy for capacity 0.
    vd_point_t dummy_pt;
    vd_contour_t dummy_c;
    vd_status_t st = vd_contour_find_external(&v, ws, give, pts ? pts : &dummy_pt, chain, pcap,
                                               cs ? cs : &dummy_c, ccap, &nc, &np);
    if (short_ws) {
        FZ_CHECK(st == VD_ERR_WORKSPACE);
    } else {
        FZ_CHECK(st == VD_OK || st == VD_ERR_CAPACITY);
        FZ_CHECK(nc <= ccap && np <= pcap);
        size_t total = 0u;
        for (size_t i = 0u; i < nc; i++) {
            const vd_contour_t *c = &cs[i];
            FZ_CHECK(c->length >= 1u);
            FZ_CHECK((size_t)c->first + c->length <= np);
            total += c->length;
            int32_t x0 = INT32_MAX, y0 = INT32_MAX, x1 = INT32_MIN, y1 = INT32_MIN;
            for (uint32_t k = 0u; k < c->length; k++) {
                const vd_point_t p = pts[c->first + k];
                FZ_CHECK(p.x >= 0 && p.y >= 0 && (uint32_t)p.x < w && (uint32_t)p.y < h);
                FZ_CHECK(mask[(size_t)p.y * stride + (size_t)p.x] != 0u);
                x0 = p.x < x0 ? p.x : x0;
                y0 = p.y < y0 ? p.y : y0;
                x1 = p.x > x1 ? p.x : x1;
                y1 = p.y > y1 ? p.y : y1;
                const vd_point_t q = pts[c->first + (k + 1u) % c->length];
                const int dx = q.x - p.x, dy = q.y - p.y;
                if (c->length == 1u) {
                    if (chain) {
                        FZ_CHECK(chain[c->first] == VD_CONTOUR_CHAIN_NONE);
                    }
                    continue;
                }
                FZ_CHECK(dx >= -1 && dx <= 1 && dy >= -1 && dy <= 1 && (dx != 0 || dy != 0));
                if (chain) {
                    const uint8_t code = chain[c->first + k];
                    FZ_CHECK(code < 8u && k_dx[code] == dx && k_dy[code] == dy);
                }
            }
            FZ_CHECK(c->box.x == x0 && c->box.y == y0 && c->box.w == x1 - x0 + 1 && c->box.h == y1 - y0 + 1);
        }
        FZ_CHECK(total == np);
        // Contours are disjoint (each an external border of a different region).
        if (st == VD_OK) {
            int any = 0;
            for (size_t i = 0u; i < (size_t)h * stride && !any; i++) {
                any = (i % stride) < w && mask[i] != 0u;
            }
            FZ_CHECK(any == (nc > 0u));
        }
    }
    free(cs);
    free(chain);
    free(pts);
    free(ws);
    free(mask);
    return 0;
}
