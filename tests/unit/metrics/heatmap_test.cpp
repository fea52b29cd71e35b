// SPDX-License-Identifier: MIT
#include "meshmark/metrics/heatmap.h"

#include <limits>

#include <gtest/gtest.h>

namespace meshmark
{

TEST(HeatmapTest, scale_runs_from_blue_through_green_to_red)
{
    EXPECT_EQ(heat_color(0.0), (Rgb8{0, 0, 255}));
    EXPECT_EQ(heat_color(0.25), (Rgb8{0, 255, 255}));
    EXPECT_EQ(heat_color(0.5), (Rgb8{0, 255, 0}));
    EXPECT_EQ(heat_color(0.75), (Rgb8{255, 255, 0}));
    EXPECT_EQ(heat_color(1.0), (Rgb8{255, 0, 0}));
    EXPECT_EQ(heat_color(-3.0), heat_color(0.0));
    EXPECT_EQ(heat_color(7.0), heat_color(1.0));
    EXPECT_EQ(heat_color(std::numeric_limits<double>::quiet_NaN()), heat_color(1.0));
}

TEST(HeatmapTest, red_grows_and_blue_fades_along_the_scale)
{
    Rgb8 previous = heat_color(0.0);
    for (int i = 1; i <= 1000; ++i)
    {
        const Rgb8 c = heat_color(i / 1000.0);
        EXPECT_GE(c[0], previous[0]) << i;
        EXPECT_LE(c[2], previous[2]) << i;
        previous = c;
    }
}

TEST(HeatmapTest, distance_colors_scale_by_the_maximum)
{
    const Eigen::VectorXd d = (Eigen::VectorXd(3) << 0.0, 1.0, 2.0).finished();
    const auto colors = distance_colors(d, 2.0);
    ASSERT_EQ(colors.size(), 3U);
    EXPECT_EQ(colors[0], heat_color(0.0));
    EXPECT_EQ(colors[1], heat_color(0.5));
    EXPECT_EQ(colors[2], heat_color(1.0));
    for (const auto& c : distance_colors(d, 0.0))
    {
        EXPECT_EQ(c, heat_color(0.0));
    }
}

}  // namespace meshmark
