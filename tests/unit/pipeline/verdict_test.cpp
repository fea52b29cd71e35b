// SPDX-License-Identifier: MIT
// The one verdict of a detection (verdict.h): claimed or not, whose copy, its probability, and
// the sentence that says it.
#include "meshmark/pipeline/verdict.h"

#include <string>

#include <gtest/gtest.h>

namespace meshmark
{
namespace
{

constexpr double kMax = 1e-6;

DetectReport single_owner(bool present, double p)
{
    DetectReport report;
    report.decision.is_present = present;
    report.decision.false_positive_probability = p;
    report.owner_detected = present;
    report.owner_false_positive_probability = p;
    return report;
}

// A family key's report traced over five recipients: the owner's mark alone at \p alone,
// ownership (alone or joint) at \p ownership, and \p accused with their bounds.
DetectReport family(double alone, double ownership,
                    std::vector<std::pair<std::string, double>> accused)
{
    DetectReport report;
    report.recipients_traced = 5;
    report.decision.is_present = alone <= kMax;
    report.decision.false_positive_probability = alone;
    report.owner_false_positive_probability = ownership;
    report.owner_detected = ownership <= kMax;
    for (const auto& [name, p] : accused)
    {
        RecipientScore r;
        r.name = name;
        r.false_positive_probability = p;
        r.is_accused = true;
        report.accused.push_back(r);
    }
    return report;
}

TEST(VerdictTest, a_single_owner_key_claims_what_its_mark_shows_at_the_marks_probability)
{
    const Verdict found = verdict_of(single_owner(true, 3e-12), kMax);
    EXPECT_TRUE(found.claimed);
    EXPECT_EQ(found.false_positive_probability, 3e-12);
    EXPECT_TRUE(found.accused.empty());
    EXPECT_EQ(headline(found).rfind("Claimed: a copy of the original. ", 0), 0U) << headline(found);

    const Verdict missed = verdict_of(single_owner(false, 0.02), kMax);
    EXPECT_FALSE(missed.claimed);
    EXPECT_EQ(headline(missed).rfind("Not shown: ", 0), 0U) << headline(missed);
    EXPECT_NE(headline(missed).find("1 in 50 times (0.02)"), std::string::npos) << headline(missed);
}

// The contradiction the verdict removes: the owner's mark alone not found, yet a recipient is
// accused. The copy is claimed, named, at the accusation's probability, not the mark alone's.
TEST(VerdictTest,
     an_accusation_claims_the_copy_at_the_accusations_probability_whatever_the_mark_alone_reads)
{
    const DetectReport report = family(0.0111, 4e-9, {{"bob", 2e-9}});
    ASSERT_TRUE(report.detected());
    const Verdict verdict = verdict_of(report, kMax);
    EXPECT_TRUE(verdict.claimed);
    ASSERT_EQ(verdict.accused.size(), 1U);
    EXPECT_EQ(verdict.accused[0], "bob");
    EXPECT_EQ(verdict.false_positive_probability, 2e-9);
    EXPECT_EQ(headline(verdict),
              "Claimed: a copy of the original, made from the copy issued to bob. The chance that "
              "a mesh without "
              "this mark gives this result is at most 1 in 500 million (2e-09).");

    // Two accused: both named, the strongest's probability.
    const Verdict two = verdict_of(family(0.5, 1e-30, {{"ann", 1e-20}, {"cat", 1e-8}}), kMax);
    EXPECT_EQ(two.false_positive_probability, 1e-20);
    EXPECT_NE(headline(two).find("the copies issued to ann and cat."), std::string::npos)
        << headline(two);
}

TEST(VerdictTest, ownership_shown_without_an_accusation_is_a_claim_that_names_nobody)
{
    const DetectReport report = family(0.3, 2e-7, {});
    EXPECT_TRUE(report.detected());
    const Verdict verdict = verdict_of(report, kMax);
    EXPECT_TRUE(verdict.claimed);
    EXPECT_EQ(verdict.false_positive_probability, 2e-7);
    EXPECT_NE(headline(verdict).find("no recipient's copy named"), std::string::npos)
        << headline(verdict);

    const DetectReport nothing = family(0.3, 0.04, {});
    EXPECT_FALSE(nothing.detected());
    EXPECT_FALSE(verdict_of(nothing, kMax).claimed);
    EXPECT_EQ(verdict_of(nothing, kMax).false_positive_probability, 0.04);
}

}  // namespace
}  // namespace meshmark
