// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

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

/// \brief A copy's vertices in the original's order, as far as its triangles tell them.
struct TriangleRenumbering
{
    /// #V_original x 3, the suspect's frame: row i the suspect vertex standing for original
    /// vertex i, the suspect's centroid where none does.
    Positions in_order;
    /// Per original vertex, 1 when a suspect vertex stands for it; empty when every one has one.
    std::vector<std::uint8_t> reached;
    std::size_t unreached = 0;  ///< Original vertices no suspect vertex stands for.
};

/// \brief The suspect's positions in the original's vertex order, when it is made of the
/// original's parts (connected by triangles), each numbered another way but with its triangles
/// in the original's order and turn, the parts in any order (Blender joins a model's objects
/// in an order of its own, and its writers number each part's vertices as they go).
/// \details A part is matched to the original's part of the same triangles over local numbers
/// (its vertices numbered as its triangles first use them), triangles with a repeated corner
/// left out. Parts whose shape is one part's on each side are matched outright and place the
/// copy (a similarity fit); parts of a shape several share (a model's four wheels) go to the
/// nearest of the original's after that fit. Parts left unmatched (changed, dropped, merged)
/// leave their original vertices out, as a crop does; it holds when 90% of the original's
/// vertices are reached, nullopt otherwise. Apart from telling alike parts apart it looks at no
/// position, so it holds however far a tool moved the vertices. Never a key.
[[nodiscard]] std::optional<TriangleRenumbering> renumbered_by_parts(const TriangleMesh& original,
                                                                     const TriangleMesh& suspect);

}  // namespace meshmark
