// SPDX-License-Identifier: MIT
#include "meshmark/render/rasterizer.h"

#include <random>

#include <gtest/gtest.h>

namespace meshmark
{
namespace
{

Positions screen_points(std::initializer_list<std::array<double, 3>> rows)
{
    Positions s(static_cast<Eigen::Index>(rows.size()), 3);
    Eigen::Index i = 0;
    for (const auto& r : rows)
    {
        s.row(i++) << r[0], r[1], r[2];
    }
    return s;
}

Faces faces_of(std::initializer_list<std::array<std::int32_t, 3>> rows)
{
    Faces f(static_cast<Eigen::Index>(rows.size()), 3);
    Eigen::Index i = 0;
    for (const auto& r : rows)
    {
        f.row(i++) << r[0], r[1], r[2];
    }
    return f;
}

int covered(const VisibilityBuffer& b)
{
    int n = 0;
    for (const std::int32_t p : b.primitive)
    {
        n += p >= 0 ? 1 : 0;
    }
    return n;
}

}  // namespace

TEST(RasterizerTest, right_triangle_covers_the_pixel_centres_inside_it)
{
    // Legs of 8 pixels along the axes: centre (x + 0.5, y + 0.5) is inside when x + y + 1 < 8.
    const Positions s = screen_points({{0, 0, 0}, {8, 0, 0}, {0, 8, 0}});
    for (const Faces& f : {faces_of({{0, 1, 2}}), faces_of({{0, 2, 1}})})  // both windings
    {
        const VisibilityBuffer b = rasterize_triangles(s, f, 12, 10, 1);
        ASSERT_EQ(b.width, 12);
        ASSERT_EQ(b.height, 10);
        for (int y = 0; y < 10; ++y)
        {
            for (int x = 0; x < 12; ++x)
            {
                if (x + y + 1 < 8)
                {
                    EXPECT_EQ(b.primitive[b.index(x, y)], 0) << x << "," << y;
                }
                else if (x + y + 1 > 8)
                {
                    EXPECT_EQ(b.primitive[b.index(x, y)], -1) << x << "," << y;
                }
            }
        }
    }
}

TEST(RasterizerTest, triangles_sharing_an_edge_cover_each_pixel_once)
{
    // A square cut along a diagonal through pixel centres (7.5 = 7 + 0.5): the tie pixels on
    // the diagonal belong to exactly one of the two triangles.
    const Positions s = screen_points({{0.5, 0.5, 0}, {7.5, 0.5, 0}, {7.5, 7.5, 0}, {0.5, 7.5, 0}});
    const VisibilityBuffer first = rasterize_triangles(s, faces_of({{0, 1, 2}}), 9, 9, 1);
    const VisibilityBuffer second = rasterize_triangles(s, faces_of({{0, 2, 3}}), 9, 9, 1);
    int overlap = 0;
    int either = 0;
    for (std::size_t k = 0; k < first.primitive.size(); ++k)
    {
        overlap += first.primitive[k] >= 0 && second.primitive[k] >= 0 ? 1 : 0;
        either += first.primitive[k] >= 0 || second.primitive[k] >= 0 ? 1 : 0;
    }
    EXPECT_EQ(overlap, 0);
    // Centres in [0.5, 7.5]^2: 8 x 8 pixels, of which the rule keeps two adjacent sides of the
    // square's outline (a neighbouring square would own the other two): 7 x 7.
    EXPECT_EQ(either, 7 * 7);
    EXPECT_EQ(covered(rasterize_triangles(s, faces_of({{0, 1, 2}, {0, 2, 3}}), 9, 9, 1)), either);
}

TEST(RasterizerTest, nearest_triangle_wins_whatever_the_order)
{
    // Two overlapping triangles, the second nearer (larger depth).
    const Positions s =
        screen_points({{0, 0, 1}, {10, 0, 1}, {0, 10, 1}, {0, 0, 2}, {10, 0, 2}, {0, 10, 2}});
    const VisibilityBuffer far_first =
        rasterize_triangles(s, faces_of({{0, 1, 2}, {3, 4, 5}}), 10, 10, 1);
    const VisibilityBuffer near_first =
        rasterize_triangles(s, faces_of({{3, 4, 5}, {0, 1, 2}}), 10, 10, 1);
    EXPECT_EQ(far_first.primitive[far_first.index(2, 2)], 1);
    EXPECT_EQ(near_first.primitive[near_first.index(2, 2)], 0);
    EXPECT_FLOAT_EQ(far_first.depth[far_first.index(2, 2)], 2.0f);
    // A tilted plane crossing the flat one: each pixel shows whichever is nearer there.
    const Positions tilted =
        screen_points({{0, 0, 0}, {10, 0, 3}, {0, 10, 0}, {0, 0, 1.5}, {10, 0, 1.5}, {0, 10, 1.5}});
    const VisibilityBuffer b =
        rasterize_triangles(tilted, faces_of({{0, 1, 2}, {3, 4, 5}}), 10, 10, 1);
    EXPECT_EQ(b.primitive[b.index(1, 1)], 1);  // depth 0.45 < 1.5 on the tilted one
    EXPECT_EQ(b.primitive[b.index(7, 1)], 0);  // depth 2.25 > 1.5
}

TEST(RasterizerTest, barycentric_weights_reproduce_the_pixel_centre)
{
    const Positions s = screen_points({{1.2, 0.7, 0}, {18.3, 3.1, 1}, {4.4, 15.9, 2}});
    const VisibilityBuffer b = rasterize_triangles(s, faces_of({{0, 1, 2}}), 20, 20, 1);
    int checked = 0;
    for (int y = 0; y < 20; ++y)
    {
        for (int x = 0; x < 20; ++x)
        {
            const std::size_t k = b.index(x, y);
            if (b.primitive[k] < 0)
            {
                continue;
            }
            const double u = b.u[k];
            const double v = b.v[k];
            const Eigen::Vector3d p = (1 - u - v) * s.row(0) + u * s.row(1) + v * s.row(2);
            EXPECT_NEAR(p.x(), x + 0.5, 1e-4);
            EXPECT_NEAR(p.y(), y + 0.5, 1e-4);
            EXPECT_NEAR(p.z(), b.depth[k], 1e-5);
            ++checked;
        }
    }
    EXPECT_GT(checked, 80);
}

TEST(RasterizerTest, degenerate_and_offscreen_triangles_draw_nothing)
{
    const Positions s = screen_points(
        {{0, 0, 0}, {5, 5, 0}, {10, 10, 0}, {-50, -50, 0}, {-40, -50, 0}, {-50, -40, 0}});
    EXPECT_EQ(covered(rasterize_triangles(s, faces_of({{0, 1, 2}, {3, 4, 5}}), 16, 16, 1)), 0);
}

TEST(RasterizerTest, same_buffer_for_any_thread_count)
{
    // Random overlapping triangles spanning many bands.
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> coord(-10.0, 210.0);
    Positions s(600, 3);
    for (Eigen::Index i = 0; i < s.rows(); ++i)
    {
        s.row(i) << coord(rng), coord(rng), coord(rng);
    }
    Faces f(200, 3);
    for (Eigen::Index i = 0; i < f.rows(); ++i)
    {
        f.row(i) << static_cast<std::int32_t>(3 * i), static_cast<std::int32_t>(3 * i + 1),
            static_cast<std::int32_t>(3 * i + 2);
    }
    const VisibilityBuffer one = rasterize_triangles(s, f, 200, 150, 1);
    const VisibilityBuffer four = rasterize_triangles(s, f, 200, 150, 4);
    EXPECT_EQ(one.primitive, four.primitive);
    EXPECT_EQ(one.depth, four.depth);
    EXPECT_EQ(one.u, four.u);
    EXPECT_GT(covered(one), 200 * 150 / 2);
}

TEST(RasterizerTest, points_are_discs_and_the_nearest_shows)
{
    const Positions s = screen_points({{10, 10, 0}, {12, 10, 1}, {30.2, 30.7, 0}});
    const VisibilityBuffer b = rasterize_points(s, {0, 1, 2}, 3.0, 40, 40, 2);
    // Pixel centres within 3 pixels of (10, 10) or (12, 10); the nearer point 1 wins between.
    EXPECT_EQ(b.primitive[b.index(11, 10)], 1);
    EXPECT_EQ(b.primitive[b.index(7, 10)], 0);
    EXPECT_EQ(b.primitive[b.index(14, 10)], 1);
    EXPECT_EQ(b.primitive[b.index(10, 14)], -1);
    // A lone disc of radius 3: the pixel centres within 3 of (30.2, 30.7).
    int expected = 0;
    int found = 0;
    for (int y = 20; y < 40; ++y)
    {
        for (int x = 20; x < 40; ++x)
        {
            const double dx = x + 0.5 - 30.2;
            const double dy = y + 0.5 - 30.7;
            expected += dx * dx + dy * dy <= 9.0 ? 1 : 0;
            found += b.primitive[b.index(x, y)] == 2 ? 1 : 0;
        }
    }
    EXPECT_EQ(found, expected);
    // A tiny radius still draws the pixel under the point.
    const VisibilityBuffer tiny = rasterize_points(s, {2}, 0.1, 40, 40, 1);
    EXPECT_EQ(covered(tiny), 1);
    EXPECT_EQ(tiny.primitive[tiny.index(30, 30)], 2);
}

}  // namespace meshmark
