// SPDX-License-Identifier: MIT
// Every attack of the suite, at its default level, on awkward geometry made from a real scan
// (the shared bunny.off, open at its base; tests/support/awkward_geometry.h). None may crash
// (the sanitizer job runs this file too): each attack either returns a mesh whose indices are
// in range and whose positions are finite, or refuses with meshmark::Error. Before the degenerate
// triangles were dropped ahead of CGAL, `remesh` on the collapsed part died with SIGSEGV in CGAL's
// tangential relaxation.
#include "support/awkward_geometry.h"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

// The suite's attacks at their default levels (`meshmark attack --help`).
const std::vector<std::string> kAttacks = {"similarity",
                                           "noise",
                                           "smooth",
                                           "taubin",
                                           "quantize",
                                           "simplify",
                                           "remesh",
                                           "subdivide",
                                           "subdivide=midpoint",
                                           "subdivide=sqrt3",
                                           "crop",
                                           "reorder",
                                           "voxel"};

TEST(AwkwardGeometryTest,
     every_attack_on_every_awkward_variant_of_a_real_scan_returns_a_mesh_or_refuses)
{
    const auto path = test::mesh_dir() / "bunny.off";
    if (!std::filesystem::exists(path))
    {
        GTEST_SKIP() << path << " is not available";
    }
    const TriangleMesh scan = read_mesh(path);
    int refused = 0;
    int ran = 0;
    for (const auto& [name, mesh] : test::awkward_variants(scan))
    {
        for (const std::string& attack : kAttacks)
        {
            SCOPED_TRACE(name + " " + attack);
            try
            {
                const AttackResult result = apply_attacks(mesh, parse_attack_spec(attack), 3);
                ++ran;
                EXPECT_TRUE(result.mesh.V.allFinite());
                if (result.mesh.F.rows() > 0)
                {
                    EXPECT_GE(result.mesh.F.minCoeff(), 0);
                    EXPECT_LT(result.mesh.F.maxCoeff(), result.mesh.V.rows());
                }
            }
            catch (const Error& e)
            {
                // A refusal is one sentence naming the attack (or the missing voxel plugin).
                ++refused;
                EXPECT_FALSE(std::string(e.what()).empty());
            }
        }
    }
    EXPECT_GT(ran, 100) << "refused " << refused;
}

TEST(AwkwardGeometryTest, a_triangle_soup_is_remeshed_as_the_surface_it_splits)
{
    // A file whose triangles each have corners of their own (coincident vertices) is the same
    // surface: remeshed to a quarter of its distinct vertices, as the scan itself is. Before the
    // weld, CGAL could not collapse a single edge of the soup and returned it unchanged (3 times
    // as many vertices as faces).
    const auto path = test::mesh_dir() / "bunny.off";
    if (!std::filesystem::exists(path))
    {
        GTEST_SKIP() << path << " is not available";
    }
    const TriangleMesh scan = read_mesh(path);
    TriangleMesh soup;
    for (const auto& [name, mesh] : test::awkward_variants(scan))
    {
        if (name == "soup")
        {
            soup = mesh;
        }
    }
    ASSERT_EQ(soup.V.rows(), 3 * scan.F.rows());
    const AttackResult whole = apply_attacks(scan, parse_attack_spec("remesh"), 3);
    const AttackResult split = apply_attacks(soup, parse_attack_spec("remesh"), 3);
    const auto count = static_cast<double>(whole.mesh.V.rows());
    EXPECT_NEAR(static_cast<double>(split.mesh.V.rows()), count, 0.1 * count);
    EXPECT_LT(split.mesh.V.rows(), split.mesh.F.rows());
}

}  // namespace
}  // namespace meshmark
