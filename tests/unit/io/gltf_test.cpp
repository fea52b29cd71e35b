// SPDX-License-Identifier: MIT
// glTF 2.0 / GLB: world-frame welded reading, and the preserving writer (only position bytes
// and POSITION min/max change; the result stays a valid asset for tinygltf).
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <set>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include "gltf_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::GltfBuilder;
using test::Json;

struct Glb
{
    Json json;
    std::string bin;
};

Glb split(const std::string& bytes)
{
    Glb glb;
    glb.json = test::glb_json(bytes, &glb.bin);
    return glb;
}

// The unit box [0,1]^3 as 24 corners (4 per face, so every corner appears 3 times, as a
// glTF exporter writes a box with per-face normals) and 12 triangles.
void box_faces(std::vector<float>& xyz, std::vector<float>& normals,
               std::vector<std::uint16_t>& idx, const Eigen::Matrix4d& place)
{
    const int axes[6][3] = {{0, 1, 2}, {0, 1, 2}, {1, 2, 0}, {1, 2, 0}, {2, 0, 1}, {2, 0, 1}};
    for (int f = 0; f < 6; ++f)
    {
        const float side = static_cast<float>(f % 2);
        const auto base = static_cast<std::uint16_t>(xyz.size() / 3);
        const float uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        for (const auto& c : uv)
        {
            float p[3] = {0, 0, 0};
            p[axes[f][0]] = c[0];
            p[axes[f][1]] = c[1];
            p[axes[f][2]] = side;
            const Eigen::Vector4d q = place * Eigen::Vector4d(p[0], p[1], p[2], 1.0);
            for (int d = 0; d < 3; ++d)
            {
                xyz.push_back(static_cast<float>(q[d]));
                normals.push_back(d == axes[f][2] ? (side > 0 ? 1.0f : -1.0f) : 0.0f);
            }
        }
        for (const int k : {0, 1, 2, 0, 2, 3})
        {
            idx.push_back(static_cast<std::uint16_t>(base + k));
        }
    }
}

// Column-major array of a 4x4 matrix, as glTF stores node.matrix.
std::vector<double> column_major(const Eigen::Matrix4d& m)
{
    return std::vector<double>(m.data(), m.data() + 16);
}

/// Two boxes sharing the face x = 1 in world space:
/// - box A (mesh 0): interleaved POSITION+NORMAL (stride 24) plus TEXCOORD_0, under a node
///   with a matrix (scale 2, translation (1, 0, 0)), so its world box is [1,3]x[0,2]x[0,2];
/// - box B (mesh 1): packed positions, under a node with TRS (rotation 90 deg about z,
///   scale 0.5, translation) that is the child of a translated root; its local positions are
///   the world box [3,5]x[0,2]x[0,2] mapped back through that transform in float32.
struct TwoBoxes
{
    GltfBuilder builder;
    Eigen::Matrix4d a_to_world;
    Eigen::Matrix4d b_to_world;
};

TwoBoxes two_boxes()
{
    TwoBoxes t;
    auto& b = t.builder;
    Eigen::Affine3d a = Eigen::Affine3d::Identity();
    a.translate(Eigen::Vector3d(1, 0, 0)).scale(2.0);
    t.a_to_world = a.matrix();

    // Box A: interleaved position + normal, separate UVs.
    std::vector<float> xyz;
    std::vector<float> normals;
    std::vector<std::uint16_t> idx;
    box_faces(xyz, normals, idx, Eigen::Matrix4d::Identity());
    std::vector<float> interleaved;
    std::vector<float> uvs;
    for (std::size_t i = 0; i < xyz.size() / 3; ++i)
    {
        interleaved.insert(interleaved.end(),
                           {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], normals[3 * i],
                            normals[3 * i + 1], normals[3 * i + 2]});
        uvs.insert(uvs.end(), {static_cast<float>(i % 2), static_cast<float>((i / 2) % 2)});
    }
    const int view = b.view(GltfBuilder::raw(interleaved), 24);
    const int pos_a = b.accessor(view, 0, 5126, xyz.size() / 3, "VEC3");
    b.set_bounds(pos_a, xyz);
    const int nrm_a = b.accessor(view, 12, 5126, xyz.size() / 3, "VEC3");
    const int uv_a = b.accessor(b.view(GltfBuilder::raw(uvs)), 0, 5126, uvs.size() / 2, "VEC2");
    const int idx_a = b.indices(idx);
    const int mesh_a = b.mesh(Json::array(
        {{{"attributes", {{"POSITION", pos_a}, {"NORMAL", nrm_a}, {"TEXCOORD_0", uv_a}}},
          {"indices", idx_a},
          {"material", 0}}}));
    b.node({{"name", "A"}, {"mesh", mesh_a}, {"matrix", column_major(t.a_to_world)}});

    // Box B under root R (translation) -> child (TRS).
    const Eigen::Vector3d root_t(0.5, 0.25, 0.0);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
    const Eigen::Vector3d child_t(2.0, -1.0, 0.0);
    Eigen::Affine3d bt = Eigen::Affine3d::Identity();
    bt.translate(root_t).translate(child_t).rotate(q).scale(0.5);
    t.b_to_world = bt.matrix();
    Eigen::Affine3d world_box = Eigen::Affine3d::Identity();
    world_box.translate(Eigen::Vector3d(3, 0, 0)).scale(2.0);
    std::vector<float> xyz_b;
    std::vector<float> normals_b;
    std::vector<std::uint16_t> idx_b;
    box_faces(xyz_b, normals_b, idx_b, t.b_to_world.inverse() * world_box.matrix());
    const int pos_b = b.positions(xyz_b);
    const int mesh_b = b.mesh(Json::array({{{"attributes", {{"POSITION", pos_b}}},
                                            {"indices", b.indices(idx_b)},
                                            {"extras", {{"tag", "b"}}}}}));
    const int child = b.node({{"name", "B"},
                              {"mesh", mesh_b},
                              {"translation", {child_t.x(), child_t.y(), child_t.z()}},
                              {"rotation", {q.x(), q.y(), q.z(), q.w()}},
                              {"scale", {0.5, 0.5, 0.5}}},
                             false);
    b.node({{"name", "R"},
            {"translation", {root_t.x(), root_t.y(), root_t.z()}},
            {"children", {child}}});
    b.doc["extensionsUsed"] = {"EXT_unknown_vendor"};
    b.doc["extensions"] = {{"EXT_unknown_vendor", {{"keep", {1, 2, 3}}}}};
    return t;
}

// Moves every welded vertex by a smooth, vertex-dependent offset.
Positions displaced(const Positions& V)
{
    Positions result = V;
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        result(i, 0) += 0.01 * std::sin(3.0 * V(i, 1));
        result(i, 1) += 0.02 * std::cos(2.0 * V(i, 2));
        result(i, 2) += 0.015 * std::sin(V(i, 0));
    }
    return result;
}

// Byte ranges of every POSITION element of the plain accessors in a GLB JSON.
std::vector<bool> position_bytes(const Json& doc, std::size_t size)
{
    std::vector<bool> mask(size, false);
    std::set<int> position_accessors;
    for (const auto& mesh : doc["meshes"])
    {
        for (const auto& prim : mesh["primitives"])
        {
            position_accessors.insert(prim["attributes"]["POSITION"].get<int>());
        }
    }
    for (const int a : position_accessors)
    {
        const auto& acc = doc["accessors"][static_cast<std::size_t>(a)];
        const auto& view = doc["bufferViews"][acc["bufferView"].get<std::size_t>()];
        const std::size_t stride = view.value("byteStride", std::size_t{12});
        const std::size_t first =
            view.value("byteOffset", std::size_t{0}) + acc.value("byteOffset", std::size_t{0});
        for (std::size_t e = 0; e < acc["count"].get<std::size_t>(); ++e)
        {
            for (std::size_t k = 0; k < 12; ++k)
            {
                mask[first + e * stride + k] = true;
            }
        }
    }
    return mask;
}

