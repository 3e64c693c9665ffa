// SPDX-License-Identifier: MIT
// Atomic output files for vd_fir_demo: write to a hidden temporary name, rename() on success;
// the directories they go to, and the file-name part of a path.
//
// rename() within one directory is atomic on POSIX file systems, so a reader
// sees either no file or the complete file, and an error or a crash leaves at
// most a hidden ".<name>.tmp.<pid>" behind (removed on the error paths).
#include "out.h"

#include <errno.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

const char *demo_basename(const char *path)
{
    const char *s = strrchr(path, '/');
    return s != NULL ? s + 1 : path;
}

vd_status_t demo_atomic_open(demo_atomic_t *a, const char *path, char *err, size_t err_len)
{
    memset(a, 0, sizeof *a);
    size_t l = strlen(path);
    if (l == 0 || l >= sizeof a->final_path) {
        snprintf(err, err_len, "bad output path '%s'", path);
        return VD_ERR_ARG;
    }
    memcpy(a->final_path, path, l + 1);
    const char *base = demo_basename(path);
    int dirlen = (int)(base - path);
    snprintf(a->tmp_path, sizeof a->tmp_path, "%.*s.%s.tmp.%ld", dirlen, path, base, (long)getpid());
    a->f = fopen(a->tmp_path, "wb");
    if (a->f == NULL) {
        snprintf(err, err_len, "cannot write %s: %s", path, strerror(errno));
        return VD_ERR_IO;
    }
    return VD_OK;
}

vd_status_t demo_atomic_commit(demo_atomic_t *a, char *err, size_t err_len)
{
    if (a->f == NULL) {
        snprintf(err, err_len, "internal: output %s not open", a->final_path);
        return VD_ERR_STATE;
    }
    bool bad = fflush(a->f) != 0 || ferror(a->f) != 0;
    int e = errno;
    if (fclose(a->f) != 0 && !bad) {
        bad = true;
        e = errno;
    }
    a->f = NULL;
    if (bad) {
        remove(a->tmp_path);
        snprintf(err, err_len, "cannot write %s: %s", a->final_path, strerror(e));
        return VD_ERR_IO;
    }
    if (rename(a->tmp_path, a->final_path) != 0) {
        e = errno;
        remove(a->tmp_path);
        snprintf(err, err_len, "cannot rename %s to %s: %s", a->tmp_path, a->final_path, strerror(e));
        return VD_ERR_IO;
    }
    return VD_OK;
}

void demo_atomic_abort(demo_atomic_t *a)
{
    if (a->f != NULL) {
        fclose(a->f);
        a->f = NULL;
        remove(a->tmp_path);
    }
}

vd_status_t demo_mkdirs(const char *path, char *err, size_t err_len)
{
    char p[4096];
    size_t l = strlen(path);
    if (l == 0 || l >= sizeof p) {
        snprintf(err, err_len, "bad directory path '%s'", path);
        return VD_ERR_ARG;
    }
    memcpy(p, path, l + 1);
    // Each '/' is visited once: bounded by the path length.
    for (size_t i = 1; i <= l; i++) {
        if (p[i] == '/' || p[i] == '\0') {
            char saved = p[i];
            p[i] = '\0';
            if (mkdir(p, 0777) != 0 && errno != EEXIST) {
                snprintf(err, err_len, "cannot create directory %s: %s", p, strerror(errno));
                return VD_ERR_IO;
            }
            p[i] = saved;
        }
    }
    struct stat sb;
    if (stat(path, &sb) != 0 || !S_ISDIR(sb.st_mode)) {
        snprintf(err, err_len, "%s is not a directory", path);
        return VD_ERR_IO;
    }
    return VD_OK;
}
