// SPDX-License-Identifier: MIT
// The two streaming passes of the RBF basis (docs/algorithms/basis.md) on generated surfaces of
// 10K, 100K and 1M vertices, k = 100, 1 and 2 threads:
//   BM_BasisPass  RbfBasis construction (pass 1: Gram matrix, then the k x k eigenproblem);
//   BM_Synthesis  synthesize() of m = 8 modes (pass 2), with the orthogonality check as embed
//                 runs it;
//   BM_ProjectDesign  project_design() as detect's resampled extraction runs it.
#include <cstdint>
#include <map>
#include <numeric>
#include <span>
#include <vector>

#include <benchmark/benchmark.h>

#include "bench_mesh.h"
#include "meshmark/basis/rbf_basis.h"
#include "meshmark/core/bounding_box.h"

namespace
{

using namespace meshmark;

constexpr int kBasisSize = 100;
constexpr int kModes = 8;

struct Setup
{
    TriangleMesh mesh;
    std::vector<std::int32_t> active;
    std::vector<std::int32_t> centers;
    double sigma = 0.0;
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();
};

// One generated surface per size, shared by all benchmarks of that size.
const Setup& setup_for(std::int64_t vertices)
{
    static std::map<std::int64_t, Setup> cache;
    auto it = cache.find(vertices);
    if (it != cache.end())
    {
        return it->second;
    }
    Setup s;
    s.mesh = cli::bumpy_torus(vertices);
    s.active.resize(static_cast<std::size_t>(s.mesh.V.rows()));
    std::iota(s.active.begin(), s.active.end(), 0);
    s.centers = random_centers(s.mesh.V, s.active, kBasisSize, 42);
    s.sigma = bounding_box(s.mesh.V, s.active).diagonal() / 2.0;  // sigma factor 1, as embed
    s.origin = s.mesh.V.colwise().mean().transpose();
    return cache.emplace(vertices, std::move(s)).first->second;
}

void BM_BasisPass(benchmark::State& state)
{
    const Setup& s = setup_for(state.range(0));
    const auto threads = static_cast<int>(state.range(1));
    for (auto _ : state)
    {
        const RbfBasis basis(position_rows(s.mesh.V, s.active), s.centers, s.sigma, s.origin,
                             threads);
        benchmark::DoNotOptimize(basis.singular_values().data());
    }
    state.counters["vertices"] = static_cast<double>(s.mesh.V.rows());
    state.counters["us_per_vertex"] = benchmark::Counter(
        static_cast<double>(s.mesh.V.rows()) * 1e-6,
        benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void BM_Synthesis(benchmark::State& state)
{
    const Setup& s = setup_for(state.range(0));
    const auto threads = static_cast<int>(state.range(1));
    const RbfBasis basis(position_rows(s.mesh.V, s.active), s.centers, s.sigma, s.origin, threads);
    const Eigen::MatrixX3d change = Eigen::MatrixX3d::Constant(kModes, 3, 1e-3);
    for (auto _ : state)
    {
        double orthogonality = 0.0;
        const Positions field = basis.synthesize(change, &orthogonality);
        benchmark::DoNotOptimize(field.data());
        benchmark::DoNotOptimize(orthogonality);
    }
    state.counters["vertices"] = static_cast<double>(s.mesh.V.rows());
    state.counters["us_per_vertex"] = benchmark::Counter(
        static_cast<double>(s.mesh.V.rows()) * 1e-6,
        benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// The resampled extraction's normal system (watermark.cpp, extract_resampled): U_r^T X for a
// design of 81 columns (6 x 8 sampling products, 3 x 11 nuisance and observation columns) built
// per row block over the well-conditioned modes (~95 on real meshes), 8 of them handed to the
// fill.
void BM_ProjectDesign(benchmark::State& state)
{
    const Setup& s = setup_for(state.range(0));
    const auto threads = static_cast<int>(state.range(1));
    const RbfBasis basis(position_rows(s.mesh.V, s.active), s.centers, s.sigma, s.origin, threads);
    const int modes = basis.well_conditioned_modes(1e-8);  // as the extraction chooses them
    constexpr std::size_t kWidth = 81;
    const auto fill = [&](std::span<const std::int32_t> rows, const double* U, double* X)
    {
        for (std::size_t a = 0; a < rows.size(); ++a)
        {
            const auto i = rows[a];
            for (std::size_t c = 0; c < kWidth; ++c)
            {
                X[a * kWidth + c] =
                    U[a * kModes + c % kModes] * s.mesh.V(i, static_cast<Eigen::Index>(c % 3));
            }
        }
    };
    for (auto _ : state)
    {
        const Eigen::MatrixXd system = basis.project_design(modes, kModes, kWidth, fill);
        benchmark::DoNotOptimize(system.data());
    }
    state.counters["vertices"] = static_cast<double>(s.mesh.V.rows());
    state.counters["us_per_vertex"] = benchmark::Counter(
        static_cast<double>(s.mesh.V.rows()) * 1e-6,
        benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void sizes_and_threads(benchmark::internal::Benchmark* b)
{
    for (const std::int64_t n : {10'000, 100'000, 1'000'000})
    {
        for (const std::int64_t t : {1, 2})
        {
            b->Args({n, t});
        }
    }
    b->ArgNames({"n", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

}  // namespace

BENCHMARK(BM_BasisPass)->Apply(sizes_and_threads);
BENCHMARK(BM_Synthesis)->Apply(sizes_and_threads);
BENCHMARK(BM_ProjectDesign)->Apply(sizes_and_threads);
