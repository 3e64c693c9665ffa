// SPDX-License-Identifier: MIT
// The choice of --cnn-full-res / --cnn-polarity auto (tools/demo/common/flipagree.c) on hand-worked counts:
// ratings, the highest per polarity, the margin for the other polarity, the least frames, a fixed resolution,
// and the summary text (never past its buffer).
#include "unity.h"
#include "flipagree.h"

#include <math.h>
#include <string.h>

// Unity is built without double support: exact enough for ratings of q8 sums
#define ASSERT_NEAR(want, got) TEST_ASSERT_TRUE_MESSAGE(fabs((want) - (got)) < 1e-12, #got)

void setUp(void)
{
}

void tearDown(void)
{
}

// Configuration k with `boxes` boxes whose score_q8 sum is `q8sum` and `matched` pairs.
static void put(demo_autores_t *a, unsigned k, uint64_t boxes, uint64_t q8sum, uint64_t matched)
{
    a->boxes[k] = boxes;
    a->score_q8[k] = q8sum;
    a->matched[k] = matched;
    a->measured = (uint8_t)(a->measured | (1u << k));
}

static demo_autores_t fresh(uint32_t frames)
{
    demo_autores_t a;
    memset(&a, 0, sizeof a);
    a.frames = frames;
    a.fixed_res = DEMO_AUTORES_RES;   // resolution auto
    return a;
}

static void test_rating_is_mean_score_plus_a_quarter_of_the_agreement(void)
{
    demo_autores_t a = fresh(16u);
    put(&a, 0u, 4u, 4u * 102u, 1u);   // mean 102 / 255 = 0.4, agreement 2 x 1 / 4 = 0.5
    ASSERT_NEAR(0.4, demo_autores_mean_score(&a, 0u));
    ASSERT_NEAR(0.5, demo_autores_agreement(&a, 0u));
    ASSERT_NEAR(0.4 + 0.125, demo_autores_rating(&a, 0u));
    // no box, not measured, out of range: -1
    ASSERT_NEAR(-1.0, demo_autores_rating(&a, 1u));
    ASSERT_NEAR(-1.0, demo_autores_agreement(&a, DEMO_AUTORES_CONFIGS));
    ASSERT_NEAR(-1.0, demo_autores_mean_score(&a, 99u));
}

static void test_highest_resolution_ties_to_the_lower(void)
{
    demo_autores_t a = fresh(16u);
    put(&a, 0u, 2u, 204u, 1u);   // 0.4 + 0.25 = 0.65
    put(&a, 1u, 2u, 204u, 1u);   // the same: a tie keeps half
    put(&a, 2u, 2u, 255u, 0u);   // 0.5 + 0 = 0.5
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTOR_CNN_RES_HALF, demo_autores_decide(&a));
    put(&a, 2u, 2u, 306u, 1u);   // 0.6 + 0.25 = 0.85: quarter
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTOR_CNN_RES_QUARTER, demo_autores_decide(&a));
    TEST_ASSERT_EQUAL_UINT8(0u, a.inverted);
    // fewer than DEMO_AUTORES_MIN_FRAMES frames: the first configuration measured (half)
    a.frames = DEMO_AUTORES_MIN_FRAMES - 1u;
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTOR_CNN_RES_HALF, demo_autores_decide(&a));
}

static void test_inverted_only_above_the_margin(void)
{
    demo_autores_t a = fresh(20u);
    put(&a, 0u, 10u, 10u * 102u, 4u);   // half as is: 0.4 + 0.2 = 0.6
    put(&a, 1u, 10u, 10u * 51u, 0u);    // full as is: 0.2
    put(&a, 2u, 0u, 0u, 0u);            // quarter as is: no box
    // full inverted: 0.6 + the margin exactly (mean 0.6 + margin, agreement 0): not above it, as it is
    const uint64_t at = (uint64_t)((0.6 + DEMO_AUTORES_INVERT_MARGIN) * 255.0 * 100.0 + 0.5);
    put(&a, 3u, 2u, 2u * 51u, 0u);      // half inverted: 0.2
    put(&a, 4u, 100u, at, 0u);          // ~0.6 + margin (rounded to q8 sums: within 1/25500)
    put(&a, 5u, 2u, 2u * 51u, 0u);
    const double r4 = demo_autores_rating(&a, 4u);
    demo_autores_decide(&a);
    TEST_ASSERT_EQUAL_UINT8(r4 > 0.6 + DEMO_AUTORES_INVERT_MARGIN ? 1u : 0u, a.inverted);
    // clearly above: inverted, at the inverted frames' best resolution (full)
    put(&a, 4u, 100u, 100u * 204u, 0u);   // 0.8
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTOR_CNN_RES_FULL, demo_autores_decide(&a));
    TEST_ASSERT_EQUAL_UINT8(1u, a.inverted);
    // below: as it is, half
    put(&a, 4u, 100u, 100u * 158u, 0u);   // 0.6196 < 0.6 + 0.025
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTOR_CNN_RES_HALF, demo_autores_decide(&a));
    TEST_ASSERT_EQUAL_UINT8(0u, a.inverted);
    // too few frames: never the other polarity
    put(&a, 4u, 100u, 100u * 255u, 50u);
    a.frames = DEMO_AUTORES_MIN_FRAMES - 1u;
    demo_autores_decide(&a);
    TEST_ASSERT_EQUAL_UINT8(0u, a.inverted);
}

