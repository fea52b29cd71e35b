// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Cost and placement of the edge collapses.
enum class SimplificationPolicy
{
    GarlandHeckbert,  ///< Plane quadric error metric [Garland & Heckbert 1997].
    LindstromTurk,    ///< Memoryless volume/boundary/shape optimization [Lindstrom & Turk 1998].
};

/// Implementation of the edge collapses.
enum class SimplificationMethod
{
    /// meshoptimizer's quadric collapse onto existing vertices: about 1 s on a 437K-vertex
    /// mesh, but no link-condition check, so the result may be non-manifold and open.
    Meshoptimizer,
    Cgal,  ///< CGAL's Surface_mesh_simplification with `policy` (exact count, slower).
};

/// Parameters of the simplification attack.
struct SimplificationOptions
{
    /// Fraction of the referenced vertices kept; the benchmark's levels are 0.5, 0.25, 0.1,
    /// 0.02 and 0.01. Range (0, 1].
    double vertex_fraction = 0.5;
    /// Used by the CGAL method (and its fallback) only.
    SimplificationPolicy policy = SimplificationPolicy::GarlandHeckbert;
    SimplificationMethod method = SimplificationMethod::Cgal;
    /// Garland-Heckbert policy of the CGAL method: weight of the quadrics that hold the
    /// border edges in place (CGAL's discontinuity multiplier). 100, CGAL's default, keeps
    /// borders nearly fixed; 1 is the boundary weight of Open3D's and MeshLab's quadric
    /// decimations. Positive and finite.
    double boundary_weight = 100.0;

    /// \throws InvalidOption when vertex_fraction is outside (0, 1], or boundary_weight is not
    /// positive and finite or differs from its default with the Lindstrom-Turk policy or the
    /// meshoptimizer method (which do not use it).
    void validate() const;
    bool operator==(const SimplificationOptions&) const = default;
};

/// \brief Quadric edge-collapse simplification down to a fraction of the vertices, with CGAL's
/// Surface_mesh_simplification.
/// \details The target is `round(vertex_fraction * referenced vertex count)` (at least 4); each
/// collapse removes one vertex and collapses stop at the target, so the result has the target
/// count. Collapses keep the surface a combinatorial manifold (link condition) and refuse
/// placements that flip a face normal, so a closed manifold input stays closed and
/// edge-manifold. When the collapses run out above the target, the cause is topological
/// (triangular holes, around which every collapse would pinch the surface, and loose
/// triangles, typically left by repairing a non-manifold input): those holes are closed, the
/// loose triangles removed, and collapsing goes on. Messy input is repaired first (see
/// "Messy meshes" in docs/algorithms/attacks.md): unreferenced vertices and degenerate or
/// duplicate faces are dropped, the fewest faces are dropped so that no edge has more than
/// two, and what is still non-manifold is cut apart. New vertices have no correspondence with
/// old ones. With SimplificationMethod::Meshoptimizer, meshopt_simplify runs on the input as
/// is (vertices kept, not moved; count within 5% of the target, else the CGAL path runs) and
/// none of the manifold guarantees above hold. [Garland & Heckbert 1997; Lindstrom & Turk 1998;
/// CGAL Surface_mesh_simplification] \throws InvalidOption from options.validate(); InvalidMesh for
/// a mesh with no faces, or with none left once degenerate and duplicate faces are dropped.
[[nodiscard]] TriangleMesh simplify(const TriangleMesh& mesh, const SimplificationOptions& options);

}  // namespace meshmark
