// SPDX-License-Identifier: MIT
#include "pipeline/streamed_write.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark {
namespace {

std::string file_bytes(const std::filesystem::path& path)
{
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Moves every second vertex by a small amount; the others keep their bits.
Positions perturbed(const Positions& V)
{
    Positions out = V;
    for (Eigen::Index i = 0; i < out.rows(); i += 2)
    {
        out.row(i) += Eigen::RowVector3d(1e-3, -2e-3, 0.5e-3) * static_cast<double>(1 + i % 7);
    }
    return out;
}

void expect_same_bytes_as_write_mesh_file(const std::filesystem::path& input, const std::filesystem::path& dir)
{
    const MeshFile file = read_mesh_file(input);
    const Positions moved = perturbed(file.mesh.V);
    const auto reference = dir / "reference.ply";
    const auto streamed = dir / "streamed.ply";
    write_mesh_file(reference, file, moved);
    ASSERT_TRUE(detail::write_binary_ply_streamed(streamed, file, moved));
    const std::string expected = file_bytes(reference);
    EXPECT_GT(expected.size(), 0U);
    EXPECT_TRUE(expected == file_bytes(streamed)) << input;
    EXPECT_FALSE(expected == file_bytes(input)) << "the positions should have changed";
}

}  // namespace

TEST(StreamedWriteTest, matches_the_preserving_writer_byte_for_byte)
{
    const auto dir = test::temp_dir("streamed_write");
    // Float32 and float64 positions; 2562 and 40962 vertices (the latter spans several 1 MiB
    // slices as float64: 40962 x 24 bytes).
    for (const int level : {4, 6})
    {
        for (const bool single : {true, false})
        {
            WriteOptions options;
            options.use_single_precision = single;
            const auto input = dir / ("input-" + std::to_string(level) + (single ? "f" : "d") + ".ply");
            write_mesh(input, lumpy_ellipsoid(level), options);
            expect_same_bytes_as_write_mesh_file(input, dir);
        }
    }
}

TEST(StreamedWriteTest, matches_on_shared_binary_ply_with_extra_properties)
{
    const auto horse = test::mesh_dir() / "horse.ply";  // binary, x y z nx ny nz
    if (!std::filesystem::exists(horse))
    {
        GTEST_SKIP() << "shared meshes not available";
    }
    expect_same_bytes_as_write_mesh_file(horse, test::temp_dir("streamed_write_horse"));
}

TEST(StreamedWriteTest, declines_other_formats_and_checks_values)
{
    const auto dir = test::temp_dir("streamed_write_other");
    const auto obj = dir / "input.obj";
    write_mesh(obj, lumpy_ellipsoid(2));
    const MeshFile text = read_mesh_file(obj);
    EXPECT_FALSE(detail::write_binary_ply_streamed(dir / "out.obj", text, text.mesh.V));
    EXPECT_FALSE(std::filesystem::exists(dir / "out.obj"));

    const auto ply = dir / "input.ply";
    write_mesh(ply, lumpy_ellipsoid(2));
    const MeshFile binary = read_mesh_file(ply);
    EXPECT_FALSE(detail::write_binary_ply_streamed(dir / "out.obj", binary, binary.mesh.V));
    Positions bad = binary.mesh.V;
    bad(3, 1) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW((void)detail::write_binary_ply_streamed(dir / "out.ply", binary, bad), InvalidMesh);
    EXPECT_FALSE(std::filesystem::exists(dir / "out.ply"));
}

}  // namespace meshmark
