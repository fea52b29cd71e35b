// SPDX-License-Identifier: MIT
// The meshmark program as users and scripts see it: exit codes, --json, messages, no partial files.
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <sys/wait.h>

#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "process_util.h"
#include "support/cli_run.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

using test::CliRun;
using test::slurp;

CliRun run(const std::string& arguments, const fs::path& dir)
{
    return test::run_cli(arguments, dir);
}

class CliTest : public ::testing::Test
{
protected:
    void SetUp() override
    {
        if (test::cli_path().empty())
        {
            GTEST_SKIP() << "the CLI is not built";
        }
        dir_ = test::temp_dir(::testing::UnitTest::GetInstance()->current_test_info()->name());
        original_ = dir_ / "original.ply";
        write_mesh(original_, lumpy_ellipsoid(5));
    }
    fs::path dir_;
    fs::path original_;
};

TEST_F(CliTest, embed_then_detect_reports_json_and_exit_codes)
{
    const auto marked = dir_ / "marked.ply";
    const auto key = dir_ / "key.json";
    CliRun r = run("embed " + original_.string() + " -o " + marked.string() + " --key " +
                       key.string() + " --message hello --seed 12 --json",
                   dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto embed_json = nlohmann::json::parse(r.out);
    EXPECT_GT(embed_json["rms_displacement"].get<double>(), 0.0);
    // 120 coefficients by default from 5,000 vertices on (this mesh: 10,242).
    EXPECT_EQ(nlohmann::json::parse(slurp(key))["embedding"]["repetitions"], 5);
    EXPECT_TRUE(embed_json["seconds"].contains("total"));
    struct stat st
    {
    };
    ASSERT_EQ(::stat(key.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777U, 0600U);

    r = run("detect " + marked.string() + " --original " + original_.string() + " --key " +
                key.string() + " --json",
            dir_);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_TRUE(j["detected"].get<bool>());
    EXPECT_DOUBLE_EQ(j["correlation"].get<double>(), 1.0);
    EXPECT_EQ(j["bits_expected"].get<std::string>(), j["bits_found"].get<std::string>());
    for (const char* field : {"false_positive_probability", "cropped_fraction", "outlier_fraction",
                              "registration", "seconds"})
    {
        EXPECT_TRUE(j.contains(field)) << field;
    }
    EXPECT_EQ(j["registration"]["transform"].size(), 4U);
    EXPECT_TRUE(j["registration"].contains("rms_error"));

    r = run("detect " + original_.string() + " --original " + original_.string() + " --key " +
                key.string() + " --json",
            dir_);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_FALSE(nlohmann::json::parse(r.out)["detected"].get<bool>());
}

TEST_F(CliTest, recipient_copies_are_issued_in_any_format_and_traced)
{
    const auto key = dir_ / "family.json";
    const auto names = dir_ / "names.txt";
    {
        std::ofstream out(names);
        out << "# buyers\nalice\n  Studio B  \n\ncarol\n";
    }
    const std::string pattern = (dir_ / "copy-{recipient}.glb").string();
    CliRun r = run("embed " + original_.string() + " -o '" + pattern + "' --key " + key.string() +
                       " --recipients " + names.string() + " --recipient dave --seed 3 --json",
                   dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto issued = nlohmann::json::parse(r.out);
    ASSERT_EQ(issued["copies"].size(), 4U);
    EXPECT_EQ(issued["recipients_in_key"], 4);
    EXPECT_EQ(issued["copies"][2]["name"], "Studio B");  // --recipient names first, then the file's
    EXPECT_TRUE(fs::exists(dir_ / "copy-Studio B.glb"));
    // The owner's mark of a new family key takes 2 repetitions unless asked (its code modes
    // follow it in the basis of 100); --repetitions given is kept.
    EXPECT_EQ(nlohmann::json::parse(slurp(key))["embedding"]["repetitions"], 2);
    r = run("embed " + original_.string() + " -o '" + (dir_ / "r3-{recipient}.ply").string() +
                "' --key " + (dir_ / "r3.json").string() +
                " --recipient x --repetitions 3 --recipient-modes 40 -q",
            dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(slurp(dir_ / "r3.json"))["embedding"]["repetitions"], 3);

    r = run("detect '" + (dir_ / "copy-Studio B.glb").string() + "' --original " +
                original_.string() + " --key " + key.string() + " --json",
            dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    auto found = nlohmann::json::parse(r.out);
    EXPECT_TRUE(found["detected"].get<bool>());
    EXPECT_TRUE(found["owner_detected"].get<bool>());
    EXPECT_LE(found["owner_false_positive_probability"].get<double>(), 1e-6);
    EXPECT_EQ(found["recipients_traced"], 4);
    ASSERT_EQ(found["recipients"].size(), 1U);
    EXPECT_EQ(found["recipients"][0]["name"], "Studio B");
    EXPECT_LE(found["recipients"][0]["false_positive_probability"].get<double>(), 1e-6);
    // One verdict: the top-level probability is the accusation's (not the owner's mark alone's,
    // which is under owner_mark), and the headline says the same.
    EXPECT_EQ(found["false_positive_probability"],
              found["recipients"][0]["false_positive_probability"]);
    EXPECT_TRUE(found["owner_mark"].contains("score"));
    EXPECT_LT(found["owner_mark"]["false_positive_probability"].get<double>(), 1.0);
    EXPECT_EQ(found["headline"].get<std::string>().rfind(
                  "Claimed: a copy of the original, made from the copy issued "
                  "to Studio B. ",
                  0),
              0U)
        << found["headline"];
    // The text report names the accused with both readings (the regions' may be what accuses).
    r = run("detect '" + (dir_ / "copy-Studio B.glb").string() + "' --original " +
                original_.string() + " --key " + key.string(),
            dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find("1 of 4 recipients accused:\n    Studio B: z = "), std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find(": " + found["headline"].get<std::string>() + "\n"), std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find(", regions z = "), std::string::npos) << r.out;

    // The unmarked original accuses nobody (exit 1); the text report says so.
    r = run("detect " + original_.string() + " --original " + original_.string() + " --key " +
                key.string(),
            dir_);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.out.find("0 of 4 recipients accused"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("ownership not shown"), std::string::npos) << r.out;
    r = run("detect " + original_.string() + " --original " + original_.string() + " --key " +
                key.string() + " --json",
            dir_);
    const auto unmarked = nlohmann::json::parse(r.out);
    EXPECT_FALSE(unmarked["detected"].get<bool>());
    EXPECT_EQ(unmarked["headline"].get<std::string>().rfind("Not shown: ", 0), 0U)
        << unmarked["headline"];
    EXPECT_EQ(unmarked["false_positive_probability"], unmarked["owner_false_positive_probability"]);
    EXPECT_FALSE(unmarked["owner_detected"].get<bool>());
    EXPECT_GT(unmarked["owner_false_positive_probability"].get<double>(), 1e-6);

    // A later call re-issues a name byte for byte and adds a new one.
    const std::string before = slurp(dir_ / "copy-alice.glb");
    r = run("embed " + original_.string() + " -o '" + (dir_ / "again-{recipient}.glb").string() +
                "' --key " + key.string() + " --recipient alice --recipient erin -q",
            dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(before == slurp(dir_ / "again-alice.glb"));
    EXPECT_EQ(nlohmann::json::parse(slurp(key))["recipients"]["issued"].size(), 5U);

    // Refusals: one sentence, no file.
    r = run("embed " + original_.string() + " -o " + (dir_ / "one.ply").string() + " --key " +
                (dir_ / "k2.json").string() + " --recipient x",
            dir_);
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.err.find("{recipient}"), std::string::npos) << r.err;
    r = run("embed " + original_.string() + " -o '" + pattern + "' --key " +
                (dir_ / "k3.json").string() + " --recipient x --stream",
            dir_);
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.err.find("--stream"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "copy-x.glb"));
    EXPECT_FALSE(fs::exists(dir_ / "k2.json"));
    EXPECT_FALSE(fs::exists(dir_ / "k3.json"));
}

TEST_F(CliTest, memory_budget_streams_a_binary_ply_to_the_same_bytes)
{
    const auto memory = dir_ / "memory.ply";
    const auto streamed = dir_ / "streamed.ply";
    // The same bytes for the vertex measure; the surface measure is applied out of core as its
    // vertex equivalent, with a note (below).
    const std::string common = " --message hello --seed 12 --json --strength-measure vertex";
    CliRun r = run("embed " + original_.string() + " -o " + memory.string() + " --key " +
                       (dir_ / "memory.json").string() + common,
                   dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_FALSE(nlohmann::json::parse(r.out)["streamed"].get<bool>());
    r = run("embed " + original_.string() + " -o " + streamed.string() + " --key " +
                (dir_ / "streamed.json").string() + common + " --memory-budget 1",
            dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_TRUE(j["streamed"].get<bool>());
    for (const char* phase : {"scan", "frame", "basis", "write", "total"})
    {
        EXPECT_TRUE(j["seconds"].contains(phase)) << phase;
    }
    EXPECT_TRUE(slurp(memory) == slurp(streamed));
    EXPECT_EQ(slurp(dir_ / "memory.json"), slurp(dir_ / "streamed.json"));
    r = run("detect " + streamed.string() + " --original " + original_.string() + " --key " +
                (dir_ / "streamed.json").string(),
            dir_);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    r = run("embed " + original_.string() + " -o " + (dir_ / "surface.ply").string() + " --key " +
                (dir_ / "surface.json").string() + " --memory-budget 1",
            dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(
        r.err.find("note: out of core, the strength is applied as an RMS vertex displacement"),
        std::string::npos)
        << r.err;
    EXPECT_NE(slurp(dir_ / "surface.json").find("\"strength_measure\": \"vertex\""),
              std::string::npos);

    // An ASCII PLY: embedded in memory with a note under a budget, a usage error with --stream.
    const auto ascii = dir_ / "ascii.ply";
    WriteOptions text;
    text.is_binary = false;
    write_mesh(ascii, lumpy_ellipsoid(4), text);
    r = run("embed " + ascii.string() + " -o " + (dir_ / "a.ply").string() + " --key " +
                (dir_ / "a.json").string() + common + " --memory-budget 1",
            dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_FALSE(nlohmann::json::parse(r.out)["streamed"].get<bool>());
    EXPECT_NE(r.err.find("cannot be streamed"), std::string::npos) << r.err;
    r = run("embed " + ascii.string() + " -o " + (dir_ / "b.ply").string() + " --key " +
                (dir_ / "b.json").string() + common + " --stream",
            dir_);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("ASCII"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "b.ply"));
    EXPECT_FALSE(fs::exists(dir_ / "b.json"));
}

// --repetitions takes "auto" (the default; the key records the number chosen) or a whole
// number >= 1; anything else is a usage error that names the option, before any work.
TEST_F(CliTest, repetitions_are_auto_or_a_positive_number)
{
    const auto out = dir_ / "r.ply";
    const auto key = dir_ / "r.json";
    const std::string head =
        "embed " + original_.string() + " -o " + out.string() + " --key " + key.string();
    CliRun r = run(head + " --repetitions auto -q", dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(slurp(key))["embedding"]["repetitions"],
              5);  // 10,242 vertices: 5
    for (const char* bad : {"0", "-2", "x", "2.5"})
    {
        r = run(head + " --force --repetitions " + bad, dir_);
        EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.err;
        EXPECT_NE(r.err.find("--repetitions"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("must be auto or a whole number"), std::string::npos) << r.err;
    }
    r = run("embed --help", dir_);
    EXPECT_NE(r.out.find("auto|INT"), std::string::npos) << r.out;
}

TEST_F(CliTest, help_texts_are_short_and_undated)
{
    // --help gives one or two lines per option; the detail lives in docs/cli.md (issue 51).
    for (const char* command :
         {"", "demo", "embed", "detect", "attack", "compare", "catalog", "catalog add",
          "catalog list", "catalog issue", "catalog scan", "catalog export", "serve", "bench",
          "bench speed", "bench robustness", "bench approximation"})
    {
        const CliRun r = run(std::string(command) + " --help", dir_);
        ASSERT_EQ(r.exit_code, 0) << command << ": " << r.err;
        std::istringstream lines(r.out);
        for (std::string line; std::getline(lines, line);)
        {
            EXPECT_LE(line.size(), 160U) << "meshmark " << command << " --help: " << line;
        }
        EXPECT_EQ(r.out.find("2026-"), std::string::npos)
            << "meshmark " << command << " --help names a date";
    }
}

TEST_F(CliTest, streaming_refuses_the_laplacian_basis_and_decimated_centers)
{
    // The streamed passes build the RBF basis with random centers only: --stream is a usage
    // error naming the reason, a budget falls back to the in-memory embed with a note.
    for (const char* option : {" --basis laplacian", " --centers decimate"})
    {
        const auto out = dir_ / "s.ply";
        const auto key = dir_ / "s.json";
        CliRun r = run("embed " + original_.string() + " -o " + out.string() + " --key " +
                           key.string() + option + " --stream",
                       dir_);
        EXPECT_EQ(r.exit_code, 2) << option << ": " << r.err;
        EXPECT_NE(r.err.find("in memory"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(out));
        EXPECT_FALSE(fs::exists(key));
        r = run("embed " + original_.string() + " -o " + out.string() + " --key " + key.string() +
                    option + " --memory-budget 1 --json",
                dir_);
        ASSERT_EQ(r.exit_code, 0) << option << ": " << r.err;
        EXPECT_FALSE(nlohmann::json::parse(r.out)["streamed"].get<bool>()) << option;
        EXPECT_NE(r.err.find("cannot be streamed"), std::string::npos) << r.err;
        fs::remove(out);
        fs::remove(key);
    }
}

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

TEST_F(CliTest, watermarks_a_point_cloud_and_keeps_it_a_point_cloud)
{
    TriangleMesh cloud = lumpy_ellipsoid(5);
    cloud.F.resize(0, 3);
    const auto input = dir_ / "scan.ply";
    write_mesh(input, cloud);
    const auto marked = dir_ / "scan_marked.ply";
    const auto key = dir_ / "key.json";
    ASSERT_EQ(
        run("embed " + input.string() + " -o " + marked.string() + " --key " + key.string(), dir_)
            .exit_code,
        0);
    const TriangleMesh back = read_mesh(marked);
    EXPECT_EQ(back.F.rows(), 0);
    EXPECT_EQ(back.V.rows(), cloud.V.rows());
    EXPECT_EQ(run("detect " + marked.string() + " --original " + input.string() + " --key " +
                      key.string(),
                  dir_)
                  .exit_code,
              0);
    EXPECT_EQ(
        run("detect " + input.string() + " --original " + input.string() + " --key " + key.string(),
            dir_)
            .exit_code,
        1);
}

TEST_F(CliTest, never_overwrites_the_input_or_an_existing_key)
{
    const std::string before = slurp(original_);
    CliRun r = run("embed " + original_.string() + " -o " + original_.string() + " --key " +
                       (dir_ / "k.json").string(),
                   dir_);
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find("input"), std::string::npos) << r.err;
    EXPECT_EQ(slurp(original_), before);
    EXPECT_FALSE(fs::exists(dir_ / "k.json"));

    const auto key = dir_ / "key.json";
    ASSERT_EQ(run("embed " + original_.string() + " -o " + (dir_ / "a.ply").string() + " --key " +
                      key.string(),
                  dir_)
                  .exit_code,
              0);
    const std::string key_text = slurp(key);
    r = run("embed " + original_.string() + " -o " + (dir_ / "b.ply").string() + " --key " +
                key.string(),
            dir_);
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(slurp(key), key_text);
    EXPECT_FALSE(fs::exists(dir_ / "b.ply"));
}

// -o INPUT --force replaces the input with its marked copy, which keeps the input's permissions.
TEST_F(CliTest, embedding_in_place_keeps_the_input_permissions)
{
    const auto input = dir_ / "in_place.ply";
    fs::copy_file(original_, input);
    const auto mode =
        fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read;  // 0640
    fs::permissions(input, mode);
    const std::string before = slurp(input);
    const CliRun r = run("embed " + input.string() + " -o " + input.string() + " --key " +
                             (dir_ / "ip.json").string() + " --force",
                         dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(slurp(input), before);
    EXPECT_EQ(fs::status(input).permissions(), mode);
}

// Each bad input: one clear sentence naming the file, the right exit code, no output file.
struct BadInput
{
    const char* name;
    const char* content;  // written to dir/<file>
    const char* file;
    int exit_code;
    const char* expected_words;
};

TEST_F(CliTest, bad_inputs_fail_cleanly_without_output)
{
    std::string line_ply =
        "ply\nformat ascii 1.0\nelement vertex 200\nproperty float x\nproperty float y\n"
        "property float z\nend_header\n";
    for (int i = 0; i < 200; ++i)
    {
        line_ply += std::to_string(i) + " " + std::to_string(2 * i) + " 0\n";
    }
    const BadInput cases[] = {
        {"truncated binary",
         "ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\n"
         "property float y\nproperty float z\nend_header\n\x01\x02",
         "truncated.ply", 3, "truncated.ply"},
        {"malformed header", "ply\nformat ascii 1.0\nelement vertex three\nend_header\n",
         "header.ply", 3, "header.ply"},
        {"nan coordinate", "OFF\n3 1 0\n0 0 0\nnan 1 0\n0 1 1\n3 0 1 2\n", "nan.off", 3, "nan.off"},
        {"index out of range", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "index.obj", 3, "index.obj"},
        {"too few vertices", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 2 3\n",
         "tiny.off", 3, "basis"},
        {"collinear vertices", line_ply.c_str(), "line.ply", 4, "collinear"},
        {"unknown extension", "whatever", "mesh.xyz", 3, "mesh.xyz"},
    };
    for (const auto& c : cases)
    {
        const auto input = dir_ / c.file;
        std::ofstream(input, std::ios::binary) << c.content;
        const auto output = dir_ / (std::string("out_") + c.file + ".ply");
        const auto key = dir_ / (std::string("key_") + c.file + ".json");
        const CliRun r = run(
            "embed " + input.string() + " -o " + output.string() + " --key " + key.string(), dir_);
        EXPECT_EQ(r.exit_code, c.exit_code) << c.name << ": " << r.err;
        EXPECT_NE(r.err.find(c.expected_words), std::string::npos) << c.name << ": " << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.name << ": " << r.err;
        EXPECT_FALSE(fs::exists(output)) << c.name;
        EXPECT_FALSE(fs::exists(key)) << c.name;
    }
    // Missing input and unknown output extension.
    CliRun r = run("embed " + (dir_ / "missing.ply").string() + " -o " + (dir_ / "o.ply").string() +
                       " --key " + (dir_ / "k.json").string(),
                   dir_);
    EXPECT_GE(r.exit_code, 2);
    EXPECT_NE(r.err.find("missing.ply"), std::string::npos) << r.err;
    r = run("embed " + original_.string() + " -o " + (dir_ / "o.abc").string() + " --key " +
                (dir_ / "k.json").string(),
            dir_);
    EXPECT_EQ(r.exit_code, 3) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "o.abc"));
    EXPECT_FALSE(fs::exists(dir_ / "k.json"));
}

TEST_F(CliTest, gram_rows_is_recorded_and_bad_values_are_usage_errors)
{
    const auto output = dir_ / "out.ply";
    const auto key = dir_ / "key.json";
    const std::string files =
        "embed " + original_.string() + " -o " + output.string() + " --key " + key.string();
    // A 2000-row sample of the 10242 vertices: recorded in the key, and detection rebuilds it.
    CliRun r = run(files + " --seed 9 --gram-rows 2000 --json", dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(slurp(key).find("\"gram_rows\": 2000"), std::string::npos) << slurp(key);
    const auto report = nlohmann::json::parse(r.out);
    EXPECT_GT(report["orthogonality_error"].get<double>(), 1e-9);
    r = run("detect " + output.string() + " --original " + original_.string() + " --key " +
                key.string(),
            dir_);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    fs::remove(output);
    fs::remove(key);
    const std::pair<const char*, const char*> bad[] = {
        {"-3", "--gram-rows: must be a number, 0 or more, got -3"},
        {"5", "at least 16 times the basis size (1600), got 5"},
    };
    for (const auto& [value, message] : bad)
    {
        r = run(files + " --gram-rows " + value, dir_);
        EXPECT_EQ(r.exit_code, 2) << value << ": " << r.err;
        EXPECT_NE(r.err.find(message), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(output));
        EXPECT_FALSE(fs::exists(key));
    }
}

// `bench speed` with every check of issue 5 on a generated 100K-vertex mesh: the copy is found
// through the registration path (a reordered copy of this mesh was missed before the least
// squares of the extraction scaled its columns: 6 of 24 bits), the streamed embed and the
// 1-thread embed give the in-memory output byte for byte, and the exit code says so.
TEST_F(CliTest, bench_speed_detects_a_reordered_copy_and_checks_streaming_and_threads)
{
    const CliRun r =
        run("bench speed --no-shared --sizes 100000 --attack reorder --out-of-core 16 "
            "--compare-threads --threads 2 --json -q --work-dir " +
                (dir_ / "work").string(),
            dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
    const auto report = nlohmann::json::parse(r.out);
    ASSERT_EQ(report["runs"].size(), 1U);
    const auto& run = report["runs"][0];
    EXPECT_EQ(run["vertices"].get<std::int64_t>(), 100000);
    EXPECT_EQ(run["detect_attack"].get<std::string>(), "reorder");
    EXPECT_TRUE(run["detected"].get<bool>());
    EXPECT_GT(run["correlation"].get<double>(), 0.99);
    EXPECT_TRUE(run["stream_identical"].get<bool>());
    EXPECT_LT(run["stream_peak_mib"].get<double>(), run["embed_peak_mib"].get<double>());
    EXPECT_TRUE(run["one_thread_identical"].get<bool>());
    EXPECT_GT(run["one_thread_seconds"]["total"].get<double>(), 0.0);
}

TEST_F(CliTest, detect_rejects_corrupt_keys_wrong_originals_and_mismatched_suspects)
{
    const auto marked = dir_ / "marked.ply";
    const auto key = dir_ / "key.json";
    ASSERT_EQ(
        run("embed " + original_.string() + " -o " + marked.string() + " --key " + key.string(),
            dir_)
            .exit_code,
        0);
    const std::string text = slurp(key);
    const auto truncated = dir_ / "truncated.json";
    std::ofstream(truncated) << text.substr(0, text.size() / 2);
    CliRun r = run("detect " + marked.string() + " --original " + original_.string() + " --key " +
                       truncated.string(),
                   dir_);
    EXPECT_EQ(r.exit_code, 3);
    EXPECT_NE(r.err.find("truncated.json"), std::string::npos) << r.err;

    std::string future = text;
    future.replace(future.find("\"version\": 1"), 12, "\"version\": 7");
    const auto other_version = dir_ / "future.json";
    std::ofstream(other_version) << future;
    r = run("detect " + marked.string() + " --original " + original_.string() + " --key " +
                other_version.string(),
            dir_);
    EXPECT_EQ(r.exit_code, 3);
    EXPECT_NE(r.err.find("version"), std::string::npos) << r.err;

    // A suspect with other vertices: refused in the vertex-for-vertex mode, with a clear reason.
    const auto smaller = dir_ / "smaller.ply";
    write_mesh(smaller, lumpy_ellipsoid(4));
    r = run("detect " + smaller.string() + " --original " + original_.string() + " --key " +
                key.string() + " --no-register",
            dir_);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("smaller.ply"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("vertices"), std::string::npos) << r.err;

    // With registration (the default) the same unmarked, coarser copy is examined and not claimed.
    r = run("detect " + smaller.string() + " --original " + original_.string() + " --key " +
                key.string(),
            dir_);
    EXPECT_EQ(r.exit_code, 1) << r.err;

    const auto other_original = dir_ / "other.ply";
    write_mesh(other_original, lumpy_ellipsoid(4));
    r = run("detect " + marked.string() + " --original " + other_original.string() + " --key " +
                key.string(),
            dir_);
    EXPECT_EQ(r.exit_code, 3);
    EXPECT_NE(r.err.find("not the original"), std::string::npos) << r.err;
}

// `bench robustness` end to end on a tiny run: the marked copies are found, the unmarked ones
// and the wrong keys are not, and every trial is reported.
TEST_F(CliTest, bench_robustness_reports_every_trial)
{
    const auto json_file = dir_ / "trials.json";
    const auto markdown = dir_ / "table.md";
    const CliRun r =
        run("bench robustness -q --mesh " + original_.string() +
                " --keys 2 --wrong-keys 2 --unmarked-keys 1 --attacks \"noise=0.001;reorder\""
                " --json-file " +
                json_file.string() + " --markdown " + markdown.string(),
            dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto trials = nlohmann::json::parse(slurp(json_file))["trials"];
    // Per key: 3 marked (none + 2 attacks), 2 wrong keys; key 0 also 3 unmarked.
    ASSERT_EQ(trials.size(), 2u * 3u + 2u * 2u + 3u);
    int marked = 0;
    for (const auto& t : trials)
    {
        EXPECT_EQ(t["error"].get<std::string>(), "") << t.dump();
        const bool is_marked = t["kind"] == "marked";
        EXPECT_EQ(t["detected"].get<bool>(), is_marked) << t.dump();
        // Reordered copies are resampled on the whole surface: no row is far from it.
        EXPECT_EQ(t["outlier_fraction"].get<double>(), 0.0) << t.dump();
        marked += is_marked ? 1 : 0;
    }
    EXPECT_EQ(marked, 6);
    EXPECT_NE(slurp(markdown).find("| `reorder` | 2 | 2/2 |"), std::string::npos)
        << slurp(markdown);
    EXPECT_NE(slurp(markdown).find("strength default (surface)"), std::string::npos)
        << slurp(markdown);
    EXPECT_EQ(nlohmann::json::parse(slurp(json_file))["settings"]["strength_measure"], "surface");
    // The embedding is calibrated as embed calibrates it: the surface distance is the strength.
    const auto embeddings = nlohmann::json::parse(slurp(json_file))["embeddings"];
    ASSERT_EQ(embeddings.size(), 1u);
    EXPECT_NEAR(embeddings[0]["mrms"].get<double>(), 5.9e-4, 0.03 * 5.9e-4);
    // The per-mesh table: 6 marked copies of one mesh, all found.
    EXPECT_NE(slurp(markdown).find("| " + original_.filename().string() + " | 6 | 6/6 |"),
              std::string::npos)
        << slurp(markdown);

    // A second run (another seed, so other keys) merged with the first: tables of both, no rerun.
    const auto second = dir_ / "second.json";
    ASSERT_EQ(run("bench robustness -q --mesh " + original_.string() +
                      " --keys 1 --wrong-keys 1 --unmarked-keys 0 --attacks reorder --seed 2 "
                      "--json-file " +
                      second.string(),
                  dir_)
                  .exit_code,
              0);
    const CliRun other_seed = run(
        "bench robustness --from-json " + json_file.string() + " --from-json " + second.string(),
        dir_);
    EXPECT_EQ(other_seed.exit_code, 3) << "runs with other settings must not be merged";
    EXPECT_NE(other_seed.err.find("settings"), std::string::npos) << other_seed.err;

    // The same mesh twice would count the same keys twice: refused.
    const CliRun twice = run(
        "bench robustness --from-json " + json_file.string() + " --from-json " + json_file.string(),
        dir_);
    EXPECT_EQ(twice.exit_code, 3);
    EXPECT_NE(twice.err.find("already"), std::string::npos) << twice.err;

    const auto copy = dir_ / ("copy" + original_.extension().string());
    fs::copy_file(original_, copy);
    const auto third = dir_ / "third.json";
    ASSERT_EQ(run("bench robustness -q --mesh " + copy.string() +
                      " --keys 1 --wrong-keys 2 --unmarked-keys 1 --attacks reorder --json-file " +
                      third.string(),
                  dir_)
                  .exit_code,
              0);
    const CliRun merged =
        run("bench robustness --from-json " + json_file.string() + " --from-json " + third.string(),
            dir_);
    ASSERT_EQ(merged.exit_code, 0) << merged.err;
    // 2 + 1 keys' reorder copies, all found; 4 + 2 wrong keys, none claimed.
    EXPECT_NE(merged.out.find("| `reorder` | 3 | 3/3 |"), std::string::npos) << merged.out;
    EXPECT_NE(merged.out.find("| wrong key on a marked copy | 6 | 0 |"), std::string::npos)
        << merged.out;
    EXPECT_NE(merged.out.find("Keys per mesh: 1-2"), std::string::npos) << merged.out;
}

}  // namespace
}  // namespace meshmark

namespace meshmark
{

TEST_F(CliTest, laplacian_basis_and_decimated_centers_embed_detect_and_fail_cleanly)
{
    // A smaller original than the fixture's: the Laplacian basis is computed three times.
    const auto original = dir_ / "small.ply";
    write_mesh(original, lumpy_ellipsoid(4));
    for (const std::string flags : {"--basis laplacian", "--centers decimate"})
    {
        const auto marked = dir_ / "marked.ply";
        const auto key = dir_ / "key.json";
        CliRun r = run("embed " + original.string() + " -o " + marked.string() + " --key " +
                           key.string() + " --seed 5 --json --force " + flags,
                       dir_);
        ASSERT_EQ(r.exit_code, 0) << flags << ": " << r.err;
        const auto report = nlohmann::json::parse(r.out);
        const auto key_json = nlohmann::json::parse(slurp(key));
        if (flags == "--basis laplacian")
        {
            EXPECT_EQ(report["basis"], "laplacian");
            EXPECT_EQ(key_json["embedding"]["basis"], "laplacian");
        }
        else
        {
            EXPECT_EQ(report["centers"], "decimate");
            EXPECT_EQ(key_json["embedding"]["centers"], "decimate");
        }
        EXPECT_EQ(run("detect " + marked.string() + " --original " + original.string() + " --key " +
                          key.string(),
                      dir_)
                      .exit_code,
                  0)
            << flags;
        EXPECT_EQ(run("detect " + original.string() + " --original " + original.string() +
                          " --key " + key.string(),
                      dir_)
                      .exit_code,
                  1)
            << flags;
    }

    // A point cloud: one sentence naming the file, exit code 3, no output, no key.
    TriangleMesh cloud = lumpy_ellipsoid(3);
    cloud.F.resize(0, 3);
    const auto cloud_path = dir_ / "cloud.ply";
    write_mesh(cloud_path, cloud);
    for (const std::string flags : {"--basis laplacian", "--centers decimate"})
    {
        const auto out = dir_ / "cloud_marked.ply";
        const auto key = dir_ / "cloud_key.json";
        const CliRun r = run("embed " + cloud_path.string() + " -o " + out.string() + " --key " +
                                 key.string() + " " + flags,
                             dir_);
        EXPECT_EQ(r.exit_code, 3) << flags;
        EXPECT_NE(r.err.find(cloud_path.string()), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("point cloud"), std::string::npos) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
        EXPECT_FALSE(fs::exists(out));
        EXPECT_FALSE(fs::exists(key));
    }
    EXPECT_EQ(run("embed " + original_.string() + " -o " + (dir_ / "x.ply").string() + " --key " +
                      (dir_ / "x.json").string() + " --basis wavelet",
                  dir_)
                  .exit_code,
              2);
}

}  // namespace meshmark

namespace meshmark
{

// Issue 50: four `embed` calls creating one single-owner key at once (into folders that do not
// exist yet). Exactly one succeeds; the others are refused (exit 2: a key already exists) and
// leave nothing behind; the winner's copy is traced by the key that is there.
TEST_F(CliTest, calls_creating_one_key_at_once_leave_one_key_and_its_copy_only)
{
    constexpr int kCalls = 4;
    std::vector<pid_t> calls;
    for (int c = 0; c < kCalls; ++c)
    {
        const std::string out = (dir_ / ("out" + std::to_string(c)) / "m.ply").string();
        const std::string key = (dir_ / "keys" / "k.json").string();
        calls.push_back(
            test::spawn_cli({"embed", original_.string(), "-o", out, "--key", key, "-q"}));
    }
    int succeeded = -1;
    int refused = 0;
    for (int c = 0; c < kCalls; ++c)
    {
        const int status = test::wait_for(calls[static_cast<std::size_t>(c)]);
        if (status == 0)
        {
            EXPECT_EQ(succeeded, -1) << "two calls created the key";
            succeeded = c;
        }
        else
        {
            EXPECT_EQ(status, 2);
            ++refused;
        }
    }
    ASSERT_GE(succeeded, 0);
    EXPECT_EQ(refused, kCalls - 1);
    for (int c = 0; c < kCalls; ++c)
    {
        EXPECT_EQ(fs::exists(dir_ / ("out" + std::to_string(c))), c == succeeded) << "call " << c;
    }
    const CliRun detect = run(
        "detect " + (dir_ / ("out" + std::to_string(succeeded)) / "m.ply").string() +
            " --original " + original_.string() + " --key " + (dir_ / "keys" / "k.json").string(),
        dir_);
    EXPECT_EQ(detect.exit_code, 0) << detect.err;
}

}  // namespace meshmark
