// SPDX-License-Identifier: MIT
#include "meshmark/attacks/smoothing.h"

#include <cmath>
#include <initializer_list>
#include <string>
#include <utility>

#include "attacks/detail/format.h"
#include "attacks/detail/sampling.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/adjacency.h"

namespace meshmark
{
namespace
{

// Largest iteration count accepted: 1000 times the benchmark's largest level (100), a bound
// against typing errors; chosen by hand; no study on record.
constexpr int kMaxIterations = 100000;
// Below this many vertices a step takes microseconds and a parallel region costs more than it
// saves (much more on a loaded machine, where a descheduled thread stalls every barrier).
constexpr Eigen::Index kParallelMinimum = 20000;

void check_iterations(const char* attack, int iterations)
{
    if (iterations < 0 || iterations > kMaxIterations)
    {
        throw InvalidOption(std::string(attack) + ": iterations " + std::to_string(iterations) +
                            " is outside 0.." + std::to_string(kMaxIterations) + ".");
    }
}

void check_has_faces(const TriangleMesh& mesh, const char* attack)
{
    if (mesh.is_point_cloud() && mesh.V.rows() > 0)
    {
        throw InvalidMesh(std::string(attack) +
                          ": the mesh has no faces (a point cloud), so its vertices have no "
                          "neighbours to average.");
    }
}

// One Jacobi step, out_i = p_i + factor * (mean of the neighbours of i - p_i), each row written
// by one thread from the previous positions only, neighbours summed in adjacency order.
void laplacian_step(const Positions& in, const VertexAdjacency& adjacency, double factor,
                    int threads, Positions& out)
{
    const auto n = static_cast<Eigen::Index>(adjacency.vertex_count());
#pragma omp parallel for num_threads(threads) schedule(static) if (n >= kParallelMinimum)
    for (Eigen::Index i = 0; i < n; ++i)
    {
        const auto neighbours = adjacency.of(static_cast<std::size_t>(i));
        if (neighbours.empty())
        {
            out.row(i) = in.row(i);
            continue;
        }
        Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
        for (const auto j : neighbours)
        {
            sum += in.row(j);
        }
        const Eigen::RowVector3d mean = sum / static_cast<double>(neighbours.size());
        out.row(i) = in.row(i) + factor * (mean - in.row(i));
    }
}

// Runs the factors in turn, `rounds` times, ping-ponging between two buffers.
TriangleMesh smooth(const TriangleMesh& mesh, std::initializer_list<double> factors, int rounds,
                    int threads)
{
    const VertexAdjacency adjacency = vertex_adjacency(mesh);
    const int thread_count = resolve_threads(threads);
    TriangleMesh result = mesh;
    Positions scratch(mesh.V.rows(), 3);
    for (int round = 0; round < rounds; ++round)
    {
        for (const double factor : factors)
        {
            laplacian_step(result.V, adjacency, factor, thread_count, scratch);
            std::swap(result.V, scratch);
        }
    }
    return result;
}

}  // namespace

void LaplacianSmoothingOptions::validate() const
{
    check_iterations("smooth", iterations);
    if (!std::isfinite(lambda) || lambda <= 0.0 || lambda > 1.0)
    {
        throw InvalidOption("smooth: lambda " + detail::format_number(lambda) +
                            " is outside (0, 1].");
    }
}

void TaubinSmoothingOptions::validate() const
{
    check_iterations("taubin", iterations);
    if (!std::isfinite(lambda) || lambda <= 0.0 || lambda > 1.0)
    {
        throw InvalidOption("taubin: lambda " + detail::format_number(lambda) +
                            " is outside (0, 1].");
    }
    if (!std::isfinite(mu) || mu >= 0.0 || mu < -1.0 || -mu < lambda)
    {
        throw InvalidOption("taubin: mu " + detail::format_number(mu) +
                            " must lie in [-1, 0) with -mu >= lambda (" +
                            detail::format_number(lambda) + ").");
    }
}

TriangleMesh smooth_laplacian(const TriangleMesh& mesh, const LaplacianSmoothingOptions& options,
                              int threads)
{
    options.validate();
    check_has_faces(mesh, "smooth");
    return smooth(mesh, {options.lambda}, options.iterations, threads);
}

TriangleMesh smooth_taubin(const TriangleMesh& mesh, const TaubinSmoothingOptions& options,
                           int threads)
{
    options.validate();
    check_has_faces(mesh, "taubin");
    return smooth(mesh, {options.lambda, options.mu}, options.iterations, threads);
}

}  // namespace meshmark
