// SPDX-License-Identifier: MIT
// Unit tests of suppress.h: hand-worked suppression and ordering, a naive reference on random boxes, the merge's
// overlap test, arguments.
#include "unity.h"
#include "testutil.h"

#include <string.h>

void setUp(void) {}
void tearDown(void) {}

static vd_detection_t det(int32_t x, int32_t y, int32_t w, int32_t h, uint8_t score, uint32_t tag)
{
    vd_detection_t d;
    memset(&d, 0, sizeof(d));
    d.box.x = x;
    d.box.y = y;
    d.box.w = w;
    d.box.h = h;
    d.score_q8 = score;
    d.track_id = tag;   // identifies the detection in the checks
    return d;
}

static void test_hand_worked(void)
{
    vd_detection_t d[5];
    d[0] = det(0, 0, 10, 10, 100u, 1u);
    d[1] = det(1, 0, 10, 10, 200u, 2u);    // IoU with tag 1: 90 / 110 = 0.818 -> suppresses it
    d[2] = det(50, 50, 10, 10, 100u, 3u);  // same score as tag 1, later: stays after it
    d[3] = det(5, 0, 10, 10, 150u, 4u);    // IoU with tag 2: 60 / 140 = 0.43 <= 0.5: kept
    d[4] = det(80, 0, 4, 4, 100u, 5u);
    size_t k = 99u;
    vd_suppress_stats_t st;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_suppress_nms(d, 5u, 16384u, 10u, &k, &st));
    TEST_ASSERT_EQUAL_size_t(4u, k);
    TEST_ASSERT_EQUAL_UINT32(1u, st.suppressed);
    TEST_ASSERT_EQUAL_UINT32(0u, st.overflow);
    const uint32_t want[4] = {2u, 4u, 3u, 5u};   // score order, ties in input order
    for (size_t i = 0; i < 4u; i++) {
        TEST_ASSERT_EQUAL_UINT32(want[i], d[i].track_id);
    }
    // Budget: the third and fourth survivors overflow; suppression is counted first.
    d[0] = det(0, 0, 10, 10, 100u, 1u);
    d[1] = det(1, 0, 10, 10, 200u, 2u);
    d[2] = det(50, 50, 10, 10, 100u, 3u);
    d[3] = det(5, 0, 10, 10, 150u, 4u);
    d[4] = det(80, 0, 4, 4, 100u, 5u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_suppress_nms(d, 5u, 16384u, 2u, &k, &st));
    TEST_ASSERT_EQUAL_size_t(2u, k);
    TEST_ASSERT_EQUAL_UINT32(1u, st.suppressed);
    TEST_ASSERT_EQUAL_UINT32(2u, st.overflow);
    TEST_ASSERT_EQUAL_UINT32(2u, d[0].track_id);
    TEST_ASSERT_EQUAL_UINT32(4u, d[1].track_id);
    // 32768 suppresses nothing (IoU <= 1); identical boxes are suppressed at any lower threshold.
    d[0] = det(0, 0, 10, 10, 9u, 1u);
    d[1] = det(0, 0, 10, 10, 9u, 2u);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_suppress_nms(d, 2u, 32768u, 10u, &k, NULL));
    TEST_ASSERT_EQUAL_size_t(2u, k);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_suppress_nms(d, 2u, 32767u, 10u, &k, &st));
    TEST_ASSERT_EQUAL_size_t(1u, k);
    TEST_ASSERT_EQUAL_UINT32(1u, d[0].track_id);
    TEST_ASSERT_EQUAL_UINT32(1u, st.suppressed);
    // max_keep 0: nothing kept, every survivor overflows.
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_suppress_nms(d, 2u, 32768u, 0u, &k, &st));
    TEST_ASSERT_EQUAL_size_t(0u, k);
    TEST_ASSERT_EQUAL_UINT32(2u, st.overflow);
}

