// SPDX-License-Identifier: MIT
#pragma once

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief Unit normal of every triangle, from the right-hand rule on its corner order.
/// \details A degenerate triangle (zero area) gets a zero normal rather than NaN.
/// \param mesh  Triangle mesh; indices must be in range (see validate()).
/// \return #F×3 unit normals, row f for face f.
[[nodiscard]] Positions face_normals(const TriangleMesh& mesh);

/// \brief Area of every triangle.
/// \return #F areas, in the mesh's units squared.
[[nodiscard]] Eigen::VectorXd face_areas(const TriangleMesh& mesh);

/// \brief Total area of the triangles (the sum of face_areas, accumulated in face order).
[[nodiscard]] double surface_area(const TriangleMesh& mesh);

/// \brief Area-weighted unit vertex normals.
/// \details The normal of a vertex is the normalized sum of the unnormalized normals (cross
/// products) of the triangles around it, so large triangles count more and slivers little
/// [Max 1999 discusses the weightings; area weighting is the common default]. The sum runs in
/// face order, so the result is deterministic. Vertices used by no face, or whose incident
/// normals cancel, get a zero normal.
/// \param mesh  Triangle mesh; indices must be in range (see validate()).
/// \return #V×3 unit (or zero) normals.
[[nodiscard]] Positions vertex_normals(const TriangleMesh& mesh);

}  // namespace meshmark
