// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshmark::detail
{

/// Vertices of different transform groups are welded when closer than this fraction of the
/// bbox diagonal. An exporter that stores each part as T^-1 * world in float32 leaves the
/// parts' shared vertices a few float32 ulps apart in world space (~1e-7 of the extent); the
/// factor 10 margin stays far below any real edge length (a 1M-vertex mesh has ~1e-3 D).
inline constexpr double kCrossTransformWeldRel = 1e-6;

/// \brief Weld world positions into distinct vertices.
/// \details Bit-identical positions (-0 == +0) always become one vertex. When there is more
/// than one group, a position also joins the nearest earlier vertex within
/// tolerance_rel * bbox diagonal that no position of its own group has joined yet, so two
/// distinct positions of one group (one transform) are never merged.
/// \param world        3 doubles per position.
/// \param group        Transform group of each position.
/// \param xyz          Out: 3 doubles per welded vertex (the first position that made it).
/// \return The welded vertex of each position; vertices are numbered by first appearance.
[[nodiscard]] std::vector<std::int32_t> weld_world_positions(const std::vector<double>& world,
                                                             const std::vector<std::int32_t>& group,
                                                             std::size_t group_count,
                                                             double tolerance_rel,
                                                             std::vector<double>& xyz);

}  // namespace meshmark::detail
