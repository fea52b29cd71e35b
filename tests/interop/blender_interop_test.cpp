// SPDX-License-Identifier: MIT
// The interop suite's Blender case (docs/interop.md): `meshmark attack voxel=N` against Blender's
// own voxel remesh (Remesh modifier, Voxel mode, adaptivity 0, Voxel Size = diagonal / N) of the
// same mesh. Both run OpenVDB's level set and surface extraction, so they must give the same
// vertices; only their order and the split of Blender's quads into triangles may differ.
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "interop_support.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark::test::interop
{

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
        const ToolRun attack = meshmark(
            {"attack", input.string(), "-o", ours.string(), "voxel=" + resolution, "-q"}, scratch);
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

// Blender's OBJ writer with loose edges (`l` lines) and a loose vertex: marked, every line but
// the moved `v` lines is kept byte for byte, the wire's vertices do not move (they carry no
// mark), and the mark is found (issue 52, item 1).
TEST(BlenderInterop, AnObjWithLooseEdgesIsMarkedAndKeptLineForLine)
{
    INTEROP_REQUIRE_TOOLS("meshmark", "blender");
    const fs::path scratch = temp_dir("interop-blender-wire");
    const fs::path input = scratch / "wire.obj";
    const ToolRun blender = run(
        {tools().blender.string(), "-b", "--factory-startup", "--python-exit-code", "2", "--python",
         (fs::path(MESHMARK_INTEROP_DIR) / "blender_wire_obj.py").string(), "--", input.string()},
        scratch);
    ASSERT_TRUE(blender.ok() && fs::exists(input)) << blender.describe();
    const fs::path marked = scratch / "marked.obj";
    const fs::path key = scratch / "key.json";
    const ToolRun embed = meshmark(
        {"embed", input.string(), "-o", marked.string(), "--key", key.string(), "-q"}, scratch);
    ASSERT_TRUE(embed.ok()) << embed.describe();

    const auto lines = [](const fs::path& path)
    {
        std::vector<std::string> all;
        std::istringstream in(file_bytes(path));
        for (std::string line; std::getline(in, line);)
        {
            all.push_back(line);
        }
        return all;
    };
    const std::vector<std::string> before = lines(input);
    const std::vector<std::string> after = lines(marked);
    ASSERT_EQ(before.size(), after.size());
    int loose_edges = 0;
    int moved = 0;
    for (std::size_t k = 0; k < before.size(); ++k)
    {
        loose_edges += before[k].rfind("l ", 0) == 0 ? 1 : 0;
        if (before[k].rfind("v ", 0) != 0)
        {
            EXPECT_EQ(after[k], before[k]) << "line " << k + 1;
        }
        moved += before[k] != after[k] ? 1 : 0;
    }
    EXPECT_EQ(loose_edges, 19);
    const TriangleMesh original = read_mesh(input);
    const TriangleMesh copy = read_mesh(marked);
    const auto wire = static_cast<Eigen::Index>(
        original.V.rows() - static_cast<Eigen::Index>(referenced_vertices(original).size()));
    EXPECT_EQ(wire, 21);  // the cable's 20 vertices and the loose one
    EXPECT_EQ(moved, static_cast<int>(referenced_vertices(original).size()));
    for (Eigen::Index i = original.V.rows() - wire; i < original.V.rows(); ++i)
    {
        EXPECT_EQ(copy.V.row(i), original.V.row(i)) << "wire vertex " << i;
    }
    const ToolRun detect = meshmark(
        {"detect", marked.string(), "--original", input.string(), "--key", key.string(), "-q"},
        scratch);
    EXPECT_EQ(detect.result.exit_code, 0) << detect.describe();
}

}  // namespace meshmark::test::interop
