// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>

namespace meshmark
{

/// \brief One step of SplitMix64 [Steele, Lea, Flood 2014]: a bijective 64-bit mixer.
[[nodiscard]] constexpr std::uint64_t splitmix64(std::uint64_t x) noexcept
{
    x += 0x9E3779B97F4A7C15ULL;
    x = (x ^ (x >> 30U)) * 0xBF58476D1CE4E5B9ULL;
    x = (x ^ (x >> 27U)) * 0x94D049BB133111EBULL;
    return x ^ (x >> 31U);
}

/// \brief The hash of hash_bytes() fed in pieces: SplitMix64 folded over the bytes, 8 at a time.
/// \details The state starts as splitmix64(seed ^ size * 0x9E3779B97F4A7C15) for the total
/// \p size given up front; each 8-byte word, packed little-endian, is mixed in as
/// h = splitmix64(h ^ word); a last partial word is zero-padded. Pieces may split the bytes
/// anywhere: the value depends only on the concatenation. Documented and platform
/// independent, so seeds and fingerprints derived from it are the same everywhere (the
/// key's position hash is this over the positions as IEEE doubles, row by row). Not a
/// cryptographic hash.
class Hasher
{
public:
    /// A hash of \p size bytes in total, with \p seed.
    explicit Hasher(std::uint64_t size, std::uint64_t seed = 0) noexcept
        : state_(splitmix64(seed ^ (size * 0x9E3779B97F4A7C15ULL)))
    {
    }
    /// Feed the next \p size bytes at \p data.
    void update(const void* data, std::size_t size) noexcept;
    /// The hash of the bytes fed so far (which must add up to the size given at construction).
    [[nodiscard]] std::uint64_t value() const noexcept;

private:
    std::uint64_t state_;
    std::uint64_t pending_ = 0;   // bytes of an unfinished word, packed little-endian
    unsigned pending_bytes_ = 0;  // 0..7
};

/// \brief 64-bit hash of a byte string: Hasher(size, seed) fed the whole string.
[[nodiscard]] std::uint64_t hash_bytes(const void* data, std::size_t size,
                                       std::uint64_t seed = 0) noexcept;

}  // namespace meshmark