Json without_position_bounds(Json doc)
{
    for (const auto& mesh : doc["meshes"])
    {
        for (const auto& prim : mesh["primitives"])
        {
            auto& acc = doc["accessors"][prim["attributes"]["POSITION"].get<std::size_t>()];
            acc.erase("min");
            acc.erase("max");
        }
    }
    return doc;
}

bool tinygltf_reads(const fs::path& path)
{
    tinygltf::TinyGLTF loader;
    tinygltf::Model model;
    std::string err;
    std::string warn;
    const bool ok = path.extension() == ".glb"
                        ? loader.LoadBinaryFromFile(&model, &err, &warn, path.string())
                        : loader.LoadASCIIFromFile(&model, &err, &warn, path.string());
    EXPECT_TRUE(err.empty()) << err;
    return ok;
}

class GltfTest : public ::testing::Test
{
protected:
    fs::path dir = test::temp_dir("gltf_test");
};

TEST_F(GltfTest, reads_world_positions_and_welds_seams_and_touching_parts)
{
    const auto t = two_boxes();
    test::put_bytes(dir / "boxes.glb", t.builder.glb());
    const MeshFile file = read_mesh_file(dir / "boxes.glb");
    EXPECT_EQ(file.format, MeshFormat::Glb);
    // 8 corners of A + 4 new corners of B: the 3 seam copies of each corner and the 4 shared
    // corners of the touching face (a few float32 ulps apart in world space) are welded.
    EXPECT_EQ(file.mesh.V.rows(), 12);
    EXPECT_EQ(file.mesh.F.rows(), 24);
    EXPECT_NEAR(file.mesh.V.col(0).minCoeff(), 1.0, 1e-6);
    EXPECT_NEAR(file.mesh.V.col(0).maxCoeff(), 5.0, 1e-6);
    EXPECT_NEAR(file.mesh.V.col(1).maxCoeff(), 2.0, 1e-6);
    for (Eigen::Index f = 0; f < file.mesh.F.rows(); ++f)
    {
        EXPECT_NE(file.mesh.F(f, 0), file.mesh.F(f, 1));
        EXPECT_NE(file.mesh.F(f, 1), file.mesh.F(f, 2));
    }
}

TEST_F(GltfTest, unchanged_positions_reproduce_glb_and_gltf_byte_for_byte)
{
    const auto t = two_boxes();
    test::put_bytes(dir / "in.glb", t.builder.glb());
    test::put_bytes(dir / "in.gltf", t.builder.gltf());
    for (const char* name : {"in.glb", "in.gltf"})
    {
        const MeshFile file = read_mesh_file(dir / name);
        const fs::path out = dir / (std::string("out") + fs::path(name).extension().string());
        write_mesh_file(out, file, file.mesh.V);
        EXPECT_EQ(test::file_bytes(out), test::file_bytes(dir / name)) << name;
    }
}

TEST_F(GltfTest, changed_positions_change_only_position_bytes_and_bounds)
{
    const auto t = two_boxes();
    test::put_bytes(dir / "in.glb", t.builder.glb());
    const MeshFile file = read_mesh_file(dir / "in.glb");
    const Positions moved = displaced(file.mesh.V);
    write_mesh_file(dir / "out.glb", file, moved);
    EXPECT_TRUE(tinygltf_reads(dir / "out.glb"));

    const Glb before = split(test::file_bytes(dir / "in.glb"));
    const Glb after = split(test::file_bytes(dir / "out.glb"));
    // JSON: equal once the POSITION bounds are left out; the extension/extras survive.
    EXPECT_EQ(without_position_bounds(after.json), without_position_bounds(before.json));
    EXPECT_NE(after.json["accessors"][0]["max"], before.json["accessors"][0]["max"]);
    // Binary: every byte outside the position elements is identical (normals, UVs,
    // indices, padding); some position bytes changed.
    ASSERT_EQ(after.bin.size(), before.bin.size());
    const auto mask = position_bytes(before.json, before.bin.size());
    std::size_t changed_position_bytes = 0;
    for (std::size_t k = 0; k < before.bin.size(); ++k)
    {
        if (!mask[k])
        {
            ASSERT_EQ(after.bin[k], before.bin[k]) << "byte " << k;
        }
        else if (after.bin[k] != before.bin[k])
        {
            ++changed_position_bytes;
        }
    }
    EXPECT_GT(changed_position_bytes, 0U);

    // Read back: same welded structure (no cracks at seams or between the parts) and the
    // new positions to float32 precision.
    const MeshFile again = read_mesh_file(dir / "out.glb");
    ASSERT_EQ(again.mesh.V.rows(), file.mesh.V.rows());
    EXPECT_EQ(again.mesh.F, file.mesh.F);
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);

    // Bounds are those of the stored floats.
    for (const int a : {0, 4})
    {
        const auto& acc = after.json["accessors"][static_cast<std::size_t>(a)];
        ASSERT_EQ(acc["type"], "VEC3");
        const auto& view = after.json["bufferViews"][acc["bufferView"].get<std::size_t>()];
        const std::size_t stride = view.value("byteStride", std::size_t{12});
        const std::size_t first = view.value("byteOffset", std::size_t{0});
        for (std::size_t d = 0; d < 3; ++d)
        {
            float lo = 1e30f;
            float hi = -1e30f;
            for (std::size_t e = 0; e < acc["count"].get<std::size_t>(); ++e)
            {
                const float v = test::float_at(after.bin, first + e * stride + 4 * d);
                lo = std::min(lo, v);
                hi = std::max(hi, v);
            }
            EXPECT_EQ(static_cast<float>(acc["min"][d].get<double>()), lo);
            EXPECT_EQ(static_cast<float>(acc["max"][d].get<double>()), hi);
        }
    }
}

TEST_F(GltfTest, data_uri_gltf_round_trip_keeps_json_and_rewrites_only_the_buffer)
{
    const auto t = two_boxes();
    test::put_bytes(dir / "in.gltf", t.builder.gltf());
    const MeshFile file = read_mesh_file(dir / "in.gltf");
    EXPECT_EQ(file.mesh.V.rows(), 12);
    const Positions moved = displaced(file.mesh.V);
    write_mesh_file(dir / "out.gltf", file, moved);
    EXPECT_TRUE(tinygltf_reads(dir / "out.gltf"));
    auto before = Json::parse(test::file_bytes(dir / "in.gltf"));
    auto after = Json::parse(test::file_bytes(dir / "out.gltf"));
    EXPECT_NE(after["buffers"][0]["uri"], before["buffers"][0]["uri"]);
    EXPECT_EQ(after["buffers"][0]["uri"].get<std::string>().rfind(
                  "data:application/octet-stream;base64,", 0),
              0U);
    after["buffers"][0].erase("uri");
    before["buffers"][0].erase("uri");
    EXPECT_EQ(without_position_bounds(after), without_position_bounds(before));
    const MeshFile again = read_mesh_file(dir / "out.gltf");
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(GltfTest, external_buffer_is_written_beside_the_output_and_the_input_is_untouched)
{
    const auto t = two_boxes();
    fs::create_directories(dir / "src");
    fs::create_directories(dir / "dst");
    test::put_bytes(dir / "src" / "scene.gltf", t.builder.gltf("scene data.bin"));
    test::put_bytes(dir / "src" / "scene data.bin", t.builder.bin);
    const MeshFile file = read_mesh_file(dir / "src" / "scene.gltf");
    const Positions moved = displaced(file.mesh.V);
    write_mesh_file(dir / "dst" / "marked.gltf", file, moved);
    EXPECT_EQ(test::file_bytes(dir / "src" / "scene data.bin"), t.builder.bin);
    ASSERT_TRUE(fs::exists(dir / "dst" / "marked.bin"));
    const auto out = Json::parse(test::file_bytes(dir / "dst" / "marked.gltf"));
    EXPECT_EQ(out["buffers"][0]["uri"], "marked.bin");
    EXPECT_TRUE(tinygltf_reads(dir / "dst" / "marked.gltf"));
    const MeshFile again = read_mesh_file(dir / "dst" / "marked.gltf");
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);

    // In place: the new buffer gets a name that is not the source's buffer file.
    test::put_bytes(dir / "src" / "scene.bin", t.builder.bin);
    test::put_bytes(dir / "src" / "s2.gltf", t.builder.gltf("scene.bin"));
    const MeshFile second = read_mesh_file(dir / "src" / "s2.gltf");
    write_mesh_file(dir / "src" / "scene.gltf", second, displaced(second.mesh.V));
    EXPECT_EQ(test::file_bytes(dir / "src" / "scene.bin"), t.builder.bin);
    EXPECT_EQ(Json::parse(test::file_bytes(dir / "src" / "scene.gltf"))["buffers"][0]["uri"],
              "scene_wm.bin");
}

