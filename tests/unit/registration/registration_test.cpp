// SPDX-License-Identifier: MIT
#include "meshmark/registration/registration.h"

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/registration/point_pairs.h"
#include "perturbations.h"
#include "support/test_shapes.h"

namespace meshmark
{
namespace
{

double linear_det(const Eigen::Matrix4d& T)
{
    return T.topLeftCorner<3, 3>().determinant();
}

// The suspect's clean positions mapped back by the registration, compared with where they
// came from in the reference, relative to the reference's bbox diagonal.
double alignment_error(const RegistrationResult& result, const Positions& clean_suspect,
                       const Positions& truth, double diagonal)
{
    return test::rms_distance(transform_points(result.transform, clean_suspect), truth) / diagonal;
}

// Registers two copies of a lumpy ellipsoid, each moved by a random similarity (mirrored when
// \p mirrored, seeded by \p seed), checks that each converges to the exact alignment with the
// right reflection flag, and hands the result and the applied transform to \p more_checks.
template <class Checks>
void check_random_copies(std::uint64_t seed, bool mirrored, Checks more_checks)
{
    const TriangleMesh reference = lumpy_ellipsoid(3);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(seed);
    for (int trial = 0; trial < 2; ++trial)
    {
        const Eigen::Matrix4d T = test::random_similarity(rng, mirrored);
        TriangleMesh suspect = reference;
        suspect.V = test::apply(T, reference.V);
        const RegistrationResult result = register_to_reference(suspect, reference);
        EXPECT_TRUE(result.converged) << "trial " << trial;
        EXPECT_EQ(result.is_reflection, mirrored);
        EXPECT_LT(alignment_error(result, suspect.V, reference.V, D), 1e-9) << "trial " << trial;
        more_checks(result, T);
    }
}

TEST(RegistrationTest, recovers_known_similarities_of_lumpy_ellipsoid)
{
    check_random_copies(1, false,
                        [](const RegistrationResult& result, const Eigen::Matrix4d& T)
                        {
                            // The recovered transform is the inverse of the applied one, scale
                            // included.
                            const Eigen::Matrix4d expected = T.inverse();
                            EXPECT_LT((result.transform - expected).norm() / expected.norm(), 1e-9);
                            EXPECT_NEAR(result.scale * std::cbrt(T.block<3, 3>(0, 0).determinant()),
                                        1.0, 1e-9);
                            EXPECT_LT(result.rms_error, 1e-9);
                            EXPECT_GT(result.overlap_fraction, 0.99);
                        });
}

TEST(RegistrationTest, recovers_mirrored_copy_and_reports_reflection)
{
    check_random_copies(2, true,
                        [](const RegistrationResult& result, const Eigen::Matrix4d& /*T*/)
                        { EXPECT_LT(linear_det(result.transform), 0.0); });
}

TEST(RegistrationTest, refuses_reflection_when_not_allowed)
{
    const TriangleMesh reference = lumpy_ellipsoid(3);
    Rng rng(3);
    TriangleMesh suspect = reference;
    suspect.V = test::apply(test::random_similarity(rng, true), reference.V);
    const RegistrationResult result =
        register_to_reference(suspect, reference, {.allow_reflection = false});
    EXPECT_FALSE(result.is_reflection);
    EXPECT_GT(linear_det(result.transform), 0.0);
    // A proper map cannot fit a mirrored asymmetric shape.
    EXPECT_GT(result.rms_error, 1e-3);
}

// The fine stage's structure over the reference is handed out only when asked for (detection's
// symmetry search reuses it), by both entry points, and answers on the reference's surface:
// every vertex lies on it, and a face's centroid lifted along its normal is that far above it.
TEST(RegistrationTest, keeps_the_reference_surface_only_when_asked)
{
    const TriangleMesh reference = lumpy_ellipsoid(3);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(4);
    TriangleMesh suspect = reference;
    suspect.V = test::apply(test::random_similarity(rng, false), reference.V);
    EXPECT_EQ(register_to_reference(suspect, reference).reference_surface, nullptr);
    const RegistrationResult result =
        register_to_reference(suspect, reference, {.keep_reference_surface = true});
    ASSERT_NE(result.reference_surface, nullptr);
    const std::vector<PointPair> pairs = {
        {suspect.V.row(0).transpose(), reference.V.row(0).transpose()},
        {suspect.V.row(50).transpose(), reference.V.row(50).transpose()},
        {suspect.V.row(100).transpose(), reference.V.row(100).transpose()},
        {suspect.V.row(150).transpose(), reference.V.row(150).transpose()}};
    EXPECT_EQ(register_to_reference(suspect, reference, pairs).reference_surface, nullptr);
    EXPECT_NE(register_to_reference(suspect, reference, pairs, {.keep_reference_surface = true})
                  .reference_surface,
              nullptr);
    const SurfaceMatcher& surface = *result.reference_surface;
    ASSERT_TRUE(surface.has_normals());
    for (Eigen::Index v = 0; v < reference.V.rows(); v += 37)
    {
        EXPECT_LT(surface.match(reference.V.row(v).transpose()).distance, 1e-12 * D);
    }
    for (Eigen::Index f = 0; f < reference.F.rows(); f += 53)
    {
        const Eigen::Vector3d a = reference.V.row(reference.F(f, 0)).transpose();
        const Eigen::Vector3d b = reference.V.row(reference.F(f, 1)).transpose();
        const Eigen::Vector3d c = reference.V.row(reference.F(f, 2)).transpose();
        const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
        const double lift = 1e-4 * D;  // far below the ellipsoid's curvature radius
        const SurfaceMatch m = surface.match((a + b + c) / 3.0 + lift * n);
        EXPECT_NEAR(m.distance, lift, 1e-3 * lift) << "face " << f;
        EXPECT_GT(m.normal.dot(n), 0.999) << "face " << f;
    }
}

// Started near the answer (the copy's true pose turned by 8 degrees and moved by 3% of the
// diagonal), register_from lands on it, mirrored copies included, and keeps the start's
// handedness; a start that is no similarity is refused.
TEST(RegistrationTest, registers_from_a_start_near_the_answer)
{
    const TriangleMesh reference = lumpy_ellipsoid(3);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(7);
    for (const bool mirrored : {false, true})
    {
        const Eigen::Matrix4d T = test::random_similarity(rng, mirrored);
        TriangleMesh suspect = reference;
        suspect.V = test::apply(T, reference.V);
        Eigen::Matrix4d nudge = Eigen::Matrix4d::Identity();
        nudge.topLeftCorner<3, 3>() = Eigen::AngleAxisd(8.0 * std::numbers::pi / 180.0,
                                                        Eigen::Vector3d(1.0, 2.0, 0.5).normalized())
                                          .matrix();
        nudge.topRightCorner<3, 1>() = Eigen::Vector3d(0.03 * D, 0.0, -0.01 * D);
        const RegistrationResult result = register_from(suspect, reference, nudge * T.inverse());
        EXPECT_EQ(result.is_reflection, mirrored);
        EXPECT_EQ(linear_det(result.transform) < 0.0, mirrored);
        EXPECT_LT(alignment_error(result, suspect.V, reference.V, D), 1e-9) << mirrored;
        EXPECT_LT(result.rms_error, 1e-9);
        EXPECT_EQ(result.candidates, 1);
    }
    Eigen::Matrix4d sheared = Eigen::Matrix4d::Identity();
    sheared(0, 1) = 0.5;
    EXPECT_THROW((void)register_from(reference, reference, sheared), InvalidOption);
}

// The principal spread sees the shape, not its place, size or handedness: a moved, scaled,
// mirrored copy has the same; stretching one axis changes it.
TEST(RegistrationTest, principal_spread_is_the_same_for_every_similar_copy)
{
    const TriangleMesh reference = lumpy_ellipsoid(3);
    const Eigen::Vector3d spread = principal_spread(reference);
    EXPECT_NEAR(spread.sum(), 1.0, 1e-12);
    EXPECT_LE(spread(0), spread(1));
    EXPECT_LE(spread(1), spread(2));
    Rng rng(9);
    for (const bool mirrored : {false, true})
    {
        TriangleMesh copy = reference;
        copy.V = test::apply(test::random_similarity(rng, mirrored), reference.V);
        EXPECT_LT((principal_spread(copy) - spread).norm(), 1e-9) << mirrored;
    }
    TriangleMesh stretched = reference;
    stretched.V.col(0) *= 1.2;
    EXPECT_GT((principal_spread(stretched) - spread).norm(), 1e-2);
    TriangleMesh flat = reference;
    flat.V.setZero();
    EXPECT_THROW((void)principal_spread(flat), InvalidMesh);
}

// A copy turned and slightly scaled about its own centre has the original's centroid and
// nearly its radius, so the registration keeps the start in place (the identity) through
// every round, although it is wrong here. Refined without a scale clamp, such a start can
// shrink the copy onto one point of the reference, where the residual vanishes; the choice
// must refuse that and keep the right pose.
TEST(RegistrationTest, copies_turned_about_their_own_centre_are_registered)
{
    const TriangleMesh reference = lumpy_ellipsoid(3);
    const double D = bounding_box(reference.V).diagonal();
    const Eigen::Vector3d centre = reference.V.colwise().mean().transpose();
    Rng rng(41);
    for (int trial = 0; trial < 4; ++trial)
    {
        Eigen::Quaterniond q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
        q.normalize();
        const double scale = rng.uniform(0.85, 1.15);
        Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
        T.block<3, 3>(0, 0) = scale * q.toRotationMatrix();
        T.block<3, 1>(0, 3) = centre - T.block<3, 3>(0, 0) * centre;
        TriangleMesh suspect = reference;
        suspect.V = test::apply(T, reference.V);
        const RegistrationResult result = register_to_reference(suspect, reference);
        EXPECT_TRUE(result.converged) << "trial " << trial;
        EXPECT_FALSE(result.is_reflection) << "trial " << trial;
        EXPECT_NEAR(result.scale * scale, 1.0, 1e-9) << "trial " << trial;
        EXPECT_LT(alignment_error(result, suspect.V, reference.V, D), 1e-9) << "trial " << trial;
    }
}

TEST(RegistrationTest, converges_on_copy_cropped_to_half_by_a_plane)
{
    const TriangleMesh reference = lumpy_ellipsoid(3);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(4);
    for (int trial = 0; trial < 2; ++trial)
    {
        const Eigen::Vector3d n =
            Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
        const test::Cropped cropped = test::crop_by_plane(reference, n, 0.5);
        const Eigen::Matrix4d T = test::random_similarity(rng, trial % 2 == 1);
        TriangleMesh suspect = cropped.mesh;
        suspect.V = test::apply(T, cropped.mesh.V);
        const RegistrationResult result = register_to_reference(suspect, reference);
        EXPECT_TRUE(result.converged) << "trial " << trial;
        EXPECT_EQ(result.is_reflection, trial % 2 == 1);
        EXPECT_LT(alignment_error(result, suspect.V, cropped.mesh.V, D), 1e-8) << "trial " << trial;
    }
}

// A mirrored copy, noisy as a marked one is (0.1% of the diagonal), of a nearly
// mirror-symmetric vehicle (a box on one side of its roof) fits about as well unmirrored, laid
// on the symmetric 97%: the registration gives that fit too (other_handedness), of the other
// determinant's sign, and one of the two is the exact alignment. A lumpy ellipsoid's mirrored
// copy fits only one way: no other handedness.
TEST(RegistrationTest, gives_the_other_handedness_when_a_nearly_symmetric_reference_fits_both_ways)
{
    Rng rng(5);
    const TriangleMesh vehicle = test::vehicle(true);
    const double D = bounding_box(vehicle.V).diagonal();
    for (int trial = 0; trial < 2; ++trial)
    {
        TriangleMesh suspect = vehicle;
        const Eigen::Matrix4d T = test::random_similarity(rng, true);
        suspect.V = test::apply(T, test::add_noise(vehicle.V, 0.001 * D, rng));
        const RegistrationResult result = register_to_reference(suspect, vehicle);
        ASSERT_TRUE(result.other_handedness.has_value()) << "trial " << trial;
        EXPECT_LT(linear_det(result.transform) * linear_det(*result.other_handedness), 0.0);
        const Positions clean = test::apply(T, vehicle.V);
        RegistrationResult other = result;
        other.transform = *result.other_handedness;
        EXPECT_LT(std::min(alignment_error(result, clean, vehicle.V, D),
                           alignment_error(other, clean, vehicle.V, D)),
                  1e-3)
            << "trial " << trial;
    }
    const TriangleMesh lumpy = lumpy_ellipsoid(3);
    const double d = bounding_box(lumpy.V).diagonal();
    TriangleMesh suspect = lumpy;
    suspect.V =
        test::apply(test::random_similarity(rng, true), test::add_noise(lumpy.V, 0.001 * d, rng));
    const RegistrationResult result = register_to_reference(suspect, lumpy);
    EXPECT_TRUE(result.is_reflection);
    EXPECT_FALSE(result.other_handedness.has_value());
}

// A modelling tool bisects along a coordinate axis through the bounding box's centre (Blender's
// bisect, a cut in half in any editor); the half is then moved anywhere. Without the axis
// halves among the crop hypotheses no start led to the right pose (the moments of a multi-part
// asset's half are close to many other parts'), and without the overlap in the score the half
// turned end for end, which lays 92% of its samples exactly on the other half (tyres and
// body), tied with the right pose and was chosen: 0.9% of the diagonal off.
TEST(RegistrationTest, registers_a_half_cut_through_the_bounding_box_centre_along_an_axis)
{
    const TriangleMesh reference = test::vehicle();
    const BoundingBox box = bounding_box(reference.V);
    const double D = box.diagonal();
    Rng rng(21);
    for (int axis = 0; axis < 2; ++axis)
    {
        const Eigen::Vector3d n = Eigen::Vector3d::Unit(axis);
        const double centre = 0.5 * (box.min(axis) + box.max(axis));
        const auto below = (reference.V.col(axis).array() < centre).count();
        const test::Cropped half = test::crop_by_plane(
            reference, n, static_cast<double>(below) / static_cast<double>(reference.V.rows()));
        for (int trial = 0; trial < 2; ++trial)
        {
            TriangleMesh suspect = half.mesh;
            suspect.V = test::apply(test::random_similarity(rng, false), half.mesh.V);
            const RegistrationResult result = register_to_reference(suspect, reference);
            EXPECT_FALSE(result.is_reflection);
            EXPECT_LT(alignment_error(result, suspect.V, half.mesh.V, D), 1e-6)
                << "axis " << axis << ", trial " << trial << ": RMS " << result.rms_error
                << ", overlap " << result.overlap_fraction;
        }
    }
}

// A box of 12 triangles beside dense tyres, like a game vehicle's body: a copy whose box is
// finely tessellated (a remesh, a voxel remesh) has most of its samples above the box's large
// faces, where the nearest vertex of the reference is often a tyre's. Matched through the
// vertices alone, ICP settled on a wrong pose (a voxel remesh of such a vehicle registered
// 0.2% of the diagonal off, and its mark was lost); the points inside large faces fix that.
TEST(RegistrationTest, registers_a_finely_tessellated_copy_of_large_faces_beside_dense_parts)
{
    TriangleMesh box;
    box.V.resize(8, 3);
    for (int i = 0; i < 8; ++i)
    {
        box.V.row(i) << ((i & 1) != 0 ? 1.1 : -1.1), ((i & 2) != 0 ? 0.5 : -0.5),
            ((i & 4) != 0 ? 0.85 : 0.35);
    }
    box.F.resize(12, 3);
    box.F << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4,
        6, 1, 3, 5, 3, 7, 5;
    std::vector<TriangleMesh> tyres;
    for (const double x : {0.75, -0.75})
    {
        for (const double y : {0.62, -0.62})
        {
            tyres.push_back(test::tyre({x, y, 0.32}));
        }
    }
    std::vector<TriangleMesh> parts = tyres;
    parts.insert(parts.begin(), box);
    const TriangleMesh reference = test::joined(parts);
    // The box again, each face a 16 x 16 grid (the same surface).
    std::vector<TriangleMesh> faces;
    for (int axis = 0; axis < 3; ++axis)
    {
        for (const int side : {0, 1})
        {
            TriangleMesh grid = plane_grid(16, 16);
            const Eigen::Vector3d lo = box.V.row(0).transpose();
            const Eigen::Vector3d hi = box.V.row(7).transpose();
            const int u = (axis + 1) % 3;
            const int w = (axis + 2) % 3;
            Positions V(grid.V.rows(), 3);
            for (Eigen::Index i = 0; i < grid.V.rows(); ++i)
            {
                V(i, axis) = side == 0 ? lo(axis) : hi(axis);
                V(i, u) = lo(u) + grid.V(i, 0) * (hi(u) - lo(u));
                V(i, w) = lo(w) + grid.V(i, 1) * (hi(w) - lo(w));
            }
            grid.V = V;
            faces.push_back(grid);
        }
    }
    parts.front() = test::joined(faces);
    const TriangleMesh fine = test::joined(parts);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(5);
    for (int trial = 0; trial < 2; ++trial)
    {
        TriangleMesh suspect = fine;
        suspect.V = test::apply(test::random_similarity(rng, false), fine.V);
        const RegistrationResult result = register_to_reference(suspect, reference);
        EXPECT_TRUE(result.converged) << "trial " << trial;
        EXPECT_LT(alignment_error(result, suspect.V, fine.V, D), 1e-6)
            << "trial " << trial << ": RMS " << result.rms_error;
    }
}

// An articulated copy: the part of the shape beyond a hinge turned by 25 degrees (a character
// re-posed, a lid opened). No single pose fits it; the registration must lay the larger part
// exactly on the reference (the rest is then read like a crop). Trimmed at 90% alone, the fit
// settled between the two parts.
TEST(RegistrationTest, lays_the_larger_part_of_a_copy_bent_at_a_hinge_on_the_reference)
{
    const TriangleMesh reference = lumpy_ellipsoid(4);
    const double D = bounding_box(reference.V).diagonal();
    const double hinge = 0.3;
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(25.0 * std::numbers::pi / 180.0, Eigen::Vector3d::UnitY())
            .toRotationMatrix();
    TriangleMesh bent = reference;
    std::vector<Eigen::Index> still;
    for (Eigen::Index i = 0; i < bent.V.rows(); ++i)
    {
        const Eigen::Vector3d x = reference.V.row(i).transpose();
        if (x.x() > hinge)
        {
            const Eigen::Vector3d pivot(hinge, 0.0, 0.0);
            bent.V.row(i) = (turn * (x - pivot) + pivot).transpose();
        }
        else
        {
            still.push_back(i);
        }
    }
    Rng rng(9);
    for (int trial = 0; trial < 2; ++trial)
    {
        TriangleMesh suspect = bent;
        suspect.V = test::apply(test::random_similarity(rng, false), bent.V);
        const RegistrationResult result = register_to_reference(suspect, reference);
        const Positions back = transform_points(result.transform, suspect.V);
        double squared = 0.0;
        for (const Eigen::Index i : still)
        {
            squared += (back.row(i) - reference.V.row(i)).squaredNorm();
        }
        EXPECT_FALSE(result.is_reflection);
        EXPECT_LT(std::sqrt(squared / static_cast<double>(still.size())) / D, 1e-6)
            << "trial " << trial << ": RMS " << result.rms_error << ", overlap "
            << result.overlap_fraction;
    }
}

TEST(RegistrationTest, converges_on_noisy_copy)
{
    const TriangleMesh reference = lumpy_ellipsoid(4);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(5);
    for (int trial = 0; trial < 2; ++trial)
    {
        const Eigen::Matrix4d T = test::random_similarity(rng, false);
        TriangleMesh suspect = reference;
        const Positions clean = test::apply(T, reference.V);
        suspect.V =
            test::add_noise(clean, 0.01 * D * std::cbrt(T.block<3, 3>(0, 0).determinant()), rng);
        const RegistrationResult result = register_to_reference(suspect, reference);
        EXPECT_TRUE(result.converged) << "trial " << trial;
        // Noise of 1% of the diagonal averages out over thousands of samples.
        EXPECT_LT(alignment_error(result, clean, reference.V, D), 1e-3) << "trial " << trial;
        EXPECT_GT(result.rms_error, 1e-3);  // the residual reflects the noise
    }
}

TEST(RegistrationTest, converges_on_point_cloud_and_triangle_soup)
{
    const TriangleMesh reference = lumpy_ellipsoid(3);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(6);
    const Eigen::Matrix4d T = test::random_similarity(rng, false);
    TriangleMesh cloud;
    cloud.V = test::apply(T, reference.V);
    const RegistrationResult from_cloud = register_to_reference(cloud, reference);
    EXPECT_TRUE(from_cloud.converged);
    EXPECT_LT(alignment_error(from_cloud, cloud.V, reference.V, D), 1e-9);

    TriangleMesh soup = test::triangle_soup(reference);
    const Positions soup_truth = soup.V;
    soup.V = test::apply(T, soup.V);
    const RegistrationResult from_soup = register_to_reference(soup, reference);
    EXPECT_TRUE(from_soup.converged);
    EXPECT_LT(alignment_error(from_soup, soup.V, soup_truth, D), 1e-9);
}

// A triangle soup whose triangles were shrunk to slivers about their centroids (Open3D's
// Taubin filter on an STL read without welding: the copy's vertices still lie on the surface,
// its triangles cover none of it). Here the slivers of one end keep 10^4 times the size
// of the rest (its last 5% along x), so area moments would put the copy's centre, axes and
// scale at that end (the moved copy then lands 0.21 of the diagonal off); its vertices
// measure it instead (has_collapsed_triangles), in place and moved.
TEST(RegistrationTest, converges_on_a_soup_of_collapsed_triangles)
{
    const TriangleMesh reference = lumpy_ellipsoid(4);
    const double D = bounding_box(reference.V).diagonal();
    TriangleMesh soup = test::triangle_soup(reference);
    const double end = reference.V.col(0).maxCoeff() -
                       0.05 * (reference.V.col(0).maxCoeff() - reference.V.col(0).minCoeff());
    for (Eigen::Index f = 0; f < soup.F.rows(); ++f)
    {
        const Eigen::RowVector3d centre =
            (soup.V.row(3 * f) + soup.V.row(3 * f + 1) + soup.V.row(3 * f + 2)) / 3.0;
        const double shrink = centre(0) > end ? 1e-4 : 1e-8;
        for (Eigen::Index c = 0; c < 3; ++c)
        {
            soup.V.row(3 * f + c) = centre + shrink * (soup.V.row(3 * f + c) - centre);
        }
    }
    const Positions truth = soup.V;
    const RegistrationResult in_place = register_to_reference(soup, reference);
    EXPECT_TRUE(in_place.converged);
    EXPECT_LT(alignment_error(in_place, soup.V, truth, D), 1e-4);
    Rng rng(8);
    const Eigen::Matrix4d T = test::random_similarity(rng, false);
    soup.V = test::apply(T, truth);
    const RegistrationResult moved = register_to_reference(soup, reference);
    EXPECT_TRUE(moved.converged);
    EXPECT_LT(alignment_error(moved, soup.V, truth, D), 1e-4);
}

TEST(RegistrationTest, point_cloud_reference_works)
{
    TriangleMesh reference = lumpy_ellipsoid(3);
    reference.F.resize(0, 3);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(7);
    TriangleMesh suspect = reference;
    suspect.V = test::apply(test::random_similarity(rng, false), reference.V);
    const RegistrationResult result = register_to_reference(suspect, reference);
    EXPECT_TRUE(result.converged);
    EXPECT_LT(alignment_error(result, suspect.V, reference.V, D), 1e-9);
}

TEST(RegistrationTest, user_point_pairs_give_the_transform)
{
    // A torus is symmetric about its axis: no automatic method can tell its rotation about z,
    // but three pairs can.
    const TriangleMesh reference = torus(1.0, 0.35, 48, 24);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(8);
    const Eigen::Matrix4d T = test::random_similarity(rng, false);
    TriangleMesh suspect = reference;
    suspect.V = test::apply(T, reference.V);
    std::vector<PointPair> pairs;
    for (const Eigen::Index i : {Eigen::Index{0}, Eigen::Index{300}, Eigen::Index{700}})
    {
        pairs.push_back({suspect.V.row(i).transpose(), reference.V.row(i).transpose()});
    }
    const Eigen::Matrix4d from_pairs = similarity_from_pairs(pairs);
    EXPECT_LT((from_pairs - T.inverse()).norm() / T.inverse().norm(), 1e-9);

    const RegistrationResult result = register_to_reference(suspect, reference, pairs);
    EXPECT_TRUE(result.converged);
    EXPECT_FALSE(result.is_reflection);
    EXPECT_LT(alignment_error(result, suspect.V, reference.V, D), 1e-9);
}

TEST(RegistrationTest, similarity_from_pairs_finds_reflections_and_rejects_collinear_points)
{
    Rng rng(9);
    const Eigen::Matrix4d T = test::random_similarity(rng, true);
    std::vector<PointPair> pairs;
    const TriangleMesh shape = lumpy_ellipsoid(1);
    for (Eigen::Index i = 0; i < 6; ++i)
    {
        const Eigen::Vector3d p = shape.V.row(7 * i).transpose();
        pairs.push_back({T.block<3, 3>(0, 0) * p + T.block<3, 1>(0, 3), p});
    }
    const Eigen::Matrix4d A = similarity_from_pairs(pairs);
    EXPECT_LT((A - T.inverse()).norm() / T.inverse().norm(), 1e-9);
    EXPECT_LT(linear_det(A), 0.0);
    EXPECT_GT(linear_det(similarity_from_pairs(pairs, false)), 0.0);

    std::vector<PointPair> collinear;
    for (int i = 0; i < 4; ++i)
    {
        collinear.push_back({Eigen::Vector3d(i, 2.0 * i, 0.0), Eigen::Vector3d(i, 0.0, 0.0)});
    }
    EXPECT_THROW(static_cast<void>(similarity_from_pairs(collinear)), InvalidOption);
    collinear.resize(2);
    EXPECT_THROW(static_cast<void>(similarity_from_pairs(collinear)), InvalidOption);
}

TEST(RegistrationTest, is_bit_identical_for_one_and_two_threads)
{
    const TriangleMesh reference = lumpy_ellipsoid(3);
    Rng rng(10);
    const test::Cropped cropped =
        test::crop_by_plane(reference, Eigen::Vector3d(0.3, -0.5, 0.8).normalized(), 0.6);
    TriangleMesh suspect = cropped.mesh;
    suspect.V =
        test::add_noise(test::apply(test::random_similarity(rng, true), cropped.mesh.V), 0.02, rng);
    const RegistrationResult one = register_to_reference(suspect, reference, {.threads = 1});
    const RegistrationResult two = register_to_reference(suspect, reference, {.threads = 2});
    for (Eigen::Index i = 0; i < 16; ++i)
    {
        EXPECT_EQ(one.transform.data()[i], two.transform.data()[i]) << "entry " << i;
    }
    EXPECT_EQ(one.rms_error, two.rms_error);
    EXPECT_EQ(one.iterations, two.iterations);
    EXPECT_EQ(one.overlap_fraction, two.overlap_fraction);
}

TEST(RegistrationTest, rejects_bad_input_and_options)
{
    const TriangleMesh reference = lumpy_ellipsoid(2);
    TriangleMesh tiny;
    tiny.V = Positions::Zero(3, 3);
    EXPECT_THROW(static_cast<void>(register_to_reference(tiny, reference)), InvalidMesh);
    TriangleMesh flat_point;
    flat_point.V = Positions::Ones(10, 3);
    EXPECT_THROW(static_cast<void>(register_to_reference(flat_point, reference)), InvalidMesh);
    EXPECT_THROW(static_cast<void>(register_to_reference(reference, reference, {.trim_keep = 0.1})),
                 InvalidOption);
    EXPECT_THROW(static_cast<void>(register_to_reference(reference, reference, {.threads = -1})),
                 InvalidOption);
}

}  // namespace
}  // namespace meshmark
