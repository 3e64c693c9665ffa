// SPDX-License-Identifier: MIT
// Replays fuzz inputs without libFuzzer: every file named (or found in a named directory) is passed to the
// harness's LLVMFuzzerTestOneInput, then, with -m N, N deterministic mutations of each file (bit flips,
// byte sets, truncations, insertions) so the normal gcc and ASan builds also exercise nearby inputs.
//
// Usage: fuzz_<target>_replay [-m N] <file|dir>...   Exit status 0 when every input returned; a finding
// aborts (non-zero exit, the harness names the failed invariant; the sanitizers print a stack).
#include "fuzz_common.h"

#include <dirent.h>
#include <sys/stat.h>

static size_t g_files;
static size_t g_runs;

static uint32_t xorshift(uint32_t *s)
{
    uint32_t x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *s = x;
    return x;
}

static void run_one(const uint8_t *p, size_t n)
{
    // A fresh heap copy of exactly n bytes, as libFuzzer gives, so over-reads are caught by ASan.
    uint8_t *copy = fz_alloc(n);
    if (n) {
        memcpy(copy, p, n);
    }
    (void)LLVMFuzzerTestOneInput(copy, n);
    free(copy);
    g_runs++;
}

static void mutate_runs(const uint8_t *p, size_t n, unsigned count, uint32_t seed)
{
    const size_t cap = n + 64u;
    uint8_t *buf = fz_alloc(cap);
    uint32_t s = seed | 1u;
    for (unsigned i = 0u; i < count; i++) {
        size_t len = n;
        if (n) {
            memcpy(buf, p, n);
        }
        const unsigned edits = 1u + xorshift(&s) % 4u;
        for (unsigned e = 0u; e < edits; e++) {
            const uint32_t k = xorshift(&s);
            switch (k % 5u) {
            case 0: // flip one bit
                if (len) {
                    buf[(k >> 3) % len] ^= (uint8_t)(1u << ((k >> 24) & 7u));
                }
                break;
            case 1: // set a byte to an edge value
                if (len) {
                    static const uint8_t edge[6] = {0x00, 0x01, 0x7F, 0x80, 0xFE, 0xFF};
                    buf[(k >> 3) % len] = edge[(k >> 24) % 6u];
                }
                break;
            case 2: // truncate
                len = len ? (k >> 3) % len : 0u;
                break;
            case 3: // append a few random bytes
                for (unsigned a = 0u; a < 1u + (k >> 28) && len < cap; a++) {
                    buf[len++] = (uint8_t)xorshift(&s);
                }
                break;
            default: // random byte
                if (len) {
                    buf[(k >> 3) % len] = (uint8_t)(k >> 24);
                }
                break;
            }
        }
        run_one(buf, len);
    }
    free(buf);
}

static int replay_file(const char *path, unsigned mutations)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        fprintf(stderr, "replay: cannot open %s\n", path);
        return 1;
    }
    uint8_t *buf = NULL;
    size_t len = 0u, cap = 0u;
    for (;;) {
        if (len == cap) {
            cap = cap ? 2u * cap : 4096u;
            uint8_t *nb = realloc(buf, cap);
            if (nb == NULL) {
                abort();
            }
            buf = nb;
        }
        const size_t got = fread(buf + len, 1u, cap - len, f);
        len += got;
        if (got == 0u) {
            break;
        }
    }
    fclose(f);
    run_one(buf, len);
    uint32_t seed = 2166136261u;
    for (const char *c = path; *c; c++) {
        seed = (seed ^ (uint8_t)*c) * 16777619u;
    }
    mutate_runs(buf, len, mutations, seed);
    free(buf);
    g_files++;
    return 0;
}

static int replay_path(const char *path, unsigned mutations)
{
    struct stat sb;
    if (stat(path, &sb) != 0) {
        // A target without regressions yet has no directory: nothing to replay.
        return 0;
    }
    if (!S_ISDIR(sb.st_mode)) {
        return replay_file(path, mutations);
    }
    DIR *d = opendir(path);
    if (d == NULL) {
        fprintf(stderr, "replay: cannot read %s\n", path);
        return 1;
    }
    int rc = 0;
    struct dirent *de;
    while ((de = readdir(d)) != NULL) {
        if (de->d_name[0] == '.') {
            continue;
        }
        char full[4096];
        if ((size_t)snprintf(full, sizeof(full), "%s/%s", path, de->d_name) >= sizeof(full)) {
            rc = 1;
            continue;
        }
        rc |= replay_file(full, mutations);
    }
    closedir(d);
    return rc;
}

int main(int argc, char **argv)
{
    unsigned mutations = 0u;
    int rc = 0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "-m") == 0 && i + 1 < argc) {
            mutations = (unsigned)strtoul(argv[++i], NULL, 10);
            continue;
        }
        rc |= replay_path(argv[i], mutations);
    }
    // The empty input too (every harness must accept it).
    run_one((const uint8_t *)"", 0u);
    printf("replayed %zu files, %zu inputs: no finding\n", g_files, g_runs);
    return rc;
}
