// SPDX-License-Identifier: MIT
// Scratch-directory and file helpers for the port tests.
#include "port_testutil.h"
#include "unity.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char g_dir[512];
static char g_paths[8][1024];
static unsigned g_next;

const char *pt_tmpdir(void)
{
    pt_tmpdir_remove();
    const char *base = getenv("TMPDIR");
    (void)snprintf(g_dir, sizeof(g_dir), "%s/vd_port_test_XXXXXX", base != NULL ? base : "/tmp");
    TEST_ASSERT_NOT_NULL(mkdtemp(g_dir));
    return g_dir;
}

static void remove_tree(const char *dir, int depth)
{
    DIR *d = opendir(dir);
    if (d == NULL) {
        return;
    }
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) {
            continue;
        }
        char p[1024];
        (void)snprintf(p, sizeof(p), "%s/%s", dir, e->d_name);
        struct stat sb;
        if (lstat(p, &sb) == 0 && S_ISDIR(sb.st_mode) && depth > 0) {
            remove_tree(p, depth - 1);
        } else {
            (void)unlink(p);
        }
    }
    (void)closedir(d);
    (void)rmdir(dir);
}

void pt_tmpdir_remove(void)
{
    if (g_dir[0] != '\0') {
        remove_tree(g_dir, 2);
        g_dir[0] = '\0';
    }
}

const char *pt_path(const char *name)
{
    char *p = g_paths[g_next++ % 8u];
    (void)snprintf(p, sizeof(g_paths[0]), "%s/%s", g_dir, name);
    return p;
}

const char *pt_write(const char *name, const void *data, size_t len)
{
    const char *p = pt_path(name);
    FILE *fp = fopen(p, "wb");
    TEST_ASSERT_NOT_NULL(fp);
    if (len != 0u) {
        TEST_ASSERT_EQUAL_size_t(len, fwrite(data, 1u, len, fp));
    }
    TEST_ASSERT_EQUAL_INT(0, fclose(fp));
    return p;
}

const char *pt_write_pgm(const char *name, const char *header, const void *data, size_t len)
{
    size_t hl = strlen(header);
    uint8_t *buf = (uint8_t *)malloc(hl + len + 1u);
    TEST_ASSERT_NOT_NULL(buf);
    memcpy(buf, header, hl);
    if (len != 0u) {
        memcpy(buf + hl, data, len);
    }
    const char *p = pt_write(name, buf, hl + len);
    free(buf);
    return p;
}

long pt_read(const char *path, uint8_t *buf, size_t cap)
{
    FILE *fp = fopen(path, "rb");
    if (fp == NULL) {
        return -1;
    }
    size_t n = fread(buf, 1u, cap, fp);
    (void)fclose(fp);
    return (long)n;
}
