// SPDX-License-Identifier: MIT
// `meshmark demo`: the whole story on a mesh the program makes itself, no external data.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <unistd.h>

#include "commands.h"
#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/metrics/distortion.h"
#include "meshmark/pipeline/detect_file.h"
#include "meshmark/pipeline/embed_file.h"
#include "meshmark/render/heatmap_image.h"
#include "report.h"

namespace meshmark::cli
{
namespace
{

struct DemoArgs
{
    std::string dir;
    int subdivisions = 6;
    std::string attack = "noise=0.001,smooth=10";
};

void say(const GlobalArgs& global, const std::string& line)
{
    if (!global.quiet)
    {
        std::printf("%s\n", line.c_str());
        std::fflush(stdout);
    }
}

std::string verdict(const DetectReport& r)
{
    const auto& d = r.decision;
    return std::string(d.is_present ? "FOUND" : "not found") +
           " (R = " + format_number(d.correlation) + ", " + std::to_string(d.matches) + "/" +
           std::to_string(d.bit_count) + " bits, false-positive probability " +
           format_number(d.false_positive_probability) + ")";
}

int run_demo(const DemoArgs& args, const GlobalArgs& global)
{
    namespace fs = std::filesystem;
    const fs::path dir = args.dir.empty() ? fs::temp_directory_path() /
                                                ("meshmark-demo-" + std::to_string(::getpid()))
                                          : fs::path(args.dir);
    fs::create_directories(dir);
    const auto original = dir / "original.ply";
    const auto marked = dir / "marked.ply";
    const auto attacked = dir / "attacked.ply";
    const auto key = dir / "key.json";
    const auto heatmap = dir / "heatmap.png";

    // 1. A model of our own: a lumpy ellipsoid.
    const TriangleMesh mesh = lumpy_ellipsoid(args.subdivisions);
    write_mesh(original, mesh);
    say(global, "1. made " + original.string() + " (" + std::to_string(mesh.vertex_count()) +
                    " vertices, " + std::to_string(mesh.face_count()) + " triangles)");

    // 2. Watermark it with the default settings.
    EmbedFileOptions embed_options;
    embed_options.message = "meshmark demo";
    embed_options.seed = 20261122;
    embed_options.threads = global.threads;
    embed_options.force = true;
    const EmbedReport embedded = embed_file(original, marked, key, embed_options);
    say(global, "2. embedded '" + *embed_options.message + "' (" +
                    std::to_string(embedded.key.payload.size()) + " bits) into " + marked.string() +
                    ": surface distance RMS " +
                    format_number(100.0 * embedded.stats.surface_rms_rel) +
                    "% (vertex displacement RMS " +
                    format_number(100.0 * embedded.stats.rms_displacement_rel) +
                    "%) of the bbox diagonal, " + format_number(embedded.seconds.total) +
                    " s; key in " + key.string());

    // A picture of the mark: each marked vertex's distance to the original surface, blue (none)
    // to red (the largest): what `compare original marked --heatmap` draws, the same figures.
    const TriangleMesh marked_mesh = read_mesh(marked);
    CompareOptions distance_options;
    distance_options.keep_vertex_distances = true;
    distance_options.threads = global.threads;
    const DistortionReport distances = compare_meshes(mesh, marked_mesh, distance_options);
    HeatmapImageOptions picture_options;
    picture_options.unit_length = distances.diagonal;
    picture_options.threads = global.threads;
    const HeatmapPicture picture =
        render_heatmap(marked_mesh, distances.vertex_distances_ba, picture_options);
    write_png(heatmap, picture.image);
    say(global, "   picture of the mark: " + heatmap.string() +
                    " (each vertex's distance to the original surface, blue 0 to red " +
                    format_number(100.0 * picture.max_distance / picture.unit_length) +
                    "% of the bbox diagonal)");

    // 3. Perturb the marked copy.
    const auto specs = parse_attack_spec(args.attack);
    const AttackResult result = apply_attacks(marked_mesh, specs, 7, global.threads);
    write_mesh(attacked, result.mesh);
    say(global, "3. attacked it with '" + to_string(specs) + "' -> " + attacked.string());

    // 4. Detect in the attacked copy, and check that the unmarked original is not claimed.
    DetectFileOptions detect_options;
    detect_options.threads = global.threads;
    const DetectReport found = detect_file(attacked, original, key, detect_options);
    say(global, "4. detect in the attacked copy: watermark " + verdict(found));
    const DetectReport clean = detect_file(original, original, key, detect_options);
    say(global, "5. detect in the unmarked original: watermark " + verdict(clean));

    const bool as_expected = found.decision.is_present && !clean.decision.is_present;
    say(global, as_expected
                    ? "Verdict: ownership proven for the attacked copy; the unmarked original is "
                      "not claimed."
                    : "Verdict: UNEXPECTED result (see above).");
    return as_expected ? 0 : 1;
}

}  // namespace

void register_demo(CLI::App& app, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<DemoArgs>();
    auto* command = app.add_subcommand(
        "demo",
        "Make a mesh, embed, draw the mark (heatmap.png, as compare --heatmap), attack, detect; "
        "exit 0 when all goes as expected");
    command->add_option("--dir", args->dir,
                        "Folder for the demo's files (default: a new temporary folder)");
    command
        ->add_option("--subdivisions", args->subdivisions,
                     "Size of the demo mesh: 10*4^s+2 vertices (6 gives 40,962)")
        ->check(CLI::Range(3, 9))
        ->capture_default_str();
    command
        ->add_option("--attack", args->attack,
                     "Attack chain applied to the marked copy (see `attack --help`)")
        ->capture_default_str();
    add_global_flags(*command, global);
    command->callback([args, &global, &runner]()
                      { runner = [args, &global]() { return run_demo(*args, global); }; });
}

}  // namespace meshmark::cli
