// SPDX-License-Identifier: MIT
#include "meshmark/watermark/watermark.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <span>
#include <thread>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <gtest/gtest.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/normals.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/watermark/detector.h"
#include "support/test_shapes.h"
#include "watermark/nuisance.h"

namespace meshmark
{
namespace
{

Key make_key(const TriangleMesh& mesh, std::uint64_t seed,
             EmbeddingRule rule = EmbeddingRule::Additive, double strength = -1.0)
{
    EmbedOptions options;
    options.rule = rule;
    options.strength = strength;
    Key key = meshmark::make_key(options, seed);
    key.original = fingerprint(mesh);
    return key;
}

Decision detect_positions(const SpectralWatermark& mark, const TriangleMesh& original,
                          const Positions& suspect)
{
    const DetectOptions options;
    return mark.decide(Detector(mark, original).extract(suspect, options), options);
}

// \p P with uniform noise of at most 1e-3 of \p mesh's bounding box diagonal on every coordinate.
Positions with_noise(const TriangleMesh& mesh, Positions P, std::uint64_t seed)
{
    const double D = bounding_box(mesh.V).diagonal();
    Rng rng(seed);
    for (Eigen::Index i = 0; i < P.size(); ++i)
    {
        P.data()[i] += rng.uniform(-1e-3, 1e-3) * D;
    }
    return P;
}

bool same_extraction(const Extraction& a, const Extraction& b)
{
    return a.normalized_change == b.normalized_change && a.weights == b.weights &&
           a.bit_values == b.bit_values && a.bits_found == b.bits_found;
}

}  // namespace

// A watermark given the rows and frame (as the out-of-core embedding builds it) is the one
// built from the mesh, and complete: it embeds and is read back like it.
TEST(SpectralWatermarkTest, built_from_rows_and_frame_it_is_the_watermark_built_from_the_mesh)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const Key key = make_key(mesh, 12);
    const SpectralWatermark from_mesh(mesh, key, 2);
    const std::vector<std::int32_t> active = referenced_vertices(mesh);
    const SpectralWatermark from_rows(key, position_rows(mesh.V, active),
                                      canonical_frame(mesh.V, active), 2);
    EXPECT_EQ(from_rows.centers(), from_mesh.centers());
    EXPECT_TRUE(from_rows.coefficient_change() == from_mesh.coefficient_change());
    const Positions marked = mesh.V + from_rows.displacement();
    EXPECT_TRUE(marked == mesh.V + from_mesh.displacement());
    EXPECT_TRUE(detect_positions(from_rows, mesh, marked).is_present);

    // Without the mesh there is no Laplacian basis and no decimation: refused, not half built.
    Key laplacian = key;
    laplacian.options.basis = BasisType::Laplacian;
    EXPECT_THROW(SpectralWatermark(laplacian, position_rows(mesh.V, active),
                                   canonical_frame(mesh.V, active)),
                 InvalidOption);
    // A detector refuses an original that is not the watermark's.
    const TriangleMesh other = lumpy_ellipsoid(3);
    EXPECT_THROW(Detector(from_rows, other), InvalidOption);
}

// Extraction keeps no state: several threads reading suspects through one Detector at once get
// what one thread gets.
TEST(SpectralWatermarkTest, extraction_is_safe_from_several_threads_at_once)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, make_key(mesh, 21), 1);
    const Detector detector(mark, mesh);
    const Positions noisy = with_noise(mesh, mesh.V + mark.displacement(), 9);
    const DetectOptions options;
    const Extraction expected = detector.extract(noisy, options);
    const Extraction expected_resampled = detector.extract_resampled(noisy, options);
    constexpr int kThreads = 4;
    std::array<Extraction, kThreads> found;
    std::array<Extraction, kThreads> found_resampled;
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t)
    {
        threads.emplace_back(
            [&, t]()
            {
                const auto slot = static_cast<std::size_t>(t);
                found[slot] = detector.extract(noisy, options);
                found_resampled[slot] = detector.extract_resampled(noisy, options);
            });
    }
    for (auto& thread : threads)
    {
        thread.join();
    }
    for (std::size_t t = 0; t < kThreads; ++t)
    {
        EXPECT_TRUE(same_extraction(found[t], expected)) << t;
        EXPECT_TRUE(same_extraction(found_resampled[t], expected_resampled)) << t;
    }
    EXPECT_TRUE(mark.decide(expected, options).is_present);
}

// add_rows is add() with the pass chosen once: the same frame to the bit.
TEST(CanonicalFrameTest, add_rows_gives_the_frame_of_add_row_by_row)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    std::vector<std::int32_t> rows = referenced_vertices(mesh);
    rows.erase(rows.begin() + 5, rows.begin() + 40);  // not every row, and not from 0 only
    CanonicalFrameBuilder one_by_one;
    CanonicalFrameBuilder batched;
    while (one_by_one.pass() != CanonicalFrameBuilder::Pass::Done)
    {
        for (const std::int32_t i : rows)
        {
            one_by_one.add(mesh.V.row(i).transpose());
        }
        one_by_one.next_pass();
        // Two batches per pass: the running sums carry over between calls.
        batched.add_rows(mesh.V, std::span(rows).first(rows.size() / 3));
        batched.add_rows(mesh.V, std::span(rows).subspan(rows.size() / 3));
        batched.next_pass();
    }
    ASSERT_EQ(batched.pass(), CanonicalFrameBuilder::Pass::Done);
    EXPECT_EQ(batched.frame().origin, one_by_one.frame().origin);
    EXPECT_EQ(batched.frame().axes, one_by_one.frame().axes);
    EXPECT_EQ(batched.frame().diagonal, one_by_one.frame().diagonal);
    EXPECT_GT(batched.frame().diagonal, 0.0);
}

