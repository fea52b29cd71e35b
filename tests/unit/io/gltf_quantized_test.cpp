// SPDX-License-Identifier: MIT
// KHR_mesh_quantization as the ecosystem's tools write it (gltfpack: unsigned 14-bit integers
// under a node that dequantizes them; glTF-Transform: normalized int16, also inside Draco):
// marked positions that leave the integer range widen the grid (node transform adjusted) or
// turn the accessor into float32, never refused and never clamped; Draco integer positions
// are re-encoded as integers.
#include <cmath>

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#include <gtest/gtest.h>

#include "gltf_test_support.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::GltfBuilder;
using test::Json;

constexpr int kGrid = 5;

// Stored integer positions of a kGrid x kGrid wavy patch spanning [0, top] in x and y.
std::vector<std::int32_t> patch_values(int low, int top)
{
    std::vector<std::int32_t> q;
    for (int i = 0; i < kGrid; ++i)
    {
        for (int j = 0; j < kGrid; ++j)
        {
            const double x = i / double(kGrid - 1);
            const double y = j / double(kGrid - 1);
            q.push_back(low + static_cast<std::int32_t>(std::lround((top - low) * x)));
            q.push_back(low + static_cast<std::int32_t>(std::lround((top - low) * y)));
            q.push_back(low + static_cast<std::int32_t>(
                                  std::lround((top - low) * (0.5 + 0.4 * std::sin(3.0 * x + y)))));
        }
    }
    return q;
}

std::vector<std::uint16_t> patch_triangles()
{
    std::vector<std::uint16_t> t;
    for (int i = 0; i + 1 < kGrid; ++i)
    {
        for (int j = 0; j + 1 < kGrid; ++j)
        {
            const auto v = static_cast<std::uint16_t>(i * kGrid + j);
            const auto right = static_cast<std::uint16_t>(v + kGrid);
            t.insert(t.end(),
                     {v, right, static_cast<std::uint16_t>(right + 1), v,
                      static_cast<std::uint16_t>(right + 1), static_cast<std::uint16_t>(v + 1)});
        }
    }
    return t;
}

template <typename T>
std::vector<T> narrowed(const std::vector<std::int32_t>& values)
{
    return {values.begin(), values.end()};
}

// Bounds of VEC3 integer values, as glTF requires them on a POSITION accessor.
void set_int_bounds(GltfBuilder& b, int accessor, const std::vector<std::int32_t>& q)
{
    std::array<std::int32_t, 3> lo{INT32_MAX, INT32_MAX, INT32_MAX};
    std::array<std::int32_t, 3> hi{INT32_MIN, INT32_MIN, INT32_MIN};
    for (std::size_t k = 0; k < q.size(); ++k)
    {
        lo[k % 3] = std::min(lo[k % 3], q[k]);
        hi[k % 3] = std::max(hi[k % 3], q[k]);
    }
    b.doc["accessors"][static_cast<std::size_t>(accessor)]["min"] = lo;
    b.doc["accessors"][static_cast<std::size_t>(accessor)]["max"] = hi;
}

void mark_quantized(GltfBuilder& b)
{
    b.doc["extensionsUsed"] = {"KHR_mesh_quantization"};
    b.doc["extensionsRequired"] = {"KHR_mesh_quantization"};
}

class GltfQuantizedTest : public ::testing::Test
{
protected:
    fs::path dir = test::temp_dir("gltf_quantized_test");

    // Writes \p moved over \p file, reads it back, and checks every vertex against \p moved
    // within \p step (the world size of one grid step) per axis.
    Json write_and_check(const MeshFile& file, const Positions& moved, const fs::path& out,
                         double step)
    {
        write_mesh_file(out, file, moved);
        const MeshFile again = read_mesh_file(out);
        EXPECT_EQ(again.mesh.V.rows(), moved.rows());
        EXPECT_EQ(again.mesh.F, file.mesh.F);
        if (again.mesh.V.rows() == moved.rows())
        {
            EXPECT_LE((again.mesh.V - moved).cwiseAbs().maxCoeff(), step) << out;
        }
        return test::glb_json(test::file_bytes(out));
    }
};

