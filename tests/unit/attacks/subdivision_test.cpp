// SPDX-License-Identifier: MIT
#include "meshmark/attacks/subdivision.h"

#include <algorithm>
#include <array>
#include <set>

#include <gtest/gtest.h>

#include "attack_test_util.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

std::set<std::array<double, 3>> positions(const TriangleMesh& mesh)
{
    std::set<std::array<double, 3>> result;
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        result.insert({mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2)});
    }
    return result;
}

}  // namespace

TEST(SubdivisionTest, counts_follow_each_scheme_and_closed_surfaces_stay_closed)
{
    const TriangleMesh mesh = icosphere(2);  // V 162, E 480, F 320
    struct Case
    {
        SubdivisionScheme scheme;
        Eigen::Index vertices;
        Eigen::Index faces;
    };
    for (const Case& c :
         {Case{SubdivisionScheme::Loop, 642, 1280}, Case{SubdivisionScheme::Midpoint, 642, 1280},
          Case{SubdivisionScheme::Sqrt3, 482, 960}})
    {
        const TriangleMesh s = subdivide(mesh, {.scheme = c.scheme});
        EXPECT_EQ(s.V.rows(), c.vertices);
        EXPECT_EQ(s.F.rows(), c.faces);
        const EdgeStatistics edges = edge_statistics(s);
        EXPECT_TRUE(edges.is_closed());
        EXPECT_TRUE(edges.is_consistently_oriented());
    }
    const TriangleMesh twice = subdivide(mesh, {.scheme = SubdivisionScheme::Loop, .steps = 2});
    EXPECT_EQ(twice.F.rows(), 16 * 320);
}

TEST(SubdivisionTest, midpoint_keeps_old_vertices_and_adds_edge_midpoints)
{
    const TriangleMesh mesh = icosphere(1);
    const TriangleMesh s = subdivide(mesh, {.scheme = SubdivisionScheme::Midpoint});
    const auto out = positions(s);
    for (const auto& p : positions(mesh))
    {
        EXPECT_TRUE(out.contains(p));
    }
    // Every new vertex lies inside the unit sphere (a chord midpoint), every old one on it.
    const Eigen::VectorXd r = s.V.rowwise().norm();
    EXPECT_EQ((r.array() > 1.0 - 1e-12).count(), mesh.V.rows());
}

TEST(SubdivisionTest, loop_smooths_towards_the_inside_of_a_convex_surface)
{
    const TriangleMesh mesh = icosphere(2);
    const TriangleMesh s = subdivide(mesh, {.scheme = SubdivisionScheme::Loop});
    const Eigen::VectorXd r = s.V.rowwise().norm();
    EXPECT_LT(r.maxCoeff(), 1.0);
    EXPECT_GT(r.minCoeff(), 0.95);
}

TEST(SubdivisionTest, open_surfaces_subdivide_and_point_clouds_throw)
{
    const TriangleMesh grid = plane_grid(5, 4);  // V 30, E 69, F 40
    EXPECT_EQ(subdivide(grid, {.scheme = SubdivisionScheme::Loop}).V.rows(), 30 + 69);
    EXPECT_EQ(subdivide(grid, {.scheme = SubdivisionScheme::Sqrt3}).F.rows(), 3 * 40);
    EXPECT_THROW((void)subdivide(test::point_cloud_of(grid), {}), InvalidMesh);
    EXPECT_THROW((void)subdivide(grid, {.steps = 0}), InvalidOption);
}

}  // namespace meshmark
