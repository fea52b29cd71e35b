// SPDX-License-Identifier: MIT
// The readings of a suspect: damped readings, further readings, row weights.
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/QR>
#include <gtest/gtest.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/normals.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/watermark/detector.h"
#include "meshmark/watermark/watermark.h"
#include "support/test_shapes.h"
#include "watermark/nuisance.h"
#include "watermark_test_support.h"

namespace meshmark
{

using test::make_key;
using test::with_noise;

// Damped least squares: with orthonormal modulated columns it shrinks the plain solution by
// 1 / (1 + level); whatever the nuisance fields add to the target is projected out.
TEST(DampedReadingsTest, shrink_the_least_squares_and_ignore_the_nuisance)
{
    Rng rng(5);
    const Eigen::Index rows = 40;
    const Eigen::Index modulated = 6;
    const Eigen::Index fields = 3;
    // Orthonormal columns: the first `modulated` span the mark, the next `fields` the nuisance.
    Eigen::MatrixXd random(rows, modulated + fields);
    for (Eigen::Index i = 0; i < random.size(); ++i)
    {
        random.data()[i] = rng.normal();
    }
    const Eigen::MatrixXd q = Eigen::HouseholderQR<Eigen::MatrixXd>(random).householderQ() *
                              Eigen::MatrixXd::Identity(rows, modulated + fields);
    const Eigen::VectorXd x = (Eigen::VectorXd(modulated) << 1, -1, 1, 1, -1, 0.5).finished();
    const Eigen::VectorXd g = (Eigen::VectorXd(fields) << 3, -7, 11).finished();
    const Eigen::VectorXd target = q.leftCols(modulated) * x + q.rightCols(fields) * g;
    const std::vector<Eigen::VectorXd> readings = detail::damped_readings(q, modulated, target);
    ASSERT_EQ(readings.size(), detail::kDampingLevels.size());
    for (std::size_t l = 0; l < readings.size(); ++l)
    {
        EXPECT_LT((readings[l] - x / (1.0 + detail::kDampingLevels[l])).norm(), 1e-12) << l;
    }
    EXPECT_TRUE(
        detail::damped_readings(Eigen::MatrixXd::Zero(rows, modulated + fields), modulated, target)
            .empty());
}

// Half the model cropped away (the registration marks those rows; 96 coefficients): the
// modulated modes are nearly dependent on what is left, and the damped readings score far
// higher than the least squares' weightings; the decision counts them as two more statistics
// in its bound.
TEST(DampedReadingsTest, a_half_model_scores_higher_damped)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    EmbedOptions embed;
    embed.repetitions = 4;
    Key key = meshmark::make_key(embed, 23);
    key.original = fingerprint(mesh);
    const SpectralWatermark mark(mesh, key);
    const Positions marked = mesh.V + mark.displacement();
    std::vector<std::uint8_t> is_kept(static_cast<std::size_t>(mesh.V.rows()), 0);
    Positions resampled = mesh.V;
    const double middle = mesh.V.col(0).mean();
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        if (mesh.V(i, 0) < middle)
        {
            is_kept[static_cast<std::size_t>(i)] = 1;
            resampled.row(i) = marked.row(i);
        }
    }
    const DetectOptions options;
    Extraction extraction = Detector(mark, mesh).extract_resampled(resampled, options, &is_kept);
    ASSERT_EQ(extraction.further_changes.size(), detail::kDampingLevels.size());
    // A resampled suspect scores its damped readings alone (Extraction::damped_only).
    ASSERT_TRUE(extraction.damped_only);
    const Decision damped = mark.decide(extraction, options);
    EXPECT_EQ(damped.statistic_count, 2);
    EXPECT_DOUBLE_EQ(damped.score_false_positive_probability, 2.0 * damped.score_tail);
    EXPECT_LE(damped.score_tail, rademacher_tail_bound(damped.score));
    // Read twice (detection's two readings of a resampled suspect): both readings' damped
    // readings and the three joining them, 7 statistics, not the 13 of every weighting.
    Extraction twice = extraction;
    add_further_reading(twice, extraction);
    EXPECT_EQ(mark.decide(twice, options).statistic_count, 2 + 2 + joined_reading_count(2));
    twice.damped_only = false;
    EXPECT_EQ(mark.decide(twice, options).statistic_count, 13);
    extraction.damped_only = false;
    const Decision every = mark.decide(extraction, options);
    EXPECT_EQ(every.statistic_count, 5);
    EXPECT_EQ(every.score, damped.score) << "the best statistic is a damped one here";
    EXPECT_DOUBLE_EQ(every.score_false_positive_probability, 5.0 * every.score_tail);
    extraction.further_changes.clear();
    const Decision plain = mark.decide(extraction, options);
    EXPECT_EQ(plain.statistic_count, 3);
    // (Measured: 5.15 against 1.45. The marked positions are kept whole, not projected on the
    // normals as a resampling would, so the tangential part of the mark is noise here.)
    EXPECT_GT(damped.score, plain.score + 2.5)
        << "damped " << damped.score << ", plain " << plain.score;
    // Without a damped reading the flag cannot leave the verdict without statistics.
    extraction.damped_only = true;
    const Decision fallback = mark.decide(extraction, options);
    EXPECT_EQ(fallback.statistic_count, 3);
    EXPECT_EQ(fallback.score, plain.score);
}

