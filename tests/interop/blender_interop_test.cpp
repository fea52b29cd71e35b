// SPDX-License-Identifier: MIT
// The interop suite's Blender case (docs/interop.md): `meshmark attack voxel=N` against Blender's
// own voxel remesh (Remesh modifier, Voxel mode, adaptivity 0, Voxel Size = diagonal / N) of the
// same mesh. Both run OpenVDB's level set and surface extraction, so they must give the same
// vertices; only their order and the split of Blender's quads into triangles may differ.
#include <gtest/gtest.h>

#include <string>

#include "interop_support.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark::test::interop {

TEST(BlenderInterop, VoxelRemeshGivesBlendersVertices)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender");
    const fs::path scratch = temp_dir("interop-blender-voxel");
    const fs::path input = scratch / "lumpy.ply";
    write_mesh(input, lumpy_ellipsoid(4));
    for (const std::string resolution : {"150", "60"})
    {
        const fs::path theirs = scratch / ("blender_" + resolution + ".ply");
        const fs::path ours = scratch / ("meshmark_" + resolution + ".ply");
        const ToolRun blender =
            run({tools().blender.string(), "-b", "--factory-startup", "--python",
                 (fs::path(MESHMARK_INTEROP_DIR) / "blender_voxel_remesh.py").string(), "--",
                 input.string(), theirs.string(), resolution},
                scratch);
        ASSERT_TRUE(blender.ok() && fs::exists(theirs)) << blender.describe();
        const ToolRun attack =
            meshmark({"attack", input.string(), "-o", ours.string(), "voxel=" + resolution, "-q"},
                     scratch);
        ASSERT_TRUE(attack.ok()) << attack.describe();

        const TriangleMesh a = read_mesh(theirs);
        const TriangleMesh b = read_mesh(ours);
        ASSERT_EQ(a.V.rows(), b.V.rows()) << "N = " << resolution;
        // Blender's quads, fan-split by the reader, against our triangles: same count.
        EXPECT_EQ(a.F.rows(), b.F.rows()) << "N = " << resolution;
        // Every Blender vertex is one of ours, up to single-precision rounding.
        const double diagonal = bounds(b.V).diagonal();
        const ClosestPointIndex index = cloud_index(b.V);
        double worst = 0.0;
        for (const ClosestPoint& c : index.closest(a.V))
        {
            worst = std::max(worst, c.distance);
        }
        EXPECT_LT(worst, 1e-5 * diagonal) << "N = " << resolution;
    }
}

}  // namespace meshmark::test::interop
