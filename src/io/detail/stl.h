// SPDX-License-Identifier: MIT
// The binary STL layout, shared by the reader (stl_read.cpp) and the writers (stl_write.cpp).
#pragma once

#include <cstddef>

namespace meshmark::detail
{

inline constexpr std::size_t kStlHeaderSize = 80;
inline constexpr std::size_t kStlFacetOffset = 84;  // Header and the uint32 facet count.
inline constexpr std::size_t kStlFacetSize =
    50;  // Normal, 3 corners (float32 each), uint16 attribute.
inline constexpr int kStlFloatDecimalDigits = 9;  // FLT_DECIMAL_DIG: see append_like_token.

}  // namespace meshmark::detail
