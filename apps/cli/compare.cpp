// SPDX-License-Identifier: MIT
// `meshmark compare`: distortion metrics between two meshes, and an optional distance heatmap.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "commands.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/metrics/distortion.h"
#include "meshmark/pipeline/report_json.h"
#include "meshmark/render/heatmap_image.h"
#include "meshmark/report/compare_heatmap.h"
#include "progress.h"
#include "report.h"

namespace meshmark::cli
{
namespace
{

struct CompareArgs
{
    std::string a;
    std::string b;
    bool json = false;
    std::string heatmap;
    std::string view;  // of a .png heatmap; empty = the default
    std::string size;  // of a .png heatmap, WxH; empty = the default
    std::string up;    // of a .png heatmap: the model's up axis; empty = +Y
    std::string unit;  // --unit: A's coordinates' unit
    CompareOptions options;
};

// A's coordinates' unit: --unit, else the file's; the flag says which.
struct CompareUnit
{
    std::optional<LengthUnit> unit;
    bool is_from_file = false;
};

double seconds_since(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

enum class HeatmapKind
{
    None,
    Ply,  // B with per-vertex colors
    Png,  // a picture of B
};

HeatmapKind heatmap_kind(const std::string& path)
{
    if (path.empty())
    {
        return HeatmapKind::None;
    }
    return heatmap_file_kind(path) == HeatmapFile::Png ? HeatmapKind::Png : HeatmapKind::Ply;
}

// The heatmap is a colored PLY or a PNG picture, and never replaces an input; --view and
// --size describe the picture. Returns the picture's options (unused for a PLY).
HeatmapImageOptions check_heatmap_args(const CompareArgs& args)
{
    const HeatmapKind kind = heatmap_kind(args.heatmap);
    HeatmapImageOptions image;
    if (kind != HeatmapKind::Png)
    {
        for (const auto& [name, value] :
             {std::pair{"--view", &args.view}, std::pair{"--size", &args.size},
              std::pair{"--up", &args.up}})
        {
            if (!value->empty())
            {
                throw InvalidOption(std::string("compare: ") + name +
                                    " applies to a .png --heatmap only.");
            }
        }
    }
    if (kind == HeatmapKind::None)
    {
        return image;
    }
    const std::filesystem::path out(args.heatmap);
    if (is_same_file(out, args.a) || is_same_file(out, args.b))
    {
        throw InvalidOption("compare: --heatmap " + args.heatmap +
                            " would overwrite an input mesh.");
    }
    try
    {
        if (!args.view.empty())
        {
            image.view = parse_view(args.view);
        }
        if (!args.size.empty())
        {
            image.size = parse_image_size(args.size);
        }
        if (!args.up.empty())
        {
            image.up = parse_up_axis(args.up);
        }
    }
    catch (const InvalidOption& e)
    {
        throw InvalidOption(std::string("compare: ") + e.what());
    }
    return image;
}

void print_text(const CompareArgs& args, const TriangleMesh& a, const TriangleMesh& b,
                const DistortionReport& r, const CompareUnit& unit)
{
    // "0.27%", or "0.27% (0.81 mm)" in A's unit when it is known.
    const auto pct = [&](double rel)
    {
        std::string text = format_number(100.0 * rel, 4) + "%";
        if (unit.unit)
        {
            text += " (" + format_length(rel * r.diagonal, *unit.unit) + ")";
        }
        return text;
    };
    std::printf("A: %s (%lld vertices, %lld triangles)\nB: %s (%lld vertices, %lld triangles)\n",
                args.a.c_str(), static_cast<long long>(a.vertex_count()),
                static_cast<long long>(a.face_count()), args.b.c_str(),
                static_cast<long long>(b.vertex_count()), static_cast<long long>(b.face_count()));
    const std::string diagonal =
        unit.unit ? format_number(r.diagonal, 6) + " " + to_string(*unit.unit) +
                        (unit.is_from_file ? ", the unit A's file states" : ", --unit")
                  : format_number(r.diagonal, 6) + ", no unit known: see --unit";
    std::printf("distances in %% of the bounding-box diagonal of A (%s):\n", diagonal.c_str());
    std::printf("  Hausdorff     %s  (A->B %s, B->A %s)\n", pct(r.hausdorff_rel).c_str(),
                pct(r.hausdorff_ab_rel).c_str(), pct(r.hausdorff_ba_rel).c_str());
    std::printf("  RMS           A->B %s, B->A %s\n", pct(r.rms_ab_rel).c_str(),
                pct(r.rms_ba_rel).c_str());
    std::printf("  MRMS          %s\n", pct(r.mrms_rel).c_str());
    if (r.displacement)
    {
        std::printf("  displacement  max %s, RMS %s (same connectivity)\n",
                    pct(r.max_displacement_rel).c_str(), pct(r.rms_displacement_rel).c_str());
    }
    std::printf("samples: A %lld vertices + %lld on faces, B %lld vertices + %lld on faces\n",
                static_cast<long long>(r.a_to_b.vertex_samples),
                static_cast<long long>(r.a_to_b.area_samples),
                static_cast<long long>(r.b_to_a.vertex_samples),
                static_cast<long long>(r.b_to_a.area_samples));
}

int run_compare(const CompareArgs& args, const GlobalArgs& global)
{
    const auto start = std::chrono::steady_clock::now();
    const HeatmapImageOptions image_options = check_heatmap_args(args);
    const std::optional<LengthUnit> given_unit =
        args.unit.empty() ? std::nullopt : std::optional<LengthUnit>(parse_length_unit(args.unit));
    const bool png = heatmap_kind(args.heatmap) == HeatmapKind::Png;
    // Phases and a running clock on a terminal, after the first second (as embed and detect);
    // silent otherwise. The phases are the --json `seconds` keys.
    std::optional<PhaseProgress> progress;
    ProgressCallback report_phase = [](std::string_view, double) {};
    if (PhaseProgress::should_show(global.quiet))
    {
        progress.emplace(PhaseProgressOptions{"meshmark compare"});
        report_phase = progress->callback();
    }

    // Read both meshes, then measure.
    report_phase("read", 0.0);
    CompareUnit unit;
    MeshFile a_file = read_mesh_file(args.a);
    unit.unit = given_unit ? given_unit : a_file.unit;
    unit.is_from_file = args.unit.empty() && unit.unit.has_value();
    const TriangleMesh a = std::move(a_file.mesh);
    a_file = MeshFile{};  // the file's bytes are not needed any more
    const TriangleMesh b = read_mesh(args.b);
    const double read_seconds = seconds_since(start);
    report_phase("read", 1.0);
    CompareOptions options = args.options;
    options.threads = global.threads;
    options.keep_vertex_distances = !args.heatmap.empty();
    options.progress = report_phase;
    const DistortionReport report = compare_meshes(a, b, options);

    // Optional heatmap of B's vertices.
    double heatmap_seconds = 0.0;
    double heatmap_max = 0.0;
    if (!args.heatmap.empty())
    {
        report_phase("heatmap", 0.0);
        const auto phase = std::chrono::steady_clock::now();
        heatmap_max = write_distance_heatmap(args.heatmap, b, report.vertex_distances_ba,
                                             image_options, report.diagonal, global.threads);
        heatmap_seconds = seconds_since(phase);
        report_phase("heatmap", 1.0);
    }
    if (progress)
    {
        progress->finish();
    }

    if (args.json)
    {
        nlohmann::json out = compare_report_json(args.a, args.b, a, b, report, args.options.seed);
        complete_compare_json(out, report, unit.unit, unit.is_from_file, args.heatmap, heatmap_max,
                              {read_seconds, heatmap_seconds, seconds_since(start)});
        print_json(out);
        return 0;
    }
    print_text(args, a, b, report, unit);
    if (!args.heatmap.empty())
    {
        const std::string seen =
            png ? ", seen from azimuth " + format_number(image_options.view.azimuth_deg, 4) +
                      ", elevation " + format_number(image_options.view.elevation_deg, 4) + " (" +
                      std::to_string(image_options.size.width) + "x" +
                      std::to_string(image_options.size.height) + ")"
                : "";
        std::printf(
            "heatmap: %s (B colored by distance to A%s: blue 0, red %s%% of the diagonal)\n",
            args.heatmap.c_str(), seen.c_str(),
            format_number(100.0 * heatmap_max / report.diagonal, 4).c_str());
    }
    if (!global.quiet)
    {
        std::fprintf(stderr,
                     "meshmark compare: %.2f s (read %.2f, index %.2f, A->B %.2f, B->A %.2f)\n",
                     seconds_since(start), read_seconds, report.seconds.index,
                     report.seconds.a_to_b, report.seconds.b_to_a);
    }
    return 0;
}

}  // namespace

void register_compare(CLI::App& app, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<CompareArgs>();
    auto* command = app.add_subcommand(
        "compare",
        "Distortion between two meshes, surface to surface, in % of A's bbox diagonal: Hausdorff, "
        "RMS, MRMS (docs/cli.md)");
    command->add_option("A", args->a, "Reference mesh (defines the unit)")
        ->required()
        ->check(CLI::ExistingFile);
    command->add_option("B", args->b, "Mesh compared with A")->required()->check(CLI::ExistingFile);
    command->add_flag("--json", args->json,
                      "Print one JSON object on stdout (fields: docs/cli.md)");
    command->add_option(
        "--heatmap", args->heatmap,
        "Color B by each vertex's distance to A's surface, blue 0 to red the largest: FILE.png "
        "(a picture) or FILE.ply");
    command->add_option(
        "--view", args->view,
        std::string("View of a .png heatmap: ") + kViewNames + ", or AZIMUTH,ELEVATION in degrees");
    command->add_option(
        "--up", args->up,
        "Up axis of B in a .png heatmap: y (default), z (Blender, CAD, print), x, -y, -z, -x");
    command->add_option("--size", args->size,
                        "Size of a .png heatmap in pixels, WIDTHxHEIGHT (default 1024x768; " +
                            std::to_string(kMinImageSide) + " to " + std::to_string(kMaxImageSide) +
                            " per side)");
    command
        ->add_option("--samples", args->options.samples,
                     "Area samples per surface on top of the vertices; 0 = automatic (" +
                         std::to_string(kAutoSamplesPerFace) + " per triangle, " +
                         std::to_string(kMinAutoSamples) + " to " +
                         std::to_string(kMaxAutoSamples) + ")")
        ->check(CLI::Range(std::int64_t{0}, std::int64_t{1'000'000'000}))
        ->capture_default_str();
    command->add_option("--seed", args->options.seed, "Seed of the stratified sampling")
        ->capture_default_str();
    command->add_option(
        "--unit", args->unit,
        "Unit of A's coordinates (um mm cm m in ft), overriding its file's; distances are also "
        "given in it");
    add_global_flags(*command, global);
    command->callback([args, &global, &runner]()
                      { runner = [args, &global]() { return run_compare(*args, global); }; });
}

}  // namespace meshmark::cli
