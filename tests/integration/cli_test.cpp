// SPDX-License-Identifier: MIT
// The meshmark program as users and scripts see it: embed and detect with --json and exit codes,
// recipient copies, streaming under a memory budget, repetitions, help texts, point clouds,
// --gram-rows, the Laplacian basis and decimated centres.
#include <algorithm>
#include <cstdlib>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <sys/wait.h>

#include "cli_test_support.h"
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
using test::CliTest;
using test::run;
using test::slurp;
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
}  // namespace
}  // namespace meshmark
