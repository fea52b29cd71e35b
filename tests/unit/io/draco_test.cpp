// SPDX-License-Identifier: MIT
// KHR_draco_mesh_compression: decode, write back with new positions re-encoded with the
// input's quantization and attribute ids, the rest of the asset carried through.
#include <cmath>
#include <limits>

#include <Eigen/Geometry>
#include <draco/attributes/attribute_quantization_transform.h>
#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
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

constexpr int kGrid = 12;
constexpr int kPositionBits = 12;

// A wavy height-field patch of kGrid x kGrid points with UVs, Draco-encoded (edgebreaker,
// 12-bit positions, 10-bit UVs).
struct DracoPatch
{
    std::string bytes;
    int position_id = 0;
    int uv_id = 0;
    std::uint32_t points = 0;
};

DracoPatch draco_patch()
{
    const auto at = [](int i, int j)
    {
        const double x = i / static_cast<double>(kGrid - 1);
        const double y = j / static_cast<double>(kGrid - 1);
        return std::array<float, 3>{
            static_cast<float>(x), static_cast<float>(y),
            static_cast<float>(0.1 * std::sin(6.0 * x) * std::cos(4.0 * y))};
    };
    const int faces = 2 * (kGrid - 1) * (kGrid - 1);
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(faces);
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    const int uv = builder.AddAttribute(draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32);
    int f = 0;
    for (int i = 0; i + 1 < kGrid; ++i)
    {
        for (int j = 0; j + 1 < kGrid; ++j)
        {
            const std::array<std::array<int, 2>, 6> corners{
                {{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j}, {i + 1, j + 1}, {i, j + 1}}};
            for (int t = 0; t < 2; ++t)
            {
                std::array<std::array<float, 3>, 3> p{};
                std::array<std::array<float, 2>, 3> u{};
                for (int c = 0; c < 3; ++c)
                {
                    const auto& g = corners[static_cast<std::size_t>(3 * t + c)];
                    p[static_cast<std::size_t>(c)] = at(g[0], g[1]);
                    u[static_cast<std::size_t>(c)] = {p[static_cast<std::size_t>(c)][0],
                                                      p[static_cast<std::size_t>(c)][1]};
                }
                builder.SetAttributeValuesForFace(pos, draco::FaceIndex(f), p[0].data(),
                                                  p[1].data(), p[2].data());
                builder.SetAttributeValuesForFace(uv, draco::FaceIndex(f), u[0].data(), u[1].data(),
                                                  u[2].data());
                ++f;
            }
        }
    }
    auto mesh = builder.Finalize();
    draco::Encoder encoder;
    encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, kPositionBits);
    encoder.SetAttributeQuantization(draco::GeometryAttribute::TEX_COORD, 10);
    encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
    draco::EncoderBuffer out;
    EXPECT_TRUE(encoder.EncodeMeshToBuffer(*mesh, &out).ok());
    DracoPatch patch;
    patch.bytes.assign(out.data(), out.size());
    patch.position_id = static_cast<int>(mesh->attribute(pos)->unique_id());
    patch.uv_id = static_cast<int>(mesh->attribute(uv)->unique_id());
    patch.points = mesh->num_points();
    return patch;
}

std::unique_ptr<draco::Mesh> decode(const std::string& bytes, bool skip_transform)
{
    draco::DecoderBuffer buffer;
    buffer.Init(bytes.data(), bytes.size());
    draco::Decoder decoder;
    if (skip_transform)
    {
        decoder.SetSkipAttributeTransform(draco::GeometryAttribute::POSITION);
    }
    auto result = decoder.DecodeMeshFromBuffer(&buffer);
    EXPECT_TRUE(result.ok());
    return std::move(result).value();
}

