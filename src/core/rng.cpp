// SPDX-License-Identifier: MIT
#include "meshmark/core/rng.h"

#include <cmath>
#include <numbers>

namespace meshmark
{

std::uint64_t derive_seed(std::uint64_t seed, std::string_view purpose) noexcept
{
    return splitmix64(seed ^ hash_bytes(purpose.data(), purpose.size(), 0x6D6573686D61726BULL));
}

std::uint64_t Rng::below(std::uint64_t n)
{
    // Lemire-free simple rejection: discard the top partial range so every value is equally likely.
    const std::uint64_t limit = (~std::uint64_t{0}) - ((~std::uint64_t{0}) % n);
    std::uint64_t x = engine_();
    while (x >= limit)
    {
        x = engine_();
    }
    return x % n;
}

double Rng::normal()
{
    if (has_spare_)
    {
        has_spare_ = false;
        return spare_normal_;
    }
    double u1 = uniform();
    while (u1 <= 0.0)
    {
        u1 = uniform();
    }
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    const double t = 2.0 * std::numbers::pi * u2;
    spare_normal_ = r * std::sin(t);
    has_spare_ = true;
    return r * std::cos(t);
}

}  // namespace meshmark
