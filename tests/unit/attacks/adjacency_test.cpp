// SPDX-License-Identifier: MIT
#include "meshmark/geometry/adjacency.h"

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/geometry/shapes.h"

namespace meshmark
{

TEST(AdjacencyTest, icosphere_neighbours_are_symmetric_sorted_and_match_euler)
{
    const TriangleMesh mesh = icosphere(2);
    const VertexAdjacency adjacency = vertex_adjacency(mesh);
    ASSERT_EQ(adjacency.vertex_count(), static_cast<std::size_t>(mesh.V.rows()));
    for (std::size_t v = 0; v < adjacency.vertex_count(); ++v)
    {
        const auto row = adjacency.of(v);
        // Icosahedron vertices keep valence 5, all others have 6.
        EXPECT_TRUE(row.size() == 5 || row.size() == 6) << "vertex " << v;
        EXPECT_TRUE(std::is_sorted(row.begin(), row.end()));
        for (const auto u : row)
        {
            const auto back = adjacency.of(static_cast<std::size_t>(u));
            EXPECT_TRUE(std::binary_search(back.begin(), back.end(), static_cast<std::int32_t>(v)));
        }
    }
    // Euler: V - E + F = 2 for a sphere, and each edge appears in two rows.
    const auto edges = static_cast<Eigen::Index>(adjacency.neighbors.size() / 2);
    EXPECT_EQ(mesh.V.rows() - edges + mesh.F.rows(), 2);
}

TEST(AdjacencyTest, polygon_adjacency_leaves_out_inner_edges_unless_a_face_has_them_too)
{
    // A quad 0-1-2-3 as two triangles (inner edge 0-2), a triangle 0-2-4 on that same edge (a
    // face of its own: the edge stays), and a stale polygon whose rows are out of range.
    TriangleMesh mesh;
    mesh.V = Positions::Zero(5, 3);
    mesh.F.resize(3, 3);
    mesh.F << 0, 1, 2, 0, 2, 3, 0, 2, 4;
    mesh.polygons = {{0, 4}, {2, 5}};
    const auto row = [](const VertexAdjacency& adjacency, std::size_t v)
    {
        const auto r = adjacency.of(v);
        return std::vector<std::int32_t>(r.begin(), r.end());
    };
    const VertexAdjacency with_triangle = polygon_adjacency(mesh);
    EXPECT_EQ(row(with_triangle, 0), (std::vector<std::int32_t>{1, 2, 3, 4}));
    EXPECT_EQ(row(with_triangle, 1), (std::vector<std::int32_t>{0, 2}));
    EXPECT_EQ(row(with_triangle, 3), (std::vector<std::int32_t>{0, 2}));

    mesh.F.conservativeResize(2, 3);  // the triangle gone: the quad's inner edge is left out
    mesh.polygons = {{0, 4}};
    const VertexAdjacency quad = polygon_adjacency(mesh);
    EXPECT_EQ(row(quad, 0), (std::vector<std::int32_t>{1, 3}));
    EXPECT_EQ(row(quad, 2), (std::vector<std::int32_t>{1, 3}));

    mesh.polygons.clear();  // no polygons: the triangles' adjacency
    EXPECT_EQ(polygon_adjacency(mesh).neighbors, vertex_adjacency(mesh).neighbors);
}

TEST(AdjacencyTest, vertex_faces_list_every_face_of_each_vertex_in_face_order)
{
    TriangleMesh mesh = icosphere(1);
    mesh.V.conservativeResize(mesh.V.rows() + 1, 3);  // an unreferenced vertex
    mesh.V.row(mesh.V.rows() - 1).setZero();
    const VertexFaces incidence = vertex_faces(mesh);
    ASSERT_EQ(incidence.offsets.size(), static_cast<std::size_t>(mesh.V.rows()) + 1);
    EXPECT_EQ(incidence.faces.size(), static_cast<std::size_t>(3 * mesh.F.rows()));
    for (Eigen::Index v = 0; v < mesh.V.rows(); ++v)
    {
        std::vector<Eigen::Index> expected;
        for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
        {
            if ((mesh.F.row(f).array() == v).any())
            {
                expected.push_back(f);
            }
        }
        const auto row = incidence.of(static_cast<std::size_t>(v));
        EXPECT_EQ(std::vector<Eigen::Index>(row.begin(), row.end()), expected) << "vertex " << v;
    }
    EXPECT_TRUE(incidence.of(static_cast<std::size_t>(mesh.V.rows() - 1)).empty());
}

TEST(AdjacencyTest, unreferenced_vertex_and_point_cloud_have_no_neighbours)
{
    TriangleMesh mesh = icosphere(0);
    mesh.V.conservativeResize(mesh.V.rows() + 1, 3);
    mesh.V.row(mesh.V.rows() - 1).setZero();
    const VertexAdjacency adjacency = vertex_adjacency(mesh);
    EXPECT_TRUE(adjacency.of(adjacency.vertex_count() - 1).empty());

    TriangleMesh cloud;
    cloud.V = mesh.V;
    EXPECT_TRUE(vertex_adjacency(cloud).neighbors.empty());
}

TEST(AdjacencyTest, edge_statistics_classify_closed_open_flipped_and_non_manifold)
{
    const EdgeStatistics sphere = edge_statistics(icosphere(2));
    EXPECT_TRUE(sphere.is_closed());
    EXPECT_TRUE(sphere.is_consistently_oriented());
    EXPECT_EQ(sphere.edge_count, 480U);

    // A 3 x 2 grid has 2 * (3 + 2) boundary edges.
    const EdgeStatistics grid = edge_statistics(plane_grid(3, 2));
    EXPECT_EQ(grid.boundary_edge_count, 10U);
    EXPECT_FALSE(grid.is_closed());
    EXPECT_TRUE(grid.is_consistently_oriented());

    // Flipping one face of a closed sphere makes its three edges inconsistent.
    TriangleMesh flipped = icosphere(1);
    std::swap(flipped.F(0, 1), flipped.F(0, 2));
    EXPECT_EQ(edge_statistics(flipped).inconsistent_edge_count, 3U);

    // A third face on an existing edge makes it non-manifold.
    TriangleMesh fin = icosphere(1);
    fin.V.conservativeResize(fin.V.rows() + 1, 3);
    fin.V.row(fin.V.rows() - 1) << 2.0, 0.0, 0.0;
    fin.F.conservativeResize(fin.F.rows() + 1, 3);
    fin.F.row(fin.F.rows() - 1) << fin.F(0, 0), fin.F(0, 1),
        static_cast<std::int32_t>(fin.V.rows() - 1);
    const EdgeStatistics fin_stats = edge_statistics(fin);
    EXPECT_EQ(fin_stats.non_manifold_edge_count, 1U);
    EXPECT_EQ(fin_stats.boundary_edge_count, 2U);
    EXPECT_FALSE(fin_stats.is_edge_manifold());
}

TEST(AdjacencyTest, position_ids_join_vertices_at_one_position_under_the_lowest_index)
{
    // A seam split: vertices 3 and 5 repeat 1 and 0; vertex 4 is at a nearby, different place.
    Positions V(6, 3);
    V << 0, 0, 0,     //
        1, 0, 0,      //
        0, 1, 0,      //
        1, 0, 0,      //
        1, 1e-12, 0,  //
        0, 0, 0;
    const std::vector<std::int32_t> id = position_ids(V);
    EXPECT_EQ(id, (std::vector<std::int32_t>{0, 1, 2, 1, 4, 0}));
    // A seam-split icosphere: every copy maps back to its first vertex.
    const TriangleMesh sphere = icosphere(1);
    Positions doubled(2 * sphere.V.rows(), 3);
    doubled << sphere.V, sphere.V;
    const std::vector<std::int32_t> ids = position_ids(doubled);
    for (Eigen::Index v = 0; v < sphere.V.rows(); ++v)
    {
        EXPECT_EQ(ids[static_cast<std::size_t>(v)], v);
        EXPECT_EQ(ids[static_cast<std::size_t>(v + sphere.V.rows())], v);
    }
}

}  // namespace meshmark