TEST(SpectralWatermarkTest, marked_copy_reads_back_all_bits_with_both_rules)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    for (const auto rule : {EmbeddingRule::Additive, EmbeddingRule::Paper})
    {
        const SpectralWatermark mark(mesh, make_key(mesh, 42, rule));
        EmbedStats stats;
        const Positions marked = mesh.V + mark.displacement(&stats);
        const Decision decision = detect_positions(mark, mesh, marked);
        EXPECT_DOUBLE_EQ(decision.correlation, 1.0) << to_string(rule);
        EXPECT_TRUE(decision.is_present);
        EXPECT_EQ(decision.bits_found, decision.bits_expected);
        EXPECT_NEAR(decision.bits_false_positive_probability, std::pow(0.5, 24), 1e-20);
        // 3 m r coefficients read back as +-1: the uniform weighting scores sqrt(3 m r), and
        // the combined verdict's probability is the smaller of the score's bound (times 16/15)
        // and the bit count's tail (times 16), far below 1e-6. The score is the best of 5
        // statistics: 3 weightings of the least squares and 2 damped readings.
        const int coefficients = 3 * modulated_modes(mark.key().options);
        EXPECT_EQ(decision.coefficient_count, coefficients);
        EXPECT_NEAR(decision.score, std::sqrt(static_cast<double>(coefficients)), 1e-6)
            << to_string(rule);
        EXPECT_EQ(decision.verdict, VerdictRule::Combined);
        EXPECT_NEAR(decision.false_positive_probability /
                        std::min(5.0 * decision.score_tail * 16.0 / 15.0, 16.0 * std::pow(0.5, 24)),
                    1.0, 1e-12);
        EXPECT_EQ(decision.statistic_count, 5);
        EXPECT_DOUBLE_EQ(decision.score_false_positive_probability, 5.0 * decision.score_tail);
        // The tail counted for these weights: far below the formula's (1.3e-21 / 5 here), which
        // must hold for every weight vector (RademacherTail).
        EXPECT_LT(decision.score_tail, 1e-6 * rademacher_tail_bound(decision.score));
        EXPECT_LT(decision.false_positive_probability, 1e-9);
        EXPECT_LT(stats.orthogonality_error, 1e-9);
    }
}

TEST(SpectralWatermarkTest, additive_strength_is_the_rms_displacement_in_diagonals)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    Key key = make_key(mesh, 7, EmbeddingRule::Additive, 2e-3);
    key.options.measure = StrengthMeasure::Vertex;
    const SpectralWatermark mark(mesh, key);
    const Positions d = mark.displacement();
    const double rms = std::sqrt(d.rowwise().squaredNorm().mean());
    EXPECT_NEAR(rms / mark.frame().diagonal, 2e-3, 1e-9);
    // The surface measure: the calibrated vertex strength, or sqrt(3) times the strength
    // before the embedding calibrates it (the pipeline's job: FacadeTest).
    key.options.measure = StrengthMeasure::Surface;
    key.options.vertex_strength = 1.5e-3;
    const Positions calibrated = SpectralWatermark(mesh, key).displacement();
    EXPECT_NEAR(std::sqrt(calibrated.rowwise().squaredNorm().mean()) / mark.frame().diagonal,
                1.5e-3, 1e-9);
    key.options.vertex_strength = -1.0;
    const Positions nominal = SpectralWatermark(mesh, key).displacement();
    EXPECT_NEAR(std::sqrt(nominal.rowwise().squaredNorm().mean()) / mark.frame().diagonal,
                std::sqrt(3.0) * 2e-3, 1e-9);
}

TEST(SpectralWatermarkTest, zero_strength_reproduces_the_input)
{
    const TriangleMesh mesh = lumpy_ellipsoid(3);
    for (const auto rule : {EmbeddingRule::Additive, EmbeddingRule::Paper})
    {
        const SpectralWatermark mark(mesh, make_key(mesh, 3, rule, 0.0));
        const Positions marked = mesh.V + mark.displacement();
        const double diagonal = bounding_box(mesh.V).diagonal();
        EXPECT_LE((marked - mesh.V).cwiseAbs().maxCoeff(), 1e-12 * diagonal);
    }
}

TEST(SpectralWatermarkTest, unmarked_and_wrong_key_copies_are_not_claimed)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, make_key(mesh, 100));
    const Decision unmarked = detect_positions(mark, mesh, mesh.V);
    EXPECT_FALSE(unmarked.is_present);
    EXPECT_EQ(unmarked.correlation, 0.0);  // nothing moved: every bit undecided
    double sum = 0.0;
    double largest = 0.0;
    const int trials = 25;
    for (int t = 0; t < trials; ++t)
    {
        const SpectralWatermark other(mesh, make_key(mesh, 1000 + static_cast<std::uint64_t>(t)));
        const Positions marked_other = mesh.V + other.displacement();
        const Decision d = detect_positions(mark, mesh, marked_other);
        sum += d.correlation;
        largest = std::max(largest, d.correlation);
    }
    EXPECT_LT(sum / trials, 0.6);
    EXPECT_LT(largest, 0.9);
}