// A second reading of the same coefficients (detection's reading of a resampled suspect
// against the original's vertices) joins the first with all its statistics: its changes
// under the three weightings and its own further readings, each paid for in the union bound.
TEST(FurtherReadingTest, another_reading_adds_its_statistics)
{
    Extraction primary;
    primary.normalized_change = {1.0, -1.0, 0.5};
    primary.weights = {1.0, 1.0, 1.0};
    Extraction other;
    other.normalized_change = {2.0, 0.0, -1.0};
    other.weights = {4.0, 1.0, 0.25};
    other.further_changes = {{0.5, 0.5, 0.5}};
    add_further_reading(primary, other);
    ASSERT_EQ(primary.further_changes.size(), 4U);
    EXPECT_EQ(primary.further_changes[0], (std::vector<double>{2.0, 0.0, -1.0}));
    EXPECT_EQ(primary.further_changes[1], (std::vector<double>{4.0, 0.0, -0.5}));
    EXPECT_EQ(primary.further_changes[2], (std::vector<double>{8.0, 0.0, -0.25}));
    EXPECT_EQ(primary.further_changes[3], (std::vector<double>{0.5, 0.5, 0.5}));
    EXPECT_TRUE(primary.further_recipient_changes.empty()) << "no code read, nothing to pair";
    // The verdict counts them: 3 weightings + 4 further readings.
    EXPECT_EQ(SoftCorrelation(primary.normalized_change, primary.weights, primary.further_changes)
                  .statistic_count(),
              7);
    // The other reading's weightings are recorded, so a verdict on damped readings alone can
    // leave them out; without the weightings only the further readings count.
    EXPECT_EQ(primary.further_weightings, (std::vector<std::size_t>{0, 1, 2}));
    EXPECT_EQ(
        SoftCorrelation(primary.normalized_change, primary.weights, primary.further_changes, false)
            .statistic_count(),
        4);

    // With a family code read: the code's part is paired, zeros where the other reading has none.
    Extraction family;
    family.normalized_change = {1.0, -1.0, 0.5};
    family.weights = {1.0, 1.0, 1.0};
    family.recipient_change = {1.0, 1.0};
    family.recipient_weights = {1.0, 1.0};
    family.further_changes = {{0.0, 0.0, 0.0}};
    family.further_recipient_changes = {{0.0, 0.0}};
    Extraction no_code = other;
    no_code.further_changes.clear();
    add_further_reading(family, no_code);
    ASSERT_EQ(family.further_recipient_changes.size(), 4U);
    EXPECT_EQ(family.further_recipient_changes[3], (std::vector<double>{0.0, 0.0}));
    Extraction with_code = no_code;
    with_code.recipient_change = {-1.0, 3.0};
    with_code.recipient_weights = {9.0, 0.0};
    add_further_reading(family, with_code);
    ASSERT_EQ(family.further_recipient_changes.size(), family.further_changes.size());
    EXPECT_EQ(family.further_recipient_changes[5], (std::vector<double>{-3.0, 0.0}));

    other.normalized_change.pop_back();
    EXPECT_THROW(add_further_reading(primary, other), InvalidOption);
}

