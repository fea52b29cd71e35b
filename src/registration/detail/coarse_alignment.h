// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark::detail
{

/// Centroid and covariance of a shape.
struct Moments
{
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    double weight = 0.0;  ///< The total area (area_moments) or vertex count (vertex_moments).
};

/// Moments of the uniform distribution on the triangles of \p mesh (area-weighted).
/// \pre mesh has faces. A zero-area mesh gives zero moments.
[[nodiscard]] Moments area_moments(const TriangleMesh& mesh);

/// Moments of the listed vertices, equally weighted. \pre rows is not empty.
[[nodiscard]] Moments vertex_moments(const Positions& V, const std::vector<std::int32_t>& rows);

/// Principal axes as the columns of a proper rotation, largest variance first.
[[nodiscard]] Eigen::Matrix3d principal_frame(const Eigen::Matrix3d& covariance);

/// The 24 rotations that map coordinate axes to signed coordinate axes.
[[nodiscard]] std::vector<Eigen::Matrix3d> axis_rotations();

/// The rotations worth trying between the principal frames of covariances \p a and \p b:
/// the four sign flips when both have well separated axes, all 24 axis rotations otherwise.
[[nodiscard]] std::vector<Eigen::Matrix3d> frame_rotations(const Eigen::Matrix3d& a,
                                                           const Eigen::Matrix3d& b);

/// \brief Moments of the parts of \p reference that a plane crop could have left, ranked by
/// how well their scale-free shape matches \p suspect's; the best few, then the 6 halves on
/// either side of the bounding box's centre plane along each coordinate axis (where modelling
/// tools cut a model in half), whatever their shape.
/// \param use_area  Area moments (triangles) or vertex moments (points), as for \p whole.
/// \param rows      The reference's used vertices (for vertex moments).
/// \param whole     The whole reference's moments.
[[nodiscard]] std::vector<Moments> crop_hypotheses(const TriangleMesh& reference, bool use_area,
                                                   const std::vector<std::int32_t>& rows,
                                                   const Moments& whole, const Moments& suspect,
                                                   std::uint64_t seed);

/// A seeded random permutation of \p rows (Fisher-Yates driven by meshmark::Rng).
[[nodiscard]] std::vector<std::int32_t> shuffled(std::vector<std::int32_t> rows,
                                                 std::uint64_t seed);

}  // namespace meshmark::detail
