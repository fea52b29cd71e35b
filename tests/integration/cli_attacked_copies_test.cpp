// SPDX-License-Identifier: MIT
// The meshmark program on altered copies: reordered copies of a mirror-symmetric mesh, coarse
// remeshes, attacked copies (and the same attacks on the original), far copies not claimed.

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_test_support.h"
#include "process_util.h"
#include "support/cli_run.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

using test::CliRun;
using test::CliTest;
using test::run;
TEST_F(CliTest, reordered_copies_of_a_mirror_symmetric_mesh_are_found)
{
    // beetle.obj is left-right symmetric: for these keys the coarse registration used to keep
    // only mirrored starts, the copy registered as its mirror image and the mark was lost
    // (z -0.02, 2.85, 0.73). Seed 2 always worked.
    const fs::path beetle = test::mesh_dir() / "beetle.obj";
    if (!fs::exists(beetle))
    {
        GTEST_SKIP() << beetle << " is missing";
    }
    for (const char* seed : {"1", "2", "20", "22"})
    {
        const auto marked = dir_ / "beetle_marked.obj";
        const auto reordered = dir_ / "beetle_reordered.obj";
        const auto key = dir_ / "beetle.json";
        ASSERT_EQ(run("embed " + beetle.string() + " -o " + marked.string() + " --key " +
                          key.string() + " --seed " + seed + " --force",
                      dir_)
                      .exit_code,
                  0);
        ASSERT_EQ(run("attack " + marked.string() + " -o " + reordered.string() + " --seed " +
                          seed + " reorder",
                      dir_)
                      .exit_code,
                  0);
        const CliRun r = run("detect " + reordered.string() + " --original " + beetle.string() +
                                 " --key " + key.string() + " --json",
                             dir_);
        EXPECT_EQ(r.exit_code, 0) << "seed " << seed << ": " << r.out << r.err;
        const auto j = nlohmann::json::parse(r.out);
        // A proper pose: the reordered copy was not moved at all.
        EXPECT_GT(j["registration"]["transform"][0][0].get<double>(), 0.99)
            << "seed " << seed << ": " << r.out;
    }
}

TEST_F(CliTest, rows_far_from_a_coarsely_remeshed_copy_are_left_out)
{
    // decimated-max.obj (5.3K vertices) remeshed to 25%: about 5% of the original's rows lie
    // several mark amplitudes from the remeshed surface. Read with the others they swamped the
    // mark (z 3.4-4.1 for seeds 1-4); left out, it is claimed (z 5.7-6.3). The same remesh of
    // the unmarked mesh leaves rows out too and is not claimed, and which rows are left out
    // does not depend on the key.
    const fs::path mesh = test::mesh_dir() / "decimated-max.obj";
    if (!fs::exists(mesh))
    {
        GTEST_SKIP() << mesh << " is missing";
    }
    const auto marked = dir_ / "dm_marked.obj";
    const auto key = dir_ / "dm.json";
    const auto other_key = dir_ / "dm_other.json";
    const auto attacked = dir_ / "dm_remeshed.obj";
    const auto clean = dir_ / "dm_clean.obj";
    ASSERT_EQ(run("embed " + mesh.string() + " -o " + marked.string() + " --key " + key.string() +
                      " --seed 1",
                  dir_)
                  .exit_code,
              0);
    ASSERT_EQ(run("embed " + mesh.string() + " -o " + (dir_ / "dm_other.obj").string() + " --key " +
                      other_key.string() + " --seed 2",
                  dir_)
                  .exit_code,
              0);
    ASSERT_EQ(
        run("attack " + marked.string() + " -o " + attacked.string() + " --seed 1 remesh=0.25",
            dir_)
            .exit_code,
        0);
    ASSERT_EQ(
        run("attack " + mesh.string() + " -o " + clean.string() + " --seed 1 remesh=0.25", dir_)
            .exit_code,
        0);
    auto detect = [&](const fs::path& suspect, const fs::path& with_key)
    {
        const CliRun r = run("detect " + suspect.string() + " --original " + mesh.string() +
                                 " --key " + with_key.string() + " --json",
                             dir_);
        EXPECT_LE(r.exit_code, 1) << r.err;
        return nlohmann::json::parse(r.out);
    };
    const auto found = detect(attacked, key);
    EXPECT_TRUE(found["detected"].get<bool>()) << found.dump();
    EXPECT_GT(found["score"].get<double>(), 5.5);
    EXPECT_GT(found["outlier_fraction"].get<double>(), 0.02);
    EXPECT_LT(found["outlier_fraction"].get<double>(), 0.15);
    EXPECT_EQ(found["cropped_fraction"].get<double>(), 0.0);
    const auto unmarked = detect(clean, key);
    EXPECT_FALSE(unmarked["detected"].get<bool>()) << unmarked.dump();
    EXPECT_GT(unmarked["outlier_fraction"].get<double>(), 0.02);
    EXPECT_EQ(detect(clean, other_key)["outlier_fraction"], unmarked["outlier_fraction"]);
}

