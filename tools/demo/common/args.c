// SPDX-License-Identifier: MIT
// Command line of vd_fir_demo (and of the GStreamer element vdfir, which builds one from its
// properties): run options (input, outputs, evaluation) and the detector settings of settings.c.
//
// Two passes over argv: the first takes the run options and finds --config (so a usage error
// is reported before any file is read), the config file is applied next, and the second pass
// applies the detector-setting flags over it, so flags win. A switch setting (--cnn-rescore,
// --cnn-flip) may be given without a value on the command line (= on); in the config file it
// takes true/false or "on"/"off".
#include "args.h"

#include <string.h>

// The bundled clips (tools/demo/common/CMakeLists.txt sets both to absolute paths of the build):
// the real HIT-UAV excerpt committed under tools/demo/hit-uav-clip (CC BY 4.0, the default),
// and the synthetic radiometric clip generated at build time (--clip synthetic | synthetic-u8).
#ifndef VD_DEMO_HIT_CLIP_DIR
#define VD_DEMO_HIT_CLIP_DIR "tools/demo/hit-uav-clip"
#endif
#ifndef VD_DEMO_CLIP_DIR
#define VD_DEMO_CLIP_DIR "build/clip"
#endif
#define VD_DEMO_DEFAULT_INPUT VD_DEMO_HIT_CLIP_DIR "/images"

void demo_args_usage(FILE *f)
{
    fprintf(f,
            "usage: vd_fir_demo [options]\n"
            "Detects vehicles in far-infrared frames with the vd library: an int8 CNN (--sources cnn,\n"
            "the default when models/vd_cnn.vdm exists) or the paper 001 pipeline (--sources hotspot).\n\n"
            "input and outputs:\n"
            "  --input PATH        directory of frames (*.pgm *.png *.jpg *.raw *.y16, sorted by name), list file\n"
            "                      (*.txt / *.lst, one path per line), one image or raw file, or /dev/videoN\n"
            "                      (default: the bundled clip, see --clip)\n"
            "  --clip NAME         bundled clip used without --input: hit-uav (default: 38 real drone frames of\n"
            "                      HIT-UAV, CC BY 4.0, %s), synthetic (generated 16-bit radiometric\n"
            "                      night road, %s/u16) or synthetic-u8 (the same clip in 8 bits)\n"
            "  --raw-size WxH      frame size of raw files (required for raw input)\n"
            "  --raw-format F      raw samples: u16 (little-endian, default), u16be or u8\n"
            "  --device-size WxH   V4L2: requested frame size (default: the driver's)\n"
            "  --fps N             V4L2: requested frame rate\n"
            "  --pixfmt F          V4L2: grey or y16 (default: y16 if offered)\n"
            "  --timeout-ms N      V4L2: wait per frame (default 2000)\n"
            "  --frames N          stop after N frames (default: all; a camera runs until Ctrl-C)\n"
            "  --model FILE        .vdm model. A DBN (versions 1-2) verifies hot-spot/contrast/window candidates\n"
            "                      (default: models/vd_dbn_grey.vdm, else the first DBN models/*.vdm; loaded only\n"
            "                      when a source or --cnn-rescore needs it; 'none' = no DBN: every candidate is\n"
            "                      kept with score 1.0 and the default sources are hotspot). A CNN (version 3) is\n"
            "                      taken as --cnn-model. Without --sources, a DBN --model keeps the paper pipeline\n"
            "                      and a CNN model (--cnn-model, a CNN --model, or models/vd_cnn.vdm when no\n"
            "                      --model is given) makes the sources cnn; with the cnn source and no\n"
            "                      --max-candidates/--max-detections, both become the model's top-K (twice\n"
            "                      that for candidates with --cnn-flip; +64 for the other sources); with a\n"
            "                      second network (--cnn-model2, default models/vd_cnn2.vdm beside the default\n"
            "                      models/vd_cnn.vdm) the larger top-K and 32 detections\n"
            "  --out DIR           annotated PNG frames: boxes yellow = new, green = confirmed,\n"
            "                      magenta = recovered; track id and score above each box\n"
            "  --no-scores         do not draw the id/score text\n"
            "  --json FILE         detections as JSON Lines, one object per frame (docs/demo.md)\n"
            "  --eval ANNOTATIONS  compare with ground truth: COCO-like JSON (HIT-UAV layout too) or a YOLO\n"
            "                      label folder; prints TP rate, FP rate, precision, recall, FPPI\n"
            "                      (default with a bundled clip: its annotations.json)\n"
            "  --classes LIST      vehicle classes for --eval, ids or names, comma separated (default: classes\n"
            "                      named car/othervehicle/vehicle/truck/bus/van; YOLO without names: 2 = MSRS car)\n"
            "  --eval-out FILE     write the evaluation figures as JSON\n"
            "  --report DIR        DIR/index.html, one self-contained page: summary, stage times and, with\n"
            "                      ground truth, TP/FP/AP, the precision-recall curve and a gallery of the\n"
            "                      frames with misses and false positives\n"
            "  --quiet             no progress lines\n"
            "  --help              this text\n\n"
            "detector settings (also keys of --config FILE, a JSON object such as {\"hot-thr\": 150}; flags win):\n"
            "  --config FILE       read settings from FILE\n",
            VD_DEMO_HIT_CLIP_DIR, VD_DEMO_CLIP_DIR);
    demo_settings_usage(f);
    fprintf(f, "\nErrors print one line on stderr and exit non-zero; outputs are written to temporary names\n"
               "and renamed only when the whole run succeeded.\n");
}

