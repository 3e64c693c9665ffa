// SPDX-License-Identifier: MIT
// Fuzz harness: vd_fir_demo's JSON reader (tools/demo/common/json.c) and its --config file
// (tools/demo/common/settings.c).
//
// Input: the JSON text. It is parsed with demo_json_parse and, when accepted,
// the token array is checked (every token inside the text, subtrees nested,
// container sizes equal to the children reached by demo_json_first /
// demo_json_sibling, every number readable, every string decodable unless it
// holds \u0000, and each decoded string survives demo_json_write_string ->
// demo_json_parse -> demo_json_string unchanged). The text is then written to
// a temporary file and given to demo_args_parse_to as "--config FILE": the
// result must be 0 (accepted) or -1 (error line written), never --help's 1,
// and an accepted config must be a JSON object whose detector settings
// vd_detector_cfg_resolve either accepts or rejects with VD_ERR_ARG.
#include "args.h"
#include "json.h"
#include "fuzz_common.h"
#include "vd/detector.h"

#include <unistd.h>

static FILE *g_null;

static FILE *null_file(void)
{
    if (g_null == NULL) {
        g_null = fopen("/dev/null", "w");
        FZ_CHECK(g_null != NULL);
    }
    return g_null;
}

static bool span_has(const char *s, size_t n, const char *what)
{
    const size_t w = strlen(what);
    for (size_t i = 0u; i + w <= n; i++) {
        if (memcmp(s + i, what, w) == 0) {
            return true;
        }
    }
    return false;
}

// A decoded string written with demo_json_write_string must read back the same.
static void round_trip(const char *s)
{
    char *mem = NULL;
    size_t mem_len = 0u;
    FILE *f = open_memstream(&mem, &mem_len);
    FZ_CHECK(f != NULL);
    demo_json_write_string(f, s);
    FZ_CHECK(fclose(f) == 0);
    demo_json_t d;
    char err[128];
    FZ_CHECK(demo_json_parse(&d, mem, mem_len, err, sizeof err) == VD_OK);
    FZ_CHECK(d.n == 1u && d.tok[0].type == DEMO_JSON_STRING);
    const size_t cap = strlen(s) + 1u;
    char *back = fz_alloc(cap);
    FZ_CHECK(demo_json_string(&d, 0, back, cap));
    FZ_CHECK(strcmp(back, s) == 0);
    free(back);
    demo_json_free(&d);
    free(mem);
}