TEST_F(GltfQuantizedTest, gltfpack_layout_shifts_its_grid_when_a_mark_leaves_the_type)
{
    // gltfpack's default: unsigned, not normalized, 14-bit values in [0, 16383], dequantized
    // by the node's translation and uniform scale.
    GltfBuilder b;
    const auto q = patch_values(0, 16383);
    const int pos = b.accessor(b.view(GltfBuilder::raw(narrowed<std::uint16_t>(q))), 0, 5123,
                               q.size() / 3, "VEC3");
    set_int_bounds(b, pos, q);
    const int mesh = b.mesh(Json::array(
        {{{"attributes", {{"POSITION", pos}}}, {"indices", b.indices(patch_triangles())}}}));
    const double scale = 1.0 / 16383.0;
    b.node({{"mesh", mesh}, {"translation", {-0.5, -0.25, 2.0}}, {"scale", {scale, scale, scale}}});
    mark_quantized(b);
    test::put_bytes(dir / "pack.glb", b.glb());

    const MeshFile file = read_mesh_file(dir / "pack.glb");
    ASSERT_EQ(file.mesh.V.rows(), kGrid * kGrid);
    Positions moved = file.mesh.V;
    moved(0, 0) -= 2.6 * scale;  // stored x = -2.6: below what an unsigned type holds
    moved(7, 2) += 0.3 * scale;
    const Json after = write_and_check(file, moved, dir / "pack_out.glb", 0.5 * scale + 1e-12);
    const auto& acc = after["accessors"][static_cast<std::size_t>(pos)];
    EXPECT_EQ(acc["componentType"], 5123);  // still quantized, not float
    EXPECT_EQ(acc["min"][0], 0);            // shifted by a whole 3 steps: -2.6 -> 0.4 -> 0
    EXPECT_EQ(acc["max"][0], 16383 + 3);
    const auto& node = after["nodes"][0];
    EXPECT_NEAR(node["translation"][0].get<double>(), -0.5 - 3 * scale, 1e-15);
    EXPECT_EQ(node["translation"][1].get<double>(), -0.25);
    EXPECT_EQ(node["scale"][0].get<double>(), scale);
    // A whole-step shift keeps every unmoved vertex exactly where it was (up to the double
    // rounding of the new translation).
    const MeshFile again = read_mesh_file(dir / "pack_out.glb");
    for (Eigen::Index i = 1; i < moved.rows(); ++i)
    {
        if (i != 7)
        {
            EXPECT_LE((again.mesh.V.row(i) - file.mesh.V.row(i)).cwiseAbs().maxCoeff(), 1e-12) << i;
        }
    }
}

TEST_F(GltfQuantizedTest, full_range_normalized_int16_scales_its_grid_and_the_node)
{
    // glTF-Transform's quantize: normalized int16 spanning [-32767, 32767] on the largest axis.
    GltfBuilder b;
    const auto q = patch_values(-32767, 32767);
    const int pos = b.accessor(b.view(GltfBuilder::raw(narrowed<std::int16_t>(q))), 0, 5122,
                               q.size() / 3, "VEC3", true);
    set_int_bounds(b, pos, q);
    const int mesh = b.mesh(Json::array(
        {{{"attributes", {{"POSITION", pos}}}, {"indices", b.indices(patch_triangles())}}}));
    b.node({{"mesh", mesh},
            {"translation", {0.0, 0.1, 0.2}},
            {"rotation", {0.0, 0.0, std::sin(0.3), std::cos(0.3)}},
            {"scale", {0.8, 0.8, 0.8}}});
    mark_quantized(b);
    test::put_bytes(dir / "gt.glb", b.glb());

    const MeshFile file = read_mesh_file(dir / "gt.glb");
    Positions moved = file.mesh.V;
    for (Eigen::Index i = 0; i < moved.rows(); i += 3)
    {
        moved.row(i) *= 1.001;  // several vertices pushed outside the full range
    }
    // Half a step of the widened grid per local axis; the node's rotation mixes x and y, so a
    // world axis sees up to sqrt(3) times that.
    const double step = 0.8 / 32767.0 * 1.002;
    const Json after =
        write_and_check(file, moved, dir / "gt_out.glb", 0.5 * step * std::sqrt(3.0));
    const auto& acc = after["accessors"][static_cast<std::size_t>(pos)];
    EXPECT_EQ(acc["componentType"], 5122);
    EXPECT_EQ(acc["normalized"], true);
    EXPECT_GE(acc["min"][0].get<int>(), -32767);
    EXPECT_LE(acc["max"][0].get<int>(), 32767);
    const double new_scale = after["nodes"][0]["scale"][0].get<double>();
    EXPECT_GT(new_scale, 0.8);
    EXPECT_LT(new_scale, 0.8 * 1.01);
    EXPECT_EQ(after["nodes"][0]["rotation"], b.doc["nodes"][0]["rotation"]);
}

