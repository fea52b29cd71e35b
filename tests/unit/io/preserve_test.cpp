// SPDX-License-Identifier: MIT
// The preserving writer: unchanged positions give the same bytes; changed positions keep the
// file's precision and leave every other byte or token as it was.
#include <charconv>
#include <cmath>
#include <cstring>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "io_test_support.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{

using test::fixture;

namespace
{

const std::vector<std::string> kValidFixtures{
    "cube_ascii.ply", "cube_binary_le.ply", "cube_binary_be.ply",  "cube_normals_extra_props.ply",
    "tristrip.ply",   "quad_faces.obj",     "obj_index_forms.obj", "obj_artist_statements.obj",
    "cube.off",       "cube_ascii.stl",     "cube_binary.stl",     "cube_binary_solid_header.stl"};

// Moves every coordinate by a small, vertex-dependent amount.
Positions perturbed(const Positions& V)
{
    Positions result = V;
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        for (Eigen::Index d = 0; d < 3; ++d)
        {
            result(i, d) += 1e-3 * static_cast<double>(1 + ((7 * i + 3 * d) % 11)) + 1.0 / 3.0;
        }
    }
    return result;
}

double as_float(double v)
{
    return static_cast<double>(static_cast<float>(v));
}

bool is_number(const std::string& token)
{
    double value = 0.0;
    const auto r = std::from_chars(token.data(), token.data() + token.size(), value);
    return r.ec == std::errc() && r.ptr == token.data() + token.size();
}

// Number of tokens that differ between two texts of the same line/token structure; fails
// if the structure differs or a differing token is not a number on both sides.
std::size_t changed_number_tokens(const std::string& before, const std::string& after)
{
    const auto a = test::line_tokens(before);
    const auto b = test::line_tokens(after);
    EXPECT_EQ(a.size(), b.size());
    std::size_t changed = 0;
    for (std::size_t l = 0; l < std::min(a.size(), b.size()); ++l)
    {
        EXPECT_EQ(a[l].size(), b[l].size()) << "line " << l + 1;
        for (std::size_t t = 0; t < std::min(a[l].size(), b[l].size()); ++t)
        {
            if (a[l][t] != b[l][t])
            {
                EXPECT_TRUE(is_number(a[l][t]) && is_number(b[l][t]))
                    << "line " << l + 1 << ": '" << a[l][t] << "' -> '" << b[l][t] << "'";
                ++changed;
            }
        }
    }
    return changed;
}

float float_at(const std::string& bytes, std::size_t offset)
{
    float value = 0.0F;
    std::memcpy(&value, bytes.data() + offset, 4);
    return value;
}

}  // namespace

TEST(PreserveTest, unchanged_positions_reproduce_every_fixture_byte_for_byte)
{
    const auto dir = test::temp_dir("preserve_same");
    for (const auto& name : kValidFixtures)
    {
        SCOPED_TRACE(name);
        const auto file = read_mesh_file(fixture(name));
        write_mesh_file(dir / name, file, file.mesh.V);
        EXPECT_EQ(test::file_bytes(dir / name), test::file_bytes(fixture(name)));
    }
}

TEST(PreserveTest, changed_binary_ply_positions_keep_type_and_every_other_byte)
{
    const auto dir = test::temp_dir("preserve_binary");
    for (const std::string name :
         {"cube_binary_le.ply", "cube_binary_be.ply", "cube_normals_extra_props.ply"})
    {
        SCOPED_TRACE(name);
        const auto original = read_mesh_file(fixture(name));
        const auto moved = perturbed(original.mesh.V);
        write_mesh_file(dir / name, original, moved);
        const auto changed = read_mesh_file(dir / name);
        EXPECT_EQ(changed.mesh.F, original.mesh.F);
        for (Eigen::Index k = 0; k < moved.size(); ++k)
        {
            const double expected =
                original.is_single_precision ? as_float(moved.data()[k]) : moved.data()[k];
            EXPECT_EQ(changed.mesh.V.data()[k], expected) << "coordinate " << k;
        }
        // Restoring the positions restores the file exactly: nothing else was touched.
        write_mesh_file(dir / ("restored_" + name), changed, original.mesh.V);
        EXPECT_EQ(test::file_bytes(dir / ("restored_" + name)), test::file_bytes(fixture(name)));
    }
}

