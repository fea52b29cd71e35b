// SPDX-License-Identifier: MIT
// mesh_file_bytes: in the source's format, the bytes write_mesh_file writes beside the source
// (mtllib lines and image URIs as written); in another format, write_mesh's bytes.
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gltf_test_support.h"
#include "io_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::GltfBuilder;
using test::Json;

// Moves every coordinate by a small, vertex-dependent amount.
Positions perturbed(const Positions& V)
{
    Positions result = V;
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        for (Eigen::Index d = 0; d < 3; ++d)
        {
            result(i, d) += 1e-3 * static_cast<double>(1 + ((7 * i + 3 * d) % 11));
        }
    }
    return result;
}

// The cube of the fixtures as a glTF asset: 8 float positions, 12 triangles, a material.
GltfBuilder cube_gltf()
{
    GltfBuilder b;
    std::vector<float> xyz;
    for (const auto& row : test::cube_positions(1.0))
    {
        for (const double v : row)
        {
            xyz.push_back(static_cast<float>(v));
        }
    }
    std::vector<std::uint16_t> idx;
    for (const auto& t : test::cube_triangles())
    {
        for (const auto v : t)
        {
            idx.push_back(static_cast<std::uint16_t>(v));
        }
    }
    const int positions = b.positions(xyz);
    const int indices = b.indices(idx);
    b.mesh(Json::array(
        {{{"attributes", {{"POSITION", positions}}}, {"indices", indices}, {"material", 0}}}));
    b.node({{"mesh", 0}, {"translation", {1.0, 2.0, 3.0}}});
    return b;
}

class BytesTest : public ::testing::Test
{
protected:
    fs::path dir = test::temp_dir("bytes_test");

    // \p name copied from tests/data into dir.
    fs::path copied(const std::string& name) const
    {
        const fs::path to = dir / name;
        fs::copy_file(test::fixture(name), to, fs::copy_options::overwrite_existing);
        return to;
    }

    // mesh_file_bytes of moved positions in the source's format equals the file write_mesh_file
    // writes beside the source, and differs from the source (the positions did move).
    void expect_same_as_file_beside(const fs::path& path) const
    {
        SCOPED_TRACE(path.filename().string());
        const MeshFile source = read_mesh_file(path);
        const Positions moved = perturbed(source.mesh.V);
        const std::string bytes = mesh_file_bytes(source, moved, source.format);
        const fs::path copy = path.parent_path() / ("copy" + path.extension().string());
        write_mesh_file(copy, source, moved);
        EXPECT_EQ(bytes, test::file_bytes(copy));
        EXPECT_NE(bytes, test::file_bytes(path));
        // Unchanged positions give the source back.
        EXPECT_EQ(mesh_file_bytes(source, source.mesh.V, source.format), test::file_bytes(path));
    }

    // In another format: write_mesh's bytes of the moved positions and the triangles.
    void expect_same_as_generic(const fs::path& path, MeshFormat format, const std::string& ext,
                                const WriteOptions& options = {}) const
    {
        SCOPED_TRACE(path.filename().string() + " as " + ext);
        const MeshFile source = read_mesh_file(path);
        const Positions moved = perturbed(source.mesh.V);
        TriangleMesh mesh;
        mesh.V = moved;
        mesh.F = source.mesh.F;
        const fs::path generic = dir / ("generic" + ext);
        write_mesh(generic, mesh, options);
        EXPECT_EQ(mesh_file_bytes(source, moved, format, options), test::file_bytes(generic));
    }
};

TEST_F(BytesTest, text_and_binary_fixtures_give_the_file_written_beside_them)
{
    for (const char* name : {"cube_ascii.ply", "cube_binary_le.ply", "cube_binary_be.ply",
                             "cube_normals_extra_props.ply", "tristrip.ply", "quad_faces.obj",
                             "obj_artist_statements.obj", "cube.off", "cube_ascii.stl",
                             "cube_binary.stl", "cube_binary_solid_header.stl"})
    {
        expect_same_as_file_beside(copied(name));
    }
}

TEST_F(BytesTest, other_formats_give_write_mesh_bytes)
{
    expect_same_as_generic(copied("cube_binary_le.ply"), MeshFormat::Obj, ".obj");
    expect_same_as_generic(copied("cube.off"), MeshFormat::Ply, ".ply", {.is_binary = false});
    expect_same_as_generic(copied("cube_ascii.stl"), MeshFormat::Glb, ".glb");
    expect_same_as_generic(copied("quad_faces.obj"), MeshFormat::Stl, ".stl");
    expect_same_as_generic(copied("cube_ascii.ply"), MeshFormat::ThreeMf, ".3mf");
    expect_same_as_generic(copied("cube_binary.stl"), MeshFormat::Gltf, ".gltf");
    expect_same_as_generic(copied("cube_ascii.ply"), MeshFormat::Off, ".off",
                           {.use_single_precision = true});
}

