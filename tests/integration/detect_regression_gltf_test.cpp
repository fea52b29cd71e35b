// SPDX-License-Identifier: MIT
// The regression test's situational paths and glTF groups (see detect_regression_test.cpp for
// what is compared and how the expectations are regenerated): a registration that does not
// converge, the bits verdict, a Draco-compressed and an instanced glTF.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#include <gtest/gtest.h>

#include "detect_regression_support.h"
#include "gltf_test_support.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"
#include "support/test_shapes.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using namespace regression;  // detect_regression_support.h

// The lumpy ellipsoid's positions (float) and triangles (uint16), as a glTF stores them.
void gltf_arrays(const TriangleMesh& shape, std::vector<float>& xyz,
                 std::vector<std::uint16_t>& idx)
{
    for (Eigen::Index v = 0; v < shape.V.rows(); ++v)
    {
        for (int c = 0; c < 3; ++c)
        {
            xyz.push_back(static_cast<float>(shape.V(v, c)));
        }
    }
    for (Eigen::Index f = 0; f < shape.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            idx.push_back(static_cast<std::uint16_t>(shape.F(f, c)));
        }
    }
}

// A GLB whose one primitive is \p shape Draco-compressed (KHR_draco_mesh_compression:
// edgebreaker, 14-bit positions, Draco's defaults), under one node.
std::string draco_glb(const TriangleMesh& shape)
{
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(static_cast<int>(shape.F.rows()));
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    for (Eigen::Index f = 0; f < shape.F.rows(); ++f)
    {
        std::array<std::array<float, 3>, 3> p{};
        for (int c = 0; c < 3; ++c)
        {
            for (int k = 0; k < 3; ++k)
            {
                p[static_cast<std::size_t>(c)][static_cast<std::size_t>(k)] =
                    static_cast<float>(shape.V(shape.F(f, c), k));
            }
        }
        builder.SetAttributeValuesForFace(pos, draco::FaceIndex(static_cast<std::uint32_t>(f)),
                                          p[0].data(), p[1].data(), p[2].data());
    }
    const std::unique_ptr<draco::Mesh> mesh = builder.Finalize();
    draco::Encoder encoder;
    encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 14);
    encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
    draco::EncoderBuffer out;
    EXPECT_TRUE(encoder.EncodeMeshToBuffer(*mesh, &out).ok());

    test::GltfBuilder b;
    const int view = b.view(std::string(out.data(), out.size()));
    const auto position = static_cast<int>(b.doc["accessors"].size());
    b.doc["accessors"].push_back(
        {{"componentType", 5126},
         {"count", mesh->num_points()},
         {"type", "VEC3"},
         {"min", {shape.V.col(0).minCoeff(), shape.V.col(1).minCoeff(), shape.V.col(2).minCoeff()}},
         {"max",
          {shape.V.col(0).maxCoeff(), shape.V.col(1).maxCoeff(), shape.V.col(2).maxCoeff()}}});
    const auto indices = static_cast<int>(b.doc["accessors"].size());
    b.doc["accessors"].push_back(
        {{"componentType", 5125}, {"count", 3 * mesh->num_faces()}, {"type", "SCALAR"}});
    const int gltf_mesh = b.mesh(test::Json::array(
        {{{"attributes", {{"POSITION", position}}},
          {"indices", indices},
          {"material", 0},
          {"extensions",
           {{"KHR_draco_mesh_compression",
             {{"bufferView", view},
              {"attributes", {{"POSITION", mesh->attribute(pos)->unique_id()}}}}}}}}}));
    b.node({{"mesh", gltf_mesh}});
    b.doc["extensionsUsed"] = {"KHR_draco_mesh_compression"};
    b.doc["extensionsRequired"] = {"KHR_draco_mesh_compression"};
    return b.glb();
}

// Whether the GLB at \p path still stores its geometry Draco-compressed.
bool is_draco(const fs::path& path)
{
    const test::Json doc = test::glb_json(test::slurp(path));
    return doc.contains("extensionsUsed") &&
           doc.at("extensionsUsed").dump().find("KHR_draco_mesh_compression") != std::string::npos;
}