TEST(PreserveTest, changed_ascii_ply_tokens_use_the_declared_type)
{
    const auto dir = test::temp_dir("preserve_ascii_ply");
    const auto original = read_mesh_file(fixture("cube_ascii.ply"));
    Positions moved = original.mesh.V;
    moved(6, 2) = 1.0 / 3.0;  // float property: shortest float digits
    moved(0, 0) = 0.1;
    write_mesh_file(dir / "c.ply", original, moved);
    auto expected = test::file_bytes(fixture("cube_ascii.ply"));
    expected.replace(expected.find("1 1 1.1"), 7, "1 1 0.33333334");
    expected.replace(expected.find("end_header\n0 0 0") + 11, 5, "0.1 0 0");
    EXPECT_EQ(test::file_bytes(dir / "c.ply"), expected);
    EXPECT_EQ(read_mesh(dir / "c.ply").V(6, 2), as_float(1.0 / 3.0));

    // A double property keeps double digits.
    test::put_bytes(dir / "d.ply",
                    "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\n"
                    "property double y\nproperty int z\nend_header\n1 2 3\n");
    const auto typed = read_mesh_file(dir / "d.ply");
    Positions p(1, 3);
    p << 1.0 / 3.0, 2.0, 4.6;  // int property: rounded
    write_mesh_file(dir / "d2.ply", typed, p);
    const auto text = test::file_bytes(dir / "d2.ply");
    EXPECT_EQ(text.substr(text.find("end_header\n") + 11), "0.3333333333333333 2 5\n");
}

TEST(PreserveTest, changed_obj_and_off_tokens_follow_the_significant_digit_rule)
{
    const auto dir = test::temp_dir("preserve_digits");
    // <= 9 significant digits: rewritten as shortest float32 digits; more: float64 digits.
    // Unchanged tokens keep their text, however they were written.
    const std::string obj = "v 0.5 0.12345678901234567 2.000000 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    test::put_bytes(dir / "a.obj", obj);
    const auto file = read_mesh_file(dir / "a.obj");
    EXPECT_FALSE(file.is_single_precision);
    Positions moved = file.mesh.V;
    moved(0, 0) = 1.0 / 3.0;
    moved(0, 1) = 1.0 / 3.0;
    write_mesh_file(dir / "b.obj", file, moved);
    EXPECT_EQ(test::file_bytes(dir / "b.obj"),
              "v 0.33333334 0.3333333333333333 2.000000 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");

    test::put_bytes(dir / "a.off",
                    "OFF\n3 1 0\n0.5 0.12345678901234567 2.000000\n1 0 0\n0 1 0\n"
                    "3 0 1 2\n");
    const auto off = read_mesh_file(dir / "a.off");
    write_mesh_file(dir / "b.off", off, moved);
    EXPECT_EQ(test::file_bytes(dir / "b.off"),
              "OFF\n3 1 0\n0.33333334 0.3333333333333333 2.000000\n1 0 0\n0 1 0\n3 0 1 2\n");
}

TEST(PreserveTest, perturbed_text_files_change_only_position_tokens)
{
    const auto dir = test::temp_dir("preserve_tokens");
    for (const std::string name :
         {"cube_ascii.ply", "tristrip.ply", "quad_faces.obj", "obj_index_forms.obj", "cube.off"})
    {
        SCOPED_TRACE(name);
        const auto original = read_mesh_file(fixture(name));
        const auto moved = perturbed(original.mesh.V);
        write_mesh_file(dir / name, original, moved);
        // Every coordinate's text changes, and nothing else does.
        EXPECT_EQ(
            changed_number_tokens(test::file_bytes(fixture(name)), test::file_bytes(dir / name)),
            static_cast<std::size_t>(moved.size()));
        const auto changed = read_mesh_file(dir / name);
        EXPECT_EQ(changed.mesh.F, original.mesh.F);
        for (Eigen::Index k = 0; k < moved.size(); ++k)
        {
            // Short tokens come back as the shortest digits of the float32 rounding.
            EXPECT_NEAR(changed.mesh.V.data()[k], moved.data()[k],
                        std::abs(moved.data()[k]) * 0x1p-23);
        }
    }
}

