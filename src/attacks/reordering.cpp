// SPDX-License-Identifier: MIT
#include "meshmark/attacks/reordering.h"

#include <utility>
#include <vector>

namespace meshmark
{
namespace
{

// Uniform random permutation of 0..n-1 (Fisher-Yates with unbiased Rng::below draws).
std::vector<std::int32_t> random_permutation(Eigen::Index n, Rng& rng)
{
    std::vector<std::int32_t> order = identity_correspondence(n);
    for (std::size_t i = order.size(); i > 1; --i)
    {
        const auto j = static_cast<std::size_t>(rng.below(i));
        std::swap(order[i - 1], order[j]);
    }
    return order;
}

}  // namespace

AttackResult reorder(const TriangleMesh& mesh, const ReorderOptions& options, Rng& rng)
{
    options.validate();
    // New vertex k is old vertex source[k]; new face k is old face face_order[k].
    std::vector<std::int32_t> source = random_permutation(mesh.V.rows(), rng);
    const std::vector<std::int32_t> face_order = random_permutation(mesh.F.rows(), rng);
    std::vector<std::int32_t> new_index(source.size());
    AttackResult result;
    result.mesh.V.resize(mesh.V.rows(), 3);
    for (std::size_t k = 0; k < source.size(); ++k)
    {
        result.mesh.V.row(static_cast<Eigen::Index>(k)) = mesh.V.row(source[k]);
        new_index[static_cast<std::size_t>(source[k])] = static_cast<std::int32_t>(k);
    }
    result.mesh.F.resize(mesh.F.rows(), 3);
    for (std::size_t k = 0; k < face_order.size(); ++k)
    {
        for (int c = 0; c < 3; ++c)
        {
            result.mesh.F(static_cast<Eigen::Index>(k), c) =
                new_index[static_cast<std::size_t>(mesh.F(face_order[k], c))];
        }
    }
    result.source_vertex = std::move(source);
    return result;
}

}  // namespace meshmark
