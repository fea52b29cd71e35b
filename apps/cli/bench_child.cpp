// SPDX-License-Identifier: MIT
#include "bench_child.h"

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "bench_mesh.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

extern char** environ;  // NOLINT: POSIX, for posix_spawn

namespace meshmark::cli
{

namespace fs = std::filesystem;

ChildRun run_child(const fs::path& program, const std::vector<std::string>& args)
{
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(program.c_str()));  // posix_spawn's signature; not written
    for (const auto& a : args)
    {
        argv.push_back(const_cast<char*>(a.c_str()));
    }
    argv.push_back(nullptr);

    int pipe_fds[2];
    if (::pipe(pipe_fds) != 0)
    {
        throw IoError(std::string("cannot create a pipe for a benchmark run (") +
                      std::strerror(errno) + ").");
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
    posix_spawn_file_actions_addclose(&actions, pipe_fds[1]);
    pid_t pid = 0;
    const auto start = std::chrono::steady_clock::now();
    const int spawned =
        ::posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(pipe_fds[1]);
    if (spawned != 0)
    {
        ::close(pipe_fds[0]);
        throw IoError(program.string() + ": cannot start a benchmark run (" +
                      std::strerror(spawned) + ").");
    }
    std::string output;
    char buffer[4096];
    for (;;)
    {
        const ssize_t got = ::read(pipe_fds[0], buffer, sizeof(buffer));
        if (got > 0)
        {
            output.append(buffer, static_cast<std::size_t>(got));
        }
        else if (got == 0 || errno != EINTR)
        {
            break;
        }
    }
    ::close(pipe_fds[0]);
    int status = 0;
    rusage usage{};
    while (::wait4(pid, &status, 0, &usage) < 0)
    {
        if (errno != EINTR)
        {
            throw IoError(std::string("cannot wait for a benchmark run (") + std::strerror(errno) +
                          ").");
        }
    }
    ChildRun run;
    run.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    run.peak_mib = static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kibibytes
    const auto seconds = [](const timeval& t)
    { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
    run.cpu_seconds = seconds(usage.ru_utime) + seconds(usage.ru_stime);
    run.report = nlohmann::json::parse(output, nullptr, false);
    if (run.report.is_discarded())
    {
        run.report = nlohmann::json::object();
    }
    return run;
}

void write_generated(const fs::path& path, std::int64_t vertices)
{
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    if (pid < 0)
    {
        throw IoError(std::string("cannot fork to generate a mesh (") + std::strerror(errno) +
                      ").");
    }
    if (pid == 0)
    {
        int code = 0;
        try
        {
            WriteOptions options;
            options.use_single_precision = true;
            write_mesh(path, bumpy_torus(vertices), options);
        }
        catch (const std::exception& e)
        {
            std::fprintf(stderr, "meshmark bench: %s\n", e.what());
            code = 1;
        }
        ::_exit(code);
    }
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR)
    {
    }
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    {
        throw IoError(path.string() + ": cannot write the generated mesh of " +
                      std::to_string(vertices) + " vertices.");
    }
}

}  // namespace meshmark::cli
