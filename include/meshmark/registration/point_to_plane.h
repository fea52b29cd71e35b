// SPDX-License-Identifier: MIT
#pragma once

#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/registration/surface_matcher.h"

namespace meshmark
{

/// \brief One linearized point-to-plane update [Chen & Medioni 1992; Low 2004]: the small
/// motion that best lays the points listed in \p kept onto the planes of their matches.
/// \details Residuals r_i = n_i . (y_i - q_i), with y_i = row i of \p Y and (q_i, n_i) the
/// point and normal of \p matches[i]. The motion is about the kept points' centre c, and its
/// rotation (and scale) unknowns are multiplied by their RMS radius L, so that every column of
/// the Jacobian is a length (conditioning): y' = c + k dR (y - c) + tau, with dR the rotation
/// by delta(0:3) / L, k = 1 + delta(3) / L when \p N is 7 (with scale; k = 1 when \p N is 6)
/// and tau the last three entries. A little damping (1e-9 of the mean diagonal) keeps the
/// directions the surface leaves free (a sphere's rotation, a cylinder's slide) where they
/// are. The sums run in the order of \p kept, so the same order gives the same bits. A match
/// with a zero normal (a degenerate triangle) adds nothing. Used by the registration's fine
/// stage (N = 7) and detection's near-mirror refits (N = 6).
template <int N>
struct PointToPlaneStep
{
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< c
    double radius = 0.0;                               ///< L
    Eigen::Matrix<double, N, 1> delta = Eigen::Matrix<double, N, 1>::Zero();
};

/// The update above; nullopt when \p kept is empty or the update is not finite.
/// \tparam N 6 (rigid) or 7 (rigid and uniform scale).
template <int N>
[[nodiscard]] std::optional<PointToPlaneStep<N>> point_to_plane_step(
    const Positions& Y, const std::vector<SurfaceMatch>& matches,
    std::span<const Eigen::Index> kept);

}  // namespace meshmark