// Images with relative URIs: written to another folder, the marked asset must still show its
// textures. Each image is copied beside the output (same relative path), unless the same bytes
// are there already; one whose path leaves the output's folder or whose place holds another
// file is reached from the output instead; a missing image, a data: URI and an output in the
// source's folder change nothing; a failed write leaves no image or folder behind.
TEST_F(GltfTest, images_are_copied_beside_an_output_in_another_folder_or_reached_from_it)
{
    auto t = two_boxes();
    t.builder.doc["images"] = Json::array({{{"uri", "tex/a%20b.png"}},
                                           {{"uri", "../shared.png"}},
                                           {{"uri", "clash.png"}},
                                           {{"uri", "same.png"}},
                                           {{"uri", "missing.png"}},
                                           {{"uri", "data:image/png;base64,AAAA"}}});
    fs::create_directories(dir / "src" / "tex");
    fs::create_directories(dir / "out" / "dst");
    test::put_bytes(dir / "src" / "scene.gltf", t.builder.gltf());
    test::put_bytes(dir / "src" / "tex" / "a b.png", "A");
    test::put_bytes(dir / "shared.png", "S");
    test::put_bytes(dir / "src" / "clash.png", "C");
    test::put_bytes(dir / "src" / "same.png", "M");
    test::put_bytes(dir / "out" / "dst" / "clash.png", "another file");
    test::put_bytes(dir / "out" / "dst" / "same.png", "M");
    const std::string source = test::file_bytes(dir / "src" / "scene.gltf");
    const MeshFile file = read_mesh_file(dir / "src" / "scene.gltf");
    const Positions moved = displaced(file.mesh.V);

    write_mesh_file(dir / "out" / "dst" / "marked.gltf", file, moved);
    const Json images =
        Json::parse(test::file_bytes(dir / "out" / "dst" / "marked.gltf"))["images"];
    EXPECT_EQ(images[0]["uri"], "tex/a%20b.png");
    EXPECT_EQ(test::file_bytes(dir / "out" / "dst" / "tex" / "a b.png"), "A");
    EXPECT_EQ(images[1]["uri"], "../../shared.png");
    EXPECT_EQ(images[2]["uri"], "../../src/clash.png");
    EXPECT_EQ(test::file_bytes(dir / "out" / "dst" / "clash.png"), "another file");
    EXPECT_EQ(images[3]["uri"], "same.png");
    EXPECT_EQ(images[4]["uri"], "missing.png");
    EXPECT_FALSE(fs::exists(dir / "out" / "dst" / "missing.png"));
    EXPECT_EQ(images[5]["uri"], "data:image/png;base64,AAAA");
    EXPECT_FALSE(fs::exists(dir / "out" / "dst" / "shared.png"));
    EXPECT_EQ(test::file_bytes(dir / "src" / "scene.gltf"), source);
    EXPECT_LT(
        (read_mesh_file(dir / "out" / "dst" / "marked.gltf").mesh.V - moved).cwiseAbs().maxCoeff(),
        1e-6);

    // In the source's folder every URI already resolves: the images are left as they are.
    write_mesh_file(dir / "src" / "marked.gltf", file, moved);
    EXPECT_EQ(Json::parse(test::file_bytes(dir / "src" / "marked.gltf"))["images"],
              t.builder.doc["images"]);

    // The asset cannot be written (its name is a folder): no image and no folder are left.
    fs::create_directories(dir / "fail" / "m.gltf");
    EXPECT_THROW(write_mesh_file(dir / "fail" / "m.gltf", file, moved), Error);
    EXPECT_FALSE(fs::exists(dir / "fail" / "tex"));
    EXPECT_FALSE(fs::exists(dir / "fail" / "same.png"));
}

TEST_F(GltfTest, instanced_mesh_is_watermarked_once_through_its_first_instance)
{
    GltfBuilder b;
    std::vector<float> xyz;
    std::vector<float> normals;
    std::vector<std::uint16_t> idx;
    box_faces(xyz, normals, idx, Eigen::Matrix4d::Identity());
    const int pos = b.positions(xyz);
    const int mesh =
        b.mesh(Json::array({{{"attributes", {{"POSITION", pos}}}, {"indices", b.indices(idx)}}}));
    b.node({{"mesh", mesh}, {"translation", {10.0, 0.0, 0.0}}});
    b.node({{"mesh", mesh}, {"translation", {-10.0, 0.0, 0.0}}});
    test::put_bytes(dir / "inst.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "inst.glb");
    ASSERT_EQ(file.mesh.V.rows(), 8);
    EXPECT_EQ(file.mesh.F.rows(), 12);
    EXPECT_NEAR(file.mesh.V.col(0).minCoeff(), 10.0, 0.0);
    // The second instance is kept aside, unwelded (one point per element), at x = -10 + local.
    ASSERT_EQ(file.instances.V.rows(), static_cast<Eigen::Index>(xyz.size() / 3));
    EXPECT_EQ(file.instances.F.rows(), 12);
    EXPECT_NEAR(file.instances.V.col(0).maxCoeff(), -10.0 + file.mesh.V.col(0).maxCoeff() - 10.0,
                1e-12);
    Positions moved = file.mesh.V;
    moved(0, 2) += 0.25;
    write_mesh_file(dir / "inst_out.glb", file, moved);
    const MeshFile again = read_mesh_file(dir / "inst_out.glb");
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);
    // ... and shows the same local displacement, rigidly moved.
    ASSERT_EQ(again.instances.V.rows(), file.instances.V.rows());
    const Positions shift = again.instances.V - file.instances.V;
    EXPECT_NEAR(shift.col(2).maxCoeff(), 0.25, 1e-6);
    EXPECT_LT(shift.leftCols(2).cwiseAbs().maxCoeff(), 1e-6);
}

