// SPDX-License-Identifier: MIT
// The spectral watermark: built, embedded and read back; its strength, repetitions and
// refusals; the Laplacian basis and decimated centres.
#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <thread>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/watermark/detector.h"
#include "meshmark/watermark/watermark.h"
#include "support/test_shapes.h"
#include "watermark/nuisance.h"
#include "watermark_test_support.h"

namespace meshmark
{

using test::detect_positions;
using test::make_key;
using test::with_noise;

namespace
{
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
