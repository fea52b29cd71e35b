// SPDX-License-Identifier: MIT
// glTF 2.0 / GLB meshes in their scene pose: instances, skins, animated rigs, morph targets,
// whole-asset animations, bind poses.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <span>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "gltf_test_fixture.h"
#include "gltf_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::box_faces;
using test::Glb;
using test::GltfBuilder;
using test::GltfTest;
using test::Json;
using test::split;

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
}  // namespace
}  // namespace meshmark
