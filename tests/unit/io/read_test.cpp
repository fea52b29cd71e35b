// SPDX-License-Identifier: MIT
// Reading the tiny fixtures of tests/data: exact counts, positions and triangles per feature.
#include <algorithm>
#include <array>
#include <cstring>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "io_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{

using test::cube_positions;
using test::cube_triangles;
using test::fixture;

namespace
{
const double kFloatTop = static_cast<double>(1.1F);  // 1.1 as stored in float32
}  // namespace

TEST(IoTest, format_from_extension_is_case_insensitive)
{
    EXPECT_EQ(format_from_extension("a/b.PLY"), MeshFormat::Ply);
    EXPECT_EQ(format_from_extension("b.Obj"), MeshFormat::Obj);
    EXPECT_EQ(format_from_extension("b.off"), MeshFormat::Off);
    EXPECT_EQ(format_from_extension("b.sTl"), MeshFormat::Stl);
    EXPECT_STREQ(to_string(MeshFormat::Stl), "STL");
}

TEST(IoTest, rejects_unknown_extension_naming_the_file)
{
    test::expect_error<IoError>([] { static_cast<void>(format_from_extension("mesh.xyz")); },
                                {"mesh.xyz", "'.xyz'"});
    test::expect_error<IoError>([] { static_cast<void>(read_mesh("no_extension")); },
                                {"no_extension", "extension"});
}

TEST(IoTest, reads_ascii_ply)
{
    const auto file = read_mesh_file(fixture("cube_ascii.ply"));
    EXPECT_EQ(file.format, MeshFormat::Ply);
    EXPECT_TRUE(file.is_single_precision);
    // Typed ASCII: a float property reads as the float it denotes.
    test::expect_cube(file.mesh, kFloatTop);
}

TEST(IoTest, reads_binary_ply_in_both_byte_orders)
{
    for (const char* name : {"cube_binary_le.ply", "cube_binary_be.ply"})
    {
        SCOPED_TRACE(name);
        const auto file = read_mesh_file(fixture(name));
        EXPECT_TRUE(file.is_single_precision);
        test::expect_cube(file.mesh, kFloatTop);
    }
}

TEST(IoTest, skips_extra_properties_and_elements_by_declared_type)
{
    // double x/y/z split by other properties, a list in the vertex element, an extra
    // element with lists, and face properties around the index list.
    const auto file = read_mesh_file(fixture("cube_normals_extra_props.ply"));
    EXPECT_FALSE(file.is_single_precision);
    test::expect_cube(file.mesh, 1.1);
}

TEST(IoTest, decodes_triangle_strips_with_restart_and_degenerates)
{
    // Strip 0 1 2 3 -1 4 5 6 7 7 8 9: odd triangles flipped, parity kept across the
    // skipped degenerate triangles (6,7,7) and (7,7,8).
    const auto mesh = read_mesh(fixture("tristrip.ply"));
    EXPECT_EQ(mesh.V.rows(), 10);
    test::expect_triangles(mesh, {{0, 1, 2}, {2, 1, 3}, {4, 5, 6}, {6, 5, 7}, {7, 8, 9}});
}

TEST(IoTest, fan_triangulates_convex_obj_polygons_and_fills_the_others_inside)
{
    // The quads are convex: fans from their first corner. The pentagon (3 4 8 9 7) is not: seen
    // along its normal, corner 9 lies inside the square of the other four, and the fan from
    // corner 3 would hold a triangle with no area there; it is filled from corner 9 instead.
    const auto mesh = read_mesh(fixture("quad_faces.obj"));
    ASSERT_EQ(mesh.V.rows(), 9);
    EXPECT_EQ(mesh.V(8, 1), 1.5);
    ASSERT_EQ(mesh.F.rows(), 13);
    TriangleMesh quads = mesh;
    quads.F.conservativeResize(10, 3);
    test::expect_triangles(quads, {{0, 3, 2},
                                   {0, 2, 1},
                                   {4, 5, 6},
                                   {4, 6, 7},
                                   {0, 1, 5},
                                   {0, 5, 4},
                                   {0, 4, 7},
                                   {0, 7, 3},
                                   {1, 2, 6},
                                   {1, 6, 5}});
    // The pentagon: three triangles on its corners, none flipped against its normal, which
    // together make its vector area. (Seen along the normal, 9 is near the diagonal 3-7 of a
    // square: which triangles the triangulation picks there is a tie, not pinned here.)
    // Twice its vector area: the same for every surface the outline bounds.
    const std::array<int, 5> outline = {2, 3, 7, 8, 6};
    Eigen::RowVector3d newell = Eigen::RowVector3d::Zero();
    for (std::size_t k = 0; k < outline.size(); ++k)
    {
        newell += mesh.V.row(outline[k]).cross(mesh.V.row(outline[(k + 1) % outline.size()]));
    }
    Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
    for (Eigen::Index f = 10; f < 13; ++f)
    {
        for (Eigen::Index c = 0; c < 3; ++c)
        {
            EXPECT_TRUE(mesh.F(f, c) == 2 || mesh.F(f, c) == 3 || mesh.F(f, c) == 6 ||
                        mesh.F(f, c) == 7 || mesh.F(f, c) == 8);
        }
        const Eigen::RowVector3d a = mesh.V.row(mesh.F(f, 0));
        const Eigen::RowVector3d n =
            (mesh.V.row(mesh.F(f, 1)) - a).cross(mesh.V.row(mesh.F(f, 2)) - a);
        EXPECT_GE(n.dot(newell), -1e-12) << "triangle " << f;
        sum += n;
    }
    EXPECT_LT((sum - newell).norm(), 1e-12);
}

