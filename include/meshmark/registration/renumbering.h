// SPDX-License-Identifier: MIT
#pragma once

#include <optional>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief The suspect's positions in the original's vertex order, when it is the original's mesh
/// renumbered where it stands (a writer that numbers the vertices its own way and moves nothing
/// but the mark: a Draco re-encoding).
/// \details Same vertex and triangle counts, every vertex within \p tolerance of its original
/// vertex. The vertices that stand for an original vertex beyond doubt (mutual nearest, the next
/// at least twice as far) start the correspondence and the triangles carry it to the others;
/// where no vertex is beyond doubt (vertices nearer each other than the mark moves them: a CAD
/// plate's arcs), up to 10,000 vertices, the vertices the triangles leave no choice for start it.
/// It holds when every vertex is reached, each original vertex once, and every suspect triangle
/// is a triangle of the original; nullopt otherwise. Positions and triangles only, never a key.
[[nodiscard]] std::optional<Positions> renumbered_in_place(const TriangleMesh& original,
                                                           const TriangleMesh& suspect,
                                                           double tolerance, int threads);

/// \brief The suspect's positions in the original's vertex order, when its triangles are the
/// original's, in the original's order and each with its corners in the same turn, over
/// vertices numbered another way (Blender's PLY writer; its import may drop up to 1% of
/// repeated and degenerate triangles). Looks at no position, so it holds however far a tool
/// moved the vertices; nullopt otherwise. Triangles only, never a key.
[[nodiscard]] std::optional<Positions> renumbered_by_triangles(const TriangleMesh& original,
                                                               const TriangleMesh& suspect);

}  // namespace meshmark
