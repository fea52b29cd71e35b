// SPDX-License-Identifier: MIT
// End to end through the pipeline: embed into a two-part GLB whose parts sit under different
// node transforms, move the whole asset by a similarity, detect.
#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "gltf_test_support.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/meshmark.h"
#include "meshmark/pipeline/detect_file.h"
#include "meshmark/pipeline/embed_file.h"
#include "meshmark/registration/registration.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::GltfBuilder;
using test::Json;

// The lumpy ellipsoid cut in two by the plane x = 0: each half is one primitive of its own
// mesh, stored in its node's local frame (float32), so the cut vertices appear in both parts
// and meet again in world space only to float32 precision.
std::string two_part_glb(const TriangleMesh& shape)
{
    Eigen::Affine3d t0 = Eigen::Affine3d::Identity();
    t0.translate(Eigen::Vector3d(0.3, -0.2, 0.1))
        .rotate(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
    Eigen::Affine3d t1 = Eigen::Affine3d::Identity();
    t1.translate(Eigen::Vector3d(-1.0, 0.5, 2.0)).scale(1.5);
    const std::array<Eigen::Matrix4d, 2> to_world{t0.matrix(), t1.matrix()};
    GltfBuilder b;
    for (int part = 0; part < 2; ++part)
    {
        std::vector<std::int32_t> local_of(static_cast<std::size_t>(shape.V.rows()), -1);
        std::vector<float> xyz;
        std::vector<std::uint16_t> idx;
        const Eigen::Matrix4d to_local = to_world[static_cast<std::size_t>(part)].inverse();
        for (Eigen::Index f = 0; f < shape.F.rows(); ++f)
        {
            const double cx = (shape.V(shape.F(f, 0), 0) + shape.V(shape.F(f, 1), 0) +
                               shape.V(shape.F(f, 2), 0)) /
                              3;
            if ((cx < 0.0) != (part == 0))
            {
                continue;
            }
            for (Eigen::Index c = 0; c < 3; ++c)
            {
                const auto v = static_cast<std::size_t>(shape.F(f, c));
                if (local_of[v] < 0)
                {
                    local_of[v] = static_cast<std::int32_t>(xyz.size() / 3);
                    const Eigen::Vector4d p =
                        to_local * Eigen::Vector4d(shape.V(static_cast<Eigen::Index>(v), 0),
                                                   shape.V(static_cast<Eigen::Index>(v), 1),
                                                   shape.V(static_cast<Eigen::Index>(v), 2), 1.0);
                    xyz.insert(xyz.end(), {static_cast<float>(p.x()), static_cast<float>(p.y()),
                                           static_cast<float>(p.z())});
                }
                idx.push_back(static_cast<std::uint16_t>(local_of[v]));
            }
        }
        const int pos = b.positions(xyz);
        const int mesh = b.mesh(
            Json::array({{{"attributes", {{"POSITION", pos}}}, {"indices", b.indices(idx)}}}));
        const auto& m = to_world[static_cast<std::size_t>(part)];
        b.node({{"mesh", mesh}, {"matrix", std::vector<double>(m.data(), m.data() + 16)}});
    }
    return b.glb();
}

TEST(GltfPipelineTest, two_part_glb_detects_after_a_similarity_of_the_whole_asset)
{
    const fs::path dir = test::temp_dir("gltf_pipeline_test");
    const TriangleMesh shape = lumpy_ellipsoid(4);
    test::put_bytes(dir / "asset.glb", two_part_glb(shape));
    const MeshFile original = read_mesh_file(dir / "asset.glb");
    // The two halves weld back into the closed surface.
    ASSERT_EQ(original.mesh.V.rows(), shape.V.rows());

    EmbedFileOptions options;
    options.seed = 7;
    options.message = "glTF";
    options.threads = 1;
    // Spread over 4 coefficients per bit: with r = 1 (24 coefficients) the score of even an
    // intact mark stays below the default 1e-6 false-positive bound.
    options.embed.repetitions = 4;
    const auto report =
        embed_file(dir / "asset.glb", dir / "marked.glb", dir / "key.json", options);
    EXPECT_EQ(report.output_format, MeshFormat::Glb);

    // The whole asset rotated, scaled and moved (every accessor's positions).
    Eigen::Affine3d s = Eigen::Affine3d::Identity();
    s.translate(Eigen::Vector3d(5, -3, 1))
        .rotate(Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.2, 1, -0.4).normalized()))
        .scale(2.5);
    const auto moved = [&s](const MeshFile& file)
    {
        Positions V = file.mesh.V;
        for (Eigen::Index i = 0; i < V.rows(); ++i)
        {
            V.row(i) = (s * Eigen::Vector3d(V.row(i).transpose())).transpose();
        }
        return V;
    };
    const MeshFile marked = read_mesh_file(dir / "marked.glb");
    ASSERT_EQ(marked.mesh.V.rows(), original.mesh.V.rows());
    write_mesh_file(dir / "suspect.glb", marked, moved(marked));
    write_mesh_file(dir / "clean.glb", original, moved(original));

    DetectFileOptions detect;
    detect.threads = 1;
    const auto found =
        detect_file(dir / "suspect.glb", dir / "asset.glb", dir / "key.json", detect);
    EXPECT_TRUE(found.decision.is_present)
        << "R " << found.decision.correlation << " z " << found.decision.score << " matches "
        << found.decision.matches << "/" << found.decision.bit_count << " alignment "
        << found.registration_method() << " rms " << found.registration_rms;
    EXPECT_EQ(found.decision.matches, found.decision.bit_count);
    const auto clean = detect_file(dir / "clean.glb", dir / "asset.glb", dir / "key.json", detect);
    EXPECT_FALSE(clean.decision.is_present);
}

