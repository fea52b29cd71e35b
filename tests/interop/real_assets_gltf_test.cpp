// SPDX-License-Identifier: MIT
// The interop suite's real assets (docs/interop.md): models other people made with other tools,
// from Debian's assimp-testmodels (/usr/share/assimp/models): Khronos' 2CylinderEngine sample as
// a .glb and as a Draco-compressed .gltf with its .bin, and the textured low-poly spider of
// OBJ/spider.obj (19 groups whose touching parts repeat 40 of its 762 positions).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "interop_support.h"
#include "meshmark/io/mesh_io.h"
#include "real_assets_support.h"
#include "support/test_paths.h"

namespace meshmark::test::interop
{

// Khronos' engine, 115 primitives under a node tree: the marked .glb and the marked Draco
// .gltf are valid, the independent reader finds the same primitives and vertex counts with
// positions moved by the mark only, and the mark reads intact.
TEST(RealAssetsInterop, MarksKhronosEngineAsGlbAndAsDracoGltf)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "node", "assimp-testmodels");
    const fs::path scratch = temp_dir("interop-real-engine");
    for (const fs::path& input : {kModels / "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb",
                                  kModels / "glTF2/draco/2CylinderEngine.gltf"})
    {
        const bool is_draco = input.extension() == ".gltf";
        const fs::path marked = scratch / (is_draco ? "marked.gltf" : "marked.glb");
        const fs::path key = scratch / (is_draco ? "key_draco.json" : "key_glb.json");
        const ToolRun marking = embed(input, marked, key, kSeed, scratch);
        ASSERT_TRUE(marking.ok()) << marking.describe();

        std::string error;
        const Validation validation = validate(marked, scratch, &error);
        ASSERT_TRUE(error.empty()) << error;
        EXPECT_EQ(validation.errors, 0) << input << ": " << validation.messages;
        if (is_draco)
        {
            EXPECT_NE(validation.codes.find("UNSUPPORTED_EXTENSION"), std::string::npos)
                << "the marked .gltf no longer uses KHR_draco_mesh_compression: "
                << validation.codes;
        }
        const Positions before = independent_read(input, scratch, &error);
        ASSERT_TRUE(error.empty()) << error;
        const Positions after = independent_read(marked, scratch, &error);
        ASSERT_TRUE(error.empty()) << error;
        ASSERT_EQ(before.rows(), after.rows()) << input;
        // The mark's displacement: at most 0.5% of the diagonal anywhere (0.30-0.37% measured),
        // about 0.06-0.1% RMS, and not zero.
        const auto [worst, rms] =
            is_draco ? nearest_distances(before, after)
                     : std::pair{
                           (after - before).rowwise().norm().maxCoeff() / bounds(before).diagonal(),
                           std::sqrt((after - before).rowwise().squaredNorm().mean()) /
                               bounds(before).diagonal()};
        EXPECT_LT(worst, 5e-3) << input;
        EXPECT_GT(rms, 2e-4) << input;
        EXPECT_LT(rms, 2e-3) << input;

        int exit_code = -1;
        const nlohmann::json report = detect_json(marked, input, key, scratch, &exit_code);
        ASSERT_TRUE(report.is_object()) << input;
        EXPECT_EQ(exit_code, 0) << report.dump();
        EXPECT_GE(report.value("score", 0.0), 10.0) << report.dump();
    }
}

