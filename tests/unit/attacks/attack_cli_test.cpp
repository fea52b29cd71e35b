// SPDX-License-Identifier: MIT
// `meshmark attack` end to end: exit codes, determinism across runs, refusal to overwrite.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <sys/wait.h>

#include "attack_test_util.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

class AttackCliTest : public ::testing::Test
{
protected:
    void SetUp() override
    {
        if (test::cli_path().empty() || !std::filesystem::exists(test::cli_path()))
        {
            GTEST_SKIP() << "the meshmark program is not built";
        }
        dir_ = test::temp_dir("attack_cli");
        input_ = dir_ / "ellipsoid.ply";
        write_mesh(input_, lumpy_ellipsoid(4));  // 2562 vertices
    }

    // Runs `meshmark attack ARGS` (after the environment assignments ENV, if any), stdout and
    // stderr to files; returns the exit code.
    int run(const std::string& args, const std::string& env = "") const
    {
        const std::string command =
            (env.empty() ? "" : "env " + env + " ") + test::cli_path().string() + " attack " +
            args + " >" + (dir_ / "stdout.txt").string() + " 2>" + (dir_ / "stderr.txt").string();
        const int status = std::system(command.c_str());
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }

    std::string file(const std::string& name) const
    {
        std::ifstream in(dir_ / name, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }

    std::filesystem::path dir_;
    std::filesystem::path input_;
};

TEST_F(AttackCliTest, chain_writes_the_attacked_mesh_and_is_reproducible_per_seed)
{
    const std::string spec = " similarity,simplify=0.1,noise=0.001";
    ASSERT_EQ(run(input_.string() + " -o " + (dir_ / "a.ply").string() + " --seed 3" + spec), 0)
        << file("stderr.txt");
    EXPECT_NE(file("stderr.txt").find("2562 vertices"), std::string::npos) << file("stderr.txt");
    ASSERT_EQ(run(input_.string() + " -o " + (dir_ / "b.ply").string() + " --seed 3 -q" + spec), 0);
    EXPECT_TRUE(file("stderr.txt").empty());
    ASSERT_EQ(run(input_.string() + " -o " + (dir_ / "c.ply").string() + " --seed 4" + spec), 0);
    const TriangleMesh a = read_mesh(dir_ / "a.ply");
    EXPECT_LE(test::relative_error(static_cast<double>(a.V.rows()), 256.2), 0.1);
    EXPECT_EQ(file("a.ply"), file("b.ply"));
    EXPECT_NE(file("a.ply"), file("c.ply"));
}

TEST_F(AttackCliTest, json_reports_counts_and_the_similarity_applied)
{
    ASSERT_EQ(run(input_.string() + " -o " + (dir_ / "s.obj").string() +
                  " --json similarity:axis=z:angle=90:scale=2"),
              0);
    const std::string json = file("stdout.txt");
    EXPECT_NE(json.find("\"spec\":\"similarity:angle=90:scale=2\""), std::string::npos) << json;
    EXPECT_NE(json.find("\"vertices_after\":2562"), std::string::npos) << json;
    EXPECT_NE(json.find("\"transform\":[["), std::string::npos) << json;
    const TriangleMesh in = read_mesh(input_);
    const TriangleMesh out = read_mesh(dir_ / "s.obj");
    ASSERT_EQ(out.V.rows(), in.V.rows());
    EXPECT_NEAR(out.V(0, 0), -2.0 * in.V(0, 1), 1e-9);
    EXPECT_NEAR(out.V(0, 1), 2.0 * in.V(0, 0), 1e-9);
}

TEST_F(AttackCliTest, errors_map_to_exit_codes_and_leave_no_output)
{
    const std::string out = (dir_ / "never.ply").string();
    EXPECT_EQ(run(input_.string() + " -o " + out + " nosie=0.1"), 2);
    EXPECT_NE(file("stderr.txt").find("unknown attack 'nosie'"), std::string::npos);
    EXPECT_EQ(run(input_.string() + " -o " + out + " noise=0.1:foo=2"), 2);
    EXPECT_EQ(run((dir_ / "missing.ply").string() + " -o " + out + " noise"), 3);
    EXPECT_EQ(run(input_.string() + " -o " + (dir_ / "out.xyz").string() + " noise"), 3);

    TriangleMesh cloud;
    cloud.V = lumpy_ellipsoid(2).V;
    write_mesh(dir_ / "cloud.ply", cloud);
    EXPECT_EQ(run((dir_ / "cloud.ply").string() + " -o " + out + " smooth=5"), 3);
    EXPECT_NE(file("stderr.txt").find("cloud.ply"), std::string::npos) << file("stderr.txt");
    EXPECT_FALSE(std::filesystem::exists(out));
}

TEST_F(AttackCliTest, voxel_remeshing_writes_a_closed_new_mesh_the_same_for_any_thread_count)
{
    ASSERT_EQ(
        run(input_.string() + " -o " + (dir_ / "v1.ply").string() + " --json --threads 1 voxel=60"),
        0)
        << file("stderr.txt");
    const std::string json = file("stdout.txt");
    EXPECT_NE(json.find("\"spec\":\"voxel=60\""), std::string::npos) << json;
    EXPECT_NE(json.find("\"has_correspondence\":false"), std::string::npos) << json;
    ASSERT_EQ(run(input_.string() + " -o " + (dir_ / "v2.ply").string() + " --threads 2 voxel=60"),
              0);
    EXPECT_EQ(file("v1.ply"), file("v2.ply"));
    const TriangleMesh out = read_mesh(dir_ / "v1.ply");
    EXPECT_TRUE(edge_statistics(out).is_closed());
    EXPECT_NE(out.V.rows(), 2562);

    const std::string never = (dir_ / "never.ply").string();
    EXPECT_EQ(run(input_.string() + " -o " + never + " voxel=5"), 2);
    EXPECT_NE(file("stderr.txt").find("resolution 5 is outside [10, 2000]"), std::string::npos)
        << file("stderr.txt");
    TriangleMesh cloud;
    cloud.V = lumpy_ellipsoid(2).V;
    write_mesh(dir_ / "cloud.ply", cloud);
    EXPECT_EQ(run((dir_ / "cloud.ply").string() + " -o " + never + " voxel=150"), 3);
    EXPECT_NE(file("stderr.txt").find("cloud.ply"), std::string::npos) << file("stderr.txt");
    EXPECT_FALSE(std::filesystem::exists(never));
}

// OpenVDB is in a plugin loaded by the voxel step only: other attacks never load it, and a
// missing or broken plugin is an installation error (exit 5) that names the file.
TEST_F(AttackCliTest, voxel_plugin_is_loaded_only_by_the_voxel_step_and_reported_when_missing)
{
    const std::string out = (dir_ / "out.ply").string();
    // glibc's loader lists every object it opens (LD_DEBUG=files).
    ASSERT_EQ(run(input_.string() + " -o " + out + " noise=0.001", "LD_DEBUG=files"), 0);
    EXPECT_EQ(file("stderr.txt").find("libopenvdb"), std::string::npos);
    EXPECT_EQ(file("stderr.txt").find("libmeshmark_voxel.so"), std::string::npos);
    ASSERT_EQ(run(input_.string() + " -o " + out + " voxel=30", "LD_DEBUG=files"), 0);
    EXPECT_NE(file("stderr.txt").find("libmeshmark_voxel.so"), std::string::npos);
    EXPECT_NE(file("stderr.txt").find("libopenvdb"), std::string::npos);
    const std::string reference = file("out.ply");

    // MESHMARK_PLUGIN_DIR is the only place searched when set: the real plugin is not found
    // from an empty directory, while the other attacks still run.
    const std::filesystem::path empty = dir_ / "no_plugin";
    std::filesystem::create_directories(empty);
    const std::string in_empty = "MESHMARK_PLUGIN_DIR=" + empty.string();
    const std::string never = (dir_ / "never.ply").string();
    EXPECT_EQ(run(input_.string() + " -o " + never + " voxel=30", in_empty), 5);
    EXPECT_NE(file("stderr.txt")
                  .find("needs libmeshmark_voxel.so (OpenVDB), which was not found "
                        "in MESHMARK_PLUGIN_DIR (" +
                        empty.string() + "): reinstall meshmark."),
              std::string::npos)
        << file("stderr.txt");
    EXPECT_FALSE(std::filesystem::exists(never));
    EXPECT_EQ(run(input_.string() + " -o " + never + " noise=0.001", in_empty), 0);
    std::filesystem::remove(never);

    // A file of that name that is no shared object: refused with the loader's reason.
    const std::filesystem::path broken = empty / "libmeshmark_voxel.so";
    std::ofstream(broken) << "not a library\n";
    EXPECT_EQ(run(input_.string() + " -o " + never + " voxel=30", in_empty), 5);
    EXPECT_NE(file("stderr.txt").find("could not load " + broken.string()), std::string::npos)
        << file("stderr.txt");
    EXPECT_FALSE(std::filesystem::exists(never));

    // The directory the build puts it in (lib/meshmark/ beside bin/), named explicitly: the same
    // mesh as found by the default search.
    const std::filesystem::path built =
        test::cli_path().parent_path().parent_path() / "lib" / "meshmark";
    ASSERT_EQ(run(input_.string() + " -o " + never + " voxel=30",
                  "MESHMARK_PLUGIN_DIR=" + built.string()),
              0)
        << file("stderr.txt");
    EXPECT_EQ(file("never.ply"), reference);
}

TEST_F(AttackCliTest, refuses_to_overwrite_the_input_unless_forced)
{
    const std::string before = file("ellipsoid.ply");
    EXPECT_EQ(run(input_.string() + " -o " + input_.string() + " noise=0.01"), 2);
    EXPECT_EQ(file("ellipsoid.ply"), before);
    EXPECT_EQ(run(input_.string() + " -o " + input_.string() + " --force noise=0.01"), 0);
    EXPECT_NE(file("ellipsoid.ply"), before);
}

}  // namespace
}  // namespace meshmark
