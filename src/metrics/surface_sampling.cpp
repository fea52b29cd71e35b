// SPDX-License-Identifier: MIT
#include "meshmark/metrics/surface_sampling.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <omp.h>

#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/core/threads.h"

namespace meshmark
{

Eigen::VectorXd cumulative_face_areas(const TriangleMesh& mesh)
{
    Eigen::VectorXd cumulative(mesh.F.rows());
    double total = 0.0;
    // Sequential prefix sum: a fixed summation order, so the strata are the same everywhere.
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)).transpose();
        const Eigen::Vector3d ab = mesh.V.row(mesh.F(f, 1)).transpose() - a;
        const Eigen::Vector3d ac = mesh.V.row(mesh.F(f, 2)).transpose() - a;
        total += 0.5 * ab.cross(ac).norm();
        cumulative[f] = total;
    }
    return cumulative;
}

void sample_surface_block(const TriangleMesh& mesh, const Eigen::VectorXd& cumulative_areas,
                          std::int64_t count, std::uint64_t seed, std::int64_t block,
                          Positions& out)
{
    const std::int64_t start = block * kSamplesPerBlock;
    const std::int64_t n = std::clamp(count - start, std::int64_t{0}, kSamplesPerBlock);
    out.resize(static_cast<Eigen::Index>(n), 3);
    if (n == 0)
    {
        return;
    }
    const Eigen::Index last_face = cumulative_areas.size() - 1;
    const double total = cumulative_areas[last_face];
    const double stratum = total / static_cast<double>(count);
    Rng rng(splitmix64(splitmix64(seed) ^ static_cast<std::uint64_t>(block)));
    const double* begin = cumulative_areas.data();
    const double* end = begin + cumulative_areas.size();
    Eigen::Index face = 0;
    for (std::int64_t j = 0; j < n; ++j)
    {
        // A uniform position in stratum k of the total area, then the face that holds it: the
        // first one whose cumulative area exceeds it (zero-area faces are never chosen).
        const double u =
            std::min((static_cast<double>(start + j) + rng.uniform()) * stratum, total);
        if (j == 0)
        {
            face = std::min(static_cast<Eigen::Index>(std::upper_bound(begin, end, u) - begin),
                            last_face);
        }
        while (face < last_face && cumulative_areas[face] <= u)
        {
            ++face;
        }
        // Uniform point in the triangle [Osada et al. 2002, "Shape distributions", Sec. 4.2].
        const double s = std::sqrt(rng.uniform());
        const double r = rng.uniform();
        const auto row = static_cast<Eigen::Index>(j);
        out.row(row) = (1.0 - s) * mesh.V.row(mesh.F(face, 0)) +
                       (s * (1.0 - r)) * mesh.V.row(mesh.F(face, 1)) +
                       (s * r) * mesh.V.row(mesh.F(face, 2));
    }
}

Positions sample_surface(const TriangleMesh& mesh, std::int64_t count, std::uint64_t seed,
                         int threads)
{
    if (count < 0)
    {
        throw InvalidOption("sample_surface: count = " + std::to_string(count) + " must be >= 0.");
    }
    const Eigen::VectorXd cumulative = cumulative_face_areas(mesh);
    if (cumulative.size() == 0 || !(cumulative[cumulative.size() - 1] > 0.0) || count == 0)
    {
        return Positions(0, 3);
    }
    Positions samples(static_cast<Eigen::Index>(count), 3);
    const std::int64_t blocks = (count + kSamplesPerBlock - 1) / kSamplesPerBlock;
    // Blocks are independent streams written to disjoint rows: any schedule gives the same output.
#pragma omp parallel num_threads(resolve_threads(threads))
    {
        Positions buffer;
#pragma omp for schedule(dynamic, 4)
        for (std::int64_t b = 0; b < blocks; ++b)
        {
            sample_surface_block(mesh, cumulative, count, seed, b, buffer);
            samples.middleRows(static_cast<Eigen::Index>(b * kSamplesPerBlock), buffer.rows()) =
                buffer;
        }
    }
    return samples;
}

}  // namespace meshmark
