// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace meshmark
{

/// An 8-bit sRGB color.
using Rgb8 = std::array<std::uint8_t, 3>;

/// \brief Color of \p t on the distance scale: blue (t = 0), cyan (0.25), green (0.5),
/// yellow (0.75), red (t = 1), linear in between; t is clamped to [0, 1] (NaN gives red).
/// \details The hue ramp of distance maps such as Fig. 1 of Wu & Kobbelt: a hue sweep from
/// 240° to 0° at full saturation and value.
[[nodiscard]] Rgb8 heat_color(double t);

/// \brief Per-vertex colors for distances: heat_color(distance / max_distance).
/// \param distances    #V distances (non-negative).
/// \param max_distance Distance shown in red; when it is zero (or not positive) every vertex is
/// blue.
[[nodiscard]] std::vector<Rgb8> distance_colors(const Eigen::VectorXd& distances,
                                                double max_distance);

}  // namespace meshmark
