// SPDX-License-Identifier: MIT
// A small Unity-compatible test runner, written for vd. It implements the
// subset of the Unity API (ThrowTheSwitch.org) that vd's tests use, with the
// same macros and the same result lines ("N Tests N Failures N Ignored",
// then "OK" or "FAIL"), so the tests build unchanged against real Unity
// (-DVD_UNITY_DIR=...). See docs/testing.md.
#ifndef VD_UNITY_COMPAT_H
#define VD_UNITY_COMPAT_H

#include <setjmp.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

void setUp(void);
void tearDown(void);

void UnityBegin(const char *filename);
int UnityEnd(void);
void UnityDefaultTestRun(void (*func)(void), const char *name, int line);
void UnityFail(const char *msg, int line);
void UnityIgnore(const char *msg, int line);
void UnityAssertEqualNumber(int64_t expected, int64_t actual, const char *msg, int line, int is_unsigned);
void UnityAssertWithin(uint64_t delta, int64_t expected, int64_t actual, const char *msg, int line);
void UnityAssertCompare(int64_t threshold, int64_t actual, int op, const char *msg, int line);
void UnityAssertEqualMemory(const void *expected, const void *actual, size_t len, size_t num, const char *msg, int line);
void UnityAssertEqualString(const char *expected, const char *actual, const char *msg, int line);
void UnityAssertEqualIntArray(const void *expected, const void *actual, size_t num, size_t elem, int is_signed, const char *msg, int line);

#define UNITY_BEGIN() UnityBegin(__FILE__)
#define UNITY_END() UnityEnd()
#define RUN_TEST(func) UnityDefaultTestRun(func, #func, __LINE__)

#define TEST_FAIL_MESSAGE(msg) UnityFail((msg), __LINE__)
#define TEST_FAIL() UnityFail(NULL, __LINE__)
#define TEST_IGNORE_MESSAGE(msg) UnityIgnore((msg), __LINE__)
#define TEST_IGNORE() UnityIgnore(NULL, __LINE__)
#define TEST_MESSAGE(msg) ((void)(msg))

#define TEST_ASSERT_MESSAGE(c, msg) do { if (!(c)) { UnityFail((msg), __LINE__); } } while (0)
#define TEST_ASSERT(c) TEST_ASSERT_MESSAGE((c), "Expression Evaluated To FALSE")
#define TEST_ASSERT_TRUE(c) TEST_ASSERT_MESSAGE((c), "Expected TRUE Was FALSE")
#define TEST_ASSERT_FALSE(c) TEST_ASSERT_MESSAGE(!(c), "Expected FALSE Was TRUE")
#define TEST_ASSERT_TRUE_MESSAGE(c, m) TEST_ASSERT_MESSAGE((c), (m))
#define TEST_ASSERT_FALSE_MESSAGE(c, m) TEST_ASSERT_MESSAGE(!(c), (m))
#define TEST_ASSERT_NULL(p) TEST_ASSERT_MESSAGE((p) == NULL, "Expected NULL")
#define TEST_ASSERT_NOT_NULL(p) TEST_ASSERT_MESSAGE((p) != NULL, "Expected Non-NULL")
#define TEST_ASSERT_NULL_MESSAGE(p, m) TEST_ASSERT_MESSAGE((p) == NULL, (m))
#define TEST_ASSERT_NOT_NULL_MESSAGE(p, m) TEST_ASSERT_MESSAGE((p) != NULL, (m))
#define TEST_ASSERT_EQUAL_PTR(e, a) TEST_ASSERT_MESSAGE((const void *)(e) == (const void *)(a), "Expected Pointer Equal")

