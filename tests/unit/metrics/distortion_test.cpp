// SPDX-License-Identifier: MIT
#include "meshmark/metrics/distortion.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

TriangleMesh translated(TriangleMesh mesh, const Eigen::RowVector3d& t)
{
    mesh.V.rowwise() += t;
    return mesh;
}

CompareOptions with_samples(std::int64_t samples, int threads = 2)
{
    CompareOptions options;
    options.samples = samples;
    options.threads = threads;
    return options;
}

/// Flat grid over [0,1]^2 with 20x20 cells, and the same grid with its centre vertex raised by h.
constexpr int kBumpCells = 20;
constexpr double kBumpHeight = 0.1;

TriangleMesh bumped_grid()
{
    TriangleMesh mesh = plane_grid(kBumpCells, kBumpCells);
    mesh.V((kBumpCells / 2) * (kBumpCells + 1) + kBumpCells / 2, 2) = kBumpHeight;
    return mesh;
}

}  // namespace

TEST(DistortionTest, mesh_against_itself_is_zero)
{
    const TriangleMesh mesh = lumpy_ellipsoid(3);
    const DistortionReport r = compare_meshes(mesh, mesh, with_samples(5000));
    EXPECT_LE(r.hausdorff_rel, 1e-12);
    EXPECT_LE(r.mrms_rel, 1e-12);
    ASSERT_TRUE(r.displacement.has_value());
    EXPECT_EQ(r.displacement->max, 0.0);
    EXPECT_EQ(r.rms_displacement_rel, 0.0);
    EXPECT_EQ(r.a_to_b.vertex_samples, mesh.V.rows());
    EXPECT_EQ(r.a_to_b.area_samples, 5000);
}

TEST(DistortionTest, scaled_sphere_is_one_percent_of_radius_away)
{
    // Every point of the unit sphere is 0.01 from the sphere of radius 1.01. On the polyhedra,
    // vertices are exactly 0.01 from the other copy (the nearest point is the matching vertex)
    // and points inside faces a little less (their faces are flat).
    const TriangleMesh a = icosphere(3);
    TriangleMesh b = a;
    b.V *= 1.01;
    const DistortionReport r = compare_meshes(a, b, with_samples(5000));
    EXPECT_NEAR(r.diagonal, 2.0 * std::sqrt(3.0), 1e-12);
    const double expected_rel = 0.01 / r.diagonal;
    EXPECT_NEAR(r.hausdorff_rel, expected_rel, 0.02 * expected_rel);
    EXPECT_NEAR(r.hausdorff_ab_rel, expected_rel, 0.02 * expected_rel);
    EXPECT_NEAR(r.hausdorff_ba_rel, expected_rel, 0.02 * expected_rel);
    // Interior points are closer than vertices: RMS lies a little below the maximum.
    EXPECT_LE(r.rms_ab_rel, r.hausdorff_ab_rel);
    EXPECT_NEAR(r.rms_ab_rel, expected_rel, 0.03 * expected_rel);
    EXPECT_NEAR(r.mrms_rel, std::max(r.rms_ab_rel, r.rms_ba_rel), 0.0);
    EXPECT_NEAR(r.max_displacement_rel, expected_rel, 1e-12);
}

TEST(DistortionTest, translated_copy_is_the_translation_away)
{
    // A plane moved along its normal: every distance is exactly the translation.
    const TriangleMesh grid = plane_grid(10, 10);
    const DistortionReport flat =
        compare_meshes(grid, translated(grid, {0.0, 0.0, 0.05}), with_samples(2000));
    const double diagonal = std::sqrt(2.0);
    EXPECT_NEAR(flat.diagonal, diagonal, 1e-15);
    EXPECT_NEAR(flat.hausdorff_ab_rel, 0.05 / diagonal, 1e-12);
    EXPECT_NEAR(flat.hausdorff_ba_rel, 0.05 / diagonal, 1e-12);
    EXPECT_NEAR(flat.rms_ab_rel, 0.05 / diagonal, 1e-12);
    EXPECT_NEAR(flat.rms_ba_rel, 0.05 / diagonal, 1e-12);
    EXPECT_NEAR(flat.rms_displacement_rel, 0.05 / diagonal, 1e-12);

    // A sphere moved by t: the farthest points are the poles along t, at |t|.
    const TriangleMesh sphere = icosphere(3);
    const DistortionReport moved =
        compare_meshes(sphere, translated(sphere, {0.0, 0.0, 0.02}), with_samples(5000));
    EXPECT_NEAR(moved.hausdorff_rel * moved.diagonal, 0.02, 0.01 * 0.02);
}

