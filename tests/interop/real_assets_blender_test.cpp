// SPDX-License-Identifier: MIT
// The interop suite's real assets (docs/interop.md) through Blender: copies of low-poly game
// models, rigged and animated characters, symmetric shapes, turntables and shape-keyed creatures
// read vertex for vertex, in their poses or through their blends.
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
TEST(RealAssetsInterop, BlenderCopiesOfALowPolyGameModelAreReadVertexForVertex)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels");
    const fs::path scratch = temp_dir("interop-real-spider");
    const fs::path original = kModels / "OBJ/spider.obj";
    const fs::path marked = scratch / "marked.obj";
    const fs::path key = scratch / "key.json";
    const ToolRun marking = embed(original, marked, key, "1", scratch);
    ASSERT_TRUE(marking.ok()) << marking.describe();

    const fs::path out = scratch / "blender";
    const ToolRun blender = blender_attacks(marked, out, {"gltf", "merge"}, scratch);
    ASSERT_TRUE(blender.ok()) << blender.describe();
    for (const char* copy : {"gltf.glb", "merge.ply"})
    {
        const TriangleMesh mesh = read_mesh(out / copy);
        EXPECT_EQ(mesh.V.rows(), 722) << copy << ": Blender joined another number of positions";
        int exit_code = -1;
        const nlohmann::json report = detect_json(out / copy, original, key, scratch, &exit_code);
        ASSERT_TRUE(report.is_object()) << copy;
        EXPECT_EQ(exit_code, 0) << report.dump();
        EXPECT_EQ(report["registration"].value("method", ""), "registration (vertices matched)")
            << copy;
        EXPECT_GE(report.value("score", 0.0), 9.5) << copy << ": " << report.dump();
    }
}

// A rigged character converted the way people convert game formats (`assimp export` of the
// DirectX BCN_Epileptic.X to .glb): its scene pose is not its bind pose, so Blender (like every
// viewer) shows it bent by its joints. meshmark reads a skinned mesh the same way; read
// through the node's transform instead, every Blender copy of the marked character was another
// shape and lost its mark (z 1.2-1.3 after plain round trips).
TEST(RealAssetsInterop, BlenderRoundTripsOfAConvertedRiggedCharacterAreClaimed)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels", "assimp");
    const fs::path scratch = temp_dir("interop-real-rig");
    std::string error;
    const auto [original, marked, key] =
        convert_and_mark("X/BCN_Epileptic.X", "character.glb", scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    const fs::path out = scratch / "blender";
    const ToolRun blender = blender_attacks(marked, out, {"gltf", "ply"}, scratch);
    ASSERT_TRUE(blender.ok()) << blender.describe();
    for (const char* copy : {"gltf.glb", "ply.ply"})
    {
        int exit_code = -1;
        const nlohmann::json report = detect_json(out / copy, original, key, scratch, &exit_code);
        ASSERT_TRUE(report.is_object()) << copy;
        EXPECT_EQ(exit_code, 0) << copy << ": " << report.dump();
        EXPECT_GE(report.value("score", 0.0), 7.0) << copy << ": " << report.dump();
    }
}

// LightWave's pink egg (`DXF/PinkEggFromLW.dxf`, converted to .glb by assimp: 266 positions,
// symmetric by a half turn about its long axis and by mirrors), marked and written by
// Blender's PLY writer (every vertex split per face corner, turned Z up): registration settles
// half a turn off as readily as in place, and read there the mark was noise (z 0.71); each
// twin pose is read now (docs/algorithms/detection.md, General suspects, step 1b). The unmarked
// egg through the same round trip is not claimed.
TEST(RealAssetsInterop, ABlenderCopyOfASymmetricEggIsReadInItsTwinPoses)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels", "assimp");
    const fs::path scratch = temp_dir("interop-real-egg");
    expect_blender_ply_copy_claimed("DXF/PinkEggFromLW.dxf", "egg.glb", scratch);
}

// Blender's Suzanne (`BLEND/Suzanne_248.blend`, converted to .glb by assimp: 11,616 positions,
// mirror-symmetric vertex for vertex), marked, then mirrored in Blender (bench/blender/
// attacks.py `mirror`: Object > Mirror > X and Apply Scale). The mirrored copy puts each vertex
// where its mirror partner stood, so registration matches it unmirrored and the mark read
// nothing (z 0.55 before the original's mirror images were read as twin poses); read in the
// mirrored pose it is claimed. The unmarked Suzanne mirrored the same way is not.
TEST(RealAssetsInterop, ABlenderMirroredCopyOfSuzanneIsReadInItsMirroredPose)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels", "assimp");
    const fs::path scratch = temp_dir("interop-real-suzanne");
    expect_blender_ply_copy_claimed("BLEND/Suzanne_248.blend", "suzanne.glb", scratch, "mirror",
                                    "registration (vertices matched)");
}