#define UNITY_EQ_S(e, a, m) UnityAssertEqualNumber((int64_t)(e), (int64_t)(a), (m), __LINE__, 0)
#define UNITY_EQ_U(e, a, m) UnityAssertEqualNumber((int64_t)(e), (int64_t)(a), (m), __LINE__, 1)
#define TEST_ASSERT_EQUAL(e, a) UNITY_EQ_S(e, a, NULL)
#define TEST_ASSERT_EQUAL_INT(e, a) UNITY_EQ_S(e, a, NULL)
#define TEST_ASSERT_EQUAL_INT8(e, a) UNITY_EQ_S(e, a, NULL)
#define TEST_ASSERT_EQUAL_INT16(e, a) UNITY_EQ_S(e, a, NULL)
#define TEST_ASSERT_EQUAL_INT32(e, a) UNITY_EQ_S(e, a, NULL)
#define TEST_ASSERT_EQUAL_INT64(e, a) UNITY_EQ_S(e, a, NULL)
#define TEST_ASSERT_EQUAL_UINT(e, a) UNITY_EQ_U(e, a, NULL)
#define TEST_ASSERT_EQUAL_UINT8(e, a) UNITY_EQ_U(e, a, NULL)
#define TEST_ASSERT_EQUAL_UINT16(e, a) UNITY_EQ_U(e, a, NULL)
#define TEST_ASSERT_EQUAL_UINT32(e, a) UNITY_EQ_U(e, a, NULL)
#define TEST_ASSERT_EQUAL_UINT64(e, a) UNITY_EQ_U(e, a, NULL)
#define TEST_ASSERT_EQUAL_size_t(e, a) UNITY_EQ_U(e, a, NULL)
#define TEST_ASSERT_EQUAL_HEX8(e, a) UNITY_EQ_U(e, a, NULL)
#define TEST_ASSERT_EQUAL_HEX16(e, a) UNITY_EQ_U(e, a, NULL)
#define TEST_ASSERT_EQUAL_HEX32(e, a) UNITY_EQ_U(e, a, NULL)
#define TEST_ASSERT_EQUAL_HEX8_MESSAGE(e, a, m) UNITY_EQ_U(e, a, m)
#define TEST_ASSERT_EQUAL_INT_MESSAGE(e, a, m) UNITY_EQ_S(e, a, m)
#define TEST_ASSERT_EQUAL_INT32_MESSAGE(e, a, m) UNITY_EQ_S(e, a, m)
#define TEST_ASSERT_EQUAL_UINT_MESSAGE(e, a, m) UNITY_EQ_U(e, a, m)
#define TEST_ASSERT_EQUAL_UINT8_MESSAGE(e, a, m) UNITY_EQ_U(e, a, m)
#define TEST_ASSERT_EQUAL_UINT16_MESSAGE(e, a, m) UNITY_EQ_U(e, a, m)
#define TEST_ASSERT_EQUAL_UINT32_MESSAGE(e, a, m) UNITY_EQ_U(e, a, m)
#define TEST_ASSERT_EQUAL_size_t_MESSAGE(e, a, m) UNITY_EQ_U(e, a, m)
#define TEST_ASSERT_NOT_EQUAL(e, a) TEST_ASSERT_MESSAGE((e) != (a), "Expected Not-Equal")
#define TEST_ASSERT_INT_WITHIN(d, e, a) UnityAssertWithin((uint64_t)(d), (int64_t)(e), (int64_t)(a), NULL, __LINE__)
#define TEST_ASSERT_UINT_WITHIN(d, e, a) UnityAssertWithin((uint64_t)(d), (int64_t)(e), (int64_t)(a), NULL, __LINE__)
#define TEST_ASSERT_INT_WITHIN_MESSAGE(d, e, a, m) UnityAssertWithin((uint64_t)(d), (int64_t)(e), (int64_t)(a), (m), __LINE__)
#define TEST_ASSERT_INT32_WITHIN(d, e, a) TEST_ASSERT_INT_WITHIN(d, e, a)