// Situational paths of detection on the generated ellipsoid (embedded as in the "ellipsoid"
// group): a copy under noise of 20% of the diagonal, renumbered, whose registration does not
// converge (its trimmed RMS error is above RegistrationOptions::max_rms_rel), and the bits
// verdict (--verdict bits: R against --threshold) on the marked copy and on a moved, renumbered
// one (registered without the symmetry search, which the bits verdict skips).
TEST(DetectRegression, generated_paths)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("paths");
    write_mesh(g.at("original.ply"), lumpy_ellipsoid(4));
    g.embed("marked", g.at("original.ply"), "marked.ply", "key.json", 101);
    g.attack("marked.ply", "noise=0.2,reorder", 11, "not_converged.ply");
    g.detect("not_converged", "not_converged.ply", g.at("original.ply"), "key.json");
    EXPECT_EQ(g.report("not_converged")["registration"]["method"], "registration (not converged)")
        << "the case no longer takes the path it is there for";
    g.detect("marked_bits", "marked.ply", g.at("original.ply"), "key.json", "--verdict bits");
    g.attack("marked.ply", "similarity,reorder", 3, "similarity_reorder.ply");
    g.detect("similarity_reorder_bits", "similarity_reorder.ply", g.at("original.ply"), "key.json",
             "--verdict bits");
    for (const char* label : {"marked_bits", "similarity_reorder_bits"})
    {
        EXPECT_EQ(g.report(label)["verdict"], "bits") << label;
    }
    g.finish();
}

// A Draco-compressed glTF (edgebreaker, 14-bit positions): embed re-encodes the marked
// positions into Draco data (its points renumbered by edgebreaker's traversal), read back where
// they stand; the marked copy moved and renumbered, and the unmarked original.
TEST(DetectRegression, gltf_draco)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("draco");
    test::put_bytes(g.at("original.glb"), draco_glb(lumpy_ellipsoid(4)));
    g.embed("marked", g.at("original.glb"), "marked.glb", "key.json", 909);
    EXPECT_TRUE(is_draco(g.at("marked.glb"))) << "embed no longer writes Draco data";
    g.detect("marked", "marked.glb", g.at("original.glb"), "key.json");
    g.attack("marked.glb", "similarity,reorder", 1, "similarity_reorder.ply");
    g.detect("similarity_reorder", "similarity_reorder.ply", g.at("original.glb"), "key.json");
    g.detect("unmarked", "original.glb", g.at("original.glb"), "key.json");
    g.finish();
}

// An instanced glTF: one mesh (the lumpy ellipsoid) shown by three nodes (moved, turned,
// scaled). Embed marks the stored positions once (every instance shows the mark); detection reads
// the marked file, and a flattened copy that shows every instance as geometry of its own
// (as gltf-transform's join leaves it), renumbered, registered against all the instances.
TEST(DetectRegression, gltf_instanced)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("instanced");
    std::vector<float> xyz;
    std::vector<std::uint16_t> idx;
    gltf_arrays(lumpy_ellipsoid(4), xyz, idx);
    test::GltfBuilder b;
    const int mesh = b.mesh(test::Json::array(
        {{{"attributes", {{"POSITION", b.positions(xyz)}}}, {"indices", b.indices(idx)}}}));
    b.node({{"mesh", mesh}, {"translation", {3.0, 0.0, 0.0}}});
    b.node({{"mesh", mesh}, {"translation", {-3.0, 0.0, 0.0}}, {"rotation", {0.0, 0.0, 0.6, 0.8}}});
    b.node({{"mesh", mesh}, {"translation", {0.0, 3.0, 1.0}}, {"scale", {0.5, 0.5, 0.5}}});
    test::put_bytes(g.at("original.glb"), b.glb());
    g.embed("marked", g.at("original.glb"), "marked.glb", "key.json", 1010);
    const MeshFile marked = read_mesh_file(g.at("marked.glb"));
    ASSERT_EQ(marked.instances.V.rows(), 2 * static_cast<Eigen::Index>(xyz.size() / 3))
        << "the marked file no longer shows its mesh through three nodes";
    g.detect("marked", "marked.glb", g.at("original.glb"), "key.json");
    TriangleMesh flat;
    const Eigen::Index n = marked.mesh.V.rows();
    flat.V.resize(n + marked.instances.V.rows(), 3);
    flat.V << marked.mesh.V, marked.instances.V;
    flat.F.resize(marked.mesh.F.rows() + marked.instances.F.rows(), 3);
    flat.F << marked.mesh.F, (marked.instances.F.array() + static_cast<std::int32_t>(n)).matrix();
    write_mesh(g.at("flattened.ply"), flat);
    g.attack("flattened.ply", "reorder", 1, "flattened_reordered.ply");
    g.detect("flattened_reordered", "flattened_reordered.ply", g.at("original.glb"), "key.json");
    g.finish();
}

}  // namespace
}  // namespace meshmark
