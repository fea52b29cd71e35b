// SPDX-License-Identifier: MIT
#include "meshmark/attacks/simplification.h"

#include <cmath>
#include <variant>
#include <vector>

#include <gtest/gtest.h>

#include "attack_test_util.h"
#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{

TEST(SimplificationTest, closed_sphere_reaches_the_target_and_stays_closed_on_the_surface)
{
    const TriangleMesh mesh = icosphere(4);  // 2562 vertices
    for (const auto policy :
         {SimplificationPolicy::GarlandHeckbert, SimplificationPolicy::LindstromTurk})
    {
        for (const double fraction : {0.5, 0.25, 0.1, 0.02})
        {
            const TriangleMesh s = simplify(mesh, {.vertex_fraction = fraction, .policy = policy});
            const double target = fraction * static_cast<double>(mesh.V.rows());
            EXPECT_LE(test::relative_error(static_cast<double>(s.V.rows()), target), 0.1)
                << "fraction " << fraction;
            const EdgeStatistics edges = edge_statistics(s);
            EXPECT_TRUE(edges.is_closed()) << "fraction " << fraction;
            EXPECT_TRUE(edges.is_consistently_oriented()) << "fraction " << fraction;
            // Closed genus-0 surface: V - E + F = 2.
            EXPECT_EQ(s.V.rows() - static_cast<Eigen::Index>(edges.edge_count) + s.F.rows(), 2);
            const Eigen::VectorXd r = s.V.rowwise().norm();
            EXPECT_LT((r.array() - 1.0).abs().maxCoeff(), fraction >= 0.1 ? 0.02 : 0.1);
        }
    }
}

TEST(SimplificationTest, torus_keeps_its_genus_and_result_is_deterministic)
{
    const TriangleMesh mesh = torus(1.0, 0.3, 64, 24);
    const TriangleMesh a = simplify(mesh, {.vertex_fraction = 0.1});
    const TriangleMesh b = simplify(mesh, {.vertex_fraction = 0.1});
    EXPECT_TRUE(test::bit_identical(a, b));
    const EdgeStatistics edges = edge_statistics(a);
    EXPECT_TRUE(edges.is_closed());
    EXPECT_EQ(a.V.rows() - static_cast<Eigen::Index>(edges.edge_count) + a.F.rows(), 0);
}

TEST(SimplificationTest, target_counts_referenced_vertices_and_drops_unreferenced_ones)
{
    const TriangleMesh mesh = test::with_unreferenced_vertex(icosphere(3));  // 642 + 1
    const TriangleMesh s = simplify(mesh, {.vertex_fraction = 0.5});
    EXPECT_EQ(s.V.rows(), 321);
    EXPECT_LT(s.V.cwiseAbs().maxCoeff(), 1.01);  // the vertex at (3, 3, 3) is gone
}

TEST(SimplificationTest, non_manifold_input_is_cut_apart_and_simplified)
{
    // A sphere with a fin: one extra triangle on an existing edge (three faces on that edge).
    TriangleMesh mesh = icosphere(3);
    mesh.V.conservativeResize(mesh.V.rows() + 1, 3);
    mesh.V.row(mesh.V.rows() - 1) = 1.5 * mesh.V.row(mesh.F(0, 0));
    mesh.F.conservativeResize(mesh.F.rows() + 1, 3);
    mesh.F.row(mesh.F.rows() - 1) << mesh.F(0, 1), mesh.F(0, 0),
        static_cast<std::int32_t>(mesh.V.rows() - 1);
    ASSERT_FALSE(edge_statistics(mesh).is_edge_manifold());
    const TriangleMesh s = simplify(mesh, {.vertex_fraction = 0.25});
    EXPECT_TRUE(edge_statistics(s).is_edge_manifold());
    EXPECT_LE(test::relative_error(static_cast<double>(s.V.rows()), 0.25 * 643.0), 0.1);
}

TEST(SimplificationTest, small_holes_and_loose_triangles_do_not_stop_it_short_of_the_target)
{
    // Every 40th face removed (64 triangular holes) and 10 loose triangles added: collapses
    // around a triangular hole are invalid and a loose triangle cannot shrink.
    const TriangleMesh sphere = icosphere(4);
    TriangleMesh mesh;
    mesh.V = sphere.V;
    std::vector<Eigen::RowVector3i> kept;
    for (Eigen::Index f = 0; f < sphere.F.rows(); ++f)
    {
        if (f % 40 != 0)
        {
            kept.push_back(sphere.F.row(f));
        }
    }
    const auto n = mesh.V.rows();
    mesh.V.conservativeResize(n + 30, 3);
    for (int t = 0; t < 10; ++t)
    {
        const double x = 2.0 + t;
        mesh.V.row(n + 3 * t) << x, 0.0, 0.0;
        mesh.V.row(n + 3 * t + 1) << x, 0.5, 0.0;
        mesh.V.row(n + 3 * t + 2) << x, 0.0, 0.5;
        const auto first = static_cast<int>(n + 3 * t);
        kept.emplace_back(first, first + 1, first + 2);
    }
    mesh.F.resize(static_cast<Eigen::Index>(kept.size()), 3);
    for (std::size_t f = 0; f < kept.size(); ++f)
    {
        mesh.F.row(static_cast<Eigen::Index>(f)) = kept[f];
    }
    const double target = 0.02 * static_cast<double>(mesh.V.rows());
    const TriangleMesh s = simplify(mesh, {.vertex_fraction = 0.02});
    EXPECT_LE(test::relative_error(static_cast<double>(s.V.rows()), target), 0.1)
        << s.V.rows() << " vertices";
    EXPECT_TRUE(edge_statistics(s).is_consistently_oriented());
}