// Two readings with the same number of damped readings are joined: per damping level the sum
// of the two scaled to unit norm, then all of them; the code's parts alike (zeros add
// nothing). Two readings of the same signs with different errors score higher joined.
TEST(FurtherReadingTest, joins_two_readings_damping_level_by_level_and_all_together)
{
    Extraction second;
    second.normalized_change = {1.0, 1.0, 1.0, 1.0};
    second.weights = {1.0, 1.0, 1.0, 1.0};
    second.further_changes = {{3.0, 0.0, 0.0, 4.0}, {0.0, 2.0, 0.0, 0.0}};
    second.damped_only = true;
    second.recipient_change = {1.0, 0.0};
    second.recipient_weights = {1.0, 1.0};
    second.further_recipient_changes = {{0.0, 2.0}, {0.0, 0.0}};
    Extraction first = second;
    first.further_changes = {{0.0, 0.0, 5.0, 0.0}, {1.0, 1.0, 1.0, 1.0}};
    first.further_recipient_changes = {{4.0, 0.0}, {0.0, 0.0}};
    add_further_reading(second, first);
    // Own 2, the first reading's 3 weightings and 2 damped readings, 2 + 1 joined.
    ASSERT_EQ(second.further_changes.size(), 2U + 3U + 2U + 3U);
    EXPECT_EQ(joined_reading_count(2), 3);
    EXPECT_EQ(joined_reading_count(1), 1);
    EXPECT_EQ(joined_reading_count(0), 0);
    const auto near = [](const std::vector<double>& a, const std::vector<double>& b)
    {
        ASSERT_EQ(a.size(), b.size());
        for (std::size_t c = 0; c < a.size(); ++c)
        {
            EXPECT_NEAR(a[c], b[c], 1e-15) << c;
        }
    };
    near(second.further_changes[7], {0.6, 0.0, 1.0, 0.8});
    near(second.further_changes[8], {0.5, 1.5, 0.5, 0.5});
    near(second.further_changes[9], {1.1, 1.5, 1.5, 1.3});
    near(second.further_recipient_changes[7], {1.0, 1.0});
    near(second.further_recipient_changes[8], {0.0, 0.0});
    near(second.further_recipient_changes[9], {1.0, 1.0});
    EXPECT_EQ(second.further_weightings, (std::vector<std::size_t>{2, 3, 4}));

    // A reading with weightings already joined, or with another count, is not joined again.
    Extraction again = second;
    add_further_reading(again, first);
    EXPECT_EQ(again.further_changes.size(), second.further_changes.size() + 3U + 2U);
    Extraction single = first;
    single.further_changes.pop_back();
    Extraction uneven = first;
    add_further_reading(uneven, single);
    EXPECT_EQ(uneven.further_changes.size(), 2U + 3U + 1U);

    // 120 signs read twice with independent errors of the same size: each reading alone
    // scores about 4.4, joined about 6.2, and the verdict takes the joined statistic.
    Rng rng(0x10AD);
    const std::size_t n = 120;
    const auto signs_of = [](std::size_t c) { return c % 3 == 1 ? -1.0 : 1.0; };
    Extraction a;
    a.normalized_change.assign(n, 0.0);
    a.weights.assign(n, 1.0);
    a.damped_only = true;
    Extraction b = a;
    a.further_changes.assign(1, std::vector<double>(n));
    b.further_changes.assign(1, std::vector<double>(n));
    for (std::size_t c = 0; c < n; ++c)
    {
        a.further_changes[0][c] = 0.4 * signs_of(c) + rng.normal();
        b.further_changes[0][c] = 0.4 * signs_of(c) + rng.normal();
    }
    const std::vector<double> zeros(n, 0.0);
    const SoftScore alone =
        SoftCorrelation(zeros, a.weights, {a.further_changes[0], b.further_changes[0]}, false)
            .score(signs_of);
    add_further_reading(a, b);
    std::vector<std::vector<double>> damped = {a.further_changes[0], a.further_changes[4],
                                               a.further_changes[5]};
    const SoftScore joined = SoftCorrelation(zeros, a.weights, damped, false).score(signs_of);
    EXPECT_GT(joined.z, alone.z + 1.0);
    EXPECT_LT(joined.probability, 1e-3 * alone.probability);
}

