// SPDX-License-Identifier: MIT
#include "meshmark/attacks/cropping.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "attacks/detail/format.h"
#include "attacks/detail/sampling.h"
#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

// Marks the `keep_count` listed vertices with the smallest projection on `direction` (ties
// broken by index, so exactly keep_count are marked).
std::vector<char> kept_side(const Positions& V, const std::vector<std::int32_t>& rows,
                            const Eigen::Vector3d& direction, std::size_t keep_count)
{
    std::vector<std::pair<double, std::int32_t>> order;
    order.reserve(rows.size());
    for (const auto i : rows)
    {
        order.emplace_back(V.row(i).dot(direction.transpose()), i);
    }
    if (keep_count < order.size())
    {
        std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep_count),
                         order.end());
    }
    std::vector<char> is_kept(static_cast<std::size_t>(V.rows()), 0);
    for (std::size_t k = 0; k < std::min(keep_count, order.size()); ++k)
    {
        is_kept[static_cast<std::size_t>(order[k].second)] = 1;
    }
    return is_kept;
}

// Keeps the faces whose corners are all marked (all marked vertices for a point cloud), drops
// the vertices nothing keeps and renumbers the rest in their original order.
AttackResult keep_marked(const TriangleMesh& mesh, std::vector<char> is_kept)
{
    AttackResult result;
    std::vector<Eigen::Index> kept_faces;
    if (!mesh.is_point_cloud())
    {
        std::vector<char> is_used(is_kept.size(), 0);
        for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
        {
            const auto corner = [&](int c) { return static_cast<std::size_t>(mesh.F(f, c)); };
            if (is_kept[corner(0)] != 0 && is_kept[corner(1)] != 0 && is_kept[corner(2)] != 0)
            {
                kept_faces.push_back(f);
                is_used[corner(0)] = is_used[corner(1)] = is_used[corner(2)] = 1;
            }
        }
        is_kept = std::move(is_used);
    }

    std::vector<std::int32_t> new_index(is_kept.size(), -1);
    std::vector<std::int32_t> source;
    for (std::size_t i = 0; i < is_kept.size(); ++i)
    {
        if (is_kept[i] != 0)
        {
            new_index[i] = static_cast<std::int32_t>(source.size());
            source.push_back(static_cast<std::int32_t>(i));
        }
    }
    result.mesh.V.resize(static_cast<Eigen::Index>(source.size()), 3);
    for (std::size_t k = 0; k < source.size(); ++k)
    {
        result.mesh.V.row(static_cast<Eigen::Index>(k)) = mesh.V.row(source[k]);
    }
    result.mesh.F.resize(static_cast<Eigen::Index>(kept_faces.size()), 3);
    for (std::size_t k = 0; k < kept_faces.size(); ++k)
    {
        for (int c = 0; c < 3; ++c)
        {
            result.mesh.F(static_cast<Eigen::Index>(k), c) =
                new_index[static_cast<std::size_t>(mesh.F(kept_faces[k], c))];
        }
    }
    result.source_vertex = std::move(source);
    return result;
}

}  // namespace

void CropOptions::validate() const
{
    if (!std::isfinite(vertex_fraction) || vertex_fraction <= 0.0 || vertex_fraction > 1.0)
    {
        throw InvalidOption("crop: fraction " + detail::format_number(vertex_fraction) +
                            " is outside (0, 1].");
    }
    if (direction && (!direction->allFinite() || direction->norm() == 0.0))
    {
        throw InvalidOption("crop: the cut direction must be a finite non-zero vector.");
    }
}

AttackResult crop(const TriangleMesh& mesh, const CropOptions& options, Rng& rng)
{
    options.validate();
    // Cut direction, then the plane position that leaves the requested count on the kept side.
    const Eigen::Vector3d direction =
        options.direction ? options.direction->normalized() : detail::random_unit_vector(rng);
    const auto rows = referenced_vertices(mesh);
    const auto keep_count = static_cast<std::size_t>(
        std::llround(options.vertex_fraction * static_cast<double>(rows.size())));
    return keep_marked(mesh,
                       kept_side(mesh.V, rows, direction, std::max<std::size_t>(keep_count, 1)));
}

}  // namespace meshmark
