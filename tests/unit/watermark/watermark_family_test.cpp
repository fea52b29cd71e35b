// SPDX-License-Identifier: MIT
// Families of recipients: tracing, joint readings, a code read only damped.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/watermark/detector.h"
#include "meshmark/watermark/watermark.h"
#include "watermark/nuisance.h"
#include "watermark_test_support.h"

namespace meshmark
{

using test::make_key;

namespace
{
// A family key of \p count recipients r0, r1, ... on \p mesh.
Key family_key(const TriangleMesh& mesh, std::uint64_t seed, std::uint32_t count)
{
    EmbedOptions options;
    options.repetitions = kFamilyRepetitions;
    Key key = meshmark::make_key(options, seed);
    key.original = fingerprint(mesh);
    key.recipients = RecipientCodes{};
    for (std::uint32_t i = 0; i < count; ++i)
    {
        key.recipients->recipients.push_back({"r" + std::to_string(i), i});
    }
    return key;
}

}  // namespace

TEST(SpectralWatermarkTest, tracing_a_large_family_gives_the_same_scores_on_any_thread_count)
{
    // 1,000 recipients: enough for the trace to spread them over threads, in groups of 8 with
    // a last partial group. The readings are synthetic; recipient 517's code is planted in
    // them (whole model and one region), so it alone must be accused.
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const Key key = family_key(mesh, 31, 1003);
    const SpectralWatermark one(mesh, key, 1);
    const SpectralWatermark two(mesh, key, 2);
    const auto n = static_cast<std::size_t>(3 * one.recipient_modes());
    const std::vector<std::uint8_t> planted = recipient_code(key.seed, 517, static_cast<int>(n));
    Rng rng(8);
    Extraction extraction;
    extraction.region_changes.assign(static_cast<std::size_t>(Detector::kRegionCount), {});
    for (std::size_t c = 0; c < n; ++c)
    {
        const double sign = planted[c] != 0 ? 1.0 : -1.0;
        extraction.recipient_change.push_back(sign + rng.normal());
        extraction.recipient_weights.push_back(1.0 + rng.uniform());
        for (std::size_t region = 0; region < extraction.region_changes.size(); ++region)
        {
            extraction.region_changes[region].push_back((region == 5 ? sign : 0.0) + rng.normal());
        }
    }
    const DetectOptions options;
    const std::vector<RecipientScore> a = one.trace(extraction, options);
    const std::vector<RecipientScore> b = two.trace(extraction, options);
    ASSERT_EQ(a.size(), key.recipients->recipients.size());
    ASSERT_EQ(b.size(), a.size());
    for (std::size_t i = 0; i < a.size(); ++i)
    {
        EXPECT_EQ(a[i].name, key.recipients->recipients[i].name);
        EXPECT_EQ(b[i].name, a[i].name);
        EXPECT_EQ(b[i].score, a[i].score);
        EXPECT_EQ(b[i].region_score, a[i].region_score);
        EXPECT_EQ(b[i].false_positive_probability, a[i].false_positive_probability);
        EXPECT_EQ(a[i].is_accused, i == 517) << i;
    }
    EXPECT_GT(a[517].region_score, 8.0);
}

TEST(SpectralWatermarkTest, joint_reading_shows_ownership_that_neither_part_shows_alone)
{
    // A weak owner's mark and a weak code of recipient 3 (each too weak for its own test) read
    // together give a joint score above the level; an unmarked reading gives nobody one.
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const Key key = family_key(mesh, 41, 100);
    const SpectralWatermark mark(mesh, key, 1);
    const Eigen::MatrixX3d& owner = mark.embedded_signs();
    const auto n = static_cast<std::size_t>(3 * mark.recipient_modes());
    const std::vector<std::uint8_t> code = recipient_code(key.seed, 3, static_cast<int>(n));
    const DetectOptions options;
    for (const double amplitude : {1.0, 0.0})
    {
        Rng rng(17);
        Extraction extraction;
        extraction.bits_found.assign(key.payload.size(), 2);  // the bits play no part here
        for (Eigen::Index c = 0; c < owner.size(); ++c)
        {
            extraction.normalized_change.push_back(0.5 * amplitude * owner(c / 3, c % 3) +
                                                   rng.normal());
            extraction.weights.push_back(1.0);
        }
        for (std::size_t c = 0; c < n; ++c)
        {
            extraction.recipient_change.push_back(0.5 * amplitude * (code[c] != 0 ? 1.0 : -1.0) +
                                                  rng.normal());
            extraction.recipient_weights.push_back(1.0);
        }
        const Decision decision = mark.decide(extraction, options);
        const std::vector<RecipientScore> scores = mark.trace(extraction, options);
        ASSERT_EQ(scores.size(), 100U);
        double best_other = 0.0;
        for (const RecipientScore& s : scores)
        {
            EXPECT_FALSE(s.is_accused) << s.name << " z " << s.score;
            if (s.index != 3)
            {
                best_other = std::max(best_other, s.joint_score);
                EXPECT_GT(s.joint_false_positive_probability, 1e-4) << s.name;
            }
        }
        EXPECT_FALSE(decision.is_present) << "owner's score " << decision.score;
        if (amplitude > 0.0)
        {
            EXPECT_GT(scores[3].joint_score, decision.score);
            EXPECT_GT(scores[3].joint_score, scores[3].score);
            EXPECT_LT(scores[3].joint_false_positive_probability, options.max_false_positive)
                << "joint z " << scores[3].joint_score << ", owner " << decision.score << ", code "
                << scores[3].score;
        }
        else
        {
            EXPECT_GT(scores[3].joint_false_positive_probability, 1e-4);
        }
        EXPECT_LT(best_other, 5.0);
    }
}

// A recipient's code read back only by a damped reading (the least squares' values are noise):
// the trace scores the damped reading as a further statistic, accuses that recipient and pays 5
// statistics per recipient in the bound; without the damped reading nobody is accused.
TEST(DampedReadingsTest, a_code_read_only_damped_accuses_its_recipient)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    EmbedOptions options;
    options.repetitions = kFamilyRepetitions;
    Key key = meshmark::make_key(options, 43);
    key.original = fingerprint(mesh);
    key.recipients = RecipientCodes{};
    for (std::uint32_t i = 0; i < 20; ++i)
    {
        key.recipients->recipients.push_back({"r" + std::to_string(i), i});
    }
    const SpectralWatermark mark(mesh, key);
    const auto n = static_cast<std::size_t>(3 * mark.recipient_modes());
    const std::vector<std::uint8_t> code = recipient_code(key.seed, 7, static_cast<int>(n));
    Rng rng(3);
    Extraction extraction;
    extraction.bits_found.assign(key.payload.size(), 2);
    for (std::size_t c = 0; c < n; ++c)
    {
        extraction.recipient_change.push_back(rng.normal());
        extraction.recipient_weights.push_back(1.0);
    }
    std::vector<double> damped;
    for (std::size_t c = 0; c < n; ++c)
    {
        damped.push_back(0.5 * (code[c] != 0 ? 1.0 : -1.0) + 0.3 * rng.normal());
    }
    const DetectOptions detect;
    for (const bool with_damped : {false, true})
    {
        extraction.further_recipient_changes.clear();
        if (with_damped)
        {
            extraction.further_recipient_changes = {damped, std::vector<double>(n, 0.0)};
        }
        const std::vector<RecipientScore> scores = mark.trace(extraction, detect);
        ASSERT_EQ(scores.size(), 20U);
        for (const RecipientScore& s : scores)
        {
            EXPECT_EQ(s.is_accused, with_damped && s.index == 7) << s.name << " z " << s.score;
        }
        if (with_damped)
        {
            EXPECT_GT(scores[7].score, 10.0);
            // 20 recipients times the 5 statistics' smallest tail, each statistic's weights
            // counted.
            const SoftCorrelation soft(extraction.recipient_change, extraction.recipient_weights,
                                       extraction.further_recipient_changes);
            const SoftScore own =
                soft.score([&](std::size_t c) { return code[c] != 0 ? 1.0 : -1.0; });
            EXPECT_EQ(own.z, scores[7].score);
            EXPECT_NEAR(scores[7].false_positive_probability / (20.0 * 5.0 * own.tail), 1.0, 1e-12);
            EXPECT_LT(own.tail, 1e-3 * rademacher_tail_bound(own.z));
        }
    }
}

}  // namespace meshmark
