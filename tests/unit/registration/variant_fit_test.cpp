// SPDX-License-Identifier: MIT
#include "meshmark/registration/variant_fit.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "meshmark/geometry/shape_signature.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

// Five variants of one surface, stretched along x by 0%, 2%, ..., 8%: the same triangles.
std::vector<TriangleMesh> stretched_variants()
{
    std::vector<TriangleMesh> variants;
    for (int k = 0; k < 5; ++k)
    {
        TriangleMesh mesh = lumpy_ellipsoid(3);
        mesh.V.col(0) *= 1.0 + 0.02 * k;
        variants.push_back(std::move(mesh));
    }
    return variants;
}

TEST(VariantFitTest, the_variant_a_moved_copy_was_made_from_fits_best)
{
    const std::vector<TriangleMesh> variants = stretched_variants();
    // The copy: variant 2 scaled by 2, turned by 40 degrees, moved; the start pose its inverse,
    // off by 3 degrees and a little translation (as shape_fit's pose on another variant would be).
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, 0.5).normalized()).toRotationMatrix();
    const Eigen::Vector3d shift(3.0, -1.0, 2.0);
    Positions copy = (2.0 * variants[2].V * turn.transpose()).rowwise() + shift.transpose();
    TriangleMesh moved{copy, variants[2].F};
    const Positions points = shape_sample(moved, 1024);
    ShapeFitPose start;
    start.scale = 0.5;
    start.rotation =
        Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitZ()).toRotationMatrix() * turn.transpose();
    start.translation = -0.5 * (start.rotation * shift) + Eigen::Vector3d(0.01, 0.0, -0.01);
    const std::vector<double> scores = surface_fits(points, variants, start, 5, 2);
    ASSERT_EQ(scores.size(), variants.size());
    EXPECT_EQ(std::min_element(scores.begin(), scores.end()) - scores.begin(), 2);
    EXPECT_LT(scores[2], 0.5 * std::min(scores[1], scores[3]));
    EXPECT_LT(scores[1], scores[0]);
    EXPECT_LT(scores[3], scores[4]);

    // Mirrored: the same copy with x negated, the pose saying so.
    Positions mirrored = points;
    mirrored.col(0) *= -1.0;
    start.mirrored = true;
    const std::vector<double> again = surface_fits(mirrored, variants, start, 5, 1);
    for (std::size_t k = 0; k < scores.size(); ++k)
    {
        EXPECT_NEAR(again[k], scores[k], 1e-12 + 1e-9 * scores[k]) << k;
    }
}

TEST(VariantFitTest, a_mesh_without_faces_and_too_few_points_score_infinity)
{
    std::vector<TriangleMesh> variants = stretched_variants();
    variants[1].F.resize(0, 3);
    const Positions points = shape_sample(variants[0], 256);
    const std::vector<double> scores = surface_fits(points, variants, ShapeFitPose{}, 3, 1);
    EXPECT_TRUE(std::isinf(scores[1]));
    EXPECT_TRUE(std::isfinite(scores[0]));
    EXPECT_LT(scores[0], scores[2]);
    for (const double s : surface_fits(points.topRows(2), variants, ShapeFitPose{}, 3, 1))
    {
        EXPECT_TRUE(std::isinf(s));
    }
}

}  // namespace
}  // namespace meshmark
