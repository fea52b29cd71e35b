// SPDX-License-Identifier: MIT
#include "meshmark/metrics/heatmap.h"

#include <algorithm>
#include <cmath>

namespace meshmark
{
namespace
{

std::uint8_t to_byte(double x)
{
    return static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(x, 0.0, 1.0)));
}

}  // namespace

Rgb8 heat_color(double t)
{
    // Four linear segments between blue, cyan, green, yellow and red (hue 240° down to 0°).
    const double x = std::isnan(t) ? 1.0 : std::clamp(t, 0.0, 1.0);
    if (x < 0.25)
    {
        return {0, to_byte(4.0 * x), 255};
    }
    if (x < 0.5)
    {
        return {0, 255, to_byte(1.0 - 4.0 * (x - 0.25))};
    }
    if (x < 0.75)
    {
        return {to_byte(4.0 * (x - 0.5)), 255, 0};
    }
    return {255, to_byte(1.0 - 4.0 * (x - 0.75)), 0};
}

std::vector<Rgb8> distance_colors(const Eigen::VectorXd& distances, double max_distance)
{
    std::vector<Rgb8> colors(static_cast<std::size_t>(distances.size()));
    for (Eigen::Index i = 0; i < distances.size(); ++i)
    {
        const double t = max_distance > 0.0 ? distances[i] / max_distance : 0.0;
        colors[static_cast<std::size_t>(i)] = heat_color(t);
    }
    return colors;
}

}  // namespace meshmark
