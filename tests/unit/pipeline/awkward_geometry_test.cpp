// SPDX-License-Identifier: MIT
// embed, detect and compare on awkward geometry made from a real scan (issue 52, item 4;
// tests/support/awkward_geometry.h): each variant is marked, moved and noised, and its mark is
// found in the copy; the unmarked variant is not claimed, nor its voxel remesh (which has
// detection voxel-remesh the awkward original too); compare measures the pair. None may crash;
// a variant a mark cannot use would be refused with meshmark::Error.
#include "support/awkward_geometry.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "meshmark/attacks/attack_spec.h"
#include "meshmark/attacks/voxel_remeshing.h"
#include "meshmark/meshmark.h"
#include "meshmark/metrics/distortion.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

TEST(AwkwardGeometryPipelineTest, every_awkward_variant_of_a_real_scan_is_marked_found_and_measured)
{
    const auto path = test::mesh_dir() / "bunny.off";
    if (!std::filesystem::exists(path))
    {
        GTEST_SKIP() << path << " is not available";
    }
    for (const auto& [name, mesh] : test::awkward_variants(read_mesh(path)))
    {
        SCOPED_TRACE(name);
        EmbedMeshOptions options;
        options.seed = 52;
        const EmbedResult marked = embed(mesh, options);
        TriangleMesh copy = mesh;
        copy.V = marked.positions;
        const AttackResult attacked =
            apply_attacks(copy, parse_attack_spec("similarity,noise=0.0005"), 9);
        const DetectReport found = detect(attacked.mesh, mesh, marked.key, DetectFileOptions{});
        EXPECT_TRUE(found.detected());
        const DetectReport unmarked = detect(mesh, mesh, marked.key, DetectFileOptions{});
        EXPECT_FALSE(unmarked.detected());
        // The never-marked variant voxel-remeshed: detection remeshes the awkward original
        // itself to read it (VoxelPredictor), and must neither crash nor claim it.
        const TriangleMesh remeshed = voxel_remesh(mesh, {.resolution = 150.0});
        EXPECT_FALSE(detect(remeshed, mesh, marked.key, DetectFileOptions{}).detected());
        const DistortionReport distortion = compare_meshes(mesh, copy, CompareOptions{});
        EXPECT_GT(distortion.hausdorff_rel, 0.0);
        EXPECT_LT(distortion.hausdorff_rel, 0.02);
    }
}

}  // namespace
}  // namespace meshmark
