// SPDX-License-Identifier: MIT
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include <CGAL/Simple_cartesian.h>
#include <CGAL/squared_distance_3.h>
#include <gtest/gtest.h>

#include "meshmark/core/rng.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/geometry/point_triangle.h"

namespace meshmark
{
namespace
{

using Kernel = CGAL::Simple_cartesian<double>;

Kernel::Point_3 to_cgal(const Eigen::Vector3d& p)
{
    return {p.x(), p.y(), p.z()};
}

Eigen::Vector3d random_point(Rng& rng, double scale)
{
    return scale * Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal());
}

// The distance to the answer of both forms of a triangle is CGAL's distance, and on a proper
// triangle the answer lies on it; a sliver is given its flag.
void expect_closest(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                    const Eigen::Vector3d& c)
{
    const Kernel::Triangle_3 t(to_cgal(a), to_cgal(b), to_cgal(c));
    const double expected = std::sqrt(CGAL::squared_distance(to_cgal(p), t));
    const bool is_sliver = is_sliver_triangle(a, b, c);
    for (const Eigen::Vector3d& q :
         {closest_point_on_triangle(p, TriangleCorners{a, b, c}, is_sliver),
          closest_point_on_triangle(p, TriangleEdges{a, b - a, c - a}, is_sliver)})
    {
        EXPECT_NEAR((q - p).norm(), expected, 1e-12);
        if (!is_sliver)  // CGAL's distance to a degenerate triangle is no test of lying on it
        {
            EXPECT_LE(std::sqrt(CGAL::squared_distance(to_cgal(q), t)), 1e-12);
        }
    }
}

}  // namespace

TEST(PointTriangleTest, both_forms_match_cgal_on_proper_and_degenerate_triangles)
{
    Rng rng(11);
    for (int i = 0; i < 2000; ++i)
    {
        const Eigen::Vector3d a = random_point(rng, 1.0);
        const Eigen::Vector3d b = random_point(rng, 1.0);
        const Eigen::Vector3d c = random_point(rng, 1.0);
        const Eigen::Vector3d p = random_point(rng, 2.0);
        expect_closest(p, a, b, c);
        expect_closest(p, a, b, a + 0.3 * (b - a));  // collinear corners
        expect_closest(p, a, a, c);                  // a zero-length edge
    }
}

TEST(PointTriangleTest, slivers_are_flagged_by_their_smallest_altitude)
{
    const Eigen::Vector3d a(0.0, 0.0, 0.0);
    const Eigen::Vector3d b(1.0, 0.0, 0.0);
    EXPECT_FALSE(is_sliver_triangle(a, b, Eigen::Vector3d(0.5, 0.5, 0.0)));
    EXPECT_TRUE(is_sliver_triangle(a, b, Eigen::Vector3d(0.5, 1e-4, 0.0)));
    EXPECT_TRUE(is_sliver_triangle(a, b, b));
}

TEST(PointKdTreeTest, nearest_points_match_brute_force)
{
    Rng rng(12);
    Positions points(500, 3);
    for (Eigen::Index i = 0; i < points.rows(); ++i)
    {
        points.row(i) = random_point(rng, 1.0).transpose();
    }
    PointKdTree moved_from(points);
    const PointKdTree tree(std::move(moved_from));
    EXPECT_EQ(tree.points(), points);
    for (int q = 0; q < 200; ++q)
    {
        const Eigen::Vector3d query = random_point(rng, 1.5);
        std::array<double, 2> best{std::numeric_limits<double>::infinity(),
                                   std::numeric_limits<double>::infinity()};
        for (Eigen::Index i = 0; i < points.rows(); ++i)
        {
            const double d2 = (points.row(i).transpose() - query).squaredNorm();
            if (d2 < best[0])
            {
                best = {d2, best[0]};
            }
            else if (d2 < best[1])
            {
                best[1] = d2;
            }
        }
        double squared = -1.0;
        const std::uint32_t index = tree.nearest(query, squared);
        EXPECT_DOUBLE_EQ(squared, best[0]);
        EXPECT_DOUBLE_EQ((points.row(index).transpose() - query).squaredNorm(), best[0]);
        std::array<std::uint32_t, 2> two{};
        std::array<double, 2> two_squared{};
        ASSERT_EQ(tree.nearest(query, 2, two.data(), two_squared.data()), 2U);
        EXPECT_DOUBLE_EQ(two_squared[0], best[0]);
        EXPECT_DOUBLE_EQ(two_squared[1], best[1]);
        // Within a bound: the nearest when it is nearer than the bound, nothing otherwise (the
        // bound taken on both sides of the true distance).
        for (const double bound : {0.5 * best[0], 2.0 * best[0]})
        {
            double within = -1.0;
            const std::optional<std::uint32_t> near = tree.nearest_within(query, bound, within);
            ASSERT_EQ(near.has_value(), best[0] < bound);
            if (near)
            {
                EXPECT_DOUBLE_EQ(within, best[0]);
                EXPECT_DOUBLE_EQ((points.row(*near).transpose() - query).squaredNorm(), best[0]);
            }
            else
            {
                EXPECT_EQ(within, -1.0);  // left as it was
            }
        }
    }
}

}  // namespace meshmark