TEST_F(GltfQuantizedTest, overflow_that_a_node_transform_cannot_absorb_becomes_float32)
{
    // The quantizing node has a child: changing its transform would move the child, so the
    // accessor is written as float32 and nothing else changes.
    GltfBuilder b;
    const auto q = patch_values(0, 255);
    const int pos = b.accessor(b.view(GltfBuilder::raw(narrowed<std::uint8_t>(q))), 0, 5121,
                               q.size() / 3, "VEC3", true);
    set_int_bounds(b, pos, q);
    const int mesh = b.mesh(Json::array(
        {{{"attributes", {{"POSITION", pos}}}, {"indices", b.indices(patch_triangles())}}}));
    const int child_positions = b.positions({3, 0, 0, 4, 0, 0, 3, 1, 0});
    const int child =
        b.node({{"mesh", b.mesh(Json::array({{{"attributes", {{"POSITION", child_positions}}}}}))}},
               false);
    b.node({{"mesh", mesh}, {"scale", {2.0, 2.0, 2.0}}, {"children", {child}}});
    b.doc["nodes"][static_cast<std::size_t>(child)]["translation"] = {0.0, 0.0, 1.0};
    mark_quantized(b);
    test::put_bytes(dir / "u8.glb", b.glb());

    const MeshFile file = read_mesh_file(dir / "u8.glb");
    Positions moved = file.mesh.V;
    moved(0, 0) -= 0.01;  // below 0 of an unsigned normalized type
    moved(3, 1) += 0.002;
    const Json after = write_and_check(file, moved, dir / "u8_out.glb", 1e-6);
    const auto& acc = after["accessors"][static_cast<std::size_t>(pos)];
    EXPECT_EQ(acc["componentType"], 5126);
    EXPECT_FALSE(acc.contains("normalized"));
    EXPECT_EQ(acc["min"].size(), 3U);
    EXPECT_EQ(after["nodes"], b.doc["nodes"]);  // no transform changed
    EXPECT_EQ(after["meshes"], b.doc["meshes"]);
}

// A Draco primitive whose positions are normalized int16, as `gltf-transform quantize`
// followed by `gltf-transform draco` writes it: the attribute holds integers, the accessor
// says SHORT normalized, the node scales.
std::string draco_int16_patch(const std::vector<std::int32_t>& q, int* position_id, int* points)
{
    const auto triangles = patch_triangles();
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(static_cast<int>(triangles.size() / 3));
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_INT16);
    for (std::size_t t = 0; t < triangles.size() / 3; ++t)
    {
        std::array<std::array<std::int16_t, 3>, 3> p{};
        for (std::size_t c = 0; c < 3; ++c)
        {
            for (std::size_t d = 0; d < 3; ++d)
            {
                p[c][d] = static_cast<std::int16_t>(q[3 * triangles[3 * t + c] + d]);
            }
        }
        builder.SetAttributeValuesForFace(pos, draco::FaceIndex(static_cast<std::uint32_t>(t)),
                                          p[0].data(), p[1].data(), p[2].data());
    }
    auto mesh = builder.Finalize();
    draco::Encoder encoder;
    encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
    draco::EncoderBuffer out;
    EXPECT_TRUE(encoder.EncodeMeshToBuffer(*mesh, &out).ok());
    *position_id = static_cast<int>(mesh->attribute(pos)->unique_id());
    *points = static_cast<int>(mesh->num_points());
    return {out.data(), out.size()};
}