// A skinned mesh is where a viewer (and Blender) shows it: every vertex placed by its joints,
// sum_k w_k (joint k's world matrix x its inverse bind matrix), with the weights normalized and
// the node's own transform ignored, as glTF requires. A rig whose scene pose is not its bind
// pose (a converted character: the knee bent) read through the node's transform instead made
// every Blender copy of it another shape (BCN_Epileptic from assimp's models: z 1.3 after a
// plain PLY round trip). A moved position is written back through its own matrix's inverse.
TEST_F(GltfTest, skinned_mesh_is_read_in_the_scene_pose_and_written_back_through_its_joints)
{
    const test::KneeRig rig;
    GltfBuilder b;
    const std::size_t n = rig.size();
    const int pos = b.positions(rig.xyz);
    const int joint_acc = b.accessor(b.view(GltfBuilder::raw(rig.joints)), 0, 5121, n, "VEC4");
    const int weight_acc = b.accessor(b.view(GltfBuilder::raw(rig.weights)), 0, 5126, n, "VEC4");
    const int mesh = b.mesh(Json::array(
        {{{"attributes", {{"POSITION", pos}, {"JOINTS_0", joint_acc}, {"WEIGHTS_0", weight_acc}}},
          {"indices", b.indices(rig.idx)}}}));
    rig.add_skeleton(b, mesh);
    test::put_bytes(dir / "rig.glb", b.glb());
    Positions expected(static_cast<Eigen::Index>(n), 3);
    for (std::size_t v = 0; v < n; ++v)
    {
        expected.row(static_cast<Eigen::Index>(v)) = rig.shown(v).transpose();
    }
    const MeshFile file = read_mesh_file(dir / "rig.glb");
    ASSERT_EQ(file.mesh.V.rows(), static_cast<Eigen::Index>(n));
    EXPECT_LT((file.mesh.V - expected).cwiseAbs().maxCoeff(), 1e-6);

    // Moved by a small field, written, read again: the same field, in the scene pose.
    const Positions moved = test::nudged(file.mesh.V);
    write_mesh_file(dir / "rig_out.glb", file, moved);
    const MeshFile again = read_mesh_file(dir / "rig_out.glb");
    ASSERT_EQ(again.mesh.V.rows(), moved.rows());
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);
    // Only the positions changed: the skin, its joints and every node are as they were.
    const Glb out = split(test::file_bytes(dir / "rig_out.glb"));
    EXPECT_EQ(out.json["skins"], b.doc["skins"]);
    EXPECT_EQ(out.json["nodes"], b.doc["nodes"]);
}

// Blender shows an animated asset at frame 1 of its first animation (1/24 s after its start)
// and hands that pose on to every copy made from the import (its PLY and OBJ writers, its
// modifiers): the reader gives that pose beside the stored mesh, each vertex placed by the
// joints as the animation moves them (a STEP key already passed, a LINEAR turn interpolated as
// Blender does, its second key brought into the first one's hemisphere), and the linear map
// that takes a displacement made there back to the stored frame. An animation that only moves
// the asset as a whole, and an asset without animations, give no pose.
TEST_F(GltfTest, an_animated_rig_gives_the_pose_blender_shows_it_in)
{
    const auto [xyz, idx] = test::strip(16, -1.0f, 0.125f);
    const auto n = static_cast<Eigen::Index>(xyz.size() / 3);
    const test::BendingArm arm;
    test::put_bytes(dir / "arm.glb", arm.glb(xyz, idx));
    const MeshFile file = read_mesh_file(dir / "arm.glb");
    ASSERT_EQ(file.mesh.V.rows(), n);
    // What Blender shows: frame 1 of the first animation.
    ShownPose pose;
    const double frame_one = 1.0 / 24.0;
    for_each_animation_pose(dir / "arm.glb", std::span<const double>(&frame_one, 1),
                            [&](ShownPose&& p) { pose = std::move(p); });
    ASSERT_EQ(pose.V.rows(), n);
    ASSERT_EQ(pose.to_rest.size(), static_cast<std::size_t>(n));
    EXPECT_EQ(pose.name, "animation 'bend' at 1/24 s");
    double largest_bend = 0.0;
    for (Eigen::Index v = 0; v < n; ++v)
    {
        const Eigen::Vector3d p(xyz[3 * v], xyz[3 * v + 1], xyz[3 * v + 2]);
        EXPECT_LT((file.mesh.V.row(v).transpose() - p).norm(), 1e-6) << v;  // stored straight
        EXPECT_LT((pose.V.row(v).transpose() - arm.shown(p)).norm(), 1e-6) << v;
        largest_bend =
            std::max(largest_bend, (arm.shown(p) - p - Eigen::Vector3d(0.0, arm.lift, 0.0)).norm());
        // A displacement d made in the pose comes back as the stored displacement.
        const Eigen::Vector3d d(1e-3, -2e-3, 1.5e-3);
        const double w = arm.weight(p.x());
        EXPECT_LT(
            (pose.to_rest[static_cast<std::size_t>(v)] * (arm.shown(p + d, w) - arm.shown(p, w)) -
             d)
                .norm(),
            1e-9)
            << v;
    }
    EXPECT_GT(largest_bend, 0.3);  // the pose is not the stored shape lifted

    // The animation's span, and its poses at other times (a copy exported at another frame).
    ASSERT_FALSE(file.animations.empty());
    ASSERT_EQ(file.animations.size(), 2u);  // (the second, "straight", keeps the elbow still)
    EXPECT_EQ(file.animations.front().name, "bend");
    EXPECT_EQ(file.animations[1].name, "straight");
    EXPECT_EQ(file.animations[1].index, 1u);
    EXPECT_EQ(file.animations.front().first_key, 0.0);
    EXPECT_NEAR(file.animations.front().last_key, 0.1, 1e-7);
    const std::vector<double> times{0.0, 0.05, 1.0 / 24.0, 2.0 / 24.0, 0.1};
    std::vector<ShownPose> poses;
    for_each_animation_pose(dir / "arm.glb", times,
                            [&](ShownPose&& p) { poses.push_back(std::move(p)); });
    ASSERT_EQ(poses.size(), times.size());
    EXPECT_EQ(poses[0].V.rows(), 0);  // at its start the animation only keeps the stored pose
    EXPECT_EQ(poses[1].name, "animation 'bend' at 0.05 s");
    EXPECT_EQ(poses[2].name, "animation 'bend' at 1/24 s");
    EXPECT_EQ(poses[3].name, "animation 'bend' at 2/24 s");
    for (std::size_t k = 1; k < times.size(); ++k)
    {
        ASSERT_EQ(poses[k].V.rows(), n) << k;
        EXPECT_EQ(poses[k].time, times[k]);
        for (Eigen::Index v = 0; v < n; ++v)
        {
            const Eigen::Vector3d p(xyz[3 * v], xyz[3 * v + 1], xyz[3 * v + 2]);
            EXPECT_LT(
                (poses[k].V.row(v).transpose() - arm.shown(p, arm.weight(p.x()), times[k])).norm(),
                1e-6)
                << k << " " << v;
        }
    }
    EXPECT_EQ(poses[2].V, pose.V);  // the same pose, each time read afresh

    test::BendingArm lifted_only = arm;
    lifted_only.turn = 0.0;
    test::put_bytes(dir / "lifted.glb", lifted_only.glb(xyz, idx));
    Eigen::Index lifted_rows = -1;
    for_each_animation_pose(dir / "lifted.glb", std::span<const double>(&frame_one, 1),
                            [&](ShownPose&& p) { lifted_rows = p.V.rows(); });
    EXPECT_EQ(lifted_rows, 0);
    EXPECT_EQ(read_mesh_file(dir / "lifted.glb").mesh.V.rows(), n);
}