TEST(PreserveTest, obj_edges_points_and_continuations_are_read_and_kept_and_carry_no_triangle)
{
    // Two-vertex faces, `l` polylines and `p` points (an older exporter's wires) are no
    // triangles; statements continued with a backslash are read whole; the vertices only the
    // wire uses keep their bytes when the cube's move.
    const auto file = read_mesh_file(fixture("obj_artist_statements.obj"));
    ASSERT_EQ(file.mesh.vertex_count(), 11);
    ASSERT_EQ(file.mesh.face_count(), 12);  // the six quads of the cube, fanned
    EXPECT_EQ(file.mesh.V.row(4), Eigen::RowVector3d(-1.0, 1.0, -1.0));
    EXPECT_EQ(file.mesh.V.row(5), Eigen::RowVector3d(-1.0, -1.0, -1.0));
    EXPECT_EQ(file.mesh.F.row(4), Eigen::RowVector3i(7, 6, 4));  // f 8 7 \ 5 6, first fan triangle
    EXPECT_EQ(static_cast<Eigen::Index>(referenced_vertices(file.mesh).size()), 8);

    const auto dir = test::temp_dir("preserve_obj_wires");
    Positions moved = file.mesh.V;
    moved.topRows(8) = perturbed(file.mesh.V).topRows(8);
    write_mesh_file(dir / "moved.obj", file, moved);
    EXPECT_EQ(changed_number_tokens(test::file_bytes(fixture("obj_artist_statements.obj")),
                                    test::file_bytes(dir / "moved.obj")),
              24U);
    const auto back = read_mesh_file(dir / "moved.obj");
    EXPECT_EQ(back.mesh.F, file.mesh.F);
    EXPECT_EQ(back.mesh.V.bottomRows(3), file.mesh.V.bottomRows(3));

    // A face with no vertex at all is still an error, naming its line.
    write_file_atomically(dir / "empty_face.obj", [](std::ostream& out) { out << "v 0 0 0\nf\n"; });
    try
    {
        (void)read_mesh_file(dir / "empty_face.obj");
        FAIL() << "read a face with no vertices";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
    }
}

TEST(PreserveTest, changed_binary_stl_moves_corners_and_recomputes_normals)
{
    const auto dir = test::temp_dir("preserve_stl");
    // Facet 1's normal is zero in this copy: it must stay zero.
    auto bytes = test::file_bytes(fixture("cube_binary.stl"));
    std::memset(bytes.data() + 84 + 50, 0, 12);
    bytes[84 + 50 * 4 + 48] = '\x2a';  // An attribute byte, to be kept.
    test::put_bytes(dir / "in.stl", bytes);
    const auto original = read_mesh_file(dir / "in.stl");
    Positions moved = original.mesh.V;
    moved(2, 0) += 0.25;  // Vertex 2 (cube corner 2) only: facets without it keep their bytes.
    moved(2, 2) -= 0.125;
    write_mesh_file(dir / "out.stl", original, moved);
    const auto out = test::file_bytes(dir / "out.stl");
    ASSERT_EQ(out.size(), bytes.size());
    EXPECT_EQ(out.substr(0, 84), bytes.substr(0, 84));
    const auto& F = original.mesh.F;
    for (Eigen::Index f = 0; f < 12; ++f)
    {
        SCOPED_TRACE(f);
        const auto at = static_cast<std::size_t>(84 + 50 * f);
        EXPECT_EQ(out.substr(at + 48, 2), bytes.substr(at + 48, 2));
        const bool touched = F(f, 0) == 2 || F(f, 1) == 2 || F(f, 2) == 2;
        if (!touched)
        {
            EXPECT_EQ(out.substr(at, 50), bytes.substr(at, 50));
            continue;
        }
        std::array<Eigen::Vector3d, 3> p;
        for (std::size_t c = 0; c < 3; ++c)
        {
            for (std::size_t d = 0; d < 3; ++d)
            {
                const auto value = float_at(out, at + 12 + 12 * c + 4 * d);
                p[c][static_cast<Eigen::Index>(d)] = static_cast<double>(value);
                EXPECT_EQ(value, static_cast<float>(moved(F(f, static_cast<Eigen::Index>(c)),
                                                          static_cast<Eigen::Index>(d))));
            }
        }
        const Eigen::Vector3d n(float_at(out, at), float_at(out, at + 4), float_at(out, at + 8));
        if (f == 1)
        {
            EXPECT_EQ(n.norm(), 0.0);
            continue;
        }
        const Eigen::Vector3d expected = (p[1] - p[0]).cross(p[2] - p[0]).normalized();
        EXPECT_NEAR((n - expected).norm(), 0.0, 1e-6);
    }
    const auto reread = read_mesh_file(dir / "out.stl");
    EXPECT_EQ(reread.mesh.F, original.mesh.F);
    EXPECT_EQ(reread.mesh.V(2, 0), as_float(moved(2, 0)));
}

TEST(PreserveTest, changed_ascii_stl_rewrites_touched_facets_only)
{
    const auto dir = test::temp_dir("preserve_ascii_stl");
    const auto original = read_mesh_file(fixture("cube_ascii.stl"));
    Positions moved = original.mesh.V;
    moved(6, 1) = 1.0 / 3.0;  // Cube corner 6 is used by 5 facets.
    write_mesh_file(dir / "out.stl", original, moved);
    // 5 facets x 3 normal components, plus the 5 corners' y coordinate.
    const auto before = test::file_bytes(fixture("cube_ascii.stl"));
    const auto after = test::file_bytes(dir / "out.stl");
    const auto changed = changed_number_tokens(before, after);
    EXPECT_GE(changed, 5U);
    EXPECT_LE(changed, 5U * 3U + 5U);
    EXPECT_NE(after.find("0.33333334"), std::string::npos);
    const auto reread = read_mesh(dir / "out.stl");
    EXPECT_EQ(reread.F, original.mesh.F);
    EXPECT_EQ(reread.V(6, 1), 0.33333334);
}

