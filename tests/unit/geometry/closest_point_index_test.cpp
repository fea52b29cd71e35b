// SPDX-License-Identifier: MIT
#include "meshmark/geometry/closest_point_index.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <utility>
#include <vector>

#include <CGAL/Simple_cartesian.h>
#include <CGAL/squared_distance_3.h>
#include <gtest/gtest.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/morton.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

using Kernel = CGAL::Simple_cartesian<double>;

Kernel::Point_3 to_cgal(const Eigen::Vector3d& p)
{
    return {p.x(), p.y(), p.z()};
}

Kernel::Triangle_3 triangle(const TriangleMesh& mesh, Eigen::Index f)
{
    auto corner = [&](int c) { return to_cgal(mesh.V.row(mesh.F(f, c)).transpose()); };
    return {corner(0), corner(1), corner(2)};
}

/// Distance from \p p to the surface by trying every triangle, with CGAL's point-triangle
/// distance as an independent oracle.
double brute_force_distance(const TriangleMesh& mesh, const Eigen::Vector3d& p)
{
    double best = std::numeric_limits<double>::infinity();
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        best = std::min(best, CGAL::squared_distance(to_cgal(p), triangle(mesh, f)));
    }
    return std::sqrt(best);
}

/// Queries of every kind: far away, near the surface, on vertices and on edge midpoints.
Positions mixed_queries(const TriangleMesh& mesh, std::uint64_t seed, Eigen::Index count)
{
    Rng rng(seed);
    const BoundingBox box = bounding_box(mesh.V);
    const Eigen::Vector3d lo = box.min - 0.5 * (box.max - box.min);
    const Eigen::Vector3d hi = box.max + 0.5 * (box.max - box.min);
    Positions queries(count, 3);
    for (Eigen::Index i = 0; i < count; ++i)
    {
        const auto v =
            static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(mesh.V.rows())));
        switch (i % 4)
        {
            case 0:  // anywhere in an enlarged box
                for (Eigen::Index k = 0; k < 3; ++k)
                {
                    queries(i, k) = rng.uniform(lo[k], hi[k]);
                }
                break;
            case 1:  // close to the surface
                for (Eigen::Index k = 0; k < 3; ++k)
                {
                    queries(i, k) = mesh.V(v, k) + 1e-3 * box.diagonal() * rng.normal();
                }
                break;
            case 2:  // exactly on a vertex
                queries.row(i) = mesh.V.row(v);
                break;
            default:  // on an edge
            {
                const auto f =
                    static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(mesh.F.rows())));
                queries.row(i) = 0.5 * (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)));
            }
        }
    }
    return queries;
}

void expect_matches_brute_force(const TriangleMesh& mesh, const Positions& queries)
{
    const ClosestPointIndex index(mesh);
    ASSERT_FALSE(index.is_point_cloud());
    const auto results = index.closest(queries, 2);
    ASSERT_EQ(static_cast<Eigen::Index>(results.size()), queries.rows());
    for (Eigen::Index i = 0; i < queries.rows(); ++i)
    {
        const Eigen::Vector3d q = queries.row(i).transpose();
        const ClosestPoint& r = results[static_cast<std::size_t>(i)];
        ASSERT_GE(r.face, 0);
        ASSERT_LT(r.face, mesh.F.rows());
        EXPECT_EQ(r.vertex, -1);
        EXPECT_NEAR(r.distance, brute_force_distance(mesh, q), 1e-12) << "query " << i;
        EXPECT_DOUBLE_EQ(r.distance, (r.point - q).norm());
        // The reported point lies on the reported face.
        EXPECT_LE(std::sqrt(CGAL::squared_distance(to_cgal(r.point), triangle(mesh, r.face))),
                  1e-12)
            << "query " << i;
    }
}

}  // namespace

TEST(ClosestPointIndexTest, matches_brute_force_on_random_queries)
{
    expect_matches_brute_force(lumpy_ellipsoid(3), mixed_queries(lumpy_ellipsoid(3), 1, 400));
    const TriangleMesh ring = torus(1.0, 0.3, 40, 16);
    expect_matches_brute_force(ring, mixed_queries(ring, 2, 400));
}

