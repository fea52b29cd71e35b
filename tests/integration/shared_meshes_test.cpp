// SPDX-License-Identifier: MIT
// Issue 2's end-to-end checks on every real mesh: embed -> write -> read -> detect, unmarked and
// wrong-key copies, and the in-place attacks the same-connectivity detector must survive.
#include <algorithm>
#include <cstdio>

#include <gtest/gtest.h>

#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/watermark/detector.h"
#include "meshmark/watermark/watermark.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

Key key_for(const TriangleMesh& mesh, std::uint64_t seed,
            const std::optional<std::string>& message = {})
{
    Key key;
    key.seed = seed;
    key.payload = message ? payload_from_message(*message, payload_bit_count(key.options))
                          : random_payload(seed, payload_bit_count(key.options));
    key.message = message;
    key.original = fingerprint(mesh);
    return key;
}

Decision decide(const SpectralWatermark& mark, const TriangleMesh& original,
                const Positions& suspect)
{
    const DetectOptions options;
    return mark.decide(Detector(mark, original).extract(suspect, options), options);
}

class SharedMeshTest : public ::testing::TestWithParam<std::filesystem::path>
{
};

TEST_P(SharedMeshTest, embeds_detects_and_rejects_unmarked_and_wrong_keys)
{
    const auto& path = GetParam();
    const MeshFile file = read_mesh_file(path);
    const TriangleMesh& mesh = file.mesh;
    const SpectralWatermark mark(mesh, key_for(mesh, 0xC0FFEE, std::string("owner")));

    // Marked copy written in the input's format (its precision) and read back: R = 1.
    EmbedStats stats;
    const Positions marked = mesh.V + mark.displacement(&stats);
    EXPECT_LT(stats.orthogonality_error, 1e-9);
    const auto out = test::temp_dir("shared") / ("marked" + path.extension().string());
    write_mesh_file(out, file, marked);
    const TriangleMesh back = read_mesh(out);
    ASSERT_EQ(back.V.rows(), mesh.V.rows());
    const Decision found = decide(mark, mesh, back.V);
    EXPECT_DOUBLE_EQ(found.correlation, 1.0);
    EXPECT_TRUE(found.is_present);
    EXPECT_LT(found.false_positive_probability, 1e-9);

    // Zero strength (paper rule, rho = 0) returns the input to within 1e-12 of the diagonal.
    Key zero = key_for(mesh, 0xC0FFEE);
    zero.options.rule = EmbeddingRule::Paper;
    zero.options.strength = 0.0;
    const Positions unchanged = mesh.V + SpectralWatermark(mesh, zero).displacement();
    EXPECT_LE((unchanged - mesh.V).cwiseAbs().maxCoeff(), 1e-12 * bounding_box(mesh.V).diagonal());

    // Unmarked original: nothing moved, nothing claimed.
    const Decision unmarked = decide(mark, mesh, mesh.V);
    EXPECT_LT(unmarked.correlation, 0.5);
    EXPECT_FALSE(unmarked.is_present);

    // Copies marked with other keys, with random payloads and with the same message.
    double sum_other = 0.0;
    double sum_same_message = 0.0;
    double largest = 0.0;
    const int trials = mesh.V.rows() > 200000 ? 2 : 4;
    for (int t = 0; t < trials; ++t)
    {
        const SpectralWatermark other(mesh, key_for(mesh, 1000 + static_cast<std::uint64_t>(t)));
        const Decision d1 = decide(mark, mesh, mesh.V + other.displacement());
        const SpectralWatermark same(mesh,
                                     key_for(mesh, 2000 + static_cast<std::uint64_t>(t), "owner"));
        const Decision d2 = decide(mark, mesh, mesh.V + same.displacement());
        EXPECT_FALSE(d1.is_present);
        EXPECT_FALSE(d2.is_present);
        const double r1 = d1.correlation;
        const double r2 = d2.correlation;
        EXPECT_LT(r1, 0.75);
        EXPECT_LT(r2, 0.75);
        sum_other += r1;
        sum_same_message += r2;
        largest = std::max({largest, r1, r2});
    }
    EXPECT_LT(sum_other / trials, 0.5 + 0.15);
    EXPECT_LT(sum_same_message / trials, 0.5 + 0.15);
    std::printf(
        "[ %s ] rms %.4f%% max %.4f%% of diagonal; wrong keys: mean R %.3f (same message %.3f), "
        "largest %.3f\n",
        path.filename().c_str(), 100.0 * stats.rms_displacement_rel,
        100.0 * stats.max_displacement_rel, sum_other / trials, sum_same_message / trials, largest);

    // In-place attacks: uniform noise of 0.1% of the diagonal, 10 Laplacian steps (lambda 0.1).
    for (const char* spec : {"noise=0.001:dist=uniform", "smooth=10:lambda=0.1"})
    {
        const AttackResult attacked = apply_attacks(back, parse_attack_spec(spec), 5);
        ASSERT_EQ(attacked.mesh.V.rows(), mesh.V.rows());
        const Decision d = decide(mark, mesh, attacked.mesh.V);
        EXPECT_GE(d.correlation, 0.75) << spec;
        EXPECT_TRUE(d.is_present) << spec << ": z = " << d.score;
        std::printf("[ %s ] %s: R = %.3f, z = %.2f\n", path.filename().c_str(), spec, d.correlation,
                    d.score);
    }
}

std::string name_of(const ::testing::TestParamInfo<std::filesystem::path>& info)
{
    std::string name = info.param.filename().string();
    std::replace_if(
        name.begin(), name.end(),
        [](char c) { return std::isalnum(static_cast<unsigned char>(c)) == 0; }, '_');
    return name;
}

INSTANTIATE_TEST_SUITE_P(Meshes, SharedMeshTest, ::testing::ValuesIn(test::shared_meshes()),
                         name_of);
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(SharedMeshTest);

}  // namespace
}  // namespace meshmark