// A GLB with the Draco patch (mesh 0, under a translated node) followed by a plain
// triangle whose bytes come after the Draco data in the buffer (mesh 1).
GltfBuilder draco_asset(const DracoPatch& patch)
{
    GltfBuilder b;
    const int view = b.view(patch.bytes);
    const int pos = b.accessor(-1, 0, 5126, patch.points, "VEC3");
    b.doc["accessors"][static_cast<std::size_t>(pos)].erase("bufferView");
    b.doc["accessors"][static_cast<std::size_t>(pos)].erase("byteOffset");
    b.doc["accessors"][static_cast<std::size_t>(pos)]["min"] = {0.0, 0.0, -0.1};
    b.doc["accessors"][static_cast<std::size_t>(pos)]["max"] = {1.0, 1.0, 0.1};
    const int uv = static_cast<int>(b.doc["accessors"].size());
    b.doc["accessors"].push_back(
        {{"componentType", 5126}, {"count", patch.points}, {"type", "VEC2"}});
    const int idx = static_cast<int>(b.doc["accessors"].size());
    b.doc["accessors"].push_back(
        {{"componentType", 5125}, {"count", 6 * (kGrid - 1) * (kGrid - 1)}, {"type", "SCALAR"}});
    const int mesh = b.mesh(
        Json::array({{{"attributes", {{"POSITION", pos}, {"TEXCOORD_0", uv}}},
                      {"indices", idx},
                      {"material", 0},
                      {"extensions",
                       {{"KHR_draco_mesh_compression",
                         {{"bufferView", view},
                          {"attributes",
                           {{"POSITION", patch.position_id}, {"TEXCOORD_0", patch.uv_id}}}}}}}}}));
    b.node({{"mesh", mesh}, {"translation", {0.0, 0.0, 2.0}}});
    const int tri = b.positions({0, 0, 5, 1, 0, 5, 0, 1, 5});
    b.node({{"mesh", b.mesh(Json::array({{{"attributes", {{"POSITION", tri}}}}}))}});
    b.doc["extensionsUsed"] = {"KHR_draco_mesh_compression"};
    b.doc["extensionsRequired"] = {"KHR_draco_mesh_compression"};
    return b;
}

class DracoTest : public ::testing::Test
{
protected:
    fs::path dir = test::temp_dir("draco_test");
};

TEST_F(DracoTest, reads_decoded_world_positions)
{
    const auto patch = draco_patch();
    test::put_bytes(dir / "d.glb", draco_asset(patch).glb());
    const MeshFile file = read_mesh_file(dir / "d.glb");
    EXPECT_EQ(file.mesh.V.rows(), kGrid * kGrid + 3);
    EXPECT_EQ(file.mesh.F.rows(), 2 * (kGrid - 1) * (kGrid - 1) + 1);
    // The patch sits at z = 2 +- 0.1 (node translation), the triangle at z = 5.
    const double step = 1.0 / ((1 << kPositionBits) - 1);
    EXPECT_NEAR(file.mesh.V.col(0).maxCoeff(), 1.0, step);
    EXPECT_NEAR(file.mesh.V.topRows(kGrid * kGrid).col(2).minCoeff(), 1.9, 0.02);
    EXPECT_NEAR(file.mesh.V.col(2).maxCoeff(), 5.0, 0.0);
}