TEST_F(CliTest, a_coarse_remesh_is_read_against_the_original_surface)
{
    // dragon_vrip_res4.ply (5.2K vertices) remeshed to 5% keeps about 260 vertices: its
    // triangles cut under the original's curved surface by several mark amplitudes, and read
    // against the original's vertices the copy scored z 2.1-2.8 (bench seeds 1-4). Against the
    // original's surface laid under the same triangles it is claimed; the unmarked mesh
    // remeshed the same way is not.
    const fs::path mesh = test::mesh_dir() / "dragon_vrip_res4.ply";
    if (!fs::exists(mesh))
    {
        GTEST_SKIP() << mesh << " is missing";
    }
    const auto marked = dir_ / "dr_marked.ply";
    const auto key = dir_ / "dr.json";
    const auto attacked = dir_ / "dr_remeshed.ply";
    const auto clean = dir_ / "dr_clean.ply";
    ASSERT_EQ(run("embed " + mesh.string() + " -o " + marked.string() + " --key " + key.string() +
                      " --seed 1",
                  dir_)
                  .exit_code,
              0);
    ASSERT_EQ(
        run("attack " + marked.string() + " -o " + attacked.string() + " --seed 3 remesh=0.05",
            dir_)
            .exit_code,
        0);
    ASSERT_EQ(
        run("attack " + mesh.string() + " -o " + clean.string() + " --seed 3 remesh=0.05", dir_)
            .exit_code,
        0);
    auto detect = [&](const fs::path& suspect)
    {
        const CliRun r = run("detect " + suspect.string() + " --original " + mesh.string() +
                                 " --key " + key.string() + " --json",
                             dir_);
        EXPECT_LE(r.exit_code, 1) << r.err;
        return nlohmann::json::parse(r.out);
    };
    const auto found = detect(attacked);
    EXPECT_LT(found["suspect_vertices"].get<int>(), 400);
    EXPECT_TRUE(found["detected"].get<bool>()) << found.dump();
    EXPECT_GT(found["score"].get<double>(), 6.0);
    // Read both ways: the first reading alone was not conclusive.
    EXPECT_TRUE(found["seconds"].contains("match surface")) << found.dump();
    const auto unmarked = detect(clean);
    EXPECT_FALSE(unmarked["detected"].get<bool>()) << unmarked.dump();
    EXPECT_LT(unmarked["score"].get<double>(), 4.0);
    EXPECT_TRUE(unmarked["seconds"].contains("match surface"));
    // A clear copy (reordered: resampled at its own vertices) is claimed by the first reading
    // alone, paid for as if both were read: no second reading.
    const auto reordered = dir_ / "dr_reordered.ply";
    ASSERT_EQ(
        run("attack " + marked.string() + " -o " + reordered.string() + " --seed 3 reorder", dir_)
            .exit_code,
        0);
    const auto clear = detect(reordered);
    EXPECT_TRUE(clear["detected"].get<bool>()) << clear.dump();
    EXPECT_FALSE(clear["seconds"].contains("match surface")) << clear.dump();
}

