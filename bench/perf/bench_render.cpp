// SPDX-License-Identifier: MIT
// The distance picture (render_heatmap: projection, vertex normals, rasterization at 2x2
// supersampling, shading, colour bar) of the full-resolution Stanford dragon (437,645 vertices,
// 871,414 triangles; read from $MESHMARK_MESH_DIR or ../shared/data/meshes, skipped when
// missing) and of a generated 1M-vertex torus, at 1024x768; PNG encoding separately.
#include <cstdlib>
#include <filesystem>
#include <optional>

#include <benchmark/benchmark.h>

#include "bench_mesh.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/render/heatmap_image.h"

namespace
{

using namespace meshmark;

struct Scene
{
    TriangleMesh mesh;
    Eigen::VectorXd distances;
};

Scene scene_of(TriangleMesh mesh)
{
    // Any smooth field will do: the distance to the bounding box's centre plane.
    Scene s{std::move(mesh), {}};
    s.distances = (s.mesh.V.col(1).array() - s.mesh.V.col(1).mean()).abs();
    return s;
}

const std::optional<Scene>& dragon()
{
    static const std::optional<Scene> scene = []() -> std::optional<Scene>
    {
        const char* env = std::getenv("MESHMARK_MESH_DIR");
        const std::filesystem::path file =
            std::filesystem::path(env != nullptr ? env : MESHMARK_BENCH_MESH_DIR) /
            "dragon_vrip.ply";
        if (!std::filesystem::exists(file))
        {
            return std::nullopt;
        }
        return scene_of(read_mesh(file));
    }();
    return scene;
}

const Scene& torus()
{
    static const Scene scene = scene_of(cli::bumpy_torus(1'000'000));
    return scene;
}

void run(benchmark::State& state, const Scene& scene)
{
    HeatmapImageOptions options;
    options.threads = static_cast<int>(state.range(0));
    for (auto _ : state)
    {
        benchmark::DoNotOptimize(render_heatmap(scene.mesh, scene.distances, options));
    }
    state.counters["vertices"] = static_cast<double>(scene.mesh.vertex_count());
    state.counters["faces"] = static_cast<double>(scene.mesh.face_count());
}

void BM_RenderHeatmapDragon(benchmark::State& state)
{
    if (!dragon())
    {
        state.SkipWithError("dragon_vrip.ply not found (set MESHMARK_MESH_DIR)");
        return;
    }
    run(state, *dragon());
}
BENCHMARK(BM_RenderHeatmapDragon)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond);

void BM_RenderHeatmapTorus1M(benchmark::State& state)
{
    run(state, torus());
}
BENCHMARK(BM_RenderHeatmapTorus1M)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond);

void BM_EncodePng(benchmark::State& state)
{
    const RgbImage image = render_heatmap(torus().mesh, torus().distances).image;
    for (auto _ : state)
    {
        benchmark::DoNotOptimize(encode_png(image));
    }
}
BENCHMARK(BM_EncodePng)->Unit(benchmark::kMillisecond);

}  // namespace
