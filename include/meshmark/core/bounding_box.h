// SPDX-License-Identifier: MIT
#pragma once

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Axis-aligned bounding box.
struct BoundingBox
{
    Eigen::Vector3d min = Eigen::Vector3d::Constant(0.0);
    Eigen::Vector3d max = Eigen::Vector3d::Constant(0.0);

    [[nodiscard]] double diagonal() const { return (max - min).norm(); }
    [[nodiscard]] Eigen::Vector3d center() const { return 0.5 * (min + max); }
};

/// \brief Axis-aligned bounding box of all vertices (referenced or not).
/// \return A zero box at the origin for an empty mesh.
[[nodiscard]] BoundingBox bounding_box(const Positions& V);

/// \brief Axis-aligned bounding box of the listed vertices.
[[nodiscard]] BoundingBox bounding_box(const Positions& V, const std::vector<std::int32_t>& rows);

}  // namespace meshmark
