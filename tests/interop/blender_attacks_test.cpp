// SPDX-License-Identifier: MIT
// The interop suite's check of the Blender re-work bench (bench/blender/attacks.py,
// docs/robustness.md): four of its cheap operations on a small generated mesh, run by Blender
// itself, each output read back by meshmark and compared with what the operation must do; and an
// unknown operation refused before anything is written.
#include <cmath>
#include <numbers>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "interop_support.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark::test::interop
{

namespace
{

const fs::path kAttacks = fs::path(MESHMARK_BENCH_BLENDER_DIR) / "attacks.py";

ToolRun blender_attacks(const fs::path& input, const fs::path& out_dir,
                        const std::vector<std::string>& ops, const fs::path& scratch)
{
    std::vector<std::string> words = {tools().blender.string(), "-b",     "--factory-startup",
                                      "--python-exit-code",     "2",      "--python",
                                      kAttacks.string(),        "--",     input.string(),
                                      out_dir.string(),         "--seed", "7"};
    words.insert(words.end(), ops.begin(), ops.end());
    return run(words, scratch);
}

}  // namespace

TEST(BlenderInterop, ReworkBenchOperationsDoWhatTheySay)
{
    INTEROP_REQUIRE_TOOLS("blender");
    const fs::path scratch = temp_dir("interop-blender-attacks");
    const fs::path input = scratch / "lumpy.ply";
    const TriangleMesh original = lumpy_ellipsoid(4);  // 2,562 vertices, 5,120 faces
    write_mesh(input, original);
    const fs::path out = scratch / "out";
    fs::create_directories(out);
    const ToolRun blender =
        blender_attacks(input, out, {"decimate=0.5", "transform", "mirror", "bisect"}, scratch);
    ASSERT_TRUE(blender.ok()) << blender.describe();
    ASSERT_TRUE(fs::exists(out / "attacks.json")) << blender.describe();

    const Box box = bounds(original.V);
    const double diagonal = box.diagonal();

    // Decimate (collapse) to 50%: half the faces, within 10%, and still on the surface.
    const TriangleMesh decimated = read_mesh(out / "decimate_0.5.ply");
    EXPECT_NEAR(static_cast<double>(decimated.F.rows()),
                0.5 * static_cast<double>(original.F.rows()),
                0.05 * static_cast<double>(original.F.rows()));
    EXPECT_LT((bounds(decimated.V).lo - box.lo).norm(), 0.05 * diagonal);
    EXPECT_LT((bounds(decimated.V).hi - box.hi).norm(), 0.05 * diagonal);

    // Transform: every vertex moved by the documented similarity
    // p -> (0.1, -0.2, 0.3) * diagonal + 1.5 * Rz(40) Ry(30) Rx(20) p (Blender's XYZ Euler).
    // Blender's PLY writer emits the vertices in the order the faces first use them, so each
    // expected position is looked up among the written ones.
    const TriangleMesh moved = read_mesh(out / "transform.ply");
    ASSERT_EQ(moved.V.rows(), original.V.rows());
    ASSERT_EQ(moved.F.rows(), original.F.rows());
    const double degree = std::numbers::pi / 180.0;
    const Eigen::Matrix3d turn = (Eigen::AngleAxisd(40 * degree, Eigen::Vector3d::UnitZ()) *
                                  Eigen::AngleAxisd(30 * degree, Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(20 * degree, Eigen::Vector3d::UnitX()))
                                     .toRotationMatrix();
    Positions expected = (1.5 * original.V * turn.transpose()).rowwise() +
                         Eigen::RowVector3d(0.1, -0.2, 0.3) * diagonal;
    double worst = 0.0;
    for (const ClosestPoint& c : cloud_index(moved.V).closest(expected))
    {
        worst = std::max(worst, c.distance);
    }
    EXPECT_LT(worst, 1e-5 * diagonal);

    // Mirror in x about the bbox centre, the faces reversed so that they still face out: every
    // vertex where its mirror image is expected, and the enclosed volume as positive as before.
    const TriangleMesh mirrored = read_mesh(out / "mirror.ply");
    ASSERT_EQ(mirrored.V.rows(), original.V.rows());
    Positions mirror_expected = original.V;
    mirror_expected.col(0) = (box.lo.x() + box.hi.x()) - original.V.col(0).array();
    worst = 0.0;
    for (const ClosestPoint& c : cloud_index(mirrored.V).closest(mirror_expected))
    {
        worst = std::max(worst, c.distance);
    }
    EXPECT_LT(worst, 1e-5 * diagonal);
    const auto volume = [](const TriangleMesh& m)
    {
        double v = 0.0;
        for (Eigen::Index f = 0; f < m.F.rows(); ++f)
        {
            const Eigen::Vector3d a = m.V.row(m.F(f, 0));
            v += a.dot(Eigen::Vector3d(m.V.row(m.F(f, 1)))
                           .cross(Eigen::Vector3d(m.V.row(m.F(f, 2))))) /
                 6.0;
        }
        return v;
    };
    EXPECT_GT(volume(original), 0.0);
    EXPECT_NEAR(volume(mirrored), volume(original), 1e-4 * volume(original));

    // Bisect through the bbox centre across the largest extent, one side cleared: about half the
    // vertices remain, all on the kept side of the plane.
    const TriangleMesh half = read_mesh(out / "bisect.ply");
    Eigen::Index axis = 0;
    (box.hi - box.lo).maxCoeff(&axis);
    const double centre = 0.5 * (box.lo(axis) + box.hi(axis));
    EXPECT_NEAR(static_cast<double>(half.V.rows()), 0.5 * static_cast<double>(original.V.rows()),
                0.15 * static_cast<double>(original.V.rows()));
    EXPECT_GT(half.V.col(axis).minCoeff(), centre - 1e-6 * diagonal);
    EXPECT_NEAR(half.V.col(axis).maxCoeff(), box.hi(axis), 1e-6 * diagonal);
}

TEST(BlenderInterop, ReworkBenchRefusesAnUnknownOperationBeforeWriting)
{
    INTEROP_REQUIRE_TOOLS("blender");
    const fs::path scratch = temp_dir("interop-blender-attacks-bad");
    const fs::path input = scratch / "lumpy.ply";
    write_mesh(input, lumpy_ellipsoid(2));
    const fs::path out = scratch / "out";
    fs::create_directories(out);
    const ToolRun blender = blender_attacks(input, out, {"transform", "shatter=3"}, scratch);
    EXPECT_EQ(blender.result.exit_code, 2) << blender.describe();
    EXPECT_NE(blender.result.err.find("unknown operation 'shatter'"), std::string::npos)
        << blender.describe();
    EXPECT_TRUE(fs::is_empty(out)) << "nothing may be written when an operation is refused";
}

}  // namespace meshmark::test::interop