TEST(IoTest, reads_every_obj_index_form)
{
    // v, v/vt, v//vn, v/vt/vn and negative indices; groups, materials and an `l` line.
    const auto file = read_mesh_file(fixture("obj_index_forms.obj"));
    EXPECT_EQ(file.format, MeshFormat::Obj);
    EXPECT_TRUE(file.is_single_precision);
    test::expect_positions(file.mesh, {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 1}});
    test::expect_triangles(file.mesh, {{0, 1, 2}, {0, 2, 3}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}});
}

TEST(IoTest, reads_off_with_comments_and_polygons)
{
    const auto file = read_mesh_file(fixture("cube.off"));
    EXPECT_EQ(file.format, MeshFormat::Off);
    test::expect_cube(file.mesh, 1.1);
}

TEST(IoTest, reads_ascii_stl_and_welds_corners)
{
    const auto file = read_mesh_file(fixture("cube_ascii.stl"));
    EXPECT_EQ(file.format, MeshFormat::Stl);
    EXPECT_TRUE(file.is_single_precision);
    // 36 corners weld into the 8 cube vertices, numbered by first use.
    ASSERT_EQ(file.mesh.V.rows(), 8);
    ASSERT_EQ(file.mesh.F.rows(), 12);
    const auto expected = cube_positions(1.1);
    const auto triangles = cube_triangles();
    for (Eigen::Index f = 0; f < 12; ++f)
    {
        for (Eigen::Index c = 0; c < 3; ++c)
        {
            const auto& corner = expected[static_cast<std::size_t>(
                triangles[static_cast<std::size_t>(f)][static_cast<std::size_t>(c)])];
            for (Eigen::Index d = 0; d < 3; ++d)
            {
                EXPECT_EQ(file.mesh.V(file.mesh.F(f, c), d), corner[static_cast<std::size_t>(d)]);
            }
        }
    }
}

TEST(IoTest, reads_binary_stl_and_welds_corners)
{
    const auto file = read_mesh_file(fixture("cube_binary.stl"));
    EXPECT_TRUE(file.is_single_precision);
    ASSERT_EQ(file.mesh.V.rows(), 8);
    ASSERT_EQ(file.mesh.F.rows(), 12);
    // Corners of the first facet (0, 3, 2) are the first three vertices.
    test::expect_triangles(file.mesh, {{0, 1, 2},
                                       {0, 2, 3},
                                       {4, 5, 6},
                                       {4, 6, 7},
                                       {0, 3, 5},
                                       {0, 5, 4},
                                       {2, 1, 7},
                                       {2, 7, 6},
                                       {0, 4, 7},
                                       {0, 7, 1},
                                       {3, 2, 6},
                                       {3, 6, 5}});
    EXPECT_EQ(file.mesh.V(6, 2), kFloatTop);
}

TEST(IoTest, reads_binary_stl_whose_header_starts_with_solid)
{
    const auto plain = read_mesh(fixture("cube_binary.stl"));
    const auto solid = read_mesh(fixture("cube_binary_solid_header.stl"));
    EXPECT_EQ(test::file_bytes(fixture("cube_binary_solid_header.stl")).substr(0, 5), "solid");
    EXPECT_EQ(solid.V, plain.V);
    EXPECT_EQ(solid.F, plain.F);
}

