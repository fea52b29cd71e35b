// SPDX-License-Identifier: MIT
#include "meshmark/core/triangle_mesh.h"

#include <limits>

#include <gtest/gtest.h>

#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{

TEST(TriangleMeshTest, validate_rejects_nan_and_out_of_range_index)
{
    TriangleMesh mesh = icosphere(1);
    EXPECT_NO_THROW(validate(mesh, "sphere"));
    TriangleMesh bad = mesh;
    bad.V(3, 1) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(validate(bad, "sphere"), InvalidMesh);
    bad = mesh;
    bad.F(2, 0) = static_cast<std::int32_t>(mesh.V.rows());
    EXPECT_THROW(validate(bad, "sphere"), InvalidMesh);
}

TEST(TriangleMeshTest, referenced_vertices_skip_unused_and_cover_point_clouds)
{
    TriangleMesh mesh = icosphere(1);
    const auto n = mesh.V.rows();
    mesh.V.conservativeResize(n + 1, 3);
    mesh.V.row(n) << 5.0, 5.0, 5.0;
    const auto used = referenced_vertices(mesh);
    EXPECT_EQ(static_cast<Eigen::Index>(used.size()), n);
    mesh.F.resize(0, 3);
    EXPECT_EQ(static_cast<Eigen::Index>(referenced_vertices(mesh).size()), n + 1);
}

TEST(ShapesTest, icosphere_has_expected_counts_and_unit_radius)
{
    const TriangleMesh mesh = icosphere(2);
    EXPECT_EQ(mesh.V.rows(), 162);
    EXPECT_EQ(mesh.F.rows(), 320);
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        EXPECT_NEAR(mesh.V.row(i).norm(), 1.0, 1e-12);
    }
}

}  // namespace meshmark
