// SPDX-License-Identifier: MIT
// The program's physical units and embed record as users see them: compare and embed in the
// file's unit or --unit, embed --max-displacement honoured in the written file (as compare
// reads it) or refused with exit code 2, and --record's hashes.
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include "meshmark/geometry/shapes.h"
#include "meshmark/io/file_sha256.h"
#include "meshmark/io/mesh_io.h"
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

class CliUnitsTest : public ::testing::Test
{
protected:
    void SetUp() override
    {
        if (test::cli_path().empty())
        {
            GTEST_SKIP() << "the CLI is not built";
        }
        dir_ = test::temp_dir(::testing::UnitTest::GetInstance()->current_test_info()->name());
        TriangleMesh mesh = lumpy_ellipsoid(4);
        mesh.V *= 40.0;  // about 100 units across
        original_ = dir_ / "original.ply";
        write_mesh(original_, mesh, {.use_single_precision = true});
        // The same part as a 3MF, which says millimetres.
        write_mesh(dir_ / "part.3mf", mesh);
    }
    std::string in(const std::string& name) const { return (dir_ / name).string(); }
    fs::path dir_;
    fs::path original_;
};

TEST_F(CliUnitsTest, embed_and_compare_state_distortions_in_the_files_unit)
{
    const CliRun embed = run("embed " + in("part.3mf") + " -o " + in("marked.3mf") + " --key " +
                                 in("key.json") + " --seed 3 --json",
                             dir_);
    ASSERT_EQ(embed.exit_code, 0) << embed.err;
    const auto report = nlohmann::json::parse(embed.out);
    ASSERT_TRUE(report.contains("in_unit")) << embed.out;
    EXPECT_EQ(report["in_unit"]["unit"], "mm");
    EXPECT_EQ(report["in_unit"]["source"], "file");
    EXPECT_NEAR(
        report["in_unit"]["max_displacement"].get<double>(),
        report["max_displacement"].get<double>() * report["in_unit"]["bbox_diagonal"].get<double>(),
        1e-12);
    EXPECT_NE(embed.err.find(" mm)"), std::string::npos) << embed.err;

    const CliRun compare =
        run("compare " + in("part.3mf") + " " + in("marked.3mf") + " --json", dir_);
    ASSERT_EQ(compare.exit_code, 0) << compare.err;
    const auto distances = nlohmann::json::parse(compare.out);
    EXPECT_EQ(distances["unit"], "bounding-box diagonal of A");  // unchanged meaning
    EXPECT_EQ(distances["in_unit"]["unit"], "mm");
    EXPECT_NEAR(distances["in_unit"]["max_displacement"].get<double>(),
                report["in_unit"]["max_displacement"].get<double>(),
                1e-3 * report["in_unit"]["max_displacement"].get<double>());
    const CliRun text = run("compare " + in("part.3mf") + " " + in("marked.3mf"), dir_);
    EXPECT_NE(text.out.find("displacement  max "), std::string::npos) << text.out;
    EXPECT_NE(text.out.find(" mm), RMS"), std::string::npos) << text.out;

    // A PLY has no unit: nothing is stated in one, unless --unit gives it.
    const CliRun plain =
        run("compare " + original_.string() + " " + original_.string() + " --json", dir_);
    ASSERT_EQ(plain.exit_code, 0) << plain.err;
    EXPECT_FALSE(nlohmann::json::parse(plain.out).contains("in_unit"));
    const CliRun given =
        run("compare " + original_.string() + " " + original_.string() + " --json --unit in", dir_);
    EXPECT_EQ(nlohmann::json::parse(given.out)["in_unit"]["source"], "option");
    EXPECT_EQ(
        run("compare " + original_.string() + " " + original_.string() + " --unit parsec", dir_)
            .exit_code,
        2);
}

