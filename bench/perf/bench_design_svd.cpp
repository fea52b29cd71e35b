// SPDX-License-Identifier: MIT
// The SVD of a resampled suspect's design (watermark/nuisance.cpp, solve_jointly), side by side:
// Eigen's one-sided Jacobi SVD against its divide-and-conquer SVD (the one used), on designs of
// the shapes detection meets (3r rows for 3M + q columns: 276 x 250 for a furniture model traced
// against its recipients, 297 x 130 for the bunny's owner mark, 1,200 x 250 for a large basis).
#include <Eigen/SVD>
#include <benchmark/benchmark.h>

#include "meshmark/core/rng.h"

namespace
{

// A design like detection's: columns of very different scales, rescaled to unit norm as
// solve_jointly does before its decomposition.
Eigen::MatrixXd design(Eigen::Index rows, Eigen::Index cols)
{
    meshmark::Rng rng(3);
    Eigen::MatrixXd a(rows, cols);
    for (Eigen::Index c = 0; c < cols; ++c)
    {
        for (Eigen::Index r = 0; r < rows; ++r)
        {
            a(r, c) = rng.normal();
        }
    }
    a.colwise().normalize();
    return a;
}

template <typename Svd>
void BM_DesignSvd(benchmark::State& state)
{
    const Eigen::MatrixXd a = design(state.range(0), state.range(1));
    for (auto _ : state)
    {
        const Svd svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
        benchmark::DoNotOptimize(svd.singularValues().data());
    }
}

void shapes(benchmark::internal::Benchmark* b)
{
    b->ArgNames({"rows", "cols"})
        ->Args({276, 250})
        ->Args({297, 130})
        ->Args({1200, 250})
        ->Unit(benchmark::kMillisecond);
}

BENCHMARK(BM_DesignSvd<Eigen::JacobiSVD<Eigen::MatrixXd>>)
    ->Name("BM_DesignSvd/jacobi")
    ->Apply(shapes);
BENCHMARK(BM_DesignSvd<Eigen::BDCSVD<Eigen::MatrixXd>>)->Name("BM_DesignSvd/bdc")->Apply(shapes);

}  // namespace
