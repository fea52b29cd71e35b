// SPDX-License-Identifier: MIT
// The library facade (meshmark.h) reading copies of symmetric originals: each twin pose, and
// mirrored copies of mirror-symmetric (or nearly) originals read in their mirrored pose.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/meshmark.h"
#include "meshmark/metrics/distortion.h"
#include "seeded_options.h"
#include "support/test_paths.h"
#include "support/test_shapes.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

using test::seeded;

}  // namespace
// A symmetric original (an ellipsoid on a subdivided icosahedron: a half turn about each axis
// maps it onto itself, vertices onto vertices) fits a copy as well in its twin poses, and
// registration may settle in any of them (Blender's PLY copy of an egg did: z 0.71). Here the
// registration is started in a twin pose on purpose (point pairs that say the copy stands half
// a turn about x), where it stays: every twin pose is then read, the right one claims the
// copy, and the unmarked ellipsoid through the same steps is not claimed.
TEST(FacadeTest, a_copy_of_a_symmetric_original_is_read_in_each_of_its_twin_poses)
{
    const fs::path dir = test::temp_dir("facade-symmetric");
    TriangleMesh ellipsoid = icosphere(3);
    ellipsoid.V = ellipsoid.V * Eigen::Vector3d(1.0, 1.5, 2.0).asDiagonal();
    write_mesh(dir / "ellipsoid.ply", ellipsoid);
    (void)embed_file(dir / "ellipsoid.ply", dir / "marked.ply", dir / "key.json", seeded(5));
    const Key key = read_key(dir / "key.json");
    DetectFileOptions twin_start;
    const Eigen::Matrix3d half_turn = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1.5, 0),
                                     Eigen::Vector3d(0, 0, 2), Eigen::Vector3d(0.5, 0.5, 0.5)})
    {
        twin_start.pairs.push_back(PointPair{p, half_turn * p});
    }
    const auto reordered = [](const TriangleMesh& mesh)
    { return apply_attacks(mesh, parse_attack_spec("reorder"), 3, 1).mesh; };
    const DetectReport marked =
        detect(reordered(read_mesh(dir / "marked.ply")), ellipsoid, key, twin_start);
    EXPECT_TRUE(marked.decision.is_present) << marked.decision.score;
    EXPECT_GT(marked.decision.score, 9.0);
    EXPECT_LT((marked.transform.topLeftCorner<3, 3>() - Eigen::Matrix3d::Identity()).norm(), 0.05)
        << "read in the twin pose:\n"
        << marked.transform;
    const DetectReport clean = detect(reordered(ellipsoid), ellipsoid, key, twin_start);
    EXPECT_FALSE(clean.decision.is_present) << clean.decision.score;
}

// The bent ellipsoid below: an icosphere bent in its y-z plane, so that the mirror image in x
// maps it onto itself, vertices onto vertices, and no rotation does; with \p horn, a lump on
// one side only (the vertices near (0.8, 0.6, 0) pushed out, by up to 30%), as a character
// modelled with a Mirror modifier and then given a part on one side.
namespace
{

TriangleMesh bent_ellipsoid(bool horn)
{
    TriangleMesh bent = icosphere(3);
    for (Eigen::Index i = 0; i < bent.V.rows(); ++i)
    {
        Eigen::Vector3d p = bent.V.row(i);
        if (horn)
        {
            p *= 1.0 + 0.3 * std::exp(-(p - Eigen::Vector3d(0.8, 0.6, 0.0)).squaredNorm() / 0.01);
        }
        bent.V.row(i) =
            Eigen::RowVector3d(p.x(), 1.5 * p.y() + 0.4 * p.z() * p.z(), 2.0 * p.z() + 0.3 * p.y());
    }
    return bent;
}

// The bent ellipsoid (with its horn or not) marked, and that copy and the original itself
// mirrored in x and then \p moved: the copy is claimed, read in a mirrored pose; the original
// is not.
void expect_mirrored_copy_claimed(bool horn, const std::string& moved, Correspondence alignment)
{
    const fs::path dir = test::temp_dir(horn ? "facade-near-mirror" : "facade-mirror");
    const TriangleMesh bent = bent_ellipsoid(horn);
    write_mesh(dir / "bent.ply", bent);
    (void)embed_file(dir / "bent.ply", dir / "marked.ply", dir / "key.json", seeded(5));
    const Key key = read_key(dir / "key.json");
    const auto mirrored = [&](const TriangleMesh& mesh)
    { return apply_attacks(mesh, parse_attack_spec("similarity:mirror=x," + moved), 3, 1).mesh; };
    const DetectReport marked = detect(mirrored(read_mesh(dir / "marked.ply")), bent, key);
    EXPECT_EQ(marked.correspondence, alignment) << moved;
    EXPECT_TRUE(marked.decision.is_present) << moved << " " << marked.decision.score;
    EXPECT_GT(marked.decision.score, 9.0) << moved;
    EXPECT_LT((marked.transform.topLeftCorner<3, 3>().determinant()), 0.0)
        << moved << ", read unmirrored:\n"
        << marked.transform;
    const DetectReport clean = detect(mirrored(bent), bent, key);
    EXPECT_FALSE(clean.decision.is_present) << moved << " " << clean.decision.score;
}

}  // namespace