TEST(SpectralWatermarkTest, each_bit_is_spread_over_r_coefficients_with_independent_signs)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    Key key = make_key(mesh, 31);
    key.options.repetitions = 3;
    key.payload = random_payload(31, payload_bit_count(key.options));
    const SpectralWatermark mark(mesh, key);
    ASSERT_EQ(mark.embedded_signs().rows(), 24);  // m r modes
    const auto mask = payload_mask(31, 72);
    int differing_copies = 0;
    for (int c = 0; c < 72; ++c)
    {
        const int bit = key.payload[static_cast<std::size_t>(c % 24)];
        const double expected = (bit ^ mask[static_cast<std::size_t>(c)]) != 0 ? 1.0 : -1.0;
        EXPECT_EQ(mark.embedded_signs()(c / 3, c % 3), expected) << c;
        differing_copies +=
            mark.embedded_signs()(c / 3, c % 3) != mark.embedded_signs()((c % 24) / 3, c % 3);
    }
    EXPECT_GT(differing_copies, 10);  // copies of one bit do not share a sign pattern
    const DetectOptions options;
    const Extraction e = Detector(mark, mesh).extract(mesh.V + mark.displacement(), options);
    ASSERT_EQ(e.normalized_change.size(), 72u);
    ASSERT_EQ(e.bit_values.size(), 24u);
    for (std::size_t t = 0; t < 24; ++t)
    {
        EXPECT_NEAR(e.bit_values[t], key.payload[t] != 0 ? 1.0 : -1.0, 1e-6) << t;
    }
}

