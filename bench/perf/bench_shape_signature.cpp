// SPDX-License-Identifier: MIT
// The catalogue's shape index: an original's signature (shape_signature: the draw on the
// surface, then the whole and 256 crop views; every `catalog add` computes one) and a suspect's
// features (shape_features: the whole view; every `catalog scan` computes one), on generated
// tori of 3K, 30K and 300K vertices.
#include <map>

#include <benchmark/benchmark.h>

#include "bench_mesh.h"
#include "meshmark/geometry/shape_signature.h"

namespace
{

using namespace meshmark;

const TriangleMesh& mesh_of(std::int64_t vertices)
{
    static std::map<std::int64_t, TriangleMesh> meshes;
    auto found = meshes.find(vertices);
    if (found == meshes.end())
    {
        found = meshes.emplace(vertices, cli::bumpy_torus(vertices)).first;
    }
    return found->second;
}

void BM_ShapeSignature(benchmark::State& state)
{
    const TriangleMesh& mesh = mesh_of(state.range(0));
    for (auto _ : state)
    {
        benchmark::DoNotOptimize(shape_signature(mesh).views.data());
    }
}

void BM_ShapeFeatures(benchmark::State& state)
{
    const TriangleMesh& mesh = mesh_of(state.range(0));
    for (auto _ : state)
    {
        benchmark::DoNotOptimize(shape_features(mesh).data());
    }
}

BENCHMARK(BM_ShapeSignature)
    ->ArgName("vertices")
    ->Arg(3'000)
    ->Arg(30'000)
    ->Arg(300'000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ShapeFeatures)
    ->ArgName("vertices")
    ->Arg(3'000)
    ->Arg(30'000)
    ->Arg(300'000)
    ->Unit(benchmark::kMillisecond);

}  // namespace
