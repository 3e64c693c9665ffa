// SPDX-License-Identifier: MIT
// Bounded JSON reader (flat token array, explicit stack) and writer helpers of vd_demo_common
// (vd_fir_demo's --config and --eval files, the GStreamer element's config property).
//
// Algorithm: one pass over the text with a state machine and an explicit
// stack of open containers (depth <= DEMO_JSON_MAX_DEPTH), producing tokens in
// document order; each token records the index just past its subtree, so
// lookups skip whole values without recursion. Strict RFC 8259 grammar.
// Bounds: time O(text length); memory 40 bytes per token, tokens <= text
// length / 1 and <= DEMO_JSON_MAX_TOKENS; stack 64 entries.
#include "json.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

enum { S_VALUE, S_KEY, S_COLON, S_AFTER, S_END };

static vd_status_t fail_at(demo_json_t *doc, size_t pos, const char *what, char *err, size_t err_len)
{
    size_t line = 1, col = 1;
    for (size_t i = 0; i < pos && i < doc->text_len; i++) {
        if (doc->text[i] == '\n') {
            line++;
            col = 1;
        } else {
            col++;
        }
    }
    if (err != NULL && err_len > 0) {
        snprintf(err, err_len, "JSON syntax error at line %zu column %zu: %s", line, col, what);
    }
    demo_json_free(doc);
    return VD_ERR_FORMAT;
}

static vd_status_t push_tok(demo_json_t *doc, demo_json_type_t type, size_t start, char *err, size_t err_len)
{
    if (doc->n == doc->cap) {
        if (doc->cap >= DEMO_JSON_MAX_TOKENS) {
            snprintf(err, err_len, "JSON has more than %u values", DEMO_JSON_MAX_TOKENS);
            return VD_ERR_RANGE;
        }
        uint32_t ncap = doc->cap == 0 ? 256u : doc->cap * 2u;
        if (ncap > DEMO_JSON_MAX_TOKENS) {
            ncap = DEMO_JSON_MAX_TOKENS;
        }
        demo_json_tok_t *t = realloc(doc->tok, (size_t)ncap * sizeof *t);
        if (t == NULL) {
            snprintf(err, err_len, "out of memory reading JSON");
            return VD_ERR_IO;
        }
        doc->tok = t;
        doc->cap = ncap;
    }
    demo_json_tok_t *t = &doc->tok[doc->n];
    t->type = type;
    t->size = 0;
    t->next = doc->n + 1u;
    t->start = start;
    t->len = 0;
    doc->n++;
    return VD_OK;
}

