// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief Unit icosphere: an icosahedron subdivided \p subdivisions times, projected on the
/// sphere (10 * 4^subdivisions + 2 vertices). Closed, manifold, outward-facing.
/// \throws InvalidOption if subdivisions is outside 0..10.
[[nodiscard]] TriangleMesh icosphere(int subdivisions);

/// \brief Torus around the z axis, major radius \p R, minor radius \p r,
/// \p rings * \p sides vertices. Closed and manifold.
/// \throws InvalidOption unless 0 < r < R and rings, sides >= 3.
[[nodiscard]] TriangleMesh torus(double R, double r, int rings, int sides);

/// \brief Open square grid in the z = 0 plane over [0,1]^2, (nx+1)*(ny+1) vertices.
/// \throws InvalidOption unless nx, ny >= 1.
[[nodiscard]] TriangleMesh plane_grid(int nx, int ny);

/// \brief The demo mesh: a lumpy ellipsoid (radii 1, 0.7, 0.45 with smooth bumps), closed,
/// manifold, with well separated principal axes and no symmetry, 10 * 4^s + 2 vertices.
/// \details Used by `meshmark demo` and the tests, so that neither needs external data.
/// \throws InvalidOption if subdivisions is outside 0..10 (see icosphere()).
[[nodiscard]] TriangleMesh lumpy_ellipsoid(int subdivisions);

}  // namespace meshmark
