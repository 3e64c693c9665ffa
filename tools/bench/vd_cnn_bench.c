// SPDX-License-Identifier: MIT
// Benchmark of the int8 CNN (vd_cnn_run + vd_cnn_decode): median ms per frame and multiply-adds per second.
//
// Usage: vd_cnn_bench [--iters N] [--width W] [--height H] [--model m.vdm] [--seed S] [--write-model out.vdm]
// Without --model the network is the reference shape of the issue (random symmetric int8 weights,
// realistic multipliers): conv3x3 s2 1->16; dw s2 16 + pw 16->24; dw 24 + pw 24->32; dw s2 32 + pw 32->48;
// dw 48 + pw 48->64; dw s2 64 + pw 64->96; dw 96 + pw 96->96; pw 96->48; upsample; concat(64) -> 112;
// dw 112 + pw 112->48; pw 48->24; upsample; concat(32) -> 56; dw 56 + pw 56->24; dw 24 + pw 24->5
// (head at stride 4), input 320x256 by default. The frame is a smooth random image (changed per
// iteration so no result is cached). One warm-up run, then N timed runs (clock_gettime MONOTONIC);
// prints the median and the minimum. Single thread; build with CMAKE_BUILD_TYPE=Release for figures.
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "vd/vd.h"

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e3 + (double)t.tv_nsec * 1e-6;
}

static void die(const char *msg, const char *arg)
{
    fprintf(stderr, "vd_cnn_bench: %s%s%s\n", msg, arg ? ": " : "", arg ? arg : "");
    exit(2);
}

static void *xalloc(size_t n)
{
    void *p = NULL;
    if (posix_memalign(&p, 64, n ? n : 8u) != 0) {
        die("out of memory", NULL);
    }
    return p;
}

static uint32_t g_rng = 0x12345678u;

static uint32_t rnd(void)
{
    uint32_t x = g_rng;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    g_rng = x;
    return x;
}

// ------------------------------------------------------------ blob writer (docs/model-format.md, CNN kind)

typedef struct bl {
    uint8_t op, stride, in, in2;
    uint16_t cin, cout;
    int8_t zp, amin, amax;
} bl_t;

static uint8_t *g_blob;
static uint32_t g_pos;

static void wr16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)(v >> 8);
}

static void wr32(uint8_t *p, uint32_t v)
{
    wr16(p, v & 0xFFFFu);
    wr16(p + 2, v >> 16);
}

static uint32_t put(uint32_t len)
{
    g_pos = (g_pos + 3u) & ~3u;
    const uint32_t at = g_pos;
    g_pos += len;
    return at;
}

static int weighted(uint32_t op)
{
    return op >= VD_CNN_OP_CONV3X3 && op <= VD_CNN_OP_PW1X1;
}

