// SPDX-License-Identifier: MIT
// The speed target of the module on the 437K-vertex dragon (label `slow`; skipped when the
// shared meshes are missing).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/rng.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/registration/registration.h"
#include "meshmark/registration/resampling.h"
#include "perturbations.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

// The dragon against itself, moved (and, second, mirrored and cropped to half); prints the
// timings quoted in docs/algorithms/registration.md.
TEST(DragonRegistrationTest, registers_and_resamples_the_dragon)
{
    const auto path = test::mesh_dir() / "dragon_vrip.ply";
    if (!std::filesystem::exists(path))
    {
        GTEST_SKIP() << "missing " << path;
    }
    const TriangleMesh reference = read_mesh(path);
    const double D = bounding_box(reference.V).diagonal();
    Rng rng(32);
    const test::Cropped cropped =
        test::crop_by_plane(reference, Eigen::Vector3d(0.6, 0.0, 0.8), 0.5);
    for (const bool is_cropped : {false, true})
    {
        const TriangleMesh& base = is_cropped ? cropped.mesh : reference;
        TriangleMesh suspect = base;
        suspect.V = test::apply(test::random_similarity(rng, is_cropped), base.V);
        using Clock = std::chrono::steady_clock;
        const auto t0 = Clock::now();
        const RegistrationResult result = register_to_reference(suspect, reference);
        const auto t1 = Clock::now();
        const Resampling r = resample(reference, suspect, result.transform);
        const auto t2 = Clock::now();
        const double register_s = std::chrono::duration<double>(t1 - t0).count();
        const double resample_s = std::chrono::duration<double>(t2 - t1).count();
        std::printf("dragon %s: register %.3f s, resample %.3f s, candidates %d, cropped %.3f\n",
                    is_cropped ? "cropped+mirrored" : "moved", register_s, resample_s,
                    result.candidates, r.cropped_fraction);
        RecordProperty(is_cropped ? "cropped_seconds" : "moved_seconds",
                       std::to_string(register_s + resample_s));
        EXPECT_TRUE(result.converged);
        EXPECT_EQ(result.is_reflection, is_cropped);
        EXPECT_LT(test::rms_distance(transform_points(result.transform, suspect.V), base.V),
                  1e-9 * D);
        if (is_cropped)
        {
            EXPECT_GT(r.cropped_fraction, 0.45);
            EXPECT_LE(r.cropped_fraction, 0.5);
        }
        else
        {
            EXPECT_EQ(r.cropped_fraction, 0.0);
        }
    }
}

}  // namespace
}  // namespace meshmark