// Statistics a detection paid for without computing them (it stopped before a further
// reading) raise the bound as if computed; the score is unchanged.
TEST(FurtherReadingTest, unread_statistics_are_paid_for)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, make_key(mesh, 5), 1);
    Extraction extraction =
        Detector(mark, mesh)
            .extract(with_noise(mesh, mesh.V + mark.displacement(), 3), DetectOptions{});
    const DetectOptions decide_options;
    const Decision read = mark.decide(extraction, decide_options);
    extraction.unread_statistics = 5;
    const Decision paid = mark.decide(extraction, decide_options);
    EXPECT_EQ(paid.score, read.score);
    EXPECT_EQ(paid.statistic_count, read.statistic_count + 5);
    EXPECT_EQ(paid.score_tail, read.score_tail);
    EXPECT_DOUBLE_EQ(paid.score_false_positive_probability,
                     std::min(1.0, paid.statistic_count * paid.score_tail));
    EXPECT_GT(paid.score_false_positive_probability, read.score_false_positive_probability);
    EXPECT_DOUBLE_EQ(score_level_factor(VerdictRule::Combined), 16.0 / 15.0);
    EXPECT_EQ(score_level_factor(VerdictRule::Correlation), 1.0);
    EXPECT_EQ(score_level_factor(VerdictRule::Bits), 0.0);
}

// A resampled copy where a quarter of the rows were moved far off by the attack (as a coarse
// remesh cuts corners): each row's distance to the original gives it the weight detection
// uses (1 / (1 + (d / 3 a)^2) for a mark of RMS amplitude a), and the weighted reading claims
// the copy that the plain one misses. The weights see distances only, so the unmarked copy
// moved the same way stays unclaimed.
TEST(RowWeightsTest, rows_moved_far_by_an_attack_count_less)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, make_key(mesh, 31));
    const Positions displacement = mark.displacement();
    const double amplitude = std::sqrt(displacement.rowwise().squaredNorm().mean());
    const Positions normals = vertex_normals(mesh);
    const DetectOptions options;
    const Detector detector(mark, mesh);
    auto attacked = [&](const Positions& field)
    {
        // What a resampling keeps (the normal component), then 16 amplitudes off on every 4th row.
        Positions resampled = mesh.V;
        Rng rng(5);
        for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
        {
            const Eigen::RowVector3d n = normals.row(i);
            const double offset = i % 4 == 0 ? rng.uniform(-16.0, 16.0) * amplitude : 0.0;
            resampled.row(i) += (field.row(i).dot(n) + offset) * n;
        }
        return resampled;
    };
    const Positions marked = attacked(displacement);
    const double scale = 3.0 * amplitude;
    const Decision plain = mark.decide(detector.extract_resampled(marked, options), options);
    const Decision weighted =
        mark.decide(detector.extract_resampled(marked, options, nullptr, scale), options);
    EXPECT_FALSE(plain.is_present) << plain.score;
    EXPECT_TRUE(weighted.is_present) << weighted.score;
    // (Measured: 7.54 against 4.21.)
    EXPECT_GT(weighted.score, plain.score + 2.0)
        << "weighted " << weighted.score << ", plain " << plain.score;
    EXPECT_EQ(mark.decide(detector.extract_resampled(marked, options, nullptr, 0.0), options).score,
              plain.score);
    EXPECT_DOUBLE_EQ(row_weight(scale, scale), 0.5);

    const Positions unmarked = attacked(Positions::Zero(mesh.V.rows(), 3));
    EXPECT_FALSE(mark.decide(detector.extract_resampled(unmarked, options, nullptr, scale), options)
                     .is_present);
    EXPECT_THROW((void)detector.extract_resampled(marked, options, nullptr, -1.0), InvalidOption);
}

}  // namespace meshmark
