// SPDX-License-Identifier: MIT
#include "meshmark/registration/resampling.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/shapes.h"
#include "perturbations.h"

namespace meshmark
{
namespace
{

TEST(ResamplingTest, unmoved_copy_returns_reference_positions_exactly)
{
    const TriangleMesh reference = lumpy_ellipsoid(4);
    const Resampling r = resample(reference, reference, Eigen::Matrix4d::Identity());
    ASSERT_EQ(r.points.rows(), reference.V.rows());
    EXPECT_EQ(r.points, reference.V);
    EXPECT_EQ(r.distance.maxCoeff(), 0.0);
    EXPECT_EQ(r.cropped_fraction, 0.0);
    EXPECT_GT(r.mean_edge_length, 0.0);
}

TEST(ResamplingTest, registered_copy_point_cloud_and_soup_return_reference_positions)
{
    const TriangleMesh reference = lumpy_ellipsoid(4);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(21);
    const Eigen::Matrix4d T = test::random_similarity(rng, true);
    TriangleMesh suspect = reference;
    suspect.V = test::apply(T, reference.V);
    const Eigen::Matrix4d back = T.inverse();

    const Resampling mesh = resample(reference, suspect, back);
    EXPECT_LT((mesh.points - reference.V).cwiseAbs().maxCoeff(), 1e-12 * D);
    EXPECT_EQ(mesh.cropped_fraction, 0.0);

    TriangleMesh cloud;
    cloud.V = suspect.V;
    const Resampling from_cloud = resample(reference, cloud, back);
    EXPECT_LT((from_cloud.points - reference.V).cwiseAbs().maxCoeff(), 1e-12 * D);

    TriangleMesh soup = test::triangle_soup(reference);
    soup.V = test::apply(T, soup.V);
    const Resampling from_soup = resample(reference, soup, back);
    EXPECT_LT((from_soup.points - reference.V).cwiseAbs().maxCoeff(), 1e-12 * D);
}

TEST(ResamplingTest, resamples_the_surface_between_vertices)
{
    // A coarse suspect of the same sphere: reference vertices land on its triangles, not on
    // its vertices, so the distance is the chordal gap, far below the vertex spacing.
    const TriangleMesh reference = icosphere(4);
    const TriangleMesh coarse = icosphere(2);
    const Resampling r = resample(reference, coarse, Eigen::Matrix4d::Identity());
    TriangleMesh coarse_cloud;
    coarse_cloud.V = coarse.V;
    const Resampling nearest = resample(reference, coarse_cloud, Eigen::Matrix4d::Identity());
    EXPECT_LT(r.distance.maxCoeff(), 0.5 * nearest.distance.maxCoeff());
    EXPECT_LT(r.distance.maxCoeff(), 0.02);  // chord sagitta of a level-2 icosphere
    EXPECT_EQ(r.cropped_fraction, 0.0);
}

TEST(ResamplingTest, crop_marking_flags_the_removed_half)
{
    const TriangleMesh reference = lumpy_ellipsoid(5);
    Rng rng(22);
    for (int trial = 0; trial < 2; ++trial)
    {
        const Eigen::Vector3d n =
            Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
        const test::Cropped cropped = test::crop_by_plane(reference, n, 0.5);
        const Eigen::Matrix4d T = test::random_similarity(rng, false);
        TriangleMesh suspect = cropped.mesh;
        suspect.V = test::apply(T, cropped.mesh.V);
        // The known inverse isolates crop marking (registration of crops is tested apart).
        const Resampling r = resample(reference, suspect, T.inverse());
        std::size_t false_flags = 0;
        std::size_t removed = 0;
        for (std::size_t i = 0; i < r.is_cropped.size(); ++i)
        {
            removed += cropped.is_removed[i] ? 1U : 0U;
            false_flags += (r.is_cropped[i] != 0 && !cropped.is_removed[i]) ? 1U : 0U;
        }
        EXPECT_EQ(false_flags, 0U) << "kept vertices flagged as cropped";
        const double removed_fraction =
            static_cast<double>(removed) / static_cast<double>(r.is_cropped.size());
        // Only a band of about two edge lengths along the cut escapes the flag.
        EXPECT_LE(r.cropped_fraction, removed_fraction);
        EXPECT_GT(r.cropped_fraction, removed_fraction - 0.05) << "trial " << trial;
    }
}

TEST(ResamplingTest, noisy_copy_is_not_flagged_as_cropped)
{
    const TriangleMesh reference = lumpy_ellipsoid(5);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(23);
    TriangleMesh suspect = reference;
    suspect.V = test::add_noise(reference.V, 0.01 * D, rng);
    const Resampling r = resample(reference, suspect, Eigen::Matrix4d::Identity());
    EXPECT_LT(r.cropped_fraction, 0.001);
}

TEST(ResamplingTest, is_bit_identical_for_one_and_two_threads)
{
    const TriangleMesh reference = lumpy_ellipsoid(4);
    Rng rng(24);
    TriangleMesh suspect = reference;
    const Eigen::Matrix4d T = test::random_similarity(rng, false);
    suspect.V = test::add_noise(test::apply(T, reference.V), 0.05, rng);
    const Resampling one = resample(reference, suspect, T.inverse(), {.threads = 1});
    const Resampling two = resample(reference, suspect, T.inverse(), {.threads = 2});
    EXPECT_EQ(one.points, two.points);
    EXPECT_EQ(one.distance, two.distance);
    EXPECT_EQ(one.is_cropped, two.is_cropped);
    EXPECT_EQ(one.crop_threshold, two.crop_threshold);
}

TEST(ResamplingTest, matching_the_reference_surface_removes_the_chord_error)
{
    // The level-2 icosphere's vertices are level-4 vertices: a copy simplified without moving
    // its vertices. Its triangles cut below the sphere (chord error up to ~1.5% of the radius),
    // which the plain resampling reports; measured against the reference under the same
    // triangles, nothing is left.
    const TriangleMesh reference = icosphere(4);
    const TriangleMesh coarse = icosphere(2);
    Rng rng(25);
    const Eigen::Matrix4d T = test::random_similarity(rng, false);
    TriangleMesh suspect = coarse;
    suspect.V = test::apply(T, coarse.V);
    Resampling r = resample(reference, suspect, T.inverse());
    const double chord = (r.points - reference.V).rowwise().norm().maxCoeff();
    EXPECT_GT(chord, 0.005);
    const Eigen::VectorXd distance = r.distance;
    match_reference_surface(r, reference, suspect, T.inverse());
    EXPECT_LT((r.points - reference.V).rowwise().norm().maxCoeff(), 1e-9);
    EXPECT_EQ(r.distance, distance) << "the crop's distances are the plain ones";
    // The same on a surface that is not convex (the walk over the reference's faces must find
    // each corner under its bumps): level-2 vertices of the lumpy ellipsoid are level-5 ones.
    const TriangleMesh lumpy = lumpy_ellipsoid(5);
    const TriangleMesh lumpy_coarse = lumpy_ellipsoid(2);
    Resampling l = resample(lumpy, lumpy_coarse, Eigen::Matrix4d::Identity());
    EXPECT_GT((l.points - lumpy.V).rowwise().norm().maxCoeff(), 1e-3);
    match_reference_surface(l, lumpy, lumpy_coarse, Eigen::Matrix4d::Identity());
    EXPECT_LT((l.points - lumpy.V).rowwise().norm().maxCoeff(), 1e-9);

    // The same copy carrying a displacement along the normals (each coarse vertex moved
    // outward by h times a smooth field): every reference vertex then reads the field,
    // interpolated, and nothing of the chord.
    const double h = 0.002;
    TriangleMesh carried = coarse;
    auto field = [](const Eigen::Vector3d& p) { return 1.0 + 0.5 * p.x(); };
    for (Eigen::Index v = 0; v < carried.V.rows(); ++v)
    {
        const Eigen::Vector3d p = coarse.V.row(v).transpose();
        carried.V.row(v) = (p + h * field(p) * p.normalized()).transpose();
    }
    carried.V = test::apply(T, carried.V);
    Resampling plain = resample(reference, carried, T.inverse());
    Resampling matched = plain;
    match_reference_surface(matched, reference, carried, T.inverse(), 1);
    double plain_error = 0.0;
    double matched_error = 0.0;
    for (Eigen::Index i = 0; i < reference.V.rows(); ++i)
    {
        const Eigen::Vector3d p = reference.V.row(i).transpose();
        const double expected = h * field(p);
        plain_error = std::max(plain_error,
                               std::abs((plain.points.row(i).transpose() - p).dot(p) - expected));
        matched_error = std::max(
            matched_error, std::abs((matched.points.row(i).transpose() - p).dot(p) - expected));
    }
    EXPECT_GT(plain_error, 2.0 * h);
    EXPECT_LT(matched_error, 0.2 * h);
    // Deterministic across thread counts.
    Resampling two = plain;
    match_reference_surface(two, reference, carried, T.inverse(), 2);
    EXPECT_EQ(two.points, matched.points);
}

TEST(ResamplingTest, matching_a_point_cloud_uses_each_point_s_offset)
{
    const TriangleMesh reference = icosphere(3);
    TriangleMesh cloud;
    cloud.V =
        1.01 * icosphere(2).V;  // on the sphere of radius 1.01: 0.01 off the reference's vertices
    Resampling r = resample(reference, cloud, Eigen::Matrix4d::Identity());
    match_reference_surface(r, reference, cloud, Eigen::Matrix4d::Identity());
    for (Eigen::Index i = 0; i < reference.V.rows(); ++i)
    {
        const Eigen::Vector3d p = reference.V.row(i).transpose();
        // The nearest point's own offset, 0.01 along its radius (its closest reference point is
        // the level-3 vertex under it), seen along p's radius: at most half a level-2 edge away.
        const double along = (r.points.row(i).transpose() - p).dot(p);
        EXPECT_GT(along, 0.009);
        EXPECT_LT(along, 0.0100001);
    }
    Resampling other = resample(icosphere(2), cloud, Eigen::Matrix4d::Identity());
    EXPECT_THROW(match_reference_surface(other, reference, cloud, Eigen::Matrix4d::Identity()),
                 InvalidOption);
}

TEST(ResamplingTest, rejects_singular_transform_and_bad_options)
{
    const TriangleMesh mesh = lumpy_ellipsoid(1);
    EXPECT_THROW(static_cast<void>(resample(mesh, mesh, Eigen::Matrix4d::Zero())), InvalidOption);
    EXPECT_THROW(
        static_cast<void>(resample(mesh, mesh, Eigen::Matrix4d::Identity(), {.quantile = 0.0})),
        InvalidOption);
    EXPECT_THROW(static_cast<void>(resample(mesh, TriangleMesh{}, Eigen::Matrix4d::Identity())),
                 InvalidMesh);
}

}  // namespace
}  // namespace meshmark
