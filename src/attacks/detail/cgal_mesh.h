// SPDX-License-Identifier: MIT
// Private bridge between TriangleMesh and CGAL's Surface_mesh, for the CGAL-backed attacks only
// (simplification, remeshing, subdivision). Never included by a public header, so CGAL stays
// out of every translation unit but these.
#pragma once

#include <string_view>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark::detail
{

using CgalKernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalPoint = CgalKernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<CgalPoint>;

/// \brief A valid CGAL surface built from the triangles of \p mesh.
/// \details Only referenced vertices are used, and triangles of zero area (a repeated corner,
/// collinear or coincident corners: exact predicate) are dropped, since CGAL's algorithms assume
/// there are none. A mesh that is then an oriented combinatorial manifold is converted as it is.
/// Otherwise: the fewest faces are dropped so that no edge has
/// more than two (faces on the most non-manifold edges first: fins and folds), then CGAL's
/// repair_polygon_soup merges points at identical positions and drops degenerate and duplicate
/// faces, and orient_polygon_soup makes orientations agree, duplicating points where the
/// surface is still non-manifold (cutting it apart there) [Guéziec, Taubin, Lazarus, Horn 2001].
/// \param attack  Names the attack in error messages.
/// \param weld    Also repair (and so merge) when two vertices are at the same position: the
///                surface of a triangle soup or of a mesh split at its seams as one piece.
/// \throws InvalidMesh when the mesh has no faces, or no usable face is left after repair.
[[nodiscard]] SurfaceMesh to_surface_mesh(const TriangleMesh& mesh, std::string_view attack,
                                          bool weld = false);

/// \brief The vertices (renumbered densely, in CGAL's order) and triangles of \p surface.
/// \pre Every face of \p surface is a triangle.
[[nodiscard]] TriangleMesh to_triangle_mesh(const SurfaceMesh& surface);

}  // namespace meshmark::detail
