// SPDX-License-Identifier: MIT
#include "meshmark/core/morton.h"

#include <algorithm>
#include <cstdint>
#include <utility>

namespace meshmark
{
namespace
{

/// Spreads the low 21 bits of \p x to every third bit.
std::uint64_t spread_bits(std::uint64_t x) noexcept
{
    x &= 0x1fffffU;
    x = (x | x << 32U) & 0x1f00000000ffffU;
    x = (x | x << 16U) & 0x1f0000ff0000ffU;
    x = (x | x << 8U) & 0x100f00f00f00f00fU;
    x = (x | x << 4U) & 0x10c30c30c30c30c3U;
    x = (x | x << 2U) & 0x1249249249249249U;
    return x;
}

}  // namespace

std::vector<std::size_t> morton_order(const Positions& P, int bits)
{
    const auto n = static_cast<std::size_t>(P.rows());
    std::vector<std::size_t> order(n);
    if (n == 0)
    {
        return order;
    }
    const int b = std::clamp(bits, 1, 21);
    const double cells = static_cast<double>((std::uint64_t{1} << static_cast<unsigned>(b)) - 1U);
    const Eigen::RowVector3d low = P.colwise().minCoeff();
    const Eigen::RowVector3d extent = (P.colwise().maxCoeff() - low).cwiseMax(1e-300);
    std::vector<std::pair<std::uint64_t, std::size_t>> keys(n);
    for (std::size_t i = 0; i < n; ++i)
    {
        std::uint64_t code = 0;
        for (Eigen::Index d = 0; d < 3; ++d)
        {
            const double unit = (P(static_cast<Eigen::Index>(i), d) - low(d)) / extent(d);
            const auto cell = static_cast<std::uint64_t>(std::clamp(unit, 0.0, 1.0) * cells);
            code |= spread_bits(cell) << static_cast<unsigned>(d);
        }
        keys[i] = {code, i};
    }
    std::sort(keys.begin(), keys.end());
    for (std::size_t slot = 0; slot < n; ++slot)
    {
        order[slot] = keys[slot].second;
    }
    return order;
}

}  // namespace meshmark