TEST_F(CliUnitsTest, max_displacement_is_honoured_in_the_written_file_or_refused)
{
    const CliRun plain = run("embed " + original_.string() + " -o " + in("default.ply") +
                                 " --key " + in("default.json") + " --seed 5 --json",
                             dir_);
    ASSERT_EQ(plain.exit_code, 0) << plain.err;
    const auto uncapped = nlohmann::json::parse(plain.out);
    EXPECT_FALSE(uncapped.contains("in_unit"));  // a PLY states no unit
    const double default_max =
        uncapped["max_displacement"].get<double>() *
        nlohmann::json::parse(
            run("compare " + original_.string() + " " + in("default.ply") + " --json", dir_)
                .out)["bbox_diagonal"]
            .get<double>();

    // Half of it, in micrometres, the mesh being in millimetres.
    const double cap_um = 500.0 * default_max;
    const CliRun capped = run(
        "embed " + original_.string() + " -o " + in("capped.ply") + " --key " + in("capped.json") +
            " --seed 5 --unit mm --json --max-displacement " + std::to_string(cap_um) + "um",
        dir_);
    ASSERT_EQ(capped.exit_code, 0) << capped.err;
    const auto cap = nlohmann::json::parse(capped.out)["max_displacement_cap"];
    EXPECT_EQ(cap["unit"], "mm");
    EXPECT_LT(cap["strength_factor"].get<double>(), 0.51);
    const CliRun compare =
        run("compare " + original_.string() + " " + in("capped.ply") + " --unit mm --json", dir_);
    const double written =
        nlohmann::json::parse(compare.out)["in_unit"]["max_displacement"].get<double>();
    EXPECT_LE(written, cap_um / 1000.0);
    EXPECT_GT(written, 0.98 * cap_um / 1000.0);
    const CliRun found = run("detect " + in("capped.ply") + " --original " + original_.string() +
                                 " --key " + in("capped.json"),
                             dir_);
    EXPECT_EQ(found.exit_code, 0) << found.out << found.err;

    // A bare number without any unit, a cap no detectable mark fits under, recipients: usage
    // errors.
    const CliRun unitless = run("embed " + original_.string() + " -o " + in("a.ply") + " --key " +
                                    in("a.json") + " --max-displacement 0.01",
                                dir_);
    EXPECT_EQ(unitless.exit_code, 2);
    EXPECT_NE(unitless.err.find("--unit"), std::string::npos) << unitless.err;
    const CliRun tiny = run("embed " + original_.string() + " -o " + in("b.ply") + " --key " +
                                in("b.json") + " --unit mm --max-displacement 1nm",
                            dir_);
    EXPECT_EQ(tiny.exit_code, 2);  // "nm" is not a unit
    const CliRun too_small = run("embed " + original_.string() + " -o " + in("c.ply") + " --key " +
                                     in("c.json") + " --unit mm --max-displacement 0.000001um",
                                 dir_);
    EXPECT_EQ(too_small.exit_code, 2) << too_small.err;
    EXPECT_NE(too_small.err.find("the smallest cap that fits is"), std::string::npos)
        << too_small.err;
    EXPECT_NE(too_small.err.find("original.ply"), std::string::npos) << too_small.err;
    EXPECT_FALSE(fs::exists(dir_ / "c.ply"));
    EXPECT_FALSE(fs::exists(dir_ / "c.json"));
    const CliRun family =
        run("embed " + original_.string() + " -o " + in("copy-{recipient}.ply") + " --key " +
                in("family.json") + " --recipient bob --unit mm --max-displacement 0.01mm",
            dir_);
    EXPECT_EQ(family.exit_code, 2);
    EXPECT_NE(family.err.find("recipient"), std::string::npos) << family.err;
}

TEST_F(CliUnitsTest, the_record_holds_the_files_hashes_and_no_key_material)
{
    const CliRun embed =
        run("embed " + original_.string() + " -o " + in("marked.ply") + " --key " + in("key.json") +
                " --seed 7842389 --message secret-owner --record " + in("record.json") + " --json",
            dir_);
    ASSERT_EQ(embed.exit_code, 0) << embed.err;
    const auto printed = nlohmann::json::parse(embed.out)["record"];
    const auto written = nlohmann::json::parse(slurp(dir_ / "record.json"));
    EXPECT_EQ(printed, written);
    EXPECT_EQ(written["original"]["sha256"], file_sha256(original_));
    EXPECT_EQ(written["marked"]["sha256"], file_sha256(dir_ / "marked.ply"));
    EXPECT_EQ(written["key"]["sha256"], file_sha256(dir_ / "key.json"));
    const std::string text = slurp(dir_ / "record.json");
    EXPECT_EQ(text.find("secret-owner"), std::string::npos);
    EXPECT_EQ(text.find("77aa55"), std::string::npos);
    EXPECT_NE(slurp(dir_ / "key.json").find("77aa55"), std::string::npos);

    // In place (-o names the input, --force): the record's original is the file before the embed.
    fs::copy_file(original_, dir_ / "in-place.ply");
    const std::string before = file_sha256(dir_ / "in-place.ply");
    const CliRun in_place =
        run("embed " + in("in-place.ply") + " -o " + in("in-place.ply") + " --key " +
                in("in-place.json") + " --force --record " + in("in-place.record.json"),
            dir_);
    ASSERT_EQ(in_place.exit_code, 0) << in_place.err;
    const auto record = nlohmann::json::parse(slurp(dir_ / "in-place.record.json"));
    EXPECT_EQ(record["original"]["sha256"], before);
    EXPECT_EQ(record["marked"]["sha256"], file_sha256(dir_ / "in-place.ply"));
    EXPECT_NE(record["marked"]["sha256"], before);
}

}  // namespace
}  // namespace meshmark