TEST(ClosestPointIndexTest, matches_brute_force_on_open_and_tiny_meshes)
{
    const TriangleMesh grid = plane_grid(7, 5);
    expect_matches_brute_force(grid, mixed_queries(grid, 3, 500));
    TriangleMesh single;
    single.V.resize(3, 3);
    single.V << 0.0, 0.0, 0.0, 1.0, 0.2, 0.0, 0.3, 1.0, 0.5;
    single.F.resize(1, 3);
    single.F << 0, 1, 2;
    expect_matches_brute_force(single, mixed_queries(single, 4, 500));
}

TEST(ClosestPointIndexTest, handles_degenerate_triangles_like_brute_force)
{
    // A grid with a collinear (zero-area) triangle, a triangle with a repeated corner and a
    // needle appended: the index must still return the true distance to the whole set.
    TriangleMesh mesh = plane_grid(4, 4);
    const Eigen::Index n = mesh.V.rows();
    mesh.V.conservativeResize(n + 4, 3);
    mesh.V.row(n) << 0.2, 0.3, 0.4;
    mesh.V.row(n + 1) << 0.6, 0.5, 0.6;
    mesh.V.row(n + 2) << 1.0, 0.7, 0.8;  // collinear with the two above
    mesh.V.row(n + 3) << 0.6, 0.5 + 1e-13, 0.6;
    const Eigen::Index m = mesh.F.rows();
    mesh.F.conservativeResize(m + 3, 3);
    const auto i = static_cast<std::int32_t>(n);
    mesh.F.row(m) << i, i + 1, i + 2;
    mesh.F.row(m + 1) << i, i, i + 2;
    mesh.F.row(m + 2) << i, i + 1, i + 3;
    expect_matches_brute_force(mesh, mixed_queries(mesh, 5, 1000));
}

TEST(ClosestPointIndexTest, points_on_the_surface_are_at_zero_distance)
{
    const TriangleMesh mesh = lumpy_ellipsoid(2);
    const ClosestPointIndex index(mesh);
    for (Eigen::Index f = 0; f < mesh.F.rows(); f += 7)
    {
        const Eigen::Vector3d centroid =
            (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2)))
                .transpose() /
            3.0;
        EXPECT_LE(index.closest(centroid).distance, 1e-15);
    }
}

TEST(ClosestPointIndexTest, results_are_identical_for_one_and_two_threads)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const Positions queries = mixed_queries(mesh, 6, 3000);
    const ClosestPointIndex index(mesh);
    const auto one = index.closest(queries, 1);
    const auto two = index.closest(queries, 2);
    ASSERT_EQ(one.size(), two.size());
    for (std::size_t i = 0; i < one.size(); ++i)
    {
        ASSERT_EQ(one[i].face, two[i].face) << i;
        ASSERT_EQ(one[i].distance, two[i].distance) << i;
        ASSERT_EQ(one[i].point, two[i].point) << i;
        // The batch call gives what a single query gives.
        ASSERT_EQ(
            one[i].distance,
            index.closest(Eigen::Vector3d(queries.row(static_cast<Eigen::Index>(i)))).distance);
    }
}

// Above 65536 queries in a scattered order the batch answers them in Z order: every answer must
// still land in its own slot, for a scattered batch and for the same queries in a coherent one.
TEST(ClosestPointIndexTest, large_scattered_and_coherent_batches_answer_every_query_in_its_slot)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const ClosestPointIndex index(mesh);
    const Positions scattered = mixed_queries(mesh, 8, 70000);  // random: a scattered order
    // The same points in Z order: a coherent order, answered as given.
    const auto order = morton_order(scattered, 10);
    Positions coherent(scattered.rows(), 3);
    for (std::size_t k = 0; k < order.size(); ++k)
    {
        coherent.row(static_cast<Eigen::Index>(k)) =
            scattered.row(static_cast<Eigen::Index>(order[k]));
    }
    const auto a = index.closest(scattered, 2);
    const auto b = index.closest(coherent, 2);
    ASSERT_EQ(a.size(), 70000U);
    for (std::size_t k = 0; k < order.size(); k += 7)
    {
        const auto i = order[k];
        const auto single =
            index.closest(Eigen::Vector3d(scattered.row(static_cast<Eigen::Index>(i))));
        ASSERT_EQ(a[i].face, single.face) << i;
        ASSERT_EQ(a[i].point, single.point) << i;
        ASSERT_EQ(b[k].face, single.face) << k;
        ASSERT_EQ(b[k].distance, single.distance) << k;
    }
}

