// SPDX-License-Identifier: MIT
// Private: meshoptimizer's quadric edge collapse, the fast backend of simplify().
#pragma once

#include <cstddef>
#include <optional>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark::detail
{

/// \brief Simplify \p mesh with meshopt_simplify until about \p target_vertices vertices are
/// left; the result keeps the exact positions of the vertices it keeps, compacted in increasing
/// original order. Returns nullopt when the collapses stop more than \p tolerance (relative)
/// away from the target (meshoptimizer does not move border or non-manifold vertices off
/// their edges), so the caller can fall back to CGAL.
[[nodiscard]] std::optional<TriangleMesh> simplify_meshopt(const TriangleMesh& mesh,
                                                           std::size_t target_vertices,
                                                           double tolerance);

}  // namespace meshmark::detail