TEST_F(CliTest, detects_attacked_copies_and_never_the_same_attacks_on_the_original)
{
    const auto marked = dir_ / "marked.ply";
    const auto key = dir_ / "key.json";
    // A fixed key: the pipeline is deterministic, so this test is too. (On this 10K-vertex mesh
    // the last chain is near the threshold for some keys, as docs/robustness.md reports for
    // small meshes; seed 4 reads R = 0.917 there.)
    ASSERT_EQ(run("embed " + original_.string() + " -o " + marked.string() + " --key " +
                      key.string() + " --seed 4",
                  dir_)
                  .exit_code,
              0);
    for (const char* spec :
         {"similarity", "similarity:axis=z:angle=90:scale=3:tx=100", "noise=0.001,smooth=10",
          "quantize=10,similarity", "reorder", "subdivide=loop", "simplify=0.25",
          "similarity,simplify=0.1,noise=0.001"})
    {
        const auto attacked = dir_ / "attacked.ply";
        ASSERT_EQ(
            run("attack " + marked.string() + " -o " + attacked.string() + " --seed 4 " + spec,
                dir_)
                .exit_code,
            0)
            << spec;
        const CliRun r = run("detect " + attacked.string() + " --original " + original_.string() +
                                 " --key " + key.string() + " --json",
                             dir_);
        EXPECT_EQ(r.exit_code, 0) << spec << ": " << r.err;
        // The same attack on the unmarked original is not claimed.
        const auto clean = dir_ / "clean.ply";
        ASSERT_EQ(
            run("attack " + original_.string() + " -o " + clean.string() + " --seed 4 " + spec,
                dir_)
                .exit_code,
            0);
        EXPECT_EQ(run("detect " + clean.string() + " --original " + original_.string() + " --key " +
                          key.string(),
                      dir_)
                      .exit_code,
                  1)
            << spec;
    }
}

TEST_F(CliTest, a_copy_far_from_the_original_that_is_not_claimed_gets_a_note)
{
    const auto marked = dir_ / "marked.ply";
    const auto key = dir_ / "key.json";
    ASSERT_EQ(run("embed " + original_.string() + " -o " + marked.string() + " --key " +
                      key.string() + " --seed 4",
                  dir_)
                  .exit_code,
              0);
    // A simplification to 31 vertices moves the surface by several times the mark (6.5x): not
    // claimed, and the note says why, with the distance in the mark's strengths.
    const auto coarse = dir_ / "coarse.ply";
    ASSERT_EQ(
        run("attack " + marked.string() + " -o " + coarse.string() + " --seed 4 simplify=0.003",
            dir_)
            .exit_code,
        0);
    CliRun r = run("detect " + coarse.string() + " --original " + original_.string() + " --key " +
                       key.string(),
                   dir_);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("times the mark's strength"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("What an attack leaves of the mark"), std::string::npos) << r.err;
    // --json reports the unit of that ratio: the key's strength (the default, 0.059%).
    r = run("detect " + coarse.string() + " --original " + original_.string() + " --key " +
                key.string() + " --json",
            dir_);
    const auto report = nlohmann::json::parse(r.out);
    EXPECT_NEAR(report.at("mark_strength").get<double>(), 0.00059, 1e-9);
    EXPECT_GE(report.at("registration").at("rms_error").get<double>(), 3.0 * 0.00059);
    // -q keeps stderr quiet; a claimed copy (registered too) gets no note.
    r = run("detect " + coarse.string() + " --original " + original_.string() + " --key " +
                key.string() + " -q",
            dir_);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(r.err, "");
    const auto fine = dir_ / "fine.ply";
    ASSERT_EQ(
        run("attack " + marked.string() + " -o " + fine.string() + " --seed 4 simplify=0.5", dir_)
            .exit_code,
        0);
    r = run(
        "detect " + fine.string() + " --original " + original_.string() + " --key " + key.string(),
        dir_);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.err.find("note:"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace meshmark