// A lumpy ellipsoid twice as long in x (an arm's shape).
TriangleMesh long_lumpy_ellipsoid()
{
    TriangleMesh shape = lumpy_ellipsoid(4);
    shape.V.col(0) *= 2.0;
    return shape;
}

// \p shape's positions (float32) and triangles as a glTF primitive stores them.
std::pair<std::vector<float>, std::vector<std::uint16_t>> glb_arrays(const TriangleMesh& shape)
{
    std::vector<float> xyz;
    for (Eigen::Index v = 0; v < shape.V.rows(); ++v)
    {
        xyz.insert(xyz.end(), {static_cast<float>(shape.V(v, 0)), static_cast<float>(shape.V(v, 1)),
                               static_cast<float>(shape.V(v, 2))});
    }
    std::vector<std::uint16_t> idx;
    for (Eigen::Index f = 0; f < shape.F.rows(); ++f)
    {
        for (Eigen::Index c = 0; c < 3; ++c)
        {
            idx.push_back(static_cast<std::uint16_t>(shape.F(f, c)));
        }
    }
    return {xyz, idx};
}

// A rigged asset Blender shows bent (its first animation turns the elbow 41 degrees by frame
// 1): every copy made from the import carries the bend, which no similarity undoes. The copy,
// written as a PLY with its vertices in another order, is read through the pose the original
// is shown in (docs/algorithms/detection.md, General suspects, step 1c) and claimed; the
// unmarked asset through the same steps is not.
TEST(GltfPipelineTest, a_copy_of_an_animated_asset_in_the_pose_blender_shows_is_claimed)
{
    const fs::path dir = test::temp_dir("gltf_pipeline_animated");
    const auto [xyz, idx] = glb_arrays(long_lumpy_ellipsoid());
    const test::BendingArm arm;
    test::put_bytes(dir / "arm.glb", arm.glb(xyz, idx));
    EmbedFileOptions options;
    options.seed = 11;
    options.threads = 1;
    (void)embed_file(dir / "arm.glb", dir / "marked.glb", dir / "key.json", options);

    // Blender's copy: every vertex where the pose puts it (skinned with the stored weights),
    // the vertices in reverse order.
    const auto shown_copy = [&](const fs::path& file, const fs::path& out, double t = 1.0 / 24.0)
    {
        const TriangleMesh stored = read_mesh(file);
        const Eigen::Index n = stored.V.rows();
        TriangleMesh copy;
        copy.V.resize(n, 3);
        for (Eigen::Index v = 0; v < n; ++v)
        {
            copy.V.row(n - 1 - v) = arm.shown(stored.V.row(v).transpose(),
                                              arm.weight(xyz[static_cast<std::size_t>(3 * v)]), t)
                                        .transpose();
        }
        copy.F = (n - 1) - stored.F.array();
        write_mesh(out, copy);
    };
    DetectFileOptions detect;
    detect.threads = 1;
    // The marked copy posed at \p t is claimed, read through the frame named \p frame; the unmarked
    // one is not. Returns the marked copy's report.
    const auto expect_claimed_at = [&](double t, const std::string& name, const std::string& frame)
    {
        shown_copy(dir / "marked.glb", dir / ("marked_" + name + ".ply"), t);
        shown_copy(dir / "arm.glb", dir / ("clean_" + name + ".ply"), t);
        const DetectReport found = detect_file(dir / ("marked_" + name + ".ply"), dir / "arm.glb",
                                               dir / "key.json", detect);
        EXPECT_TRUE(found.decision.is_present)
            << name << " z " << found.decision.score << " " << found.registration_method();
        EXPECT_GT(found.decision.score, 9.0) << name;
        EXPECT_EQ(found.correspondence, Correspondence::AnimationFrame) << name;
        EXPECT_NE(found.pose.find(frame), std::string::npos) << found.pose;
        const DetectReport clean = detect_file(dir / ("clean_" + name + ".ply"), dir / "arm.glb",
                                               dir / "key.json", detect);
        EXPECT_FALSE(clean.decision.is_present) << name << " z " << clean.decision.score;
        return found;
    };
    (void)expect_claimed_at(1.0 / 24.0, "shown", "animation 'bend' at 1/24 s");
    // Exported at the animation's end (Blender's frame 3 and after: the elbow turned by 100
    // degrees, not 41): read through that frame, found among the animation's frames by how
    // well the copy fits each.
    const DetectReport at_end = expect_claimed_at(0.1, "end", "animation 'bend' at 0.1 s");

    // The same copy held in memory (the Blender add-on's Detect): against the original's file it
    // is read through its frame too; against the original's mesh alone it cannot be.
    const TriangleMesh held = read_mesh(dir / "marked_end.ply");
    const DetectReport in_memory =
        detect_against_file(held, dir / "arm.glb", dir / "key.json", detect);
    EXPECT_TRUE(in_memory.decision.is_present) << "z " << in_memory.decision.score;
    EXPECT_EQ(in_memory.decision.score, at_end.decision.score);
    const DetectReport arrays_only =
        meshmark::detect(held, read_mesh(dir / "arm.glb"), read_key(dir / "key.json"), detect);
    EXPECT_FALSE(arrays_only.decision.is_present) << "z " << arrays_only.decision.score;
}