// The poses of a file read once (read_mesh_file) come from what the reader kept, not from the
// file again: the same poses, bit for bit, as posing it by path, with the file gone, and again
// on a second call (each walk starts afresh); an asset without animations keeps nothing and, as
// a MeshFile without layout, gives empty poses.
TEST_F(GltfTest, the_poses_of_a_file_read_once_need_no_second_read)
{
    const auto [xyz, idx] = test::strip(16, -1.0f, 0.125f);
    const test::BendingArm arm;
    test::put_bytes(dir / "arm.glb", arm.glb(xyz, idx));
    const std::vector<double> times{0.0, 0.05, 1.0 / 24.0, 0.1};
    std::vector<ShownPose> by_path;
    for_each_animation_pose(dir / "arm.glb", times,
                            [&](ShownPose&& p) { by_path.push_back(std::move(p)); });
    const MeshFile file = read_mesh_file(dir / "arm.glb");
    fs::remove(dir / "arm.glb");
    for (int call = 0; call < 2; ++call)
    {
        std::vector<ShownPose> read_once;
        for_each_animation_pose(file, times,
                                [&](ShownPose&& p) { read_once.push_back(std::move(p)); });
        ASSERT_EQ(read_once.size(), by_path.size()) << call;
        for (std::size_t k = 0; k < times.size(); ++k)
        {
            EXPECT_EQ(read_once[k].name, by_path[k].name) << call << " " << k;
            EXPECT_EQ(read_once[k].time, by_path[k].time) << call << " " << k;
            ASSERT_EQ(read_once[k].V.rows(), by_path[k].V.rows()) << call << " " << k;
            EXPECT_TRUE(read_once[k].V == by_path[k].V) << call << " " << k;
            EXPECT_TRUE(read_once[k].to_rest == by_path[k].to_rest) << call << " " << k;
        }
        EXPECT_GT(read_once[1].V.rows(), 0);
    }
    // The second animation's frame, from the same file read once.
    std::size_t posed = 0;
    const double end = 0.1;
    for_each_animation_pose(
        file, std::span<const double>(&end, 1), [&](ShownPose&&) { ++posed; }, 1);
    EXPECT_EQ(posed, 1u);

    write_mesh(dir / "still.glb", file.mesh);
    const MeshFile still = read_mesh_file(dir / "still.glb");
    ASSERT_TRUE(still.animations.empty());
    MeshFile without_layout = file;
    without_layout.layout.reset();
    for (const MeshFile* f : std::array<const MeshFile*, 2>{&still, &without_layout})
    {
        std::vector<ShownPose> none;
        for_each_animation_pose(*f, times, [&](ShownPose&& p) { none.push_back(std::move(p)); });
        ASSERT_EQ(none.size(), times.size());
        for (const ShownPose& p : none)
        {
            EXPECT_EQ(p.V.rows(), 0);
            EXPECT_TRUE(p.name.empty());
        }
    }
}

