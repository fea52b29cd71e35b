// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/registration/surface_matcher.h"

namespace meshmark::detail
{

/// \brief Median distance from a point of \p V to its nearest other point (at most
/// \p max_queries points queried, evenly spaced in row order); 0 with fewer than 2 points.
[[nodiscard]] double median_neighbor_spacing(const Positions& V, std::size_t max_queries = 10000);

}  // namespace meshmark::detail
