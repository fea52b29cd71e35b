// SPDX-License-Identifier: MIT
// The meshmark program's bench commands end to end: `bench speed` and `bench robustness`.

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_test_support.h"
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