static int usage_error(FILE *errf, const char *fmt, const char *a, const char *b)
{
    fprintf(errf, "vd_fir_demo: error: ");
    fprintf(errf, fmt, a, b);
    fprintf(errf, " (%s; see --help)\n", vd_status_str(VD_ERR_ARG));
    return -1;
}

int demo_args_parse(demo_opts_t *o, int argc, char **argv)
{
    return demo_args_parse_to(o, argc, argv, stdout, stderr);
}

static void set_defaults(demo_opts_t *o)
{
    memset(o, 0, sizeof *o);
    o->input = VD_DEMO_DEFAULT_INPUT;
    o->input_default = true;
    o->clip_eval = VD_DEMO_HIT_CLIP_DIR "/annotations.json";
    o->raw_format = VD_PIX_U16;
    o->timeout_ms = 2000;
    o->scores = true;
    vd_detector_cfg_default(&o->cfg);
    o->cfg.temporal = true;
    o->cfg.temporal_cfg.flags |= VD_TEMPORAL_SCORES;   // track-aware scores (docs/results/temporal.md)
    o->cfg.cnn_flip = 1u;   // the shipped operating point (docs/results/detector.md): fused flip pass at the header's threshold
    o->cnn_res_auto = true;   // half or full resolution measured on the recording (autores.c, docs/demo.md)
    o->cnn_polarity_auto = true;   // white-hot or black-hot, by the same measurement (docs/demo.md "Black-hot cameras")
    o->grey_window_auto = true;    // 16-bit frames: the fixed window unless raw counts fall outside it (models.c)
}

// --clip NAME: the bundled clip's frames (applied after the first pass) and annotations.
static int clip_option(demo_opts_t *o, const char *v, const char **clip_input, FILE *errf)
{
    if (strcmp(v, "hit-uav") == 0) {
        o->clip_eval = VD_DEMO_HIT_CLIP_DIR "/annotations.json";
    } else if (strcmp(v, "synthetic") == 0 || strcmp(v, "synthetic-u8") == 0) {
        o->clip_eval = VD_DEMO_CLIP_DIR "/annotations.json";
    } else {
        return usage_error(errf, "bad --clip '%s'%s (expected hit-uav, synthetic or synthetic-u8)", v, "");
    }
    *clip_input = strcmp(v, "hit-uav") == 0     ? VD_DEMO_DEFAULT_INPUT
                  : strcmp(v, "synthetic") == 0 ? VD_DEMO_CLIP_DIR "/u16"
                                                : VD_DEMO_CLIP_DIR "/u8";
    return 0;
}

// Options of the input (raw files, V4L2 devices) that take a value: 0 taken, -1 error (printed),
// 1 not one of them.
static int input_option(demo_opts_t *o, const char *n, const char *v, FILE *errf)
{
    if (strcmp(n, "raw-size") == 0) {
        if (!demo_parse_size(v, &o->raw_w, &o->raw_h)) {
            return usage_error(errf, "bad --raw-size '%s'%s (expected WxH)", v, "");
        }
    } else if (strcmp(n, "raw-format") == 0) {
        if (strcmp(v, "u16") == 0) {
            o->raw_format = VD_PIX_U16;
        } else if (strcmp(v, "u16be") == 0) {
            o->raw_format = VD_PIX_U16;
            o->raw_big_endian = true;
        } else if (strcmp(v, "u8") == 0) {
            o->raw_format = VD_PIX_U8;
        } else {
            return usage_error(errf, "bad --raw-format '%s'%s (expected u16, u16be or u8)", v, "");
        }
    } else if (strcmp(n, "device-size") == 0) {
        if (!demo_parse_size(v, &o->dev_w, &o->dev_h)) {
            return usage_error(errf, "bad --device-size '%s'%s (expected WxH)", v, "");
        }
    } else if (strcmp(n, "fps") == 0) {
        if (!demo_parse_u32(v, 1, 1000, &o->fps)) {
            return usage_error(errf, "bad --fps '%s'%s", v, "");
        }
    } else if (strcmp(n, "pixfmt") == 0) {
        if (strcmp(v, "grey") == 0 || strcmp(v, "gray") == 0) {
            o->dev_format = VD_PIX_U8;
        } else if (strcmp(v, "y16") == 0) {
            o->dev_format = VD_PIX_U16;
        } else {
            return usage_error(errf, "bad --pixfmt '%s'%s (expected grey or y16)", v, "");
        }
    } else if (strcmp(n, "timeout-ms") == 0) {
        uint32_t t;
        if (!demo_parse_u32(v, 1, 3600000u, &t)) {
            return usage_error(errf, "bad --timeout-ms '%s'%s", v, "");
        }
        o->timeout_ms = (int32_t)t;
    } else if (strcmp(n, "frames") == 0) {
        uint32_t t;
        if (!demo_parse_u32(v, 1, UINT32_MAX, &t)) {
            return usage_error(errf, "bad --frames '%s'%s", v, "");
        }
        o->max_frames = t;
    } else {
        return 1;
    }
    return 0;
}