// The default repetitions are chosen on the original (docs/statistics.md, "How long a mark"):
// 5 from 5,000 analysed vertices on, else 4, or what the basis fits; a family key's owner mark
// 2. The watermark records the choice in its key and reads an intact copy at sqrt(3 m r).
TEST(SpectralWatermarkTest, automatic_repetitions_lengthen_the_mark_on_large_meshes)
{
    EmbedOptions options;  // k = 100, m = 8, first mode 12
    ASSERT_EQ(options.repetitions, EmbedOptions::kAutoRepetitions);
    EXPECT_EQ(automatic_repetitions(options, 4'999), 4);
    EXPECT_EQ(automatic_repetitions(options, 5'000), 5);
    options.basis_size = 50;  // 12 + 5 * 8 > 50: the longer mark does not fit
    EXPECT_EQ(automatic_repetitions(options, 1'000'000), 4);
    options.basis_size = 40;  // 12 + 4 * 8 > 40
    EXPECT_EQ(automatic_repetitions(options, 1'000'000), 3);
    options.basis_size = 20;
    EXPECT_EQ(automatic_repetitions(options, 1'000'000), 1);

    for (const int subdivisions : {4, 5})  // 2,562 and 10,242 vertices
    {
        const TriangleMesh mesh = lumpy_ellipsoid(subdivisions);
        const int expected = mesh.V.rows() >= 5'000 ? 5 : 4;
        const SpectralWatermark mark(mesh, make_key(mesh, 7));
        EXPECT_EQ(mark.key().options.repetitions, expected) << mesh.V.rows();
        EXPECT_EQ(mark.embedded_signs().rows(), 8 * expected);
        const Decision d = detect_positions(mark, mesh, mesh.V + mark.displacement());
        EXPECT_TRUE(d.is_present);
        EXPECT_NEAR(d.score, std::sqrt(24.0 * expected), 1e-6) << mesh.V.rows();
        if (expected == 5)
        {
            Key family = make_key(mesh, 8);
            family.recipients = RecipientCodes{};
            family.recipients->recipients.push_back({"a", 0});
            EXPECT_EQ(SpectralWatermark(mesh, family).key().options.repetitions,
                      kFamilyRepetitions);
        }
    }
}

// The verdict's bound must hold for suspects that do not carry the key's mark: over many keys,
// the share of an unmarked (noisy) copy's verdicts with a probability of at most alpha never
// exceeds alpha (docs/statistics.md has the 10,000-key study on the real meshes).
TEST(SpectralWatermarkTest, scores_of_unmarked_copies_follow_the_null_model)
{
    const TriangleMesh mesh = lumpy_ellipsoid(3);
    const double D = bounding_box(mesh.V).diagonal();
    Rng rng(11);
    Positions noisy = mesh.V;
    for (Eigen::Index i = 0; i < noisy.size(); ++i)
    {
        noisy.data()[i] += rng.uniform(-2e-3, 2e-3) * D;
    }
    const int trials = 120;
    double sum = 0.0;
    int below_half = 0;
    int below_tenth = 0;
    int positive = 0;
    int claimed = 0;
    for (int t = 0; t < trials; ++t)
    {
        const SpectralWatermark mark(mesh, make_key(mesh, 7000 + static_cast<std::uint64_t>(t)));
        const DetectOptions options;
        const Decision d = mark.decide(Detector(mark, mesh).extract(noisy, options), options);
        sum += d.score;
        positive += d.score > 0.0 ? 1 : 0;
        below_half += d.false_positive_probability <= 0.5 ? 1 : 0;
        below_tenth += d.false_positive_probability <= 0.1 ? 1 : 0;
        claimed += d.is_present ? 1 : 0;
    }
    // The best of three N(0, 1) scores: mean about 0.6 when they are correlated as here.
    EXPECT_GT(sum / trials, 0.0);
    EXPECT_LT(sum / trials, 1.2);
    EXPECT_GT(positive, trials / 3);  // the scores are not degenerate
    EXPECT_LE(below_half, 60 + 17);   // alpha = 0.5: at most 60 expected, + 3 sigma
    EXPECT_LE(below_tenth, 12 + 10);  // alpha = 0.1: at most 12 expected, + 3 sigma
    EXPECT_EQ(claimed, 0);
}

// Every coefficient's sign right but the magnitudes uneven (an attack that leaves a few
// coefficients far larger than the rest, as a bisection does): the score stays below 5, which
// the formula bound refuses whatever the weights, but a sum of random signs with these weights
// reaches it only when nearly every sign agrees, and the counted tail claims.
// An extraction of \p mark's coefficients with unit weights and changes value(c, embedded sign).
template <class Value>
Extraction unit_weight_extraction(const SpectralWatermark& mark, Value value)
{
    const auto coefficients = static_cast<std::size_t>(mark.embedded_signs().size());
    Extraction e;
    e.weights.assign(coefficients, 1.0);
    for (std::size_t c = 0; c < coefficients; ++c)
    {
        e.normalized_change.push_back(
            value(c, mark.embedded_signs()(static_cast<Eigen::Index>(c / 3),
                                           static_cast<Eigen::Index>(c % 3))));
    }
    return e;
}

TEST(SpectralWatermarkTest, soft_verdict_claims_every_sign_right_with_uneven_magnitudes)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, make_key(mesh, 9));
    Extraction e = unit_weight_extraction(
        mark, [](std::size_t c, double sign) { return sign * (c % 7 == 0 ? 30.0 : 0.2); });
    e.bits_found.assign(mark.key().payload.size(), 2);  // no bit decided: the score alone
    DetectOptions correlation;
    correlation.verdict = VerdictRule::Correlation;
    const Decision soft = mark.decide(e, correlation);
    EXPECT_LT(soft.score, 5.0);
    EXPECT_GT(3.0 * rademacher_tail_bound(soft.score), 1e-6) << "the formula alone refuses";
    EXPECT_TRUE(soft.is_present);
    // (Measured: z 3.89, tail 1.3e-29: the 14 large coefficients and nearly every small one must
    // agree.)
    EXPECT_LT(soft.score_tail, 1e-15);
    EXPECT_TRUE(mark.decide(e, DetectOptions{}).is_present);
}

// Every payload bit read right while the coefficients look like noise to the soft score: the
// combined verdict claims through the bit count (2^-24, times 16); one bit wrong, it refuses.
TEST(SpectralWatermarkTest, combined_verdict_claims_a_perfect_bit_read_the_score_refuses)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, make_key(mesh, 9));
    Rng rng(4);
    Extraction e = unit_weight_extraction(mark, [&](std::size_t, double) { return rng.normal(); });
    for (const std::uint8_t bit : mark.key().payload)
    {
        e.bits_found.push_back(bit);
    }
    DetectOptions correlation;
    correlation.verdict = VerdictRule::Correlation;
    const Decision soft = mark.decide(e, correlation);
    EXPECT_LT(soft.score, 3.0);
    EXPECT_FALSE(soft.is_present);
    const Decision combined = mark.decide(e, DetectOptions{});
    EXPECT_EQ(combined.score, soft.score);
    EXPECT_EQ(combined.matches, combined.bit_count);
    EXPECT_NEAR(combined.false_positive_probability / (16.0 * std::pow(0.5, 24)), 1.0, 1e-12);
    EXPECT_TRUE(combined.is_present);
    e.bits_found[0] = 1 - e.bits_found[0];
    EXPECT_FALSE(mark.decide(e, DetectOptions{}).is_present);  // 25 / 2^24 * 16 > 1e-6
}

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

TEST(SpectralWatermarkTest, bits_verdict_is_the_papers_rule)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, make_key(mesh, 8));
    DetectOptions options;
    options.verdict = VerdictRule::Bits;
    const Decision d =
        mark.decide(Detector(mark, mesh).extract(mesh.V + mark.displacement(), options), options);
    EXPECT_TRUE(d.is_present);
    EXPECT_EQ(d.verdict, VerdictRule::Bits);
    EXPECT_EQ(d.false_positive_probability, d.bits_false_positive_probability);
    options.threshold = 1.0;
    EXPECT_TRUE(
        mark.decide(Detector(mark, mesh).extract(mesh.V + mark.displacement(), options), options)
            .is_present);
    EXPECT_FALSE(mark.decide(Detector(mark, mesh).extract(mesh.V, options), options).is_present);
    EXPECT_EQ(parse_verdict_rule("bits"), VerdictRule::Bits);
    EXPECT_EQ(parse_verdict_rule(to_string(VerdictRule::Correlation)), VerdictRule::Correlation);
    EXPECT_EQ(parse_verdict_rule(to_string(VerdictRule::Combined)), VerdictRule::Combined);
    EXPECT_THROW((void)parse_verdict_rule("R"), InvalidOption);
    options.max_false_positive = 0.0;
    EXPECT_THROW(options.validate(), InvalidOption);
}

