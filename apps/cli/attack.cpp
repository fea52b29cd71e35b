// SPDX-License-Identifier: MIT
// `meshmark attack`: apply a chain of attacks (the robustness benchmark's suite) to a mesh file.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "meshmark/attacks/attack_spec.h"
#include "meshmark/pipeline/attack_file.h"
#include "progress.h"
#include "report.h"

namespace meshmark::cli
{
namespace
{

struct AttackArgs
{
    std::string input;
    std::string output;
    std::string spec;
    std::uint64_t seed = 0;
    bool force = false;
    bool json = false;
};

std::string number(double value)
{
    return format_number(value, 6);
}

// The whole grammar, with the defaults taken from the options structs (one source of truth).
std::string grammar_help()
{
    const SimilarityOptions similarity;
    const NoiseOptions noise;
    const LaplacianSmoothingOptions smooth;
    const TaubinSmoothingOptions taubin;
    const QuantizationOptions quantize;
    const SimplificationOptions simplify;
    const RemeshingOptions remesh;
    const CropOptions crop;
    const VoxelRemeshingOptions voxel;
    return "SPEC := STEP[,STEP]...  (left to right)   STEP := NAME[=LEVEL][:KEY=VALUE]...\n"
           "Steps (default level; their keys and details: docs/cli.md, "
           "docs/algorithms/attacks.md):\n"
           "  similarity         random rotation, scale and move (keys smax=" +
           number(similarity.max_scale) + " tmax=" + number(similarity.max_translation_radii) +
           "), or explicit; mirror=x|y|z\n"
           "  noise=A            random displacement, A of the bbox diagonal (" +
           number(noise.amplitude) +
           ")\n"
           "  smooth=N           Laplacian smoothing, N iterations (" +
           std::to_string(smooth.iterations) + "; lambda=" + number(smooth.lambda) +
           ")\n"
           "  taubin=N           Taubin smoothing, N step pairs (" +
           std::to_string(taubin.iterations) + "; lambda=" + number(taubin.lambda) +
           " mu=" + number(taubin.mu) +
           ")\n"
           "  quantize=B         coordinates snapped to 2^B levels over the bbox (" +
           std::to_string(quantize.bits) +
           ")\n"
           "  simplify=F         quadric edge collapse to F of the vertices (" +
           number(simplify.vertex_fraction) +
           "; policy=gh|lt boundary=" + number(simplify.boundary_weight) +
           ")\n"
           "  remesh=F           isotropic remeshing to F of the vertices (" +
           number(remesh.vertex_fraction) + "; iter=" + std::to_string(remesh.iterations) +
           ")\n"
           "  subdivide=S        loop|midpoint|sqrt3 (loop; steps=1)\n"
           "  crop=F             plane cut keeping F of the vertices (" +
           number(crop.vertex_fraction) +
           "; axis=x|y|z)\n"
           "  reorder            random permutation of the vertices and of the faces\n"
           "  voxel=N            voxel remesh as Blender's, voxel edge = bbox diagonal / N (" +
           number(voxel.resolution) +
           ")\n"
           "Example: meshmark attack in.ply -o out.ply --seed 3 "
           "similarity,simplify=0.1,noise=0.001";
}

double phase_seconds(const PhaseTimings& timings, const std::string& name)
{
    for (const auto& [phase, seconds] : timings.phases)
    {
        if (phase == name)
        {
            return seconds;
        }
    }
    return 0.0;
}

int run_attack(const AttackArgs& args, const GlobalArgs& global)
{
    AttackFileOptions options;
    options.seed = args.seed;
    options.threads = global.threads;
    options.force = args.force;
    // Phases and a running clock on a terminal, after the first second (remeshing or simplifying
    // a large mesh takes several); silent otherwise. The phases are the --json `seconds` keys.
    const AttackFileReport report =
        with_progress("meshmark attack", global.quiet, options.progress,
                      [&] { return attack_file(args.input, args.output, args.spec, options); });

    if (args.json)
    {
        print_json(attack_report_json(report, args.input, args.output));
    }
    if (!global.quiet)
    {
        std::fprintf(stderr,
                     "meshmark: attack %s (seed %llu): %lld vertices, %lld faces -> %lld vertices, "
                     "%lld faces in %.2f s (read %.2f, attack %.2f, write %.2f); wrote %s\n",
                     report.spec.c_str(), static_cast<unsigned long long>(args.seed),
                     static_cast<long long>(report.vertices_before),
                     static_cast<long long>(report.faces_before),
                     static_cast<long long>(report.vertices_after),
                     static_cast<long long>(report.faces_after), report.seconds.total,
                     phase_seconds(report.seconds, "read"), phase_seconds(report.seconds, "attack"),
                     phase_seconds(report.seconds, "write"), args.output.c_str());
        if (global.verbose && report.similarity)
        {
            std::fprintf(stderr, "meshmark: similarity applied (input -> output): %s\n",
                         matrix_json(*report.similarity).dump().c_str());
        }
    }
    return 0;
}

}  // namespace

void register_attack(CLI::App& app, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<AttackArgs>();
    auto* command = app.add_subcommand(
        "attack",
        "Apply a chain of attacks to a mesh (to test a watermark's robustness) and write the "
        "result (format from -o's extension).");
    command
        ->add_option("INPUT", args->input, "Mesh to attack (.ply .obj .off .stl .gltf .glb .3mf)")
        ->required();
    command
        ->add_option("SPEC", args->spec, "Attack chain, e.g. similarity,simplify=0.1,noise=0.001")
        ->required();
    command->add_option("-o,--output", args->output, "Attacked mesh to write (atomically)")
        ->required();
    command->add_option("--seed", args->seed, "Seed of every random choice of the chain")
        ->capture_default_str();
    command->add_flag("--force", args->force, "Allow -o to replace the input file");
    command->add_flag("--json", args->json,
                      "Print a JSON report on stdout (counts, canonical spec, the 4x4 similarity "
                      "applied or null, timings)");
    command->footer(grammar_help());
    add_global_flags(*command, global);
    command->callback([args, &global, &runner]()
                      { runner = [args, &global]() { return run_attack(*args, global); }; });
}

}  // namespace meshmark::cli
