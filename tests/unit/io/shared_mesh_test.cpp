// SPDX-License-Identifier: MIT
// The real meshes of the shared folder: counts from SOURCES.md, byte-identical round trips,
// and perturbed round trips that keep the file's precision.
#include <cmath>
#include <fstream>
#include <map>
#include <regex>

#include <gtest/gtest.h>

#include "io_test_support.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{

namespace
{

struct Counts
{
    long vertices = 0;
    long faces = 0;
    long unreferenced = 0;
};

// Counts from the SOURCES.md table: "| file | model | format | V | F | bnd | nm | unref | ...".
std::map<std::string, Counts> sources_counts()
{
    std::map<std::string, Counts> counts;
    std::ifstream sources(test::mesh_dir() / "SOURCES.md");
    const std::regex row(
        R"(^\| ([^ |]+\.(ply|obj|off|stl)) \|[^|]*\|[^|]*\| (\d+)[^|]*\| (\d+) \| \d+ \| \d+ \| (\d+) \|)");
    std::string line;
    while (std::getline(sources, line))
    {
        std::smatch m;
        if (std::regex_search(line, m, row))
        {
            counts[m[1].str()] = {std::stol(m[3].str()), std::stol(m[4].str()),
                                  std::stol(m[5].str())};
        }
    }
    return counts;
}

}  // namespace

TEST(SharedMeshTest, reads_counts_of_sources_md_and_round_trips_byte_identically)
{
    const auto meshes = test::shared_meshes();
    if (meshes.empty())
    {
        GTEST_SKIP() << "no shared meshes in " << test::mesh_dir();
    }
    const auto counts = sources_counts();
    ASSERT_EQ(counts.size(), meshes.size());
    const auto dir = test::temp_dir("shared_same");
    for (const auto& path : meshes)
    {
        SCOPED_TRACE(path.filename().string());
        const auto file = read_mesh_file(path);
        const auto& expected = counts.at(path.filename().string());
        EXPECT_EQ(file.mesh.V.rows(), expected.vertices);
        EXPECT_EQ(file.mesh.F.rows(), expected.faces);
        EXPECT_EQ(file.mesh.V.rows() - static_cast<long>(referenced_vertices(file.mesh).size()),
                  expected.unreferenced);
        const auto out = dir / path.filename();
        write_mesh_file(out, file, file.mesh.V);
        EXPECT_TRUE(test::file_bytes(out) == test::file_bytes(path)) << "bytes differ";
        std::filesystem::remove(out);
    }
}

TEST(SharedMeshTest, perturbed_positions_round_trip_within_file_precision)
{
    const auto meshes = test::shared_meshes_up_to(150000);
    if (meshes.empty())
    {
        GTEST_SKIP() << "no shared meshes in " << test::mesh_dir();
    }
    const auto dir = test::temp_dir("shared_moved");
    for (const auto& path : meshes)
    {
        SCOPED_TRACE(path.filename().string());
        const auto file = read_mesh_file(path);
        // A watermark-sized displacement: 1e-4 of the coordinate range.
        const double scale = 1e-4 * (file.mesh.V.maxCoeff() - file.mesh.V.minCoeff());
        Positions moved = file.mesh.V;
        for (Eigen::Index k = 0; k < moved.size(); ++k)
        {
            moved.data()[k] += scale * std::sin(0.37 * static_cast<double>(k));
        }
        const auto out = dir / path.filename();
        write_mesh_file(out, file, moved);
        const auto back = read_mesh_file(out);
        ASSERT_EQ(back.mesh.V.rows(), file.mesh.V.rows());
        EXPECT_EQ(back.mesh.F, file.mesh.F);
        EXPECT_EQ(back.is_single_precision, file.is_single_precision);
        double worst = 0.0;
        for (Eigen::Index k = 0; k < moved.size(); ++k)
        {
            const double error = std::abs(back.mesh.V.data()[k] - moved.data()[k]);
            worst = std::max(worst, error / std::max(std::abs(moved.data()[k]), 1e-30));
        }
        // Float32 rounding (half an ulp, 2^-24 relative) plus, for text, the shortest decimal
        // of that float read back as a double (another half ulp at most).
        EXPECT_LE(worst, 0x1p-23);
        std::filesystem::remove(out);
    }
}

}  // namespace meshmark