TEST(SpectralWatermarkTest, same_message_under_another_key_is_not_claimed)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    Key key = make_key(mesh, 5);
    key.payload = payload_from_message("owner", payload_bit_count(key.options));
    const SpectralWatermark mark(mesh, key);
    double sum = 0.0;
    const int trials = 25;
    for (int t = 0; t < trials; ++t)
    {
        Key other_key = make_key(mesh, 500 + static_cast<std::uint64_t>(t));
        other_key.payload = key.payload;
        const SpectralWatermark other(mesh, other_key);
        sum += detect_positions(mark, mesh, mesh.V + other.displacement()).correlation;
    }
    // Without the key-derived mask this would be near 1 (docs/algorithms/embedding.md, "Payload
    // bits").
    EXPECT_LT(sum / trials, 0.6);
}

TEST(SpectralWatermarkTest, displacement_follows_the_model_under_similarity_transforms)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const double D = bounding_box(mesh.V).diagonal();
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
    const double scale = 3.7;
    const Eigen::RowVector3d shift(10.0 * D, -4.0 * D, 7.0 * D);
    TriangleMesh moved = mesh;
    moved.V = ((mesh.V * R.transpose()) * scale).rowwise() + shift;
    for (const auto rule : {EmbeddingRule::Additive, EmbeddingRule::Paper})
    {
        const Positions d0 = SpectralWatermark(mesh, make_key(mesh, 9, rule)).displacement();
        const Positions d1 = SpectralWatermark(moved, make_key(moved, 9, rule)).displacement();
        const Positions expected = (d0 * R.transpose()) * scale;
        const double magnitude = d0.cwiseAbs().maxCoeff() * scale;
        EXPECT_LT((d1 - expected).cwiseAbs().maxCoeff(), 1e-8 * magnitude) << to_string(rule);
    }
}

TEST(SpectralWatermarkTest, unreferenced_vertices_never_move_and_point_clouds_work)
{
    TriangleMesh mesh = lumpy_ellipsoid(3);
    const auto n = mesh.V.rows();
    mesh.V.conservativeResize(n + 1, 3);
    mesh.V.row(n) << 9.0, 9.0, 9.0;
    const SpectralWatermark mark(mesh, make_key(mesh, 1));
    const Positions d = mark.displacement();
    EXPECT_EQ(d.row(n).squaredNorm(), 0.0);

    TriangleMesh cloud = lumpy_ellipsoid(3);
    cloud.F.resize(0, 3);
    const SpectralWatermark cloud_mark(cloud, make_key(cloud, 2));
    EXPECT_DOUBLE_EQ(
        detect_positions(cloud_mark, cloud, cloud.V + cloud_mark.displacement()).correlation, 1.0);
}

TEST(SpectralWatermarkTest, noise_and_smoothing_keep_the_mark)
{
    const TriangleMesh mesh = lumpy_ellipsoid(5);
    const SpectralWatermark mark(mesh, make_key(mesh, 77));
    const Positions noisy = with_noise(mesh, mesh.V + mark.displacement(), 5);
    EXPECT_TRUE(detect_positions(mark, mesh, noisy).is_present);
}

TEST(SpectralWatermarkTest, degenerate_inputs_fail_cleanly)
{
    TriangleMesh line;
    line.V.resize(300, 3);
    for (Eigen::Index i = 0; i < 300; ++i)
    {
        line.V.row(i) << static_cast<double>(i), 2.0 * static_cast<double>(i), 0.0;
    }
    EXPECT_THROW(SpectralWatermark(line, make_key(line, 1)), NumericalError);
    const TriangleMesh tiny = icosphere(1);  // 42 vertices < 100 basis functions
    EXPECT_THROW(SpectralWatermark(tiny, make_key(tiny, 1)), InvalidMesh);
}

// Vertices on a few curves span fewer modes than k: the automatic mark is shortened to fit
// (and says so), reads back whole, and a mark asked to be longer is refused with the reason.
TEST(SpectralWatermarkTest, a_mesh_spanning_few_modes_gets_a_shorter_mark_or_a_clear_refusal)
{
    const TriangleMesh plate = test::outline_plate();
    const SpectralWatermark mark(plate, make_key(plate, 5));
    EmbedStats stats;
    const Positions marked = plate.V + mark.displacement(&stats);
    const EmbedOptions& options = mark.key().options;
    EXPECT_TRUE(stats.shortened_to_span);
    EXPECT_LT(stats.basis_span, 44);    // the usual mark below 5,000 vertices: modes 12-43
    EXPECT_GE(options.repetitions, 2);  // one would be claimed only in the vertex order
    EXPECT_LT(options.repetitions, 4);
    EXPECT_LE(options.first_mode + modulated_modes(options), stats.basis_span);
    const Decision decision = detect_positions(mark, plate, marked);
    EXPECT_TRUE(decision.is_present);
    EXPECT_DOUBLE_EQ(decision.correlation, 1.0);
    EXPECT_EQ(decision.coefficient_count, 3 * modulated_modes(options));
    // The basis rebuilt from the key (as detection does) accepts every mode of it.
    const SpectralWatermark again(plate, mark.key());
    EXPECT_EQ(again.key().options.repetitions, options.repetitions);
    EXPECT_DOUBLE_EQ(detect_positions(again, plate, marked).correlation, 1.0);

    Key longer = make_key(plate, 5);
    longer.options.repetitions = 4;
    try
    {
        (void)SpectralWatermark(plate, longer);
        ADD_FAILURE() << "a mark of 44 modes on a plate spanning " << stats.basis_span;
    }
    catch (const NumericalError& e)
    {
        const std::string what = e.what();
        EXPECT_NE(what.find("span only " + std::to_string(stats.basis_span) + " independent modes"),
                  std::string::npos)
            << what;
        EXPECT_NE(what.find("needs 44"), std::string::npos) << what;
        EXPECT_NE(what.find("--repetitions"), std::string::npos) << what;
    }

    // A surface spans every mode: nothing shortened.
    const TriangleMesh ellipsoid = lumpy_ellipsoid(4);
    const SpectralWatermark full(ellipsoid, make_key(ellipsoid, 5));
    EmbedStats full_stats;
    (void)full.displacement(&full_stats);
    EXPECT_FALSE(full_stats.shortened_to_span);
    EXPECT_EQ(full.key().options.repetitions,
              automatic_repetitions(full.key().options, ellipsoid.V.rows()));
    EXPECT_GE(full_stats.basis_span, 44);
}