TEST_F(BytesTest, obj_material_libraries_stay_as_written)
{
    const std::string text =
        "mtllib scene.mtl\n" + test::file_bytes(test::fixture("quad_faces.obj"));
    fs::create_directories(dir / "src");
    test::put_bytes(dir / "src" / "scene.obj", text);
    test::put_bytes(dir / "src" / "scene.mtl", "newmtl red\nKd 1 0 0\n");
    expect_same_as_file_beside(dir / "src" / "scene.obj");

    const MeshFile source = read_mesh_file(dir / "src" / "scene.obj");
    const std::string bytes = mesh_file_bytes(source, perturbed(source.mesh.V), MeshFormat::Obj);
    EXPECT_EQ(bytes.rfind("mtllib scene.mtl\n", 0), 0U);
    // Written into another folder, the library would be relinked: not so the bytes.
    fs::create_directories(dir / "out");
    write_mesh_file(dir / "out" / "marked.obj", source, perturbed(source.mesh.V));
    EXPECT_EQ(test::file_bytes(dir / "out" / "marked.obj").rfind("mtllib ../src/scene.mtl\n", 0),
              0U);
}

TEST_F(BytesTest, glb_and_data_uri_gltf_give_the_file_written_beside_them)
{
    GltfBuilder b = cube_gltf();
    b.doc["images"] = Json::array({{{"uri", "tex/wood.png"}}, {{"uri", "../shared.png"}}});
    fs::create_directories(dir / "src" / "tex");
    test::put_bytes(dir / "src" / "tex" / "wood.png", "W");
    test::put_bytes(dir / "shared.png", "S");
    test::put_bytes(dir / "src" / "cube.glb", b.glb());
    test::put_bytes(dir / "src" / "cube.gltf", b.gltf());
    expect_same_as_file_beside(dir / "src" / "cube.glb");
    expect_same_as_file_beside(dir / "src" / "cube.gltf");

    // Image URIs as written; nothing copied anywhere.
    const MeshFile source = read_mesh_file(dir / "src" / "cube.gltf");
    const std::string bytes = mesh_file_bytes(source, perturbed(source.mesh.V), MeshFormat::Gltf);
    EXPECT_EQ(Json::parse(bytes)["images"], b.doc["images"]);
    // A GLB asked of the .gltf is the generic asset (positions and triangles).
    expect_same_as_generic(dir / "src" / "cube.gltf", MeshFormat::Glb, ".glb");
    expect_same_as_generic(dir / "src" / "cube.glb", MeshFormat::Ply, ".ply");
}

TEST_F(BytesTest, three_mf_gives_the_file_written_beside_it)
{
    TriangleMesh mesh = read_mesh(test::fixture("cube_ascii.ply"));
    write_mesh(dir / "cube.3mf", mesh);
    expect_same_as_file_beside(dir / "cube.3mf");
    expect_same_as_generic(dir / "cube.3mf", MeshFormat::Stl, ".stl", {.is_binary = false});
}

TEST_F(BytesTest, gltf_with_external_buffers_is_refused_in_its_own_format_only)
{
    const GltfBuilder b = cube_gltf();
    test::put_bytes(dir / "scene.gltf", b.gltf("scene.bin"));
    test::put_bytes(dir / "scene.bin", b.bin);
    const MeshFile source = read_mesh_file(dir / "scene.gltf");
    const Positions moved = perturbed(source.mesh.V);
    test::expect_error<IoError>([&] { (void)mesh_file_bytes(source, moved, MeshFormat::Gltf); },
                                {(dir / "scene.gltf").string(), "external buffers",
                                 "cannot be returned as one .gltf file", "another format"});
    // Converted, it is one file.
    expect_same_as_generic(dir / "scene.gltf", MeshFormat::Glb, ".glb");
}

TEST_F(BytesTest, rejects_a_row_count_mismatch_and_non_finite_positions)
{
    const MeshFile source = read_mesh_file(copied("cube_binary_le.ply"));
    const Positions fewer = source.mesh.V.topRows(source.mesh.V.rows() - 1);
    test::expect_error<InvalidOption>([&]
                                      { (void)mesh_file_bytes(source, fewer, MeshFormat::Ply); },
                                      {"mesh_file_bytes", "7 rows", "8 vertices"});
    EXPECT_THROW((void)mesh_file_bytes(source, fewer, MeshFormat::Obj), InvalidOption);

    Positions bad = source.mesh.V;
    bad(3, 1) = std::numeric_limits<double>::quiet_NaN();
    test::expect_error<InvalidMesh>([&] { (void)mesh_file_bytes(source, bad, MeshFormat::Ply); },
                                    {"cube_binary_le.ply", "vertex 3"});
    EXPECT_THROW((void)mesh_file_bytes(source, bad, MeshFormat::Stl), InvalidMesh);
}

}  // namespace
}  // namespace meshmark