// A mesh with morph targets (Blender's shape keys) is shown, and copied by Blender, as its base
// positions plus each target's POSITION deltas times its weight: the node's `weights`, else
// the mesh's, as an animation's weights channel sets them at a time. The reader keeps the base
// positions as the mesh (what a marked copy changes) and gives the blend as a pose, each vertex
// moved by its deltas with no change of frame: a file that shows a fixed blend gets one pose of
// no length past its animations, one whose animation keys the weights gets that animation's
// poses (none where every weight is 0). Writing a moved mesh changes no target or weight.
TEST_F(GltfTest, a_blend_of_morph_targets_is_a_pose_over_the_stored_positions)
{
    const auto [xyz, idx] = test::strip(16, -1.0f, 0.125f);
    const std::size_t n = xyz.size() / 3;
    // Two targets: a bump over the right half, a lean of the whole along z.
    std::vector<float> bump(xyz.size(), 0.0f);
    std::vector<float> lean(xyz.size(), 0.0f);
    for (std::size_t v = 0; v < n; ++v)
    {
        bump[3 * v + 1] = xyz[3 * v] > 0.0f ? 0.5f * xyz[3 * v] * xyz[3 * v] : 0.0f;
        lean[3 * v + 2] = 0.25f * xyz[3 * v];
    }
    const auto shown = [&](std::size_t v, double w_bump, double w_lean)
    {
        return Eigen::Vector3d(
            xyz[3 * v] + w_bump * bump[3 * v] + w_lean * lean[3 * v],
            xyz[3 * v + 1] + w_bump * bump[3 * v + 1] + w_lean * lean[3 * v + 1],
            xyz[3 * v + 2] + w_bump * bump[3 * v + 2] + w_lean * lean[3 * v + 2]);
    };
    // \p animated: a LINEAR channel from (0.6, 0.2) at t = 0 to (0, 0) at t = 1.
    const auto make = [&](const std::string& name, bool animated)
    {
        GltfBuilder b;
        const int pos = b.positions(xyz);
        const int t0 = b.positions(bump);
        const int t1 = b.positions(lean);
        const int mesh =
            b.mesh(Json::array({{{"attributes", {{"POSITION", pos}}},
                                 {"indices", b.indices(idx)},
                                 {"targets", {{{"POSITION", t0}}, {{"POSITION", t1}}}}}}));
        b.doc["meshes"][0]["weights"] = {0.5, 0.0};
        const int node = b.node({{"mesh", mesh}, {"translation", {0.0, 2.0, 0.0}}});
        if (animated)
        {
            const std::vector<float> times{0.0f, 1.0f};
            const std::vector<float> weights{0.6f, 0.2f, 0.0f, 0.0f};
            const int at = b.accessor(b.view(GltfBuilder::raw(times)), 0, 5126, 2, "SCALAR");
            const int to = b.accessor(b.view(GltfBuilder::raw(weights)), 0, 5126, 4, "SCALAR");
            b.doc["animations"] = Json::array(
                {{{"name", "puff"},
                  {"samplers", {{{"input", at}, {"output", to}}}},
                  {"channels",
                   {{{"sampler", 0}, {"target", {{"node", node}, {"path", "weights"}}}}}}}});
        }
        test::put_bytes(dir / name, b.glb());
        return b;
    };
    const Eigen::Vector3d lift(0.0, 2.0, 0.0);

    // A fixed blend: the mesh's weights (0.5 of the bump).
    const GltfBuilder still = make("still.glb", false);
    const MeshFile file = read_mesh_file(dir / "still.glb");
    ASSERT_EQ(file.mesh.V.rows(), static_cast<Eigen::Index>(n));
    ASSERT_EQ(file.animations.size(), 1u);
    EXPECT_EQ(file.animations.front().index, 0u);  // (past the file's none)
    EXPECT_EQ(file.animations.front().name, "the stored morph target weights");
    EXPECT_FALSE(file.animations.front().moves_only_as_a_whole);
    ShownPose pose;
    const double zero = 0.0;
    for_each_animation_pose(
        dir / "still.glb", std::span<const double>(&zero, 1),
        [&](ShownPose&& p) { pose = std::move(p); }, file.animations.front().index);
    ASSERT_EQ(pose.V.rows(), static_cast<Eigen::Index>(n));
    EXPECT_EQ(pose.name, "the stored morph target weights");
    for (std::size_t v = 0; v < n; ++v)
    {
        const auto r = static_cast<Eigen::Index>(v);
        EXPECT_LT((file.mesh.V.row(r).transpose() - (shown(v, 0.0, 0.0) + lift)).norm(), 1e-6)
            << v;  // the base
        EXPECT_LT((pose.V.row(r).transpose() - (shown(v, 0.5, 0.0) + lift)).norm(), 1e-6) << v;
        EXPECT_LT((pose.to_rest[v] - Eigen::Matrix3d::Identity()).norm(), 1e-12) << v;
    }
    // A node's own weights win over its mesh's.
    {
        GltfBuilder b = still;
        b.doc["nodes"][0]["weights"] = {0.0, 1.0};
        test::put_bytes(dir / "node_weights.glb", b.glb());
        ShownPose leaned;
        for_each_animation_pose(
            dir / "node_weights.glb", std::span<const double>(&zero, 1),
            [&](ShownPose&& p) { leaned = std::move(p); }, 0);
        ASSERT_EQ(leaned.V.rows(), static_cast<Eigen::Index>(n));
        for (std::size_t v = 0; v < n; ++v)
        {
            EXPECT_LT((leaned.V.row(static_cast<Eigen::Index>(v)).transpose() -
                       (shown(v, 0.0, 1.0) + lift))
                          .norm(),
                      1e-6);
        }
        b.doc["nodes"][0]["weights"] = {0.0, 0.0};
        test::put_bytes(dir / "no_blend.glb", b.glb());
        EXPECT_TRUE(
            read_mesh_file(dir / "no_blend.glb").animations.empty());  // nothing blended, no pose
    }
    // A target that cannot be read (a SCALAR accessor as its POSITION) or of another length
    // adds nothing; the others still blend.
    for (const bool scalar : {true, false})
    {
        GltfBuilder b = still;
        const std::vector<float> other =
            scalar ? std::vector<float>(n, 1.0f) : std::vector<float>(3, 1.0f);
        const int bad = scalar ? b.accessor(b.view(GltfBuilder::raw(other)), 0, 5126, n, "SCALAR")
                               : b.positions(other);
        b.doc["meshes"][0]["primitives"][0]["targets"][1]["POSITION"] = bad;
        b.doc["meshes"][0]["weights"] = {0.5, 1.0};
        test::put_bytes(dir / "bad_target.glb", b.glb());
        ShownPose bumped;
        for_each_animation_pose(
            dir / "bad_target.glb", std::span<const double>(&zero, 1),
            [&](ShownPose&& p) { bumped = std::move(p); }, 0);
        ASSERT_EQ(bumped.V.rows(), static_cast<Eigen::Index>(n)) << scalar;
        for (std::size_t v = 0; v < n; ++v)
        {
            EXPECT_LT((bumped.V.row(static_cast<Eigen::Index>(v)).transpose() -
                       (shown(v, 0.5, 0.0) + lift))
                          .norm(),
                      1e-6)
                << scalar;
        }
    }
    // The base moved and written back: the targets and weights untouched.
    const Positions moved = test::nudged(file.mesh.V);
    write_mesh_file(dir / "still_out.glb", file, moved);
    EXPECT_LT((read_mesh_file(dir / "still_out.glb").mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);
    const Glb out = split(test::file_bytes(dir / "still_out.glb"));
    EXPECT_EQ(out.json["meshes"], still.doc["meshes"]);
    EXPECT_EQ(out.json["nodes"], still.doc["nodes"]);

    // Keyed weights: the animation's span, its poses interpolated, none where the weights are 0.
    (void)make("keyed.glb", true);
    const MeshFile keyed = read_mesh_file(dir / "keyed.glb");
    ASSERT_EQ(keyed.animations.size(), 1u);  // (no pose of the fixed weights besides it)
    EXPECT_EQ(keyed.animations.front().name, "puff");
    EXPECT_EQ(keyed.animations.front().last_key, 1.0);
    EXPECT_FALSE(keyed.animations.front().moves_only_as_a_whole);
    const std::vector<double> times{0.0, 0.25, 1.0};
    std::vector<ShownPose> poses;
    for_each_animation_pose(dir / "keyed.glb", times,
                            [&](ShownPose&& p) { poses.push_back(std::move(p)); });
    ASSERT_EQ(poses.size(), 3u);
    EXPECT_EQ(poses[1].name, "animation 'puff' at 6/24 s");
    EXPECT_EQ(poses[2].V.rows(), 0);
    for (std::size_t k = 0; k < 2; ++k)
    {
        ASSERT_EQ(poses[k].V.rows(), static_cast<Eigen::Index>(n)) << k;
        const double s = 1.0 - times[k];
        for (std::size_t v = 0; v < n; ++v)
        {
            EXPECT_LT((poses[k].V.row(static_cast<Eigen::Index>(v)).transpose() -
                       (shown(v, 0.6 * s, 0.2 * s) + lift))
                          .norm(),
                      1e-6)
                << k << " " << v;
        }
    }
}

// Which animations only move the asset as a whole (a turntable: no frame poses the mesh, so
// detection has nothing to read a copy through) and which may bend it: two boxes, the second
// under the first's node, both under a stand, with one channel at a time on a node of the tree.
TEST_F(GltfTest, an_animation_that_only_moves_the_whole_asset_is_told_apart)
{
    struct Case
    {
        const char* name;
        int target;  // 0: the first box's node, 1: the second box's, 2: a camera beside them
        const char* path;
        std::vector<float> values;        // two keys
        std::vector<double> stand_scale;  // the stand's scale
        bool is_whole;
    };
    const float h = std::sqrt(0.5f);
    const std::vector<Case> cases{
        {"turntable", 0, "rotation", {0, 0, 0, 1, 0, h, 0, h}, {1, 1, 1}, true},
        {"turntable on a larger stand", 0, "rotation", {0, 0, 0, 1, 0, h, 0, h}, {2, 2, 2}, true},
        // (a scale of 1.3 as Blender writes it: uniform to float32 rounding)
        {"turntable on Blender's stand",
         0,
         "rotation",
         {0, 0, 0, 1, 0, h, 0, h},
         {1.2999998331069946, 1.2999999523162842, 1.2999998331069946},
         true},
        {"grow", 0, "scale", {1, 1, 1, 2, 2, 2}, {1, 1, 1}, true},
        {"squash", 0, "scale", {1, 1, 1, 1, 0.5f, 1}, {1, 1, 1}, false},
        {"turn on a stretched stand", 0, "rotation", {0, 0, 0, 1, 0, h, 0, h}, {3, 1, 1}, false},
        {"door", 1, "rotation", {0, 0, 0, 1, 0, h, 0, h}, {1, 1, 1}, false},
        {"camera", 2, "translation", {0, 0, 0, 0, 0, 5}, {1, 1, 1}, false},
    };
    for (const Case& c : cases)
    {
        GltfBuilder b;
        const auto box = [&]
        {
            std::vector<float> xyz;
            std::vector<float> normals;
            std::vector<std::uint16_t> idx;
            box_faces(xyz, normals, idx, Eigen::Matrix4d::Identity());
            return b.mesh(Json::array(
                {{{"attributes", {{"POSITION", b.positions(xyz)}}}, {"indices", b.indices(idx)}}}));
        };
        const int second = b.node({{"mesh", box()}, {"translation", {2.5, 0.0, 0.0}}}, false);
        const int first = b.node({{"mesh", box()}, {"children", {second}}}, false);
        (void)b.node({{"name", "stand"}, {"children", {first}}, {"scale", c.stand_scale}});
        const int camera = b.node({{"name", "camera"}});
        const std::vector<float> times{0.0f, 1.0f};
        const int at = b.accessor(b.view(GltfBuilder::raw(times)), 0, 5126, 2, "SCALAR");
        const int to = b.accessor(b.view(GltfBuilder::raw(c.values)), 0, 5126, 2,
                                  std::string(c.path) == "rotation" ? "VEC4" : "VEC3");
        const int target = std::array{first, second, camera}[static_cast<std::size_t>(c.target)];
        b.doc["animations"] = Json::array(
            {{{"samplers", {{{"input", at}, {"output", to}}}},
              {"channels", {{{"sampler", 0}, {"target", {{"node", target}, {"path", c.path}}}}}}}});
        test::put_bytes(dir / "moving.glb", b.glb());
        const MeshFile file = read_mesh_file(dir / "moving.glb");
        ASSERT_EQ(file.mesh.V.rows(), 16) << c.name;
        ASSERT_FALSE(file.animations.empty()) << c.name;
        EXPECT_EQ(file.animations.front().moves_only_as_a_whole, c.is_whole) << c.name;
        // What the poses say halfway: none where the whole only moves (nor where only the camera
        // does); the door and the squash bend the asset, and the turn on a stretched stand shears
        // it.
        const std::vector<double> halfway{0.5};
        Eigen::Index rows = -1;
        for_each_animation_pose(dir / "moving.glb", halfway,
                                [&](ShownPose&& p) { rows = p.V.rows(); });
        const bool is_bent = std::string(c.name) != "camera" && !c.is_whole;
        EXPECT_EQ(rows, is_bent ? 16 : 0) << c.name;
    }
}

// A rig in its bind pose (what most exporters write) places each vertex where its node does,
// up to the float32 rounding of the inverse bind matrices: it is read through the node, to the
// bit, as before skins were applied, so keys made then still match.
TEST_F(GltfTest, skinned_mesh_in_its_bind_pose_reads_exactly_as_through_its_node)
{
    GltfBuilder b;
    std::vector<float> xyz;
    std::vector<float> normals;
    std::vector<std::uint16_t> idx;
    box_faces(xyz, normals, idx, Eigen::Matrix4d::Identity());
    const std::size_t n = xyz.size() / 3;
    const std::vector<std::uint8_t> joints(4 * n, 0);
    std::vector<float> weights(4 * n, 0.0f);
    for (std::size_t v = 0; v < n; ++v)
    {
        weights[4 * v] = 1.0f;
    }
    // The joint turned by 30 degrees and moved; its inverse bind matrix undoes that, in float32.
    const double angle = 30.0 * std::numbers::pi / 180.0;
    const Eigen::Affine3d joint_world =
        Eigen::Translation3d(0.3, -0.2, 0.1) * Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ());
    const Eigen::Matrix4d inverse = joint_world.inverse().matrix();
    std::vector<float> ibm(16);
    for (int k = 0; k < 16; ++k)
    {
        ibm[static_cast<std::size_t>(k)] =
            static_cast<float>(inverse(k % 4, k / 4));  // column-major
    }
    const int pos = b.positions(xyz);
    const int mesh = b.mesh(Json::array(
        {{{"attributes",
           {{"POSITION", pos},
            {"JOINTS_0", b.accessor(b.view(GltfBuilder::raw(joints)), 0, 5121, n, "VEC4")},
            {"WEIGHTS_0", b.accessor(b.view(GltfBuilder::raw(weights)), 0, 5126, n, "VEC4")}}},
          {"indices", b.indices(idx)}}}));
    const int joint = b.node({{"translation", {0.3, -0.2, 0.1}},
                              {"rotation", {0.0, 0.0, std::sin(angle / 2), std::cos(angle / 2)}}});
    b.node({{"mesh", mesh}, {"skin", 0}});
    b.doc["skins"] = Json::array(
        {{{"joints", {joint}},
          {"inverseBindMatrices", b.accessor(b.view(GltfBuilder::raw(ibm)), 0, 5126, 1, "MAT4")}}});
    test::put_bytes(dir / "bind.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "bind.glb");
    ASSERT_EQ(file.mesh.V.rows(), 8);
    for (Eigen::Index v = 0; v < 8; ++v)
    {
        for (int d = 0; d < 3; ++d)
        {
            // The box's corners are 0 or 1 exactly; through the joints they would be off by
            // about 1e-7.
            EXPECT_TRUE(file.mesh.V(v, d) == 0.0 || file.mesh.V(v, d) == 1.0) << file.mesh.V(v, d);
        }
    }
}

// Two vertices a float32 step apart (a CAD model's repeated corners) moved alike must stay two:
// written as float32 their new coordinates would round to the same floats, and the reader
// would weld them (an IFC building lost 182 of its 16,942 vertices so, and its marked copy was
// no longer read vertex for vertex). The writer moves the later one on by float32 steps.
TEST_F(GltfTest, vertices_a_float_step_apart_stay_apart_when_moved_alike)
{
    const float a = 0.3F;
    const float b = std::nextafter(a, 1.0F);
    GltfBuilder g;
    const int pos = g.positions({a, 0, 0, b, 0, 0, 0, 1, 0, 0, 0, 1});
    g.node({{"mesh", g.mesh(Json::array({{{"attributes", {{"POSITION", pos}}},
                                          {"indices", g.indices({0, 2, 3, 1, 3, 2})}}}))}});
    test::put_bytes(dir / "close.glb", g.glb());
    const MeshFile file = read_mesh_file(dir / "close.glb");
    ASSERT_EQ(file.mesh.V.rows(), 4);
    Positions moved = file.mesh.V;
    moved.col(0).array() += 0.3;  // both land on 0.6000000238 in float32
    ASSERT_EQ(static_cast<float>(moved(0, 0)), static_cast<float>(moved(1, 0)));
    write_mesh_file(dir / "close_out.glb", file, moved);
    const MeshFile again = read_mesh_file(dir / "close_out.glb");
    ASSERT_EQ(again.mesh.V.rows(), 4);
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_NE(again.mesh.V(0, 0), again.mesh.V(1, 0));
}

TEST_F(GltfTest, sparse_accessor_positions_are_read_and_written_through)
{
    // Base positions in a view; the sparse part replaces elements 1 and 2.
    GltfBuilder b;
    const std::vector<float> base{0, 0, 0, 9, 9, 9, 9, 9, 9, 0, 1, 0};
    const std::vector<float> values{1, 0, 0, 1, 1, 0};
    const std::vector<std::uint16_t> which{1, 2};
    const int base_view = b.view(GltfBuilder::raw(base));
    const int index_view = b.view(GltfBuilder::raw(which));
    const int value_view = b.view(GltfBuilder::raw(values));
    const int pos = b.accessor(base_view, 0, 5126, 4, "VEC3");
    b.doc["accessors"][static_cast<std::size_t>(pos)]["sparse"] = {
        {"count", 2},
        {"indices", {{"bufferView", index_view}, {"componentType", 5123}}},
        {"values", {{"bufferView", value_view}}}};
    b.set_bounds(pos, {0, 0, 0, 1, 1, 0});
    const int mesh = b.mesh(Json::array(
        {{{"attributes", {{"POSITION", pos}}}, {"indices", b.indices({0, 1, 2, 0, 2, 3})}}}));
    b.node({{"mesh", mesh}});
    test::put_bytes(dir / "sparse.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "sparse.glb");
    ASSERT_EQ(file.mesh.V.rows(), 4);
    EXPECT_EQ(file.mesh.V(1, 0), 1.0);
    EXPECT_EQ(file.mesh.V(2, 1), 1.0);
    Positions moved = file.mesh.V;
    moved(1, 2) = 0.5;   // a sparse element
    moved(3, 2) = -0.5;  // a base element
    write_mesh_file(dir / "sparse_out.glb", file, moved);
    const Glb after = split(test::file_bytes(dir / "sparse_out.glb"));
    const Glb before = split(test::file_bytes(dir / "sparse.glb"));
    // The overridden base element 1 is untouched; the sparse value and base element 3 moved.
    const auto& views = after.json["bufferViews"];
    const std::size_t base_at = views[static_cast<std::size_t>(base_view)]["byteOffset"];
    const std::size_t value_at = views[static_cast<std::size_t>(value_view)]["byteOffset"];
    EXPECT_EQ(test::float_at(after.bin, base_at + 12 + 8), 9.0f);
    EXPECT_EQ(test::float_at(after.bin, value_at + 8), 0.5f);
    EXPECT_EQ(test::float_at(after.bin, base_at + 36 + 8), -0.5f);
    EXPECT_EQ(after.json["accessors"][static_cast<std::size_t>(pos)]["min"][2], -0.5);
    EXPECT_EQ(after.json["accessors"][static_cast<std::size_t>(pos)]["max"][2], 0.5);
    const MeshFile again = read_mesh_file(dir / "sparse_out.glb");
    EXPECT_EQ(again.mesh.V, moved);
    EXPECT_TRUE(tinygltf_reads(dir / "sparse_out.glb"));
    static_cast<void>(before);
}

TEST_F(GltfTest, quantized_positions_are_dequantized_and_requantized)
{
    // KHR_mesh_quantization: normalized int16 positions under a scaling node.
    GltfBuilder b;
    const std::vector<std::int16_t> q{0, 0, 0, 32767, 0, 0, 32767, 32767, 0, 0, 32767, 0};
    const int view = b.view(GltfBuilder::raw(q));
    const int pos = b.accessor(view, 0, 5122, 4, "VEC3", true);
    b.doc["accessors"][static_cast<std::size_t>(pos)]["min"] = {0, 0, 0};
    b.doc["accessors"][static_cast<std::size_t>(pos)]["max"] = {32767, 32767, 0};
    const int mesh = b.mesh(Json::array(
        {{{"attributes", {{"POSITION", pos}}}, {"indices", b.indices({0, 1, 2, 0, 2, 3})}}}));
    b.node({{"mesh", mesh}, {"scale", {4.0, 4.0, 4.0}}});
    b.doc["extensionsUsed"] = {"KHR_mesh_quantization"};
    b.doc["extensionsRequired"] = {"KHR_mesh_quantization"};
    test::put_bytes(dir / "q.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "q.glb");
    ASSERT_EQ(file.mesh.V.rows(), 4);
    EXPECT_DOUBLE_EQ(file.mesh.V(2, 0), 4.0);
    Positions moved = file.mesh.V;
    moved(2, 0) = 2.0;
    moved(0, 2) = -1.0;
    write_mesh_file(dir / "q_out.glb", file, moved);
    const MeshFile again = read_mesh_file(dir / "q_out.glb");
    // One int16 step of a 4-unit normalized range is 4 / 32767.
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 4.0 / 32767.0);
    const Glb after = split(test::file_bytes(dir / "q_out.glb"));
    EXPECT_EQ(after.json["accessors"][static_cast<std::size_t>(pos)]["min"][2], -8192);
    EXPECT_EQ(after.json["accessors"][static_cast<std::size_t>(pos)]["max"][0], 32767);
}

TEST_F(GltfTest, generic_writer_makes_valid_glb_and_gltf)
{
    TriangleMesh mesh;
    mesh.V.resize(4, 3);
    mesh.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0.1, 0.2, 1.0 / 3.0;
    mesh.F.resize(4, 3);
    mesh.F << 0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3;
    for (const char* name : {"w.glb", "w.gltf"})
    {
        write_mesh(dir / name, mesh);
        EXPECT_TRUE(tinygltf_reads(dir / name));
        const TriangleMesh again = read_mesh(dir / name);
        EXPECT_EQ(again.F, mesh.F);
        EXPECT_LT((again.V - mesh.V).cwiseAbs().maxCoeff(), 1e-7);
    }
}

// glTF 1.0 assets (2015-2016: collections keyed by name, a "version" string or number) are
// either refused by tinygltf with an unrelated reason or read as an empty scene; both are
// refused naming the version and the upgrade.
TEST_F(GltfTest, gltf_1_0_assets_are_refused_naming_the_version_and_the_upgrade)
{
    const auto expect_refused =
        [&](const std::string& name, const std::string& bytes, const std::string& version)
    {
        test::put_bytes(dir / name, bytes);
        try
        {
            static_cast<void>(read_mesh_file(dir / name));
            ADD_FAILURE() << name << " was accepted";
        }
        catch (const IoError& e)
        {
            const std::string what = e.what();
            EXPECT_NE(what.find(name), std::string::npos) << what;
            EXPECT_NE(what.find("glTF " + version + " is not supported"), std::string::npos)
                << what;
            EXPECT_NE(what.find("gltf-pipeline"), std::string::npos) << what;
        }
    };
    // The 1.0 layout, as collada2gltf wrote it (tinygltf reads it as a scene without meshes).
    const std::string v1 = R"({"asset": {"version": "1.0"}, "scene": "defaultScene",
        "scenes": {"defaultScene": {"nodes": ["node"]}}, "nodes": {"node": {"meshes": ["box"]}},
        "meshes": {"box": {"primitives": [{"attributes": {"POSITION": "pos"}, "mode": 4}]}},
        "accessors": {"pos": {"bufferView": "view", "byteOffset": 0, "componentType": 5126, "count": 3,
                              "type": "VEC3"}},
        "bufferViews": {"view": {"buffer": "buf", "byteOffset": 0, "byteLength": 36}},
        "buffers": {"buf": {"byteLength": 36, "uri": "data:application/octet-stream;base64,)" +
                           test::base64(std::string(36, '\0')) + R"("}}})";
    expect_refused("v1.gltf", v1, "1.0");
    // A numeric version (tinygltf refuses the asset object).
    std::string numeric = v1;
    numeric.replace(numeric.find(R"("version": "1.0")"), 16, R"("version": 1)");
    expect_refused("v1_number.gltf", numeric, "1");
    // No version at all, the 1.0 layout.
    std::string unversioned = v1;
    unversioned.replace(unversioned.find(R"("version": "1.0")"), 16, R"("generator": "x")");
    expect_refused("v1_unversioned.gltf", unversioned, "1.0");
    // A GLB container of version 1 (KHR_binary_glTF).
    std::string glb1 = two_boxes().builder.glb();
    glb1[4] = 1;
    try
    {
        test::put_bytes(dir / "v1.glb", glb1);
        static_cast<void>(read_mesh_file(dir / "v1.glb"));
        ADD_FAILURE() << "v1.glb was accepted";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("glTF 1.0 binary"), std::string::npos) << e.what();
    }
}

