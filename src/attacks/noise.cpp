// SPDX-License-Identifier: MIT
#include "meshmark/attacks/noise.h"

#include <cmath>
#include <string>
#include <vector>

#include "attacks/detail/format.h"
#include "attacks/detail/sampling.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/normals.h"

namespace meshmark
{
namespace
{

// Vertices per random stream: the streams, not the threads, decide the draws, so the result is
// the same for any thread count; large enough that seeding costs nothing.
constexpr Eigen::Index kBlockSize = 4096;

// Mean distance of the listed vertices to their centroid (sums in index order).
double mean_centroid_distance(const Positions& V, const std::vector<std::int32_t>& rows)
{
    if (rows.empty())
    {
        return 0.0;
    }
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto i : rows)
    {
        centroid += V.row(i).transpose();
    }
    centroid /= static_cast<double>(rows.size());
    double total = 0.0;
    for (const auto i : rows)
    {
        total += (V.row(i).transpose() - centroid).norm();
    }
    return total / static_cast<double>(rows.size());
}

double reference_length(const TriangleMesh& mesh, NoiseReference reference)
{
    const auto rows = referenced_vertices(mesh);
    return reference == NoiseReference::BboxDiagonal ? bounding_box(mesh.V, rows).diagonal()
                                                     : mean_centroid_distance(mesh.V, rows);
}

double draw(Rng& rng, NoiseDistribution distribution, double amplitude)
{
    return distribution == NoiseDistribution::Uniform ? rng.uniform(-amplitude, amplitude)
                                                      : amplitude * rng.normal();
}

}  // namespace

void NoiseOptions::validate() const
{
    if (!std::isfinite(amplitude) || amplitude < 0.0 || amplitude > 1.0)
    {
        throw InvalidOption("noise: amplitude " + detail::format_number(amplitude) +
                            " is outside [0, 1] (a fraction of the reference length).");
    }
}

TriangleMesh add_noise(const TriangleMesh& mesh, const NoiseOptions& options, Rng& rng, int threads)
{
    options.validate();
    const bool along_normals = options.direction == NoiseDirection::Normal;
    if (along_normals && mesh.is_point_cloud() && mesh.V.rows() > 0)
    {
        throw InvalidMesh(
            "noise: noise along normals needs faces, but the mesh is a point cloud "
            "(use dir=iso).");
    }

    // Absolute amplitude, normals if needed, and one seed for all the block streams.
    const double amplitude = options.amplitude * reference_length(mesh, options.reference);
    const Positions normals = along_normals ? vertex_normals(mesh) : Positions();
    const std::uint64_t base_seed = rng.bits();

    // Displace block by block; each block owns its rows and its stream.
    TriangleMesh result = mesh;
    const Eigen::Index n = mesh.V.rows();
    const Eigen::Index blocks = (n + kBlockSize - 1) / kBlockSize;
    // Threads from 4 blocks on (chosen by hand; no study on record).
#pragma omp parallel for num_threads(resolve_threads(threads)) schedule(static) if (blocks >= 4)
    for (Eigen::Index b = 0; b < blocks; ++b)
    {
        Rng block_rng(splitmix64(base_seed ^ splitmix64(static_cast<std::uint64_t>(b))));
        const Eigen::Index end = std::min(n, (b + 1) * kBlockSize);
        for (Eigen::Index i = b * kBlockSize; i < end; ++i)
        {
            if (along_normals)
            {
                result.V.row(i) +=
                    draw(block_rng, options.distribution, amplitude) * normals.row(i);
                continue;
            }
            for (int d = 0; d < 3; ++d)
            {
                result.V(i, d) += draw(block_rng, options.distribution, amplitude);
            }
        }
    }
    return result;
}

}  // namespace meshmark
