// SPDX-License-Identifier: MIT
// vd on a bare-metal Cortex-M: loads the CNN model from flash, runs
// vd_detector_run on each frame in flash and prints the detections as JSON
// Lines (the vd_fir_demo contract, byte for byte the same text) over
// semihosting; exits 0, or 2 with the vd_status_str() text on an error
// (3: a fault, startup.c).
//
// The settings are vd_fir_demo's for a CNN model: zero config (the paper's
// defaults), temporal analysis on with track-aware scores, source cnn, max_candidates and
// max_detections = the model's top-K, max_width/height = the frame size.
// After the JSON lines, one "# vd_fw ..." line per frame and one summary
// line report SysTick cycles (whole vd_detector_run), the CNN stage's time
// from the detector's clock callback, the instruction-count calibration and
// the stack high-water mark (tools/vdtools/generators/embedded_report.py reads them).
#include <stdint.h>
#include <string.h>

#include "vd/vd.h"

#include "board.h"
#include "fw_data.h"
#include "semihost.h"

// Workspace bytes: vd_detector_workspace_size() for this model and frame size
// (the firmware checks it at start and prints the figure when it is short).
#ifndef FW_WORKSPACE_BYTES
#define FW_WORKSPACE_BYTES (300u * 1024u)
#endif
// Detections per frame: max_detections + max_tracks + 1, as vd_fir_demo.
#define FW_MAX_OUT 256u

static uint8_t workspace[FW_WORKSPACE_BYTES] __attribute__((section(".vd_workspace"), aligned(64)));
static vd_detector_t det;
static vd_cnn_model_t cnn;
static vd_detection_t dets[FW_MAX_OUT];
static char line[256];

// Per-stage timing through the detector's clock callback (microseconds).
static uint32_t clock_us(void *user)
{
    (void)user;
    return (uint32_t)(fw_ticks() / (FW_CPU_HZ / 1000000u));
}

// Output buffer: text is collected in `line` and written whenever it fills
// (one semihosting call per 255 characters rather than per piece).
typedef struct {
    char *p;
    char *end;
} buf_t;

static void flush(buf_t *b)
{
    *b->p = '\0';
    sh_puts(line);
    b->p = line;
}

static void put_s(buf_t *b, const char *s)
{
    while (*s != '\0') {
        if (b->p == b->end) {
            flush(b);
        }
        *b->p++ = *s++;
    }
}

static void put_u(buf_t *b, uint32_t v)
{
    char t[11];
    put_s(b, sh_utoa(v, t));
}

static void put_i(buf_t *b, int32_t v)
{
    if (v < 0) {
        put_s(b, "-");
        put_u(b, 0u - (uint32_t)v);
    } else {
        put_u(b, (uint32_t)v);
    }
}

// score_q8 / 255 with three decimals, as printf("%.3f"): round(q * 1000 / 255)
// half up; q * 1000 / 255 is never exactly halfway (255 is odd and has no factor 2).
static void put_score(buf_t *b, uint32_t q8)
{
    uint32_t milli = (q8 * 2000u + 255u) / 510u;
    put_u(b, milli / 1000u);
    put_s(b, ".");
    put_s(b, milli % 1000u < 100u ? (milli % 1000u < 10u ? "00" : "0") : "");
    put_u(b, milli % 1000u);
}

// One JSON line of the DESIGN.md schema, formatted as vd_fir_demo formats it.
static void print_json(const vd_fw_frame_t *f, uint32_t seq, size_t n)
{
    buf_t b = {line, line + sizeof line - 1u};
    put_s(&b, "{\"frame\": \"");
    put_s(&b, f->name);  // generated names need no JSON escaping (gen_arrays.py)
    put_s(&b, "\", \"seq\": ");
    put_u(&b, seq);
    put_s(&b, ", \"width\": ");
    put_u(&b, f->width);
    put_s(&b, ", \"height\": ");
    put_u(&b, f->height);
    put_s(&b, ", \"detections\": [");
    for (size_t i = 0; i < n; i++) {
        const vd_detection_t *d = &dets[i];
        put_s(&b, i ? ", {\"box\": [" : "{\"box\": [");
        put_i(&b, d->box.x);
        put_s(&b, ", ");
        put_i(&b, d->box.y);
        put_s(&b, ", ");
        put_i(&b, d->box.w);
        put_s(&b, ", ");
        put_i(&b, d->box.h);
        put_s(&b, "], \"score\": ");
        put_score(&b, d->score_q8);
        put_s(&b, ", \"track\": ");
        if (d->track_id != 0u && d->state != VD_TRACK_NONE) {
            put_u(&b, d->track_id);
        } else {
            put_s(&b, "null");
        }
        put_s(&b, ", \"source\": \"");
        put_s(&b, vd_detection_source_name(d->source));
        put_s(&b, "\", \"state\": \"");
        put_s(&b, vd_detection_state_name(d->state));
        put_s(&b, "\"}");
    }
    put_s(&b, "]}\n");
    flush(&b);
}

