// SPDX-License-Identifier: MIT
// The fixture of the program's tests (cli_*_test.cpp): a folder per test holding a lumpy
// ellipsoid as original.ply, and the program run in that folder.
#pragma once

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/cli_run.h"
#include "support/test_paths.h"

namespace meshmark::test
{

inline CliRun run(const std::string& arguments, const std::filesystem::path& dir)
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
    std::filesystem::path dir_;
    std::filesystem::path original_;
};

}  // namespace meshmark::test
