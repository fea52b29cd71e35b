// SPDX-License-Identifier: MIT
#include "meshmark/geometry/normals.h"

#include <numbers>

#include <gtest/gtest.h>

#include "meshmark/geometry/shapes.h"

namespace meshmark
{

TEST(NormalsTest, icosphere_normals_point_outwards_along_the_radius)
{
    const TriangleMesh mesh = icosphere(3);
    const Positions vn = vertex_normals(mesh);
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        EXPECT_NEAR(vn.row(i).norm(), 1.0, 1e-12);
        EXPECT_GT(vn.row(i).dot(mesh.V.row(i).normalized()), 0.999) << "vertex " << i;
    }
    const Positions fn = face_normals(mesh);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const Eigen::RowVector3d centre =
            (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))) / 3.0;
        EXPECT_GT(fn.row(f).dot(centre.normalized()), 0.99) << "face " << f;
    }
}

TEST(NormalsTest, areas_sum_to_the_sphere_area_and_the_unit_square)
{
    EXPECT_NEAR(surface_area(icosphere(5)), 4.0 * std::numbers::pi, 0.01 * 4.0 * std::numbers::pi);
    const TriangleMesh grid = plane_grid(4, 3);
    EXPECT_NEAR(surface_area(grid), 1.0, 1e-12);
    EXPECT_NEAR(face_areas(grid).sum(), 1.0, 1e-12);
    EXPECT_NEAR(face_areas(grid).minCoeff(), 1.0 / 24.0, 1e-12);
}

TEST(NormalsTest, degenerate_faces_and_unused_vertices_get_zero_normals)
{
    TriangleMesh mesh;
    mesh.V.resize(4, 3);
    mesh.V << 0, 0, 0, 1, 0, 0, 2, 0, 0, 5, 5, 5;  // collinear triangle, plus an unused vertex
    mesh.F.resize(1, 3);
    mesh.F << 0, 1, 2;
    EXPECT_TRUE(face_normals(mesh).row(0).isZero(0.0));
    EXPECT_TRUE(vertex_normals(mesh).isZero(0.0));
    EXPECT_EQ(face_areas(mesh)(0), 0.0);
}

}  // namespace meshmark
