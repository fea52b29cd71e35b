// SPDX-License-Identifier: MIT
// Numbers as a reader without statistics reads them (plain_numbers.h).
#include "meshmark/core/plain_numbers.h"

#include <cmath>

#include <gtest/gtest.h>

namespace meshmark
{
namespace
{

TEST(PlainNumbersTest, one_in_rounds_to_two_significant_digits_in_words)
{
    EXPECT_EQ(one_in(1.0), "1 in 1");
    EXPECT_EQ(one_in(0.5), "1 in 2");
    EXPECT_EQ(one_in(0.7), "1 in 1.4");
    EXPECT_EQ(one_in(0.0111), "1 in 90");
    EXPECT_EQ(one_in(1.0 / 12345.0), "1 in 12,000");
    EXPECT_EQ(one_in(1e-6), "1 in 1 million");
    EXPECT_EQ(one_in(1.0 / 999'999.0), "1 in 1 million");
    EXPECT_EQ(one_in(3.1e-8), "1 in 32 million");
    EXPECT_EQ(one_in(3.1e-10), "1 in 3.2 billion");
    EXPECT_EQ(one_in(2.5e-12), "1 in 400 billion");
    EXPECT_EQ(one_in(1e-13), "1 in 10 trillion");
    EXPECT_EQ(one_in(1e-15), "1 in 10^15");
    EXPECT_EQ(one_in(2.2e-22), "1 in 4.5 \u00d7 10^21");
    EXPECT_EQ(one_in(1e-301), "less than 1 in 10^300");
    EXPECT_EQ(one_in(0.0), "less than 1 in 10^300");
    EXPECT_EQ(one_in(std::nan("")), "1 in 1");
}

TEST(PlainNumbersTest, grouped_digits_groups_thousands)
{
    EXPECT_EQ(grouped_digits(0), "0");
    EXPECT_EQ(grouped_digits(999), "999");
    EXPECT_EQ(grouped_digits(1000), "1,000");
    EXPECT_EQ(grouped_digits(12345678), "12,345,678");
}

}  // namespace
}  // namespace meshmark