// Khronos' ClearCoatTest, a .gltf whose six textures are files beside it, marked into another
// folder: the validator finds every texture (before, six IO_ERRORs: "not found") and the same
// issues as in the source, and the independent reader the same positions up to the mark.
TEST(RealAssetsInterop, ATexturedGltfMarkedIntoAnotherFolderKeepsItsTextures)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "node", "assimp-testmodels");
    const fs::path scratch = temp_dir("interop-real-textures");
    const fs::path input = kModels / "glTF2/ClearCoat-glTF/ClearCoatTest.gltf";
    const fs::path marked = scratch / "out" / "marked.gltf";
    fs::create_directories(marked.parent_path());
    const ToolRun marking = embed(input, marked, scratch / "key.json", kSeed, scratch);
    ASSERT_TRUE(marking.ok()) << marking.describe();

    std::string error;
    const Validation source = validate(input, scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    const Validation validation = validate(marked, scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    EXPECT_EQ(validation.codes.find("IO_ERROR"), std::string::npos) << validation.messages;
    EXPECT_EQ(validation.errors, source.errors) << validation.messages;
    EXPECT_EQ(validation.codes, source.codes);
    for (const char* image :
         {"ClearCoatLabels.png", "PartialCoating.png", "PlasticWrap_normals.jpg"})
    {
        EXPECT_EQ(file_bytes(marked.parent_path() / image), file_bytes(input.parent_path() / image))
            << image;
    }
    const Positions before = independent_read(input, scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    const Positions after = independent_read(marked, scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    ASSERT_EQ(before.rows(), after.rows());
    EXPECT_GT((after - before).rowwise().norm().maxCoeff(), 0.0);
    EXPECT_LT((after - before).rowwise().norm().maxCoeff() / bounds(before).diagonal(), 5e-3);
}

// The engine voxel-remeshed (meshmark's voxel step reproduces Blender's Remesh modifier) and
// turned from Y up to Z up, as Blender writes it: the voxel surface keeps the outer shell of
// the assembly and drops its inner parts, so its moments (RMS radius, principal axes) are no
// longer the original's; every start from them registered it at scale 0.91 (z 0.49). The
// starts at the original's scale on its coordinate axes find it.
TEST(RealAssetsInterop, AVoxelRemeshOfTheEngineWrittenZUpIsRegisteredAndClaimed)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "assimp-testmodels");
    const fs::path scratch = temp_dir("interop-real-engine-voxel");
    const fs::path original = kModels / "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
    const fs::path marked = scratch / "marked.glb";
    const fs::path key = scratch / "key.json";
    const ToolRun marking = embed(original, marked, key, "1", scratch);
    ASSERT_TRUE(marking.ok()) << marking.describe();
    const fs::path copy = scratch / "voxel.ply";
    const ToolRun attack = meshmark({"attack", marked.string(), "-o", copy.string(), "--seed", "1",
                                     "voxel=150,similarity:axis=x:angle=-90:tx=5", "-q"},
                                    scratch);
    ASSERT_TRUE(attack.ok()) << attack.describe();
    int exit_code = -1;
    const nlohmann::json report = detect_json(copy, original, key, scratch, &exit_code);
    ASSERT_TRUE(report.is_object());
    EXPECT_EQ(exit_code, 0) << report.dump();
    EXPECT_NEAR(registration_scale(report), 1.0, 0.01) << report.dump();
    EXPECT_GE(report.value("score", 0.0), 5.5) << report.dump();
}

// A low-poly game model through Blender: the OBJ importer keeps the spider's 762 vertices, its
// glTF writer and Merge by Distance join the 40 repeated positions (722 vertices). Such copies
// are the original's vertices and must be read vertex for vertex; the registration of this
// small, thin-legged mesh does not meet its stopping tolerance, which once sent them through
// the resampling (z 8.40 instead of 9.7).
TEST(RealAssetsInterop, KhronosAnimatedMorphCubeIsPosedAsBlenderShowsIt)
{
    INTEROP_REQUIRE_TOOLS("blender", "assimp-testmodels");
    const fs::path model =
        kModels / "glTF2/glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf";
    const fs::path scratch = temp_dir("interop-real-morph-cube");
    const std::vector<int> frames{1, 20, 40};
    std::vector<std::string> ops;
    std::vector<double> times;
    for (const int f : frames)
    {
        ops.push_back("pose=" + std::to_string(f));
        times.push_back(f / 24.0);
    }
    const ToolRun blender = blender_attacks(model, scratch / "posed", ops, scratch);
    ASSERT_TRUE(blender.ok()) << blender.describe();
    const MeshFile file = read_mesh_file(model);
    ASSERT_EQ(file.mesh.V.rows(), 8);  // (its 24 vertex records welded into the cube's corners)
    ASSERT_EQ(file.animations.size(), 1u);
    EXPECT_FALSE(file.animations.front().moves_only_as_a_whole);
    std::vector<ShownPose> poses;
    for_each_animation_pose(
        model, times, [&](ShownPose&& p) { poses.push_back(std::move(p)); },
        file.animations.front().index);
    ASSERT_EQ(poses.size(), frames.size());
    // glTF's y is Blender's z: Blender's (x, y, z) is glTF's (x, -z, y).
    const auto in_blender = [](const Positions& V)
    {
        Positions B(V.rows(), 3);
        B.col(0) = V.col(0);
        B.col(1) = -V.col(2);
        B.col(2) = V.col(1);
        return B;
    };
    double farthest_from_stored = 0.0;
    for (std::size_t k = 0; k < frames.size(); ++k)
    {
        const Positions copy =
            read_mesh(scratch / "posed" / ("pose_" + std::to_string(frames[k]) + ".ply")).V;
        const Positions& shown =
            poses[k].V.rows() == 0 ? file.mesh.V : poses[k].V;  // (no blend: stored)
        const auto [worst, rms] = nearest_distances(copy, in_blender(shown));
        EXPECT_LT(worst, 1e-5) << "frame " << frames[k] << ", rms " << rms;
        farthest_from_stored =
            std::max(farthest_from_stored, nearest_distances(copy, in_blender(file.mesh.V)).first);
    }
    EXPECT_GT(farthest_from_stored, 0.05);
}

// \p model of assimp-testmodels converted to .glb (without its animations when \p still:
// strip_animations.mjs), compressed by `gltf-transform draco` into \p scratch / draco.glb and
// marked with key kSeed (marked.glb, key.json); \p error is set if a step fails.
ConvertedAndMarked convert_compress_and_mark(const fs::path& model, bool still,
                                             const fs::path& scratch, std::string* error)
{
    fs::path plain = scratch / "plain.glb";
    const ToolRun convert = assimp_to_glb(kModels / model, plain, scratch);
    if (!convert.ok())
    {
        *error = convert.describe();
        return {};
    }
    if (still)
    {
        const fs::path stripped = scratch / "still.glb";
        const ToolRun strip =
            node_helper("strip_animations.mjs", {plain.string(), stripped.string()}, scratch);
        if (!strip.ok())
        {
            *error = strip.describe();
            return {};
        }
        plain = stripped;
    }
    ConvertedAndMarked files{scratch / "draco.glb", scratch / "marked.glb", scratch / "key.json"};
    const ToolRun compress =
        run({tools().gltf_transform.string(), "draco", plain.string(), files.original.string()},
            scratch);
    if (!compress.ok())
    {
        *error = compress.describe();
        return {};
    }
    const ToolRun marking = embed(files.original, files.marked, files.key, kSeed, scratch);
    if (!marking.ok())
    {
        *error = marking.describe();
        return {};
    }
    return files;
}

// \p original (Draco-compressed) and its \p marked copy each decoded by glTF-Transform
// (decode_draco.mjs: what a Draco-enabled importer sees; Debian's Blender is built without
// Draco), then put through Blender's \p operations; every copy (each operation's PLY output, and
// the decoded file itself when \p with_decoded) detected against the original: the marked
// ones claimed with z >= \p min_score, the unmarked ones not.
void expect_decoded_blender_copies_claimed(const fs::path& original, const fs::path& marked,
                                           const fs::path& key,
                                           const std::vector<std::string>& operations,
                                           bool with_decoded, double min_score,
                                           const fs::path& scratch)
{
    for (const auto& [input, name] :
         {std::pair{marked, std::string("marked")}, std::pair{original, std::string("clean")}})
    {
        const fs::path decoded = scratch / (name + "_decoded.glb");
        const ToolRun decode =
            node_helper("decode_draco.mjs", {input.string(), decoded.string()}, scratch);
        ASSERT_TRUE(decode.ok()) << decode.describe();
        const ToolRun blender = blender_attacks(decoded, scratch / name, operations, scratch);
        ASSERT_TRUE(blender.ok()) << blender.describe();
        std::vector<fs::path> copies;
        if (with_decoded)
        {
            copies.push_back(decoded);
        }
        for (std::string operation : operations)
        {
            std::replace(operation.begin(), operation.end(), '=', '_');
            copies.push_back(scratch / name / (operation + ".ply"));
        }
        for (const fs::path& copy : copies)
        {
            int exit_code = -1;
            const nlohmann::json report = detect_json(copy, original, key, scratch, &exit_code);
            ASSERT_TRUE(report.is_object()) << copy;
            EXPECT_EQ(exit_code, input == marked ? 0 : 1) << copy << " " << report.dump();
            if (input == marked)
            {
                EXPECT_GE(report.value("score", 0.0), min_score) << copy << " " << report.dump();
            }
        }
    }
}

// The same character compressed by `gltf-transform draco` (its JOINTS_0 and WEIGHTS_0 inside the
// Draco data, as web pipelines ship characters), marked, and imported by a Blender that decodes
// Draco (Debian's does not: glTF-Transform decodes it first, decode_draco.mjs) and exported at
// frame 1 and at frame 20: both claimed, posed through the joints decoded from the Draco data
// (z 0.99 and 0.57 when the poses were read through the mesh node); the unmarked ones not.
TEST(RealAssetsInterop, BlenderCopiesOfADracoCompressedCharacterAreClaimed)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels", "assimp", "node",
                          "gltf-transform");
    const fs::path scratch = temp_dir("interop-real-wuson-draco");
    std::string error;
    const auto [original, marked, key] =
        convert_compress_and_mark("X/Testwuson.X", false, scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    expect_decoded_blender_copies_claimed(original, marked, key, {"ply", "pose=20"}, false, 9.0,
                                          scratch);
}