// For equal weights the sum of n random signs is 2 Bin(n, 1/2) - n, so the exact tail is known:
// the bound must never fall below it, and must be reasonably tight in the range that matters.
TEST(RademacherBoundTest, never_below_the_exact_tail_of_equal_weights)
{
    for (const int n : {8, 24, 48, 96, 192})
    {
        for (int k = n / 2; k <= n; ++k)
        {
            const double z = (2.0 * k - n) / std::sqrt(static_cast<double>(n));
            const double exact = binomial_tail_half(n, k);
            EXPECT_GE(rademacher_tail_bound(z), exact * (1.0 - 1e-12)) << n << " " << k;
        }
    }
    EXPECT_EQ(rademacher_tail_bound(0.0), 1.0);
    EXPECT_EQ(rademacher_tail_bound(-3.0), 1.0);
    EXPECT_NEAR(rademacher_tail_bound(1.0), std::exp(-0.5), 1e-15);  // Hoeffding below z ~ 3.3
    // Pinelis beyond: (2 e^3 / 9) (1 - Phi(6)) = 4.4634 * 9.866e-10.
    EXPECT_NEAR(rademacher_tail_bound(6.0) / 4.4036e-9, 1.0, 1e-3);
    // Within a factor 5 of the normal tail at the default level (z ~ 5).
    EXPECT_LT(rademacher_tail_bound(5.0), 5.0 * 0.5 * std::erfc(5.0 / std::sqrt(2.0)));
}

// Equal weights: the sum is 2 Bin(n, 1/2) - n, so the computed tail must be the binomial tail
// exactly at every attainable score, and a score between two attainable ones (more than the
// resolution past one) must get the next one's tail: not the formula's, 1.9-4.5 times larger.
TEST(RademacherTailTest, is_the_binomial_tail_for_equal_weights)
{
    for (const int n : {8, 24, 96, 120})
    {
        const RademacherTail tail(std::vector<double>(static_cast<std::size_t>(n), 0.7));
        EXPECT_LE(tail.slack(), 0.02);
        for (int k = n / 2 + 1; k <= n; ++k)
        {
            const double z = (2.0 * k - n) / std::sqrt(static_cast<double>(n));
            const double exact = binomial_tail_half(n, k);
            EXPECT_GE(tail(z), exact * (1.0 - 1e-12)) << n << " " << k;
            EXPECT_LE(tail(z), binomial_tail_half(n, k - 1) * (1.0 + 1e-8)) << n << " " << k;
            if (k < n)
            {
                EXPECT_NEAR(tail(z + 0.03) / binomial_tail_half(n, k + 1), 1.0, 1e-8)
                    << n << " " << k;
            }
        }
        EXPECT_EQ(tail(std::sqrt(static_cast<double>(n)) + 0.03), 0.0)
            << "beyond every sign agreeing";
    }
    // 120 coefficients at z = 5: P(Bin(120, 1/2) >= 88) = 1.5e-7 against the formula's 1.3e-6.
    const RademacherTail tail(std::vector<double>(120, 1.0));
    EXPECT_NEAR(tail(5.0) / binomial_tail_half(120, 88), 1.0, 1e-8);
    EXPECT_LT(tail(5.0), rademacher_tail_bound(5.0) / 4.0);
    EXPECT_EQ(tail(0.0), 1.0);
    EXPECT_EQ(tail(-2.0), 1.0);
    EXPECT_EQ(RademacherTail(std::vector<double>(10, 0.0))(1.0), 1.0);
    EXPECT_THROW(RademacherTail(std::vector<double>(4, 1.0), 0.0), InvalidOption);
}

