// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <vector>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief The rows of \p P in Z (Morton) order of their positions, ties by row index.
/// \details Each coordinate is scaled to the points' bounding box and quantized to \p bits bits
/// (1..21; cell = floor(unit * (2^bits - 1))), the three cells are interleaved (x in the lowest
/// bit) and the rows sorted by (code, row). Used to lay out data so that neighbouring entries
/// hold nearby points: the RBF centers' columns (10 bits) and the registration's ICP samples
/// (21 bits). \return row indices, the first row of the order first.
[[nodiscard]] std::vector<std::size_t> morton_order(const Positions& P, int bits);

}  // namespace meshmark