// A random model with the given layers: weights uniform int8, biases small,
// multipliers so that outputs spread over the int8 range (scale ~ 1/(16 sqrt K)).
static uint32_t write_model(const bl_t *L, uint32_t n, uint16_t w, uint16_t h, uint8_t out_stride, uint8_t n_ch)
{
    uint64_t cap = 4096u;
    for (uint32_t l = 0u; l < n; l++) {
        cap += 9u * (uint64_t)L[l].cin * L[l].cout + 16u * (uint64_t)L[l].cout + 16u;
    }
    cap += 1024u * 5u + 8u;
    g_blob = xalloc((size_t)cap);
    memset(g_blob, 0, (size_t)cap);
    g_pos = 128u + 32u * n;
    for (uint32_t l = 0u; l < n; l++) {
        uint8_t *e = g_blob + 128u + 32u * l;
        e[0] = L[l].op;
        e[1] = L[l].stride;
        e[2] = L[l].in;
        e[3] = L[l].in2;
        wr16(e + 4, L[l].cin);
        wr16(e + 6, L[l].cout);
        e[8] = (uint8_t)L[l].zp;
        e[9] = (uint8_t)L[l].amin;
        e[10] = (uint8_t)L[l].amax;
        if (!weighted(L[l].op)) {
            continue;
        }
        const uint32_t k = L[l].op == VD_CNN_OP_CONV3X3 ? 9u * L[l].cin : L[l].op == VD_CNN_OP_DW3X3 ? 9u : L[l].cin;
        const uint32_t wl = k * L[l].cout;
        const uint32_t ow = put(wl);
        // Symmetric int8 weights, -127..127, as per-channel symmetric quantisation makes them.
        for (uint32_t i = 0u; i < wl; i++) {
            g_blob[ow + i] = (uint8_t)(int8_t)((int32_t)(rnd() % 255u) - 127);
        }
        const uint32_t ob = put(4u * L[l].cout);
        const uint32_t om = put(4u * L[l].cout);
        const uint32_t os = put(L[l].cout);
        // Output ~ acc / (16 sqrt(K) * 64): shift from log2 of that divisor.
        uint32_t sh = 10u;
        while ((1u << (sh - 10u)) * (1u << (sh - 10u)) < k) {
            sh++;
        }
        for (uint32_t o = 0u; o < L[l].cout; o++) {
            wr32(g_blob + ob + 4u * o, (uint32_t)((int32_t)(rnd() % 2001u) - 1000));
            wr32(g_blob + om + 4u * o, 0x40000000u + (rnd() & 0x3FFFFFFFu));
            g_blob[os + o] = (uint8_t)(-(int32_t)sh);
        }
        wr32(e + 12, ow);
        wr32(e + 16, ob);
        wr32(e + 20, om);
        wr32(e + 24, os);
    }
    const uint32_t dec = put(4u * 256u * n_ch);
    for (uint32_t ch = 0u; ch < n_ch; ch++) {
        for (uint32_t i = 0u; i < 256u; i++) {
            const uint32_t v = ch == 0u ? i * 128u : ch <= 2u ? i * 64u : i;
            wr32(g_blob + dec + 4u * (ch * 256u + i), v);
        }
    }
    const uint32_t total = (g_pos + 3u) & ~3u;
    memcpy(g_blob, "VDMF", 4);
    wr16(g_blob + 4, 3u);
    wr16(g_blob + 6, 128u);
    wr32(g_blob + 8, total);
    g_blob[16] = 2u;
    g_blob[17] = 1u;   // percentile stretch 1..99 %
    g_blob[18] = (uint8_t)n;
    g_blob[19] = n_ch;
    wr16(g_blob + 20, w);
    wr16(g_blob + 22, h);
    wr16(g_blob + 24, 10u);
    wr16(g_blob + 26, 990u);
    wr16(g_blob + 28, 16u);
    g_blob[30] = 0x80u;
    g_blob[31] = out_stride;
    wr32(g_blob + 32, 128u);
    wr32(g_blob + 36, dec);
    g_blob[40] = 40u;
    wr16(g_blob + 42, 100u);
    memcpy(g_blob + 48, "bench-ref", 9);
    // CRC-32 (zlib) of [16, total).
    uint32_t c = 0xFFFFFFFFu;
    for (uint32_t i = 16u; i < total; i++) {
        c ^= g_blob[i];
        for (int b = 0; b < 8; b++) {
            c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
        }
    }
    wr32(g_blob + 12, ~c);
    return total;
}