// Naive NMS: repeatedly take the best remaining (highest score, earliest on
// ties), keep it unless it overlaps a kept one.
static size_t naive_nms(const vd_detection_t *in, size_t n, uint32_t iou, size_t max_keep, vd_detection_t *out,
                        uint32_t *suppressed, uint32_t *overflow)
{
    bool used[64];
    memset(used, 0, sizeof(used));
    size_t k = 0u;
    *suppressed = 0u;
    *overflow = 0u;
    for (size_t round = 0; round < n; round++) {
        size_t best = n;
        for (size_t i = 0; i < n; i++) {
            if (!used[i] && (best == n || in[i].score_q8 > in[best].score_q8)) {
                best = i;
            }
        }
        used[best] = true;
        bool ok = true;
        for (size_t j = 0; j < k; j++) {
            ok = ok && vd_rect_iou_q15(&in[best].box, &out[j].box) <= iou;
        }
        if (!ok) {
            (*suppressed)++;
        } else if (k >= max_keep) {
            (*overflow)++;
        } else {
            out[k++] = in[best];
        }
    }
    return k;
}

static void test_random_vs_naive(void)
{
    uint32_t seed = 42u;
    vd_detection_t in[64];
    vd_detection_t d[64];
    vd_detection_t ref[64];
    for (int trial = 0; trial < 500; trial++) {
        const size_t n = tu_rand(&seed) % 65u;
        for (size_t i = 0; i < n; i++) {
            in[i] = det((int32_t)(tu_rand(&seed) % 60u), (int32_t)(tu_rand(&seed) % 60u),
                        (int32_t)(1u + tu_rand(&seed) % 30u), (int32_t)(1u + tu_rand(&seed) % 30u),
                        (uint8_t)(tu_rand(&seed) % 8u), (uint32_t)i);   // few scores: many ties
        }
        memcpy(d, in, n * sizeof(in[0]));
        const uint32_t iou = tu_rand(&seed) % 32769u;
        const size_t max_keep = tu_rand(&seed) % 70u;
        uint32_t sup = 0u;
        uint32_t ovf = 0u;
        const size_t nref = naive_nms(in, n, iou, max_keep, ref, &sup, &ovf);
        size_t k = 0u;
        vd_suppress_stats_t st;
        TEST_ASSERT_EQUAL_INT(VD_OK, vd_suppress_nms(n == 0u ? NULL : d, n, iou, max_keep, &k, &st));
        TEST_ASSERT_EQUAL_size_t(nref, k);
        TEST_ASSERT_EQUAL_UINT32(sup, st.suppressed);
        TEST_ASSERT_EQUAL_UINT32(ovf, st.overflow);
        if (k > 0u) {
            TEST_ASSERT_EQUAL_MEMORY(ref, d, k * sizeof(d[0]));
        }
    }
}

static void test_overlaps(void)
{
    vd_detection_t list[3];
    list[0] = det(0, 0, 10, 10, 0u, 1u);
    list[1] = det(20, 0, 10, 10, 0u, 2u);
    list[2] = det(40, 0, 10, 10, 0u, 3u);
    const vd_rect_t b = {21, 0, 10, 10};   // IoU with list[1]: 90 / 110 = 0.818 = 26810 in Q15
    const uint32_t iou = vd_rect_iou_q15(&b, &list[1].box);
    TEST_ASSERT_TRUE(vd_suppress_overlaps(&b, list, 3u, iou - 1u));
    TEST_ASSERT_FALSE(vd_suppress_overlaps(&b, list, 3u, iou));   // strictly greater
    TEST_ASSERT_FALSE(vd_suppress_overlaps(&b, list, 1u, 0u));    // only list[0]: no overlap at all
    TEST_ASSERT_FALSE(vd_suppress_overlaps(&b, list, 0u, 0u));
    TEST_ASSERT_FALSE(vd_suppress_overlaps(NULL, list, 3u, 0u));
    TEST_ASSERT_FALSE(vd_suppress_overlaps(&b, NULL, 3u, 0u));
}

static void test_arguments(void)
{
    vd_detection_t d[1];
    d[0] = det(0, 0, 1, 1, 1u, 1u);
    size_t k = 7u;
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_suppress_nms(d, 1u, 16384u, 1u, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(VD_ERR_ARG, vd_suppress_nms(NULL, 1u, 16384u, 1u, &k, NULL));
    TEST_ASSERT_EQUAL_size_t(0u, k);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_suppress_nms(NULL, 0u, 16384u, 1u, &k, NULL));
    TEST_ASSERT_EQUAL_size_t(0u, k);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_suppress_nms(d, 1u, 16384u, 1u, &k, NULL));
    TEST_ASSERT_EQUAL_size_t(1u, k);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_hand_worked);
    RUN_TEST(test_random_vs_naive);
    RUN_TEST(test_overlaps);
    RUN_TEST(test_arguments);
    return UNITY_END();
}