// DirectX's Wuson (`X/Testwuson.X`, converted to .glb by assimp: 2,124 positions skinned to 38
// joints, three animations): Blender shows it at frame 1 of its first animation (a run), and
// its PLY writer hands that pose on. Read against the stored pose, the mark was noise (z 1.78);
// read through the pose the original is shown in (docs/algorithms/detection.md, General
// suspects, step 1c), it is claimed. The unmarked character through the same round trip is not.
TEST(RealAssetsInterop, ABlenderCopyOfAnAnimatedCharacterIsReadInThePoseBlenderShowsIt)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels", "assimp");
    const fs::path scratch = temp_dir("interop-real-wuson");
    expect_blender_ply_copy_claimed("X/Testwuson.X", "wuson.glb", scratch);
}

// The same character exported by Blender at frame 20 of its run (a user who poses it for a
// print or a render): read through the frame of its animation it fits best (step 1c; z 9.79,
// 3.80 when the frame is looked for only by a short ICP, -0.70 when only frame 1 is read).
TEST(RealAssetsInterop, ABlenderCopyOfAnAnimatedCharacterExportedAtAnotherFrameIsClaimed)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels", "assimp");
    const fs::path scratch = temp_dir("interop-real-wuson-frame");
    expect_blender_ply_copy_claimed("X/Testwuson.X", "wuson.glb", scratch, "pose=20");
}

// The same character moved (turned, scaled) and mirrored in Blender as it is shown (the
// re-work's `transform` and `mirror` bake a rigged mesh's pose first): read through the pose
// Blender shows it in, each is claimed. Until the seventeenth session the re-work moved or
// mirrored the mesh data under bones that were not, which is no similarity of any pose (held-out
// copies of this character read z 1.77 / 2.15 moved and 0.46 / 2.55 mirrored that way; 9.78 /
// 9.79 both now).
TEST(RealAssetsInterop, ABlenderMirroredCopyOfAnAnimatedCharacterIsClaimed)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels", "assimp");
    const fs::path scratch = temp_dir("interop-real-wuson-mirror");
    expect_blender_ply_copy_claimed("X/Testwuson.X", "wuson.glb", scratch, "mirror");
}

TEST(RealAssetsInterop, ABlenderMovedCopyOfAnAnimatedCharacterIsClaimed)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels", "assimp");
    const fs::path scratch = temp_dir("interop-real-wuson-transform");
    expect_blender_ply_copy_claimed("X/Testwuson.X", "wuson.glb", scratch, "transform");
}

// The same character after the user switched Blender's action to its second animation (its
// walk; Blender plays the first, the run, and keeps the others in muted NLA tracks) and exported
// it at frame 20 (`attacks.py second-action=20`): read through the walk's frame 20 and claimed
// (z 9.79; 0.87 when only the first animation was searched), the unmarked one not.
TEST(RealAssetsInterop, ABlenderCopyPosedByAnotherAnimationIsReadThroughIt)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender", "assimp-testmodels", "assimp");
    const fs::path scratch = temp_dir("interop-real-wuson-walk");
    expect_blender_ply_copy_claimed("X/Testwuson.X", "wuson.glb", scratch, "second-action=20",
                                    "registration (animation 'Wuson_Walk' at 20/24 s)");
}

// A shop or viewer model on a display turntable (bench/blender/make_game_asset.py
// turntable-vehicle: Blender turns the vehicle's root once over frames 1-96): the animation
// only moves the asset as a whole, so detection does not search its frames (no "poses" phase)
// and charges nothing for a second reading. Blender's PLY copy exported at frame 30 (turned by
// 110 degrees) is claimed; the unmarked model through the same steps is not.
TEST(RealAssetsInterop, ABlenderTurntableIsReadAsOneAssetWithoutAFrameSearch)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender");
    const fs::path scratch = temp_dir("interop-real-turntable");
    std::string error;
    const MarkedGameAsset asset =
        make_and_mark_game_asset("turntable-vehicle", kSeed, {}, scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    check_marked_and_clean(asset.original, asset.marked, asset.key, "pose=30", "pose_30.ply",
                           scratch,
                           [](const nlohmann::json& report, int exit_code, bool is_marked)
                           {
                               EXPECT_FALSE(report["seconds"].contains("poses")) << report.dump();
                               EXPECT_EQ(exit_code, is_marked ? 0 : 1) << report.dump();
                               if (is_marked)
                               {
                                   EXPECT_GE(report.value("score", 0.0), 10.0) << report.dump();
                               }
                           });
}

