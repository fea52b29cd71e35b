// SPDX-License-Identifier: MIT
// meshmark.compare: `meshmark compare A B --json`, with its heatmap (a colored PLY or a PNG
// picture, written by the library's write_distance_heatmap, as the program writes it).
#include <chrono>
#include <optional>
#include <string>

#include <pybind11/stl.h>

#include "bindings.h"
#include "convert.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/core/length_unit.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/metrics/distortion.h"
#include "meshmark/pipeline/report_json.h"
#include "meshmark/render/view.h"
#include "meshmark/report/compare_heatmap.h"
#include "typed.h"

namespace meshmark::python
{
namespace
{

using Path = std::filesystem::path;
using Text = std::optional<std::string>;

constexpr const char* kCompareDoc =
    R"(Distortion between two mesh files: `meshmark compare A B --json`.

Hausdorff, RMS, MRMS (and the displacement when they share connectivity), relative to the
bounding-box diagonal of a. Returns the program's JSON report as a dict. Keywords (the
options of `meshmark compare`):
  samples    area samples per surface on top of the vertices; 0 = automatic
  seed       seed of the stratified sampling
  heatmap    a .png file (a picture of b) or a .ply file (b with per-vertex colors): b colored
             by each vertex's distance to a's surface, blue 0 to red the largest; the same
             bytes as `meshmark compare --heatmap`. The report then has 'heatmap'.
  view, size, up  of a .png heatmap: a view name or 'AZIMUTH,ELEVATION', 'WIDTHxHEIGHT',
             b's up axis ('y', 'z', 'x', '-y', ...)
  unit       unit of a's coordinates (um mm cm m in ft), overriding its file's; the report
             then has 'in_unit' (also when a's file states a unit)
  threads    0 = all cores (the result does not depend on it)
Raises meshmark.InvalidOption for bad options, IoError, InvalidMesh.)";

// The picture's options, checked as the program checks --heatmap, --view, --size and --up.
HeatmapImageOptions heatmap_options(const std::optional<Path>& heatmap, const Path& a,
                                    const Path& b, const Text& view, const Text& size,
                                    const Text& up)
{
    const bool png = heatmap && heatmap_file_kind(*heatmap, "heatmap") == HeatmapFile::Png;
    HeatmapImageOptions image;
    if (!png)
    {
        for (const auto& [name, value] :
             {std::pair{"view", &view}, std::pair{"size", &size}, std::pair{"up", &up}})
        {
            if (*value)
            {
                throw InvalidOption(std::string("compare: ") + name +
                                    " applies to a .png heatmap only.");
            }
        }
    }
    if (!heatmap)
    {
        return image;
    }
    if (is_same_file(*heatmap, a) || is_same_file(*heatmap, b))
    {
        throw InvalidOption("compare: heatmap " + heatmap->string() +
                            " would overwrite an input mesh.");
    }
    try
    {
        if (view)
        {
            image.view = parse_view(*view);
        }
        if (size)
        {
            image.size = parse_image_size(*size);
        }
        if (up)
        {
            image.up = parse_up_axis(*up);
        }
    }
    catch (const InvalidOption& e)
    {
        throw InvalidOption(std::string("compare: ") + e.what());
    }
    return image;
}

}  // namespace

void bind_compare(py::module_& m)
{
    m.def(
        "compare",
        [](const Path& a_path, const Path& b_path, std::int64_t samples, const SeedInt& seed,
           const OptionalPath& heatmap_arg, const OptionalStr& view_arg,
           const OptionalStr& size_arg, const OptionalStr& up_arg, const OptionalStr& unit_arg,
           int threads) -> Report
        {
            const std::optional<Path> heatmap = path_from(heatmap_arg.handle(), "heatmap");
            const Text view = text_from(view_arg.handle(), "view");
            const Text size = text_from(size_arg.handle(), "size");
            const Text up = text_from(up_arg.handle(), "up");
            const Text unit = text_from(unit_arg.handle(), "unit");
            CompareOptions options;
            options.samples = samples;
            options.seed = seed_from(seed.handle()).value_or(0);
            options.threads = threads;
            options.keep_vertex_distances = heatmap.has_value();
            const HeatmapImageOptions image =
                heatmap_options(heatmap, a_path, b_path, view, size, up);
            const std::optional<LengthUnit> given_unit =
                unit ? std::optional<LengthUnit>(parse_length_unit(*unit)) : std::nullopt;
            nlohmann::json out;
            {
                py::gil_scoped_release release;
                using Clock = std::chrono::steady_clock;
                const auto start = Clock::now();
                const auto since = [](Clock::time_point t)
                { return std::chrono::duration<double>(Clock::now() - t).count(); };
                MeshFile a_file = read_mesh_file(a_path);
                const std::optional<LengthUnit> a_unit = given_unit ? given_unit : a_file.unit;
                const bool unit_from_file = !given_unit && a_unit.has_value();
                const TriangleMesh a = std::move(a_file.mesh);
                a_file = MeshFile{};
                const TriangleMesh b = read_mesh(b_path);
                const double read_seconds = since(start);
                const DistortionReport report = compare_meshes(a, b, options);
                double heatmap_seconds = 0.0;
                double heatmap_max = 0.0;
                if (heatmap)
                {
                    const auto phase = Clock::now();
                    heatmap_max = write_distance_heatmap(*heatmap, b, report.vertex_distances_ba,
                                                         image, report.diagonal, threads);
                    heatmap_seconds = since(phase);
                }
                out = compare_report_json(a_path.string(), b_path.string(), a, b, report,
                                          options.seed);
                complete_compare_json(out, report, a_unit, unit_from_file,
                                      heatmap ? heatmap->string() : std::string(), heatmap_max,
                                      {read_seconds, heatmap_seconds, since(start)});
            }
            return to_python(out);
        },
        py::arg("a"), py::arg("b"), py::kw_only(), py::arg("samples") = 0, py::arg("seed") = 0,
        py::arg("heatmap") = py::none(), py::arg("view") = py::none(), py::arg("size") = py::none(),
        py::arg("up") = py::none(), py::arg("unit") = py::none(), py::arg("threads") = 0,
        kCompareDoc);
}

}  // namespace meshmark::python
