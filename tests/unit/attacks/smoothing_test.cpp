// SPDX-License-Identifier: MIT
#include "meshmark/attacks/smoothing.h"

#include <cmath>

#include <gtest/gtest.h>

#include "attack_test_util.h"
#include "meshmark/attacks/noise.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

// Standard deviation of the distances to the origin: the roughness of a noisy sphere.
double radial_spread(const TriangleMesh& mesh)
{
    const Eigen::VectorXd r = mesh.V.rowwise().norm();
    return std::sqrt((r.array() - r.mean()).square().mean());
}

TriangleMesh noisy_sphere()
{
    Rng rng(3);
    return add_noise(icosphere(4), {.amplitude = 0.005}, rng);
}

}  // namespace

TEST(SmoothingTest, one_step_moves_each_vertex_lambda_of_the_way_to_its_neighbour_mean)
{
    const TriangleMesh mesh = noisy_sphere();
    const TriangleMesh smoothed = smooth_laplacian(mesh, {.iterations = 1, .lambda = 0.25});
    const VertexAdjacency adjacency = vertex_adjacency(mesh);
    for (const Eigen::Index i : {0, 17, 1000})
    {
        Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
        for (const auto j : adjacency.of(static_cast<std::size_t>(i)))
        {
            mean += mesh.V.row(j);
        }
        mean /= static_cast<double>(adjacency.of(static_cast<std::size_t>(i)).size());
        const Eigen::RowVector3d expected = mesh.V.row(i) + 0.25 * (mean - mesh.V.row(i));
        EXPECT_LT((smoothed.V.row(i) - expected).norm(), 1e-15);
    }
    EXPECT_EQ(smoothed.F, mesh.F);
}

TEST(SmoothingTest, laplacian_smoothing_removes_noise_and_shrinks_more_with_more_iterations)
{
    // Smoothing is linear, so smooth(noisy) - smooth(clean) is the noise that survives.
    const TriangleMesh clean = icosphere(4);
    const TriangleMesh noisy = noisy_sphere();
    const double initial_noise = (noisy.V - clean.V).norm();
    double previous_noise = initial_noise;
    double previous_radius = test::mean_radius(noisy);
    for (const int iterations : {5, 10, 30, 50, 100})
    {
        const TriangleMesh smoothed = smooth_laplacian(noisy, {.iterations = iterations});
        const double noise =
            (smoothed.V - smooth_laplacian(clean, {.iterations = iterations}).V).norm();
        const double radius = test::mean_radius(smoothed);
        EXPECT_LT(noise, (iterations == 5 ? 0.7 : 1.0) * previous_noise) << iterations;
        EXPECT_LT(radius, previous_radius) << iterations << " iterations";
        previous_noise = noise;
        previous_radius = radius;
    }
    EXPECT_LT(previous_noise, 0.3 * initial_noise);
    EXPECT_LT(previous_radius, 0.99);
}

TEST(SmoothingTest, taubin_removes_noise_with_far_less_shrinkage_than_laplacian)
{
    const TriangleMesh mesh = noisy_sphere();
    const TriangleMesh taubin = smooth_taubin(mesh, {.iterations = 10});
    const TriangleMesh laplacian = smooth_laplacian(mesh, {.iterations = 20, .lambda = 0.5});
    EXPECT_LT(radial_spread(taubin), 0.5 * radial_spread(mesh));
    const double taubin_shrink = std::abs(1.0 - test::mean_radius(taubin));
    const double laplacian_shrink = std::abs(1.0 - test::mean_radius(laplacian));
    EXPECT_LT(taubin_shrink, 0.2 * laplacian_shrink);
}

TEST(SmoothingTest, result_is_bit_identical_for_any_thread_count)
{
    Rng rng(3);
    // 40962 vertices: above the size where smoothing goes parallel.
    const TriangleMesh mesh = add_noise(icosphere(6), {.amplitude = 0.005}, rng);
    const TriangleMesh one = smooth_laplacian(mesh, {.iterations = 7}, 1);
    EXPECT_TRUE(test::bit_identical(one, smooth_laplacian(mesh, {.iterations = 7}, 2)));
    EXPECT_TRUE(test::bit_identical(one, smooth_laplacian(mesh, {.iterations = 7}, 3)));
    const TriangleMesh taubin = smooth_taubin(mesh, {.iterations = 3}, 1);
    EXPECT_TRUE(test::bit_identical(taubin, smooth_taubin(mesh, {.iterations = 3}, 2)));
}

TEST(SmoothingTest, zero_iterations_and_unused_vertices_leave_positions_unchanged)
{
    const TriangleMesh mesh = test::with_unreferenced_vertex(noisy_sphere());
    EXPECT_TRUE(test::bit_identical(smooth_laplacian(mesh, {.iterations = 0}), mesh));
    const TriangleMesh smoothed = smooth_laplacian(mesh, {.iterations = 5});
    const Eigen::Index last = mesh.V.rows() - 1;
    EXPECT_EQ(smoothed.V.row(last), mesh.V.row(last));
}

TEST(SmoothingTest, point_clouds_and_bad_options_throw)
{
    const TriangleMesh cloud = test::point_cloud_of(icosphere(1));
    EXPECT_THROW((void)smooth_laplacian(cloud, {}), InvalidMesh);
    EXPECT_THROW((void)smooth_taubin(cloud, {}), InvalidMesh);
    const TriangleMesh mesh = icosphere(1);
    EXPECT_THROW((void)smooth_laplacian(mesh, {.iterations = -1}), InvalidOption);
    EXPECT_THROW((void)smooth_laplacian(mesh, {.lambda = 1.5}), InvalidOption);
    EXPECT_THROW((void)smooth_taubin(mesh, {.lambda = 0.6, .mu = -0.5}), InvalidOption);
    EXPECT_THROW((void)smooth_taubin(mesh, {.mu = 0.5}), InvalidOption);
}

}  // namespace meshmark
