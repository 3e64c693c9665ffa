// SPDX-License-Identifier: MIT
// Fuzz harness: vd_fir_demo's command-line parser (demo_args_parse_to, tools/demo/common/args.c).
//
// Input: the arguments, one per line (argv[0] is "vd_fir_demo"; at most 64);
// a line "%%" ends them and the rest of the input is the text of a config
// file: every value after "--config" is replaced by that file's path (or by a
// path that does not exist when there is no such text), so the parser reads
// only the harness's file. Checks: the result is 1 (--help), 0 or -1; after
// 0 every parsed value is in its documented range, the pointers point into
// argv (or to the copy of --cnn-model), and the detector settings are either
// accepted or rejected with VD_ERR_ARG by vd_detector_cfg_resolve.
#include "args.h"
#include "fuzz_common.h"
#include "vd/detector.h"

#include <unistd.h>

#define MAX_ARGS 64

static FILE *g_null;

static FILE *null_file(void)
{
    if (g_null == NULL) {
        g_null = fopen("/dev/null", "w");
        FZ_CHECK(g_null != NULL);
    }
    return g_null;
}

static const char *tmp_path(void)
{
    static char path[256];
    const char *dir = getenv("TMPDIR");
    snprintf(path, sizeof(path), "%s/vd_fuzz_demo_args_%ld.json", dir ? dir : "/tmp", (long)getpid());
    return path;
}

static bool in_argv(const char *p, char **argv, int argc)
{
    for (int i = 0; i < argc; i++) {
        if (p == argv[i]) {
            return true;
        }
    }
    return false;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    // A NUL-terminated copy, cut into lines in place.
    char *buf = fz_alloc(size + 1u);
    if (size) {
        memcpy(buf, data, size);
    }
    buf[size] = '\0';
    char *argv[MAX_ARGS + 2];
    char a0[] = "vd_fir_demo";
    int argc = 0;
    argv[argc++] = a0;
    const char *cfg_text = NULL;
    size_t cfg_len = 0u;
    size_t pos = 0u;
    while (pos < size && argc < MAX_ARGS + 1) {
        char *line = buf + pos;
        char *nl = memchr(line, '\n', size - pos);
        const size_t l = nl != NULL ? (size_t)(nl - line) : size - pos;
        line[l] = '\0';
        pos += l + 1u;
        if (strcmp(line, "%%") == 0) {
            cfg_text = (const char *)data + (pos < size ? pos : size);
            cfg_len = pos < size ? size - pos : 0u;
            break;
        }
        argv[argc++] = line;
    }
    argv[argc] = NULL;

    const char *path = tmp_path();
    char missing[] = "/nonexistent/vd_fuzz_demo_args.json";
    bool wrote = false;
    if (cfg_text != NULL) {
        FILE *f = fopen(path, "wb");
        if (f != NULL) {
            if (cfg_len) {
                (void)fwrite(cfg_text, 1u, cfg_len, f);
            }
            fclose(f);
            wrote = true;
        }
    }
    for (int i = 1; i + 1 < argc; i++) {
        if (strcmp(argv[i], "--config") == 0) {
            argv[i + 1] = wrote ? (char *)(uintptr_t)path : missing;
        }
    }

    static demo_opts_t o;
    const int rc = demo_args_parse_to(&o, argc, argv, null_file(), null_file());
    FZ_CHECK(rc == 0 || rc == 1 || rc == -1);
    if (rc == 0) {
        FZ_CHECK(o.input != NULL && (o.input_default || in_argv(o.input, argv, argc)));
        const char *const ptrs[] = {o.model, o.out_dir, o.json, o.eval, o.classes, o.eval_out, o.report};
        for (size_t k = 0u; k < sizeof ptrs / sizeof ptrs[0]; k++) {
            FZ_CHECK(ptrs[k] == NULL || in_argv(ptrs[k], argv, argc));
        }
        FZ_CHECK(o.cnn_model == NULL || (o.cnn_model == o.cnn_model_buf && o.cnn_model_buf[0] != '\0'));
        FZ_CHECK((o.raw_w == 0u) == (o.raw_h == 0u) && o.raw_w <= VD_MAX_DIM && o.raw_h <= VD_MAX_DIM);
        FZ_CHECK((o.dev_w == 0u) == (o.dev_h == 0u) && o.dev_w <= VD_MAX_DIM && o.dev_h <= VD_MAX_DIM);
        FZ_CHECK(o.fps <= 1000u && o.timeout_ms >= 1 && o.timeout_ms <= 3600000);
        FZ_CHECK(o.raw_format == VD_PIX_U16 || o.raw_format == VD_PIX_U8);
        FZ_CHECK(!o.raw_big_endian || o.raw_format == VD_PIX_U16);
        FZ_CHECK(o.eval != NULL || o.input_default || (o.classes == NULL && o.eval_out == NULL));
        FZ_CHECK(o.cfg.windows.n_bands <= VD_WINDOWS_MAX_BANDS && o.cfg.windows.n_aspects <= VD_WINDOWS_MAX_ASPECTS);
        FZ_CHECK(!o.sources_set || o.cfg.sources != 0u);
        vd_detector_cfg_t c = o.cfg;
        const vd_status_t rs = vd_detector_cfg_resolve(&c);
        FZ_CHECK(rs == VD_OK || rs == VD_ERR_ARG);
    }
    if (wrote) {
        (void)remove(path);
    }
    free(buf);
    return 0;
}
