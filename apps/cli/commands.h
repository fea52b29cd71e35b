// SPDX-License-Identifier: MIT
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace meshmark::cli
{

/// What `meshmark --version` prints (the project's version, from CMake), also stated in reports.
inline constexpr const char* kVersion = "meshmark " MESHMARK_VERSION;

/// Flags every command accepts.
struct GlobalArgs
{
    int threads = 0;       ///< 0 = all cores.
    bool quiet = false;    ///< No progress or summary on stderr.
    bool verbose = false;  ///< More detail on stderr.
};

/// The command chosen on the command line, run by main after parsing; returns the exit code.
using CommandRunner = std::function<int()>;

// One registration function per subcommand (one file each): adds the subcommand and its flags
// to \p app (with add_global_flags, which binds --threads/--quiet/--verbose to \p global) and,
// when it is the one chosen, stores in \p runner the call that runs it.
void register_embed(CLI::App& app, GlobalArgs& global, CommandRunner& runner);
void register_detect(CLI::App& app, GlobalArgs& global, CommandRunner& runner);
void register_demo(CLI::App& app, GlobalArgs& global, CommandRunner& runner);
void register_attack(CLI::App& app, GlobalArgs& global, CommandRunner& runner);
void register_compare(CLI::App& app, GlobalArgs& global, CommandRunner& runner);
void register_bench(CLI::App& app, GlobalArgs& global, CommandRunner& runner);
/// `bench robustness` (bench_robustness.cpp), added under \p bench by register_bench.
void register_bench_robustness(CLI::App& bench, GlobalArgs& global, CommandRunner& runner);
/// `bench approximation` (bench_approximation.cpp), added under \p bench by register_bench.
void register_bench_approximation(CLI::App& bench, GlobalArgs& global, CommandRunner& runner);

/// Accepts a number >= 0 ("must be 0 or more, got -3"; CLI11's NonNegativeNumber prints the
/// largest double as the range's end).
[[nodiscard]] CLI::Validator non_negative();

/// \brief --repetitions: "auto" (stored as EmbedOptions::kAutoRepetitions, the watermark chooses
/// on the original) or a whole number >= 1.
[[nodiscard]] CLI::Validator repetitions_choice();

/// --lock-timeout's seconds as a duration.
[[nodiscard]] std::chrono::milliseconds lock_timeout_of(double seconds);
/// `meshmark catalog ...` (catalog.cpp).
void register_catalog(CLI::App& app, GlobalArgs& global, CommandRunner& runner);
/// `catalog migrate` (catalog_migrate.cpp), added under \p catalog by register_catalog.
void register_catalog_migrate(CLI::App& catalog, GlobalArgs& global, CommandRunner& runner);
/// `meshmark serve` (serve.cpp).
void register_serve(CLI::App& app, GlobalArgs& global, CommandRunner& runner);
/// Adds --threads, --quiet and --verbose to a subcommand.
void add_global_flags(CLI::App& command, GlobalArgs& global);

}  // namespace meshmark::cli
