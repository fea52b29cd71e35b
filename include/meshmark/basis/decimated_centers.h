// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief Choose \p k RBF centers as the survivors of a QEM edge-collapse decimation of the
/// active part of \p mesh down to k vertices [Wu & Kobbelt 2005, Sec. 4, Fig. 4;
/// Garland & Heckbert 1997].
/// \details The active rows are first welded by exact position (seams and triangle soups
/// repeat positions; two centers at one position would make the Gram matrix singular), then
/// decimated with meshoptimizer's quadric simplifier (meshopt_simplify), which only removes
/// vertices and keeps the survivors' indices. Passes remove half of the remaining excess each,
/// the last ones one collapse at a time, so the count lands on k. Should the collapses stop
/// at most 16 vertices above k (no collapse left, or one that would remove two vertices at
/// once), the survivors of highest index are dropped. Deterministic (no seed: the same mesh
/// always gives the same centers); single-threaded.
/// \param mesh    Triangle mesh (faces required).
/// \param active  Rows taking part (sorted, unique).
/// \param k       Number of centers, >= 1.
/// \return k distinct row indices of \p mesh, increasing, at k distinct positions.
/// \throws InvalidMesh for a point cloud, or when the collapses stop above k vertices (e.g.
/// too many separate pieces); InvalidOption for k < 1.
[[nodiscard]] std::vector<std::int32_t> decimated_centers(const TriangleMesh& mesh,
                                                          const std::vector<std::int32_t>& active,
                                                          int k);

}  // namespace meshmark