static void check_doc(const demo_json_t *d, const char *text, size_t len)
{
    FZ_CHECK(d->n >= 1u && d->n <= d->cap && d->tok[0].next == d->n);
    // a decoded string is at most as long as its escaped text
    char *buf = fz_alloc(len + 1u);
    unsigned round_trips = 0u;
    for (uint32_t i = 0u; i < d->n; i++) {
        const demo_json_tok_t *t = &d->tok[i];
        FZ_CHECK(t->next > i && t->next <= d->n);
        FZ_CHECK(t->start <= len && t->len <= len - t->start);
        switch (t->type) {
        case DEMO_JSON_STRING:
            FZ_CHECK(t->next == i + 1u);
            if (demo_json_string(d, i, buf, len + 1u)) {
                FZ_CHECK(strlen(buf) <= t->len);
                if (round_trips++ < 32u) {
                    round_trip(buf);
                }
            } else {
                FZ_CHECK(span_has(text + t->start, t->len, "u0000"));
            }
            break;
        case DEMO_JSON_NUMBER: {
            double v = 0.0;
            FZ_CHECK(t->next == i + 1u);
            FZ_CHECK(demo_json_number(d, i, &v) == (t->len < 64u));
            break;
        }
        case DEMO_JSON_OBJECT:
        case DEMO_JSON_ARRAY: {
            FZ_CHECK(text[t->start] == (t->type == DEMO_JSON_OBJECT ? '{' : '['));
            FZ_CHECK(text[t->start + t->len - 1u] == (t->type == DEMO_JSON_OBJECT ? '}' : ']'));
            int64_t c = demo_json_first(d, i);
            if (t->size == 0u) {
                FZ_CHECK(c < 0 && t->next == i + 1u);
                break;
            }
            for (uint32_t k = 0u; k < t->size; k++) {
                FZ_CHECK(c > (int64_t)i && c < (int64_t)t->next);
                if (t->type == DEMO_JSON_OBJECT) {
                    FZ_CHECK(d->tok[c].type == DEMO_JSON_STRING && (uint32_t)c + 1u < t->next);
                    c = demo_json_sibling(d, (uint32_t)c + 1u);   // past the value
                } else {
                    c = demo_json_sibling(d, (uint32_t)c);
                }
                FZ_CHECK(c >= 0 && c <= (int64_t)t->next);
            }
            FZ_CHECK(c == (int64_t)t->next);
            break;
        }
        default:
            FZ_CHECK(t->type == DEMO_JSON_TRUE || t->type == DEMO_JSON_FALSE || t->type == DEMO_JSON_NULL);
            FZ_CHECK(t->next == i + 1u);
            break;
        }
    }
    free(buf);
    // lookups on the root: present keys are values right after a key
    static const char *const keys[] = {"hot-thr", "sources", "cnn-model", "images", "annotations", ""};
    for (size_t k = 0u; k < sizeof keys / sizeof keys[0]; k++) {
        const int64_t v = demo_json_get(d, 0u, keys[k]);
        FZ_CHECK(v < 0 || (d->tok[0].type == DEMO_JSON_OBJECT && v >= 2 && v < (int64_t)d->n &&
                           demo_json_string_eq(d, v - 1, keys[k])));
    }
}

static const char *tmp_path(void)
{
    static char path[256];
    const char *dir = getenv("TMPDIR");
    snprintf(path, sizeof(path), "%s/vd_fuzz_demo_config_%ld.json", dir ? dir : "/tmp", (long)getpid());
    return path;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *text = (const char *)data;
    demo_json_t d;
    char err[256];
    err[0] = '\0';
    const vd_status_t st = demo_json_parse(&d, text, size, err, sizeof err);
    bool object = false;
    if (st == VD_OK) {
        check_doc(&d, text, size);
        object = d.tok[0].type == DEMO_JSON_OBJECT;
        demo_json_free(&d);
    } else {
        FZ_CHECK(st == VD_ERR_FORMAT || st == VD_ERR_RANGE);
        FZ_CHECK(err[0] != '\0' && d.tok == NULL && d.n == 0u);
    }

    // The same text as a --config file.
    const char *path = tmp_path();
    FILE *f = fopen(path, "wb");
    if (f == NULL) {
        return 0;
    }
    if (size) {
        (void)fwrite(data, 1u, size, f);
    }
    fclose(f);
    char a0[] = "vd_fir_demo", a1[] = "--config";
    char *argv[] = {a0, a1, (char *)(uintptr_t)path, NULL};
    static demo_opts_t o;
    const int rc = demo_args_parse_to(&o, 3, argv, null_file(), null_file());
    (void)remove(path);
    FZ_CHECK(rc == 0 || rc == -1);
    if (rc == 0) {
        FZ_CHECK(object);
        FZ_CHECK(o.cfg.windows.n_bands <= VD_WINDOWS_MAX_BANDS && o.cfg.windows.n_aspects <= VD_WINDOWS_MAX_ASPECTS);
        FZ_CHECK(!o.sources_set || o.cfg.sources != 0u);
        FZ_CHECK(o.cnn_model == NULL || (o.cnn_model == o.cnn_model_buf && o.cnn_model_buf[0] != '\0'));
        vd_detector_cfg_t c = o.cfg;
        const vd_status_t rs = vd_detector_cfg_resolve(&c);
        FZ_CHECK(rs == VD_OK || rs == VD_ERR_ARG);
    }
    return 0;
}
