// SPDX-License-Identifier: MIT
// `meshmark detect`: look for a key's watermark in a suspect copy.
#include <array>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/pipeline/detect_file.h"
#include "meshmark/pipeline/verdict.h"
#include "meshmark/registration/point_pairs.h"
#include "meshmark/report/evidence_report.h"
#include "progress.h"
#include "report.h"

namespace meshmark::cli
{
namespace
{

struct DetectArgs
{
    std::string suspect;
    std::string original;
    std::string key;
    std::string pairs;
    bool json = false;
    bool no_register = false;
    bool no_trace = false;
    std::string verdict = "combined";
    std::string report;  // --report FILE.html|FILE.pdf
    DetectOptions decision;
};

/// --report names an .html or .pdf file that is none of the inputs (checked before detecting).
void check_report_path(const DetectArgs& args)
{
    if (args.report.empty())
    {
        return;
    }
    (void)evidence_format(args.report);
    for (const std::string* input : {&args.suspect, &args.original, &args.key, &args.pairs})
    {
        if (!input->empty() && is_same_file(args.report, *input))
        {
            throw InvalidOption("--report " + args.report + " would overwrite an input file.");
        }
    }
}

int run_detect(const DetectArgs& args, const GlobalArgs& global)
{
    check_report_path(args);
    DetectFileOptions options;
    options.decision = args.decision;
    options.decision.verdict = parse_verdict_rule(args.verdict);
    options.threads = global.threads;
    options.allow_registration = !args.no_register;
    options.trace = !args.no_trace;
    if (!args.pairs.empty())
    {
        options.pairs = read_point_pairs(args.pairs);
    }
    // Phases and a running clock on a terminal, after the first second; silent otherwise.
    const DetectReport report =
        with_progress("meshmark detect", global.quiet, options.progress,
                      [&] { return detect_file(args.suspect, args.original, args.key, options); });
    const Decision& d = report.decision;
    if (!args.report.empty())
    {
        // The evidence report states what --json states: it is written from the same object.
        const auto start = std::chrono::steady_clock::now();
        DetectionReportOptions report_options;
        report_options.pictures.threads = global.threads;
        report_options.version = kVersion;
        report_options.command =
            detect_command(args.suspect, args.original, args.key, args.pairs, options);
        write_detection_report(args.report, args.suspect, args.original, args.key,
                               detect_report_json(report, args.decision), report_options);
        if (!global.quiet)
        {
            std::fprintf(
                stderr, "meshmark detect: report written to %s (%.2f s)\n", args.report.c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
    }
    if (args.json)
    {
        print_json(detect_report_json(report, args.decision, global.verbose));
    }
    else
    {
        // The verdict first, in one sentence; the readings it rests on under it.
        const Verdict verdict = verdict_of(report, args.decision.max_false_positive);
        std::printf("%s: %s\n", args.suspect.c_str(), headline(verdict).c_str());
        std::printf(
            "  owner's mark alone: %s, z = %.2f over %d coefficients, R = %.3f (%d of %d bits), "
            "false-positive probability %s\n",
            d.is_present ? "found" : "not found", d.score, d.coefficient_count, d.correlation,
            d.matches, d.bit_count, format_number(d.false_positive_probability).c_str());
        if (report.recipients_traced > 0)
        {
            std::printf(
                "  ownership %s (the owner's mark, alone or with a recipient's code), "
                "false-positive probability %s\n",
                report.owner_detected ? "shown" : "not shown",
                format_number(report.owner_false_positive_probability).c_str());
            std::printf("  %zu of %zu recipients accused%s\n", report.accused.size(),
                        report.recipients_traced, report.accused.empty() ? "" : ":");
            for (const RecipientScore& r : report.accused)
            {
                // The regions' score too when there is one: it may be what accuses (a splice).
                std::array<char, 32> regions{};
                if (r.region_score > 0.0)
                {
                    std::snprintf(regions.data(), regions.size(), ", regions z = %.2f",
                                  r.region_score);
                }
                std::printf("    %s: z = %.2f%s, false-positive probability %s\n", r.name.c_str(),
                            r.score, regions.data(),
                            format_number(r.false_positive_probability).c_str());
            }
        }
        // Why a "not found" says little here (DetectReport::is_far_copy).
        if (!report.detected() && !global.quiet && report.is_far_copy())
        {
            std::fprintf(stderr,
                         "meshmark: note: the suspect lies %.3g%% of the diagonal (RMS) from the "
                         "original, %.1f times "
                         "the mark's strength: marked copies that far from the original (a coarse "
                         "simplification "
                         "that moves the vertices, a voxel remesh that fills thin parts) often "
                         "keep too little of "
                         "the mark to be claimed (docs/robustness.md, \"What an attack leaves of "
                         "the mark\").\n",
                         100.0 * report.registration_rms,
                         report.registration_rms / report.mark_strength);
        }
        if (global.verbose)
        {
            std::printf(
                "  expected %s\n  found    %s\n  alignment %s, RMS distance %s of the diagonal, "
                "cropped %.1f%%, far rows left out %.1f%%, %.3f s\n",
                d.bits_expected.c_str(), d.bits_found.c_str(), report.registration_method().c_str(),
                format_number(report.registration_rms).c_str(), 100.0 * report.cropped_fraction,
                100.0 * report.outlier_fraction, report.seconds.total);
        }
    }
    return report.detected() ? 0 : 1;
}

}  // namespace

void register_detect(CLI::App& app, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<DetectArgs>();
    auto* command = app.add_subcommand(
        "detect",
        "Look for KEY's watermark in SUSPECT (needs the original); exit 0 when claimed, 1 when not "
        "(docs/cli.md)");
    command->add_option("SUSPECT", args->suspect, "Suspect mesh")
        ->required()
        ->check(CLI::ExistingFile);
    command
        ->add_option("--original", args->original,
                     "The original (unmarked) mesh the key was made for")
        ->required()
        ->check(CLI::ExistingFile);
    command->add_option("--key", args->key, "Key file written by embed")
        ->required()
        ->check(CLI::ExistingFile);
    command
        ->add_option(
            "--verdict", args->verdict,
            "combined: correlation or bits read back, bound <= --max-fpp; correlation alone; "
            "bits: R >= --threshold")
        ->check(CLI::IsMember({"combined", "correlation", "bits"}))
        ->capture_default_str();
    command
        ->add_option("--max-fpp", args->decision.max_false_positive,
                     "Largest false-positive probability at which ownership is claimed")
        ->capture_default_str();
    command
        ->add_option(
            "--threshold", args->decision.threshold,
            "Bits verdict: claim ownership when R (fraction of payload bits read back) >= this")
        ->capture_default_str();
    command
        ->add_option("--epsilon", args->decision.epsilon,
                     "Undecided band around zero change, as a fraction of the modulation")
        ->capture_default_str();
    command
        ->add_option("--pairs", args->pairs,
                     "File of >= 3 point pairs 'xs ys zs  xo yo zo' to start the registration from")
        ->check(CLI::ExistingFile);
    command->add_flag("--no-trace", args->no_trace,
                      "With a family key: decide on the owner's mark alone (shared by every copy), "
                      "without naming recipients");
    command->add_flag(
        "--no-register", args->no_register,
        "Only accept a suspect whose vertices correspond to the original's (no registration)");
    command->add_option("--report", args->report,
                        "Also write an evidence report, FILE.html or FILE.pdf (docs/evidence.md)");
    command->add_flag("--json", args->json,
                      "Print one JSON object on stdout (fields: docs/cli.md)");
    add_global_flags(*command, global);
    command->callback([args, &global, &runner]()
                      { runner = [args, &global]() { return run_detect(*args, global); }; });
}

}  // namespace meshmark::cli