// Uneven weights, signs and zeros: every one of the 2^16 sign vectors counted. The computed
// tail is never below the exact one and never above the exact tail one resolution lower.
TEST(RademacherTailTest, brackets_the_exact_tail_of_any_weights)
{
    Rng rng(3);
    for (int trial = 0; trial < 6; ++trial)
    {
        std::vector<double> a(16);
        for (double& v : a)
        {
            v = trial % 2 == 0 ? rng.normal() : std::exp(2.0 * rng.normal());  // heavy tails too
        }
        a[5] = 0.0;
        double norm_sq = 0.0;
        for (const double v : a)
        {
            norm_sq += v * v;
        }
        std::vector<double> sums;
        for (std::uint32_t signs = 0; signs < (1U << 16U); ++signs)
        {
            double sum = 0.0;
            for (std::size_t i = 0; i < a.size(); ++i)
            {
                sum += ((signs >> i) & 1U) != 0 ? a[i] : -a[i];
            }
            sums.push_back(sum / std::sqrt(norm_sq));
        }
        auto exact = [&](double z)
        {
            return static_cast<double>(
                       std::count_if(sums.begin(), sums.end(), [z](double s) { return s >= z; })) /
                   static_cast<double>(sums.size());
        };
        const RademacherTail tail(a);
        for (double z = 0.25; z < 4.2; z += 0.05)
        {
            EXPECT_GE(tail(z), exact(z) * (1.0 - 1e-12)) << trial << " " << z;
            EXPECT_LE(tail(z), exact(z - 0.02 - 1e-9) * (1.0 + 1e-8)) << trial << " " << z;
        }
        // Each attainable sum: its own tail is at least 2^-16 (the sign vector that gave it).
        EXPECT_GE(tail(*std::max_element(sums.begin(), sums.end())), std::pow(0.5, 16));
    }
}

// 48 weights like an extraction's |x_c| (normal values), 4 million sign vectors drawn: at the
// scores where the counted tail is 1e-3 and 1e-4, the share of draws reaching them lies within
// 4 standard deviations of [the tail one resolution up, the counted tail].
TEST(RademacherTailTest, agrees_with_sampled_signs_for_48_normal_weights)
{
    Rng rng(11);
    std::vector<double> a(48);
    double norm_sq = 0.0;
    for (double& v : a)
    {
        v = rng.normal();
        norm_sq += v * v;
    }
    const RademacherTail tail(a);
    auto score_at = [&](double level) {  // the smallest z on a 0.001 grid with tail(z) <= level
        double z = 0.0;
        while (tail(z) > level)
        {
            z += 0.001;
        }
        return z;
    };
    const std::array<double, 2> levels{1e-3, 1e-4};
    std::array<double, 2> at{score_at(levels[0]), score_at(levels[1])};
    std::array<double, 2> hits{};
    std::array<double, 2>
        hits_up{};  // at z + 0.021: the counted tail there bounds these from above
    const double norm = std::sqrt(norm_sq);
    constexpr int kDraws = 4'000'000;
    for (int d = 0; d < kDraws; ++d)
    {
        const std::uint64_t bits = rng.bits();
        double sum = 0.0;
        for (std::size_t i = 0; i < a.size(); ++i)
        {
            sum += ((bits >> i) & 1U) != 0 ? a[i] : -a[i];
        }
        sum /= norm;
        for (std::size_t l = 0; l < levels.size(); ++l)
        {
            hits[l] += sum >= at[l] ? 1.0 : 0.0;
            hits_up[l] += sum >= at[l] + 0.021 ? 1.0 : 0.0;
        }
    }
    for (std::size_t l = 0; l < levels.size(); ++l)
    {
        const double p = tail(at[l]);
        const double sigma = std::sqrt(p * kDraws);
        EXPECT_LE(hits[l], p * kDraws + 4.0 * sigma)
            << "the counted tail is below the sampled share at " << at[l];
        // One resolution up, the exact tail is at most the counted one here: the sampled share
        // there may not exceed it, and the counted tail must not be far above the share below.
        EXPECT_LE(hits_up[l], p * kDraws + 4.0 * sigma);
        EXPECT_GE(hits[l], tail(at[l] + 0.021) * kDraws - 4.0 * sigma)
            << "the counted tail is loose at " << at[l];
    }
}

// Weights too many to count within RademacherTail::kMaxWork: the tail is 1 and a soft
// correlation over them falls back on the formula bound alone.
TEST(RademacherTailTest, leaves_too_many_weights_to_the_formula)
{
    EXPECT_TRUE(RademacherTail(std::vector<double>(400, 1.0)).is_counted());
    const RademacherTail many(std::vector<double>(600, 1.0));
    EXPECT_FALSE(many.is_counted());
    EXPECT_EQ(many(5.0), 1.0);
    std::vector<double> x(600, 1.0);
    const SoftCorrelation soft(x, std::vector<double>(600, 1.0));
    const SoftScore scored = soft.score([](std::size_t) { return 1.0; });
    EXPECT_NEAR(scored.z, std::sqrt(600.0), 1e-9);
    EXPECT_DOUBLE_EQ(scored.tail, rademacher_tail_bound(scored.z));
    EXPECT_DOUBLE_EQ(scored.probability, 3.0 * rademacher_tail_bound(scored.z));
}

