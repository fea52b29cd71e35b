// SPDX-License-Identifier: MIT
#include "meshmark/attacks/cropping.h"

#include <algorithm>

#include <gtest/gtest.h>

#include "attack_test_util.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{

TEST(CroppingTest, keeps_the_requested_fraction_on_one_side_of_the_plane)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);  // 2562 vertices
    for (const double fraction : {0.9, 0.7, 0.5})
    {
        for (std::uint64_t seed = 0; seed < 5; ++seed)
        {
            Rng rng(seed);
            const AttackResult result = crop(mesh, {.vertex_fraction = fraction}, rng);
            const double target = fraction * static_cast<double>(mesh.V.rows());
            EXPECT_LE(test::relative_error(static_cast<double>(result.mesh.V.rows()), target), 0.02)
                << "fraction " << fraction << ", seed " << seed;
            EXPECT_LE(result.mesh.V.rows(), static_cast<Eigen::Index>(std::round(target)));
            EXPECT_TRUE(edge_statistics(result.mesh).is_consistently_oriented());
            EXPECT_EQ(referenced_vertices(result.mesh).size(),
                      static_cast<std::size_t>(result.mesh.V.rows()));
        }
    }
}

TEST(CroppingTest, explicit_axis_cuts_away_the_far_side_and_correspondence_holds)
{
    const TriangleMesh mesh = icosphere(4);
    Rng rng(1);
    const AttackResult result =
        crop(mesh, {.vertex_fraction = 0.5, .direction = Eigen::Vector3d::UnitX()}, rng);
    ASSERT_TRUE(result.source_vertex.has_value());
    const auto& source = *result.source_vertex;
    ASSERT_EQ(source.size(), static_cast<std::size_t>(result.mesh.V.rows()));
    std::vector<char> is_kept(static_cast<std::size_t>(mesh.V.rows()), 0);
    for (std::size_t k = 0; k < source.size(); ++k)
    {
        EXPECT_EQ(result.mesh.V.row(static_cast<Eigen::Index>(k)), mesh.V.row(source[k]));
        is_kept[static_cast<std::size_t>(source[k])] = 1;
        if (k > 0)
        {
            EXPECT_LT(source[k - 1], source[k]);  // original order kept
        }
    }
    // Every kept vertex lies at or before every removed one along x.
    double kept_max = -1e300;
    double removed_min = 1e300;
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        if (is_kept[static_cast<std::size_t>(i)] != 0)
        {
            kept_max = std::max(kept_max, mesh.V(i, 0));
        }
        else
        {
            removed_min = std::min(removed_min, mesh.V(i, 0));
        }
    }
    EXPECT_LE(kept_max, removed_min + 1e-12);
    EXPECT_LT(kept_max, 0.05);
}

TEST(CroppingTest, point_cloud_keeps_exactly_the_target_and_seeds_change_the_cut)
{
    const TriangleMesh cloud = test::point_cloud_of(icosphere(3));  // 642 points
    Rng a(1);
    Rng b(1);
    Rng c(2);
    const AttackResult first = crop(cloud, {.vertex_fraction = 0.7}, a);
    EXPECT_EQ(first.mesh.V.rows(), 449);  // round(0.7 * 642)
    EXPECT_TRUE(test::bit_identical(first.mesh, crop(cloud, {.vertex_fraction = 0.7}, b).mesh));
    EXPECT_FALSE(test::bit_identical(first.mesh, crop(cloud, {.vertex_fraction = 0.7}, c).mesh));
    EXPECT_THROW((void)crop(cloud, {.vertex_fraction = 0.0}, a), InvalidOption);
    EXPECT_THROW((void)crop(cloud, {.direction = Eigen::Vector3d::Zero()}, a), InvalidOption);
}

}  // namespace meshmark
