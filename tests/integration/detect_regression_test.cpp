// SPDX-License-Identifier: MIT
// Behaviour unchanged (issue 51): the built `meshmark` program on a fixed corpus, compared
// exactly with saved expectations (tests/data/expectations/detect/<group>.json).
//
// Each group embeds a mesh with a fixed --seed, attacks the marked copy with fixed seeds
// (noise, crop, simplify, remesh, similarity, reorder, a mirrored copy, a copy split at seams,
// a copy of an animated asset in another pose, copies of a family key's recipients, a copy whose
// registration does not converge, a Draco-compressed and an instanced glTF) and runs
// `detect --json` on each (`--verdict bits` for a few). Every field of the JSON but `seconds`
// (scores, z, the false-positive probabilities, the verdict, the accused, the registration's
// method, RMS and transform, the bit counts...) must print exactly as saved, and so must the
// SHA-256 of every file embed and attack wrote and the exit code of detect. A failure names the
// group, the case and the field, with the saved and the found value.
//
// The basis runs its portable kernels (MESHMARK_BASIS_KERNEL=portable), so the figures do not
// depend on the processor's SIMD (src/basis/rbf_kernels.cpp). The "shared" group uses the shared
// meshes (MESHMARK_MESH_DIR or ../shared/data/meshes) and is skipped without them.
//
// Regenerating the expectations (only when a change of behaviour is intended, and said so in the
// commit): build the program, then
//     MESHMARK_UPDATE_EXPECTATIONS=1 ctest --test-dir build -L regression
// rewrites tests/data/expectations/detect/*.json in the source tree (docs/reliability.md).
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "detect_regression_support.h"
#include "gltf_test_support.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"
#include "support/test_shapes.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using namespace regression;  // detect_regression_support.h

// The marked copy's triangles on the side x > 0 get vertices of their own where they meet the
// other side, as a writer splits a mesh at its UV seams (Blender's PLY and OBJ writers).
TriangleMesh split_at_seam(const TriangleMesh& mesh)
{
    TriangleMesh out = mesh;
    const auto n = static_cast<std::size_t>(mesh.V.rows());
    std::vector<int> side(n, 0);  // bit 1: used by a face on x <= 0, bit 2: on x > 0
    std::vector<bool> right(static_cast<std::size_t>(mesh.F.rows()));
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const double x =
            mesh.V(mesh.F(f, 0), 0) + mesh.V(mesh.F(f, 1), 0) + mesh.V(mesh.F(f, 2), 0);
        right[static_cast<std::size_t>(f)] = x > 0.0;
        for (int c = 0; c < 3; ++c)
        {
            side[static_cast<std::size_t>(mesh.F(f, c))] |= x > 0.0 ? 2 : 1;
        }
    }
    std::vector<std::int32_t> copy(n, -1);
    std::vector<Eigen::Index> added;
    for (std::size_t v = 0; v < n; ++v)
    {
        if (side[v] == 3)
        {
            copy[v] = static_cast<std::int32_t>(n + added.size());
            added.push_back(static_cast<Eigen::Index>(v));
        }
    }
    out.V.conservativeResize(static_cast<Eigen::Index>(n + added.size()), 3);
    for (std::size_t k = 0; k < added.size(); ++k)
    {
        out.V.row(static_cast<Eigen::Index>(n + k)) = mesh.V.row(added[k]);
    }
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            const auto v = static_cast<std::size_t>(mesh.F(f, c));
            if (right[static_cast<std::size_t>(f)] && copy[v] >= 0)
            {
                out.F(f, c) = copy[v];
            }
        }
    }
    return out;
}