TEST(SimplificationTest, meshopt_keeps_input_vertices_near_the_target_and_is_deterministic)
{
    const TriangleMesh mesh = torus(1.0, 0.3, 64, 24);  // 1536 vertices
    for (const double fraction : {0.5, 0.1, 0.02})
    {
        const SimplificationOptions options{.vertex_fraction = fraction,
                                            .method = SimplificationMethod::Meshoptimizer};
        const TriangleMesh a = simplify(mesh, options);
        const TriangleMesh b = simplify(mesh, options);
        EXPECT_TRUE(test::bit_identical(a, b)) << "fraction " << fraction;
        const double target = fraction * static_cast<double>(mesh.V.rows());
        EXPECT_LE(test::relative_error(static_cast<double>(a.V.rows()), target), 0.1)
            << "fraction " << fraction << ": " << a.V.rows() << " vertices";
        // Collapses land on existing vertices: every kept position is an input position,
        // in increasing original order, and no face is degenerate.
        Eigen::Index cursor = 0;
        for (Eigen::Index v = 0; v < a.V.rows(); ++v)
        {
            while (cursor < mesh.V.rows() && mesh.V.row(cursor) != a.V.row(v))
            {
                ++cursor;
            }
            ASSERT_LT(cursor, mesh.V.rows()) << "vertex " << v << " is not an input vertex";
        }
        for (Eigen::Index f = 0; f < a.F.rows(); ++f)
        {
            EXPECT_TRUE(a.F(f, 0) != a.F(f, 1) && a.F(f, 1) != a.F(f, 2) && a.F(f, 0) != a.F(f, 2));
        }
        EXPECT_EQ(referenced_vertices(a).size(), static_cast<std::size_t>(a.V.rows()));
    }
}

TEST(SimplificationTest, method_key_parses_and_round_trips)
{
    const auto specs = parse_attack_spec("simplify=0.1:method=meshopt,simplify=0.2:method=cgal");
    ASSERT_EQ(specs.size(), 2U);
    const auto& fast = std::get<SimplificationOptions>(specs[0]);
    EXPECT_EQ(fast.method, SimplificationMethod::Meshoptimizer);
    EXPECT_EQ(std::get<SimplificationOptions>(specs[1]).method, SimplificationMethod::Cgal);
    EXPECT_EQ(to_string(specs[0]), "simplify=0.1:method=meshopt");
    EXPECT_EQ(to_string(specs[1]), "simplify=0.2");  // the default method is omitted
    EXPECT_EQ(parse_attack_spec(to_string(specs[0])).front(), specs[0]);
    EXPECT_THROW((void)parse_attack_spec("simplify=0.1:method=fast"), InvalidOption);
}

TEST(SimplificationTest, boundary_key_parses_round_trips_and_weighs_the_borders)
{
    const auto specs = parse_attack_spec("simplify=0.1:boundary=1,simplify=0.1:boundary=100");
    EXPECT_EQ(std::get<SimplificationOptions>(specs[0]).boundary_weight, 1.0);
    EXPECT_EQ(to_string(specs[0]), "simplify=0.1:boundary=1");
    EXPECT_EQ(to_string(specs[1]), "simplify=0.1");  // CGAL's default is omitted
    EXPECT_EQ(parse_attack_spec(to_string(specs[0])).front(), specs[0]);
    // Only the Garland-Heckbert policy of the CGAL method uses it; a weight must be positive.
    EXPECT_THROW((void)parse_attack_spec("simplify=0.1:policy=lt:boundary=1"), InvalidOption);
    EXPECT_THROW((void)parse_attack_spec("simplify=0.1:method=meshopt:boundary=1"), InvalidOption);
    EXPECT_THROW((void)parse_attack_spec("simplify=0.1:boundary=0"), InvalidOption);

    // An open, bumpy sheet: the default weight keeps the border nearly in place, so more of the
    // kept edges stay on it than with Open3D's and MeshLab's weight of 1.
    TriangleMesh sheet = plane_grid(40, 40);
    for (Eigen::Index i = 0; i < sheet.V.rows(); ++i)
    {
        sheet.V(i, 2) = 0.05 * std::sin(9.0 * sheet.V(i, 0)) * std::cos(7.0 * sheet.V(i, 1));
    }
    const TriangleMesh held = simplify(sheet, {.vertex_fraction = 0.05});
    const TriangleMesh loose = simplify(sheet, {.vertex_fraction = 0.05, .boundary_weight = 1.0});
    EXPECT_EQ(held.V.rows(), loose.V.rows());
    EXPECT_GT(edge_statistics(held).boundary_edge_count,
              edge_statistics(loose).boundary_edge_count);
}

TEST(SimplificationTest, meshopt_point_clouds_still_throw)
{
    EXPECT_THROW((void)simplify(test::point_cloud_of(icosphere(1)),
                                {.method = SimplificationMethod::Meshoptimizer}),
                 InvalidMesh);
}

TEST(SimplificationTest, point_clouds_and_bad_fractions_throw)
{
    EXPECT_THROW((void)simplify(test::point_cloud_of(icosphere(1)), {}), InvalidMesh);
    EXPECT_THROW((void)simplify(icosphere(1), {.vertex_fraction = 0.0}), InvalidOption);
    EXPECT_THROW((void)simplify(icosphere(1), {.vertex_fraction = 1.5}), InvalidOption);
}

}  // namespace meshmark
