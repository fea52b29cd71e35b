// SPDX-License-Identifier: MIT
// Internal to `catalog scan` (catalog_scan.cpp): candidates besides the shape rankings
// (shape_ranking.cpp, declared in catalog_scan.h).
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "meshmark/catalog/catalog.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark::catalog_detail
{

// The assets of \p index whose original has \p suspect's vertex and face counts and fits it in
// order within kInOrderFit, best fit first; the originals read on \p threads threads.
[[nodiscard]] std::vector<std::size_t> in_order_fits(const Catalog& catalog,
                                                     const std::vector<Catalog::IndexEntry>& index,
                                                     const TriangleMesh& suspect, int threads);

// The places of \p ranked from \p from on that hold one of \p variants (closest first), and at
// least kVariantPlaces (the last others), given to the closest variants not placed elsewhere, in
// order; \p taken follows.
void closest_variants_first(std::vector<std::pair<float, std::size_t>>& ranked, std::size_t from,
                            std::vector<bool>& taken,
                            const std::vector<std::pair<double, std::size_t>>& variants,
                            const std::vector<float>& distance);

}  // namespace meshmark::catalog_detail