static bool is_ws(char c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

static bool is_digit(char c)
{
    return c >= '0' && c <= '9';
}

static int hexval(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    return -1;
}

// Scans a string starting after its opening quote; returns the index of the
// closing quote, or (size_t)-1 on a syntax error (*why set).
static size_t scan_string(const char *s, size_t len, size_t i, const char **why)
{
    while (i < len) {
        unsigned char c = (unsigned char)s[i];
        if (c == '"') {
            return i;
        }
        if (c < 0x20u) {
            *why = "control character in string";
            return (size_t)-1;
        }
        if (c == '\\') {
            if (i + 1 >= len) {
                break;
            }
            char e = s[i + 1];
            if (e == 'u') {
                if (i + 6 > len) {
                    break;
                }
                for (size_t k = 2; k < 6; k++) {
                    if (hexval(s[i + k]) < 0) {
                        *why = "bad \\u escape";
                        return (size_t)-1;
                    }
                }
                i += 6;
                continue;
            }
            if (strchr("\"\\/bfnrt", e) == NULL || e == '\0') {
                *why = "bad escape in string";
                return (size_t)-1;
            }
            i += 2;
            continue;
        }
        i++;
    }
    *why = "unterminated string";
    return (size_t)-1;
}

// Scans a number; returns the index after it or (size_t)-1.
static size_t scan_number(const char *s, size_t len, size_t i)
{
    if (i < len && s[i] == '-') {
        i++;
    }
    if (i >= len || !is_digit(s[i])) {
        return (size_t)-1;
    }
    if (s[i] == '0') {
        i++;
    } else {
        while (i < len && is_digit(s[i])) {
            i++;
        }
    }
    if (i < len && s[i] == '.') {
        i++;
        if (i >= len || !is_digit(s[i])) {
            return (size_t)-1;
        }
        while (i < len && is_digit(s[i])) {
            i++;
        }
    }
    if (i < len && (s[i] == 'e' || s[i] == 'E')) {
        i++;
        if (i < len && (s[i] == '+' || s[i] == '-')) {
            i++;
        }
        if (i >= len || !is_digit(s[i])) {
            return (size_t)-1;
        }
        while (i < len && is_digit(s[i])) {
            i++;
        }
    }
    return i;
}

// '{' or '[' at text[*i]: its token pushed (an array's size counts its first element already,
// the others at each ','), *i past it. VD_OK, or the error (doc freed).
static vd_status_t open_container(demo_json_t *doc, size_t *i, char *err, size_t err_len)
{
    const char *text = doc->text;
    const size_t len = doc->text_len;
    const char c = text[*i];
    vd_status_t st = push_tok(doc, c == '{' ? DEMO_JSON_OBJECT : DEMO_JSON_ARRAY, *i, err, err_len);
    if (st != VD_OK) {
        demo_json_free(doc);
        return st;
    }
    (*i)++;
    if (c == '[') {
        while (*i < len && is_ws(text[*i])) {
            (*i)++;
        }
        if (*i < len && text[*i] != ']') {
            doc->tok[doc->n - 1].size = 1;
        }
    }
    return VD_OK;
}

// '}' or ']' at text[*i] closing container token `top_idx`, the parser in `state` before it: the
// container's span and the index past its subtree recorded, *i past it. VD_OK, or the error
// (doc freed).
static vd_status_t close_container(demo_json_t *doc, uint32_t top_idx, int state, size_t *i, char *err,
                                   size_t err_len)
{
    const char c = doc->text[*i];
    demo_json_tok_t *top = &doc->tok[top_idx];
    bool empty_ok = state == S_AFTER || (state == S_KEY && top->size == 0 && c == '}') ||
                    (state == S_VALUE && top->size == 0 && c == ']' && top->type == DEMO_JSON_ARRAY);
    if (!empty_ok || (c == '}') != (top->type == DEMO_JSON_OBJECT)) {
        return fail_at(doc, *i, "unexpected closing bracket", err, err_len);
    }
    top->next = doc->n;
    top->len = *i + 1 - top->start;
    (*i)++;
    return VD_OK;
}

// A string, number, true, false or null at text[*i]: its token pushed, *i past it. VD_OK, or the
// error (doc freed).
static vd_status_t scalar(demo_json_t *doc, size_t *i, char *err, size_t err_len)
{
    const char *text = doc->text;
    const size_t len = doc->text_len;
    const char c = text[*i];
    const char *why = "";
    demo_json_type_t type;
    size_t start = *i, end;
    if (c == '"') {
        end = scan_string(text, len, *i + 1, &why);
        if (end == (size_t)-1) {
            return fail_at(doc, *i, why, err, err_len);
        }
        type = DEMO_JSON_STRING;
        start = *i + 1;
        *i = end + 1;
    } else if (c == '-' || is_digit(c)) {
        end = scan_number(text, len, *i);
        if (end == (size_t)-1) {
            return fail_at(doc, *i, "bad number", err, err_len);
        }
        type = DEMO_JSON_NUMBER;
        *i = end;
    } else if (len - *i >= 4 && memcmp(text + *i, "true", 4) == 0) {
        type = DEMO_JSON_TRUE;
        end = *i + 4;
        *i = end;
    } else if (len - *i >= 5 && memcmp(text + *i, "false", 5) == 0) {
        type = DEMO_JSON_FALSE;
        end = *i + 5;
        *i = end;
    } else if (len - *i >= 4 && memcmp(text + *i, "null", 4) == 0) {
        type = DEMO_JSON_NULL;
        end = *i + 4;
        *i = end;
    } else {
        return fail_at(doc, *i, "expected a value", err, err_len);
    }
    vd_status_t st = push_tok(doc, type, start, err, err_len);
    if (st != VD_OK) {
        demo_json_free(doc);
        return st;
    }
    doc->tok[doc->n - 1].len = end - start;
    return VD_OK;
}

// A ',' at text[*i] after a value in container top: the next state (a key in an object, a value in an
// array, whose count grows); a closing bracket right after it is a trailing comma.
static vd_status_t after_comma(demo_json_t *doc, demo_json_tok_t *top, size_t *i, int *state, char *err,
                               size_t err_len)
{
    const char *text = doc->text;
    const size_t len = doc->text_len;
    (*i)++;
    *state = top->type == DEMO_JSON_OBJECT ? S_KEY : S_VALUE;
    if (top->type == DEMO_JSON_ARRAY) {
        top->size++;
    }
    while (*i < len && is_ws(text[*i])) {
        (*i)++;
    }
    if (*i < len && (text[*i] == '}' || text[*i] == ']')) {
        return fail_at(doc, *i, "trailing comma", err, err_len);
    }
    return VD_OK;
}

vd_status_t demo_json_parse(demo_json_t *doc, const char *text, size_t len, char *err, size_t err_len)
{
    char dummy[8];
    if (err == NULL || err_len == 0) {
        err = dummy;
        err_len = sizeof dummy;
    }
    memset(doc, 0, sizeof *doc);
    doc->text = text;
    doc->text_len = len;
    if (text == NULL) {
        snprintf(err, err_len, "no JSON text");
        return VD_ERR_ARG;
    }
    if (len > DEMO_JSON_MAX_BYTES) {
        snprintf(err, err_len, "JSON text longer than %u bytes", DEMO_JSON_MAX_BYTES);
        return VD_ERR_RANGE;
    }
    uint32_t stack[DEMO_JSON_MAX_DEPTH];
    size_t depth = 0;
    int state = S_VALUE;
    size_t i = 0;
    vd_status_t st;
    // Every iteration consumes at least one byte or ends the loop, so the loop
    // runs at most len + 1 times.
    for (;;) {
        while (i < len && is_ws(text[i])) {
            i++;
        }
        if (state == S_END) {
            if (i != len) {
                return fail_at(doc, i, "text after the JSON value", err, err_len);
            }
            return VD_OK;
        }
        if (i >= len) {
            return fail_at(doc, i, "unexpected end of text", err, err_len);
        }
        char c = text[i];
        bool completed = false;   // a value (or a closing bracket) just finished
        if (state == S_KEY) {
            if (c == '}' && doc->tok[stack[depth - 1]].size == 0) {
                // empty object: handled as a closer below
            } else if (c != '"') {
                return fail_at(doc, i, "expected a string key", err, err_len);
            } else {
                st = scalar(doc, &i, err, err_len);   // the key: a string
                if (st != VD_OK) {
                    return st;
                }
                doc->tok[stack[depth - 1]].size++;
                state = S_COLON;
                continue;
            }
        }
        if (state == S_COLON) {
            if (c != ':') {
                return fail_at(doc, i, "expected ':'", err, err_len);
            }
            i++;
            state = S_VALUE;
            continue;
        }
        if (state == S_AFTER) {
            demo_json_tok_t *top = &doc->tok[stack[depth - 1]];
            if (c == ',') {
                st = after_comma(doc, top, &i, &state, err, err_len);
                if (st != VD_OK) {
                    return st;
                }
                continue;
            }
            if ((c == '}' && top->type != DEMO_JSON_OBJECT) || (c == ']' && top->type != DEMO_JSON_ARRAY) ||
                (c != '}' && c != ']')) {
                return fail_at(doc, i, "expected ',' or a closing bracket", err, err_len);
            }
        }
        if (c == '}' || c == ']') {
            if (depth == 0) {
                return fail_at(doc, i, "unexpected closing bracket", err, err_len);
            }
            st = close_container(doc, stack[depth - 1], state, &i, err, err_len);
            if (st != VD_OK) {
                return st;
            }
            depth--;
            completed = true;
        } else {
            if (state != S_VALUE) {
                return fail_at(doc, i, "unexpected character", err, err_len);
            }
            if (c == '{' || c == '[') {
                if (depth == DEMO_JSON_MAX_DEPTH) {
                    snprintf(err, err_len, "JSON nested deeper than %d levels", DEMO_JSON_MAX_DEPTH);
                    demo_json_free(doc);
                    return VD_ERR_RANGE;
                }
                st = open_container(doc, &i, err, err_len);
                if (st != VD_OK) {
                    return st;
                }
                stack[depth++] = doc->n - 1u;
                state = c == '{' ? S_KEY : S_VALUE;
                continue;
            }
            st = scalar(doc, &i, err, err_len);
            if (st != VD_OK) {
                return st;
            }
            completed = true;
        }
        if (completed) {
            state = depth == 0 ? S_END : S_AFTER;
        }
    }
}

void demo_json_free(demo_json_t *doc)
{
    if (doc != NULL) {
        free(doc->tok);
        doc->tok = NULL;
        doc->n = doc->cap = 0;
    }
}

int64_t demo_json_first(const demo_json_t *doc, uint32_t container)
{
    if (container >= doc->n) {
        return -1;
    }
    const demo_json_tok_t *t = &doc->tok[container];
    if ((t->type != DEMO_JSON_OBJECT && t->type != DEMO_JSON_ARRAY) || t->size == 0) {
        return -1;
    }
    return (int64_t)container + 1;
}

int64_t demo_json_sibling(const demo_json_t *doc, uint32_t elem)
{
    // The parent is not stored: the caller iterates a known count or stops at
    // the container's `next`. We return tok.next and let the caller check.
    if (elem >= doc->n) {
        return -1;
    }
    return (int64_t)doc->tok[elem].next;
}

bool demo_json_string_eq(const demo_json_t *doc, int64_t idx, const char *key)
{
    char buf[256];
    if (!demo_json_string(doc, idx, buf, sizeof buf)) {
        return false;
    }
    return strcmp(buf, key) == 0;
}

int64_t demo_json_get(const demo_json_t *doc, uint32_t obj, const char *key)
{
    if (obj >= doc->n || doc->tok[obj].type != DEMO_JSON_OBJECT) {
        return -1;
    }
    uint32_t k = obj + 1u;
    for (uint32_t i = 0; i < doc->tok[obj].size && k + 1u < doc->n; i++) {
        if (demo_json_string_eq(doc, k, key)) {
            return (int64_t)k + 1;
        }
        k = doc->tok[k + 1u].next;
    }
    return -1;
}

bool demo_json_number(const demo_json_t *doc, int64_t idx, double *out)
{
    if (idx < 0 || (uint64_t)idx >= doc->n || doc->tok[idx].type != DEMO_JSON_NUMBER) {
        return false;
    }
    char buf[64];
    const demo_json_tok_t *t = &doc->tok[idx];
    if (t->len >= sizeof buf) {
        return false;
    }
    memcpy(buf, doc->text + t->start, t->len);
    buf[t->len] = '\0';
    errno = 0;
    char *end = NULL;
    double v = strtod(buf, &end);
    if (end == buf || *end != '\0') {
        return false;
    }
    *out = v;
    return true;
}

static size_t put_utf8(char *dst, uint32_t cp)
{
    if (cp < 0x80u) {
        dst[0] = (char)cp;
        return 1;
    }
    if (cp < 0x800u) {
        dst[0] = (char)(0xC0u | (cp >> 6));
        dst[1] = (char)(0x80u | (cp & 0x3Fu));
        return 2;
    }
    if (cp < 0x10000u) {
        dst[0] = (char)(0xE0u | (cp >> 12));
        dst[1] = (char)(0x80u | ((cp >> 6) & 0x3Fu));
        dst[2] = (char)(0x80u | (cp & 0x3Fu));
        return 3;
    }
    dst[0] = (char)(0xF0u | (cp >> 18));
    dst[1] = (char)(0x80u | ((cp >> 12) & 0x3Fu));
    dst[2] = (char)(0x80u | ((cp >> 6) & 0x3Fu));
    dst[3] = (char)(0x80u | (cp & 0x3Fu));
    return 4;
}

static uint32_t hex4(const char *s)
{
    uint32_t v = 0;
    for (int k = 0; k < 4; k++) {
        v = (v << 4) | (uint32_t)hexval(s[k]);
    }
    return v;
}

bool demo_json_string(const demo_json_t *doc, int64_t idx, char *buf, size_t cap)
{
    if (idx < 0 || (uint64_t)idx >= doc->n || doc->tok[idx].type != DEMO_JSON_STRING || cap == 0) {
        return false;
    }
    const demo_json_tok_t *t = &doc->tok[idx];
    const char *s = doc->text + t->start;
    size_t o = 0;
    for (size_t i = 0; i < t->len;) {
        char tmp[4];
        size_t n = 1;
        if (s[i] != '\\') {
            tmp[0] = s[i];
            i++;
        } else {
            char e = s[i + 1];   // the scanner guaranteed a complete escape
            if (e == 'u') {
                uint32_t cp = hex4(s + i + 2);
                i += 6;
                if (cp >= 0xD800u && cp < 0xDC00u && i + 6 <= t->len && s[i] == '\\' && s[i + 1] == 'u') {
                    uint32_t lo = hex4(s + i + 2);
                    if (lo >= 0xDC00u && lo < 0xE000u) {
                        cp = 0x10000u + ((cp - 0xD800u) << 10) + (lo - 0xDC00u);
                        i += 6;
                    }
                }
                if (cp == 0) {
                    return false;
                }
                n = put_utf8(tmp, cp);
            } else {
                i += 2;
                switch (e) {
                case 'b': tmp[0] = '\b'; break;
                case 'f': tmp[0] = '\f'; break;
                case 'n': tmp[0] = '\n'; break;
                case 'r': tmp[0] = '\r'; break;
                case 't': tmp[0] = '\t'; break;
                default: tmp[0] = e; break;
                }
            }
        }
        if (o + n >= cap) {
            return false;
        }
        memcpy(buf + o, tmp, n);
        o += n;
    }
    buf[o] = '\0';
    return true;
}

void demo_json_write_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; *p != '\0'; p++) {
        switch (*p) {
        case '"': fputs("\\\"", f); break;
        case '\\': fputs("\\\\", f); break;
        case '\n': fputs("\\n", f); break;
        case '\r': fputs("\\r", f); break;
        case '\t': fputs("\\t", f); break;
        default:
            if (*p < 0x20u) {
                fprintf(f, "\\u%04x", (unsigned)*p);
            } else {
                fputc(*p, f);
            }
        }
    }
    fputc('"', f);
}

