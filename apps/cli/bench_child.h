// SPDX-License-Identifier: MIT
// `meshmark bench speed`'s child processes: each timed run is a child of its own, so that its
// peak RSS (wait4's ru_maxrss) is that run's alone (see bench.cpp).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace meshmark::cli
{

/// One child run: its exit code, JSON report (if any) and peak RSS.
struct ChildRun
{
    int exit_code = -1;
    nlohmann::json report;
    double peak_mib = 0.0;
    double wall_seconds = 0.0;
    double cpu_seconds = 0.0;  ///< User + system time of the child, all its threads.
};

/// \brief Runs \p program with \p args (posix_spawn, the parent's environment) and waits for
/// it: exit code, the JSON it printed on stdout (an empty object if none), peak RSS and times.
[[nodiscard]] ChildRun run_child(const std::filesystem::path& program,
                                 const std::vector<std::string>& args);

/// \brief Writes bumpy_torus(vertices) as a binary float32 PLY from a forked child: Linux folds
/// the RSS peak of the process image an exec replaces into the child's ru_maxrss, so the parent
/// never loads a mesh. \throws IoError when the child cannot be forked or fails.
void write_generated(const std::filesystem::path& path, std::int64_t vertices);

}  // namespace meshmark::cli
