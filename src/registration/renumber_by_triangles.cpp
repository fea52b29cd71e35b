// SPDX-License-Identifier: MIT
// A copy whose triangles are the original's, in its order, over vertices numbered another way
// (Blender's PLY writer): the renumbering read off the triangles alone.
#include <algorithm>
#include <optional>
#include <vector>

#include "meshmark/registration/renumbering.h"

namespace meshmark
{
namespace
{

// Original triangles a writer may leave out and still be taken as numbering the others its own
// way: Blender drops an original's repeated and degenerate triangles on import (24 of the 13,502
// of OpenCASCADE's motor).
constexpr double kMaxDroppedTriangles = 0.01;

}  // namespace

// The suspect's positions in the original's vertex order, when its triangles are the original's,
// in the original's order and each with its corners in the same turn, over vertices numbered
// another way: Blender's PLY writer numbers the vertices in the order its triangles first use
// them, and its import drops repeated and degenerate triangles (at most kMaxDroppedTriangles of
// them are skipped). Unlike renumbered_in_place it looks at no position, so it holds however far
// a tool moved the vertices (Blender's Smooth modifier, 0.5 x 10, on OpenCASCADE's motor, 6,635
// vertices: read through registration at z 4.15, in the original's order 10.77). Each suspect
// triangle is the next original triangle whose corners are still free or already the same
// vertices; it holds when every suspect vertex stands for one original vertex and each
// original vertex for one suspect vertex. Triangles only, never the key.
std::optional<Positions> renumbered_by_triangles(const TriangleMesh& original,
                                                 const TriangleMesh& suspect)
{
    const Eigen::Index n = original.V.rows();
    const Eigen::Index faces = original.F.rows();
    const auto droppable =
        static_cast<Eigen::Index>(kMaxDroppedTriangles * static_cast<double>(faces));
    if (suspect.V.rows() != n || faces == 0 || suspect.F.rows() > faces ||
        suspect.F.rows() < faces - droppable)
    {
        return std::nullopt;
    }
    std::vector<std::int32_t> original_of(static_cast<std::size_t>(n),
                                          -1);  // suspect vertex -> original
    std::vector<std::int32_t> suspect_of(static_cast<std::size_t>(n),
                                         -1);  // original vertex -> suspect
    Eigen::Index next = 0;                     // the next original triangle
    for (Eigen::Index f = 0; f < suspect.F.rows(); ++f)
    {
        if (suspect.F(f, 0) == suspect.F(f, 1) || suspect.F(f, 1) == suspect.F(f, 2) ||
            suspect.F(f, 2) == suspect.F(f, 0))
        {
            return std::nullopt;  // a triangle with a repeated corner is no triangle of a copy
        }
        for (;; ++next)
        {
            if (next >= faces || next - f > droppable)
            {
                return std::nullopt;
            }
            bool fits = true;
            for (Eigen::Index k = 0; k < 3 && fits; ++k)
            {
                const auto s = static_cast<std::size_t>(suspect.F(f, k));
                const auto o = static_cast<std::size_t>(original.F(next, k));
                fits = original_of[s] == static_cast<std::int32_t>(o) ||
                       (original_of[s] < 0 && suspect_of[o] < 0);
            }
            if (fits)
            {
                for (Eigen::Index k = 0; k < 3; ++k)
                {
                    original_of[static_cast<std::size_t>(suspect.F(f, k))] = original.F(next, k);
                    suspect_of[static_cast<std::size_t>(original.F(next, k))] = suspect.F(f, k);
                }
                ++next;
                break;
            }
        }
    }
    if (std::any_of(suspect_of.begin(), suspect_of.end(), [](std::int32_t s) { return s < 0; }))
    {
        return std::nullopt;  // an original vertex no suspect triangle uses: not the same numbering
    }
    Positions in_order(n, 3);
    for (Eigen::Index i = 0; i < n; ++i)
    {
        in_order.row(i) = suspect.V.row(suspect_of[static_cast<std::size_t>(i)]);
    }
    return in_order;
}

}  // namespace meshmark