// SysTick cycles of exactly 2 * FW_CALIB_LOOPS + 2 instructions (a subs/bne
// loop): under QEMU -icount the ratio turns cycles into instruction counts.
#define FW_CALIB_LOOPS 1000000u
static uint32_t calibrate(void)
{
    uint32_t n = FW_CALIB_LOOPS;
    uint64_t t0 = fw_ticks();
    __asm__ volatile("1: subs %0, %0, #1\n bne 1b" : "+r"(n) : : "cc");
    return (uint32_t)(fw_ticks() - t0);
}

static int fail(const char *what, vd_status_t st)
{
    sh_puts("vd_fw: ");
    sh_puts(what);
    sh_puts(": ");
    sh_puts(vd_status_str(st));
    sh_puts("\n");
    return 2;
}

int main(void)
{
    vd_status_t st = vd_cnn_load(&cnn, vd_fw_model, vd_fw_model_bytes);
    if (st != VD_OK) {
        return fail("vd_cnn_load", st);
    }
    const vd_fw_frame_t *f0 = &vd_fw_frames[0];
    vd_detector_cfg_t cfg;
    vd_detector_cfg_default(&cfg);
    cfg.temporal = true;
    cfg.temporal_cfg.flags |= VD_TEMPORAL_SCORES;   // as the demo's default (docs/results/temporal.md)
    cfg.sources = VD_DETECTOR_SRC_CNN;
    cfg.cnn_model = &cnn;
    cfg.max_candidates = cnn.max_peaks;
    cfg.max_detections = cnn.max_peaks;
    cfg.max_width = f0->width;
    cfg.max_height = f0->height;
    cfg.max_region_w = (uint16_t)(cfg.max_region_w > f0->width ? f0->width : cfg.max_region_w);
    cfg.max_region_h = (uint16_t)(cfg.max_region_h > f0->height ? f0->height : cfg.max_region_h);
    cfg.clock_us = clock_us;
    size_t bytes = 0;
    st = vd_detector_workspace_size(&cfg, NULL, &bytes);
    if (st != VD_OK) {
        return fail("vd_detector_workspace_size", st);
    }
    if (bytes > sizeof workspace) {
        sh_puts("vd_fw: workspace needs ");
        sh_putu((uint32_t)bytes);
        sh_puts(" bytes (FW_WORKSPACE_BYTES)\n");
        return fail("vd_detector_init", VD_ERR_WORKSPACE);
    }
    st = vd_detector_init(&det, &cfg, NULL, workspace, sizeof workspace);
    if (st != VD_OK) {
        return fail("vd_detector_init", st);
    }
    size_t cap = (size_t)det.cfg.max_detections + det.cfg.max_tracks + 1u;
    if (cap > FW_MAX_OUT) {
        return fail("detections buffer", VD_ERR_CAPACITY);
    }
    uint64_t cycles[8] = {0};
    uint32_t cnn_us[8] = {0};
    for (uint32_t i = 0; i < vd_fw_frame_count; i++) {
        const vd_fw_frame_t *f = &vd_fw_frames[i];
        vd_frame_t fr = {f->data, f->width, f->height, (size_t)f->width * (f->u16 ? 2u : 1u),
                         f->u16 ? VD_PIX_U16 : VD_PIX_U8, i, 0u};
        size_t n = 0;
        uint64_t t0 = fw_ticks();
        st = vd_detector_run(&det, &fr, dets, cap, &n);
        uint64_t t1 = fw_ticks();
        if (i < 8u) {
            cycles[i] = t1 - t0;
            cnn_us[i] = vd_detector_last_stats(&det)->time_us[VD_DETECTOR_STAGE_CNN];
        }
        if (st != VD_OK && st != VD_ERR_CAPACITY) {
            return fail(f->name, st);  // VD_ERR_CAPACITY: results valid, as the demo treats it
        }
        print_json(f, i, n);
    }
    // Measurements after the JSON lines ("#": not detections).
    for (uint32_t i = 0; i < vd_fw_frame_count && i < 8u; i++) {
        sh_puts("# vd_fw frame ");
        sh_putu(i);
        sh_puts(" systick_cycles ");
        sh_putu((uint32_t)cycles[i]);
        sh_puts(" cnn_stage_us ");
        sh_putu(cnn_us[i]);
        sh_puts("\n");
    }
    sh_puts("# vd_fw calib_insns ");
    sh_putu(2u * FW_CALIB_LOOPS + 2u);
    sh_puts(" systick_cycles ");
    sh_putu(calibrate());
    sh_puts("\n# vd_fw workspace_bytes ");
    sh_putu((uint32_t)bytes);
    sh_puts(" workspace_reserved ");
    sh_putu((uint32_t)sizeof workspace);
    sh_puts(" stack_used ");
    sh_putu(fw_stack_used());
    sh_puts(" stack_size ");
    sh_putu(fw_stack_size());
    sh_puts("\n");
    return 0;
}
