// SPDX-License-Identifier: MIT
#include "meshmark/core/hash.h"

#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/rng.h"

namespace meshmark
{

// Fed in pieces split anywhere, the hasher gives hash_bytes of the whole.
TEST(HasherTest, pieces_give_the_hash_of_the_whole)
{
    std::vector<unsigned char> buffer(97);
    Rng rng(5);
    for (auto& byte : buffer)
    {
        byte = static_cast<unsigned char>(rng.below(256));
    }
    for (std::size_t size = 0; size <= buffer.size(); size += 3)
    {
        const std::uint64_t whole = hash_bytes(buffer.data(), size, 0x77U);
        for (std::size_t cut = 0; cut <= size; ++cut)
        {
            for (std::size_t step = 1; step <= 9; step += 4)
            {
                Hasher hasher(size, 0x77U);
                hasher.update(buffer.data(), cut);
                for (std::size_t i = cut; i < size; i += step)
                {
                    hasher.update(buffer.data() + i, std::min(step, size - i));
                }
                ASSERT_EQ(hasher.value(), whole)
                    << "size " << size << " cut " << cut << " step " << step;
            }
        }
    }
}

// The position hash of a key over doubles fed row by row (what the out-of-core embed does).
TEST(HasherTest, rows_of_doubles_give_the_hash_of_the_array)
{
    const std::vector<double> xyz = {0.5, -1.25, 3.0, 1e-300, 7.0, -0.0, 2.5, 4.0, 8.0};
    Hasher hasher(xyz.size() * sizeof(double));
    for (std::size_t row = 0; row < 3; ++row)
    {
        hasher.update(xyz.data() + 3 * row, 3 * sizeof(double));
    }
    EXPECT_EQ(hasher.value(), hash_bytes(xyz.data(), xyz.size() * sizeof(double)));
}

}  // namespace meshmark
