// SPDX-License-Identifier: MIT
// Private: quadric edge collapse on a CGAL surface, shared by simplify() and remesh().
#pragma once

#include <cstddef>

#include "attacks/detail/cgal_mesh.h"
#include "meshmark/attacks/simplification.h"

namespace meshmark::detail
{

/// \brief Collapse edges of \p surface with \p policy until it has \p target_vertices vertices
/// (or no valid collapse is left). Does nothing when it already has that few. \p boundary_weight:
/// SimplificationOptions::boundary_weight (Garland-Heckbert only).
void simplify_surface(SurfaceMesh& surface, std::size_t target_vertices,
                      SimplificationPolicy policy,
                      double boundary_weight = SimplificationOptions{}.boundary_weight);

}  // namespace meshmark::detail
