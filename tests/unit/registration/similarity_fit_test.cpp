// SPDX-License-Identifier: MIT
#include "meshmark/registration/similarity_fit.h"

#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "meshmark/core/rng.h"

namespace meshmark
{
namespace
{

// \p count points with coordinates drawn from a normal distribution (seeded).
Eigen::Matrix3Xd random_points(int count, std::uint64_t seed)
{
    Rng rng(seed);
    Eigen::Matrix3Xd X(3, count);
    for (int i = 0; i < count; ++i)
    {
        X.col(i) = Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal());
    }
    return X;
}

SimilarityTransform known_similarity()
{
    SimilarityTransform T;
    T.scale = 2.5;
    T.rotation =
        Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
    T.translation = Eigen::Vector3d(3.0, -1.0, 0.25);
    return T;
}

Eigen::Matrix3Xd moved(const SimilarityTransform& T, const Eigen::Matrix3Xd& X)
{
    return ((T.scale * T.rotation * X).colwise() + T.translation).eval();
}

TEST(SimilarityFitTest, recovers_a_known_similarity_from_exact_pairs)
{
    const Eigen::Matrix3Xd X = random_points(50, 1);
    const SimilarityTransform T = known_similarity();
    const SimilarityTransform fit = similarity_parts(fit_similarity(X, moved(T, X)));
    EXPECT_NEAR(fit.scale, T.scale, 1e-12);
    EXPECT_LT((fit.rotation - T.rotation).norm(), 1e-12);
    EXPECT_LT((fit.translation - T.translation).norm(), 1e-12);
    EXPECT_NEAR(fit.rotation.determinant(), 1.0, 1e-12);
}

TEST(SimilarityFitTest, never_returns_a_reflection)
{
    // Points mirrored (x -> -x) and moved: the best orthogonal map is a reflection, the fit
    // gives the closest proper rotation instead (callers that accept mirror images mirror the
    // points themselves).
    const Eigen::Matrix3Xd X = random_points(40, 2);
    Eigen::Matrix3Xd Y = moved(known_similarity(), X);
    Y.row(0) = -Y.row(0);
    const Eigen::Matrix4d A = fit_similarity(X, Y);
    const double det = A.block<3, 3>(0, 0).determinant();
    EXPECT_GT(det, 0.0);
    const SimilarityTransform parts = similarity_parts(A);
    EXPECT_NEAR(parts.rotation.determinant(), 1.0, 1e-12);
    EXPECT_LT((parts.rotation * parts.rotation.transpose() - Eigen::Matrix3d::Identity()).norm(),
              1e-12);
}

TEST(SimilarityFitTest, is_the_least_squares_fit_of_noisy_pairs)
{
    // Against small changes of its parts, the fit's squared residual does not decrease.
    const Eigen::Matrix3Xd X = random_points(200, 3);
    Eigen::Matrix3Xd Y = moved(known_similarity(), X) + 0.05 * random_points(200, 4);
    const Eigen::Matrix4d A = fit_similarity(X, Y);
    auto residual = [&](const Eigen::Matrix4d& B)
    { return ((B.block<3, 3>(0, 0) * X).colwise() + B.block<3, 1>(0, 3) - Y).squaredNorm(); };
    const double best = residual(A);
    for (int k = 0; k < 7; ++k)
    {
        for (const double h : {-1e-4, 1e-4})
        {
            SimilarityTransform T = similarity_parts(A);
            if (k < 3)
            {
                T.rotation =
                    Eigen::AngleAxisd(h, Eigen::Vector3d::Unit(k)).toRotationMatrix() * T.rotation;
            }
            else if (k == 3)
            {
                T.scale *= 1.0 + h;
            }
            else
            {
                T.translation(k - 4) += h;
            }
            Eigen::Matrix4d B = Eigen::Matrix4d::Identity();
            B.block<3, 3>(0, 0) = T.scale * T.rotation;
            B.block<3, 1>(0, 3) = T.translation;
            EXPECT_GE(residual(B), best) << "part " << k << ", step " << h;
        }
    }
}

TEST(SimilarityFitTest, is_eigen_umeyama_bit_for_bit)
{
    // Every caller got Eigen::umeyama before the fit was written once; its results stay the same.
    const Eigen::Matrix3Xd X = random_points(100, 5);
    const Eigen::Matrix3Xd Y = moved(known_similarity(), X) + 0.01 * random_points(100, 6);
    EXPECT_EQ(fit_similarity(X, Y), Eigen::umeyama(X, Y, true));
    const Positions P = X.transpose();
    const Positions Q = Y.transpose();
    EXPECT_EQ(fit_similarity_rows(P, Q), Eigen::umeyama(P.transpose(), Q.transpose(), true));
}

TEST(SimilarityFitTest, rows_fit_the_same_map_as_columns)
{
    const Eigen::Matrix3Xd X = random_points(30, 7);
    const Eigen::Matrix3Xd Y = moved(known_similarity(), X);
    const Positions P = X.transpose();
    const Positions Q = Y.transpose();
    EXPECT_LT((fit_similarity_rows(P, Q) - fit_similarity(X, Y)).norm(), 1e-12);
}

TEST(SimilarityFitTest, parts_split_the_matrix)
{
    const SimilarityTransform T = known_similarity();
    Eigen::Matrix4d A = Eigen::Matrix4d::Identity();
    A.block<3, 3>(0, 0) = T.scale * T.rotation;
    A.block<3, 1>(0, 3) = T.translation;
    const SimilarityTransform parts = similarity_parts(A);
    EXPECT_NEAR(parts.scale, T.scale, 1e-14);
    EXPECT_LT((parts.rotation - T.rotation).norm(), 1e-14);
    EXPECT_EQ(parts.translation, T.translation);
    EXPECT_EQ(similarity_parts(Eigen::Matrix4d::Zero()).scale, 0.0);
}

}  // namespace
}  // namespace meshmark
