// SPDX-License-Identifier: MIT
#include "meshmark/attacks/similarity.h"

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "attack_test_util.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

// Least-squares similarity from corresponding point sets [Umeyama 1991], as a registration would
// recover it from the output.
AppliedSimilarity recover(const Positions& from, const Positions& to)
{
    const Eigen::Matrix4d m = Eigen::umeyama(from.transpose(), to.transpose(), true);
    AppliedSimilarity t;
    t.scale = m.topLeftCorner<3, 3>().col(0).norm();
    t.rotation = m.topLeftCorner<3, 3>() / t.scale;
    t.translation = m.topRightCorner<3, 1>();
    return t;
}

}  // namespace

TEST(SimilarityTest, explicit_transform_rotates_scales_then_translates_about_the_origin)
{
    TriangleMesh mesh;
    mesh.V.resize(2, 3);
    mesh.V << 1, 0, 0, 0, 0, 1;
    const SimilarityOptions options{.is_random = false,
                                    .axis = Eigen::Vector3d::UnitZ(),
                                    .angle_deg = 90.0,
                                    .scale = 2.0,
                                    .translation = {1.0, 2.0, 3.0}};
    Rng rng(1);
    const AttackResult result = apply_similarity(mesh, options, rng);
    EXPECT_TRUE(result.mesh.V.row(0).isApprox(Eigen::RowVector3d(1.0, 4.0, 3.0), 1e-12));
    EXPECT_TRUE(result.mesh.V.row(1).isApprox(Eigen::RowVector3d(1.0, 2.0, 5.0), 1e-12));
    ASSERT_TRUE(result.similarity.has_value());
    EXPECT_DOUBLE_EQ(result.similarity->scale, 2.0);
    ASSERT_TRUE(result.source_vertex.has_value());
    EXPECT_EQ(*result.source_vertex, (std::vector<std::int32_t>{0, 1}));
}

TEST(SimilarityTest, random_transform_is_recovered_exactly_from_the_output)
{
    const TriangleMesh mesh = lumpy_ellipsoid(2);
    for (std::uint64_t seed = 0; seed < 20; ++seed)
    {
        Rng rng(seed);
        const AttackResult result = apply_similarity(mesh, {}, rng);
        ASSERT_TRUE(result.similarity.has_value());
        const AppliedSimilarity& t = *result.similarity;
        EXPECT_NEAR(t.rotation.determinant(), 1.0, 1e-12);
        EXPECT_TRUE((t.rotation.transpose() * t.rotation).isIdentity(1e-12));
        EXPECT_GE(t.scale, 0.1 * (1 - 1e-12));
        EXPECT_LE(t.scale, 10.0 * (1 + 1e-12));
        EXPECT_EQ(result.mesh.F, mesh.F);

        const AppliedSimilarity found = recover(mesh.V, result.mesh.V);
        EXPECT_NEAR(found.scale / t.scale, 1.0, 1e-9);
        EXPECT_TRUE(found.rotation.isApprox(t.rotation, 1e-9));
        const double size = t.scale * bounding_box(mesh.V).diagonal();
        EXPECT_LT((found.translation - t.translation).norm(), 1e-9 * size);
        // The inverse maps the output back onto the input.
        const TriangleMesh back = transformed(result.mesh, t.inverse());
        EXPECT_LT((back.V - mesh.V).cwiseAbs().maxCoeff(), 1e-9);
    }
}

