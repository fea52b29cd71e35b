// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/attacks/attack_result.h"
#include "meshmark/core/rng.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Parameters of the reordering attack (it has none; the stream decides everything).
struct ReorderOptions
{
    void validate() const {}
    bool operator==(const ReorderOptions&) const = default;
};

/// \brief Shuffle the order of the vertices and of the faces (uniform random permutations,
/// Fisher-Yates with unbiased draws).
/// \details Geometry is unchanged: the same triangles, each with its corner order (and so its
/// orientation), refer to the renumbered vertices; unreferenced vertices are kept.
/// \return The shuffled mesh and, for each of its vertices, the input vertex it was.
[[nodiscard]] AttackResult reorder(const TriangleMesh& mesh, const ReorderOptions& options,
                                   Rng& rng);

}  // namespace meshmark
