// SPDX-License-Identifier: MIT
// The meshmark program: parses the command line, runs one subcommand, maps errors to exit codes.
#include <cstdio>
#include <exception>

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "commands.h"
#include "meshmark/core/error.h"
#include "meshmark/watermark/key.h"

namespace meshmark::cli
{

CLI::Validator non_negative()
{
    return CLI::Validator(
        [](std::string& text) -> std::string
        {
            double value = 0.0;
            if (!CLI::detail::lexical_cast(text, value) || !(value >= 0.0))
            {
                return "must be a number, 0 or more, got " + text;
            }
            return {};
        },
        "NONNEGATIVE");
}

CLI::Validator repetitions_choice()
{
    return CLI::Validator(
        [](std::string& text) -> std::string
        {
            if (text == "auto")
            {
                text = std::to_string(EmbedOptions::kAutoRepetitions);
                return {};
            }
            int value = 0;
            if (!CLI::detail::lexical_cast(text, value) || value < 1)
            {
                return "must be auto or a whole number, 1 or more, got " + text;
            }
            return {};
        },
        "");
}

void add_global_flags(CLI::App& command, GlobalArgs& global)
{
    command
        .add_option("--threads", global.threads,
                    "Worker threads (0 = all cores); results are "
                    "bit-identical for any value")
        ->check(CLI::Range(0, 1024))
        ->default_val(0);
    command.add_flag("-q,--quiet", global.quiet, "No progress or summary on stderr");
    command.add_flag("-v,--verbose", global.verbose, "More detail on stderr");
}

}  // namespace meshmark::cli

int main(int argc, char** argv)
{
    using namespace meshmark;
#ifdef __GLIBC__
    // Each phase of a large embed or detect allocates and frees working arrays of 1-100 MB. By
    // default glibc serves blocks from 128 KiB up with fresh mmap()s (the threshold then adapts
    // from run to run), so every phase faults its pages in again; blocks up to 32 MiB now stay on
    // the heap, which is returned to the system only when 256 MiB lie free at its top. Measured
    // on the 1M-vertex registration-path detect (docs/performance.md): 3.15 -> 3.03 s wall, system
    // time 0.39 -> 0.26 s, peak RSS 461 -> 474 MiB; the 1M embed 0.49 -> 0.44 s, peak unchanged.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
#endif
    CLI::App app{
        "meshmark: robust invisible watermarks for 3D meshes (spectral RBF method of "
        "Wu & Kobbelt, with corrections).\n"
        "Exit codes: 0 success (detect: watermark found), 1 detect: not found, "
        "2 usage, 3 invalid input, 4 numerical failure, 5 internal error.",
        "meshmark"};
    app.set_version_flag("--version", cli::kVersion);
    app.require_subcommand(1);
    cli::GlobalArgs global;
    cli::CommandRunner runner;
    for (const auto register_command :
         {cli::register_demo, cli::register_embed, cli::register_detect, cli::register_attack,
          cli::register_compare, cli::register_bench, cli::register_catalog, cli::register_serve})
    {
        register_command(app, global, runner);
    }
    try
    {
        app.parse(argc, argv);
    }
    catch (const CLI::ParseError& e)
    {
        const int code = app.exit(e);
        return code == 0 ? 0 : static_cast<int>(ExitCode::Usage);
    }
    try
    {
        return runner ? runner() : static_cast<int>(ExitCode::Usage);
    }
    catch (const std::exception& e)
    {
        std::fprintf(stderr, "meshmark: %s\n", e.what());
        return static_cast<int>(exit_code_for(e));
    }
}
