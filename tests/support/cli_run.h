// SPDX-License-Identifier: MIT
#pragma once

// Running the built meshmark program from a test, as a user would from a shell.

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h>

#include "support/test_paths.h"

namespace meshmark::test
{

/// What a run of the program left: its exit code (128 + the signal when one ended it) and
/// its stdout and stderr.
struct CliRun
{
    int exit_code = -1;
    std::string out;
    std::string err;
};

/// The bytes of \p path (empty when it cannot be read).
inline std::string slurp(const std::filesystem::path& path)
{
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

/// Runs `meshmark ARGUMENTS` through the shell (ARGUMENTS quoted by the caller), its output
/// captured in files of \p dir.
inline CliRun run_cli(const std::string& arguments, const std::filesystem::path& dir)
{
    const auto out = dir / "stdout.txt";
    const auto err = dir / "stderr.txt";
    const std::string command = "\"" + cli_path().string() + "\" " + arguments + " > \"" +
                                out.string() + "\" 2> \"" + err.string() + "\"";
    const int status = std::system(command.c_str());
    CliRun result;
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    result.out = slurp(out);
    result.err = slurp(err);
    return result;
}

}  // namespace meshmark::test
