// SPDX-License-Identifier: MIT
// `meshmark embed`: watermark a mesh file and write its key.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "meshmark/pipeline/embed_file.h"
#include "progress.h"
#include "report.h"

namespace meshmark::cli {
namespace {

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
    std::uint64_t seed = 0;
    bool has_seed = false;
    bool json = false;
    bool force = false;
    std::int64_t memory_budget = 0;
    bool stream = false;
    EmbedOptions options;
};

int run_embed(const EmbedArgs& args, const GlobalArgs& global)
{
    EmbedFileOptions options;
    options.embed = args.options;
    options.embed.rule = parse_embedding_rule(args.rule);
    options.embed.basis = parse_basis_type(args.basis);
    options.embed.centers = parse_center_selection(args.centers);
    options.embed.strength = args.strength;
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
    options.force = args.force;
    options.replace_input = args.force;  // -o may name the input only with --force
    options.memory_budget_mib = args.memory_budget;
    options.force_stream = args.stream;
    // Phases and a running clock on a terminal, after the first second; silent otherwise.
    std::optional<PhaseProgress> progress;
    if (PhaseProgress::should_show(global.quiet))
    {
        progress.emplace(PhaseProgressOptions{"meshmark embed"});
        options.progress = progress->callback();
    }

    const EmbedReport report = embed_file(args.input, args.output, args.key, options);
    if (progress)
    {
        progress->finish();
    }

    const auto& stats = report.stats;
    if (args.json)
    {
        print_json(embed_report_json(report, args.input, args.output, args.key));
    }
    if (!global.quiet && !report.stream_note.empty())
    {
        std::fprintf(stderr, "meshmark: note: %s; embedded in memory.\n", report.stream_note.c_str());
    }
    if (!global.quiet)
    {
        std::fprintf(stderr,
                     "meshmark: embedded %zu bits into %s (%lld vertices) in %.3f s; displacement "
                     "RMS %s%%, max %s%% of the bbox diagonal; key in %s\n",
                     report.key.payload.size(), args.output.c_str(),
                     static_cast<long long>(report.vertex_count), report.seconds.total,
                     format_number(100.0 * stats.rms_displacement_rel).c_str(),
                     format_number(100.0 * stats.max_displacement_rel).c_str(), args.key.c_str());
        if (stats.weak_bits > 0)
        {
            std::fprintf(stderr,
                         "meshmark: warning: %d of the %zu bits sit on coefficients below a tenth of "
                         "the largest; under the paper's rule they are the first to fail (the "
                         "additive rule has no such bits).\n",
                         stats.weak_bits, report.key.payload.size());
        }
    }
    return 0;
}

}  // namespace

void register_embed(CLI::App& app, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<EmbedArgs>();
    auto* command = app.add_subcommand(
        "embed",
        "Watermark a mesh: writes the marked copy (same format as -o's extension; everything but "
        "vertex positions is preserved when it is the input's format) and a key file (JSON, mode "
        "0600) that, with the original, regenerates and detects the mark.");
    command->add_option("INPUT", args->input,
                        "Original mesh (.ply .obj .off .stl .gltf .glb .3mf); never modified")
        ->required()
        ->check(CLI::ExistingFile);
    command->add_option("-o,--output", args->output, "Watermarked mesh to write")->required();
    command->add_option("--key", args->key, "Key file to write (refuses to replace one unless --force)")
        ->required();
    auto* message = command->add_option("--message", args->message,
                                        "Payload: a text, hashed to the 3m payload bits");
    command->add_option("--bits", args->bits, "Payload: exactly ceil(3m/4) hex digits, MSB first")
        ->excludes(message);
    command->add_option("--basis", args->basis,
                        "rbf: orthogonalized RBFs (Wu & Kobbelt; fast, any size); laplacian: "
                        "eigenvectors of the combinatorial mesh Laplacian (the slower baseline; "
                        "needs faces)")
        ->check(CLI::IsMember({"rbf", "laplacian"}))
        ->capture_default_str();
    command->add_option("--basis-size", args->options.basis_size,
                        "k, basis functions (RBF centers or Laplacian eigenvectors)")
        ->capture_default_str();
    command->add_option("--centers", args->centers,
                        "RBF centers: random (from the seed) or decimate (survivors of a QEM "
                        "decimation to k vertices; needs faces)")
        ->check(CLI::IsMember({"random", "decimate"}))
        ->capture_default_str();
    command->add_option("--coefficients", args->options.coefficients,
                        "m, payload bits per axis (3m payload bits)")
        ->capture_default_str();
    command->add_option("--repetitions", args->options.repetitions,
                        "r, coefficients per payload bit (the mark uses m*r modes, each copy with "
                        "its own key sign; more copies, same distortion, stronger verdict)")
        ->capture_default_str();
    command->add_option("--first-mode", args->options.first_mode,
                        "Index of the first modulated mode (the lowest modes are nearly rigid "
                        "motions, which detection removes)")
        ->capture_default_str();
    command->add_option("--rule", args->rule,
                        "additive: beta = alpha + b's (default); paper: beta = alpha(1 + b'rho)")
        ->check(CLI::IsMember({"additive", "paper"}))
        ->capture_default_str();
    command->add_option("--strength", args->strength,
                        "additive: RMS vertex displacement as a fraction of the bbox diagonal "
                        "(default 0.001); paper: rho (default 0.01)");
    command->add_option("--sigma-factor", args->options.sigma_factor,
                        "RBF support = factor * bbox diagonal / 2")
        ->capture_default_str();
    command->add_option("--gram-rows", args->options.gram_rows,
                        "RBF basis: estimate its Gram matrix from at most this many evenly spaced "
                        "vertices (0 = all); bounds the basis cost of very large meshes, smaller "
                        "meshes are unaffected (the key records it)")
        ->check(non_negative())
        ->capture_default_str();
    command->add_option("--seed", args->seed,
                        "Secret seed (centers, payload mask, random payload); random if absent");
    command->add_option("--memory-budget", args->memory_budget,
                        "MiB: when the in-memory embed of a binary PLY would need more, stream it "
                        "from disk in chunks (same output bytes and key; an input that cannot be "
                        "streamed is embedded in memory with a note). 0 = no budget")
        ->check(non_negative())
        ->capture_default_str();
    command->add_flag("--stream", args->stream,
                      "Always embed out of core (binary PLY with fixed-size vertex records, "
                      "written to .ply); any other input is an error");
    command->add_flag("--json", args->json, "Print a JSON report on stdout");
    command->add_flag("--force", args->force,
                      "Replace an existing key file, or the input itself when -o names it "
                      "(atomically: a complete marked file or the untouched original)");
    add_global_flags(*command, global);
    command->callback([args, &global, &runner, command]() {
        args->has_seed = command->count("--seed") > 0;
        runner = [args, &global]() { return run_embed(*args, global); };
    });
}

}  // namespace meshmark::cli
