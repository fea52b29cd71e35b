// SPDX-License-Identifier: MIT
// Generic writers: write -> read round trips for every format and option.
#include <cstring>

#include <gtest/gtest.h>

#include "io_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{

namespace
{

// A tetrahedron with coordinates that need all 17 digits, plus one unreferenced vertex.
TriangleMesh awkward_tetrahedron()
{
    TriangleMesh mesh;
    mesh.V.resize(5, 3);
    mesh.V << 0.1, 1.0 / 3.0, -2.0 / 7.0,  //
        1e-7, 12345.678901234567, 0.0,     //
        -1.5, 2.0 / 3.0, 1e10 / 3.0,       //
        0.7, -0.2, 5e-320,                 //
        9.0, 9.0, 9.0;
    mesh.F.resize(4, 3);
    mesh.F << 0, 1, 2, 0, 3, 1, 1, 3, 2, 2, 3, 0;
    return mesh;
}

Positions as_float(const Positions& V)
{
    return V.cast<float>().cast<double>();
}

}  // namespace

TEST(WriteTest, ply_round_trips_in_every_encoding_and_precision)
{
    const auto dir = test::temp_dir("write_ply");
    const auto mesh = awkward_tetrahedron();
    for (const bool is_binary : {true, false})
    {
        for (const bool is_single : {false, true})
        {
            SCOPED_TRACE(std::string(is_binary ? "binary" : "ascii") +
                         (is_single ? " float" : " double"));
            const auto path = dir / "t.ply";
            write_mesh(path, mesh, {.is_binary = is_binary, .use_single_precision = is_single});
            const auto file = read_mesh_file(path);
            EXPECT_EQ(file.is_single_precision, is_single);
            EXPECT_EQ(file.mesh.V, is_single ? as_float(mesh.V) : mesh.V);
            EXPECT_EQ(file.mesh.F, mesh.F);
            const auto bytes = test::file_bytes(path);
            EXPECT_NE(
                bytes.find(is_binary ? "format binary_little_endian 1.0\n" : "format ascii 1.0\n"),
                std::string::npos);
        }
    }
}

TEST(WriteTest, ply_writes_vertex_colors)
{
    const auto dir = test::temp_dir("write_colors");
    const auto mesh = awkward_tetrahedron();
    const std::vector<std::array<std::uint8_t, 3>> colors{
        {255, 0, 1}, {2, 3, 4}, {5, 6, 7}, {8, 9, 10}, {11, 12, 13}};
    write_mesh(dir / "c.ply", mesh, {.vertex_colors = &colors});
    const auto bytes = test::file_bytes(dir / "c.ply");
    const auto body = bytes.find("end_header\n") + 11;
    EXPECT_NE(bytes.find("property uchar red\nproperty uchar green\nproperty uchar blue\n"),
              std::string::npos);
    // Record 1: 3 doubles, then its 3 color bytes.
    EXPECT_EQ(bytes.substr(body + 27 + 24, 3), std::string("\x02\x03\x04"));
    EXPECT_EQ(read_mesh(dir / "c.ply").V, mesh.V);
    write_mesh(dir / "a.ply", mesh, {.is_binary = false, .vertex_colors = &colors});
    EXPECT_NE(test::file_bytes(dir / "a.ply").find(" 255 0 1\n"), std::string::npos);
    EXPECT_EQ(read_mesh(dir / "a.ply").V, mesh.V);
    const std::vector<std::array<std::uint8_t, 3>> too_few(2);
    EXPECT_THROW(write_mesh(dir / "b.ply", mesh, {.vertex_colors = &too_few}), InvalidOption);
}

TEST(WriteTest, obj_and_off_round_trip_exactly)
{
    const auto dir = test::temp_dir("write_text");
    const auto mesh = awkward_tetrahedron();
    for (const std::string name : {"t.obj", "t.off"})
    {
        SCOPED_TRACE(name);
        write_mesh(dir / name, mesh);
        const auto back = read_mesh(dir / name);
        EXPECT_EQ(back.V, mesh.V);
        EXPECT_EQ(back.F, mesh.F);
        write_mesh(dir / name, mesh, {.use_single_precision = true});
        EXPECT_EQ(read_mesh(dir / name).V.cast<float>(), mesh.V.cast<float>());
    }
}

TEST(WriteTest, stl_round_trips_welded_in_binary_and_ascii)
{
    const auto dir = test::temp_dir("write_stl");
    const auto mesh = awkward_tetrahedron();
    for (const bool is_binary : {true, false})
    {
        SCOPED_TRACE(is_binary ? "binary" : "ascii");
        write_mesh(dir / "t.stl", mesh, {.is_binary = is_binary});
        const auto bytes = test::file_bytes(dir / "t.stl");
        EXPECT_EQ(bytes.substr(0, 5) == "solid", !is_binary);
        const auto back = read_mesh_file(dir / "t.stl");
        // The unreferenced vertex is gone; the others are numbered by first use, which here
        // is their original order.
        ASSERT_EQ(back.mesh.V.rows(), 4);
        EXPECT_EQ(back.mesh.F, mesh.F);
        const Positions expected = mesh.V.topRows(4);
        EXPECT_EQ(back.mesh.V, is_binary ? as_float(expected) : expected);
        EXPECT_EQ(back.is_single_precision, is_binary);
    }
}

TEST(WriteTest, binary_stl_normals_are_unit_and_outward)
{
    const auto dir = test::temp_dir("write_stl_normals");
    TriangleMesh mesh;
    mesh.V.resize(3, 3);
    mesh.V << 0, 0, 0, 2, 0, 0, 0, 2, 0;
    mesh.F.resize(1, 3);
    mesh.F << 0, 1, 2;
    write_mesh(dir / "n.stl", mesh);
    const auto bytes = test::file_bytes(dir / "n.stl");
    ASSERT_EQ(bytes.size(), 84U + 50U);
    std::array<float, 3> n{};
    std::memcpy(n.data(), bytes.data() + 84, 12);
    EXPECT_EQ(n[0], 0.0F);
    EXPECT_EQ(n[1], 0.0F);
    EXPECT_EQ(n[2], 1.0F);
}

TEST(WriteTest, rejects_invalid_meshes_and_unwritable_targets)
{
    const auto dir = test::temp_dir("write_bad");
    auto mesh = awkward_tetrahedron();
    write_mesh(dir / "blocker.ply", mesh);  // a file where a folder should be
    test::expect_error<IoError>([&] { write_mesh(dir / "blocker.ply" / "t.ply", mesh); },
                                {"t.ply", "blocker.ply"});
    std::filesystem::remove(dir / "blocker.ply");
    test::expect_error<IoError>([&] { write_mesh(dir / "t.xyz", mesh); }, {"t.xyz"});
    mesh.F(2, 1) = 5;
    test::expect_error<InvalidMesh>([&] { write_mesh(dir / "t.ply", mesh); }, {"face 2"});
    EXPECT_TRUE(std::filesystem::is_empty(dir));
}

}  // namespace meshmark