// The reference network of the issue; returns the layer count.
static uint32_t reference_layers(bl_t *L)
{
    uint32_t n = 0u;
    // Every tensor has zero point -128 (ReLU outputs: act_min = out_zp = -128).
#define ADD(op_, s_, in_, in2_, ci_, co_)                                                               \
    do {                                                                                               \
        const bl_t x_ = {(uint8_t)(op_), (uint8_t)(s_), (uint8_t)(in_), (uint8_t)(in2_), (uint16_t)(ci_), \
                         (uint16_t)(co_), -128, -128, 127};                                            \
        L[n++] = x_;                                                                                   \
    } while (0)
    const uint32_t C = VD_CNN_OP_CONV3X3, D = VD_CNN_OP_DW3X3, P = VD_CNN_OP_PW1X1, U = VD_CNN_OP_UPSAMPLE2,
                   K = VD_CNN_OP_CONCAT;
    ADD(C, 2, 0, 0, 1, 16);      // t1  f2  16
    ADD(D, 2, 1, 0, 16, 16);     // t2  f4
    ADD(P, 1, 2, 0, 16, 24);     // t3  f4  24
    ADD(D, 1, 3, 0, 24, 24);     // t4
    ADD(P, 1, 4, 0, 24, 32);     // t5  f4  32  (skip 2)
    ADD(D, 2, 5, 0, 32, 32);     // t6  f8
    ADD(P, 1, 6, 0, 32, 48);     // t7  f8  48
    ADD(D, 1, 7, 0, 48, 48);     // t8
    ADD(P, 1, 8, 0, 48, 64);     // t9  f8  64  (skip 1)
    ADD(D, 2, 9, 0, 64, 64);     // t10 f16
    ADD(P, 1, 10, 0, 64, 96);    // t11 f16 96
    ADD(D, 1, 11, 0, 96, 96);    // t12
    ADD(P, 1, 12, 0, 96, 96);    // t13
    ADD(P, 1, 13, 0, 96, 48);    // t14 f16 48
    ADD(U, 1, 14, 0, 48, 48);    // t15 f8
    ADD(K, 1, 15, 9, 48, 112);   // t16 f8  112
    ADD(D, 1, 16, 0, 112, 112);  // t17
    ADD(P, 1, 17, 0, 112, 48);   // t18 f8  48
    ADD(P, 1, 18, 0, 48, 24);    // t19 f8  24
    ADD(U, 1, 19, 0, 24, 24);    // t20 f4
    ADD(K, 1, 20, 5, 24, 56);    // t21 f4  56
    ADD(D, 1, 21, 0, 56, 56);    // t22
    ADD(P, 1, 22, 0, 56, 24);    // t23 f4  24
    ADD(D, 1, 23, 0, 24, 24);    // t24
    ADD(P, 1, 24, 0, 24, 5);     // t25 f4  5 (head: no ReLU)
#undef ADD
    L[n - 1u].zp = 0;   // the head is not a ReLU output
    return n;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    int iters = 50;
    uint32_t w = 320u, h = 256u;
    const char *model_path = NULL, *write_path = NULL;
    uint32_t flags = 0u;
    int compare = 0, prepared = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--stream")) {
            flags = VD_CNN_STREAM;
        } else if (!strcmp(argv[i], "--compare")) {
            compare = 1;
        } else if (!strcmp(argv[i], "--prepared")) {
            prepared = 1;
        } else if (!strcmp(argv[i], "--iters") && i + 1 < argc) {
            iters = atoi(argv[++i]);
        } else if (!strcmp(argv[i], "--width") && i + 1 < argc) {
            w = (uint32_t)atoi(argv[++i]);
        } else if (!strcmp(argv[i], "--height") && i + 1 < argc) {
            h = (uint32_t)atoi(argv[++i]);
        } else if (!strcmp(argv[i], "--model") && i + 1 < argc) {
            model_path = argv[++i];
        } else if (!strcmp(argv[i], "--write-model") && i + 1 < argc) {
            write_path = argv[++i];
        } else if (!strcmp(argv[i], "--seed") && i + 1 < argc) {
            g_rng = (uint32_t)strtoul(argv[++i], NULL, 10) | 1u;
        } else {
            fprintf(stderr, "usage: vd_cnn_bench [--iters N] [--width W] [--height H] [--model m.vdm] "
                            "[--write-model out.vdm] [--seed S] [--stream | --compare] [--prepared]\n"
                            "  --stream   time the row-banded executor (VD_CNN_STREAM) instead of the whole-plane one\n"
                            "  --compare  time both, alternating in one process, and check their heads are equal\n"
                            "  --prepared the model's weights packed once (vd_cnn_prepare; x86) as onnxruntime does\n");
            return 2;
        }
    }
    if (iters < 1) {
        iters = 1;
    }
    uint32_t total = 0u;
    if (model_path != NULL) {
        FILE *f = fopen(model_path, "rb");
        if (f == NULL) {
            die("cannot open", model_path);
        }
        fseek(f, 0, SEEK_END);
        const long len = ftell(f);
        fseek(f, 0, SEEK_SET);
        if (len <= 0) {
            die("empty model", model_path);
        }
        g_blob = xalloc((size_t)len);
        if (fread(g_blob, 1, (size_t)len, f) != (size_t)len) {
            die("cannot read", model_path);
        }
        fclose(f);
        total = (uint32_t)len;
    } else {
        bl_t L[VD_CNN_MAX_LAYERS];
        const uint32_t n = reference_layers(L);
        total = write_model(L, n, (uint16_t)w, (uint16_t)h, 4u, 5u);
    }
    if (write_path != NULL) {
        FILE *f = fopen(write_path, "wb");
        if (f == NULL || fwrite(g_blob, 1, total, f) != total) {
            die("cannot write", write_path);
        }
        fclose(f);
    }
    static vd_cnn_model_t m;
    vd_status_t st = vd_cnn_load(&m, g_blob, total);
    if (st != VD_OK) {
        die("vd_cnn_load", vd_status_str(st));
    }
    size_t prep_bytes = 0u;
    void *prep = NULL;
    if (prepared && vd_cnn_prepared_size(&m, &prep_bytes) == VD_OK && prep_bytes > 0u) {
        prep = xalloc(prep_bytes);
        st = vd_cnn_prepare(&m, prep, prep_bytes);
        if (st != VD_OK) {
            die("vd_cnn_prepare", vd_status_str(st));
        }
    }
    size_t ws_bytes = 0u;
    uint64_t macs = 0u;
    size_t ws2_bytes = 0u;
    if (vd_cnn_workspace_size_ex(&m, w, h, flags, &ws_bytes) != VD_OK || vd_cnn_macs(&m, w, h, &macs) != VD_OK ||
        vd_cnn_workspace_size_ex(&m, w, h, VD_CNN_STREAM, &ws2_bytes) != VD_OK) {
        die("size not accepted by the model", NULL);
    }
    void *ws = xalloc(ws_bytes);
    void *ws2 = xalloc(ws2_bytes);
    double *t2s = xalloc(sizeof(double) * (size_t)iters);
    uint8_t *img = xalloc((size_t)w * h);
    double *t = xalloc(sizeof(double) * (size_t)iters);
    vd_cnn_output_t out;
    vd_cnn_box_t boxes[100];
    size_t n_boxes = 0u;
    double dec_ms = 0.0;
    for (int it = -1; it < iters; it++) {
        // A smooth image with noise and a few warm blobs, new every iteration.
        const uint32_t phase = (uint32_t)(it + 1) * 7u;
        for (uint32_t y = 0u; y < h; y++) {
            for (uint32_t x = 0u; x < w; x++) {
                uint32_t v = 60u + ((x + phase) * 90u) / w + (y * 40u) / h + (rnd() & 15u);
                if (((x / 24u) + (y / 20u) + phase) % 11u == 0u) {
                    v += 70u;
                }
                img[(size_t)y * w + x] = (uint8_t)(v > 255u ? 255u : v);
            }
        }
        double ts = 0.0;
        if (compare && (it & 1)) {
            ts = -now_ms();   // odd iterations: streamed first (order effects cancel)
            st = vd_cnn_run_ex(&m, img, w, h, w, VD_CNN_STREAM, ws2, ws2_bytes, &out);
            ts += now_ms();
        }
        const double t0 = now_ms();
        st = (st == VD_OK) ? vd_cnn_run_ex(&m, img, w, h, w, flags, ws, ws_bytes, &out) : st;
        const double t1 = now_ms();
        if (st != VD_OK) {
            die("vd_cnn_run", vd_status_str(st));
        }
        if (compare) {
            vd_cnn_output_t o2;
            if (!(it & 1)) {
                ts = -now_ms();
                st = vd_cnn_run_ex(&m, img, w, h, w, VD_CNN_STREAM, ws2, ws2_bytes, &o2);
                ts += now_ms();
            } else {
                st = vd_cnn_run_ex(&m, img, w, h, w, VD_CNN_STREAM, ws2, ws2_bytes, &o2);
            }
            if (st != VD_OK || memcmp(o2.data, out.data, (size_t)out.w * out.h * out.c) != 0) {
                die("streamed head differs from the whole-plane head", NULL);
            }
        }
        st = vd_cnn_decode(&m, &out, VD_CNN_THR_DEFAULT, 0u, w * 2u, h * 2u, boxes, 100u, &n_boxes);
        const double t2 = now_ms();
        if (st != VD_OK) {
            die("vd_cnn_decode", vd_status_str(st));
        }
        if (it >= 0) {
            t[it] = t1 - t0;
            t2s[it] = ts;
            dec_ms += t2 - t1;
        }
    }
    qsort(t, (size_t)iters, sizeof(double), cmp_double);
    const double med = t[iters / 2];
    printf("model            %s (%u layers, %u bytes)\n", m.name, (unsigned)m.n_layers, (unsigned)total);
    printf("input            %ux%u, head %ux%ux%u at stride %u\n", (unsigned)w, (unsigned)h, (unsigned)out.w,
           (unsigned)out.h, (unsigned)out.c, (unsigned)out.stride);
    printf("multiply-adds    %.2f M\n", (double)macs / 1e6);
    printf("workspace        %zu bytes\n", ws_bytes);
    printf("prepared         %zu bytes (%s)\n", prep != NULL ? prep_bytes : (size_t)0, vd_cnn_kernel_set());
    printf("vd_cnn_run       median %.3f ms, min %.3f ms over %d runs%s\n", med, t[0], iters,
           flags ? " (streamed)" : "");
    if (compare) {
        qsort(t2s, (size_t)iters, sizeof(double), cmp_double);
        printf("streamed         median %.3f ms, min %.3f ms over %d runs (alternating), workspace %zu bytes, "
               "heads equal\n", t2s[iters / 2], t2s[0], iters, ws2_bytes);
    }
    printf("throughput       %.2f GMAC/s (median)\n", (double)macs / (med * 1e-3) / 1e9);
    printf("vd_cnn_decode    %.3f ms (mean), %zu boxes\n", dec_ms / iters, n_boxes);
    free(t);
    free(t2s);
    free(img);
    free(ws);
    free(ws2);
    free(prep);
    free(g_blob);
    return 0;
}
