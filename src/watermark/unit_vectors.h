// SPDX-License-Identifier: MIT
#pragma once

// Internal to the watermark module: a reading scaled to unit norm (decision.cpp, tracing.cpp).

#include <algorithm>
#include <cmath>
#include <vector>

namespace meshmark::detail
{

/// \p values scaled to unit norm (all zeros where their norm is 0).
inline std::vector<double> scaled_to_unit(const std::vector<double>& values)
{
    double norm_sq = 0.0;
    for (const double v : values)
    {
        norm_sq += v * v;
    }
    std::vector<double> unit(values.size(), 0.0);
    if (norm_sq > 0.0)
    {
        const double scale = 1.0 / std::sqrt(norm_sq);
        std::transform(values.begin(), values.end(), unit.begin(),
                       [scale](double v) { return v * scale; });
    }
    return unit;
}

}  // namespace meshmark::detail