// The run options whose value is kept as it is (a path, a list): where it goes; NULL for others.
static const char **text_option(demo_opts_t *o, const char *n, const char **config)
{
    return strcmp(n, "model") == 0      ? &o->model
           : strcmp(n, "out") == 0      ? &o->out_dir
           : strcmp(n, "json") == 0     ? &o->json
           : strcmp(n, "eval") == 0     ? &o->eval
           : strcmp(n, "classes") == 0  ? &o->classes
           : strcmp(n, "eval-out") == 0 ? &o->eval_out
           : strcmp(n, "report") == 0   ? &o->report
           : strcmp(n, "config") == 0   ? config
                                        : NULL;
}

// First pass: everything but detector settings, and find --config. 0 to go on, 1 after --help,
// -1 on a usage error (printed).
static int first_pass(demo_opts_t *o, int argc, char **argv, FILE *out, FILE *errf, const char **config)
{
    const char *clip_input = NULL;   // --clip's frames; applied after the pass
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            demo_args_usage(out);
            return 1;
        }
        if (strcmp(a, "--quiet") == 0) {
            o->quiet = true;
            continue;
        }
        if (strcmp(a, "--no-scores") == 0) {
            o->scores = false;
            continue;
        }
        if (strncmp(a, "--", 2) != 0) {
            return usage_error(errf, "unexpected argument '%s'%s", a, "");
        }
        const int sid = demo_setting_find(a + 2);
        if (demo_setting_is_switch(sid) && strchr(a + 2, '_') == NULL) {
            if (i + 1 < argc && demo_setting_value_ok(sid, argv[i + 1])) {
                i++;   // its optional value; applied in the second pass
            }
            continue;
        }
        if (i + 1 >= argc) {
            return usage_error(errf, "%s needs a value%s", a, "");
        }
        const char *v = argv[++i];
        const char *n = a + 2;
        const char **text = text_option(o, n, config);
        int rc = 0;
        if (strcmp(n, "input") == 0) {
            o->input = v;
            o->input_default = false;
        } else if (strcmp(n, "clip") == 0) {
            rc = clip_option(o, v, &clip_input, errf);
        } else if (text != NULL) {
            *text = v;
        } else {
            rc = input_option(o, n, v, errf);
        }
        if (rc < 0) {
            return rc;
        }
        if (rc > 0 && (strchr(n, '_') != NULL || sid < 0)) {
            return usage_error(errf, "unknown option '%s'%s", a, "");
        }
    }
    if (clip_input != NULL) {
        if (!o->input_default) {
            return usage_error(errf, "--clip chooses a bundled clip: not with --input%s%s", "", "");
        }
        o->input = clip_input;
    }
    if (!o->input_default) {
        o->clip_eval = NULL;
    }
    return 0;
}

// Second pass: detector setting flags, over the config file. 0 or -1 (error printed).
static int second_pass(demo_opts_t *o, int argc, char **argv, FILE *errf)
{
    char msg[600];
    for (int i = 1; i < argc; i++) {
        if (strncmp(argv[i], "--", 2) != 0) {
            continue;
        }
        if (strcmp(argv[i], "--quiet") == 0 || strcmp(argv[i], "--no-scores") == 0) {
            continue;
        }
        int id = demo_setting_find(argv[i] + 2);
        if (demo_setting_is_switch(id)) {
            const char *v = (i + 1 < argc && demo_setting_value_ok(id, argv[i + 1])) ? argv[++i] : "on";
            if (!demo_setting_apply(o, id, v, msg, sizeof msg)) {
                return usage_error(errf, "%s%s", msg, "");
            }
            continue;
        }
        if (i + 1 >= argc) {
            break;   // the first pass made sure every other option has its value
        }
        if (id >= 0 && !demo_setting_apply(o, id, argv[i + 1], msg, sizeof msg)) {
            return usage_error(errf, "%s%s", msg, "");
        }
        i++;   // skip the value
    }
    return 0;
}

int demo_args_parse_to(demo_opts_t *o, int argc, char **argv, FILE *out, FILE *errf)
{
    set_defaults(o);
    const char *config = NULL;
    int rc = first_pass(o, argc, argv, out, errf, &config);
    if (rc != 0) {
        return rc;
    }
    char msg[600];
    if (config != NULL && !demo_settings_load(o, config, msg, sizeof msg)) {
        fprintf(errf, "vd_fir_demo: error: %s (%s)\n", msg, vd_status_str(VD_ERR_FORMAT));
        return -1;
    }
    rc = second_pass(o, argc, argv, errf);
    if (rc != 0) {
        return rc;
    }
    if (o->eval == NULL && !o->input_default && (o->classes != NULL || o->eval_out != NULL)) {
        return usage_error(errf, "--classes and --eval-out need --eval%s%s", "", "");
    }
    return 0;
}
