// SPDX-License-Identifier: MIT
#include "meshmark/metrics/surface_sampling.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/error.h"
#include "meshmark/geometry/closest_point_index.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{

TEST(SurfaceSamplingTest, samples_lie_on_the_surface_and_are_deterministic)
{
    const TriangleMesh mesh = lumpy_ellipsoid(3);
    const Positions s1 = sample_surface(mesh, 10'000, 7, 1);
    const Positions s2 = sample_surface(mesh, 10'000, 7, 2);
    ASSERT_EQ(s1.rows(), 10'000);
    EXPECT_EQ(s1, s2);
    EXPECT_NE(s1, sample_surface(mesh, 10'000, 8, 2));
    const ClosestPointIndex index(mesh);
    for (const auto& hit : index.closest(s1, 2))
    {
        EXPECT_LE(hit.distance, 1e-14);
    }
}

TEST(SurfaceSamplingTest, each_face_gets_its_area_share_within_two)
{
    // Stratification: a face spans whole strata (one sample each) plus at most two partial ones,
    // so it receives count * area / total samples with an error below 2, whatever its size.
    // (Independent uniform samples would be off by about the square root of that.)
    TriangleMesh mesh = plane_grid(8, 8);
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        mesh.V(i, 1) = mesh.V(i, 1) * mesh.V(i, 1);  // rows get taller towards y = 1
    }
    const std::int64_t count = 10'007;
    const Positions samples = sample_surface(mesh, count, 3, 2);
    const ClosestPointIndex index(mesh);
    std::vector<int> per_face(static_cast<std::size_t>(mesh.F.rows()), 0);
    for (const auto& hit : index.closest(samples, 2))
    {
        ++per_face[static_cast<std::size_t>(hit.face)];
    }
    const Eigen::VectorXd cumulative = cumulative_face_areas(mesh);
    const double total = cumulative[cumulative.size() - 1];
    EXPECT_NEAR(total, 1.0, 1e-12);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const double area = cumulative[f] - (f > 0 ? cumulative[f - 1] : 0.0);
        EXPECT_LT(std::abs(per_face[static_cast<std::size_t>(f)] -
                           static_cast<double>(count) * area / total),
                  2.0)
            << "face " << f;
    }
}

TEST(SurfaceSamplingTest, zero_area_faces_get_no_samples)
{
    TriangleMesh mesh = plane_grid(2, 1);
    mesh.F.conservativeResize(mesh.F.rows() + 1, 3);
    mesh.F.row(mesh.F.rows() - 1) << 0, 1, 2;  // collinear corners on the edge y = 0
    // A sample of the collinear face would have y == 0 exactly; on the real faces that has
    // probability zero.
    const Positions samples = sample_surface(mesh, 5000, 1, 2);
    ASSERT_EQ(samples.rows(), 5000);
    for (Eigen::Index i = 0; i < samples.rows(); ++i)
    {
        EXPECT_GT(samples(i, 1), 0.0);
    }
    TriangleMesh flat = mesh;
    flat.F = flat.F.bottomRows(1).eval();
    EXPECT_EQ(sample_surface(flat, 100, 1).rows(), 0);
    EXPECT_THROW((void)sample_surface(mesh, -1, 1), InvalidOption);
}

}  // namespace meshmark