GltfBuilder draco_int16_asset(const std::vector<std::int32_t>& q)
{
    GltfBuilder b;
    int position_id = 0;
    int points = 0;
    const int view = b.view(draco_int16_patch(q, &position_id, &points));
    b.doc["accessors"].push_back({{"componentType", 5122},
                                  {"normalized", true},
                                  {"count", points},
                                  {"type", "VEC3"},
                                  {"min", {-32767, -32767, -32767}},
                                  {"max", {32767, 32767, 32767}}});
    b.doc["accessors"].push_back(
        {{"componentType", 5125}, {"count", patch_triangles().size()}, {"type", "SCALAR"}});
    const int mesh = b.mesh(
        Json::array({{{"attributes", {{"POSITION", 0}}},
                      {"indices", 1},
                      {"extensions",
                       {{"KHR_draco_mesh_compression",
                         {{"bufferView", view}, {"attributes", {{"POSITION", position_id}}}}}}}}}));
    b.node({{"mesh", mesh}, {"translation", {0.0, 0.5, 0.25}}, {"scale", {0.9, 0.9, 0.9}}});
    b.doc["extensionsUsed"] = {"KHR_draco_mesh_compression", "KHR_mesh_quantization"};
    b.doc["extensionsRequired"] = {"KHR_draco_mesh_compression", "KHR_mesh_quantization"};
    return b;
}

std::vector<std::array<double, 3>> decoded_int16(const std::string& glb)
{
    std::string bin;
    const Json doc = test::glb_json(glb, &bin);
    const auto& view = doc["bufferViews"][0];
    const std::string bytes =
        bin.substr(view.value("byteOffset", 0U), view["byteLength"].get<std::size_t>());
    draco::DecoderBuffer buffer;
    buffer.Init(bytes.data(), bytes.size());
    draco::Decoder decoder;
    auto mesh = std::move(decoder.DecodeMeshFromBuffer(&buffer)).value();
    const auto* attribute = mesh->GetNamedAttribute(draco::GeometryAttribute::POSITION);
    EXPECT_EQ(attribute->data_type(), draco::DT_INT16);
    std::vector<std::array<double, 3>> values;
    for (draco::AttributeValueIndex i(0); i < attribute->size(); ++i)
    {
        std::array<std::int16_t, 3> v{};
        attribute->GetValue(i, v.data());
        values.push_back({double(v[0]), double(v[1]), double(v[2])});
    }
    return values;
}