// An animation that turns the Draco part about z (90 degrees over 1 s) while the plain
// triangle stays: posed at several times from one parse (the Draco data decoded once), every
// vertex of the part is where the turn puts it and the triangle's are where they were.
TEST_F(DracoTest, an_animated_draco_part_is_posed_at_every_time)
{
    const auto patch = draco_patch();
    GltfBuilder b = draco_asset(patch);
    const std::vector<float> times{0.0f, 1.0f};
    const float h = std::sqrt(0.5f);
    const std::vector<float> turns{0, 0, 0, 1, 0, 0, h, h};
    const int at = b.accessor(b.view(GltfBuilder::raw(times)), 0, 5126, 2, "SCALAR");
    const int to = b.accessor(b.view(GltfBuilder::raw(turns)), 0, 5126, 2, "VEC4");
    b.doc["animations"] = Json::array(
        {{{"samplers", {{{"input", at}, {"output", to}}}},
          {"channels", {{{"sampler", 0}, {"target", {{"node", 0}, {"path", "rotation"}}}}}}}});
    test::put_bytes(dir / "turning.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "turning.glb");
    ASSERT_FALSE(file.animations.empty());
    EXPECT_FALSE(file.animations.front().moves_only_as_a_whole);  // (the triangle does not turn)
    const std::vector<double> at_times{0.0, 0.5, 1.0, 0.5};
    const std::vector<double> angles{0.0, 0.25 * 3.14159265358979323846,
                                     0.5 * 3.14159265358979323846, 0.25 * 3.14159265358979323846};
    std::vector<ShownPose> poses;
    for_each_animation_pose(dir / "turning.glb", at_times,
                            [&](ShownPose&& p) { poses.push_back(std::move(p)); });
    ASSERT_EQ(poses.size(), at_times.size());
    EXPECT_EQ(poses[0].V.rows(), 0);  // (at the first key: the stored pose)
    for (std::size_t k = 1; k < poses.size(); ++k)
    {
        ASSERT_EQ(poses[k].V.rows(), file.mesh.V.rows()) << k;
        const Eigen::Matrix3d turn =
            Eigen::AngleAxisd(angles[k], Eigen::Vector3d::UnitZ()).toRotationMatrix();
        for (Eigen::Index v = 0; v < file.mesh.V.rows(); ++v)
        {
            const Eigen::Vector3d stored = file.mesh.V.row(v).transpose();
            const bool is_patch = stored.z() < 3.0;
            const Eigen::Vector3d expected = is_patch ? Eigen::Vector3d(turn * stored) : stored;
            EXPECT_LT((poses[k].V.row(v).transpose() - expected).norm(), 1e-6) << k << " " << v;
        }
    }
}

// A Draco primitive with a morph target: its targets stay plain accessors, element for element
// of the decoded points (encoders keep the points' order for such primitives). The mesh's
// weight of 0.5 is a pose (the stored blend): each point of the patch raised by half its
// target's delta, here 0.2 x its own x, the plain triangle where it was.
TEST_F(DracoTest, a_draco_primitive_with_a_morph_target_is_blended_point_for_point)
{
    const auto patch = draco_patch();
    GltfBuilder b = draco_asset(patch);
    const auto decoded = decode(patch.bytes, false);
    const draco::PointAttribute* position =
        decoded->GetNamedAttribute(draco::GeometryAttribute::POSITION);
    std::vector<float> delta;
    for (draco::PointIndex i(0); i < decoded->num_points(); ++i)
    {
        std::array<float, 3> p{};
        position->GetMappedValue(i, p.data());
        delta.insert(delta.end(), {0.0f, 0.0f, 0.2f * p[0]});
    }
    b.doc["meshes"][0]["primitives"][0]["targets"] =
        Json::array({{{"POSITION", b.positions(delta)}}});
    b.doc["meshes"][0]["weights"] = {0.5};
    test::put_bytes(dir / "morphed.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "morphed.glb");
    ASSERT_EQ(file.animations.size(), 1u);  // (the stored blend)
    ShownPose pose;
    const double zero = 0.0;
    for_each_animation_pose(
        dir / "morphed.glb", std::span<const double>(&zero, 1),
        [&](ShownPose&& p) { pose = std::move(p); }, file.animations.front().index);
    ASSERT_EQ(pose.V.rows(), file.mesh.V.rows());
    for (Eigen::Index v = 0; v < file.mesh.V.rows(); ++v)
    {
        const Eigen::Vector3d stored = file.mesh.V.row(v).transpose();
        const bool is_patch = stored.z() < 3.0;
        const Eigen::Vector3d expected =
            stored + Eigen::Vector3d(0.0, 0.0, is_patch ? 0.1 * stored.x() : 0.0);
        EXPECT_LT((pose.V.row(v).transpose() - expected).norm(), 1e-6) << v;
    }
}

// One corner of a skinned triangle soup.
struct SkinnedCorner
{
    std::array<float, 3> position;
    std::array<std::uint8_t, 4> joints;
    std::array<float, 4> weights;
};

// A skinned triangle soup (3 corners per triangle) Draco-encoded as gltf-transform and
// gltf-pipeline write characters (edgebreaker, 28-bit positions, JOINTS_0 and WEIGHTS_0 inside the
// Draco data), added to \p b as a mesh of one primitive; returns the mesh.
int add_skinned_draco_mesh(GltfBuilder& b, const std::vector<SkinnedCorner>& corners)
{
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(static_cast<int>(corners.size() / 3));
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    const int joints = builder.AddAttribute(draco::GeometryAttribute::GENERIC, 4, draco::DT_UINT8);
    const int weights =
        builder.AddAttribute(draco::GeometryAttribute::GENERIC, 4, draco::DT_FLOAT32);
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (std::size_t f = 0; 3 * f < corners.size(); ++f)
    {
        const auto face = draco::FaceIndex(static_cast<std::uint32_t>(f));
        const SkinnedCorner* c = &corners[3 * f];
        builder.SetAttributeValuesForFace(pos, face, c[0].position.data(), c[1].position.data(),
                                          c[2].position.data());
        builder.SetAttributeValuesForFace(joints, face, c[0].joints.data(), c[1].joints.data(),
                                          c[2].joints.data());
        builder.SetAttributeValuesForFace(weights, face, c[0].weights.data(), c[1].weights.data(),
                                          c[2].weights.data());
        for (std::size_t k = 0; k < 3; ++k)
        {
            const Eigen::Vector3d p(c[k].position[0], c[k].position[1], c[k].position[2]);
            lo = lo.cwiseMin(p);
            hi = hi.cwiseMax(p);
        }
    }
    auto mesh = builder.Finalize();
    draco::Encoder encoder;
    encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION,
                                     28);  // (the weights follow x closely)
    encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
    draco::EncoderBuffer out;
    EXPECT_TRUE(encoder.EncodeMeshToBuffer(*mesh, &out).ok());

    const int view = b.view(std::string(out.data(), out.size()));
    const auto attribute = [&](int component, const char* type)
    {
        b.doc["accessors"].push_back(
            {{"componentType", component}, {"count", mesh->num_points()}, {"type", type}});
        return static_cast<int>(b.doc["accessors"].size() - 1);
    };
    const int position_acc = attribute(5126, "VEC3");
    b.doc["accessors"][static_cast<std::size_t>(position_acc)]["min"] = {lo.x(), lo.y(), lo.z()};
    b.doc["accessors"][static_cast<std::size_t>(position_acc)]["max"] = {hi.x(), hi.y(), hi.z()};
    const int joints_acc = attribute(5121, "VEC4");
    const int weights_acc = attribute(5126, "VEC4");
    const int index_acc = static_cast<int>(b.doc["accessors"].size());
    b.doc["accessors"].push_back(
        {{"componentType", 5125}, {"count", 3 * mesh->num_faces()}, {"type", "SCALAR"}});
    const auto id = [&](int a) { return static_cast<int>(mesh->attribute(a)->unique_id()); };
    b.doc["extensionsUsed"] = {"KHR_draco_mesh_compression"};
    b.doc["extensionsRequired"] = {"KHR_draco_mesh_compression"};
    return b.mesh(Json::array(
        {{{"attributes",
           {{"POSITION", position_acc}, {"JOINTS_0", joints_acc}, {"WEIGHTS_0", weights_acc}}},
          {"indices", index_acc},
          {"extensions",
           {{"KHR_draco_mesh_compression",
             {{"bufferView", view},
              {"attributes",
               {{"POSITION", id(pos)},
                {"JOINTS_0", id(joints)},
                {"WEIGHTS_0", id(weights)}}}}}}}}}));
}

// A rigged arm whose skinned primitive is Draco-compressed (JOINTS_0 and WEIGHTS_0 inside the
// Draco data, as gltf-transform and gltf-pipeline write characters): the stored mesh, in its
// bind pose, reads as through its node, and its poses are skinned as those of
// an uncompressed rig, the joints and weights decoded from the Draco data: at 1/24 s and at the
// animation's end every vertex is where the bent arm puts it.
TEST_F(DracoTest, a_skinned_draco_primitive_is_posed_by_its_joints)
{
    const test::BendingArm arm;
    // A strip along x from -2 to 2, bent at the elbow (x = 0).
    constexpr int kAlong = 33;
    const auto at = [](int i, int j)
    {
        return std::array<float, 3>{-2.0f + 0.125f * static_cast<float>(i),
                                    0.25f * static_cast<float>(j),
                                    0.05f * static_cast<float>(i % 3)};
    };
    std::vector<SkinnedCorner> corners;
    for (int i = 0; i + 1 < kAlong; ++i)
    {
        for (const auto& g : std::array<std::array<int, 2>, 6>{
                 {{i, 0}, {i + 1, 0}, {i + 1, 1}, {i, 0}, {i + 1, 1}, {i, 1}}})
        {
            const auto p = at(g[0], g[1]);
            const auto elbow_weight = static_cast<float>(arm.weight(p[0]));
            corners.push_back({p, {0, 1, 0, 0}, {1.0f - elbow_weight, elbow_weight, 0.0f, 0.0f}});
        }
    }
    GltfBuilder b;
    const int arm_mesh = add_skinned_draco_mesh(b, corners);
    test::put_bytes(dir / "arm.glb", arm.rig(b, arm_mesh));

    const MeshFile file = read_mesh_file(dir / "arm.glb");
    ASSERT_EQ(file.mesh.V.rows(), 2 * kAlong);
    EXPECT_NEAR(file.mesh.V.col(0).minCoeff(), -2.0, 1e-6);  // stored straight, through the node
    EXPECT_NEAR(file.mesh.V.col(0).maxCoeff(), 2.0, 1e-6);
    ASSERT_FALSE(file.animations.empty());
    EXPECT_FALSE(file.animations.front().moves_only_as_a_whole);
    const std::vector<double> times{1.0 / 24.0, 0.1};
    std::vector<ShownPose> poses;
    for_each_animation_pose(dir / "arm.glb", times,
                            [&](ShownPose&& p) { poses.push_back(std::move(p)); });
    ASSERT_EQ(poses.size(), times.size());
    for (std::size_t k = 0; k < times.size(); ++k)
    {
        ASSERT_EQ(poses[k].V.rows(), file.mesh.V.rows()) << k;
        double largest_bend = 0.0;
        for (Eigen::Index v = 0; v < file.mesh.V.rows(); ++v)
        {
            const Eigen::Vector3d p = file.mesh.V.row(v).transpose();
            const Eigen::Vector3d shown = arm.shown(p, arm.weight(p.x()), times[k]);
            EXPECT_LT((poses[k].V.row(v).transpose() - shown).norm(), 1e-5) << k << " " << v;
            largest_bend =
                std::max(largest_bend, (shown - p - Eigen::Vector3d(0.0, arm.lift, 0.0)).norm());
        }
        EXPECT_GT(largest_bend, 0.3) << k;  // (a bend, not the stored shape lifted)
    }
}

// A skinned Draco primitive is read where a viewer shows it, as an uncompressed one is (its
// joints and weights decoded from the Draco data), and a moved position is written back
// through its own matrix's inverse. Read through its node instead (as before the twelfth
// session), a Draco rig whose scene pose is not its bind pose was marked in a shape no viewer
// shows, and a still copy of it (Blender's) was read against the wrong shape.
TEST_F(DracoTest,
       a_skinned_draco_primitive_is_read_in_the_scene_pose_and_written_back_through_its_joints)
{
    const test::KneeRig rig;
    std::vector<SkinnedCorner> corners;
    for (const auto v : rig.idx)
    {
        const std::size_t k = v;
        corners.push_back({{rig.xyz[3 * k], rig.xyz[3 * k + 1], rig.xyz[3 * k + 2]},
                           {rig.joints[4 * k], rig.joints[4 * k + 1], rig.joints[4 * k + 2],
                            rig.joints[4 * k + 3]},
                           {rig.weights[4 * k], rig.weights[4 * k + 1], rig.weights[4 * k + 2],
                            rig.weights[4 * k + 3]}});
    }
    GltfBuilder b;
    const int rig_mesh = add_skinned_draco_mesh(b, corners);
    rig.add_skeleton(b, rig_mesh);
    test::put_bytes(dir / "rig.glb", b.glb());

    // (Draco stores its points in an order of its own, and a re-encoding may change it.)
    const auto distance_to = [](const Positions& V, const Eigen::Vector3d& p)
    {
        double nearest = std::numeric_limits<double>::infinity();
        for (Eigen::Index i = 0; i < V.rows(); ++i)
        {
            nearest = std::min(nearest, (V.row(i).transpose() - p).norm());
        }
        return nearest;
    };
    const MeshFile file = read_mesh_file(dir / "rig.glb");
    ASSERT_EQ(file.mesh.V.rows(), static_cast<Eigen::Index>(rig.size()));
    for (std::size_t v = 0; v < rig.size(); ++v)
    {
        EXPECT_LT(distance_to(file.mesh.V, rig.shown(v)), 1e-6) << v;
    }

    // Moved by a small field, written, read again: the same field, in the scene pose.
    const Positions moved = test::nudged(file.mesh.V);
    write_mesh_file(dir / "rig_out.glb", file, moved);
    const MeshFile again = read_mesh_file(dir / "rig_out.glb");
    ASSERT_EQ(again.mesh.V.rows(), moved.rows());
    for (Eigen::Index i = 0; i < moved.rows(); ++i)
    {
        EXPECT_LT(distance_to(again.mesh.V, moved.row(i).transpose()), 1e-6) << i;
    }
    // Only the positions changed: the skin, its joints and every node are as they were.
    const Json after = test::glb_json(test::file_bytes(dir / "rig_out.glb"));
    EXPECT_EQ(after["skins"], b.doc["skins"]);
    EXPECT_EQ(after["nodes"], b.doc["nodes"]);
}

TEST_F(DracoTest, unchanged_positions_keep_the_file)
{
    const auto patch = draco_patch();
    const std::string glb = draco_asset(patch).glb();
    test::put_bytes(dir / "d.glb", glb);
    EXPECT_EQ(test::rewritten_unchanged(dir / "d.glb", dir / "same.glb"), glb);
}

TEST_F(DracoTest, changed_positions_are_reencoded_with_the_same_ids_and_quantization)
{
    const auto patch = draco_patch();
    const auto builder = draco_asset(patch);
    test::put_bytes(dir / "d.glb", builder.glb());
    const MeshFile file = read_mesh_file(dir / "d.glb");
    Positions moved = file.mesh.V;
    for (Eigen::Index i = 0; i < moved.rows(); ++i)
    {
        if (moved(i, 2) > 4.0)
        {
            continue;  // the plain triangle stays
        }
        moved(i, 2) += 0.02 * std::sin(5.0 * moved(i, 0) + 3.0 * moved(i, 1));
    }
    write_mesh_file(dir / "out.glb", file, moved);

    std::string bin_before;
    std::string bin_after;
    const Json before = test::glb_json(test::file_bytes(dir / "d.glb"), &bin_before);
    const Json after = test::glb_json(test::file_bytes(dir / "out.glb"), &bin_after);

    // The new Draco stream: same attribute ids, same position quantization.
    const auto& view = after["bufferViews"][0];
    const std::string stream =
        bin_after.substr(view.value("byteOffset", 0U), view["byteLength"].get<std::size_t>());
    const auto decoded = decode(stream, false);
    ASSERT_NE(decoded->GetAttributeByUniqueId(static_cast<std::uint32_t>(patch.position_id)),
              nullptr);
    EXPECT_EQ(decoded->GetAttributeByUniqueId(static_cast<std::uint32_t>(patch.position_id))
                  ->attribute_type(),
              draco::GeometryAttribute::POSITION);
    ASSERT_NE(decoded->GetAttributeByUniqueId(static_cast<std::uint32_t>(patch.uv_id)), nullptr);
    EXPECT_EQ(
        decoded->GetAttributeByUniqueId(static_cast<std::uint32_t>(patch.uv_id))->attribute_type(),
        draco::GeometryAttribute::TEX_COORD);
    const auto quantized = decode(stream, true);
    draco::AttributeQuantizationTransform q;
    ASSERT_TRUE(q.InitFromAttribute(
        *quantized->GetAttributeByUniqueId(static_cast<std::uint32_t>(patch.position_id))));
    EXPECT_EQ(q.quantization_bits(), kPositionBits);

    // The plain triangle after the Draco data keeps its bytes at its (shifted) offset.
    const auto& tri_before = before["bufferViews"][before["bufferViews"].size() - 1];
    const auto& tri_after = after["bufferViews"][after["bufferViews"].size() - 1];
    EXPECT_EQ(bin_after.substr(tri_after["byteOffset"], 36),
              bin_before.substr(tri_before["byteOffset"], 36));
    EXPECT_EQ(tri_after["byteOffset"].get<std::size_t>() % 4, 0U);

    // Everything but the Draco view, the views after it, the buffer length and the bounds
    // and counts of the Draco accessors is the same JSON.
    Json a = after;
    Json b = before;
    for (Json* doc : {&a, &b})
    {
        (*doc)["bufferViews"].erase((*doc)["bufferViews"].begin(), (*doc)["bufferViews"].end());
        (*doc)["buffers"] = Json::array();
        (*doc)["accessors"][0].erase("min");
        (*doc)["accessors"][0].erase("max");
    }
    EXPECT_EQ(a, b);

    // Re-read (tinygltf 2.7 cannot load Draco assets by itself: it rejects their indices
    // accessors without bufferView; read_mesh_file validates the rest with it): the moved
    // positions, to the quantization step, in the world frame.
    const MeshFile again = read_mesh_file(dir / "out.glb");
    ASSERT_EQ(again.mesh.V.rows(), moved.rows());
    const double step = 1.2 / ((1 << kPositionBits) - 1);
    for (Eigen::Index i = 0; i < moved.rows(); ++i)
    {
        double best = 1e9;
        for (Eigen::Index j = 0; j < again.mesh.V.rows(); ++j)
        {
            best = std::min(best, (again.mesh.V.row(j) - moved.row(i)).norm());
        }
        EXPECT_LT(best, step) << "vertex " << i;
    }
}

TEST_F(DracoTest, corrupt_draco_data_is_an_io_error_naming_the_file)
{
    auto patch = draco_patch();
    patch.bytes.resize(patch.bytes.size() / 2);
    test::put_bytes(dir / "broken.glb", draco_asset(patch).glb());
    try
    {
        static_cast<void>(read_mesh_file(dir / "broken.glb"));
        FAIL() << "accepted";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("broken.glb"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace meshmark
