// SPDX-License-Identifier: MIT
#include "meshmark/core/morton.h"

#include <array>
#include <vector>

#include <gtest/gtest.h>

namespace meshmark
{
namespace
{

TEST(MortonOrderTest, orders_cube_corners_by_interleaved_bits_and_ties_by_row)
{
    // Corner (x, y, z) of the unit cube has code x + 2 y + 4 z at one bit per axis.
    const std::vector<std::array<double, 3>> corners = {{1, 1, 1}, {0, 0, 0}, {1, 0, 0},
                                                        {0, 1, 1}, {0, 1, 0}, {1, 0, 1},
                                                        {0, 0, 1}, {1, 1, 0}, {0, 0, 0}};
    Positions P(static_cast<Eigen::Index>(corners.size()), 3);
    for (std::size_t i = 0; i < corners.size(); ++i)
    {
        P.row(static_cast<Eigen::Index>(i)) << corners[i][0], corners[i][1], corners[i][2];
    }
    const std::vector<std::size_t> expected = {1, 8, 2, 4, 7,
                                               6, 5, 3, 0};  // codes 0, 0, 1, 2, 3, 4, 5, 6, 7
    for (const int bits : {1, 10, 21})
    {
        EXPECT_EQ(morton_order(P, bits), expected) << bits << " bits";
    }
    EXPECT_TRUE(morton_order(Positions(0, 3), 10).empty());
}

TEST(MortonOrderTest, finer_bits_separate_points_a_coarse_grid_ties)
{
    Positions P(3, 3);
    P << 0.0008, 0.0, 0.0,  // 10 bits: cell (0, 0, 0); 21 bits: x cell 1677
        1.0, 1.0, 1.0,      //
        0.0, 0.0001, 0.0;   // 10 bits: cell (0, 0, 0); 21 bits: y cell 209, a smaller code
    EXPECT_EQ(morton_order(P, 10), (std::vector<std::size_t>{0, 2, 1}));  // tie: by row
    EXPECT_EQ(morton_order(P, 21), (std::vector<std::size_t>{2, 0, 1}));
}

}  // namespace
}  // namespace meshmark