TEST(PreserveTest, writes_in_place_over_the_source)
{
    const auto dir = test::temp_dir("preserve_in_place");
    std::filesystem::copy_file(fixture("cube_binary_le.ply"), dir / "c.ply");
    const auto file = read_mesh_file(dir / "c.ply");
    const auto moved = perturbed(file.mesh.V);
    write_mesh_file(dir / "c.ply", file, moved);
    EXPECT_EQ(read_mesh(dir / "c.ply").V(3, 1), as_float(moved(3, 1)));
}

// An OBJ's `mtllib` names resolve against its folder (and the library's textures against the
// library's): written to another folder, a library that is not there with the same bytes is
// named by its path from the output, a name with spaces included; one already there, one the
// source lacks and an output in the source's folder keep their lines; nothing else changes.
TEST(PreserveTest, obj_material_libraries_are_reached_from_an_output_in_another_folder)
{
    const auto dir = test::temp_dir("preserve_mtllib");
    std::filesystem::create_directories(dir / "src");
    std::filesystem::create_directories(dir / "out" / "dst");
    const std::string body = test::file_bytes(fixture("quad_faces.obj"));
    const std::string head =
        "mtllib scene.mtl\nmtllib my materials.mtl\r\nmtllib same.mtl missing.mtl\n";
    test::put_bytes(dir / "src" / "scene.obj", head + body);
    test::put_bytes(dir / "src" / "scene.mtl", "newmtl a\n");
    test::put_bytes(dir / "src" / "my materials.mtl", "newmtl b\n");
    test::put_bytes(dir / "src" / "same.mtl", "newmtl c\n");
    test::put_bytes(dir / "out" / "dst" / "same.mtl", "newmtl c\n");
    const auto file = read_mesh_file(dir / "src" / "scene.obj");
    const auto moved = perturbed(file.mesh.V);

    write_mesh_file(dir / "out" / "dst" / "marked.obj", file, moved);
    const std::string written = test::file_bytes(dir / "out" / "dst" / "marked.obj");
    const std::string expected_head =
        "mtllib ../../src/scene.mtl\nmtllib ../../src/my materials.mtl\r\nmtllib same.mtl "
        "missing.mtl\n";
    ASSERT_EQ(written.substr(0, expected_head.size()), expected_head);
    write_mesh_file(dir / "src" / "same_folder.obj", file, moved);
    const std::string beside = test::file_bytes(dir / "src" / "same_folder.obj");
    EXPECT_EQ(beside.substr(0, head.size()), head);
    EXPECT_EQ(written.substr(expected_head.size()), beside.substr(head.size()));
    EXPECT_EQ(read_mesh(dir / "out" / "dst" / "marked.obj").V,
              read_mesh(dir / "src" / "same_folder.obj").V);
}

TEST(PreserveTest, other_format_target_writes_the_generic_file)
{
    const auto dir = test::temp_dir("preserve_other");
    const auto file = read_mesh_file(fixture("cube_ascii.ply"));
    const auto moved = perturbed(file.mesh.V);
    write_mesh_file(dir / "c.obj", file, moved);
    const auto mesh = read_mesh(dir / "c.obj");
    EXPECT_EQ(mesh.V, moved);
    EXPECT_EQ(mesh.F, file.mesh.F);
}

TEST(PreserveTest, rejects_bad_positions_and_leaves_no_file)
{
    const auto dir = test::temp_dir("preserve_bad");
    const auto file = read_mesh_file(fixture("cube.off"));
    Positions fewer = file.mesh.V.topRows(7);
    EXPECT_THROW(write_mesh_file(dir / "a.off", file, fewer), InvalidOption);
    Positions nan = file.mesh.V;
    nan(3, 1) = std::nan("");
    test::expect_error<InvalidMesh>([&] { write_mesh_file(dir / "b.off", file, nan); },
                                    {"b.off", "vertex 3"});
    Positions huge = file.mesh.V;
    huge(0, 0) = 1e300;
    test::put_bytes(dir / "i.ply",
                    "ply\nformat binary_little_endian 1.0\nelement vertex 1\n"
                    "property short x\nproperty short y\nproperty short z\n"
                    "end_header\n" +
                        std::string(6, '\0'));
    const auto shorts = read_mesh_file(dir / "i.ply");
    EXPECT_THROW(write_mesh_file(dir / "j.ply", shorts, huge.topRows(1)), IoError);
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);
}

}  // namespace meshmark