static void test_fixed_resolution_stays(void)
{
    demo_autores_t a = fresh(20u);
    a.fixed_res = VD_DETECTOR_CNN_RES_QUARTER;   // --cnn-res quarter --cnn-polarity auto: all six measured
    for (unsigned k = 0u; k < DEMO_AUTORES_CONFIGS; k++) {
        put(&a, k, 1u, 51u, 0u);   // 0.2 each
    }
    put(&a, 4u, 1u, 255u, 0u);     // full inverted: 1.0
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTOR_CNN_RES_QUARTER, demo_autores_decide(&a));
    TEST_ASSERT_EQUAL_UINT8(1u, a.inverted);
}

static void test_nothing_measured_is_half_as_it_is(void)
{
    demo_autores_t a = fresh(64u);
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTOR_CNN_RES_HALF, demo_autores_decide(&a));
    TEST_ASSERT_EQUAL_UINT8(0u, a.inverted);
    a.measured = 0x3fu;   // measured, but no box anywhere: no evidence
    TEST_ASSERT_EQUAL_UINT8(VD_DETECTOR_CNN_RES_HALF, demo_autores_decide(&a));
    TEST_ASSERT_EQUAL_UINT8(0u, a.inverted);
}

static void test_configs_follow_the_options(void)
{
    demo_opts_t o;
    memset(&o, 0, sizeof o);
    TEST_ASSERT_EQUAL_UINT8(0u, demo_autores_configs(&o));   // neither auto: nothing measured
    o.cnn_res_auto = true;
    TEST_ASSERT_EQUAL_UINT8(0x07u, demo_autores_configs(&o));
    o.cnn_polarity_auto = true;
    TEST_ASSERT_EQUAL_UINT8(0x3fu, demo_autores_configs(&o));
    o.cnn_res_auto = false;   // a fixed resolution: the polarity still over all three
    o.cfg.cnn_res = VD_DETECTOR_CNN_RES_FULL;
    TEST_ASSERT_EQUAL_UINT8(0x3fu, demo_autores_configs(&o));
    o.cnn_polarity_auto = false;
    o.cnn_res_auto = true;
    TEST_ASSERT_EQUAL_UINT8(0x07u, demo_autores_configs(&o));
}

static void test_describe_names_and_bounds(void)
{
    demo_autores_t a = fresh(20u);
    put(&a, 0u, 4u, 4u * 102u, 1u);
    put(&a, 1u, 0u, 0u, 0u);
    put(&a, 2u, 0u, 0u, 0u);
    char buf[DEMO_AUTORES_DESCRIBE_MAX];
    demo_autores_describe(&a, false, buf, sizeof buf);
    TEST_ASSERT_EQUAL_STRING("rating half 0.525, full none (no box), quarter none (no box); mean box score half "
                             "0.400, full none (no box), quarter none (no box); flip agreement half 50.0 %, full "
                             "none (no box), quarter none (no box)", buf);
    put(&a, 3u, 0u, 0u, 0u);   // both polarities: each name carries its polarity
    demo_autores_describe(&a, false, buf, sizeof buf);
    TEST_ASSERT_NOT_NULL(strstr(buf, "rating half white-hot 0.525, full white-hot none (no box), quarter white-hot "
                                     "none (no box), half black-hot none (no box);"));
    demo_autores_describe(&a, true, buf, sizeof buf);   // the options black-hot: the other polarity is white-hot
    TEST_ASSERT_NOT_NULL(strstr(buf, "rating half black-hot 0.525"));
    // the longest text fits DEMO_AUTORES_DESCRIBE_MAX; short buffers are cut, NUL-terminated, never overrun
    a.measured = 0x3fu;
    memset(a.boxes, 0, sizeof a.boxes);
    demo_autores_describe(&a, false, buf, sizeof buf);
    TEST_ASSERT_TRUE(strlen(buf) < sizeof buf - 1u);
    for (size_t len = 1u; len < 64u; len++) {
        char small[80];
        memset(small, 'x', sizeof small);
        demo_autores_describe(&a, false, small, len);
        TEST_ASSERT_TRUE(strlen(small) < len);
        TEST_ASSERT_TRUE(small[len] == 'x');
    }
    demo_autores_describe(&a, false, buf, 0u);   // nothing written
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_rating_is_mean_score_plus_a_quarter_of_the_agreement);
    RUN_TEST(test_highest_resolution_ties_to_the_lower);
    RUN_TEST(test_inverted_only_above_the_margin);
    RUN_TEST(test_fixed_resolution_stays);
    RUN_TEST(test_nothing_measured_is_half_as_it_is);
    RUN_TEST(test_configs_follow_the_options);
    RUN_TEST(test_describe_names_and_bounds);
    return UNITY_END();
}
