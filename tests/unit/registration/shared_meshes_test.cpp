// SPDX-License-Identifier: MIT
// Registration and resampling on the real shared meshes (skipped when the folder is missing).
#include <gtest/gtest.h>

#include <algorithm>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/rng.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/registration/registration.h"
#include "meshmark/registration/resampling.h"
#include "perturbations.h"
#include "support/test_paths.h"

namespace meshmark {
namespace {

TEST(SharedMeshRegistrationTest, recovers_similarities_of_small_real_meshes)
{
    const auto paths = test::shared_meshes_up_to(4000);
    if (paths.empty())
    {
        GTEST_SKIP() << "no shared meshes in " << test::mesh_dir();
    }
    Rng rng(31);
    for (const auto& path : paths)
    {
        const TriangleMesh reference = read_mesh(path);
        const double D = bounding_box(reference.V).diagonal();
        const Eigen::Matrix4d T = test::random_similarity(rng, false);
        TriangleMesh suspect = reference;
        suspect.V = test::apply(T, reference.V);
        const RegistrationResult result = register_to_reference(suspect, reference);
        EXPECT_TRUE(result.converged) << path.filename();
        const std::vector<std::int32_t> used = referenced_vertices(reference);
        double worst = 0.0;
        const Positions back = transform_points(result.transform, suspect.V);
        for (const std::int32_t i : used)
        {
            worst = std::max(worst, (back.row(i) - reference.V.row(i)).norm());
        }
        EXPECT_LT(worst, 1e-8 * D) << path.filename();
        const Resampling r = resample(reference, suspect, result.transform);
        EXPECT_EQ(r.cropped_fraction, 0.0) << path.filename();
    }
}

}  // namespace
}  // namespace meshmark
