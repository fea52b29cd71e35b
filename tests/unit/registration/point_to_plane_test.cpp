// SPDX-License-Identifier: MIT
#include "meshmark/registration/point_to_plane.h"

#include <cmath>
#include <numeric>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "meshmark/core/rng.h"

namespace meshmark
{
namespace
{

// Points spread over an ellipsoid (semi-axes 1, 0.6, 0.3: no motion slides it along itself),
// each matched to itself with the ellipsoid's normal there.
struct EllipsoidPairs
{
    Positions points;
    std::vector<SurfaceMatch> matches;
    std::vector<Eigen::Index> all;
};

EllipsoidPairs ellipsoid_pairs(int count)
{
    EllipsoidPairs s;
    s.points.resize(count, 3);
    Rng rng(11);
    for (int i = 0; i < count; ++i)
    {
        Eigen::Vector3d d(rng.normal(), rng.normal(), rng.normal());
        d.normalize();
        const Eigen::Vector3d axes(1.0, 0.6, 0.3);
        const Eigen::Vector3d p = d.cwiseProduct(axes);
        s.points.row(i) = p.transpose();
        s.matches.push_back({p, d.cwiseQuotient(axes).normalized(), 0.0});
    }
    s.all.resize(static_cast<std::size_t>(count));
    std::iota(s.all.begin(), s.all.end(), Eigen::Index{0});
    return s;
}

// A translation is linear in the residuals: one step takes it back exactly, rigid or not,
// and leaves the rotation (and scale) where they are.
TEST(PointToPlaneTest, one_step_undoes_a_translation)
{
    const EllipsoidPairs s = ellipsoid_pairs(500);
    const Eigen::RowVector3d tau(0.01, -0.02, 0.005);
    const Positions moved = s.points.rowwise() + tau;
    const auto rigid = point_to_plane_step<6>(moved, s.matches, s.all);
    ASSERT_TRUE(rigid.has_value());
    EXPECT_LT((rigid->delta.tail<3>() + tau.transpose()).norm(), 1e-9);
    EXPECT_LT(rigid->delta.head<3>().norm(), 1e-9);
    const auto scaled = point_to_plane_step<7>(moved, s.matches, s.all);
    ASSERT_TRUE(scaled.has_value());
    EXPECT_LT((scaled->delta.tail<3>() + tau.transpose()).norm(), 1e-9);
    EXPECT_LT(scaled->delta.head<4>().norm(), 1e-9);
}

// Points of the ellipsoid scaled about its centre by 1.01 lie off their planes. The motion back is
// a scale by 1 / 1.01 about the sample's centre c and a translation, exactly linear in the
// residuals: the step with scale gives k = 1 + delta(3) / L = 1 / 1.01. The rigid one cannot undo a
// scale: it stays within a fraction of the 0.01.
TEST(PointToPlaneTest, the_step_with_scale_undoes_a_scale)
{
    const EllipsoidPairs s = ellipsoid_pairs(500);
    const Positions moved = 1.01 * s.points;
    const auto scaled = point_to_plane_step<7>(moved, s.matches, s.all);
    ASSERT_TRUE(scaled.has_value());
    EXPECT_NEAR(1.0 + scaled->delta(3) / scaled->radius, 1.0 / 1.01, 1e-9);
    EXPECT_LT(scaled->delta.head<3>().norm(), 1e-9);
    const auto rigid = point_to_plane_step<6>(moved, s.matches, s.all);
    ASSERT_TRUE(rigid.has_value());
    EXPECT_LT(rigid->delta.norm(), 0.005);
}

// Only the listed rows count, in their order; a match without a normal adds nothing; an
// empty list has no step.
TEST(PointToPlaneTest, only_the_kept_rows_with_a_plane_count)
{
    EllipsoidPairs s = ellipsoid_pairs(400);
    const Eigen::RowVector3d tau(0.0, 0.0, 0.03);
    Positions moved = s.points.rowwise() + tau;
    const auto reference = point_to_plane_step<6>(moved, s.matches, s.all);
    ASSERT_TRUE(reference.has_value());
    // Rows 400.. are far away and listed nowhere; rows given a zero normal move nothing.
    Positions more(600, 3);
    more.topRows(400) = moved;
    more.bottomRows(200).setConstant(50.0);
    std::vector<SurfaceMatch> matches = s.matches;
    matches.resize(600, SurfaceMatch{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0});
    const auto same = point_to_plane_step<6>(more, matches, s.all);
    ASSERT_TRUE(same.has_value());
    EXPECT_EQ(same->delta, reference->delta);
    EXPECT_EQ(same->centre, reference->centre);
    std::vector<Eigen::Index> with_planeless = s.all;
    with_planeless.push_back(450);
    const auto planeless = point_to_plane_step<6>(more, matches, with_planeless);
    ASSERT_TRUE(planeless.has_value());
    EXPECT_LT((planeless->delta.tail<3>() + tau.transpose()).norm(),
              1e-9);  // the translation alone
    EXPECT_FALSE(point_to_plane_step<6>(moved, s.matches, {}).has_value());
}

}  // namespace
}  // namespace meshmark