// The bend kept as the file's second animation (Blender imports it as an action the user may
// switch to; its first, "straight", keeps the arm still): a copy the user exported from the
// bend at its end is read through that animation's frame and claimed; the unmarked one is not.
TEST(GltfPipelineTest, a_copy_posed_by_another_animation_than_the_first_is_claimed)
{
    const fs::path dir = test::temp_dir("gltf_pipeline_second_animation");
    const auto [xyz, idx] = glb_arrays(long_lumpy_ellipsoid());
    test::BendingArm arm;
    arm.is_bend_first = false;
    test::put_bytes(dir / "arm.glb", arm.glb(xyz, idx));
    const MeshFile file = read_mesh_file(dir / "arm.glb");
    ASSERT_EQ(file.animations.size(), 2u);
    EXPECT_EQ(file.animations[1].name, "bend");
    EmbedFileOptions options;
    options.seed = 12;
    options.threads = 1;
    (void)embed_file(dir / "arm.glb", dir / "marked.glb", dir / "key.json", options);
    for (const char* name : {"marked", "arm"})
    {
        const TriangleMesh stored = read_mesh(dir / (std::string(name) + ".glb"));
        TriangleMesh copy = stored;
        for (Eigen::Index v = 0; v < copy.V.rows(); ++v)
        {
            copy.V.row(v) = arm.shown(stored.V.row(v).transpose(),
                                      arm.weight(xyz[static_cast<std::size_t>(3 * v)]), 0.1)
                                .transpose();
        }
        write_mesh(dir / (std::string(name) + "_bent.ply"), copy);
    }
    DetectFileOptions detect;
    detect.threads = 1;
    const DetectReport found =
        detect_file(dir / "marked_bent.ply", dir / "arm.glb", dir / "key.json", detect);
    EXPECT_TRUE(found.decision.is_present)
        << "z " << found.decision.score << " " << found.registration_method();
    EXPECT_GT(found.decision.score, 9.0);
    EXPECT_EQ(found.correspondence, Correspondence::AnimationFrame);
    EXPECT_EQ(found.registration_method(), "registration (animation 'bend' at 0.1 s)");
    const DetectReport clean =
        detect_file(dir / "arm_bent.ply", dir / "arm.glb", dir / "key.json", detect);
    EXPECT_FALSE(clean.decision.is_present) << "z " << clean.decision.score;
}

