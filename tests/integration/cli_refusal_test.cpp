// SPDX-License-Identifier: MIT
// The meshmark program refusing: it never overwrites the input or a key, keeps permissions when
// embedding in place, fails cleanly on bad inputs and corrupt keys, and leaves one key when
// several calls create it at once. One clear sentence, the right exit code, no partial files.
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

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

using test::CliRun;
using test::CliTest;
using test::run;
using test::slurp;
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

}  // namespace
}  // namespace meshmark
