// SPDX-License-Identifier: MIT
// `meshmark compare` end to end: files in, JSON and a colored PLY out, exit codes.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <stb_image.h>
#include <sys/wait.h>

#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/cli_run.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

using test::CliRun;
using test::run_cli;
using test::slurp;

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
    const CliRun run =
        run_cli("compare \"" + a_ + "\" \"" + b_ +
                    "\" --json --samples 5000 --threads 2 --heatmap \"" + heatmap.string() + "\"",
                dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto json = nlohmann::json::parse(run.out);
    const double expected = 0.05 / std::sqrt(2.0);  // relative to A's bounding-box diagonal
    for (const char* field : {"hausdorff", "hausdorff_ab", "hausdorff_ba", "rms_ab", "rms_ba",
                              "mrms", "max_displacement", "rms_displacement"})
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
    const CliRun run =
        run_cli("compare \"" + a_ + "\" \"" + other + "\" --json --samples 2000", dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto json = nlohmann::json::parse(run.out);
    EXPECT_FALSE(json.at("same_connectivity").get<bool>());
    EXPECT_FALSE(json.contains("max_displacement"));
    EXPECT_LE(json.at("hausdorff").get<double>(), 1e-12);  // both are the unit square
}

TEST_F(CompareCliTest, png_heatmap_is_a_picture_of_b_with_the_displacement_in_red)
{
    // A sphere whose right side (x > 0.3) is pushed out by 5%: seen from the front, red on the
    // right of the model, none on the left.
    const TriangleMesh sphere = icosphere(4);
    TriangleMesh bumped = sphere;
    for (Eigen::Index i = 0; i < bumped.V.rows(); ++i)
    {
        if (bumped.V(i, 0) > 0.3)
        {
            bumped.V.row(i) *= 1.05;
        }
    }
    const auto a = (dir_ / "sphere.ply").string();
    const auto b = (dir_ / "bumped.ply").string();
    write_mesh(a, sphere);
    write_mesh(b, bumped);
    const auto png = dir_ / "heat.png";
    const CliRun run = run_cli("compare \"" + a + "\" \"" + b +
                                   "\" --samples 2000 --view front --size 640x480 "
                                   "--heatmap \"" +
                                   png.string() + "\"",
                               dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_NE(run.out.find("heat.png"), std::string::npos);
    int w = 0;
    int h = 0;
    int channels = 0;
    unsigned char* data = stbi_load(png.c_str(), &w, &h, &channels, 3);
    ASSERT_NE(data, nullptr) << stbi_failure_reason();
    EXPECT_EQ(w, 640);
    EXPECT_EQ(h, 480);
    int model = 0;
    int red_left = 0;
    int red_right = 0;
    const int model_width = 480;  // the colour bar takes less than the right quarter
    for (int y = 0; y < h; ++y)
    {
        for (int x = 0; x < model_width; ++x)
        {
            const unsigned char* p = data + 3 * (static_cast<std::size_t>(y) * w + x);
            model += p[0] == 255 && p[1] == 255 && p[2] == 255 ? 0 : 1;
            const bool red = p[0] > 120 && p[1] < p[0] / 3 && p[2] < p[0] / 3;
            (x < model_width / 2 ? red_left : red_right) += red ? 1 : 0;
        }
    }
    stbi_image_free(data);
    EXPECT_GT(model, model_width * h / 5);
    EXPECT_LT(model, model_width * h * 3 / 4);
    EXPECT_EQ(red_left, 0);
    EXPECT_GT(red_right, 1000);
}

TEST_F(CompareCliTest, png_heatmap_options_are_checked)
{
    const auto png = dir_ / "heat.png";
    CliRun run = run_cli(
        "compare \"" + a_ + "\" \"" + b_ + "\" --heatmap \"" + png.string() + "\" --view sideways",
        dir_);
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_NE(run.err.find("sideways"), std::string::npos);
    run = run_cli(
        "compare \"" + a_ + "\" \"" + b_ + "\" --heatmap \"" + png.string() + "\" --size 20x20",
        dir_);
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_NE(run.err.find("20x20"), std::string::npos);
    run = run_cli("compare \"" + a_ + "\" \"" + b_ + "\" --view top", dir_);
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_NE(run.err.find(".png"), std::string::npos);
    run = run_cli("compare \"" + a_ + "\" \"" + b_ + "\" --heatmap \"" + png.string() + "\" --up w",
                  dir_);
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_NE(run.err.find("up axis 'w'"), std::string::npos);
    run = run_cli("compare \"" + a_ + "\" \"" + b_ + "\" --up z", dir_);
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_NE(run.err.find("--up applies to a .png"), std::string::npos);
    EXPECT_FALSE(std::filesystem::exists(png));
    // A point cloud B is drawn as dots.
    TriangleMesh cloud = read_mesh(b_);
    cloud.F.resize(0, 3);
    const auto cloud_path = (dir_ / "cloud.ply").string();
    write_mesh(cloud_path, cloud);
    run = run_cli("compare \"" + a_ + "\" \"" + cloud_path + "\" --samples 100 --heatmap \"" +
                      png.string() + "\"",
                  dir_);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    EXPECT_TRUE(std::filesystem::exists(png));
}

TEST_F(CompareCliTest, bad_heatmap_and_unreadable_input_fail_cleanly)
{
    const auto obj = dir_ / "heat.obj";
    CliRun run =
        run_cli("compare \"" + a_ + "\" \"" + b_ + "\" --heatmap \"" + obj.string() + "\"", dir_);
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_NE(run.err.find("heat.obj"), std::string::npos);
    EXPECT_NE(run.err.find(".ply"), std::string::npos);
    EXPECT_NE(run.err.find(".png"), std::string::npos);
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