// The game-like vehicle (bench/blender/make_game_asset.py) is nearly the same turned end for end.
// Marked with `--strength 0.001` and voxel-remeshed by Blender at 1/300 of the diagonal, the copy
// registered turned (RMS 0.28% of the diagonal) with both seeds 1 and 2 (z 1.94, -1.33): with seed
// 1 the last coarse round kept seven copies of the turned pose among its eight survivors, and now
// a round's survivors are distinct poses (0.095%, z 8.12); with seed 2 the right pose dropped out
// in the second round (the coarse rounds barely tell the two ends apart), and now the best coarse
// pose turned half a turn about each principal axis goes to the fine stage where it fits about
// as well (z 8.35). The unmarked vehicle through the same steps is not claimed.
TEST(RealAssetsInterop, AVoxelRemeshOfANearlySymmetricVehicleIsNotRegisteredTurned)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender");
    const fs::path scratch = temp_dir("interop-real-vehicle-voxel");
    std::string error;
    const MarkedGameAsset asset =
        make_and_mark_game_asset("vehicle", "1", {"--strength", "0.001"}, scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    const fs::path marked2 = scratch / "marked2.glb";
    const fs::path key2 = scratch / "key2.json";
    const ToolRun marking =
        embed(asset.original, marked2, key2, "2", scratch, {"--strength", "0.001"});
    ASSERT_TRUE(marking.ok()) << marking.describe();
    for (const auto& [marked, key] : {std::pair{asset.marked, asset.key}, std::pair{marked2, key2}})
    {
        check_marked_and_clean(
            asset.original, marked, key, "voxel=300", "voxel_300.ply", scratch,
            [&](const nlohmann::json& report, int exit_code, bool is_marked)
            {
                EXPECT_EQ(exit_code, is_marked ? 0 : 1) << key << report.dump();
                if (is_marked)
                {
                    EXPECT_GE(report.value("score", 0.0), 7.0) << key << report.dump();
                    // Turned, the copy lies 0.27-0.28% of the diagonal from the
                    // original; in its pose, under 0.1% (the mark and the remesh).
                    EXPECT_LT(report["registration"].value("rms_error", 1.0), 0.0015)
                        << key << report.dump();
                }
            });
    }
}

// The game-like creature with a shape key (bench/blender/make_game_asset.py morph-creature: "puff"
// swells its head by 1.7% of the diagonal, 0.6 in the file and keyed 0.6 -> 0 -> 1 over frames
// 1-20). Blender's copies show the blend, which the stored base positions do not; after its
// Decimate to 5% the copy read against the base scored 3.24 (seed 1) and was lost. The reader
// now gives the blend as a pose of the shape key's animation, and the copy is read through it
// (z 5.29). The unmarked creature through the same steps is not claimed.
TEST(RealAssetsInterop, ABlenderDecimateOfAShapeKeyedCreatureIsReadThroughItsBlend)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender");
    const fs::path scratch = temp_dir("interop-real-morph-decimate");
    std::string error;
    const MarkedGameAsset asset =
        make_and_mark_game_asset("morph-creature", "1", {}, scratch, &error);
    ASSERT_TRUE(error.empty()) << error;
    check_marked_and_clean(
        asset.original, asset.marked, asset.key, "decimate=0.05", "decimate_0.05.ply", scratch,
        [](const nlohmann::json& report, int exit_code, bool is_marked)
        {
            EXPECT_EQ(exit_code, is_marked ? 0 : 1) << report.dump();
            if (is_marked)
            {
                // (frames 1 and 16 show the same blend, 0.6, and either may fit first)
                EXPECT_EQ(report["registration"]
                              .value("method", "")
                              .rfind("registration (animation 'KeyAction' at ", 0),
                          0U)
                    << report.dump();
            }
        });
}

// Khronos' AnimatedMorphCube (the glTF sample models in assimp-testmodels): a cube of 24 vertices
// with two morph targets whose weights one animation keys over 4.2 s (127 keys, LINEAR). Blender's
// copies at frames 1, 20 and 40 (its PLY writer: every vertex where the shape keys show it) lie on
// the reader's poses at 1/24, 20/24 and 40/24 s, and at least one of them far from the stored
// cube: the reader blends the targets as Blender does.
}  // namespace meshmark::test::interop
