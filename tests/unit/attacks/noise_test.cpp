// SPDX-License-Identifier: MIT
#include "meshmark/attacks/noise.h"

#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "attack_test_util.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/normals.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

// RMS of all coordinates of the displacement.
double rms_per_coordinate(const TriangleMesh& a, const TriangleMesh& b)
{
    return std::sqrt((a.V - b.V).squaredNorm() / static_cast<double>(a.V.size()));
}

}  // namespace

TEST(NoiseTest, uniform_isotropic_noise_has_the_amplitude_of_its_law)
{
    const TriangleMesh mesh = icosphere(5);  // 10242 vertices, 30726 coordinates
    const double a = 0.003 * bounding_box(mesh.V).diagonal();
    Rng rng(11);
    const TriangleMesh noisy = add_noise(mesh, {.amplitude = 0.003}, rng);
    EXPECT_EQ(noisy.F, mesh.F);
    // Uniform in [-a, a]: RMS a / sqrt(3), never beyond a, zero mean.
    EXPECT_NEAR(rms_per_coordinate(noisy, mesh), a / std::sqrt(3.0), 0.02 * a / std::sqrt(3.0));
    EXPECT_LE((noisy.V - mesh.V).cwiseAbs().maxCoeff(), a);
    EXPECT_NEAR((noisy.V - mesh.V).mean(), 0.0, 0.02 * a);
}

TEST(NoiseTest, gaussian_noise_rms_equals_the_amplitude)
{
    const TriangleMesh mesh = icosphere(5);
    const double a = 0.01 * bounding_box(mesh.V).diagonal();
    Rng rng(12);
    const TriangleMesh noisy =
        add_noise(mesh, {.amplitude = 0.01, .distribution = NoiseDistribution::Gaussian}, rng);
    EXPECT_NEAR(rms_per_coordinate(noisy, mesh), a, 0.02 * a);
    EXPECT_GT((noisy.V - mesh.V).cwiseAbs().maxCoeff(), 2.5 * a);  // tails a uniform law lacks
}

TEST(NoiseTest, normal_noise_moves_along_normals_and_centroid_reference_scales_it)
{
    const TriangleMesh mesh = icosphere(5);  // unit sphere: mean centroid distance 1
    const Positions normals = vertex_normals(mesh);
    Rng rng(13);
    const TriangleMesh noisy = add_noise(mesh,
                                         {.amplitude = 0.005,
                                          .direction = NoiseDirection::Normal,
                                          .reference = NoiseReference::CentroidDistance},
                                         rng);
    const Positions d = noisy.V - mesh.V;
    double sum_sq = 0.0;
    for (Eigen::Index i = 0; i < d.rows(); ++i)
    {
        EXPECT_LT(d.row(i).cross(normals.row(i)).norm(), 1e-12) << "vertex " << i;
        sum_sq += d.row(i).squaredNorm();
    }
    const double rms = std::sqrt(sum_sq / static_cast<double>(d.rows()));
    EXPECT_NEAR(rms, 0.005 / std::sqrt(3.0), 0.02 * 0.005 / std::sqrt(3.0));
}

TEST(NoiseTest, same_seed_is_bit_identical_for_any_thread_count_and_other_seeds_differ)
{
    const TriangleMesh mesh = icosphere(6);  // 40962 vertices: 11 blocks, run in parallel
    const NoiseOptions options{.amplitude = 0.001, .distribution = NoiseDistribution::Gaussian};
    Rng a(7);
    Rng b(7);
    Rng c(7);
    Rng d(8);
    const TriangleMesh one = add_noise(mesh, options, a, 1);
    EXPECT_TRUE(test::bit_identical(one, add_noise(mesh, options, b, 2)));
    EXPECT_TRUE(test::bit_identical(one, add_noise(mesh, options, c, 3)));
    EXPECT_FALSE(test::bit_identical(one, add_noise(mesh, options, d, 1)));
}

TEST(NoiseTest, point_clouds_take_isotropic_noise_but_not_normal_noise)
{
    const TriangleMesh cloud = test::point_cloud_of(icosphere(2));
    Rng rng(1);
    const TriangleMesh noisy = add_noise(cloud, {.amplitude = 0.01}, rng);
    EXPECT_GT((noisy.V - cloud.V).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_THROW((void)add_noise(cloud, {.direction = NoiseDirection::Normal}, rng), InvalidMesh);
    EXPECT_THROW((void)add_noise(cloud, {.amplitude = -0.1}, rng), InvalidOption);
}

}  // namespace meshmark