// A turntable: the first animation only turns the asset as a whole, so no frame bends the mesh
// and there is no second reading to pay for (the reader says so from the node tree); nor when
// it only moves a camera (every pose found empty). A turned copy of the marked asset is claimed
// with the same score and false-positive probability as against the asset without an animation
// (a second reading would double the probability), and the unmarked one is not.
TEST(GltfPipelineTest, an_animation_that_only_turns_the_asset_costs_no_second_reading)
{
    const fs::path dir = test::temp_dir("gltf_pipeline_turntable");
    const auto [xyz, idx] = glb_arrays(long_lumpy_ellipsoid());
    enum class Turning
    {
        nothing,
        model,
        camera
    };
    const auto asset = [&](Turning turning)
    {
        GltfBuilder b;
        const int mesh = b.mesh(Json::array(
            {{{"attributes", {{"POSITION", b.positions(xyz)}}}, {"indices", b.indices(idx)}}}));
        const int model = b.node({{"mesh", mesh}, {"name", "model"}});
        const int camera = b.node({{"name", "camera"}, {"translation", {0.0, 1.0, 5.0}}});
        if (turning != Turning::nothing)
        {
            const std::vector<float> times{0.0f, 1.0f, 2.0f};
            const float h = std::sqrt(0.5f);
            const std::vector<float> turns{0, 0, 0, 1, 0, h,
                                           0, h, 0, 1, 0, 0};  // about y: 0, 90, 180 degrees
            const int at =
                b.accessor(b.view(GltfBuilder::raw(times)), 0, 5126, times.size(), "SCALAR");
            const int to =
                b.accessor(b.view(GltfBuilder::raw(turns)), 0, 5126, turns.size() / 4, "VEC4");
            b.doc["animations"] =
                Json::array({{{"name", "turntable"},
                              {"samplers", {{{"input", at}, {"output", to}}}},
                              {"channels",
                               {{{"sampler", 0},
                                 {"target",
                                  {{"node", turning == Turning::model ? model : camera},
                                   {"path", "rotation"}}}}}}}});
        }
        return b.glb();
    };
    test::put_bytes(dir / "turning.glb", asset(Turning::model));
    test::put_bytes(dir / "filmed.glb", asset(Turning::camera));
    test::put_bytes(dir / "still.glb", asset(Turning::nothing));
    ASSERT_TRUE(read_mesh_file(dir / "turning.glb").animations.front().moves_only_as_a_whole);
    ASSERT_FALSE(read_mesh_file(dir / "filmed.glb").animations.front().moves_only_as_a_whole);
    EmbedFileOptions options;
    options.seed = 5;
    options.threads = 1;
    (void)embed_file(dir / "turning.glb", dir / "marked.glb", dir / "key.json", options);

    // Copies as Blender writes them at frame 12: turned by 0.5 s of the animation (45 degrees).
    const Eigen::Affine3d turned(
        Eigen::AngleAxisd(0.25 * 3.14159265358979323846, Eigen::Vector3d::UnitY()));
    for (const char* name : {"marked", "turning"})
    {
        TriangleMesh copy = read_mesh(dir / (std::string(name) + ".glb"));
        copy.V = transform_points(turned.matrix(), copy.V);
        write_mesh(dir / (std::string(name) + "_copy.ply"), copy);
    }
    DetectFileOptions detect;
    detect.threads = 1;
    const DetectReport still =
        detect_file(dir / "marked_copy.ply", dir / "still.glb", dir / "key.json", detect);
    EXPECT_TRUE(still.decision.is_present) << "z " << still.decision.score;
    EXPECT_GT(still.decision.false_positive_probability, 0.0);
    for (const char* original : {"turning.glb", "filmed.glb"})
    {
        const DetectReport found =
            detect_file(dir / "marked_copy.ply", dir / original, dir / "key.json", detect);
        EXPECT_EQ(found.decision.false_positive_probability,
                  still.decision.false_positive_probability)
            << original;
        EXPECT_EQ(found.decision.score, still.decision.score) << original;
        const DetectReport clean =
            detect_file(dir / "turning_copy.ply", dir / original, dir / "key.json", detect);
        EXPECT_FALSE(clean.decision.is_present) << original << " z " << clean.decision.score;
    }
}

}  // namespace
}  // namespace meshmark
