// SPDX-License-Identifier: MIT
// `catalog add|scan --scheduler ADDRESS`: the command run on a Dask cluster by the Python
// package's meshmark.cluster (Dask's client is Python's), in a child `python3 -m
// meshmark.cluster REQUEST.json` whose stdout carries progress lines and the report.
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include "catalog_args.h"
#include "meshmark/core/error.h"
#include "progress.h"

extern char** environ;  // NOLINT: POSIX, for posix_spawn

namespace meshmark::cli
{
namespace
{
namespace fs = std::filesystem;

// The interpreter the package was built for (MESHMARK_PYTHON overrides it).
std::string python_interpreter()
{
    if (const char* given = std::getenv("MESHMARK_PYTHON"); given != nullptr && *given != '\0')
    {
        return given;
    }
    return MESHMARK_PYTHON_EXECUTABLE;
}

// Where this program's Python package is: the build tree's for a program run from the build
// tree, else the installed one; empty when neither is there (python3's own path then decides).
std::string package_folder()
{
    std::error_code error;
    const fs::path self = fs::read_symlink("/proc/self/exe", error);
    const fs::path build = MESHMARK_BUILD_DIR;
    const fs::path built = fs::path(MESHMARK_BUILD_DIR) / "python";
    if (!error && self.string().rfind(build.string() + "/", 0) == 0 &&
        fs::is_directory(built / "meshmark", error))
    {
        return built.string();
    }
    const fs::path installed = MESHMARK_PYTHON_INSTALLED;
    if (fs::is_directory(installed / "meshmark", error))
    {
        return installed.string();
    }
    return {};
}

// The environment with \p folder first on PYTHONPATH.
std::vector<std::string> child_environment(const std::string& folder)
{
    std::vector<std::string> variables;
    std::string path = folder;
    for (char** v = environ; *v != nullptr; ++v)
    {
        const std::string variable = *v;
        if (variable.rfind("PYTHONPATH=", 0) == 0)
        {
            const std::string rest = variable.substr(11);
            path = path.empty() ? rest : (rest.empty() ? path : path + ":" + rest);
            continue;
        }
        variables.push_back(variable);
    }
    if (!path.empty())
    {
        variables.push_back("PYTHONPATH=" + path);
    }
    return variables;
}

// A file removed when this goes out of scope.
struct TemporaryFile
{
    fs::path path;
    TemporaryFile(const TemporaryFile&) = delete;
    TemporaryFile& operator=(const TemporaryFile&) = delete;
    TemporaryFile(TemporaryFile&&) = delete;
    TemporaryFile& operator=(TemporaryFile&&) = delete;
    explicit TemporaryFile(const std::string& text)
    {
        std::string pattern = (fs::temp_directory_path() / "meshmark-cluster-XXXXXX").string();
        const int fd = ::mkstemp(pattern.data());  // mode 0600
        if (fd < 0)
        {
            throw IoError(fs::temp_directory_path().string() +
                          ": cannot write the cluster request (" + std::strerror(errno) + ").");
        }
        path = pattern;
        const auto written = ::write(fd, text.data(), text.size());
        ::close(fd);
        if (written != static_cast<ssize_t>(text.size()))
        {
            throw IoError(path.string() + ": cannot write the cluster request.");
        }
    }
    ~TemporaryFile()
    {
        std::error_code ignored;
        fs::remove(path, ignored);
    }
};

[[noreturn]] void rethrow(const nlohmann::json& failure)
{
    const std::string message = failure.at("error").get<std::string>();
    const std::string kind = failure.value("kind", std::string());
    if (kind == "InvalidOption")
    {
        throw InvalidOption(message);
    }
    if (kind == "InvalidMesh")
    {
        throw InvalidMesh(message);
    }
    if (kind == "NumericalError")
    {
        throw NumericalError(message);
    }
    throw IoError(message);
}

}  // namespace

nlohmann::json run_on_cluster(const char* command, const CatalogArgs& args,
                              const GlobalArgs& global)
{
    nlohmann::json options;
    const bool is_add = std::string(command) == "add";
    const bool is_issue = std::string(command) == "issue";
    if (is_issue)
    {
        options = {{"recipients_file", args.recipients_file.empty()
                                           ? nlohmann::json(nullptr)
                                           : nlohmann::json(args.recipients_file)}};
    }
    else if (is_add)
    {
        options = {{"basis_size", args.options.basis_size},
                   {"coefficients", args.options.coefficients},
                   {"force", args.force}};
        if (args.strength >= 0.0)
        {
            options["strength"] = args.strength;
        }
        if (!args.message.empty())
        {
            options["message"] = args.message;
        }
        if (args.has_seed)
        {
            options["seed"] = args.seed;
        }
    }
    else
    {
        options = {{"candidates", args.candidates},
                   {"more_candidates", args.more_candidates},
                   {"all_candidates", args.all_candidates},
                   {"max_fpp", args.max_false_positive}};
    }
    const bool shows_progress = PhaseProgress::should_show(global.quiet);
    const nlohmann::json request = {
        {"command", command},
        {"scheduler", args.scheduler},
        {"catalog", args.catalog},
        {"inputs", args.inputs},  // as given: the child runs in this folder
        {"output", args.output},
        {"lock_timeout", args.lock_timeout},
        {"progress", shows_progress},
        {"options", options},
        {"asset", args.asset},
        {"recipients", args.recipients}};
    const TemporaryFile request_file(request.dump());

    const std::string python = python_interpreter();
    const std::vector<std::string> environment = child_environment(package_folder());
    std::vector<char*> envp;
    for (const std::string& v : environment)
    {
        envp.push_back(const_cast<char*>(v.c_str()));  // posix_spawn's signature; not written
    }
    envp.push_back(nullptr);
    std::vector<std::string> words = {python, "-m", "meshmark.cluster", request_file.path.string()};
    std::vector<char*> argv;
    for (std::string& w : words)
    {
        argv.push_back(w.data());
    }
    argv.push_back(nullptr);
    int pipe_fds[2];
    if (::pipe2(pipe_fds, O_CLOEXEC) != 0)
    {
        throw IoError(std::string("cannot start the cluster client (") + std::strerror(errno) +
                      ").");
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
    pid_t pid = 0;
    const int spawned =
        ::posix_spawnp(&pid, python.c_str(), &actions, nullptr, argv.data(), envp.data());
    posix_spawn_file_actions_destroy(&actions);
    ::close(pipe_fds[1]);
    if (spawned != 0)
    {
        ::close(pipe_fds[0]);
        throw IoError(python + ": cannot run the Python interpreter for --scheduler (" +
                      std::strerror(spawned) + "); set MESHMARK_PYTHON (docs/cluster.md).");
    }

    std::optional<PhaseProgress> progress;
    if (shows_progress)
    {
        progress.emplace(PhaseProgressOptions{is_add     ? "meshmark catalog add (cluster)"
                                              : is_issue ? "meshmark catalog issue (cluster)"
                                                         : "meshmark catalog scan (cluster)"});
    }
    const ProgressCallback show = progress ? progress->callback() : ProgressCallback();
    nlohmann::json outcome;
    std::string pending;
    char buffer[65536];
    for (ssize_t n; (n = ::read(pipe_fds[0], buffer, sizeof buffer)) != 0;)
    {
        if (n < 0)
        {
            if (errno == EINTR)
            {
                continue;
            }
            break;
        }
        pending.append(buffer, static_cast<std::size_t>(n));
        for (std::size_t end; (end = pending.find('\n')) != std::string::npos;)
        {
            const std::string line = pending.substr(0, end);
            pending.erase(0, end + 1);
            const nlohmann::json message = nlohmann::json::parse(line, nullptr, false);
            if (message.is_object() && message.contains("progress") && show)
            {
                show(is_add ? "files" : (is_issue ? "copies" : "suspects"),
                     message["progress"].get<double>());
            }
            else if (message.is_object() &&
                     (message.contains("report") || message.contains("error")))
            {
                outcome = message;
            }
        }
    }
    ::close(pipe_fds[0]);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR)
    {
    }
    if (progress)
    {
        progress->finish();
    }
    if (outcome.contains("error"))
    {
        rethrow(outcome);
    }
    if (!outcome.contains("report") || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    {
        throw IoError(
            python + " -m meshmark.cluster ended without a report (exit " +
            std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status)) +
            "): is the meshmark package importable there with dask.distributed "
            "(docs/cluster.md)?");
    }
    return outcome["report"];
}

}  // namespace meshmark::cli
