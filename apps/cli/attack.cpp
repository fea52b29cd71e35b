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

namespace meshmark::cli {
namespace {

struct AttackArgs
{
    std::string input;
    std::string output;
    std::string spec;
    std::uint64_t seed = 0;
    bool force = false;
    bool json = false;
};

std::string number(double value) { return format_number(value, 6); }

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
    return "SPEC := STEP[,STEP]...  (applied left to right)   STEP := NAME[=LEVEL][:KEY=VALUE]...\n"
           "A missing level takes the default; [..] are the levels of the 3D mesh watermarking\n"
           "benchmark (Wang, Lavoue, Denis, Baskurt 2008).\n"
           "  similarity         random: uniform rotation, log-uniform scale in [1/smax, smax],\n"
           "                     bbox centre moved up to tmax bbox radii; keys smax=" +
           number(similarity.max_scale) + " tmax=" + number(similarity.max_translation_radii) +
           ".\n"
           "                     explicit (about the origin), identity where not given: axis=x|y|z\n"
           "                     or ax=,ay=,az= ; angle=DEG ; scale=S ; tx=,ty=,tz= ;\n"
           "                     mirror=x|y|z (mirrored first in that coordinate plane, as\n"
           "                     Blender's Mirror; the faces keep facing out)\n"
           "  noise=A            random displacement, A a fraction of the reference length\n"
           "                     (default " + number(noise.amplitude) +
           ") [0.0005 0.001 0.003 0.005 0.01]; keys dist=uniform|gaussian\n"
           "                     (uniform in [-a,a] or std a; default uniform), dir=iso|normal\n"
           "                     (default iso), ref=diag|centroid (bbox diagonal, default; or mean\n"
           "                     distance to the centroid, the benchmark's)\n"
           "  smooth=N           uniform Laplacian smoothing, N iterations (default " +
           std::to_string(smooth.iterations) + ") [5 10 30 50 100];\n"
           "                     key lambda=" + number(smooth.lambda) + "\n"
           "  taubin=N           Taubin lambda|mu smoothing, N step pairs (default " +
           std::to_string(taubin.iterations) + "); keys lambda=" + number(taubin.lambda) +
           " mu=" + number(taubin.mu) + "\n"
           "  quantize=B         coordinates snapped to 2^B levels over the bbox (default " +
           std::to_string(quantize.bits) + ") [7 8 9 10 11 12]\n"
           "  simplify=F         quadric edge collapse to fraction F of the vertices (default " +
           number(simplify.vertex_fraction) + ")\n"
           "                     [0.5 0.25 0.1 0.02 0.01]; key policy=gh|lt (Garland-Heckbert,\n"
           "                     default; Lindstrom-Turk); key boundary=" + number(simplify.boundary_weight) +
           " (gh: weight of the\n"
           "                     border quadrics; 1 = Open3D's and MeshLab's default)\n"
           "  remesh=F           isotropic remeshing to fraction F of the vertices, F <= 1 (default " +
           number(remesh.vertex_fraction) + ")\n"
           "                     [0.25 0.05]; key iter=" + std::to_string(remesh.iterations) +
           " (iterations per pass)\n"
           "  subdivide=S        S = loop|midpoint|sqrt3 (default loop); key steps=1\n"
           "  crop=F             plane cut keeping fraction F of the vertices (default " +
           number(crop.vertex_fraction) + ") [0.9 0.7 0.5];\n"
           "                     keys axis=x|y|z or ax=,ay=,az= (normal towards the removed side;\n"
           "                     random from the seed if absent)\n"
           "  reorder            random permutation of the vertices and of the faces\n"
           "  voxel=N            voxel remesh as in Blender (OpenVDB, adaptivity 0): the surface\n"
           "                     re-extracted from a signed-distance grid of voxel edge D/N, D the\n"
           "                     bbox diagonal (default " +
           number(voxel.resolution) + ") [300 150], N in [10, 2000];\n"
           "                     Blender's Voxel Size is D/N in object units. The result is closed;\n"
           "                     detail below a voxel, thin parts and inner surfaces are lost.\n"
           "                     OpenVDB is a plugin: <prefix>/lib/meshmark/libmeshmark_voxel.so for\n"
           "                     <prefix>/bin/meshmark, or MESHMARK_PLUGIN_DIR (then only there);\n"
           "                     without it, voxel steps exit with code 5\n"
           "Step k draws from its own stream, derived from --seed, its position and its name.\n"
           "Simplify, remesh, subdivide and voxel need faces; the first three cut non-manifold edges\n"
           "and vertices apart and drop unused vertices first. Crop drops the vertices it leaves unused.\n"
           "Example: meshmark attack in.ply -o out.ply --seed 3 similarity,simplify=0.1,noise=0.001";
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
    const AttackFileReport report = with_progress("meshmark attack", global.quiet, options.progress, [&] {
        return attack_file(args.input, args.output, args.spec, options);
    });

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
                     static_cast<long long>(report.vertices_before), static_cast<long long>(report.faces_before),
                     static_cast<long long>(report.vertices_after), static_cast<long long>(report.faces_after),
                     report.seconds.total, phase_seconds(report.seconds, "read"),
                     phase_seconds(report.seconds, "attack"), phase_seconds(report.seconds, "write"),
                     args.output.c_str());
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
    command->add_option("INPUT", args->input, "Mesh to attack (.ply .obj .off .stl .gltf .glb .3mf)")
        ->required();
    command->add_option("SPEC", args->spec, "Attack chain, e.g. similarity,simplify=0.1,noise=0.001")
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
    command->callback([args, &global, &runner]() {
        runner = [args, &global]() { return run_attack(*args, global); };
    });
}

}  // namespace meshmark::cli