// op: 0 >, 1 <, 2 >=, 3 <=  (Unity semantics: compare ACTUAL against THRESHOLD)
#define TEST_ASSERT_GREATER_THAN(t, a) UnityAssertCompare((int64_t)(t), (int64_t)(a), 0, NULL, __LINE__)
#define TEST_ASSERT_LESS_THAN(t, a) UnityAssertCompare((int64_t)(t), (int64_t)(a), 1, NULL, __LINE__)
#define TEST_ASSERT_GREATER_OR_EQUAL(t, a) UnityAssertCompare((int64_t)(t), (int64_t)(a), 2, NULL, __LINE__)
#define TEST_ASSERT_LESS_OR_EQUAL(t, a) UnityAssertCompare((int64_t)(t), (int64_t)(a), 3, NULL, __LINE__)
#define TEST_ASSERT_GREATER_THAN_INT(t, a) TEST_ASSERT_GREATER_THAN(t, a)
#define TEST_ASSERT_LESS_THAN_INT(t, a) TEST_ASSERT_LESS_THAN(t, a)
#define TEST_ASSERT_GREATER_OR_EQUAL_INT(t, a) TEST_ASSERT_GREATER_OR_EQUAL(t, a)
#define TEST_ASSERT_LESS_OR_EQUAL_INT(t, a) TEST_ASSERT_LESS_OR_EQUAL(t, a)
#define TEST_ASSERT_GREATER_THAN_UINT32(t, a) TEST_ASSERT_GREATER_THAN(t, a)
#define TEST_ASSERT_LESS_OR_EQUAL_UINT32(t, a) TEST_ASSERT_LESS_OR_EQUAL(t, a)

#define TEST_ASSERT_EQUAL_MEMORY(e, a, len) UnityAssertEqualMemory((e), (a), (size_t)(len), 1u, NULL, __LINE__)
#define TEST_ASSERT_EQUAL_MEMORY_MESSAGE(e, a, len, m) UnityAssertEqualMemory((e), (a), (size_t)(len), 1u, (m), __LINE__)
#define TEST_ASSERT_EQUAL_STRING(e, a) UnityAssertEqualString((e), (a), NULL, __LINE__)
#define TEST_ASSERT_EQUAL_STRING_MESSAGE(e, a, m) UnityAssertEqualString((e), (a), (m), __LINE__)
#define TEST_ASSERT_EQUAL_UINT8_ARRAY(e, a, n) UnityAssertEqualIntArray((e), (a), (size_t)(n), 1u, 0, NULL, __LINE__)
#define TEST_ASSERT_EQUAL_UINT16_ARRAY(e, a, n) UnityAssertEqualIntArray((e), (a), (size_t)(n), 2u, 0, NULL, __LINE__)
#define TEST_ASSERT_EQUAL_UINT32_ARRAY(e, a, n) UnityAssertEqualIntArray((e), (a), (size_t)(n), 4u, 0, NULL, __LINE__)
#define TEST_ASSERT_EQUAL_INT8_ARRAY(e, a, n) UnityAssertEqualIntArray((e), (a), (size_t)(n), 1u, 1, NULL, __LINE__)
#define TEST_ASSERT_EQUAL_INT16_ARRAY(e, a, n) UnityAssertEqualIntArray((e), (a), (size_t)(n), 2u, 1, NULL, __LINE__)
#define TEST_ASSERT_EQUAL_INT32_ARRAY(e, a, n) UnityAssertEqualIntArray((e), (a), (size_t)(n), 4u, 1, NULL, __LINE__)
#define TEST_ASSERT_EQUAL_INT_ARRAY(e, a, n) UnityAssertEqualIntArray((e), (a), (size_t)(n), sizeof(int), 1, NULL, __LINE__)
#define TEST_ASSERT_EQUAL_INT8_ARRAY_MESSAGE(e, a, n, m) UnityAssertEqualIntArray((e), (a), (size_t)(n), 1u, 1, (m), __LINE__)

#ifdef __cplusplus
}
#endif
#endif