// A generated lumpy ellipsoid (2,562 vertices): the copies that keep the vertex order, the
// renumbered ones, the registered and resampled ones, a mirrored copy, a copy split at seams,
// and the unmarked original.
TEST(DetectRegression, generated_ellipsoid)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("ellipsoid");
    write_mesh(g.at("original.ply"), lumpy_ellipsoid(4));
    g.embed("marked", g.at("original.ply"), "marked.ply", "key.json", 101);
    g.detect("marked", "marked.ply", g.at("original.ply"), "key.json");
    g.detect("unmarked", "original.ply", g.at("original.ply"), "key.json");
    struct Attack
    {
        const char* label;
        const char* spec;
        std::uint64_t seed;
    };
    for (const Attack& a :
         {Attack{"noise", "noise=0.001", 1}, Attack{"reorder", "reorder", 2},
          Attack{"similarity_reorder", "similarity,reorder", 3},
          Attack{"simplify", "simplify=0.5", 4}, Attack{"crop", "crop=0.7", 5},
          Attack{"remesh", "remesh=0.25", 6}, Attack{"mirrored", "similarity:mirror=x", 7},
          Attack{"quantize", "quantize=9", 8},
          Attack{"smooth_similarity", "smooth=5,similarity", 9}})
    {
        const std::string file = std::string(a.label) + ".ply";
        g.attack("marked.ply", a.spec, a.seed, file);
        g.detect(a.label, file, g.at("original.ply"), "key.json");
    }
    // The unmarked original through the registration and resampling: not claimed.
    g.attack("original.ply", "similarity,simplify=0.5", 10, "unmarked_simplified.ply");
    g.detect("unmarked_simplified", "unmarked_simplified.ply", g.at("original.ply"), "key.json");
    write_mesh(g.at("seams.ply"), split_at_seam(read_mesh(g.at("marked.ply"))));
    g.detect("seams", "seams.ply", g.at("original.ply"), "key.json");
    g.finish();
}

// Generated assets whose detection takes the situational paths: a nearly mirror-symmetric
// vehicle (the poses of its symmetries under the union bound), a CAD plate whose vertices crowd
// on its outline (renumbered by its triangles' constraints), and a rigged arm that bends (a copy
// in the pose Blender shows is read through the animation's frame).
TEST(DetectRegression, generated_assets)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("assets");
    write_mesh(g.at("vehicle.ply"), test::vehicle(true));
    g.embed("vehicle", g.at("vehicle.ply"), "vehicle_marked.ply", "vehicle_key.json", 202);
    g.attack("vehicle_marked.ply", "similarity:mirror=x", 1, "vehicle_mirrored.ply");
    g.detect("vehicle_mirrored", "vehicle_mirrored.ply", g.at("vehicle.ply"), "vehicle_key.json");
    g.attack("vehicle_marked.ply", "similarity,reorder", 2, "vehicle_moved.ply");
    g.detect("vehicle_moved", "vehicle_moved.ply", g.at("vehicle.ply"), "vehicle_key.json");
    g.attack("vehicle_marked.ply", "similarity:mirror=y,reorder", 3,
             "vehicle_mirrored_reordered.ply");
    g.detect("vehicle_mirrored_reordered", "vehicle_mirrored_reordered.ply", g.at("vehicle.ply"),
             "vehicle_key.json");

    write_mesh(g.at("plate.ply"), test::outline_plate());
    g.embed("plate", g.at("plate.ply"), "plate_marked.ply", "plate_key.json", 303);
    g.attack("plate_marked.ply", "reorder", 4, "plate_reordered.ply");
    g.detect("plate_reordered", "plate_reordered.ply", g.at("plate.ply"), "plate_key.json");

    // The arm (test::BendingArm over a long lumpy ellipsoid), and the marked copy as Blender
    // shows it after import (the first animation at frame 1), its vertices in reverse order.
    TriangleMesh shape = lumpy_ellipsoid(4);
    shape.V.col(0) *= 2.0;
    std::vector<float> xyz;
    std::vector<std::uint16_t> idx;
    for (Eigen::Index v = 0; v < shape.V.rows(); ++v)
    {
        for (int c = 0; c < 3; ++c)
        {
            xyz.push_back(static_cast<float>(shape.V(v, c)));
        }
    }
    for (Eigen::Index f = 0; f < shape.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            idx.push_back(static_cast<std::uint16_t>(shape.F(f, c)));
        }
    }
    const test::BendingArm arm;
    test::put_bytes(g.at("arm.glb"), arm.glb(xyz, idx));
    g.embed("arm", g.at("arm.glb"), "arm_marked.glb", "arm_key.json", 404);
    const TriangleMesh stored = read_mesh(g.at("arm_marked.glb"));
    const Eigen::Index n = stored.V.rows();
    TriangleMesh posed;
    posed.V.resize(n, 3);
    for (Eigen::Index v = 0; v < n; ++v)
    {
        posed.V.row(n - 1 - v) =
            arm.shown(stored.V.row(v).transpose(), arm.weight(xyz[static_cast<std::size_t>(3 * v)]))
                .transpose();
    }
    posed.F = (n - 1) - stored.F.array();
    write_mesh(g.at("arm_posed.ply"), posed);
    g.detect("arm_posed", "arm_posed.ply", g.at("arm.glb"), "arm_key.json");
    g.finish();
}

