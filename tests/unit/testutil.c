// SPDX-License-Identifier: MIT
#include "testutil.h"
#include "unity.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define TU_GUARD 64u
#define TU_SLOTS 4

static uint8_t *g_raw[TU_SLOTS];
static size_t g_bytes[TU_SLOTS];

void *tu_guarded_alloc(int slot, size_t bytes)
{
    tu_guarded_free(slot);
    g_raw[slot] = (uint8_t *)malloc(bytes + 2u * TU_GUARD);
    TEST_ASSERT_NOT_NULL(g_raw[slot]);
    g_bytes[slot] = bytes;
    memset(g_raw[slot], 0xA5, bytes + 2u * TU_GUARD);
    return g_raw[slot] + TU_GUARD;
}

void tu_guard_check(int slot)
{
    const uint8_t *p = g_raw[slot];
    TEST_ASSERT_NOT_NULL(p);
    for (size_t i = 0; i < TU_GUARD; i++) {
        TEST_ASSERT_EQUAL_HEX8_MESSAGE(0xA5, p[i], "guard before workspace overwritten");
        TEST_ASSERT_EQUAL_HEX8_MESSAGE(0xA5, p[TU_GUARD + g_bytes[slot] + i], "guard after workspace overwritten");
    }
}

void tu_guarded_free(int slot)
{
    free(g_raw[slot]);
    g_raw[slot] = NULL;
    g_bytes[slot] = 0u;
}

void tu_check_workspace_contract(size_t bytes, tu_ws_fn run, void *ctx)
{
    TEST_ASSERT_TRUE(bytes > 0u);
    uint8_t *ws = (uint8_t *)tu_guarded_alloc(3, bytes);
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, run(NULL, bytes, ctx));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, run(ws, bytes - 1u, ctx));
    TEST_ASSERT_EQUAL_INT(VD_ERR_WORKSPACE, run(ws + 1, bytes - 1u, ctx));
    tu_guard_check(3);
    TEST_ASSERT_EQUAL_INT(VD_OK, run(ws, bytes, ctx));
    tu_guard_check(3);
    tu_guarded_free(3);
}

void tu_assert_rect_equal(const vd_rect_t *want, const vd_rect_t *got, const char *msg)
{
    TEST_ASSERT_EQUAL_INT32_MESSAGE(want->x, got->x, msg);
    TEST_ASSERT_EQUAL_INT32_MESSAGE(want->y, got->y, msg);
    TEST_ASSERT_EQUAL_INT32_MESSAGE(want->w, got->w, msg);
    TEST_ASSERT_EQUAL_INT32_MESSAGE(want->h, got->h, msg);
}

int64_t tu_calib_temp_ck(const vd_calib_t *c, uint32_t raw)
{
    int64_t p = (int64_t)raw * c->gain_q16;
    return (int64_t)c->offset_ck + p / 65536 + ((p % 65536) >= 32768 ? 1 : 0);
}

uint32_t tu_rand(uint32_t *state)
{
    uint32_t x = *state ? *state : 0x9E3779B9u;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *state = x;
    return x;
}

const char *tu_data_dir(void)
{
    static char path[1024];
    const char *env = getenv("VD_DATA_DIR");
    snprintf(path, sizeof path, "%s", env ? env : VD_DATA_DIR);
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISDIR(st.st_mode)) {
        return NULL;
    }
    return path;
}

void tu_wr16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)((v >> 8) & 0xFFu);
}

void tu_wr32(uint8_t *p, uint32_t v)
{
    tu_wr16(p, v & 0xFFFFu);
    tu_wr16(p + 2, v >> 16);
}

uint32_t tu_rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

/* CRC-32 (IEEE 802.3, reflected 0xEDB88320) bit by bit: an independent reference for the library's
 * table-driven one, and it keeps these helpers on the public API only, so the port tests link them
 * with the shipped libvd.a (whose internal functions are local). */
uint32_t tu_crc32(const uint8_t *p, size_t n)
{
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0u; i < n; i++) {
        c ^= (uint32_t)p[i];
        for (int k = 0; k < 8; k++) {
            c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
        }
    }
    return ~c;
}

void tu_vdm_fix_crc(uint8_t *blob)
{
    const uint32_t total = tu_rd32(blob + 8);
    tu_wr32(blob + 12, tu_crc32(blob + 16, total - 16u));
}