TEST_F(GltfTest, hostile_files_fail_with_one_sentence_naming_the_file)
{
    const auto t = two_boxes();
    const std::string glb = t.builder.glb();
    const auto expect_error = [&](const std::string& name, const std::string& bytes)
    {
        test::put_bytes(dir / name, bytes);
        try
        {
            static_cast<void>(read_mesh_file(dir / name));
            ADD_FAILURE() << name << " was accepted";
        }
        catch (const Error& e)
        {
            EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
        }
    };
    expect_error("truncated.glb", glb.substr(0, glb.size() - 10));
    expect_error("not.glb", "hello world, this is not binary glTF");
    expect_error("bad.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [");

    // Index past the end of the positions.
    GltfBuilder b;
    const int pos = b.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    b.node({{"mesh", b.mesh(Json::array({{{"attributes", {{"POSITION", pos}}},
                                          {"indices", b.indices({0, 1, 7})}}}))}});
    expect_error("index.glb", b.glb());

    // A cycle in the node tree.
    GltfBuilder c;
    const int p2 = c.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const int m2 = c.mesh(Json::array({{{"attributes", {{"POSITION", p2}}}}}));
    c.node({{"mesh", m2}, {"children", {1}}});
    c.node({{"children", {0}}}, false);
    expect_error("cycle.glb", c.glb());

    // An accessor reaching past its bufferView.
    GltfBuilder d;
    const int p3 = d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    d.doc["accessors"][static_cast<std::size_t>(p3)]["count"] = 300;
    d.node({{"mesh", d.mesh(Json::array({{{"attributes", {{"POSITION", p3}}}}}))}});
    expect_error("overrun.glb", d.glb());

    // A Draco extension whose attributes are not an object (tinygltf::Value::Get asserts).
    GltfBuilder e;
    const int p4 = e.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    e.node({{"mesh", e.mesh(Json::array({{{"attributes", {{"POSITION", p4}}},
                                          {"extensions",
                                           {{"KHR_draco_mesh_compression",
                                             {{"bufferView", 0}, {"attributes", 5}}}}}}}))}});
    expect_error("draco_ext.glb", e.glb());

    // Skins: a joint index past the skin's joints, a JOINTS_0 that is not a VEC4, a skin that
    // does not exist.
    for (const std::string bad : {"joint_index", "joints_type", "missing_skin"})
    {
        GltfBuilder f;
        const int p5 = f.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
        const std::vector<std::uint8_t> joints{
            0, 0, 0, 0, 0, 0, 0, 0, static_cast<std::uint8_t>(bad == "joint_index" ? 3 : 0),
            0, 0, 0};
        const std::vector<float> weights{1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
        const int j =
            f.accessor(f.view(GltfBuilder::raw(joints)), 0, 5121, bad == "joints_type" ? 4 : 3,
                       bad == "joints_type" ? "VEC3" : "VEC4");
        const int w = f.accessor(f.view(GltfBuilder::raw(weights)), 0, 5126, 3, "VEC4");
        const int joint = f.node({{"name", "joint"}, {"translation", {0.0, 1.0, 0.0}}});
        f.node({{"mesh",
                 f.mesh(Json::array(
                     {{{"attributes", {{"POSITION", p5}, {"JOINTS_0", j}, {"WEIGHTS_0", w}}}}}))},
                {"skin", bad == "missing_skin" ? 4 : 0}});
        f.doc["skins"] = Json::array({{{"joints", {joint}}}});
        expect_error("skin_" + bad + ".glb", f.glb());
    }
}

}  // namespace
}  // namespace meshmark