// A flat fan of 64 triangles around vertex 0, which is every triangle's first corner: a query
// straight above it is exactly as far from all of them (each returns that corner bit for bit).
// Whatever order the faces come in (so whatever tree the build makes), the answer is the lowest
// face index, as ClosestPointIndex documents; a search that keeps the first tie it meets returns
// whichever face its traversal reaches first.
TEST(ClosestPointIndexTest, exact_ties_go_to_the_lowest_face_whatever_the_face_order)
{
    constexpr int n = 64;
    TriangleMesh fan;
    fan.V.resize(n + 1, 3);
    fan.V.row(0) << 0.0, 0.0, 0.0;
    for (int i = 0; i < n; ++i)
    {
        const double angle = 2.0 * std::numbers::pi * i / n;
        fan.V.row(i + 1) << std::cos(angle), std::sin(angle), 0.0;
    }
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    Rng rng(11);
    for (int trial = 0; trial < 20; ++trial)
    {
        for (int i = n - 1; i > 0; --i)
        {
            std::swap(
                order[static_cast<std::size_t>(i)],
                order[static_cast<std::size_t>(rng.below(static_cast<std::uint64_t>(i + 1)))]);
        }
        fan.F.resize(n, 3);
        for (int f = 0; f < n; ++f)
        {
            const int i = order[static_cast<std::size_t>(f)];
            fan.F.row(f) << 0, i + 1, (i + 1) % n + 1;
        }
        const ClosestPointIndex index(fan);
        const ClosestPoint hit = index.closest(Eigen::Vector3d(0.0, 0.0, 1.0));
        EXPECT_EQ(hit.face, 0) << "trial " << trial;
        EXPECT_EQ(hit.distance, 1.0);
        EXPECT_EQ(hit.point, Eigen::Vector3d::Zero());
    }
}

TEST(ClosestPointIndexTest, point_cloud_returns_nearest_vertex)
{
    TriangleMesh cloud = lumpy_ellipsoid(3);
    cloud.F.resize(0, 3);
    const ClosestPointIndex index(cloud);
    ASSERT_TRUE(index.is_point_cloud());
    TriangleMesh surface = lumpy_ellipsoid(3);
    const Positions queries = mixed_queries(surface, 7, 1000);
    const auto results = index.closest(queries, 2);
    for (Eigen::Index i = 0; i < queries.rows(); ++i)
    {
        const Eigen::RowVector3d q = queries.row(i);
        Eigen::Index nearest = 0;
        const double best = (cloud.V.rowwise() - q).rowwise().norm().minCoeff(&nearest);
        const ClosestPoint& r = results[static_cast<std::size_t>(i)];
        EXPECT_EQ(r.face, -1);
        EXPECT_NEAR(r.distance, best, 1e-12);
        EXPECT_EQ(r.point, cloud.V.row(r.vertex).transpose());
        EXPECT_NEAR((cloud.V.row(r.vertex) - q).norm(), best, 1e-12);
    }
}

TEST(ClosestPointIndexTest, rejects_empty_mesh_and_survives_moves)
{
    EXPECT_THROW(ClosestPointIndex(TriangleMesh{}), InvalidMesh);
    ClosestPointIndex a(icosphere(2));
    const Eigen::Vector3d far(3.0, 0.0, 0.0);
    const double expected = a.closest(far).distance;
    EXPECT_NEAR(expected, 2.0, 1e-12);  // (1, 0, 0) is a vertex of the icosphere
    ClosestPointIndex b(std::move(a));
    EXPECT_EQ(b.closest(far).distance, expected);
    ClosestPointIndex c(plane_grid(1, 1));
    c = std::move(b);
    EXPECT_EQ(c.closest(far).distance, expected);
}

}  // namespace meshmark
