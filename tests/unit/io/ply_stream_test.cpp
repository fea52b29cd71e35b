// SPDX-License-Identifier: MIT
// The PLY streaming API (meshmark/io/ply_stream.h) against read_mesh_file/write_mesh_file, and
// the preserving binary PLY writer across its 1 MiB slices.
#include "meshmark/io/ply_stream.h"

#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

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

// write_mesh_file's bytes read back as the moved positions (in the file's precision), and the
// displaced copy of the stream gives the same bytes.
void expect_preserving_writers_agree(const std::filesystem::path& input,
                                     const std::filesystem::path& dir, std::size_t window)
{
    const MeshFile file = read_mesh_file(input);
    const Positions moved = perturbed(file.mesh.V);
    const auto written = dir / "written.ply";
    write_mesh_file(written, file, moved);
    const MeshFile back = read_mesh_file(written);
    ASSERT_EQ(back.mesh.V.rows(), moved.rows());
    for (Eigen::Index i = 0; i < moved.rows(); ++i)
    {
        for (int d = 0; d < 3; ++d)
        {
            const double expected = file.is_single_precision
                                        ? static_cast<double>(static_cast<float>(moved(i, d)))
                                        : moved(i, d);
            ASSERT_EQ(back.mesh.V(i, d), expected) << input << " vertex " << i;
        }
    }
    EXPECT_TRUE(back.mesh.F == file.mesh.F);

    const PlyStream stream(input);
    ASSERT_EQ(stream.refusal(), "");
    EXPECT_EQ(stream.vertex_count(), static_cast<std::uint64_t>(file.mesh.V.rows()));
    const ReferencedVertices referenced = stream.scan_faces(window);
    EXPECT_EQ(referenced.triangles, static_cast<std::uint64_t>(file.mesh.F.rows()));
    // Displacements of the active rows, in row order.
    std::vector<double> displacement;
    for (std::uint64_t v = 0; v < stream.vertex_count(); ++v)
    {
        if (referenced.is_active(v))
        {
            for (int d = 0; d < 3; ++d)
            {
                const auto i = static_cast<Eigen::Index>(v);
                displacement.push_back(moved(i, d) - file.mesh.V(i, d));
            }
        }
    }
    // write_mesh_file of `displacement + V`, the positions the displaced copy writes.
    Positions marked = Positions::Zero(file.mesh.V.rows(), 3);
    std::size_t row = 0;
    for (Eigen::Index i = 0; i < marked.rows(); ++i)
    {
        if (referenced.is_active(static_cast<std::uint64_t>(i)))
        {
            marked.row(i) = Eigen::RowVector3d(displacement[3 * row], displacement[3 * row + 1],
                                               displacement[3 * row + 2]);
            ++row;
        }
    }
    marked += file.mesh.V;
    write_mesh_file(written, file, marked);
    std::ostringstream out;
    PlyDisplacedCopy copy(stream, referenced, dir / "copy.ply", out, window);
    for (std::size_t begin = 0; begin < referenced.active; begin += 1000)
    {
        const auto rows = std::min<std::size_t>(1000, referenced.active - begin);
        copy.add(rows, displacement.data() + 3 * begin);
    }
    copy.finish();
    EXPECT_TRUE(out.str() == file_bytes(written)) << input;

    // Sequential readers from any vertex, all rows and active rows alike.
    PlyVertexReader reader(stream, 3, window);
    std::vector<double> xyz(6);
    reader.read(2, xyz.data());
    EXPECT_EQ(reader.vertex(), 5U);
    EXPECT_EQ(xyz[3], file.mesh.V(4, 0));
    const auto p = stream.position(7);
    EXPECT_EQ(p[2], file.mesh.V(7, 2));
}

}  // namespace

TEST(PlyStreamTest, preserving_writers_agree_across_slices_and_windows)
{
    const auto dir = test::temp_dir("ply_stream");
    // Float32 and float64 positions; 2562 and 40962 vertices (the latter spans several 1 MiB
    // slices as float64: 40962 x 24 bytes).
    for (const int level : {4, 6})
    {
        for (const bool single : {true, false})
        {
            WriteOptions options;
            options.use_single_precision = single;
            const auto input =
                dir / ("input-" + std::to_string(level) + (single ? "f" : "d") + ".ply");
            write_mesh(input, lumpy_ellipsoid(level), options);
            expect_preserving_writers_agree(input, dir, level == 4 ? 4096 : 1U << 20U);
        }
    }
}

TEST(PlyStreamTest, agrees_on_shared_binary_ply_with_extra_properties)
{
    const auto horse = test::mesh_dir() / "horse.ply";  // binary, x y z nx ny nz
    if (!std::filesystem::exists(horse))
    {
        GTEST_SKIP() << "shared meshes not available";
    }
    expect_preserving_writers_agree(horse, test::temp_dir("ply_stream_horse"), 1U << 16U);
}

TEST(PlyStreamTest, refusals_counts_and_errors)
{
    const auto dir = test::temp_dir("ply_stream_refusals");
    const TriangleMesh mesh = lumpy_ellipsoid(2);
    const auto ascii = dir / "ascii.ply";
    WriteOptions text;
    text.is_binary = false;
    write_mesh(ascii, mesh, text);
    const PlyStream stream(ascii);
    EXPECT_NE(stream.refusal().find("ASCII"), std::string::npos);
    EXPECT_EQ(stream.vertex_count(), static_cast<std::uint64_t>(mesh.V.rows()));
    EXPECT_EQ(stream.face_records(), static_cast<std::uint64_t>(mesh.F.rows()));
    EXPECT_EQ(stream.read_memory_bytes(),
              stream.file_size() + 24 * stream.vertex_count() + 12 * stream.face_records());
    EXPECT_THROW(PlyStream(dir / "missing.ply"), IoError);

    // Truncated vertex records: an IoError when asked whether it streams.
    const auto binary = dir / "binary.ply";
    write_mesh(binary, mesh);
    std::string bytes = file_bytes(binary);
    const auto header_end = bytes.find("end_header\n") + 11;
    bytes.resize(header_end + 10);
    std::ofstream(dir / "cut.ply", std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    const PlyStream cut(dir / "cut.ply");
    EXPECT_THROW((void)cut.refusal(), IoError);
}

TEST(PlyStreamTest, preserving_writer_checks_values)
{
    const auto dir = test::temp_dir("ply_stream_values");
    const auto ply = dir / "input.ply";
    write_mesh(ply, lumpy_ellipsoid(2));
    const MeshFile binary = read_mesh_file(ply);
    Positions bad = binary.mesh.V;
    bad(3, 1) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(write_mesh_file(dir / "out.ply", binary, bad), InvalidMesh);
    EXPECT_FALSE(std::filesystem::exists(dir / "out.ply"));
}

}  // namespace meshmark
