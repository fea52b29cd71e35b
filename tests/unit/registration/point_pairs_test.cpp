// SPDX-License-Identifier: MIT
#include "meshmark/registration/point_pairs.h"

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "meshmark/core/error.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

TEST(PointPairsTest, parses_pairs_with_comments_blank_lines_and_commas)
{
    const std::string text =
        "# suspect            reference\n"
        "1 2 3   4 5 6\n"
        "\n"
        "  -1.5e-3\t+2,3   7 8 9.25   # trailing comment\r\n"
        "0 0 0 1 1 1";
    const std::vector<PointPair> pairs = parse_point_pairs(text, "pairs.txt");
    ASSERT_EQ(pairs.size(), 3U);
    EXPECT_EQ(pairs[0].suspect, Eigen::Vector3d(1, 2, 3));
    EXPECT_EQ(pairs[0].reference, Eigen::Vector3d(4, 5, 6));
    EXPECT_EQ(pairs[1].suspect, Eigen::Vector3d(-1.5e-3, 2, 3));
    EXPECT_EQ(pairs[1].reference, Eigen::Vector3d(7, 8, 9.25));
    EXPECT_EQ(pairs[2].reference, Eigen::Vector3d(1, 1, 1));
}

TEST(PointPairsTest, malformed_lines_name_the_source_and_line)
{
    try
    {
        static_cast<void>(parse_point_pairs("1 2 3 4 5 6\n1 2 3 4 5\n", "my_pairs.txt"));
        FAIL() << "five numbers were accepted";
    }
    catch (const IoError& e)
    {
        const std::string message = e.what();
        EXPECT_NE(message.find("my_pairs.txt"), std::string::npos) << message;
        EXPECT_NE(message.find("line 2"), std::string::npos) << message;
    }
    EXPECT_THROW(static_cast<void>(parse_point_pairs("1 2 3 4 5 6 7\n", "p")), IoError);
    EXPECT_THROW(static_cast<void>(parse_point_pairs("1 2 3 4 5 x\n", "p")), IoError);
    EXPECT_THROW(static_cast<void>(parse_point_pairs("1 2 3 4 5 6x\n", "p")), IoError);
    EXPECT_THROW(static_cast<void>(parse_point_pairs("1 2 3 4 5 1e999\n", "p")), IoError);
}

TEST(PointPairsTest, reads_files_and_requires_three_pairs)
{
    const auto dir = test::temp_dir("point_pairs");
    const auto good = dir / "good.txt";
    std::ofstream(good) << "0 0 0 1 1 1\n1 0 0 2 1 1\n0 1 0 1 2 1\n";
    EXPECT_EQ(read_point_pairs(good).size(), 3U);
    const auto short_file = dir / "short.txt";
    std::ofstream(short_file) << "0 0 0 1 1 1\n";
    EXPECT_THROW(static_cast<void>(read_point_pairs(short_file)), InvalidOption);
    EXPECT_THROW(static_cast<void>(read_point_pairs(dir / "missing.txt")), IoError);
}

}  // namespace
}  // namespace meshmark