TEST(DistortionTest, in_plane_shift_matches_analytic_rms)
{
    // Shifting the unit square by d along x uncovers a strip of width d whose points are
    // (d - x) from the copy: Hausdorff d, RMS sqrt(integral_0^d (d - x)^2 dx) = sqrt(d^3 / 3).
    const double d = 0.1;
    const TriangleMesh grid = plane_grid(20, 20);
    const DistortionReport r =
        compare_meshes(grid, translated(grid, {d, 0.0, 0.0}), with_samples(50'000));
    EXPECT_NEAR(r.a_to_b.max, d, 1e-12);
    EXPECT_NEAR(r.a_to_b.rms, std::sqrt(d * d * d / 3.0), 0.01 * std::sqrt(d * d * d / 3.0));
    EXPECT_NEAR(r.a_to_b.mean, d * d / 2.0, 0.01 * d * d / 2.0);
    EXPECT_NEAR(r.b_to_a.rms, r.a_to_b.rms, 0.01 * r.a_to_b.rms);  // symmetric situation
}

TEST(DistortionTest, one_sided_distances_differ_for_a_bump)
{
    // B's apex is h above the plane A: hausdorff_ba = h. The point of A under the apex is nearest
    // to the steepest faces of the bump, whose base edges (the grid diagonals) lie e = s / sqrt(2)
    // from it: hausdorff_ab = h e / sqrt(h^2 + e^2), well below h.
    const TriangleMesh a = plane_grid(kBumpCells, kBumpCells);
    const TriangleMesh b = bumped_grid();
    const DistortionReport r = compare_meshes(a, b, with_samples(5000));
    const double e = (1.0 / kBumpCells) / std::sqrt(2.0);
    const double h = kBumpHeight;
    EXPECT_NEAR(r.b_to_a.max, h, 1e-12);
    EXPECT_NEAR(r.a_to_b.max, h * e / std::sqrt(h * h + e * e), 1e-12);
    EXPECT_LT(r.hausdorff_ab_rel, 0.5 * r.hausdorff_ba_rel);
    EXPECT_EQ(r.hausdorff_rel, r.hausdorff_ba_rel);
    EXPECT_NEAR(r.b_to_a.max_point.z(), h, 1e-15);  // reached at the apex
}

TEST(DistortionTest, displacement_requires_shared_connectivity)
{
    const TriangleMesh a = lumpy_ellipsoid(3);
    TriangleMesh b = a;
    b.V.row(5) += 0.1 * a.V.row(5).normalized();  // outwards
    b.V.row(9) += Eigen::RowVector3d(0.03, 0.04, 0.0);
    const Displacement d = vertex_displacement(a, b);
    EXPECT_EQ(d.max_vertex, 5);
    EXPECT_NEAR(d.max, 0.1, 1e-15);
    EXPECT_NEAR(d.rms, std::sqrt((0.01 + 0.0025) / static_cast<double>(a.V.rows())), 1e-15);
    const DistortionReport r = compare_meshes(a, b, with_samples(2000));
    ASSERT_TRUE(r.displacement.has_value());
    EXPECT_NEAR(r.max_displacement_rel, 0.1 / r.diagonal, 1e-15);
    // The moved vertex is a sample of B, so the one-sided distance B -> A sees it (the bump is
    // 0.1 high; the surface of A is tilted against it by well under 60 degrees).
    EXPECT_GT(r.hausdorff_ba_rel, 0.5 * r.max_displacement_rel);

    TriangleMesh flipped = b;
    std::swap(flipped.F(0, 1), flipped.F(0, 2));
    EXPECT_FALSE(has_same_connectivity(a, flipped));
    EXPECT_THROW((void)vertex_displacement(a, flipped), InvalidMesh);
    EXPECT_FALSE(compare_meshes(a, flipped, with_samples(1000)).displacement.has_value());
    EXPECT_FALSE(compare_meshes(a, icosphere(2), with_samples(1000)).displacement.has_value());
    // The lumpy ellipsoid is a displaced icosphere: same connectivity, so displacement applies.
    EXPECT_TRUE(compare_meshes(a, icosphere(3), with_samples(1000)).displacement.has_value());
}

TEST(DistortionTest, point_clouds_are_measured_at_their_points)
{
    // Grid points 0.1 apart moved by 0.03 along z: each point's nearest neighbour is its copy.
    TriangleMesh cloud = plane_grid(10, 10);
    cloud.F.resize(0, 3);
    const DistortionReport r =
        compare_meshes(cloud, translated(cloud, {0.0, 0.0, 0.03}), with_samples(1000));
    EXPECT_EQ(r.a_to_b.area_samples, 0);
    EXPECT_EQ(r.a_to_b.vertex_samples, cloud.V.rows());
    EXPECT_NEAR(r.hausdorff_rel * r.diagonal, 0.03, 1e-12);
    EXPECT_NEAR(r.mrms_rel * r.diagonal, 0.03, 1e-12);
    ASSERT_TRUE(r.displacement.has_value());
    EXPECT_NEAR(r.displacement->rms, 0.03, 1e-12);

    // A cloud against a surface: the cloud's points lie on the surface, so cloud -> mesh is 0,
    // while mesh -> cloud sees the gaps between points (at most half a cell diagonal).
    const TriangleMesh grid = plane_grid(10, 10);
    const DistortionReport mixed = compare_meshes(cloud, grid, with_samples(5000));
    EXPECT_LE(mixed.a_to_b.max, 1e-15);
    EXPECT_GT(mixed.b_to_a.max, 0.06);
    EXPECT_LE(mixed.b_to_a.max, 0.05 * std::sqrt(2.0) + 1e-12);
}

TEST(DistortionTest, results_do_not_depend_on_threads_and_follow_the_seed)
{
    const TriangleMesh a = lumpy_ellipsoid(3);
    const TriangleMesh b = bumped_grid();
    CompareOptions one = with_samples(4000, 1);
    CompareOptions two = with_samples(4000, 2);
    const DistortionReport r1 = compare_meshes(a, b, one);
    const DistortionReport r2 = compare_meshes(a, b, two);
    EXPECT_EQ(r1.hausdorff_ab_rel, r2.hausdorff_ab_rel);
    EXPECT_EQ(r1.hausdorff_ba_rel, r2.hausdorff_ba_rel);
    EXPECT_EQ(r1.rms_ab_rel, r2.rms_ab_rel);
    EXPECT_EQ(r1.rms_ba_rel, r2.rms_ba_rel);
    EXPECT_EQ(r1.a_to_b.mean, r2.a_to_b.mean);
    EXPECT_EQ(r1.a_to_b.max_point, r2.a_to_b.max_point);
    two.seed = 99;
    const DistortionReport other_seed = compare_meshes(a, b, two);
    EXPECT_NE(other_seed.rms_ab_rel, r1.rms_ab_rel);
    EXPECT_NEAR(other_seed.rms_ab_rel, r1.rms_ab_rel, 0.01 * r1.rms_ab_rel);
}

TEST(DistortionTest, keeps_vertex_distances_of_b_on_request)
{
    const TriangleMesh a = plane_grid(kBumpCells, kBumpCells);
    const TriangleMesh b = bumped_grid();
    CompareOptions options = with_samples(1000);
    options.keep_vertex_distances = true;
    const DistortionReport r = compare_meshes(a, b, options);
    ASSERT_EQ(r.vertex_distances_ba.size(), b.V.rows());
    EXPECT_NEAR(r.vertex_distances_ba.maxCoeff(), kBumpHeight, 1e-15);
    EXPECT_EQ((r.vertex_distances_ba.array() > 1e-12).count(), 1);
    EXPECT_EQ(compare_meshes(a, b, with_samples(1000)).vertex_distances_ba.size(), 0);
}

TEST(DistortionTest, reports_each_phase_from_start_to_end)
{
    CompareOptions options = with_samples(1000);
    std::vector<std::pair<std::string, double>> calls;
    options.progress = [&](std::string_view phase, double fraction)
    { calls.emplace_back(phase, fraction); };
    (void)compare_meshes(icosphere(2), icosphere(3), options);
    const std::vector<std::pair<std::string, double>> expected = {{"index", 0.0},  {"index", 1.0},
                                                                  {"a_to_b", 0.0}, {"a_to_b", 1.0},
                                                                  {"b_to_a", 0.0}, {"b_to_a", 1.0}};
    EXPECT_EQ(calls, expected);
}

TEST(DistortionTest, auto_sample_count_is_clamped)
{
    EXPECT_EQ(auto_sample_count(icosphere(1)), kMinAutoSamples);
    TriangleMesh cloud = icosphere(1);
    cloud.F.resize(0, 3);
    EXPECT_EQ(auto_sample_count(cloud), 0);
    TriangleMesh big = icosphere(0);
    big.F.resize(kMaxAutoSamples / kAutoSamplesPerFace + 1, 3);
    big.F.setZero();
    EXPECT_EQ(auto_sample_count(big), kMaxAutoSamples);
}

TEST(DistortionTest, rejects_bad_options_and_unusable_meshes)
{
    const TriangleMesh mesh = icosphere(1);
    EXPECT_THROW((void)compare_meshes(mesh, mesh, with_samples(-1)), InvalidOption);
    EXPECT_THROW((void)compare_meshes(mesh, mesh, with_samples(10, -2)), InvalidOption);
    EXPECT_THROW((void)compare_meshes(mesh, TriangleMesh{}, with_samples(10)), InvalidMesh);
    TriangleMesh point;
    point.V = Positions::Zero(1, 3);
    EXPECT_THROW((void)compare_meshes(point, mesh, with_samples(10)), InvalidMesh);
}

TEST(SurfaceRmsDisplacementTest, reads_the_normal_part_of_a_field)
{
    const TriangleMesh grid = plane_grid(6, 6);  // in z = 0
    // Along the normal: the whole displacement; in the plane: nothing.
    Positions along = Positions::Zero(grid.V.rows(), 3);
    along.col(2).setConstant(0.03);
    EXPECT_NEAR(surface_rms_displacement(grid, along), 0.03, 1e-15);
    Positions sliding = Positions::Zero(grid.V.rows(), 3);
    sliding.col(0).setConstant(0.03);
    sliding.col(1).setConstant(-0.01);
    EXPECT_NEAR(surface_rms_displacement(grid, sliding), 0.0, 1e-15);

    // One triangle with corner offsets a: the mean square of their linear interpolation,
    // here by a fine midpoint quadrature over the triangle rather than the closed form.
    TriangleMesh triangle;
    triangle.V.resize(3, 3);
    triangle.V << 0, 0, 0, 2, 0, 0, 0, 1, 0;
    triangle.F.resize(1, 3);
    triangle.F << 0, 1, 2;
    const double a[3] = {0.02, -0.05, 0.01};
    Positions field = Positions::Zero(3, 3);
    for (int c = 0; c < 3; ++c)
    {
        field(c, 2) = a[c];
        field(c, 0) = 0.7 * a[c];  // a tangential part, ignored
    }
    const int n = 400;
    double sum = 0.0;
    int count = 0;
    auto add = [&](double u, double v)
    {
        const double value = (1.0 - u - v) * a[0] + u * a[1] + v * a[2];
        sum += value * value;
        ++count;
    };
    // The n^2 equal sub-triangles of a regular subdivision, each at its centroid.
    for (int i = 0; i < n; ++i)
    {
        for (int j = 0; i + j < n; ++j)
        {
            add((i + 1.0 / 3.0) / n, (j + 1.0 / 3.0) / n);
            if (i + j < n - 1)
            {
                add((i + 2.0 / 3.0) / n, (j + 2.0 / 3.0) / n);
            }
        }
    }
    EXPECT_NEAR(surface_rms_displacement(triangle, field), std::sqrt(sum / count),
                1e-3 * std::sqrt(sum / count));
}

TEST(SurfaceRmsDisplacementTest, reads_at_or_just_above_the_sampled_mrms)
{
    // A smooth field on a curved surface: the first-order value and the sampled MRMS agree
    // within a few percent, the first-order one not below (curvature only brings points closer).
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const double diagonal = (mesh.V.colwise().maxCoeff() - mesh.V.colwise().minCoeff()).norm();
    Positions field(mesh.V.rows(), 3);
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        const double x = mesh.V(i, 0);
        const double y = mesh.V(i, 1);
        const double z = mesh.V(i, 2);
        field.row(i) << std::sin(3.0 * y), std::cos(2.0 * z + x), std::sin(x - 2.0 * y);
    }
    field *= 1e-3 * diagonal;
    TriangleMesh moved = mesh;
    moved.V += field;
    const double first_order = surface_rms_displacement(mesh, field) / diagonal;
    const DistortionReport sampled = compare_meshes(mesh, moved, with_samples(200000));
    EXPECT_GE(first_order, 0.995 * sampled.mrms_rel);
    EXPECT_LE(first_order, 1.05 * sampled.mrms_rel);
    // Far from the vertex RMS: the measure is not the field's size.
    EXPECT_LT(first_order, 0.8 * sampled.rms_displacement_rel);
}

TEST(SurfaceRmsDisplacementTest, does_not_depend_on_the_thread_count)
{
    const TriangleMesh mesh = lumpy_ellipsoid(7);  // 327,680 faces: 5 blocks
    const Positions field = 1e-3 * Positions::Random(mesh.V.rows(), 3);
    const double one = surface_rms_displacement(mesh, field, 1);
    EXPECT_GT(one, 0.0);
    EXPECT_EQ(surface_rms_displacement(mesh, field, 2), one);
    EXPECT_EQ(surface_rms_displacement(mesh, field, 3), one);
}

TEST(SurfaceRmsDisplacementTest, a_point_cloud_gets_an_isotropic_fields_normal_part)
{
    TriangleMesh cloud;
    cloud.V = Positions::Random(50, 3);
    Positions field = Positions::Random(50, 3);
    EXPECT_NEAR(surface_rms_displacement(cloud, field), std::sqrt(field.squaredNorm() / 150.0),
                1e-15);
    EXPECT_THROW((void)surface_rms_displacement(cloud, Positions::Zero(49, 3)), InvalidMesh);
}

TEST(SurfaceRmsOfSumsTest, gives_the_surface_rms_of_every_sum_and_the_scale_that_hits_a_target)
{
    const TriangleMesh mesh = lumpy_ellipsoid(3);
    Positions base(mesh.V.rows(), 3);
    Positions field(mesh.V.rows(), 3);
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        base.row(i) << std::sin(2.0 * mesh.V(i, 1)), 0.3, std::cos(mesh.V(i, 0));
        field.row(i) << std::cos(3.0 * mesh.V(i, 2)), std::sin(mesh.V(i, 0) + mesh.V(i, 1)), -0.2;
    }
    base *= 1e-3;
    field *= 2e-3;
    const SurfaceRmsOfSums sums(mesh, base);
    const SurfaceRmsOfSums::Terms terms = sums.terms(field);
    for (const double c : {0.0, 0.5, 1.0, 1.7})
    {
        EXPECT_NEAR(terms.rms(c), surface_rms_displacement(mesh, base + c * field),
                    1e-12 * terms.rms(1.0))
            << c;
    }
    const double target = 1.2 * terms.rms(1.0);
    const double c = terms.scale_to(target);
    EXPECT_GT(c, 1.0);
    EXPECT_NEAR(surface_rms_displacement(mesh, base + c * field), target, 1e-12 * target);
    // No solution: a base already beyond the target, or a field without a normal part.
    EXPECT_EQ(terms.scale_to(0.5 * terms.bb > 0.0 ? std::sqrt(terms.bb) * 0.5 : 0.0), 1.0);
    EXPECT_EQ(sums.terms(Positions::Zero(mesh.V.rows(), 3)).scale_to(target), 1.0);

    TriangleMesh cloud;
    cloud.V = mesh.V;
    const SurfaceRmsOfSums::Terms points = SurfaceRmsOfSums(cloud, base).terms(field);
    EXPECT_NEAR(points.rms(0.8), surface_rms_displacement(cloud, base + 0.8 * field), 1e-15);
}

}  // namespace meshmark