// A family key with three recipients: bob's copy as issued, with noise, simplified and cropped
// (traced to bob), and the owner's unmarked original.
TEST(DetectRegression, family_key)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("family");
    write_mesh(g.at("original.ply"), lumpy_ellipsoid(4));
    g.embed("family", g.at("original.ply"), "copy_{recipient}.ply", "family.json", 505,
            "--recipient alice --recipient bob --recipient carol",
            {"copy_alice.ply", "copy_bob.ply", "copy_carol.ply", "family.json"});
    g.detect("bob", "copy_bob.ply", g.at("original.ply"), "family.json");
    g.attack("copy_bob.ply", "noise=0.001", 1, "bob_noise.ply");
    g.detect("bob_noise", "bob_noise.ply", g.at("original.ply"), "family.json");
    g.attack("copy_bob.ply", "similarity,simplify=0.5", 2, "bob_simplified.ply");
    g.detect("bob_simplified", "bob_simplified.ply", g.at("original.ply"), "family.json");
    g.attack("copy_bob.ply", "crop=0.7", 3, "bob_cropped.ply");
    g.detect("bob_cropped", "bob_cropped.ply", g.at("original.ply"), "family.json");
    g.detect("unmarked", "original.ply", g.at("original.ply"), "family.json");
    g.finish();
}

// Real meshes (skipped without the shared folder): a scan, a CAD part and a symmetric teapot.
TEST(DetectRegression, shared_meshes)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    const fs::path meshes = test::mesh_dir();
    for (const char* name : {"bunny.off", "fandisk.obj", "teapot.obj"})
    {
        if (!fs::exists(meshes / name))
        {
            GTEST_SKIP() << "no shared meshes in " << meshes << " (" << name << ")";
        }
    }
    Group g("shared");
    struct Attack
    {
        const char* label;
        const char* spec;
        std::uint64_t seed;
    };
    const auto mesh_cases = [&](const char* name, const char* stem, std::uint64_t seed,
                                std::initializer_list<Attack> attacks)
    {
        const fs::path original = meshes / name;
        const std::string ext = fs::path(name).extension().string();
        const std::string marked = std::string(stem) + "_marked" + ext;
        const std::string key = std::string(stem) + "_key.json";
        g.embed(stem, original, marked, key, seed);
        for (const Attack& a : attacks)
        {
            const std::string file = std::string(stem) + "_" + a.label + ".ply";
            g.attack(marked, a.spec, a.seed, file);
            g.detect(std::string(stem) + "_" + a.label, file, original, key);
        }
    };
    mesh_cases(
        "bunny.off", "bunny", 606,
        {Attack{"noise", "noise=0.002", 1}, Attack{"similarity_reorder", "similarity,reorder", 2},
         Attack{"simplify", "similarity,simplify=0.3", 3}, Attack{"crop", "crop=0.5", 4}});
    mesh_cases("fandisk.obj", "fandisk", 707,
               {Attack{"crop", "crop=0.5", 5}, Attack{"remesh", "remesh=0.25", 6}});
    mesh_cases("teapot.obj", "teapot", 808, {Attack{"mirrored", "similarity:mirror=y", 7}});
    g.finish();
}

}  // namespace
}  // namespace meshmark
