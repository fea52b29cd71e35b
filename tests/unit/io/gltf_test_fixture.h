// SPDX-License-Identifier: MIT
// The fixture and assets shared by the glTF tests (gltf_*_test.cpp): a GLB's two chunks, a box
// with per-face normals, two boxes under a node tree.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "gltf_test_support.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark::test
{

class GltfTest : public ::testing::Test
{
protected:
    std::filesystem::path dir = test::temp_dir("gltf_test");
};
struct Glb
{
    Json json;
    std::string bin;
};

inline Glb split(const std::string& bytes)
{
    Glb glb;
    glb.json = test::glb_json(bytes, &glb.bin);
    return glb;
}

// The unit box [0,1]^3 as 24 corners (4 per face, so every corner appears 3 times, as a
// glTF exporter writes a box with per-face normals) and 12 triangles.
inline void box_faces(std::vector<float>& xyz, std::vector<float>& normals,
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
inline std::vector<double> column_major(const Eigen::Matrix4d& m)
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

inline TwoBoxes two_boxes()
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
}  // namespace meshmark::test
