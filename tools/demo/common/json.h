// SPDX-License-Identifier: MIT
// Bounded JSON reader and writer helpers of vd_demo_common (json.c): the --config and --eval
// readers of vd_fir_demo and the GStreamer element's config property.
#ifndef VD_DEMO_JSON_H
#define VD_DEMO_JSON_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "vd/status.h"

// The whole text is tokenised into a flat array (like jsmn) by a loop with an explicit
// stack: no recursion, nesting at most DEMO_JSON_MAX_DEPTH, at most DEMO_JSON_MAX_TOKENS
// tokens, text at most DEMO_JSON_MAX_BYTES. Strict RFC 8259 syntax (no comments, no
// trailing commas).
#define DEMO_JSON_MAX_DEPTH 64
#define DEMO_JSON_MAX_TOKENS 20000000u
#define DEMO_JSON_MAX_BYTES (512u * 1024u * 1024u)

typedef enum demo_json_type {
    DEMO_JSON_OBJECT = 1,
    DEMO_JSON_ARRAY,
    DEMO_JSON_STRING,
    DEMO_JSON_NUMBER,
    DEMO_JSON_TRUE,
    DEMO_JSON_FALSE,
    DEMO_JSON_NULL
} demo_json_type_t;

typedef struct demo_json_tok {
    demo_json_type_t type;
    uint32_t size;   // object: number of keys; array: number of elements
    uint32_t next;   // index of the first token after this value's subtree
    size_t start;    // byte span in the text (strings: without the quotes)
    size_t len;
} demo_json_tok_t;

typedef struct demo_json {
    const char *text;
    size_t text_len;
    demo_json_tok_t *tok;   // malloc'd
    uint32_t n;
    uint32_t cap;
} demo_json_t;

// Parses text[0..len). On failure returns VD_ERR_FORMAT (syntax, with line
// and column in err), VD_ERR_RANGE (too deep, too many tokens, too long) or
// VD_ERR_IO (out of memory); doc is then empty. text must outlive doc.
vd_status_t demo_json_parse(demo_json_t *doc, const char *text, size_t len, char *err, size_t err_len);
void demo_json_free(demo_json_t *doc);
// Value of `key` in object token `obj`; -1 if absent or obj is not an object.
int64_t demo_json_get(const demo_json_t *doc, uint32_t obj, const char *key);
// First element / next sibling of an array (or first key of an object); -1 at the end.
int64_t demo_json_first(const demo_json_t *doc, uint32_t container);
int64_t demo_json_sibling(const demo_json_t *doc, uint32_t elem);
// Number value; false if the token is not a number.
bool demo_json_number(const demo_json_t *doc, int64_t idx, double *out);
// String value decoded (escapes, \u to UTF-8) into buf (NUL-terminated); false if
// not a string, if it does not fit, or if it contains a NUL.
bool demo_json_string(const demo_json_t *doc, int64_t idx, char *buf, size_t cap);
// True if key token `idx` (a string) equals `key` after decoding.
bool demo_json_string_eq(const demo_json_t *doc, int64_t idx, const char *key);

// JSON writer helpers: a string with escapes (quotes included).
void demo_json_write_string(FILE *f, const char *s);

// Reads a whole file (at most max_bytes) into malloc'd memory plus a NUL.
vd_status_t demo_read_file(const char *path, size_t max_bytes, char **buf, size_t *len, char *err, size_t err_len);

#endif
