// SPDX-License-Identifier: MIT
#include "meshmark/attacks/voxel_remeshing.h"

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "attack_test_util.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

double voxel_edge(const TriangleMesh& mesh, double resolution)
{
    return bounding_box(mesh.V).diagonal() / resolution;
}

}  // namespace

TEST(VoxelRemeshingTest, sphere_stays_a_closed_outward_sphere_within_a_fraction_of_a_voxel)
{
    const TriangleMesh mesh = icosphere(5);  // unit radius, 10242 vertices
    for (const double resolution : {60.0, 150.0})
    {
        const TriangleMesh r = voxel_remesh(mesh, {.resolution = resolution});
        const double voxel = voxel_edge(mesh, resolution);
        const Eigen::VectorXd radii = r.V.rowwise().norm();
        EXPECT_LT((radii.array() - 1.0).abs().maxCoeff(), 0.1 * voxel) << resolution;
        const EdgeStatistics edges = edge_statistics(r);
        EXPECT_TRUE(edges.is_closed()) << resolution;
        EXPECT_TRUE(edges.is_consistently_oriented()) << resolution;
        EXPECT_NEAR(test::signed_volume(r), 4.0 / 3.0 * std::numbers::pi, 0.04) << resolution;
        EXPECT_EQ(referenced_vertices(r).size(), static_cast<std::size_t>(r.V.rows()));
    }
}

TEST(VoxelRemeshingTest, vertex_count_goes_as_the_area_over_the_squared_voxel_edge)
{
    // One vertex per surface-crossing cell: about area / voxel^2 times a constant of order 1,
    // so doubling the resolution quadruples the count.
    const TriangleMesh mesh = torus(1.0, 0.4, 96, 48);
    const double area = 4.0 * std::numbers::pi * std::numbers::pi * 1.0 * 0.4;
    const auto coarse = static_cast<double>(voxel_remesh(mesh, {.resolution = 60.0}).V.rows());
    const auto fine = static_cast<double>(voxel_remesh(mesh, {.resolution = 120.0}).V.rows());
    EXPECT_NEAR(fine / coarse, 4.0, 0.3);
    const double per_area = coarse * std::pow(voxel_edge(mesh, 60.0), 2) / area;
    EXPECT_GT(per_area, 1.0);
    EXPECT_LT(per_area, 2.0);
}

TEST(VoxelRemeshingTest, deterministic_for_any_thread_count_and_far_from_the_origin)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const TriangleMesh one = voxel_remesh(mesh, {.resolution = 100.0}, 1);
    EXPECT_TRUE(test::bit_identical(one, voxel_remesh(mesh, {.resolution = 100.0}, 2)));
    EXPECT_TRUE(test::bit_identical(one, voxel_remesh(mesh, {.resolution = 100.0}, 0)));

    // Moved a million voxels away: single-precision points there would be off by several
    // voxels, but the mesh is brought back to the origin by whole voxels first.
    const double voxel = voxel_edge(mesh, 100.0);
    const Eigen::RowVector3d offset = Eigen::RowVector3d(1.0e6, -2.0e6, 0.5e6) * voxel;
    TriangleMesh far = mesh;
    far.V.rowwise() += offset;
    TriangleMesh back = voxel_remesh(far, {.resolution = 100.0});
    ASSERT_EQ(back.V.rows(), one.V.rows());
    ASSERT_EQ(back.F, one.F);
    back.V.rowwise() -= offset;
    EXPECT_LT((back.V - one.V).cwiseAbs().maxCoeff(), 1e-3 * voxel);
}

TEST(VoxelRemeshingTest, rejects_point_clouds_flat_meshes_and_bad_resolutions)
{
    const TriangleMesh mesh = icosphere(3);
    EXPECT_THROW((void)voxel_remesh(test::point_cloud_of(mesh), {}), InvalidMesh);
    TriangleMesh collapsed = mesh;
    collapsed.V.setConstant(0.5);
    EXPECT_THROW((void)voxel_remesh(collapsed, {}), InvalidMesh);
    for (const double bad : {9.0, 2001.0, 0.0, -150.0, std::nan("")})
    {
        EXPECT_THROW((void)voxel_remesh(mesh, {.resolution = bad}), InvalidOption) << bad;
    }
}

}  // namespace meshmark
