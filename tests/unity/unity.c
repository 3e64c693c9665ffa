// SPDX-License-Identifier: MIT
// Unity-compatible runner for vd's tests (see unity.h). A failing assertion
// longjmps out of the test, as Unity does, so later lines of that test do not run.
#include "unity.h"

#include <inttypes.h>
#include <stdio.h>
#include <string.h>

static const char *g_file = "";
static const char *g_test = "";
static unsigned g_tests;
static unsigned g_failures;
static unsigned g_ignored;
static int g_failed;
static int g_ignored_now;
static jmp_buf g_abort;

void UnityBegin(const char *filename)
{
    const char *slash = strrchr(filename, '/');
    g_file = slash ? slash + 1 : filename;
    g_tests = g_failures = g_ignored = 0u;
}

int UnityEnd(void)
{
    printf("\n-----------------------\n%u Tests %u Failures %u Ignored\n%s\n", g_tests, g_failures,
           g_ignored, g_failures == 0u ? "OK" : "FAIL");
    fflush(stdout);
    return (int)g_failures;
}

void UnityDefaultTestRun(void (*func)(void), const char *name, int line)
{
    g_test = name;
    g_failed = 0;
    g_ignored_now = 0;
    g_tests++;
    if (setjmp(g_abort) == 0) {
        setUp();
        func();
    }
    if (setjmp(g_abort) == 0) {
        tearDown();
    }
    if (g_failed) {
        g_failures++;
    } else if (g_ignored_now) {
        g_ignored++;
    } else {
        printf("%s:%d:%s:PASS\n", g_file, line, name);
    }
    fflush(stdout);
}

static void fail_line(int line, const char *detail, const char *msg)
{
    printf("%s:%d:%s:FAIL: %s%s%s\n", g_file, line, g_test, detail ? detail : "", (msg && detail) ? " " : "",
           msg ? msg : "");
    fflush(stdout);
    g_failed = 1;
    longjmp(g_abort, 1);
}

void UnityFail(const char *msg, int line)
{
    fail_line(line, NULL, msg ? msg : "Failed");
}

void UnityIgnore(const char *msg, int line)
{
    printf("%s:%d:%s:IGNORE%s%s\n", g_file, line, g_test, msg ? ": " : "", msg ? msg : "");
    g_ignored_now = 1;
    longjmp(g_abort, 1);
}

void UnityAssertEqualNumber(int64_t expected, int64_t actual, const char *msg, int line, int is_unsigned)
{
    if (expected != actual) {
        char buf[96];
        if (is_unsigned) {
            snprintf(buf, sizeof buf, "Expected %" PRIu64 " Was %" PRIu64, (uint64_t)expected, (uint64_t)actual);
        } else {
            snprintf(buf, sizeof buf, "Expected %" PRId64 " Was %" PRId64, expected, actual);
        }
        fail_line(line, buf, msg);
    }
}

void UnityAssertWithin(uint64_t delta, int64_t expected, int64_t actual, const char *msg, int line)
{
    uint64_t diff = expected > actual ? (uint64_t)(expected - actual) : (uint64_t)(actual - expected);
    if (diff > delta) {
        char buf[128];
        snprintf(buf, sizeof buf, "Values Not Within Delta %" PRIu64 ". Expected %" PRId64 " Was %" PRId64, delta,
                 expected, actual);
        fail_line(line, buf, msg);
    }
}

void UnityAssertCompare(int64_t threshold, int64_t actual, int op, const char *msg, int line)
{
    static const char *const names[] = {"greater than", "less than", "greater or equal to", "less or equal to"};
    int ok = op == 0 ? actual > threshold : op == 1 ? actual < threshold : op == 2 ? actual >= threshold
                                                                                    : actual <= threshold;
    if (!ok) {
        char buf[128];
        snprintf(buf, sizeof buf, "Expected %s %" PRId64 " Was %" PRId64, names[op & 3], threshold, actual);
        fail_line(line, buf, msg);
    }
}

void UnityAssertEqualMemory(const void *expected, const void *actual, size_t len, size_t num, const char *msg, int line)
{
    const unsigned char *e = (const unsigned char *)expected;
    const unsigned char *a = (const unsigned char *)actual;
    if (len == 0u || num == 0u) {   // as real Unity: a zero-length comparison is a test bug
        fail_line(line, "You Asked Me To Compare Nothing, Which Was Pointless.", msg);
    }
    if (e == NULL || a == NULL) {
        fail_line(line, "Memory pointer is NULL", msg);
    }
    for (size_t i = 0; i < len * num; i++) {
        if (e[i] != a[i]) {
            char buf[96];
            snprintf(buf, sizeof buf, "Memory Mismatch at byte %zu: Expected 0x%02X Was 0x%02X", i, e[i], a[i]);
            fail_line(line, buf, msg);
        }
    }
}

void UnityAssertEqualString(const char *expected, const char *actual, const char *msg, int line)
{
    if (expected == NULL || actual == NULL || strcmp(expected, actual) != 0) {
        char buf[256];
        snprintf(buf, sizeof buf, "Expected '%s' Was '%s'", expected ? expected : "(null)", actual ? actual : "(null)");
        fail_line(line, buf, msg);
    }
}

static int64_t load_elem(const unsigned char *p, size_t elem, int is_signed)
{
    switch (elem) {
    case 1: return is_signed ? (int64_t)*(const int8_t *)p : (int64_t)*(const uint8_t *)p;
    case 2: { uint16_t v; memcpy(&v, p, 2); return is_signed ? (int64_t)(int16_t)v : (int64_t)v; }
    case 4: { uint32_t v; memcpy(&v, p, 4); return is_signed ? (int64_t)(int32_t)v : (int64_t)v; }
    default: { int64_t v; memcpy(&v, p, 8); return v; }
    }
}

void UnityAssertEqualIntArray(const void *expected, const void *actual, size_t num, size_t elem, int is_signed,
                              const char *msg, int line)
{
    const unsigned char *e = (const unsigned char *)expected;
    const unsigned char *a = (const unsigned char *)actual;
    if (elem == 0u || num == 0u) {   // as real Unity: a zero-length comparison is a test bug
        fail_line(line, "You Asked Me To Compare Nothing, Which Was Pointless.", msg);
    }
    if (e == NULL || a == NULL) {
        fail_line(line, "Array pointer is NULL", msg);
    }
    for (size_t i = 0; i < num; i++) {
        int64_t ev = load_elem(e + i * elem, elem, is_signed);
        int64_t av = load_elem(a + i * elem, elem, is_signed);
        if (ev != av) {
            char buf[128];
            snprintf(buf, sizeof buf, "Element %zu Expected %" PRId64 " Was %" PRId64, i, ev, av);
            fail_line(line, buf, msg);
        }
    }
}