vd_status_t demo_read_file(const char *path, size_t max_bytes, char **buf, size_t *len, char *err, size_t err_len)
{
    *buf = NULL;
    *len = 0;
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        snprintf(err, err_len, "cannot open %s: %s", path, strerror(errno));
        return VD_ERR_IO;
    }
    size_t cap = 65536, n = 0;
    char *b = malloc(cap + 1);
    if (b == NULL) {
        fclose(f);
        snprintf(err, err_len, "out of memory reading %s", path);
        return VD_ERR_IO;
    }
    for (;;) {
        if (n == cap) {
            if (cap >= max_bytes) {
                free(b);
                fclose(f);
                snprintf(err, err_len, "%s is larger than %zu bytes", path, max_bytes);
                return VD_ERR_RANGE;
            }
            size_t ncap = cap * 2 > max_bytes ? max_bytes : cap * 2;
            char *nb = realloc(b, ncap + 1);
            if (nb == NULL) {
                free(b);
                fclose(f);
                snprintf(err, err_len, "out of memory reading %s", path);
                return VD_ERR_IO;
            }
            b = nb;
            cap = ncap;
        }
        size_t got = fread(b + n, 1, cap - n, f);
        n += got;
        if (got == 0) {
            break;
        }
    }
    bool bad = ferror(f) != 0;
    int e = errno;
    fclose(f);
    if (bad) {
        free(b);
        snprintf(err, err_len, "cannot read %s: %s", path, strerror(e));
        return VD_ERR_IO;
    }
    b[n] = '\0';
    *buf = b;
    *len = n;
    return VD_OK;
}