TEST(IoTest, keeps_unreferenced_vertices)
{
    const auto dir = test::temp_dir("io_unreferenced");
    test::put_bytes(dir / "u.obj", "v 0 0 0\nv 9 9 9\nv 1 0 0\nv 0 1 0\nf 1 3 4\n");
    const auto mesh = read_mesh(dir / "u.obj");
    EXPECT_EQ(mesh.V.rows(), 4);
    EXPECT_EQ(mesh.V(1, 0), 9.0);
    test::expect_triangles(mesh, {{0, 2, 3}});
}

TEST(IoTest, reads_point_cloud_ply_without_faces)
{
    const auto dir = test::temp_dir("io_points");
    test::put_bytes(dir / "p.ply",
                    "ply\r\nformat ascii 1.0\r\nelement vertex 2\r\nproperty double x\r\n"
                    "property double y\r\nproperty double z\r\nend_header\r\n"
                    "0.1 +2 -3e-2\r\n4 5 6\r\n");
    const auto file = read_mesh_file(dir / "p.ply");
    EXPECT_FALSE(file.is_single_precision);
    test::expect_positions(file.mesh, {{0.1, 2, -3e-2}, {4, 5, 6}});
    EXPECT_TRUE(file.mesh.is_point_cloud());
}

namespace
{

// A binary PLY of one triangle in the given byte order: float positions, `list uchar int`.
std::string one_triangle_ply(bool is_big_endian, std::int32_t last_index)
{
    std::string bytes = std::string("ply\nformat ") +
                        (is_big_endian ? "binary_big_endian" : "binary_little_endian") +
                        " 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                        "property float z\nelement face 1\n"
                        "property list uchar int vertex_indices\nend_header\n";
    const auto append = [&bytes, is_big_endian](const void* value)
    {
        std::array<char, 4> raw{};
        std::memcpy(raw.data(), value, 4);
        if (is_big_endian)
        {
            std::reverse(raw.begin(), raw.end());
        }
        bytes.append(raw.data(), 4);
    };
    for (int i = 0; i < 9; ++i)
    {
        const float value = 0.5F * static_cast<float>(i);
        append(&value);
    }
    bytes += '\x03';
    for (const std::int32_t index : {2, 0, last_index})
    {
        append(&index);
    }
    return bytes;
}

}  // namespace

TEST(IoTest, reads_binary_triangles_in_both_byte_orders)
{
    const auto dir = test::temp_dir("io_fast_faces");
    for (const bool is_big_endian : {false, true})
    {
        SCOPED_TRACE(is_big_endian ? "big-endian" : "little-endian");
        test::put_bytes(dir / "t.ply", one_triangle_ply(is_big_endian, 1));
        const auto mesh = read_mesh(dir / "t.ply");
        test::expect_positions(mesh, {{0, 0.5, 1}, {1.5, 2, 2.5}, {3, 3.5, 4}});
        test::expect_triangles(mesh, {{2, 0, 1}});
        test::put_bytes(dir / "bad.ply", one_triangle_ply(is_big_endian, -1));
        test::expect_error<InvalidMesh>([&] { static_cast<void>(read_mesh(dir / "bad.ply")); },
                                        {"bad.ply", "face 0", "vertex index -1", "0..2"});
    }
}

TEST(IoTest, reads_ascii_stl_with_several_solids)
{
    const auto dir = test::temp_dir("io_solids");
    const std::string facet =
        "facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 0 1 0\n"
        " endloop\nendfacet\n";
    test::put_bytes(dir / "s.stl",
                    "solid a\n" + facet + "endsolid a\nSOLID b\n" + facet + "ENDSOLID b\n");
    const auto mesh = read_mesh(dir / "s.stl");
    EXPECT_EQ(mesh.V.rows(), 3);
    test::expect_triangles(mesh, {{0, 1, 2}, {0, 1, 2}});
}

TEST(IoTest, reads_off_counts_on_the_keyword_line)
{
    const auto dir = test::temp_dir("io_off_counts");
    test::put_bytes(dir / "c.off",
                    "COFF 3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n"
                    "0 1 0 0 0 255 255\n3 0 1 2\n");
    const auto mesh = read_mesh(dir / "c.off");
    test::expect_positions(mesh, {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
    test::expect_triangles(mesh, {{0, 1, 2}});
}

}  // namespace meshmark
