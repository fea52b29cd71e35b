// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <random>
#include <string_view>

#include "meshmark/core/hash.h"

namespace meshmark
{

/// \brief Seed of an independent stream: `hash(purpose)` mixed with the key's seed.
/// \details Each use of randomness (centers, payload mask, random payload, attacks) draws
/// from its own stream, so adding a use never changes another.
[[nodiscard]] std::uint64_t derive_seed(std::uint64_t seed, std::string_view purpose) noexcept;

/// \brief Deterministic random stream: std::mt19937_64 with our own mappings to
/// uniform and normal numbers, because std::*_distribution differs between standard libraries.
class Rng
{
public:
    explicit Rng(std::uint64_t seed) : engine_(seed) {}

    /// Raw 64 random bits.
    [[nodiscard]] std::uint64_t bits() { return engine_(); }
    /// Uniform in [0, 1), 53 random bits.
    [[nodiscard]] double uniform() { return static_cast<double>(engine_() >> 11U) * 0x1.0p-53; }
    /// Uniform in [lo, hi).
    [[nodiscard]] double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
    /// Uniform integer in [0, n), unbiased (rejection sampling). \pre n > 0.
    [[nodiscard]] std::uint64_t below(std::uint64_t n);
    /// Standard normal (Box-Muller, both values used).
    [[nodiscard]] double normal();

private:
    std::mt19937_64 engine_;
    double spare_normal_ = 0.0;
    bool has_spare_ = false;
};

}  // namespace meshmark
