// SPDX-License-Identifier: MIT
#pragma once

#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark::test
{

/// The parts as one mesh, in order.
[[nodiscard]] TriangleMesh joined(const std::vector<TriangleMesh>& parts);

/// A dense upright torus (1,280 vertices) centred at \p centre, its axis along y.
[[nodiscard]] TriangleMesh tyre(const Eigen::Vector3d& centre);

/// A hard-surface asset of separate parts, like a game vehicle: a boxy body and cabin
/// (superellipsoids), four tyres (tori) and two lamps, turned by 25 degrees about the up axis
/// so that the coordinate axes are not its own. Mirror-symmetric (5,768 vertices); with
/// \p roof_box, nearly: a box on the cabin roof's left edge (162 vertices more), as a game vehicle
/// modelled with a Mirror modifier and then given a part on one side.
[[nodiscard]] TriangleMesh vehicle(bool roof_box = false);
/// A flat plate as CAD programs export it (a printer bed, like PrusaSlicer's Creality beds): a
/// 310 x 310 x 3 rounded square whose faces have no inner vertices, so all 200 vertices lie on
/// its two outlines, 25 on each corner arc of radius 3 (0.2 apart). Its vertices span about 35
/// modes of the RBF basis.
[[nodiscard]] TriangleMesh outline_plate();

}  // namespace meshmark::test