// The bent ellipsoid fits its own mirror image exactly. So a mirrored copy (x -> -x, as
// Blender's Mirror or a scale of -1 makes it) is matched where it stands, each vertex taken for
// its mirror partner, or, moved, registers as well unmirrored, where the tie goes: either way
// the mark is read where it is not (z 1.71 before the mirror maps). The mirrored twin pose is
// read too and claims the copy. (A 5% remesh of the teapot registered mirrored the other way
// round: z 3.37.)
TEST(FacadeTest, a_mirrored_copy_of_a_mirror_symmetric_original_is_read_in_its_mirrored_pose)
{
    expect_mirrored_copy_claimed(false, "reorder", Correspondence::VerticesMatched);
    expect_mirrored_copy_claimed(false, "reorder,similarity", Correspondence::VerticesMatched);
}

// Nearly mirror-symmetric: the bent ellipsoid with a horn on one side. Its mirror image about
// the centroid misses by far more than the mark (the horn, and the centroid and principal axes
// it moves), so the exact test finds no symmetry; refitted on the 90% of the surface that does
// mirror, it does, and a mirrored and moved copy, which registration lays unmirrored on the
// symmetric part (z 1.22 without the refit), is read mirrored and claimed.
TEST(FacadeTest, a_mirrored_copy_of_a_nearly_mirror_symmetric_original_is_read_in_its_mirrored_pose)
{
    expect_mirrored_copy_claimed(true, "reorder,similarity", Correspondence::VerticesMatched);
}

// A game vehicle that is mirror-symmetric but for a box on one side of its roof (2.7% of its
// vertices): enough to change its third moments by 4-10% of the radius cubed, so no mirror map
// passes self_symmetries' moment test, and too little for the registration to tell a mirrored
// copy from its unmirrored fit (it chose unmirrored: z 2.23 for a mirrored and reordered copy,
// 1.85 for one remeshed to half). The registration's fit of the other handedness is read too
// and claims them; the unmarked vehicle through the same steps is not claimed.
TEST(FacadeTest,
     a_mirrored_copy_of_a_nearly_mirror_symmetric_vehicle_is_read_in_its_other_handedness)
{
    const fs::path dir = test::temp_dir("facade-other-handedness");
    const TriangleMesh vehicle = test::vehicle(true);
    write_mesh(dir / "vehicle.ply", vehicle);
    (void)embed_file(dir / "vehicle.ply", dir / "marked.ply", dir / "key.json", seeded(5));
    const Key key = read_key(dir / "key.json");
    const TriangleMesh marked = read_mesh(dir / "marked.ply");
    for (const std::string moved : {"reorder", "reorder,similarity", "remesh=0.5"})
    {
        const auto mirrored = [&](const TriangleMesh& mesh) {
            return apply_attacks(mesh, parse_attack_spec("similarity:mirror=y," + moved), 3, 1)
                .mesh;
        };
        const DetectReport copy = detect(mirrored(marked), vehicle, key);
        EXPECT_TRUE(copy.decision.is_present) << moved << " " << copy.decision.score;
        EXPECT_GT(copy.decision.score, moved == "remesh=0.5" ? 5.5 : 9.0) << moved;
        EXPECT_LT((copy.transform.topLeftCorner<3, 3>().determinant()), 0.0)
            << moved << ", read unmirrored:\n"
            << copy.transform;
        const DetectReport clean = detect(mirrored(vehicle), vehicle, key);
        EXPECT_FALSE(clean.decision.is_present) << moved << " " << clean.decision.score;
    }
}
}  // namespace meshmark
