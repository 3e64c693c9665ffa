// SPDX-License-Identifier: MIT
// detection.h: the JSON Lines names of sources and track states (DESIGN.md contract).
#include <string.h>

#include "unity.h"
#include "vd/detection.h"
#include "vd/temporal.h"

void setUp(void) {}
void tearDown(void) {}

static void test_source_names(void)
{
    TEST_ASSERT_EQUAL_STRING("hotspot", vd_detection_source_name(VD_DETECTION_SOURCE_HOTSPOT));
    TEST_ASSERT_EQUAL_STRING("window", vd_detection_source_name(VD_DETECTION_SOURCE_WINDOW));
    TEST_ASSERT_EQUAL_STRING("contrast", vd_detection_source_name(VD_DETECTION_SOURCE_CONTRAST));
    TEST_ASSERT_EQUAL_STRING("cnn", vd_detection_source_name(VD_DETECTION_SOURCE_CNN));
    TEST_ASSERT_EQUAL_STRING("unknown", vd_detection_source_name(0u));
    TEST_ASSERT_EQUAL_STRING("unknown", vd_detection_source_name(5u));
    TEST_ASSERT_EQUAL_STRING("unknown", vd_detection_source_name(255u));
}

static void test_state_names(void)
{
    // temporal analysis off leaves VD_TRACK_NONE: the contract calls that "new"
    TEST_ASSERT_EQUAL_STRING("new", vd_detection_state_name(VD_TRACK_NONE));
    TEST_ASSERT_EQUAL_STRING("new", vd_detection_state_name(VD_TRACK_NEW));
    TEST_ASSERT_EQUAL_STRING("confirmed", vd_detection_state_name(VD_TRACK_CONFIRMED));
    TEST_ASSERT_EQUAL_STRING("recovered", vd_detection_state_name(VD_TRACK_RECOVERED));
    TEST_ASSERT_EQUAL_STRING("unknown", vd_detection_state_name(4u));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_source_names);
    RUN_TEST(test_state_names);
    return UNITY_END();
}
