// SPDX-License-Identifier: MIT
// The 0.1 names of vd/deprecated.h still compile and are the 0.2 functions, types and constants.
#undef VD_NO_DEPRECATED   // tests/CMakeLists.txt defines it for every other test
#include "unity.h"

#include <string.h>

#include "vd/vd.h"

void setUp(void) {}
void tearDown(void) {}

static void test_function_aliases_are_the_new_functions(void)
{
    TEST_ASSERT_TRUE(&vd_contours_workspace_size == &vd_contour_workspace_size);
    TEST_ASSERT_TRUE(&vd_contours_find_external == &vd_contour_find_external);
    TEST_ASSERT_TRUE(&vd_cc_rules_default == &vd_components_rules_default);
    TEST_ASSERT_TRUE(&vd_cc_rules_resolve == &vd_components_rules_resolve);
    TEST_ASSERT_TRUE(&vd_fill_holes_workspace_size == &vd_refine_fill_holes_workspace_size);
    TEST_ASSERT_TRUE(&vd_fill_holes_u8 == &vd_refine_fill_holes_u8);
    TEST_ASSERT_TRUE(&vd_edges_u8 == &vd_refine_edges_u8);
    TEST_ASSERT_TRUE(&vd_maxdist_from_hist == &vd_refine_maxdist_from_hist);
    TEST_ASSERT_TRUE(&vd_roi_resolve == &vd_rect_roi_resolve);
}

static void test_old_code_still_compiles(void)
{
    // A 0.1 caller: paper rules through the old type and functions.
    vd_cc_rules_t rules;
    memset(&rules, 0, sizeof rules);
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_cc_rules_resolve(&rules));
    TEST_ASSERT_EQUAL_UINT16(77u, rules.aspect_min_q8);
    TEST_ASSERT_EQUAL_UINT32(120u, rules.min_area);
    struct vd_cc_stats st = {1u, 2u, 3u, 4u};
    vd_cc_stats_t st2 = st;
    TEST_ASSERT_EQUAL_UINT32(4u, st2.labels);
    size_t bytes = 0;
    TEST_ASSERT_EQUAL_INT(VD_OK, vd_contours_workspace_size(4u, 3u, &bytes));
    TEST_ASSERT_EQUAL_size_t(6u * 5u, bytes);   // (w + 2) * (h + 2)
    TEST_ASSERT_EQUAL_UINT32(8u, VD_CHAIN_NONE);
    TEST_ASSERT_EQUAL_UINT32(255u, VD_MAXDIST_MAX_COUNT);
    TEST_ASSERT_EQUAL_UINT32(384u, VD_EXPAND_W_Q8);
    TEST_ASSERT_EQUAL_UINT32(512u, VD_EXPAND_H_Q8);
    TEST_ASSERT_EQUAL_INT32(27315, VD_CK_PER_0C);
    vd_model_t m;
    memset(&m, 0, sizeof m);
    size_t ws = 0;
    TEST_ASSERT_EQUAL_INT(VD_ERR_STATE, vd_dbn_workspace_size(&m, &ws));   // not loaded
}

static void test_issue37_constants_are_the_new_ones(void)
{
    // detection.h and detector.h constants renamed to their header's prefix (issue 37).
    vd_detection_t d;
    memset(&d, 0, sizeof d);
    d.source = VD_SOURCE_CNN;
    d.flags = VD_DET_FLAG_RECOVERED | VD_DET_FLAG_UNVERIFIED;
    TEST_ASSERT_EQUAL_STRING("cnn", vd_detection_source_name(d.source));
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTION_FLAG_RECOVERED | VD_DETECTION_FLAG_UNVERIFIED, d.flags);
    TEST_ASSERT_EQUAL_UINT32(VD_DETECTION_SOURCE_HOTSPOT, VD_SOURCE_HOTSPOT);
    TEST_ASSERT_EQUAL_UINT32(VD_DETECTION_SOURCE_WINDOW, VD_SOURCE_WINDOW);
    TEST_ASSERT_EQUAL_UINT32(VD_DETECTION_SOURCE_CONTRAST, VD_SOURCE_CONTRAST);
    TEST_ASSERT_EQUAL_UINT32(VD_DETECTION_FLAG_DECIMATED, VD_DET_FLAG_DECIMATED);
    TEST_ASSERT_EQUAL_UINT32(VD_DETECTION_FLAG_CONTOUR_TRUNC, VD_DET_FLAG_CONTOUR_TRUNC);
    vd_detector_stats_t st;
    memset(&st, 0, sizeof st);
    st.time_us[VD_DET_STAGE_CNN] = 7u;
    TEST_ASSERT_EQUAL_UINT32(7u, st.time_us[VD_DETECTOR_STAGE_CNN]);
    TEST_ASSERT_EQUAL_INT(VD_DETECTOR_STAGE_THRESHOLD, VD_DET_STAGE_THRESHOLD);
    TEST_ASSERT_EQUAL_INT(VD_DETECTOR_STAGE_TOTAL, VD_DET_STAGE_TOTAL);
    TEST_ASSERT_EQUAL_INT(VD_DETECTOR_STAGE_COUNT, VD_DET_STAGE_COUNT);
    TEST_ASSERT_EQUAL_UINT32(9830u, VD_CNN_FLIP_IOU_Q15);
    // cnn.h: the header threshold, an int8 code and not a Q format, is score_threshold_i8.
    vd_cnn_model_t m;
    memset(&m, 0, sizeof m);
    m.score_threshold_q = -7;
    TEST_ASSERT_EQUAL_INT8(-7, m.score_threshold_i8);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_function_aliases_are_the_new_functions);
    RUN_TEST(test_old_code_still_compiles);
    RUN_TEST(test_issue37_constants_are_the_new_ones);
    return UNITY_END();
}