// The converted DirectX character above without its animations (strip_animations.mjs) and
// compressed by `gltf-transform draco`: a still rig whose scene pose is not its bind pose, its
// joints and weights inside the Draco data. It is marked in the pose viewers show, as the
// uncompressed one is: the marked file decoded by glTF-Transform (what a Draco-enabled
// importer sees) and Blender's PLY copy of that are claimed, the unmarked ones not. Read
// through its mesh node (before the twelfth session), the Draco rig was marked in a shape no
// viewer shows: z 0.00 and -0.06.
TEST(RealAssetsInterop, AStillDracoCompressedRigIsMarkedInThePoseViewersShow)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels", "assimp", "node",
                          "gltf-transform");
    const fs::path scratch = temp_dir("interop-real-still-draco-rig");
    std::string error;
    const auto [original, marked, key] =
        convert_compress_and_mark("X/BCN_Epileptic.X", true, scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    expect_decoded_blender_copies_claimed(original, marked, key, {"ply"}, true, 9.0, scratch);
}

// Two Collada models of assimp's converted to .glb and compressed by `gltf-transform draco`: a
// grid of 64 cubes and a teapot used by two nodes (an instanced mesh). meshmark re-encodes a
// marked Draco primitive with edgebreaker, which numbers the points in its own order, so the
// marked file is the marked mesh renumbered; read through registration, the cubes settled a
// grid step off (z 2.18) and the teapot on its other instance (z 0.41): the marked files
// themselves were not claimed. They are read as the same mesh now, in the original's order.
TEST(RealAssetsInterop, AMarkedDracoFileIsReadAsTheSameMeshWhateverItsPointOrder)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "assimp-testmodels", "assimp", "node", "gltf-transform");
    for (const char* model :
         {"Collada/anims_with_full_rotations_between_keys.DAE", "Collada/teapot_instancenodes.DAE"})
    {
        const fs::path scratch = temp_dir("interop-real-draco-renumbered");
        std::string error;
        const auto [original, marked, key] =
            convert_compress_and_mark(model, false, scratch, &error);
        ASSERT_TRUE(error.empty()) << error;
        int exit_code = -1;
        const nlohmann::json report = detect_json(marked, original, key, scratch, &exit_code);
        ASSERT_TRUE(report.is_object()) << model;
        EXPECT_EQ(exit_code, 0) << model << " " << report.dump();
        EXPECT_EQ(report["registration"].value("method", ""), "same-connectivity") << model;
        EXPECT_GE(report.value("score", 0.0), 9.5) << model << " " << report.dump();
    }
}

// A CAD part from PrusaSlicer's shapes (an M3 screw, 7,768 vertices) smoothed by Open3D as
// the re-work bench does it (bench/blender/open3d_attacks.py, Taubin x 10): Open3D reads the
// STL as a triangle soup and smooths each triangle on its own, shrinking it to a sliver on the
// surface. The area moments the registration starts from were then noise, and with this key
// the copy registered in a helical twin pose of the thread (z 0.94); measured by its vertices
// it is claimed (z 9.98). The unmarked screw through the same filter is not.
}  // namespace meshmark::test::interop