TEST_F(GltfQuantizedTest, draco_with_normalized_int16_positions_stays_int16_and_in_place)
{
    const auto q = patch_values(-20000, 20000);
    const GltfBuilder b = draco_int16_asset(q);
    test::put_bytes(dir / "dq.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "dq.glb");
    ASSERT_EQ(file.mesh.V.rows(), kGrid * kGrid);
    // Dequantized and under the node: x of the first vertex is 0.9 * -20000 / 32767.
    EXPECT_NEAR(file.mesh.V.col(0).minCoeff(), 0.9 * -20000.0 / 32767.0, 1e-12);
    Positions moved = file.mesh.V;
    moved.col(2).array() += 0.001;
    moved(4, 0) += 0.002;
    const double step = 0.9 / 32767.0;
    const Json after = write_and_check(file, moved, dir / "dq_out.glb", 0.5 * step + 1e-12);
    EXPECT_EQ(after["nodes"], b.doc["nodes"]);  // everything fit: no transform changed
    // libdraco decodes the new stream to int16 values on the new positions' grid.
    const auto values = decoded_int16(test::file_bytes(dir / "dq_out.glb"));
    double lo = 1e9;
    for (const auto& v : values)
    {
        lo = std::min(lo, v[0]);
    }
    EXPECT_EQ(lo, -20000.0);
    EXPECT_EQ(after["accessors"][0]["min"][0], -20000);
}

TEST_F(GltfQuantizedTest, draco_int16_overflow_widens_the_grid_through_the_node)
{
    const auto q = patch_values(-32767, 32767);
    const GltfBuilder b = draco_int16_asset(q);
    test::put_bytes(dir / "dfull.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "dfull.glb");
    Positions moved = file.mesh.V;
    moved.row(0) *= 1.002;
    moved.row(24) *= 1.002;
    const double step = 0.9 / 32767.0 * 1.003;
    const Json after = write_and_check(file, moved, dir / "dfull_out.glb", 0.5 * step + 1e-12);
    EXPECT_GT(after["nodes"][0]["scale"][0].get<double>(), 0.9);
    for (const auto& v : decoded_int16(test::file_bytes(dir / "dfull_out.glb")))
    {
        for (const double c : v)
        {
            EXPECT_LE(std::abs(c), 32767.0);
        }
    }
}

TEST_F(GltfQuantizedTest, draco_int16_overflow_under_a_parent_node_becomes_float32)
{
    // The Draco primitive's node has a child: its transform cannot change, so the position
    // attribute becomes float32 (same Draco attribute id) and the accessor FLOAT.
    const auto q = patch_values(-32767, 32767);
    GltfBuilder b = draco_int16_asset(q);
    const int leaf = b.positions({3, 0, 0, 4, 0, 0, 3, 1, 0});
    const int child =
        b.node({{"mesh", b.mesh(Json::array({{{"attributes", {{"POSITION", leaf}}}}}))}}, false);
    b.doc["nodes"][0]["children"] = {child};
    test::put_bytes(dir / "dparent.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "dparent.glb");
    Positions moved = file.mesh.V;
    moved.row(0) *= 1.002;
    moved(3, 1) += 0.001;
    // 16 bits over the new extent (about 1.8 units): half a step is 1.4e-5.
    const Json after = write_and_check(file, moved, dir / "dparent_out.glb", 2e-5);
    EXPECT_EQ(after["nodes"], b.doc["nodes"]);
    EXPECT_EQ(after["accessors"][0]["componentType"], 5126);
    EXPECT_FALSE(after["accessors"][0].contains("normalized"));
    EXPECT_EQ(after["meshes"][0]["primitives"][0]["extensions"],
              b.doc["meshes"][0]["primitives"][0]["extensions"]);
    std::string bin;
    const Json doc = test::glb_json(test::file_bytes(dir / "dparent_out.glb"), &bin);
    const auto& view = doc["bufferViews"][0];
    const std::string bytes =
        bin.substr(view.value("byteOffset", 0U), view["byteLength"].get<std::size_t>());
    draco::DecoderBuffer buffer;
    buffer.Init(bytes.data(), bytes.size());
    draco::Decoder decoder;
    auto mesh = std::move(decoder.DecodeMeshFromBuffer(&buffer)).value();
    EXPECT_EQ(mesh->GetNamedAttribute(draco::GeometryAttribute::POSITION)->data_type(),
              draco::DT_FLOAT32);
}

TEST_F(GltfQuantizedTest, skinned_morphed_multi_scene_asset_changes_only_positions)
{
    // Default scene: a skinned, morphed mesh with full-range normalized int16 positions (its
    // node cannot change: the skin) and a quantized mesh under a plain node. Scene 1: a mesh
    // that the default scene does not show. Plus an embedded image.
    GltfBuilder b;
    const auto q = patch_values(-32767, 32767);
    const auto points = q.size() / 3;
    const int skinned = b.accessor(b.view(GltfBuilder::raw(narrowed<std::int16_t>(q))), 0, 5122,
                                   points, "VEC3", true);
    set_int_bounds(b, skinned, q);
    const int joints = b.accessor(b.view(std::string(4 * points, '\0')), 0, 5121, points, "VEC4");
    std::vector<float> w(4 * points, 0.0f);
    for (std::size_t i = 0; i < points; ++i)
    {
        w[4 * i] = 1.0f;
    }
    const int weights = b.accessor(b.view(GltfBuilder::raw(w)), 0, 5126, points, "VEC4");
    std::vector<float> deltas(3 * points, 0.0f);
    deltas[2] = 0.25f;
    const int target = b.accessor(b.view(GltfBuilder::raw(deltas)), 0, 5126, points, "VEC3");
    b.set_bounds(target, deltas);
    const std::vector<float> identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    const int ibm = b.accessor(b.view(GltfBuilder::raw(identity)), 0, 5126, 1, "MAT4");
    const int tris = b.indices(patch_triangles());
    const int skinned_mesh = b.mesh(Json::array(
        {{{"attributes", {{"POSITION", skinned}, {"JOINTS_0", joints}, {"WEIGHTS_0", weights}}},
          {"targets", Json::array({{{"POSITION", target}}})},
          {"indices", tris}}}));
    const auto u = patch_values(0, 16383);
    const int packed = b.accessor(b.view(GltfBuilder::raw(narrowed<std::uint16_t>(u))), 0, 5123,
                                  u.size() / 3, "VEC3");
    set_int_bounds(b, packed, u);
    const int packed_mesh =
        b.mesh(Json::array({{{"attributes", {{"POSITION", packed}}}, {"indices", tris}}}));
    const int hidden = b.positions({0, 0, 9, 1, 0, 9, 0, 1, 9});
    const int hidden_mesh = b.mesh(Json::array({{{"attributes", {{"POSITION", hidden}}}}}));
    const int joint = b.node({{"name", "joint"}});
    b.node({{"mesh", skinned_mesh}, {"skin", 0}, {"scale", {0.5, 0.5, 0.5}}});
    b.node(
        {{"mesh", packed_mesh}, {"translation", {3.0, 0.0, 0.0}}, {"scale", {1e-4, 1e-4, 1e-4}}});
    const int other = b.node({{"mesh", hidden_mesh}}, false);
    b.doc["scenes"].push_back({{"nodes", {other}}});
    b.doc["skins"] = Json::array({{{"joints", {joint}}, {"inverseBindMatrices", ibm}}});
    const std::string png = "\x89PNG\r\n\x1a\nnot really an image";
    b.doc["images"] = Json::array({{{"bufferView", b.view(png)}, {"mimeType", "image/png"}}});
    mark_quantized(b);
    test::put_bytes(dir / "rig.glb", b.glb());

    const MeshFile file = read_mesh_file(dir / "rig.glb");
    ASSERT_EQ(file.mesh.V.rows(), 2 * kGrid * kGrid);  // the scene-1 triangle is not read
    Positions moved = file.mesh.V;
    for (Eigen::Index i = 0; i < moved.rows(); ++i)
    {
        moved.row(i) = 1.001 * moved.row(i) + Eigen::RowVector3d(0.0, 0.0, 1e-3);
    }
    // Half a step of the 1e-4 grid of the packed mesh; the skinned one becomes float32.
    const Json after = write_and_check(file, moved, dir / "rig_out.glb", 0.5e-4 + 1e-9);

    // The skinned accessor became float32 (the skin's node cannot change); the other one kept
    // its type under a changed node; joints, weights, morph deltas, the inverse bind
    // matrices, the image, the hidden mesh and every node but the quantizing one are as read.
    EXPECT_EQ(after["accessors"][static_cast<std::size_t>(skinned)]["componentType"], 5126);
    EXPECT_EQ(after["accessors"][static_cast<std::size_t>(packed)]["componentType"], 5123);
    for (const char* member : {"skins", "images", "meshes", "scenes"})
    {
        EXPECT_EQ(after[member], b.doc[member]) << member;
    }
    for (const int n : {0, 1, 3})
    {
        EXPECT_EQ(after["nodes"][static_cast<std::size_t>(n)],
                  b.doc["nodes"][static_cast<std::size_t>(n)]);
    }
    const std::string before_bin = b.bin;
    std::string after_bin;
    static_cast<void>(test::glb_json(test::file_bytes(dir / "rig_out.glb"), &after_bin));
    ASSERT_GE(after_bin.size(), before_bin.size());
    for (const int view :
         {after["accessors"][static_cast<std::size_t>(joints)]["bufferView"].get<int>(),
          after["accessors"][static_cast<std::size_t>(weights)]["bufferView"].get<int>(),
          after["accessors"][static_cast<std::size_t>(target)]["bufferView"].get<int>(),
          after["accessors"][static_cast<std::size_t>(ibm)]["bufferView"].get<int>(),
          after["accessors"][static_cast<std::size_t>(hidden)]["bufferView"].get<int>(),
          after["images"][0]["bufferView"].get<int>()})
    {
        const auto& v = after["bufferViews"][static_cast<std::size_t>(view)];
        const std::size_t at = v["byteOffset"];
        const std::size_t length = v["byteLength"];
        EXPECT_EQ(after_bin.substr(at, length), before_bin.substr(at, length)) << "view " << view;
    }
}

}  // namespace
}  // namespace meshmark
