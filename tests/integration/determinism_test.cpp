// SPDX-License-Identifier: MIT
// Determinism (issue 6, item 5): the same inputs, key seed and attack seed give bit-identical
// files and reports across runs and for --threads 1, 2 and 3: the marked mesh and the key of
// `embed`, the attacked mesh of `attack --seed`, and `detect --json` without its timings.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "process_util.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::file_bytes;

// What one run of embed -> attack -> detect produced.
struct Outputs
{
    std::string marked;
    std::string key;
    std::string attacked;
    std::string detect_json;  // without "seconds"
    bool detected = false;
};

Outputs run_chain(const fs::path& original, const std::string& attack_spec, int threads,
                  const fs::path& dir)
{
    const std::string ext = original.extension().string();
    const std::string n = std::to_string(threads);
    const fs::path marked = dir / ("marked" + ext);
    const fs::path key = dir / "key.json";
    const fs::path attacked = dir / ("attacked" + ext);
    fs::remove(key);
    Outputs outputs;
    const auto embed =
        test::run_cli({"embed", original.string(), "-o", marked.string(), "--key", key.string(),
                       "--seed", "77", "--message", "determinism", "--threads", n, "--quiet"},
                      dir);
    EXPECT_EQ(embed.exit_code, 0) << embed.err;
    const auto attack = test::run_cli({"attack", marked.string(), "-o", attacked.string(), "--seed",
                                       "5", "--threads", n, "--quiet", attack_spec},
                                      dir);
    EXPECT_EQ(attack.exit_code, 0) << attack.err;
    const auto detect = test::run_cli({"detect", attacked.string(), "--original", original.string(),
                                       "--key", key.string(), "--threads", n, "--json", "--quiet"},
                                      dir);
    EXPECT_LE(detect.exit_code, 1) << detect.err;
    auto report = nlohmann::json::parse(detect.out, nullptr, false);
    EXPECT_FALSE(report.is_discarded()) << detect.out;
    if (!report.is_discarded())
    {
        EXPECT_TRUE(report.contains("seconds"));
        report.erase("seconds");
        outputs.detected = report.value("detected", false);
        outputs.detect_json = report.dump();
    }
    outputs.marked = file_bytes(marked);
    outputs.key = file_bytes(key);
    outputs.attacked = file_bytes(attacked);
    return outputs;
}

// Runs with 1, 2, 3 threads and 2 again (across runs) must agree bit for bit.
void expect_deterministic(const fs::path& original, const std::string& attack_spec,
                          const fs::path& dir)
{
    const Outputs first = run_chain(original, attack_spec, 1, dir);
    ASSERT_FALSE(first.marked.empty());
    ASSERT_FALSE(first.attacked.empty());
    ASSERT_NE(first.marked, file_bytes(original)) << "embed did not change the mesh";
    // The mark is found after the chain, so the compared report is a meaningful one.
    EXPECT_TRUE(first.detected) << first.detect_json;
    for (const int threads : {2, 3, 2})
    {
        SCOPED_TRACE("--threads " + std::to_string(threads));
        const Outputs again = run_chain(original, attack_spec, threads, dir);
        EXPECT_TRUE(again.marked == first.marked) << "marked mesh differs";
        EXPECT_EQ(again.key, first.key);
        EXPECT_TRUE(again.attacked == first.attacked) << "attacked mesh differs";
        EXPECT_EQ(again.detect_json, first.detect_json);
    }
}

class DeterminismTest : public ::testing::Test
{
protected:
    void SetUp() override
    {
        if (test::cli_path().empty())
        {
            GTEST_SKIP() << "the CLI is not built";
        }
        dir_ = test::temp_dir(::testing::UnitTest::GetInstance()->current_test_info()->name());
    }
    void TearDown() override
    {
        std::error_code ignored;
        fs::remove_all(dir_, ignored);
    }
    fs::path dir_;
};

TEST_F(DeterminismTest, generated_mesh_is_bit_identical_across_runs_and_thread_counts)
{
    const fs::path original = dir_ / "original.ply";
    write_mesh(original, lumpy_ellipsoid(5));  // 10,242 vertices, binary float64 PLY
    // Vertex-for-vertex attacks and a simplification (detection then registers and resamples).
    expect_deterministic(original, "similarity,noise=0.0005,smooth=2,simplify=0.8,reorder", dir_);
}

TEST_F(DeterminismTest, shared_mesh_is_bit_identical_across_runs_and_thread_counts)
{
    const fs::path original = test::mesh_dir() / "bun_zipper.ply";  // ASCII PLY, extra properties
    if (!fs::exists(original))
    {
        GTEST_SKIP() << original << " is missing";
    }
    // Attacks that keep the vertices in order: detection takes the vertex-for-vertex path.
    expect_deterministic(original, "similarity,noise=0.001,taubin=3,quantize=12", dir_);
}

}  // namespace
}  // namespace meshmark
