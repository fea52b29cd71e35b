// SPDX-License-Identifier: MIT
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <meshoptimizer.h>

#include "attacks/detail/simplify_meshopt.h"

namespace meshmark::detail
{
namespace
{

// Passes on the previous pass's output when a pass stops above the target: the vertex count
// per kept index is not constant (borders, pieces), so the index target is corrected each pass.
constexpr int kMaxPasses = 6;
// Relative error bound handed to meshoptimizer: far above any mesh's extent, so only the
// index target stops it.
constexpr float kUnboundedError = 1.0e3F;

std::size_t used_vertex_count(const std::vector<unsigned int>& indices, std::vector<char>& used)
{
    std::fill(used.begin(), used.end(), char{0});
    std::size_t count = 0;
    for (const unsigned int i : indices)
    {
        if (used[i] == 0)
        {
            used[i] = 1;
            ++count;
        }
    }
    return count;
}

}  // namespace

std::optional<TriangleMesh> simplify_meshopt(const TriangleMesh& mesh, std::size_t target_vertices,
                                             double tolerance)
{
    const auto vertex_count = static_cast<std::size_t>(mesh.V.rows());
    std::vector<float> positions(3 * vertex_count);
    for (std::size_t v = 0; v < vertex_count; ++v)
    {
        for (Eigen::Index c = 0; c < 3; ++c)
        {
            positions[3 * v + static_cast<std::size_t>(c)] =
                static_cast<float>(mesh.V(static_cast<Eigen::Index>(v), c));
        }
    }
    // Degenerate faces (a repeated index) carry no area and only block collapses: drop them.
    std::vector<unsigned int> indices;
    indices.reserve(3 * static_cast<std::size_t>(mesh.F.rows()));
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const auto a = mesh.F(f, 0);
        const auto b = mesh.F(f, 1);
        const auto c = mesh.F(f, 2);
        if (a != b && b != c && a != c)
        {
            indices.push_back(static_cast<unsigned int>(a));
            indices.push_back(static_cast<unsigned int>(b));
            indices.push_back(static_cast<unsigned int>(c));
        }
    }
    std::vector<char> used(vertex_count, 0);
    std::size_t current = used_vertex_count(indices, used);
    const auto target = static_cast<double>(target_vertices);
    std::vector<unsigned int> destination(indices.size());
    for (int pass = 0; pass<kMaxPasses&& static_cast<double>(current)> target; ++pass)
    {
        const double scaled =
            static_cast<double>(indices.size() / 3) * target / static_cast<double>(current);
        const auto target_indices = 3 * static_cast<std::size_t>(std::max(1.0, std::round(scaled)));
        destination.resize(indices.size());
        const std::size_t kept = meshopt_simplify(
            destination.data(), indices.data(), indices.size(), positions.data(), vertex_count,
            3 * sizeof(float), target_indices, kUnboundedError, 0, nullptr);
        if (kept == indices.size())
        {
            break;  // no collapse left
        }
        destination.resize(kept);
        indices.swap(destination);
        current = used_vertex_count(indices, used);
    }
    if (std::abs(static_cast<double>(current) - target) > tolerance * target || indices.empty())
    {
        return std::nullopt;
    }
    // Compact: kept vertices in increasing original order, with their double positions.
    (void)used_vertex_count(indices, used);
    std::vector<std::int32_t> new_index(vertex_count, -1);
    TriangleMesh result;
    result.V.resize(static_cast<Eigen::Index>(current), 3);
    std::int32_t next = 0;
    for (std::size_t v = 0; v < vertex_count; ++v)
    {
        if (used[v] != 0)
        {
            result.V.row(next) = mesh.V.row(static_cast<Eigen::Index>(v));
            new_index[v] = next++;
        }
    }
    result.F.resize(static_cast<Eigen::Index>(indices.size() / 3), 3);
    for (std::size_t i = 0; i < indices.size(); ++i)
    {
        result.F(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)) =
            new_index[indices[i]];
    }
    return result;
}

}  // namespace meshmark::detail
