// SPDX-License-Identifier: MIT
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace meshmark
{

/// The upper median of \p values (reordered in place; nearest rank, so the same on every run).
/// \pre \p values is not empty.
template <typename T>
T median_in_place(std::vector<T>& values)
{
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
    std::nth_element(values.begin(), middle, values.end());
    return *middle;
}

}  // namespace meshmark
