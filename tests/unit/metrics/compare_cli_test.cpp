// SPDX-License-Identifier: MIT
// `meshmark compare` end to end: files in, JSON and a colored PLY out, exit codes.
#include <sys/wait.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark {
namespace {

struct CliRun
{
    int exit_code = -1;
    std::string out;
    std::string err;
};

std::string slurp(const std::filesystem::path& path)
{
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

CliRun run_cli(const std::string& arguments, const std::filesystem::path& dir)
{
    const auto out = dir / "stdout.txt";
    const auto err = dir / "stderr.txt";
    const std::string command = "\"" + test::cli_path().string() + "\" " + arguments + " > \"" + out.string() +
                                "\" 2> \"" + err.string() + "\"";
    const int status = std::system(command.c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

class CompareCliTest : public ::testing::Test
{
protected:
    void SetUp() override
    {
        if (test::cli_path().empty())
        {
            GTEST_SKIP() << "the meshmark program is not built";
        }
        dir_ = test::temp_dir("compare_cli");
        // A unit grid and the same grid lifted by 0.05: every distance is exactly 0.05.
        const TriangleMesh grid = plane_grid(8, 8);
        TriangleMesh lifted = grid;
        lifted.V.col(2).array() += 0.05;
        a_ = (dir_ / "a.ply").string();
        b_ = (dir_ / "b.ply").string();
        write_mesh(a_, grid);
        write_mesh(b_, lifted);
    }

    std::filesystem::path dir_;
    std::string a_;
    std::string b_;
};

}  // namespace

TEST_F(CompareCliTest, json_reports_relative_distances_and_writes_heatmap)
{
    const auto heatmap = dir_ / "heat.ply";
    const CliRun run = run_cli("compare \"" + a_ + "\" \"" + b_ + "\" --json --samples 5000 --threads 2 --heatmap \"" +
                                heatmap.string() + "\"",
                            dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto json = nlohmann::json::parse(run.out);
    const double expected = 0.05 / std::sqrt(2.0);  // relative to A's bounding-box diagonal
    for (const char* field : {"hausdorff", "hausdorff_ab", "hausdorff_ba", "rms_ab", "rms_ba", "mrms",
                              "max_displacement", "rms_displacement"})
    {
        EXPECT_NEAR(json.at(field).get<double>(), expected, 1e-12) << field;
    }
    EXPECT_TRUE(json.at("same_connectivity").get<bool>());
    EXPECT_EQ(json.at("a").at("vertices").get<int>(), 81);
    EXPECT_EQ(json.at("a").at("area_samples").get<int>(), 5000);
    EXPECT_EQ(json.at("samples").get<int>(), 2 * (81 + 5000));
    EXPECT_GE(json.at("seconds").at("total").get<double>(), 0.0);
    // The heatmap is B with per-vertex colors.
    EXPECT_EQ(read_mesh(heatmap).V.rows(), 81);
    EXPECT_NE(slurp(heatmap).find("property uchar red"), std::string::npos);
}

TEST_F(CompareCliTest, different_connectivity_has_no_displacement)
{
    const auto other = (dir_ / "c.ply").string();
    write_mesh(other, plane_grid(5, 7));
    const CliRun run = run_cli("compare \"" + a_ + "\" \"" + other + "\" --json --samples 2000", dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto json = nlohmann::json::parse(run.out);
    EXPECT_FALSE(json.at("same_connectivity").get<bool>());
    EXPECT_FALSE(json.contains("max_displacement"));
    EXPECT_LE(json.at("hausdorff").get<double>(), 1e-12);  // both are the unit square
}

TEST_F(CompareCliTest, bad_heatmap_and_unreadable_input_fail_cleanly)
{
    const auto obj = dir_ / "heat.obj";
    CliRun run = run_cli("compare \"" + a_ + "\" \"" + b_ + "\" --heatmap \"" + obj.string() + "\"", dir_);
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_NE(run.err.find("heat.obj"), std::string::npos);
    EXPECT_FALSE(std::filesystem::exists(obj));
    run = run_cli("compare \"" + a_ + "\" \"" + b_ + "\" --heatmap \"" + a_ + "\"", dir_);
    EXPECT_EQ(run.exit_code, 2);
    const auto broken = dir_ / "broken.ply";
    std::ofstream(broken) << "ply\nformat ascii 1.0\nelement vertex 3\n";
    run = run_cli("compare \"" + a_ + "\" \"" + broken.string() + "\"", dir_);
    EXPECT_EQ(run.exit_code, 3);
    EXPECT_NE(run.err.find("broken.ply"), std::string::npos);
}

}  // namespace meshmark