// mirror=x|y|z reflects first in that coordinate plane (p -> s R M p + t), the faces turned so
// that they still face out: the signed volume keeps its sign, scaled by s^3.
TEST(SimilarityTest, a_mirror_reflects_first_and_keeps_the_faces_facing_out)
{
    const TriangleMesh mesh = lumpy_ellipsoid(1);
    for (int axis = 0; axis < 3; ++axis)
    {
        const SimilarityOptions options{.is_random = false,
                                        .axis = Eigen::Vector3d::UnitZ(),
                                        .angle_deg = 90.0,
                                        .scale = 2.0,
                                        .translation = Eigen::Vector3d(1.0, 2.0, 3.0),
                                        .mirror = axis};
        Rng rng(1);
        const AttackResult result = apply_similarity(mesh, options, rng);
        const AppliedSimilarity& t = *result.similarity;
        EXPECT_NEAR(t.rotation.determinant(), -1.0, 1e-12) << axis;
        Eigen::Matrix3d M = Eigen::Matrix3d::Identity();
        M(axis, axis) = -1.0;
        const Eigen::Matrix3d R =
            Eigen::AngleAxisd(std::numbers::pi / 2.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        for (Eigen::Index i = 0; i < mesh.V.rows(); i += 17)
        {
            const Eigen::Vector3d expected =
                2.0 * (R * (M * mesh.V.row(i).transpose())) + Eigen::Vector3d(1.0, 2.0, 3.0);
            EXPECT_LT((result.mesh.V.row(i).transpose() - expected).norm(), 1e-12)
                << axis << " " << i;
        }
        EXPECT_NEAR(test::signed_volume(result.mesh), 8.0 * test::signed_volume(mesh),
                    1e-9 * std::abs(test::signed_volume(mesh)))
            << axis;
        EXPECT_GT(test::signed_volume(mesh), 0.0);
        const TriangleMesh back = transformed(result.mesh, t.inverse());
        EXPECT_LT((back.V - mesh.V).cwiseAbs().maxCoeff(), 1e-9) << axis;
        EXPECT_EQ(back.F, mesh.F) << axis;
    }
}

TEST(SimilarityTest, random_transform_moves_the_bbox_centre_by_at_most_tmax_radii)
{
    TriangleMesh mesh = lumpy_ellipsoid(1);
    mesh.V.rowwise() += Eigen::RowVector3d(100.0, -50.0, 7.0);  // far from the origin
    const BoundingBox box = bounding_box(mesh.V);
    const SimilarityOptions options{.max_scale = 2.0, .max_translation_radii = 1.5};
    double largest = 0.0;
    for (std::uint64_t seed = 0; seed < 50; ++seed)
    {
        Rng rng(seed);
        const AppliedSimilarity t = similarity_transform(mesh, options, rng);
        const double moved = (t.apply(box.center()) - box.center()).norm();
        EXPECT_LE(moved, 1.5 * 0.5 * box.diagonal() * (1 + 1e-9));
        largest = std::max(largest, moved);
        EXPECT_GE(t.scale, 0.5 * (1 - 1e-12));
        EXPECT_LE(t.scale, 2.0 * (1 + 1e-12));
    }
    EXPECT_GT(largest, 0.5 * 1.5 * 0.5 * box.diagonal());
}

TEST(SimilarityTest, random_rotations_and_scales_spread_over_their_ranges)
{
    // A rotation uniform over SO(3) has zero mean; log-scales cover [-ln 10, ln 10].
    const TriangleMesh mesh = icosphere(0);
    Eigen::Matrix3d mean = Eigen::Matrix3d::Zero();
    double low = 0.0;
    double high = 0.0;
    const int draws = 2000;
    for (int i = 0; i < draws; ++i)
    {
        Rng rng(static_cast<std::uint64_t>(i));
        const AppliedSimilarity t = similarity_transform(mesh, {}, rng);
        mean += t.rotation / draws;
        low = std::min(low, std::log(t.scale));
        high = std::max(high, std::log(t.scale));
    }
    EXPECT_LT(mean.cwiseAbs().maxCoeff(), 0.05);
    EXPECT_LT(low, -0.9 * std::log(10.0));
    EXPECT_GT(high, 0.9 * std::log(10.0));
}

TEST(SimilarityTest, composition_and_inverse_agree_with_pointwise_application)
{
    Rng rng(5);
    const TriangleMesh mesh = icosphere(1);
    const AppliedSimilarity a = similarity_transform(mesh, {}, rng);
    const AppliedSimilarity b = similarity_transform(mesh, {}, rng);
    const Eigen::Vector3d p(0.3, -1.2, 2.5);
    EXPECT_TRUE(a.then(b).apply(p).isApprox(b.apply(a.apply(p)), 1e-12));
    EXPECT_TRUE(a.inverse().apply(a.apply(p)).isApprox(p, 1e-12));
    const Eigen::Vector4d h = a.matrix() * p.homogeneous();
    EXPECT_TRUE(h.head<3>().isApprox(a.apply(p), 1e-12));
}

TEST(SimilarityTest, invalid_options_throw)
{
    Rng rng(1);
    const TriangleMesh mesh = icosphere(0);
    EXPECT_THROW((void)similarity_transform(mesh, {.is_random = false, .scale = 0.0}, rng),
                 InvalidOption);
    EXPECT_THROW((void)similarity_transform(
                     mesh, {.is_random = false, .axis = Eigen::Vector3d::Zero()}, rng),
                 InvalidOption);
    EXPECT_THROW((void)similarity_transform(mesh, {.max_scale = 0.5}, rng), InvalidOption);
}

}  // namespace meshmark
