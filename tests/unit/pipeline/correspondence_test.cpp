// SPDX-License-Identifier: MIT
// How detection put a suspect in correspondence (correspondence.h): the words `detect --json`
// prints for each value (registration.method), and what a report derives from the value.
#include "meshmark/pipeline/correspondence.h"

#include <gtest/gtest.h>

#include "meshmark/pipeline/detect_file.h"

namespace meshmark
{
namespace
{

TEST(Correspondence, MethodWordsAreThoseOfDetectJson)
{
    EXPECT_EQ(correspondence_method(Correspondence::None, ""), "none");
    EXPECT_EQ(correspondence_method(Correspondence::InOrder, ""), "same-connectivity");
    EXPECT_EQ(correspondence_method(Correspondence::VerticesMatched, ""),
              "registration (vertices matched)");
    EXPECT_EQ(correspondence_method(Correspondence::Registered, ""), "registration");
    EXPECT_EQ(correspondence_method(Correspondence::RegisteredNotConverged, ""),
              "registration (not converged)");
    EXPECT_EQ(correspondence_method(Correspondence::AnimationFrame, "animation 'Run' at 10/24 s"),
              "registration (animation 'Run' at 10/24 s)");
    // The pose names only an animation frame.
    EXPECT_EQ(correspondence_method(Correspondence::Registered, "animation 'Run' at 10/24 s"),
              "registration");
}

TEST(Correspondence, RegisteredIsEverythingButNoneAndInOrder)
{
    EXPECT_FALSE(is_registered(Correspondence::None));
    EXPECT_FALSE(is_registered(Correspondence::InOrder));
    EXPECT_TRUE(is_registered(Correspondence::VerticesMatched));
    EXPECT_TRUE(is_registered(Correspondence::Registered));
    EXPECT_TRUE(is_registered(Correspondence::RegisteredNotConverged));
    EXPECT_TRUE(is_registered(Correspondence::AnimationFrame));
}

TEST(Correspondence, ReportReadsItsTypedValue)
{
    DetectReport report;
    EXPECT_EQ(report.registration_method(), "none");
    EXPECT_FALSE(report.registered());
    report.mark_strength = 0.001;
    report.registration_rms = DetectReport::kFarCopyStrengths * report.mark_strength;
    EXPECT_FALSE(report.is_far_copy());  // (not registered)
    report.correspondence = Correspondence::InOrder;
    EXPECT_FALSE(report.is_far_copy());
    report.correspondence = Correspondence::Registered;
    EXPECT_TRUE(report.registered());
    EXPECT_TRUE(report.is_far_copy());
    report.correspondence = Correspondence::AnimationFrame;
    report.pose = "animation 'bend' at 0.1 s";
    EXPECT_EQ(report.registration_method(), "registration (animation 'bend' at 0.1 s)");
    EXPECT_TRUE(report.is_far_copy());
}

}  // namespace
}  // namespace meshmark