// The statistics' tails are counted on several threads: the same score, tail and probability
// as on one, bit for bit, for uneven weights, several readings and signs mostly right.
TEST(SoftCorrelationTest, counts_the_same_tails_on_any_number_of_threads)
{
    Rng rng(0x7A11);
    const std::size_t n = 120;
    std::vector<double> x(n);
    std::vector<double> w(n);
    std::vector<std::vector<double>> damped(4, std::vector<double>(n));
    for (std::size_t c = 0; c < n; ++c)
    {
        x[c] = 1.0 + rng.normal();
        w[c] = 0.1 + rng.uniform() * 4.0;
        for (std::vector<double>& reading : damped)
        {
            reading[c] = 0.8 + 1.5 * rng.normal();
        }
    }
    const auto sign = [](std::size_t c) { return c % 7 == 3 ? -1.0 : 1.0; };
    const SoftScore one = SoftCorrelation(x, w, damped, true, 1).score(sign);
    EXPECT_GT(one.z, 4.0);
    EXPECT_LT(one.tail, 0.1 * rademacher_tail_bound(one.z)) << "the counted tail, not the formula";
    for (const int threads : {2, 3, 7})
    {
        const SoftScore many = SoftCorrelation(x, w, damped, true, threads).score(sign);
        EXPECT_EQ(many.z, one.z) << threads;
        EXPECT_EQ(many.tail, one.tail) << threads;
        EXPECT_EQ(many.probability, one.probability) << threads;
    }
}

TEST(BinomialTest, tail_matches_direct_sums)
{
    EXPECT_DOUBLE_EQ(binomial_tail_half(24, 0), 1.0);
    EXPECT_NEAR(binomial_tail_half(24, 24), std::pow(0.5, 24), 1e-22);
    EXPECT_NEAR(binomial_tail_half(24, 18), 190051.0 / 16777216.0, 1e-14);
    EXPECT_NEAR(binomial_tail_half(4, 2), 11.0 / 16.0, 1e-15);
    EXPECT_EQ(binomial_tail_half(24, 25), 0.0);
}

}  // namespace meshmark

namespace meshmark
{
namespace
{

Key laplacian_key(const TriangleMesh& mesh, std::uint64_t seed)
{
    Key key = make_key(mesh, seed);
    key.options.basis = BasisType::Laplacian;
    return key;
}

}  // namespace

TEST(LaplacianWatermarkTest, marked_copy_is_found_and_unmarked_or_wrong_key_is_not)
{
    TriangleMesh mesh = lumpy_ellipsoid(4);
    const auto n = mesh.V.rows();
    mesh.V.conservativeResize(n + 1, 3);
    mesh.V.row(n) << 9.0, 9.0, 9.0;  // unreferenced: inactive, never moves
    const SpectralWatermark mark(mesh, laplacian_key(mesh, 42));
    EXPECT_TRUE(mark.centers().empty());
    EXPECT_EQ(mark.basis().size(), 100);
    EmbedStats stats;
    const Positions displacement = mark.displacement(&stats);
    EXPECT_EQ(displacement.row(n).squaredNorm(), 0.0);
    EXPECT_LT(stats.orthogonality_error, 1e-10);
    EXPECT_NEAR(stats.rms_displacement_rel, 1e-3, 5e-4);  // same strength rule as RBF
    const Positions marked = mesh.V + displacement;
    const Decision found = detect_positions(mark, mesh, marked);
    EXPECT_TRUE(found.is_present);
    EXPECT_DOUBLE_EQ(found.correlation, 1.0);
    EXPECT_FALSE(detect_positions(mark, mesh, mesh.V).is_present);
    // Through the resampled path (registration's extraction) as well.
    const DetectOptions options;
    EXPECT_TRUE(
        mark.decide(Detector(mark, mesh).extract_resampled(marked, options), options).is_present);
    EXPECT_FALSE(
        mark.decide(Detector(mark, mesh).extract_resampled(mesh.V, options), options).is_present);
    for (std::uint64_t seed = 500; seed < 503; ++seed)
    {
        const SpectralWatermark other(mesh, laplacian_key(mesh, seed));
        EXPECT_FALSE(detect_positions(other, mesh, marked).is_present) << seed;
    }
    // An RBF key with the same seed does not read the Laplacian mark.
    EXPECT_FALSE(
        detect_positions(SpectralWatermark(mesh, make_key(mesh, 42)), mesh, marked).is_present);
}

TEST(LaplacianWatermarkTest, noise_keeps_the_mark_and_point_clouds_are_refused)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, laplacian_key(mesh, 7));
    const Positions noisy = with_noise(mesh, mesh.V + mark.displacement(), 3);
    EXPECT_TRUE(detect_positions(mark, mesh, noisy).is_present);
    TriangleMesh cloud = mesh;
    cloud.F.resize(0, 3);
    EXPECT_THROW(SpectralWatermark(cloud, laplacian_key(cloud, 7)), InvalidMesh);
}

TEST(DecimatedCentersWatermarkTest, centers_do_not_depend_on_the_seed_and_the_mark_reads_back)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    Key a = make_key(mesh, 1);
    Key b = make_key(mesh, 2);
    a.options.centers = CenterSelection::Decimate;
    b.options.centers = CenterSelection::Decimate;
    const SpectralWatermark mark_a(mesh, a);
    const SpectralWatermark mark_b(mesh, b);
    EXPECT_EQ(mark_a.centers(), mark_b.centers());
    EXPECT_EQ(static_cast<int>(mark_a.centers().size()), a.options.basis_size);
    const Positions marked = mesh.V + mark_a.displacement();
    EXPECT_TRUE(detect_positions(mark_a, mesh, marked).is_present);
    EXPECT_FALSE(detect_positions(mark_b, mesh, marked).is_present)
        << "the payload mask still depends on the key";
    EXPECT_FALSE(detect_positions(mark_a, mesh, mesh.V).is_present);
}

}  // namespace meshmark

namespace meshmark
{
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

}  // namespace meshmark

namespace meshmark
{

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
