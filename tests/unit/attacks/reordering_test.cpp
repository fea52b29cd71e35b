// SPDX-License-Identifier: MIT
#include "meshmark/attacks/reordering.h"

#include <algorithm>
#include <array>
#include <vector>

#include <gtest/gtest.h>

#include "attack_test_util.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

// Faces as sorted lists of corner positions, each rotated so its smallest corner comes first
// (orientation kept), the whole list sorted: equal for the same surface in any numbering.
std::vector<std::array<double, 9>> geometric_faces(const TriangleMesh& mesh)
{
    std::vector<std::array<double, 9>> faces;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        std::array<std::array<double, 3>, 3> corners;
        for (int c = 0; c < 3; ++c)
        {
            corners[static_cast<std::size_t>(c)] = {
                mesh.V(mesh.F(f, c), 0), mesh.V(mesh.F(f, c), 1), mesh.V(mesh.F(f, c), 2)};
        }
        std::rotate(corners.begin(), std::min_element(corners.begin(), corners.end()),
                    corners.end());
        std::array<double, 9> flat;
        for (std::size_t k = 0; k < 9; ++k)
        {
            flat[k] = corners[k / 3][k % 3];
        }
        faces.push_back(flat);
    }
    std::sort(faces.begin(), faces.end());
    return faces;
}

}  // namespace

TEST(ReorderingTest, same_oriented_triangles_under_a_new_numbering)
{
    const TriangleMesh mesh = test::with_unreferenced_vertex(lumpy_ellipsoid(3));
    Rng rng(9);
    const AttackResult result = reorder(mesh, {}, rng);
    ASSERT_EQ(result.mesh.V.rows(), mesh.V.rows());
    ASSERT_EQ(result.mesh.F.rows(), mesh.F.rows());
    EXPECT_EQ(geometric_faces(result.mesh), geometric_faces(mesh));
    ASSERT_TRUE(result.source_vertex.has_value());
    std::vector<std::int32_t> sorted = *result.source_vertex;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(sorted, identity_correspondence(mesh.V.rows()));
    for (std::size_t k = 0; k < sorted.size(); ++k)
    {
        EXPECT_EQ(result.mesh.V.row(static_cast<Eigen::Index>(k)),
                  mesh.V.row((*result.source_vertex)[k]));
    }
    // It really shuffled: few vertices and faces keep their index.
    EXPECT_LT((result.mesh.V.array() == mesh.V.array()).rowwise().all().count(), 20);
    EXPECT_LT((result.mesh.F.array() == mesh.F.array()).rowwise().all().count(), 20);
    EXPECT_TRUE(edge_statistics(result.mesh).is_closed());
    EXPECT_TRUE(edge_statistics(result.mesh).is_consistently_oriented());
}

TEST(ReorderingTest, same_seed_same_order_other_seed_other_order)
{
    const TriangleMesh mesh = icosphere(2);
    Rng a(4);
    Rng b(4);
    Rng c(5);
    const TriangleMesh first = reorder(mesh, {}, a).mesh;
    EXPECT_TRUE(test::bit_identical(first, reorder(mesh, {}, b).mesh));
    EXPECT_FALSE(test::bit_identical(first, reorder(mesh, {}, c).mesh));
}

}  // namespace meshmark
