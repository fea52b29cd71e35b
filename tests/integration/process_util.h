// SPDX-License-Identifier: MIT
// Running the meshmark program (and other programs) from tests with fork/exec (POSIX): exit
// codes, signals, output.
#pragma once

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "support/test_paths.h"

namespace meshmark::test
{

/// \brief Start the program \p words[0] (a path, not looked up in PATH) with arguments
/// \p words[1...]; its stdout goes to \p stdout_path (or /dev/null when empty), its stderr to
/// \p stderr_path (or /dev/null).
/// \return The child's pid (> 0), or -1 when fork failed.
inline pid_t spawn_program(std::vector<std::string> words,
                           const std::filesystem::path& stdout_path = {},
                           const std::filesystem::path& stderr_path = {})
{
    std::vector<char*> argv;
    for (auto& word : words)
    {
        argv.push_back(word.data());
    }
    argv.push_back(nullptr);
    const std::string out = stdout_path.empty() ? "/dev/null" : stdout_path.string();
    const std::string err = stderr_path.empty() ? "/dev/null" : stderr_path.string();
    const pid_t pid = ::fork();
    if (pid == 0)
    {
        // Child: only async-signal-safe calls until exec.
        const int out_fd = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        const int err_fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (out_fd < 0 || err_fd < 0 || ::dup2(out_fd, 1) < 0 || ::dup2(err_fd, 2) < 0)
        {
            ::_exit(126);
        }
        ::execv(argv[0], argv.data());
        ::_exit(127);
    }
    return pid;
}

/// \brief Start the meshmark program with \p arguments; output as spawn_program.
/// \return The child's pid (> 0), or -1 when fork failed.
inline pid_t spawn_cli(const std::vector<std::string>& arguments,
                       const std::filesystem::path& stdout_path = {},
                       const std::filesystem::path& stderr_path = {})
{
    std::vector<std::string> words{cli_path().string()};
    words.insert(words.end(), arguments.begin(), arguments.end());
    return spawn_program(std::move(words), stdout_path, stderr_path);
}

/// Exit code of a finished child, or 128 + the signal that ended it (like a shell).
inline int wait_for(pid_t pid)
{
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0)
    {
        if (errno != EINTR)
        {
            return -1;
        }
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

/// Result of run_cli.
struct CliResult
{
    int exit_code = -1;
    std::string out;       ///< stdout
    std::string err;       ///< stderr
    double seconds = 0.0;  ///< wall time, start to exit
};

/// \brief Run \p words (spawn_program) to completion; \p scratch is a folder for its captured
/// output (file names made unique by \p tag, so that several runs can share the folder).
inline CliResult run_program(std::vector<std::string> words, const std::filesystem::path& scratch,
                             const std::string& tag = "cli")
{
    const auto out = scratch / (tag + "_stdout.txt");
    const auto err = scratch / (tag + "_stderr.txt");
    const auto start = std::chrono::steady_clock::now();
    CliResult result;
    result.exit_code = wait_for(spawn_program(std::move(words), out, err));
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result.out = file_bytes(out);
    result.err = file_bytes(err);
    std::filesystem::remove(out);
    std::filesystem::remove(err);
    return result;
}

/// Run the meshmark program with \p arguments to completion; \p scratch is a folder for its
/// captured output.
inline CliResult run_cli(const std::vector<std::string>& arguments,
                         const std::filesystem::path& scratch)
{
    std::vector<std::string> words{cli_path().string()};
    words.insert(words.end(), arguments.begin(), arguments.end());
    return run_program(std::move(words), scratch);
}

}  // namespace meshmark::test
