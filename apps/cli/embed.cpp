// SPDX-License-Identifier: MIT
// `meshmark embed`: watermark a mesh file and write its key.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/core/file_lock.h"
#include "meshmark/pipeline/embed_file.h"
#include "meshmark/pipeline/embed_recipients.h"
#include "meshmark/pipeline/embed_record.h"
#include "meshmark/pipeline/report_json.h"
#include "progress.h"
#include "report.h"

namespace meshmark::cli
{
namespace
{

struct EmbedArgs
{
    std::string input;
    std::string output;
    std::string key;
    std::string message;
    std::string bits;
    std::string rule = "additive";
    std::string basis = "rbf";
    std::string centers = "random";
    double strength = -1.0;
    std::string strength_measure = "surface";
    std::uint64_t seed = 0;
    bool has_seed = false;
    bool has_repetitions =
        false;  // --repetitions given (else a family key's owner mark takes kFamilyRepetitions)
    bool json = false;
    bool force = false;
    std::int64_t memory_budget = 0;
    bool stream = false;
    std::vector<std::string> recipients;
    std::string recipients_file;
    int recipient_modes = RecipientCodes{}.modes;
    double recipient_share = RecipientCodes{}.energy_share;
    double lock_timeout = std::chrono::duration<double>(kDefaultLockTimeout).count();
    std::string unit;              // --unit: the coordinates' unit
    std::string max_displacement;  // --max-displacement LENGTH
    std::string record;            // --record FILE.json
    EmbedOptions options;
};

// " (0.81 mm)" for \p rel of the diagonal when the unit is known, else nothing.
std::string in_unit(const EmbedReport& report, double rel)
{
    return report.unit ? " (" + format_length(rel * report.diagonal, *report.unit) + ")" : "";
}

// A length in the coordinates' unit, or in "the mesh's units", to 4 digits (a cap and what
// honours it differ in the 4th).
std::string mesh_length(const EmbedReport& report, double value)
{
    return format_number(value, 4) +
           (report.unit ? std::string(" ") + to_string(*report.unit) : " (mesh units)");
}

// What --max-displacement did, on stderr.
void print_cap(const EmbedReport& report)
{
    const DisplacementCap& cap = report.cap;
    const std::string written = report.written_max_displacement >= 0.0
                                    ? "; largest in the written file " +
                                          mesh_length(report, report.written_max_displacement)
                                    : "";
    if (cap.factor < 1.0)
    {
        std::fprintf(
            stderr,
            "meshmark: --max-displacement %s: the strength was lowered to %s of the one asked for "
            "(largest displacement %s -> %s%s); an undamaged copy still reads z = %s. A weaker "
            "mark "
            "survives less damage (docs/robustness.md, \"Capped displacement\").\n",
            mesh_length(report, cap.cap).c_str(), format_number(cap.factor, 3).c_str(),
            mesh_length(report, cap.uncapped_max).c_str(),
            mesh_length(report, cap.factor * cap.uncapped_max).c_str(), written.c_str(),
            format_number(cap.intact_score, 4).c_str());
    }
    else
    {
        std::fprintf(
            stderr, "meshmark: --max-displacement %s: the mark fits at the strength asked for%s.\n",
            mesh_length(report, cap.cap).c_str(), written.c_str());
    }
}

// `meshmark embed --recipient ...`: one copy per recipient and the family key.
int run_embed_recipients(const EmbedArgs& args, const GlobalArgs& global,
                         EmbedRecipientsOptions options)
{
    if (args.stream || args.memory_budget > 0)
    {
        throw InvalidOption(
            "recipient copies are embedded in memory; --stream and --memory-budget do not apply.");
    }
    if (!args.max_displacement.empty())
    {
        throw InvalidOption(
            "--max-displacement does not apply to recipient copies: a family key has one strength "
            "for every copy, present and future, and each recipient's code moves the vertices "
            "differently; cap a single copy (embed without --recipient) instead.");
    }
    if (!args.record.empty())
    {
        throw InvalidOption("--record applies to a single copy (embed without --recipient).");
    }
    if (args.force)
    {
        throw InvalidOption(
            "--force does not apply to recipient copies: an existing family key is extended, "
            "any other key is refused.");
    }
    options.recipients = args.recipients;
    if (!args.recipients_file.empty())
    {
        const std::vector<std::string> listed = read_recipients_file(args.recipients_file);
        options.recipients.insert(options.recipients.end(), listed.begin(), listed.end());
    }
    options.recipient_modes = args.recipient_modes;
    options.recipient_share = args.recipient_share;
    options.lock_timeout = lock_timeout_of(args.lock_timeout);
    const EmbedRecipientsReport report =
        with_progress("meshmark embed", global.quiet, options.progress,
                      [&] { return embed_recipients(args.input, args.output, args.key, options); });
    if (args.json)
    {
        print_json(embed_recipients_report_json(report, args.input, args.key));
    }
    if (!global.quiet)
    {
        double largest_rms = 0.0;
        int added = 0;
        for (const IssuedCopy& copy : report.copies)
        {
            largest_rms = std::max(largest_rms, copy.stats.rms_displacement_rel);
            added += copy.is_new ? 1 : 0;
        }
        std::fprintf(
            stderr,
            "meshmark: issued %zu copies of %s (%lld vertices; %d new recipients, %zu re-issued) "
            "in "
            "%.3f s; displacement RMS at most %s%% of the bbox diagonal; %s key %s holds %zu "
            "recipients\n",
            report.copies.size(), args.input.c_str(), static_cast<long long>(report.vertex_count),
            added, report.copies.size() - static_cast<std::size_t>(added), report.seconds.total,
            format_number(100.0 * largest_rms).c_str(), report.key_created ? "new" : "updated",
            args.key.c_str(), report.key.recipients->recipients.size());
    }
    return 0;
}

int run_embed(const EmbedArgs& args, const GlobalArgs& global)
{
    EmbedFileOptions options;
    options.embed = args.options;
    options.embed.rule = parse_embedding_rule(args.rule);
    options.embed.basis = parse_basis_type(args.basis);
    options.embed.centers = parse_center_selection(args.centers);
    options.embed.strength = args.strength;
    options.embed.measure = parse_strength_measure(args.strength_measure);
    if (!args.message.empty())
    {
        options.message = args.message;
    }
    if (!args.bits.empty())
    {
        options.bits_hex = args.bits;
    }
    if (args.has_seed)
    {
        options.seed = args.seed;
    }
    options.threads = global.threads;
    if (!args.recipients.empty() || !args.recipients_file.empty())
    {
        EmbedRecipientsOptions family;
        static_cast<EmbedMeshOptions&>(family) = options;
        if (!args.has_repetitions)
        {
            family.embed.repetitions = kFamilyRepetitions;
        }
        return run_embed_recipients(args, global, std::move(family));
    }
    options.force = args.force;
    options.lock_timeout = lock_timeout_of(args.lock_timeout);
    options.replace_input = args.force;  // -o may name the input only with --force
    options.memory_budget_mib = args.memory_budget;
    options.force_stream = args.stream;
    if (!args.unit.empty())
    {
        options.unit = parse_length_unit(args.unit);
    }
    if (!args.record.empty() && (is_same_file(args.record, args.input) ||
                                 args.record == args.output || args.record == args.key))
    {
        throw InvalidOption("--record " + args.record +
                            " must differ from the input, the output and the key.");
    }
    if (!args.max_displacement.empty())
    {
        options.max_displacement_length = parse_length(args.max_displacement, "--max-displacement");
    }
    // In place, the original is hashed for the record before the marked copy replaces it.
    std::optional<RecordedFile> original_before;
    if ((args.json || !args.record.empty()) && is_same_file(args.input, args.output))
    {
        original_before = recorded_file(args.input);
    }
    // Phases and a running clock on a terminal, after the first second; silent otherwise.
    const EmbedReport report =
        with_progress("meshmark embed", global.quiet, options.progress,
                      [&] { return embed_file(args.input, args.output, args.key, options); });

    const auto& stats = report.stats;
    // The record hashes the files as written (docs/evidence.md, "The embed record").
    std::optional<EmbedRecord> record;
    if (args.json || !args.record.empty())
    {
        record = make_embed_record(args.input, args.output, args.key, report.key,
                                   original_before ? &*original_before : nullptr);
    }
    if (!args.record.empty())
    {
        write_embed_record(args.record, *record);
    }
    if (args.json)
    {
        nlohmann::json out = embed_report_json(report, args.input, args.output, args.key);
        out["record"] = to_json(*record);
        print_json(out);
    }
    if (!global.quiet && !report.stream_note.empty())
    {
        std::fprintf(stderr, "meshmark: note: %s; embedded in memory.\n",
                     report.stream_note.c_str());
    }
    if (!global.quiet && stats.shortened_to_span)
    {
        const int coefficients = 3 * modulated_modes(report.key.options);
        std::fprintf(
            stderr,
            "meshmark: note: the vertices span only %d modes of the basis (they lie on a few "
            "curves "
            "or in a small patch), so the mark has %d repetitions of the payload, %d coefficients "
            "(an intact copy scores %s): a shorter mark than usual, weaker against remeshing "
            "and simplification.\n",
            stats.basis_span, report.key.options.repetitions, coefficients,
            format_number(std::sqrt(static_cast<double>(coefficients)), 3).c_str());
    }
    if (!global.quiet && !report.strength_note.empty())
    {
        std::fprintf(stderr, "meshmark: note: %s.\n", report.strength_note.c_str());
    }
    if (!global.quiet && report.cap.cap > 0.0)
    {
        print_cap(report);
    }
    if (!global.quiet)
    {
        const std::string surface = stats.surface_rms_rel > 0.0
                                        ? "surface distance RMS " +
                                              format_number(100.0 * stats.surface_rms_rel) + "%" +
                                              in_unit(report, stats.surface_rms_rel) + ", vertex "
                                        : "";
        std::fprintf(
            stderr,
            "meshmark: embedded %zu bits into %s (%lld vertices) in %.3f s; %sdisplacement "
            "RMS %s%%%s, max %s%%%s of the bbox diagonal%s; key in %s%s%s\n",
            report.key.payload.size(), args.output.c_str(),
            static_cast<long long>(report.vertex_count), report.seconds.total, surface.c_str(),
            format_number(100.0 * stats.rms_displacement_rel).c_str(),
            in_unit(report, stats.rms_displacement_rel).c_str(),
            format_number(100.0 * stats.max_displacement_rel).c_str(),
            in_unit(report, stats.max_displacement_rel).c_str(),
            report.unit         ? ""
            : args.unit.empty() ? " (no unit known: see --unit)"
                                : " (embedded out of core: not in --unit)",
            args.key.c_str(), args.record.empty() ? "" : "; record in ", args.record.c_str());
        if (stats.weak_bits > 0)
        {
            std::fprintf(
                stderr,
                "meshmark: warning: %d of the %d modulated coefficients are below a tenth of "
                "the largest; under the paper's rule the bits they carry are the first to "
                "fail (the additive rule has no such coefficients).\n",
                stats.weak_bits, 3 * modulated_modes(report.key.options));
        }
    }
    return 0;
}

}  // namespace

std::chrono::milliseconds lock_timeout_of(double seconds)
{
    return std::chrono::milliseconds(static_cast<std::int64_t>(std::llround(1000.0 * seconds)));
}

void register_embed(CLI::App& app, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<EmbedArgs>();
    auto* command = app.add_subcommand(
        "embed",
        "Watermark a mesh: write the marked copy and its key (JSON, mode 0600); keep both and the "
        "original (docs/cli.md)");
    command
        ->add_option("INPUT", args->input,
                     "Original mesh (.ply .obj .off .stl .gltf .glb .3mf); never modified")
        ->required()
        ->check(CLI::ExistingFile);
    command
        ->add_option(
            "-o,--output", args->output,
            "Watermarked mesh to write (with --recipient: a pattern containing {recipient})")
        ->required();
    command
        ->add_option("--key", args->key,
                     "Key file to write (refuses to replace one unless --force)")
        ->required();
    auto* message = command->add_option("--message", args->message,
                                        "Payload: a text, hashed to the 3m payload bits");
    command->add_option("--bits", args->bits, "Payload: exactly ceil(3m/4) hex digits, MSB first")
        ->excludes(message);
    command
        ->add_option("--basis", args->basis,
                     "rbf: orthogonalized RBFs (Wu & Kobbelt); laplacian: mesh Laplacian "
                     "eigenvectors (slow baseline; needs faces)")
        ->check(CLI::IsMember({"rbf", "laplacian"}))
        ->capture_default_str();
    command
        ->add_option("--basis-size", args->options.basis_size,
                     "k, basis functions (RBF centers or Laplacian eigenvectors)")
        ->capture_default_str();
    command
        ->add_option("--centers", args->centers,
                     "RBF centers: random (from the seed) or decimate (a QEM decimation's "
                     "survivors; needs faces)")
        ->check(CLI::IsMember({"random", "decimate"}))
        ->capture_default_str();
    command
        ->add_option("--coefficients", args->options.coefficients,
                     "m, payload bits per axis (3m payload bits)")
        ->capture_default_str();
    command
        ->add_option(
            "--repetitions", args->options.repetitions,
            "r, coefficients per payload bit; auto: 5 from 5,000 vertices, else 4 (docs/cli.md)")
        ->transform(repetitions_choice())
        ->type_name("auto|INT")
        ->default_str("auto");
    command
        ->add_option("--first-mode", args->options.first_mode,
                     "First modulated mode (the lowest are nearly rigid motions)")
        ->capture_default_str();
    command
        ->add_option("--rule", args->rule,
                     "additive: beta = alpha + b's (default); paper: beta = alpha(1 + b'rho)")
        ->check(CLI::IsMember({"additive", "paper"}))
        ->capture_default_str();
    command->add_option("--strength", args->strength,
                        "Fraction of the bbox diagonal (default 0.00059 surface, 0.001 vertex); "
                        "paper rule: rho (default 0.01)");
    command
        ->add_option(
            "--strength-measure", args->strength_measure,
            "surface: RMS distance between the surfaces (MRMS); vertex: RMS vertex displacement")
        ->check(CLI::IsMember({"surface", "vertex"}))
        ->capture_default_str();
    command
        ->add_option("--sigma-factor", args->options.sigma_factor,
                     "RBF support = factor * bbox diagonal / 2")
        ->capture_default_str();
    command
        ->add_option("--gram-rows", args->options.gram_rows,
                     "Gram matrix from at most this many evenly spaced vertices (0 = all)")
        ->check(non_negative())
        ->capture_default_str();
    command->add_option("--seed", args->seed,
                        "Secret seed (centers, payload mask, random payload); random if absent");
    command
        ->add_option(
            "--memory-budget", args->memory_budget,
            "MiB; above it a binary PLY is embedded out of core, same result (0 = no budget)")
        ->check(non_negative())
        ->capture_default_str();
    command->add_flag("--stream", args->stream,
                      "Always embed out of core (binary PLY in, .ply out)");
    command->add_option(
        "--recipient", args->recipients,
        "Issue a traceable copy to this recipient (repeatable); -o holds {recipient}, --key is "
        "the family key");
    command
        ->add_option("--recipients", args->recipients_file,
                     "File of recipient names, one per line ('#' comments), as --recipient")
        ->check(CLI::ExistingFile);
    command
        ->add_option("--recipient-modes", args->recipient_modes,
                     "New family key: M, modes carrying each recipient's code")
        ->capture_default_str();
    command
        ->add_option("--recipient-share", args->recipient_share,
                     "New family key: the codes' share of the displacement energy")
        ->capture_default_str();
    command
        ->add_option(
            "--lock-timeout", args->lock_timeout,
            "Seconds to wait while another call issues on (or writes) the same key, then fail")
        ->check(CLI::Range(0.0, 86400.0))
        ->capture_default_str();
    command->add_option(
        "--unit", args->unit,
        "Unit of the coordinates (um mm cm m in ft), overriding the file's; distortions are "
        "also given in it");
    command
        ->add_option(
            "--max-displacement", args->max_displacement,
            "Cap on the largest vertex displacement, e.g. 0.05mm; the strength is lowered to "
            "fit")
        ->type_name("LENGTH");
    command
        ->add_option(
            "--record", args->record,
            "Write the embed record (time, version, SHA-256 of the files; never the key) for "
            "timestamping")
        ->type_name("FILE.json");
    command->add_flag("--json", args->json, "Print a JSON report on stdout (fields: docs/cli.md)");
    command->add_flag("--force", args->force,
                      "Replace an existing key, or the input itself when -o names it (atomically)");
    add_global_flags(*command, global);
    command->callback(
        [args, &global, &runner, command]()
        {
            args->has_seed = command->count("--seed") > 0;
            args->has_repetitions = command->count("--repetitions") > 0;
            runner = [args, &global]() { return run_embed(*args, global); };
        });
}

}  // namespace meshmark::cli
